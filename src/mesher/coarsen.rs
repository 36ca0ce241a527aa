//! Chord-bounded coarsening: the vertices that the octree's topology
//! criterion made denser than the chord tolerance needs are removed by
//! edge collapses (faithful `--level`, SPEC §2).
//!
//! The topology criterion refines a cell until its interval gradient
//! proves the sheet simple there, which on a product of polynomials (the
//! two-torus) or near a singular point (the heart's) is the last level
//! everywhere: edges of about one level-L cell, where the tolerance
//! allows two or three. The octree decides the topology; this pass only
//! takes back the resolution the tolerance does not need.
//!
//! # Contract
//!
//! The input is an oriented mesh whose vertices lie on `f = 0`; its
//! [`Marks`] flag vertices that must stay (a brick's seam) and the crease
//! points (their normal is one side's), and give Ω. A
//! collapse removes a vertex `r` into a neighbour `k` (a half-edge
//! collapse: `k` keeps its position, so every vertex stays on the
//! surface, and no new point is made). It is made only when
//!
//! - `r` is not pinned, its star is a closed disk or, on the mesh's
//!   boundary where Ω cuts the surface, one open fan (never at a
//!   non-manifold vertex), and its normal is a unit vector;
//! - a boundary vertex goes only along the boundary, within one face of
//!   Ω: it lies on exactly one face (not on an edge of Ω), so do its two
//!   boundary neighbours `a` and `b`, `k` is one of them, and `r` lies
//!   within the tolerance of the new boundary edge `a–b` (as a crease
//!   point of its crease edge, below). The boundary stays on ∂Ω, and a
//!   straight one (a plane cut by a face) may keep only its ends;
//! - a crease point goes only along its crease: it has exactly two sharp
//!   edges (their triangles' normals more than [`SPLIT_DEG`] apart), both
//!   to crease points `a` and `b`, `k` is one of them, and `r` lies within
//!   the tolerance (at the crease's own bend) of the new crease edge
//!   `a–b`; corners and crease ends stay. Across a crease the normals'
//!   turn is not read as a curvature, and a new triangle is held to the
//!   one it replaces at a crease corner (not to that corner's normal);
//! - the link condition holds (`DynMesh::can_collapse_topologically`,
//!   read from the removed vertex's ring: [`Around::link_holds`]):
//!   the mesh keeps its topology, closedness and orientation;
//! - no new triangle turns against the one it replaces or against ∇f: its
//!   normal is within 60° of the unit normal at each corner;
//! - no new triangle is a sliver: aspect ratio at least `MIN_ASPECT` (0.5), or
//!   at least the worst of those it replaces;
//! - no new edge is longer than `ANISOTROPY` (1.75) times what the tolerance
//!   allows where the surface bends as much as it bends most around `r`
//!   (`Around::isotropic`): triangles stay roughly isotropic on tubes;
//! - `r` lies within the tolerance of the new fan, and, **measured** on
//!   `f` (first order, `|f| / ‖∇f‖`, as the chord splits measure), every
//!   new edge's midpoint and every new triangle's centroid stand within
//!   [`SAFETY`] of the tolerance at their curvature ([`Chord::at`]), with
//!   ∇f there on the triangle's side (not across a thin wall).
//!
//! So a collapse makes no edge the chord splits ([`super::chord`]) would
//! split again. Before the first round's collapses, the flat regions (the
//! planar faces of a CSG model) are retriangulated at once from their
//! borders ([`super::planar`]), crease points and the pinned vertices
//! staying: on colonnade.vm at depth 8 that takes 269k triangles to 77k
//! in a tenth of a second, where collapsing them one by one took half a
//! second. Collapses are made in sweeps, each checked and measured on
//! the mesh as it is when it is made: a sweep visits the vertices whose
//! neighbourhood changed since their last visit, shortest edge first, and
//! tries each into its nearest neighbours (`TARGETS`: two) in order of
//! distance. The order is a function of the mesh, so the result is
//! deterministic.
//!
//! # Limits
//!
//! The measure is first order at four kinds of points (midpoints,
//! centroids, the removed vertex, the corners' normals): a fan could still
//! bulge off the surface between them, as a chord split's triangle could.
//! Quality is only kept from falling below a floor; smoothing
//! ([`super::smooth`]) improves it after. Corners stay, and so does a
//! crease point whose crease bends past the tolerance or meets a sharp
//! edge the crease pass did not sharpen. Where most vertices left are
//! held only by the aspect floor, a smoothing pass (crease points and a
//! brick's seam stay) reshapes the fans and another round visits those
//! vertices again ([`ROUNDS`], [`RETRY_SHARE`]). The pass is sequential
//! (single-threaded): each collapse is measured on the mesh the previous
//! ones left. It runs in the smoothing stage, so `--smooth 0` keeps the
//! mesh as extracted and split (and a bricked run equal to the whole one,
//! [`super::brick`]).

