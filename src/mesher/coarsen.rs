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
//! The input is an oriented mesh whose vertices lie on `f = 0`; `pinned`
//! flags vertices that must stay (crease points, a brick's seam). A
//! collapse removes a vertex `r` into a neighbour `k` (a half-edge
//! collapse: `k` keeps its position, so every vertex stays on the
//! surface, and no new point is made). It is made only when
//!
//! - `r` is not pinned, its star is a closed disk (not on the domain's
//!   boundary, not at a non-manifold vertex), and its normal is a unit
//!   vector;
//! - the link condition holds (`DynMesh::can_collapse_topologically`):
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
//! split again. Collapses are made in sweeps, each checked and measured on
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
//! ([`super::smooth`]) improves it after. Crease vertices are pinned, so a
//! model with many creases (colonnade.vm) keeps the dense strips the
//! creases bring. The pass is sequential (single-threaded): each collapse
//! is measured on the mesh the previous ones left. It runs in the
//! smoothing stage, so `--smooth 0` keeps the mesh as extracted and split
//! (and a bricked run equal to the whole one, [`super::brick`]).

use glam::DVec3;
use rayon::prelude::*;
use smallvec::SmallVec;

use super::adapt::{ALIGN, point_triangle_distance};
use crate::cancel::{Cancel, Cancelled};
use crate::eval::Evaluator;
use crate::mesh::Mesh;
use crate::mesh::dynmesh::DynMesh;
use crate::mesh::order::retain;
use crate::mesh::quality::aspect;
use crate::octree::Chord;
use crate::octree::criteria::turn;

/// The share of the tolerance a collapse may use: relaxation moves the
/// vertices afterwards and may stretch an edge a little.
pub const SAFETY: f64 = 0.8;

/// Most sweeps.
const SWEEPS: usize = 4;

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

/// Removes vertices of `mesh` by edge collapses while the chord tolerance
/// `tau` allows it (see the module doc); `pinned` flags the vertices that
/// stay. Returns, per input vertex, whether it is kept: the caller
/// filters its own per-vertex data with it ([`crate::mesh::order::retain`]);
/// the mesh's own (positions, normals, ambiguity) are filtered already.
/// Returns [`Cancelled`] when `cancel` was cancelled before a sweep (the
/// mesh is then left as it was).
pub fn coarsen<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    pinned: &[bool],
    f: &E,
    t: f64,
    tau: Chord,
    cancel: &Cancel,
) -> Result<Vec<bool>, Cancelled> {
    let mut c = Coarsener::new(mesh, pinned, tau);
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
    Ok(kept)
}

/// The state of a coarsening.
struct Coarsener {
    m: DynMesh,
    ambiguous: Vec<bool>,
    /// Vertices never removed (pinned, or not removable: [`removable`]).
    fixed: Vec<bool>,
    /// Vertices whose neighbourhood changed since their last visit.
    dirty: Vec<bool>,
    tau: Chord,
    /// Scratch: the points a collapse is measured at, their tolerances
    /// and the directions ∇f must agree with; the evaluations.
    samples: Vec<(DVec3, f64, DVec3)>,
    pts: Vec<[f64; 3]>,
    values: Vec<(f64, [f64; 3])>,
    ring: Vec<u32>,
}