use glam::DVec3;
use rayon::prelude::*;
use smallvec::SmallVec;

use super::adapt::{ALIGN, point_triangle_distance};
use super::crease::SPLIT_DEG;
use super::planar::{self, FLAT, on_tangent_plane};
use super::smooth;
use crate::cancel::{Cancel, Cancelled};
use crate::eval::Evaluator;
use crate::geometry::Bounds;
use crate::mesh::Mesh;
use crate::mesh::dynmesh::DynMesh;
use crate::mesh::order::retain;
use crate::mesh::quality::aspect;
use crate::octree::Chord;
use crate::octree::criteria::turn;

/// The share of the tolerance a collapse may use: relaxation moves the
/// vertices afterwards and may stretch an edge a little.
pub const SAFETY: f64 = 0.8;

/// Most sweeps of a round.
const SWEEPS: usize = 4;

/// Most rounds of [`coarsen`].
pub const ROUNDS: usize = 3;

/// Another round follows when at least this share of the vertices left
/// had a collapse that only the aspect floor refused: a smoothing pass
/// reshapes their fans. At depth 8 the share is 4–32 % on smooth
/// surfaces (no extra round, no extra time) and 60 % on colonnade.vm
/// after its first round (93 % before its faces were retriangulated,
/// [`super::planar`]): the fans next to its creases.
const RETRY_SHARE: f64 = 0.5;

/// A sweep that removes fewer than this share of the live vertices is the
/// last.
const STALL: f64 = 0.05;

/// No collapse makes a triangle with an aspect ratio below this, unless
/// the fan it replaces had one already. Lower than the adaptation's
/// ([`super::adapt::MIN_ASPECT`]): on a regular patch of the dual grid's
/// right triangles every collapse makes a 2:1 triangle first, which
/// smoothing then evens out (colonnade.vm at depth 8, trying three
/// targets: 210k triangles with 0.6, 153k with 0.5; `aspect_good` of
/// genus2 and bretzel5 at level 7 kept above issue 11's 0.75).
const MIN_ASPECT: f64 = 0.5;

/// How much longer than the isotropic size a new edge may be. A chord
/// along a tube does not leave it, so the chord test alone would stretch
/// triangles along every tube; a new edge is also held to the size the
/// surface's largest curvature around the removed vertex allows in every
/// direction ([`Around::isotropic`]), times this. With 1 the tubes' triangles
/// stay shapely but the two-torus keeps 0.72× Fidget's triangles at depth
/// 8; with 2 genus2's `aspect_good` falls below issue 11's 0.75
/// (`docs/faithful.md`).
const ANISOTROPY: f64 = 1.75;

/// The nearest neighbours of a vertex it may be collapsed into.
const TARGETS: usize = 2;

/// A vertex's neighbours or star, on the stack for usual valences.
type Small<T> = SmallVec<[T; 16]>;

/// What [`coarsen`] must keep of a mesh's vertices.
#[derive(Clone, Copy, Default)]
pub struct Marks<'a> {
    /// Vertices that stay where they are (a brick's seam); a shorter slice
    /// flags nothing past its end.
    pub pinned: &'a [bool],
    /// Crease points ([`super::crease`]): removed only along their crease,
    /// never moved by the smoothing between rounds.
    pub crease: &'a [bool],
    /// Ω, whose faces cut the surface: a vertex of the mesh's boundary on
    /// one face of it is removed only along that boundary
    /// ([`Kind::Boundary`]). `None`: every boundary vertex stays.
    pub domain: Option<Bounds>,
}

/// Removes vertices of `mesh` by edge collapses while the chord tolerance
/// `tau` allows it (see the module doc), keeping what `marks` flags; more
/// [`ROUNDS`] after one smoothing pass each while the aspect floor refused
/// many collapses ([`RETRY_SHARE`]). Returns, per input vertex, whether it
/// is kept: the caller filters its own per-vertex data with it
/// ([`crate::mesh::order::retain`]); the mesh's own (positions, normals,
/// ambiguity) are filtered already. Returns [`Cancelled`] when `cancel`
/// was cancelled before a sweep or during a smoothing pass (the mesh is
/// then valid, with the rounds finished before: as it was when cancelled
/// at once).
pub fn coarsen<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    marks: Marks,
    f: &E,
    t: f64,
    tau: Chord,
    cancel: &Cancel,
) -> Result<Vec<bool>, Cancelled> {
    let n = mesh.positions.len();
    let (mut pinned, mut crease) = (marks.pinned.to_vec(), marks.crease.to_vec());
    pinned.resize(n, false);
    crease.resize(n, false);
    let mut kept: Vec<bool> = vec![true; n];
    let mut visit: Option<Vec<bool>> = None;
    for round in 0..ROUNDS {
        if round > 0 {
            smooth::smooth_part(mesh, f, t, 1, &crease, &pinned, cancel)?;
        }
        let marks = Marks {
            pinned: &pinned,
            crease: &crease,
            domain: marks.domain,
        };
        let (now, sliver) = coarsen_round(mesh, &marks, visit.as_deref(), f, t, tau, cancel)?;
        let mut live = kept.iter_mut().filter(|k| **k);
        for &k in &now {
            *live.next().expect("one flag per live vertex") = k;
        }
        retain(&mut pinned, &now);
        retain(&mut crease, &now);
        let retry = sliver.iter().filter(|&&s| s).count();
        if (retry as f64) < RETRY_SHARE * sliver.len() as f64 {
            break;
        }
        visit = Some(sliver);
    }
    Ok(kept)
}

/// One round of [`coarsen`]: sweeps that visit first the vertices `visit`
/// flags (all when `None`); returns the kept flags of the round's input
/// vertices and, per kept vertex, whether only the aspect floor refused
/// its removal.
fn coarsen_round<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    marks: &Marks,
    visit: Option<&[bool]>,
    f: &E,
    t: f64,
    tau: Chord,
    cancel: &Cancel,
) -> Result<(Vec<bool>, Vec<bool>), Cancelled> {
    let mut c = Coarsener::new(mesh, marks, visit, tau);
    // The first round visits every vertex (`visit` is `None`), after the
    // flat regions are retriangulated.
    if visit.is_none() {
        c.retriangulate_planes(f, t);
    }
    for _ in 0..SWEEPS {
        cancel.check()?;
        let made = c.sweep(f, t);
        if (made as f64) < STALL * c.m.live_vert_count() as f64 {
            break;
        }
    }
    let kept = c.m.vert_alive.clone();
    let mut out = c.m.to_mesh();
    retain(&mut c.ambiguous, &kept);
    out.ambiguous = c.ambiguous;
    // `to_mesh` normalises the gradients: the input's normals, kept bit
    // for bit.
    out.normals = std::mem::take(&mut mesh.normals);
    retain(&mut out.normals, &kept);
    *mesh = out;
    retain(&mut c.sliver, &kept);
    Ok((kept, c.sliver))
}

/// Whether `flags` flags `v` (a shorter slice flags nothing past its end).
fn flag(flags: &[bool], v: usize) -> bool {
    flags.get(v).copied().unwrap_or(false)
}

/// The state of a coarsening.
struct Coarsener {
    m: DynMesh,
    ambiguous: Vec<bool>,
    /// Vertices never removed (pinned, or not removable: [`removable`]).
    fixed: Vec<bool>,
    /// Crease points: removed only along their crease ([`Kind::Crease`]).
    crease: Vec<bool>,
    /// Ω ([`Marks::domain`]).
    domain: Option<Bounds>,
    /// Vertices on the mesh's boundary that may go along Ω's faces: the
    /// planar retriangulation holds them (its regions' inner vertices
    /// have closed stars), the collapses move them along the boundary.
    open: Vec<bool>,
    /// Vertices whose neighbourhood changed since their last visit.
    dirty: Vec<bool>,
    /// Vertices whose last visit found a collapse that only the aspect
    /// floor refused ([`Verdict::Sliver`]).
    sliver: Vec<bool>,
    tau: Chord,
    /// Scratch: the points a collapse is measured at, their tolerances
    /// and the directions ∇f must agree with; the evaluations.
    samples: Vec<(DVec3, f64, DVec3)>,
    pts: Vec<[f64; 3]>,
    values: Vec<(f64, [f64; 3])>,
    ring: Vec<u32>,
}

impl Coarsener {
    fn new(mesh: &Mesh, marks: &Marks, visit: Option<&[bool]>, tau: Chord) -> Self {
        let m = DynMesh::indexed(mesh);
        let n = mesh.positions.len();
        let mut ambiguous = mesh.ambiguous.clone();
        ambiguous.resize(n, false);
        // Per vertex: fixed, and on the mesh's boundary (then removable).
        let (fixed, open): (Vec<bool>, Vec<bool>) = (0..n as u32)
            .into_par_iter()
            .map(|v| {
                let fan = fan(&m, v);
                let fixed =
                    flag(marks.pinned, v as usize) || !admits(&m, v, fan, marks.domain.as_ref());
                (fixed, !fixed && matches!(fan, Some(Some(_))))
            })
            .unzip();
        let dirty = (0..n)
            .map(|v| !fixed[v] && visit.is_none_or(|visit| flag(visit, v)))
            .collect();
        let crease = (0..n).map(|v| flag(marks.crease, v)).collect();
        Coarsener {
            m,
            ambiguous,
            fixed,
            crease,
            domain: marks.domain,
            open,
            dirty,
            sliver: vec![false; n],
            tau,
            samples: Vec::new(),
            pts: Vec::new(),
            values: Vec::new(),
            ring: Vec::new(),
        }
    }