impl Coarsener {
    fn new(mesh: &Mesh, pinned: &[bool], tau: Chord) -> Self {
        let m = DynMesh::indexed(mesh);
        let n = mesh.positions.len();
        let mut ambiguous = mesh.ambiguous.clone();
        ambiguous.resize(n, false);
        let fixed: Vec<bool> = (0..n as u32)
            .into_par_iter()
            .map(|v| pinned.get(v as usize).copied().unwrap_or(false) || !removable(&m, v))
            .collect();
        let dirty = fixed.iter().map(|&x| !x).collect();
        Coarsener {
            m,
            ambiguous,
            fixed,
            dirty,
            tau,
            samples: Vec::new(),
            pts: Vec::new(),
            values: Vec::new(),
            ring: Vec::new(),
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
        let around = Around::new(&self.m, r);
        let k = around
            .near
            .iter()
            .take(TARGETS)
            .map(|&(_, k)| k)
            .find(|&k| self.geometric(&around, k) && self.measured(f, t, &around, k))?;
        let (pk, gk) = (self.m.pos[k as usize], self.m.grad[k as usize]);
        self.m.collapse(k, r, pk, gk);
        self.ambiguous[k as usize] |= self.ambiguous[r as usize];
        Some(k)
    }

    /// The checks of collapsing `around.r` into `k` that read the mesh
    /// alone, cheapest first: the new edges' lengths ([`Around::isotropic`]),
    /// the fan ([`Around::fan_ok`]), the removed vertex within the
    /// tolerance of the fan, and the link condition.
    fn geometric(&self, around: &Around, k: u32) -> bool {
        let (m, r) = (&self.m, around.r);
        let (pr, pk) = (m.pos[r as usize], m.pos[k as usize]);
        let bend = turn(m.grad[r as usize].to_array(), m.grad[k as usize].to_array());
        around.isotropic(m, k, self.tau)
            && around.fan_ok(m, k)
            && near_fan(m, r, k) <= tolerance(self.tau, bend, pr.distance(pk))
            && m.can_collapse_topologically(k, r)
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
                v.abs() / g.length() <= tol && g.dot(side) > 0.0
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
            let tol = tolerance(tau, turn(nk.to_array(), nw.to_array()), pk.distance(pw));
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
            let bend = (0..3)
                .map(|j| turn(g[j].to_array(), g[(j + 1) % 3].to_array()))
                .fold(0.0, f64::max);
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
    /// The largest turn per length of the normals along its edges.
    kappa: f64,
    /// The worst aspect ratio of its star, once a check needs it.
    worst: std::cell::OnceCell<f64>,
}

impl Around {
    fn new(m: &DynMesh, r: u32) -> Around {
        let (pr, nr) = (m.pos[r as usize], m.grad[r as usize].to_array());
        // A closed disk (only removable vertices are visited): each
        // neighbour follows `r` in exactly one triangle of its star.
        let mut near: Small<(f64, u32)> = m.star[r as usize]
            .iter()
            .map(|&i| {
                let tri = m.tris[i as usize];
                let at = tri.iter().position(|&v| v == r).expect("r's star holds r");
                let w = tri[(at + 1) % 3];
                (pr.distance_squared(m.pos[w as usize]), w)
            })
            .collect();
        near.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let kappa = near
            .iter()
            .map(|&(d2, w)| turn(nr, m.grad[w as usize].to_array()) / d2.sqrt())
            .fold(0.0, f64::max);
        Around {
            r,
            near,
            kappa,
            worst: std::cell::OnceCell::new(),
        }
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

    /// Whether the fan that collapsing into `k` makes is acceptable: no
    /// triangle turns over, leaves a corner's normal by more than 60°, or
    /// is a sliver (see the module doc).
    fn fan_ok(&self, m: &DynMesh, k: u32) -> bool {
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
            if n.dot(old) <= 0.0 || corners.iter().any(|&v| nu.dot(m.grad[v as usize]) < ALIGN) {
                return false;
            }
            new_worst = new_worst.min(aspect(nq[0], nq[1], nq[2]));
        }
        new_worst >= MIN_ASPECT || new_worst >= *self.worst.get_or_init(|| star_worst(m, r))
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

/// Whether `v` may be removed at all: its star is one closed disk (the
/// edges opposite `v` form a single cycle through all its triangles) and
/// its normal is a unit vector.
fn removable(m: &DynMesh, v: u32) -> bool {
    let g = m.grad[v as usize];
    if (g.length() - 1.0).abs() > 1e-6 {
        return false;
    }
    // Each triangle, read from `v`, goes from one neighbour to the next.
    let steps: Small<(u32, u32)> = m.star[v as usize]
        .iter()
        .map(|&i| {
            let t = m.tris[i as usize];
            let s = t.iter().position(|&w| w == v).unwrap_or(0);
            (t[(s + 1) % 3], t[(s + 2) % 3])
        })
        .collect();
    let Some(&(first, mut at)) = steps.first() else {
        return false;
    };
    for _ in 1..steps.len() {
        if at == first {
            return false;
        }
        let mut next = steps.iter().filter(|s| s.0 == at);
        match (next.next(), next.next()) {
            (Some(&(_, to)), None) => at = to,
            _ => return false,
        }
    }
    at == first && steps.iter().filter(|s| s.0 == first).count() == 1
}