    /// Retriangulates the flat regions ([`planar`]) the collapses may
    /// touch: crease points, the boundary's and fixed vertices stay (an
    /// ambiguous vertex may go, handing its flag on). The refinement leaves alone
    /// triangles of less than a cell's square.
    fn retriangulate_planes<E: Evaluator + ?Sized>(&mut self, f: &E, t: f64) {
        let held: Vec<bool> = (0..self.m.pos.len())
            .map(|v| self.fixed[v] || self.crease[v] || self.open[v])
            .collect();
        let side = if self.tau.cell > 0.0 {
            self.tau.cell
        } else {
            self.tau.base
        };
        let changed = planar::retriangulate(&mut self.m, &held, &mut self.ambiguous, f, t, side);
        for v in changed {
            let v = v as usize;
            if !held[v] {
                self.fixed[v] = !removable(&self.m, v as u32, self.domain.as_ref());
                self.dirty[v] = !self.fixed[v];
            }
        }
    }

    /// One sweep over the dirty vertices, shortest edge first; returns the
    /// collapses made.
    fn sweep<E: Evaluator + ?Sized>(&mut self, f: &E, t: f64) -> usize {
        let m = &self.m;
        let mut order: Vec<(f64, u32)> = (0..m.pos.len() as u32)
            .into_par_iter()
            .filter(|&v| self.dirty[v as usize] && m.vert_alive[v as usize])
            .map(|v| (shortest_edge(m, v), v))
            .collect();
        order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let mut made = 0;
        for (_, r) in order {
            if !self.m.vert_alive[r as usize] || !self.dirty[r as usize] {
                continue;
            }
            self.dirty[r as usize] = false;
            if let Some(k) = self.try_remove(f, t, r) {
                made += 1;
                self.mark_around(k);
            }
        }
        made
    }

    /// Collapses `r` into the nearest of its [`TARGETS`] nearest
    /// neighbours for which every check holds; returns that neighbour.
    fn try_remove<E: Evaluator + ?Sized>(&mut self, f: &E, t: f64, r: u32) -> Option<u32> {
        let faces = self.domain.as_ref().filter(|_| self.open[r as usize]);
        let around = Around::new(&self.m, r, &self.crease, faces);
        let mut sliver = false;
        let k = around
            .targets()
            .find(|&k| match self.geometric(&around, k) {
                Verdict::Passed => around.flat || self.measured(f, t, &around, k),
                Verdict::Sliver => {
                    sliver = true;
                    false
                }
                Verdict::Refused => false,
            });
        self.sliver[r as usize] = k.is_none() && sliver;
        let k = k?;
        let (pk, gk) = (self.m.pos[k as usize], self.m.grad[k as usize]);
        self.m.collapse(k, r, pk, gk);
        self.ambiguous[k as usize] |= self.ambiguous[r as usize];
        Some(k)
    }

    /// The checks of collapsing `around.r` into `k` that read the mesh
    /// alone, cheapest first: the new edges' lengths ([`Around::isotropic`]),
    /// the fan ([`Around::fan`]), the removed vertex within the
    /// tolerance of the fan, and the link condition.
    fn geometric(&self, around: &Around, k: u32) -> Verdict {
        let (m, r) = (&self.m, around.r);
        let (pr, pk) = (m.pos[r as usize], m.pos[k as usize]);
        let near = || match around.kind {
            // Along a crease or Ω's face: `r` within the tolerance of the
            // new crease or boundary edge, at the line's own bend.
            Kind::Crease(Some([a, b])) | Kind::Boundary([a, b]) => {
                let other = m.pos[if k == a { b } else { a } as usize];
                let bend = turn(
                    (pr - pk).normalize().to_array(),
                    (other - pr).normalize().to_array(),
                );
                let length = 0.5 * pk.distance(other);
                segment_distance(pr, pk, other) <= tolerance(self.tau, bend, length)
            }
            _ => {
                let bend = turn(m.grad[r as usize].to_array(), m.grad[k as usize].to_array());
                near_fan(m, r, k) <= tolerance(self.tau, bend, pr.distance(pk))
            }
        };
        // A flat star: no curvature to hold edges to, and `r` lies on the
        // piece of plane the fan covers.
        if !around.flat && !around.isotropic(m, k, self.tau) {
            return Verdict::Refused;
        }
        let fan = around.fan(m, k, &self.crease);
        if fan == Verdict::Refused || !(around.flat || near()) || !around.link_holds(m, k) {
            return Verdict::Refused;
        }
        fan
    }

    /// Whether every new edge's midpoint and new triangle's centroid of
    /// collapsing `around.r` into `k` stands within its tolerance off `f(·, t) =
    /// 0` (first order), with ∇f on its side.
    fn measured<E: Evaluator + ?Sized>(&mut self, f: &E, t: f64, around: &Around, k: u32) -> bool {
        self.collect_samples(around, k);
        self.pts.clear();
        self.pts.extend(self.samples.iter().map(|s| s.0.to_array()));
        self.values.clear();
        self.values.resize(self.pts.len(), (0.0, [0.0; 3]));
        f.point_grad_batch(&self.pts, t, &mut self.values);
        self.samples
            .iter()
            .zip(&self.values)
            .all(|(&(_, tol, side), &(v, g))| {
                let g = DVec3::from_array(g);
                // A singular point of f (where `x y = 0`'s planes cross)
                // has no gradient to measure by, and is on the surface.
                (v == 0.0 && g == DVec3::ZERO) || (v.abs() / g.length() <= tol && g.dot(side) > 0.0)
            })
    }

    /// The points to measure for collapsing `around.r` into `k` (see
    /// [`Coarsener::measured`]) into `self.samples`.
    fn collect_samples(&mut self, around: &Around, k: u32) {
        let (m, tau, r) = (&self.m, self.tau, around.r);
        let (pk, nk) = (m.pos[k as usize], m.grad[k as usize]);
        self.samples.clear();
        for &(_, w) in &around.near {
            if w == k || m.adjacent(k, w) {
                continue;
            }
            let (pw, nw) = (m.pos[w as usize], m.grad[w as usize]);
            // Across a crease the normals' turn is no curvature: the flat
            // tolerance there.
            let bend = if self.crease[k as usize] || self.crease[w as usize] {
                0.0
            } else {
                turn(nk.to_array(), nw.to_array())
            };
            let tol = tolerance(tau, bend, pk.distance(pw));
            self.samples.push(((pk + pw) * 0.5, tol, nk + nw));
        }
        for &i in &m.star[r as usize] {
            let tri = m.tris[i as usize];
            if tri.contains(&k) {
                continue;
            }
            let c = tri.map(|v| if v == r { k } else { v });
            let (p, g) = (c.map(|v| m.pos[v as usize]), c.map(|v| m.grad[v as usize]));
            let longest = (0..3)
                .map(|j| p[j].distance(p[(j + 1) % 3]))
                .fold(0.0, f64::max);
            let bend = if c.iter().any(|&v| self.crease[v as usize]) {
                0.0
            } else {
                (0..3)
                    .map(|j| turn(g[j].to_array(), g[(j + 1) % 3].to_array()))
                    .fold(0.0, f64::max)
            };
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let centroid = (p[0] + p[1] + p[2]) / 3.0;
            self.samples
                .push((centroid, tolerance(tau, bend, longest), n));
        }
    }

    /// Marks dirty the vertices whose star a collapse into `k` changed:
    /// `k` and its neighbours.
    fn mark_around(&mut self, k: u32) {
        self.ring.clear();
        self.m.neighbours_into(k, &mut self.ring);
        self.ring.push(k);
        for &w in &self.ring {
            self.dirty[w as usize] |= !self.fixed[w as usize];
        }
    }
}

/// What a collapse may use of the tolerance `tau` at a turn of the
/// normals `turn` over `length`: [`SAFETY`] of it.
fn tolerance(tau: Chord, turn: f64, length: f64) -> f64 {
    SAFETY * tau.at(turn, length)
}

/// The length of `v`'s shortest edge.
fn shortest_edge(m: &DynMesh, v: u32) -> f64 {
    let p = m.pos[v as usize];
    m.star[v as usize]
        .iter()
        .flat_map(|&i| m.tris[i as usize])
        .filter(|&w| w != v)
        .map(|w| p.distance_squared(m.pos[w as usize]))
        .fold(f64::INFINITY, f64::min)
        .sqrt()
}

/// What the checks of removing a vertex read of its neighbourhood,
/// gathered once per visit.
struct Around {
    r: u32,
    /// Its neighbours with their squared distances, nearest first.
    near: Small<(f64, u32)>,
    /// The largest turn per length of the normals along its edges (of a
    /// crease point: along the edges of its link off the crease, on the
    /// faces it joins).
    kappa: f64,
    /// A smooth vertex or a crease point.
    kind: Kind,
    /// Its star is flat: every vertex of it has `r`'s normal and lies on
    /// `r`'s tangent plane. A fan that turns no triangle over then covers
    /// the same piece of plane as the star it replaces, so no point of the
    /// mesh moves off the surface: the measure on `f` is not needed.
    flat: bool,
    /// The worst aspect ratio of its star, once a check needs it.
    worst: std::cell::OnceCell<f64>,
}

impl Around {
    /// What the checks read around `r`; `domain` is given where `r` lies
    /// on the mesh's boundary.
    fn new(m: &DynMesh, r: u32, crease: &[bool], domain: Option<&Bounds>) -> Around {
        let (pr, nr) = (m.pos[r as usize], m.grad[r as usize].to_array());
        let boundary = match crease[r as usize] {
            false => domain.and_then(|d| boundary_neighbours(m, r, d)),
            true => None,
        };
        // A closed disk or an open fan (only removable vertices are
        // visited): each neighbour follows `r` in exactly one triangle of
        // its star, but the fan's last one.
        let mut near: Small<(f64, u32)> = m.star[r as usize]
            .iter()
            .map(|&i| {
                let tri = m.tris[i as usize];
                let at = tri.iter().position(|&v| v == r).expect("r's star holds r");
                let w = tri[(at + 1) % 3];
                (pr.distance_squared(m.pos[w as usize]), w)
            })
            .collect();
        if let Some([_, last]) = boundary {
            near.push((pr.distance_squared(m.pos[last as usize]), last));
        }
        near.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let flat = near.iter().all(|&(_, w)| {
            let g = m.grad[w as usize];
            g.dot(DVec3::from_array(nr)) >= 1.0 - FLAT && on_tangent_plane(m.pos[w as usize], g, pr)
        });
        let (kappa, kind) = if crease[r as usize] {
            let along = crease_neighbours(m, r, crease);
            (link_kappa(m, r, crease), Kind::Crease(along))
        } else if flat {
            // Not read: a flat star's new edges are not held to a size.
            (0.0, boundary.map_or(Kind::Smooth, Kind::Boundary))
        } else {
            let kappa = near
                .iter()
                .filter(|&&(_, w)| !crease[w as usize])
                .map(|&(d2, w)| turn(nr, m.grad[w as usize].to_array()) / d2.sqrt())
                .fold(0.0, f64::max);
            (kappa, boundary.map_or(Kind::Smooth, Kind::Boundary))
        };
        Around {
            r,
            near,
            kappa,
            kind,
            flat,
            worst: std::cell::OnceCell::new(),
        }
    }

    /// The neighbours `r` may be collapsed into, in the order tried: a
    /// smooth vertex's [`TARGETS`] nearest, a crease point's two along the
    /// crease (nearest first; none at a corner).
    fn targets(&self) -> impl Iterator<Item = u32> + '_ {
        let (along, take) = match self.kind {
            Kind::Smooth => (None, TARGETS),
            Kind::Crease(Some(ab)) | Kind::Boundary(ab) => (Some(ab), 2),
            Kind::Crease(None) => (None, 0),
        };
        self.near
            .iter()
            .map(|&(_, w)| w)
            .filter(move |w| along.is_none_or(|ab| ab.contains(w)))
            .take(take)
    }

    /// Whether every new edge of collapsing into `k`, shortened by
    /// [`ANISOTROPY`], would be within the tolerance if the surface bent
    /// along it as much as it bends most around the vertex.
    fn isotropic(&self, m: &DynMesh, k: u32, tau: Chord) -> bool {
        let pk = m.pos[k as usize];
        let kappa = self.kappa;
        self.near.iter().all(|&(_, w)| {
            let l = pk.distance(m.pos[w as usize]) / ANISOTROPY;
            kappa * l * l / 8.0 <= tolerance(tau, kappa * l, l)
        })
    }

    /// The link condition of collapsing `r` into `k`
    /// ([`DynMesh::can_collapse_topologically`]), read from `r`'s ring: the
    /// common neighbours of `r` and `k` are the ring's vertices other than
    /// `k` that are `k`'s neighbours, and must be exactly the vertices
    /// opposite the edge: two where `r`'s star is a closed disk, one along
    /// the boundary (the edge's one triangle; `k`'s other boundary
    /// neighbour is then not `r`'s, so the boundary loop keeps three
    /// vertices or more).
    fn link_holds(&self, m: &DynMesh, k: u32) -> bool {
        let r = self.r;
        let mut opposite: SmallVec<[u32; 2]> = SmallVec::new();
        for &i in &m.star[r as usize] {
            let tri = m.tris[i as usize];
            if tri.contains(&k) {
                opposite.extend(tri.into_iter().filter(|&v| v != r && v != k));
            }
        }
        let boundary = matches!(self.kind, Kind::Boundary(_));
        let want = if boundary { 1 } else { 2 };
        if opposite.len() != want || opposite[1..].contains(&opposite[0]) {
            return false;
        }
        if !opposite.iter().all(|&v| m.star[v as usize].len() > 3) {
            return false;
        }
        let shared = |w: u32| w != k && !opposite.contains(&w) && m.adjacent(k, w);
        if self.near.iter().any(|&(_, w)| shared(w)) {
            return false;
        }
        if boundary {
            // `k`'s fan and `r`'s join along the edge to the opposite
            // vertex: one open fan.
            return true;
        }
        // The merged vertex keeps at least 3 neighbours: `k`'s star
        // counts at most its neighbours; where that is not enough, count.
        m.star[k as usize].len() + self.near.len() >= 7 || m.can_collapse_topologically(k, r)
    }

    /// Whether the fan that collapsing into `k` makes is acceptable: no
    /// triangle turns over, leaves a corner's normal by more than 60°, or
    /// is a sliver (see the module doc).
    fn fan(&self, m: &DynMesh, k: u32, crease: &[bool]) -> Verdict {
        let (r, pk) = (self.r, m.pos[k as usize]);
        let mut new_worst = 1.0f64;
        for &i in &m.star[r as usize] {
            let tri = m.tris[i as usize];
            if tri.contains(&k) {
                continue;
            }
            let q = tri.map(|v| m.pos[v as usize]);
            let nq = tri.map(|v| if v == r { pk } else { m.pos[v as usize] });
            let n = (nq[1] - nq[0]).cross(nq[2] - nq[0]);
            let old = (q[1] - q[0]).cross(q[2] - q[0]);
            let nu = n.normalize_or_zero();
            let corners = tri.map(|v| if v == r { k } else { v });
            // A crease point's normal is one side's: the new triangle is
            // held to the one it replaces there.
            let normal = |v: u32| {
                if crease[v as usize] {
                    old.normalize_or_zero()
                } else {
                    m.grad[v as usize]
                }
            };
            if n.dot(old) <= 0.0 || corners.iter().any(|&v| nu.dot(normal(v)) < ALIGN) {
                return Verdict::Refused;
            }
            new_worst = new_worst.min(aspect(nq[0], nq[1], nq[2]));
        }
        if new_worst >= MIN_ASPECT || new_worst >= *self.worst.get_or_init(|| star_worst(m, r)) {
            Verdict::Passed
        } else {
            Verdict::Sliver
        }
    }
}

/// The worst aspect ratio of `r`'s star.
fn star_worst(m: &DynMesh, r: u32) -> f64 {
    m.star[r as usize]
        .iter()
        .map(|&i| {
            let q = m.tris[i as usize].map(|v| m.pos[v as usize]);
            aspect(q[0], q[1], q[2])
        })
        .fold(1.0, f64::min)
}

/// The distance from `r` to the fan that collapsing it into `k` makes.
fn near_fan(m: &DynMesh, r: u32, k: u32) -> f64 {
    let (pk, pr) = (m.pos[k as usize], m.pos[r as usize]);
    m.star[r as usize]
        .iter()
        .map(|&i| m.tris[i as usize])
        .filter(|tri| !tri.contains(&k))
        .map(|tri| {
            point_triangle_distance(pr, tri.map(|v| if v == r { pk } else { m.pos[v as usize] }))
        })
        .fold(f64::INFINITY, f64::min)
}

/// What a vertex visited by [`Coarsener::try_remove`] is.
#[derive(Clone, Copy)]
enum Kind {
    /// Off the creases: collapsed into one of its [`TARGETS`] nearest.
    Smooth,
    /// A crease point, with its two neighbours along the crease when it has
    /// exactly two sharp edges and both go to crease points: the only
    /// targets it may be collapsed into (none otherwise: a corner stays).
    Crease(Option<[u32; 2]>),
    /// On the mesh's boundary, on one face of Ω, with its two neighbours
    /// along the boundary on that face: collapsed only into one of them,
    /// so the boundary stays on the face.
    Boundary([u32; 2]),
}

/// What [`Coarsener::geometric`] says of a collapse.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Verdict {
    /// Every check that reads the mesh alone holds.
    Passed,
    /// Only the aspect floor refuses it: a new triangle would be a sliver.
    Sliver,
    /// Another check refuses it.
    Refused,
}

/// The distance from `p` to the segment `a–b`.
fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let s = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    if s.is_finite() {
        p.distance(a + s * ab)
    } else {
        p.distance(a)
    }
}

/// Whether the edge `r–w` is sharp: its two triangles' normals turn by
/// more than [`SPLIT_DEG`] (the crease pass's own threshold).
fn sharp(m: &DynMesh, r: u32, w: u32) -> bool {
    let Some(pair) = m.edge_pair(r, w) else {
        return false;
    };
    let [n0, n1] = pair.map(|(_, t)| {
        let p = t.map(|v| m.pos[v as usize]);
        (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
    });
    n0.dot(n1) < SPLIT_DEG.to_radians().cos()
}

/// A crease point's two neighbours along its crease: its only sharp edges
/// go to exactly two crease points. `None` at a corner, an end, or where
/// a sharp edge leaves to a vertex off the crease.
fn crease_neighbours(m: &DynMesh, r: u32, crease: &[bool]) -> Option<[u32; 2]> {
    let mut along: SmallVec<[u32; 2]> = SmallVec::new();
    for &i in &m.star[r as usize] {
        let tri = m.tris[i as usize];
        let at = tri.iter().position(|&v| v == r)?;
        let w = tri[(at + 1) % 3];
        if sharp(m, r, w) {
            if !crease[w as usize] || along.len() == 2 {
                return None;
            }
            along.push(w);
        }
    }
    (along.len() == 2).then(|| [along[0], along[1]])
}

/// The largest turn per length of the normals along the edges of `r`'s
/// link that join two vertices off the crease: the faces' curvature
/// around a crease point, whose own normal is one side's.
fn link_kappa(m: &DynMesh, r: u32, crease: &[bool]) -> f64 {
    m.star[r as usize]
        .iter()
        .map(|&i| m.tris[i as usize])
        .filter_map(|tri| {
            let at = tri.iter().position(|&v| v == r)?;
            let (x, y) = (tri[(at + 1) % 3], tri[(at + 2) % 3]);
            if crease[x as usize] || crease[y as usize] {
                return None;
            }
            let (gx, gy) = (m.grad[x as usize], m.grad[y as usize]);
            Some(turn(gx.to_array(), gy.to_array()) / m.pos[x as usize].distance(m.pos[y as usize]))
        })
        .fold(0.0, f64::max)
}

/// Whether `v` may be removed at all: its normal is a unit vector, and
/// its star is one closed disk, or one open fan whose two boundary
/// neighbours lie with it on one face of `domain` ([`boundary_neighbours`]).
fn removable(m: &DynMesh, v: u32, domain: Option<&Bounds>) -> bool {
    admits(m, v, fan(m, v), domain)
}

/// [`removable`], given `v`'s [`fan`].
fn admits(m: &DynMesh, v: u32, fan: Option<Option<[u32; 2]>>, domain: Option<&Bounds>) -> bool {
    let g = m.grad[v as usize];
    (g.length() - 1.0).abs() <= 1e-6
        && match fan {
            Some(None) => true,
            Some(Some(ends)) => domain.is_some_and(|d| on_one_face(m, v, ends, d)),
            None => false,
        }
}

/// How `v`'s star lies around it: `Some(None)`, one closed disk (the
/// edges opposite `v` form a single cycle through all its triangles);
/// `Some(Some([a, b]))`, one open fan from the neighbour `a` round to `b`
/// (`v` lies on the mesh's boundary, between its boundary edges `v–a` and
/// `v–b`); `None`, anything else (no triangles, a non-manifold vertex).
fn fan(m: &DynMesh, v: u32) -> Option<Option<[u32; 2]>> {
    // Each triangle, read from `v`, goes from one neighbour to the next.
    let steps: Small<(u32, u32)> = m.star[v as usize]
        .iter()
        .map(|&i| {
            let t = m.tris[i as usize];
            let s = t.iter().position(|&w| w == v).unwrap_or(0);
            (t[(s + 1) % 3], t[(s + 2) % 3])
        })
        .collect();
    // An open fan starts at the neighbour no triangle goes to.
    let start = steps
        .iter()
        .map(|s| s.0)
        .find(|&w| !steps.iter().any(|s| s.1 == w));
    let from = start.or(steps.first().map(|s| s.0))?;
    let mut at = from;
    for i in 0..steps.len() {
        if i > 0 && at == from {
            return None;
        }
        let mut next = steps.iter().filter(|s| s.0 == at);
        match (next.next(), next.next()) {
            (Some(&(_, to)), None) => at = to,
            _ => return None,
        }
    }
    match start {
        None => (at == from).then_some(None),
        // The walk took every triangle once and ends where none starts.
        Some(a) => (!steps.iter().any(|s| s.0 == at)).then_some(Some([a, at])),
    }
}

/// Whether the boundary vertex `v`, between its boundary neighbours
/// `ends`, lies on exactly one face of `domain` (not on an edge of Ω), and
/// both neighbours lie on that face too: the boundary edge that removing
/// `v` makes then lies in the face.
fn on_one_face(m: &DynMesh, v: u32, ends: [u32; 2], domain: &Bounds) -> bool {
    let faces = |w: u32| domain.faces(m.pos[w as usize].to_array());
    let own = faces(v);
    own.count_ones() == 1 && ends.iter().all(|&w| faces(w) & own != 0)
}

/// A vertex of the mesh's boundary that may be removed along it: its two
/// boundary neighbours, when [`removable`] allows it.
fn boundary_neighbours(m: &DynMesh, v: u32, domain: &Bounds) -> Option<[u32; 2]> {
    fan(m, v)
        .flatten()
        .filter(|&ends| on_one_face(m, v, ends, domain))
}
