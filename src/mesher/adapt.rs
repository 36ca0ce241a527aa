//! Adapting a mesh to a tolerance `D` on the surface itself (`--tolerance
//! D`, [`super::mesh_to_tolerance`]): isotropic remeshing with edge
//! lengths sized from the measured deviations, then measured repairs of
//! the triangles still farther than `D`.
//!
//! # Contract
//!
//! The input is an oriented manifold mesh, closed or cut by the domain,
//! whose vertices lie on `f = 0` (the mesher's). The output has the same
//! topology (every operation is a split, a flip of an edge whose other
//! diagonal is not an edge yet, or a collapse that passes the link
//! condition), the same orientation, and every vertex still on `f = 0`
//! (projected by bisection). Vertices flagged `keep` (sharp creases) and
//! boundary vertices never move and are never removed; edges between two
//! of them are not flipped. The deviation of a triangle is the bound of
//! [`crate::mesh::deviation`] (centroid and edge midpoints, each also at
//! most its distance to the nearest corner); the caller measures the
//! result again before it calls it within the tolerance.
//!
//! # Steps
//!
//! 1. **Size-driven iterations** (`SIZE_ITERATIONS`, Botsch & Kobbelt's
//!    isotropic remeshing with a size field): every triangle's deviation
//!    is measured (one batch) and gives its vertices a target edge length
//!    — its longest edge times `√(SIZE_SAFETY·D / deviation)`, as a chord
//!    error grows with the square of the size, within a quarter and twice
//!    the current one; per vertex the geometric mean over its star, then
//!    graded along edges. Edges longer than 4/3 of their ends' target are
//!    split, shorter than 4/5 collapsed, flips improve the worse aspect
//!    ratio of a pair, and every vertex moves towards its tangential
//!    relaxation target (`relaxation_target`), projected
//!    back. These changes are not measured one by one, so each keeps the
//!    surface as it was: no triangle may turn against ∇f or against the
//!    one it replaces, a collapse keeps the vertex it removes within `D`
//!    of the new triangles and makes no sliver (aspect below
//!    [`MIN_ASPECT`]), and a flip or collapse makes no triangle whose
//!    normal leaves ∇f at a corner by more than 60° (`ALIGN`) — one
//!    standing across a ridge sharper than itself — nor, for a flip, a
//!    fold higher than `D`.
//! 2. **Repairs**, measured: each triangle still farther than `D` is
//!    flipped with a neighbour if both new triangles are within `D` (and
//!    keep 80 % of the worse aspect ratio), else split — each edge whose
//!    midpoint is too far, or the longest edge (preferring one shared with
//!    another offending triangle). A split's vertex is the midpoint
//!    projected along the gradient line (no farther than half the edge)
//!    or, where that folds a new triangle over, along the line of the
//!    edge's triangles' normals ([`crate::roots::line_zero`]), which keeps
//!    every new triangle on its old one's side. Refused when a new
//!    triangle would face against ∇f, when no surface point is found,
//!    below a minimal edge length, or once the mesh has `BUDGET` times the
//!    input's triangles; a refused split is tried again next round, after
//!    its neighbourhood changed.
//! 3. **Relaxation** of the vertices around the repairs, each move kept
//!    only if its star's worst aspect ratio improves and every triangle
//!    of the star stays within `D`; then repairs again where needed.
//!
//! # Limits
//!
//! The deviation is measured at four points per triangle (see
//! [`crate::mesh::deviation`]). Where ∇f vanishes (a cusp, a pinch) some
//! splits find no surface point; those triangles stay outside the
//! tolerance and the caller refines its octree instead. The mesh is not
//! checked for self-intersection: a change is refused when a triangle
//! turns over, not when it passes through a distant part of the mesh.
//! Triangles are isotropic: on a tube much thinner than it is long the
//! count is set by the tube's radius. Evaluation is batched for whole-mesh
//! measurements, one point at a time for projections and checked moves.

use std::time::Instant;

use glam::DVec3;
use smallvec::SmallVec;

use crate::eval::Evaluator;
use crate::geometry::Bounds;
use crate::mesh::Mesh;
use crate::mesh::deviation::{corner_bound, sample_bound, samples, triangle_bounds};
use crate::mesh::dynmesh::{DynMesh, EdgeKey, key};
use crate::mesh::quality::aspect;
use crate::roots::{at, line_zero, project_along};

/// No collapse makes a triangle with an aspect ratio below this (unless
/// the triangles it replaces had one already).
pub const MIN_ASPECT: f64 = 0.6;

/// A split round starts only while the mesh has fewer than this many
/// times the input's triangles (or a million): where no measured point
/// can be brought within the tolerance (∇f vanishing on the surface), the
/// splits stop instead of filling memory.
const BUDGET: usize = 16;

/// Most split rounds.
const MAX_ROUNDS: usize = 40;

/// Iterations of size-driven remeshing (split, collapse, flip, relax):
/// at least this many, more (up to [`MAX_SIZE_ITERATIONS`]) while over
/// [`FAR_SHARE`] of the triangles deviate by more than twice the
/// tolerance (a first mesh much coarser than the tolerance needs).
const SIZE_ITERATIONS: usize = 2;

/// Most size-driven iterations.
const MAX_SIZE_ITERATIONS: usize = 5;

/// See [`SIZE_ITERATIONS`].
const FAR_SHARE: f64 = 0.02;

/// The share of the tolerance the size-driven iterations aim at.
const SIZE_SAFETY: f64 = 0.85;

/// How fast the target edge length may grow with distance.
const GRADE: f64 = 0.5;

/// Passes of tangential relaxation after the collapses.
const RELAX_PASSES: usize = 1;

/// A vertex whose triangles all have at least this aspect ratio is not
/// relaxed.
const SETTLED: f64 = 0.85;

/// The least cosine between a triangle's normal and ∇f at its corners
/// that an unmeasured change may leave.
pub(super) const ALIGN: f64 = 0.5;

/// Flips are tried on the edges of triangles below this aspect ratio.
const FLIP_BELOW: f64 = 0.9;

/// The sharpest fold a flip may leave between its two triangles (cosine
/// of the angle between their normals), unless the old fold was sharper.
const FLIP_FOLD_COS: f64 = 0.866;

/// What [`adapt`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Adapted {
    /// Edges split.
    pub splits: usize,
    /// Splits refused (a new triangle would turn over, or the midpoint
    /// did not project).
    pub refused: usize,
    /// Edges collapsed.
    pub collapses: usize,
    /// Edges flipped.
    pub flips: usize,
    /// Split rounds run.
    pub rounds: usize,
    /// Milliseconds in the size-driven iterations, in the measured repairs
    /// (flips and splits) and in the final relaxation.
    pub ms: [f64; 3],
}

/// Adapts `mesh` to the tolerance `tol` on `f(·, t) = 0` in `domain` (see
/// the module doc), splitting no edge shorter than `min_edge`; `keep[v]`
/// pins vertex `v` (a shorter `keep` pins nothing past its end). Returns
/// what it did.
pub fn adapt<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    keep: &[bool],
    (f, t): (&E, f64),
    domain: Bounds,
    tol: f64,
    min_edge: f64,
) -> Adapted {
    let mut a = Adapter::new(mesh, keep, (f, t), domain, tol);
    a.min_edge = min_edge;
    let clock = Instant::now();
    a.checked = false;
    for it in 0..MAX_SIZE_ITERATIONS {
        if it >= SIZE_ITERATIONS && a.far_share() <= FAR_SHARE {
            break;
        }
        let size = a.sizing();
        let size = a.split_long(size);
        a.collapse_short(size);
        a.flip_around(None);
        a.relax(None);
    }
    a.checked = true;
    let sized = clock.elapsed();
    // The tail the sizes missed: repairing flips and splits, then
    // relaxation around the vertices they made.
    let made = a.refine();
    let repaired = clock.elapsed();
    let region = a.around(&a.around(&made));
    for _ in 0..RELAX_PASSES {
        if a.relax(Some(&region)) == 0 {
            break;
        }
    }
    let relaxed = clock.elapsed();
    // Relaxation keeps every star within the tolerance; this retries what
    // the first repairs refused, in neighbourhoods the relaxation changed.
    a.refine();
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    a.counts.ms = [
        ms(sized),
        ms(repaired - sized) + ms(clock.elapsed() - relaxed),
        ms(relaxed - repaired),
    ];
    a.finish(mesh)
}

/// Triangle samples: deviation bounds at the centroid and at the
/// midpoints of `ab`, `bc`, `ca`, or NaN when not measured yet.
type Bounds4 = [f64; 4];

struct Adapter<'a, E: Evaluator + ?Sized> {
    m: DynMesh,
    ambiguous: Vec<bool>,
    keep: Vec<bool>,
    dev: Vec<Bounds4>,
    f: &'a E,
    t: f64,
    tol: f64,
    /// Ω: no vertex is put outside it, and a boundary edge's new vertex
    /// stays on the face of Ω its ends share.
    domain: Bounds,
    /// Whether flips and relaxation must keep every triangle they make
    /// within the tolerance (off during the size-driven iterations, whose
    /// triangles are measured again before the next one).
    checked: bool,
    /// No edge shorter than this is split.
    min_edge: f64,
    /// Whether the mesh has no boundary (no operation here makes or removes
    /// one).
    closed: bool,
    /// No split round starts once the mesh has this many triangles (dead
    /// ones included): `BUDGET` times the input's, at least a million.
    budget: usize,
    counts: Adapted,
}

const UNKNOWN: Bounds4 = [f64::NAN; 4];

/// A vertex's star or ring without a heap allocation in the common case.
type Small<T> = SmallVec<[T; 16]>;

/// `a <= b`, false when either is NaN (so that `!at_most` reads "not
/// known to be within").
fn at_most(a: f64, b: f64) -> bool {
    a <= b
}

/// `a > b`, false when either is NaN.
fn exceeds(a: f64, b: f64) -> bool {
    a > b
}

fn worst(b: &Bounds4) -> f64 {
    // NaN (unmeasured) compares as not within the tolerance.
    b.iter()
        .copied()
        .fold(0.0, |m, x| if x.is_nan() { f64::NAN } else { m.max(x) })
}

impl<'a, E: Evaluator + ?Sized> Adapter<'a, E> {
    fn new(mesh: &Mesh, keep: &[bool], (f, t): (&'a E, f64), domain: Bounds, tol: f64) -> Self {
        // Vertex for vertex (not `DynMesh::from_mesh`, which renumbers):
        // `keep` and the ambiguity flags are indexed like `mesh`.
        let m = DynMesh::indexed(mesh);
        let n = mesh.positions.len();
        let mut ambiguous = mesh.ambiguous.clone();
        ambiguous.resize(n, false);
        let mut kept = keep.to_vec();
        kept.resize(n, false);
        // Vertices on the boundary (an open surface cut by the domain) or
        // on a non-manifold edge stay where they are: moving or removing
        // one would move the cut.
        let mut closed = true;
        for (u, v) in m.edges_unordered() {
            if m.edge_pair(u, v).is_none() {
                kept[u as usize] = true;
                kept[v as usize] = true;
                closed = false;
            }
        }
        let dev = vec![UNKNOWN; m.tris.len()];
        Adapter {
            m,
            ambiguous,
            keep: kept,
            dev,
            f,
            t,
            tol,
            domain,
            checked: true,
            min_edge: 0.0,
            closed,
            budget: (BUDGET * mesh.triangles.len()).max(1 << 20),
            counts: Adapted::default(),
        }
    }

    /// Every live edge once, in no particular order.
    fn edges(&self) -> Vec<EdgeKey> {
        if self.closed {
            self.m.closed_edges()
        } else {
            self.m.edges_unordered()
        }
    }

    fn pos(&self, v: u32) -> DVec3 {
        self.m.pos[v as usize]
    }

    fn unit_grad(&self, v: u32) -> DVec3 {
        self.m.grad[v as usize].normalize_or_zero()
    }

    /// Deviation bounds of the triangles `tris` (vertex triples), one batch.
    fn measure(&self, tris: &[[DVec3; 3]]) -> Vec<Bounds4> {
        triangle_bounds(self.f, self.t, tris, reach(tris), true)
    }

    /// The bound of sample `s` of triangle `tri`: its distance to the
    /// nearest corner when that is already within the tolerance (no
    /// evaluation), else the least of that and [`sample_bound`].
    fn bound(&self, tri: [DVec3; 3], s: DVec3, reach: f64) -> f64 {
        let d = corner_bound(tri, s);
        if d <= self.tol {
            d
        } else {
            sample_bound(self.f, self.t, s, reach).min(d)
        }
    }

    /// The deviation bounds of `tris` if every one is within the tolerance,
    /// else `None`, one sample at a time: the centroids first (where an
    /// enlarged triangle usually fails), stopping at the first sample
    /// outside.
    fn within(&self, tris: &[[DVec3; 3]]) -> Option<Vec<Bounds4>> {
        let reach = reach(tris);
        let points: Small<[DVec3; 4]> = tris.iter().map(|&q| samples(q)).collect();
        let mut out = vec![UNKNOWN; tris.len()];
        for k in 0..4 {
            for ((q, s), b) in tris.iter().zip(&points).zip(&mut out) {
                let d = self.bound(*q, s[k], reach);
                if !at_most(d, self.tol) {
                    return None;
                }
                b[k] = d;
            }
        }
        Some(out)
    }

    /// `within` for the triangles of `star` (around `v`) with `v`
    /// moved to `q`, each read from `v` (`[q, b, c]`): only the samples that
    /// move are measured — the centroids, then the midpoints of the edges
    /// from `q` (each shared by two triangles, measured once); the midpoint
    /// of `b–c` keeps its bound when it has one.
    fn within_star(&self, v: u32, star: &[u32], q: DVec3) -> Option<Vec<Bounds4>> {
        let sides: Small<(u32, u32, usize)> = star
            .iter()
            .map(|&i| {
                let tri = self.m.tris[i as usize];
                let s = tri.iter().position(|&w| w == v).unwrap_or(0);
                (tri[(s + 1) % 3], tri[(s + 2) % 3], s)
            })
            .collect();
        let tris: Small<[DVec3; 3]> = sides
            .iter()
            .map(|&(b, c, _)| [q, self.pos(b), self.pos(c)])
            .collect();
        let reach = reach(&tris);
        let bound = |tri: [DVec3; 3], s: DVec3| self.bound(tri, s, reach);
        let mut out = vec![UNKNOWN; tris.len()];
        for (tri, b) in tris.iter().zip(&mut out) {
            b[0] = bound(*tri, samples(*tri)[0]);
            if !at_most(b[0], self.tol) {
                return None;
            }
        }
        // The edge from `q` to each neighbour, once.
        let mut spoke: Small<(u32, f64)> = Small::new();
        for (j, &(b, _, _)) in sides.iter().enumerate() {
            let d = bound(tris[j], (q + tris[j][1]) * 0.5);
            if !at_most(d, self.tol) {
                return None;
            }
            spoke.push((b, d));
        }
        for (j, &(b, c, s)) in sides.iter().enumerate() {
            let near = |w: u32| spoke.iter().find(|e| e.0 == w).map(|e| e.1);
            out[j][1] = near(b).unwrap_or(f64::NAN);
            out[j][3] = match near(c) {
                Some(d) => d,
                None => bound(tris[j], (tris[j][2] + q) * 0.5),
            };
            // Edge `b–c` is edge (s + 1) % 3 of the triangle as stored.
            let kept = self.dev[star[j] as usize][1 + (s + 1) % 3];
            out[j][2] = if kept.is_nan() {
                bound(tris[j], (tris[j][1] + tris[j][2]) * 0.5)
            } else {
                kept
            };
            if !out[j].iter().all(|&d| d <= self.tol) {
                return None;
            }
        }
        Some(out)
    }

    /// Measures every live triangle not measured yet.
    fn measure_unknown(&mut self) {
        self.dev.resize(self.m.tris.len(), UNKNOWN);
        let todo: Vec<u32> = (0..self.m.tris.len() as u32)
            .filter(|&i| self.m.tri_alive[i as usize] && self.dev[i as usize][0].is_nan())
            .collect();
        for chunk in todo.chunks(4096) {
            let q: Vec<[DVec3; 3]> = chunk.iter().map(|&i| self.corners(i)).collect();
            for (&i, b) in chunk.iter().zip(self.measure(&q)) {
                self.dev[i as usize] = b;
            }
        }
    }

    /// Whether a triangle with normal `n` on the vertices `tri` follows
    /// the surface: its normal within `ALIGN` of ∇f at every corner. An
    /// unmeasured change (the size-driven iterations) makes no triangle
    /// that does not, as one across a ridge sharper than itself would.
    fn aligned(&self, n: DVec3, tri: [u32; 3]) -> bool {
        let n = n.normalize_or_zero();
        tri.iter().all(|&v| n.dot(self.unit_grad(v)) >= ALIGN)
    }

    fn corners(&self, i: u32) -> [DVec3; 3] {
        self.m.tris[i as usize].map(|v| self.pos(v))
    }

    fn outside(&self, i: u32) -> bool {
        !at_most(worst(&self.dev[i as usize]), self.tol)
    }

    /// Split rounds until every triangle is within the tolerance or no
    /// split is possible; returns the vertices made.
    fn refine(&mut self) -> Vec<u32> {
        let mut made = Vec::new();
        for _ in 0..MAX_ROUNDS {
            if self.m.tris.len() > self.budget {
                return made;
            }
            self.measure_unknown();
            let mut edges: Vec<(f64, EdgeKey)> = Vec::new();
            for i in 0..self.m.tris.len() as u32 {
                if !self.m.tri_alive[i as usize] || !self.outside(i) {
                    continue;
                }
                // A flip that brings it within the tolerance adds nothing.
                let tri = self.m.tris[i as usize];
                if (0..3).any(|k| self.flip_if(tri[k], tri[(k + 1) % 3], true)) {
                    continue;
                }
                let tri = self.m.tris[i as usize];
                let d = self.dev[i as usize];
                let sides = [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])];
                let mut any = false;
                for (k, &(u, v)) in sides.iter().enumerate() {
                    if !at_most(d[k + 1], self.tol) {
                        edges.push((self.pos(u).distance(self.pos(v)), key(u, v)));
                        any = true;
                    }
                }
                if !any {
                    // The longest side, preferring one whose other
                    // triangle is outside the tolerance too (one split
                    // then serves both).
                    let score = |&(u, v): &(u32, u32)| {
                        let shared = self
                            .m
                            .edge_pair(u, v)
                            .is_some_and(|p| p.iter().all(|&(j, _)| j == i || self.outside(j)));
                        (shared, self.pos(u).distance_squared(self.pos(v)))
                    };
                    let (u, v) = sides
                        .into_iter()
                        .max_by(|x, y| {
                            let (sx, sy) = (score(x), score(y));
                            sx.0.cmp(&sy.0).then(sx.1.total_cmp(&sy.1))
                        })
                        .expect("three sides");
                    edges.push((self.pos(u).distance(self.pos(v)), key(u, v)));
                }
            }
            edges.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
            edges.dedup_by_key(|e| e.1);
            if edges.is_empty() {
                return made;
            }
            self.counts.rounds += 1;
            let mut touched = Vec::new();
            let before = self.counts.splits;
            for (_, (u, v)) in edges {
                if let Some(m) = self.split(u, v) {
                    touched.push(m);
                }
            }
            if self.counts.splits == before {
                return made;
            }
            self.measure_unknown();
            self.flip_around(Some(&touched));
            made.extend(touched);
        }
        made
    }

    /// Splits edge `u–v` at its projected midpoint (see the module doc);
    /// returns the new vertex.
    fn split(&mut self, u: u32, v: u32) -> Option<u32> {
        let (pu, pv) = (self.pos(u), self.pos(v));
        let len = pu.distance(pv);
        let mid = (pu + pv) * 0.5;
        let refuse = |s: &mut Self| {
            s.counts.refused += 1;
            None
        };
        if !at_most(self.min_edge, len) {
            return refuse(self);
        }
        let tris = self.m.edge_tris(u, v);
        if tris.len() > 2 {
            return refuse(self);
        }
        // The midpoint moved onto the surface along the gradient line, or,
        // where that folds a new triangle over (the edge crosses a ridge
        // sharper than itself), along the line of the edge's triangles'
        // normals, which keeps every new triangle on its old one's side.
        if tris.len() == 1 {
            // A boundary edge (the surface cut by the domain): its new
            // vertex stays on the face of Ω its ends share (not any plane
            // they happen to share: on cap_x, two ends at z = 0 took a
            // vertex 1.5 cells out of Ω), moved onto the surface along the
            // gradient's component in that face.
            let shared = self.domain.faces(pu.to_array()) & self.domain.faces(pv.to_array());
            if shared == 0 {
                return refuse(self);
            }
            let k = shared.trailing_zeros() as usize / 2;
            let (_, g) = self.f.point_grad(at(mid, self.t));
            let mut dir = DVec3::from_array(g);
            dir[k] = 0.0;
            let Some((q, g)) = line_zero(self.f, self.t, mid, dir, 0.5 * len)
                .and_then(|q| self.split_fits(&tris, q))
            else {
                return refuse(self);
            };
            return Some(self.do_split(u, v, q, g));
        }
        let along_normals = tris
            .iter()
            .map(|&(i, _)| self.m.normal(i).normalize_or_zero())
            .sum::<DVec3>();
        let Some((q, g)) = project_along(self.f, self.t, mid, 0.5 * len)
            .and_then(|(q, _)| self.split_fits(&tris, q))
            .or_else(|| {
                let q = line_zero(self.f, self.t, mid, along_normals, 0.5 * len)?;
                self.split_fits(&tris, q)
            })
        else {
            return refuse(self);
        };
        Some(self.do_split(u, v, q, g))
    }

    /// Splits `u–v` at `q` (gradient `g`), checked; returns the new vertex.
    /// A vertex on a boundary edge is kept like the edge's ends.
    fn do_split(&mut self, u: u32, v: u32, q: DVec3, g: DVec3) -> u32 {
        let boundary = self.m.edge_pair(u, v).is_none();
        let m = self.m.split(u, v, q, g);
        self.ambiguous
            .push(self.ambiguous[u as usize] || self.ambiguous[v as usize]);
        self.keep.push(boundary);
        self.dev.resize(self.m.tris.len(), UNKNOWN);
        for &i in &self.m.star[m as usize] {
            self.dev[i as usize] = UNKNOWN;
        }
        self.counts.splits += 1;
        m
    }

    /// Whether the new vertex `q` of a split of the edge whose triangles
    /// are `tris` (as [`DynMesh::edge_tris`] gives them) is acceptable (see
    /// the module doc); its gradient if so.
    fn split_fits(&self, tris: &[(u32, [u32; 3])], q: DVec3) -> Option<(DVec3, DVec3)> {
        if !self.domain.contains(q.to_array()) {
            return None;
        }
        let (_, g) = self.f.point_grad(at(q, self.t));
        let g = DVec3::from_array(g);
        let gu = g.normalize_or_zero();
        let [x, y, _] = tris.first()?.1;
        if !g.is_finite()
            || gu == DVec3::ZERO
            || gu.dot(self.unit_grad(x) + self.unit_grad(y)) <= 0.0
        {
            return None;
        }
        for &(i, [x, y, c]) in tris {
            let old = self.m.normal(i);
            let (px, py, pc) = (self.pos(x), self.pos(y), self.pos(c));
            let gc = self.unit_grad(c);
            let (gx, gy) = (self.unit_grad(x), self.unit_grad(y));
            for (n, g3) in [
                ((q - px).cross(pc - px), [gx, gu, gc]),
                ((py - q).cross(pc - q), [gu, gy, gc]),
            ] {
                // Facing along ∇f on average, and either keeping the old
                // triangle's side or facing along ∇f at each corner (where
                // the surface turns faster than the edge, as near a cusp).
                let each = g3.iter().all(|g| n.dot(*g) > 0.0);
                if n.dot(g3[0] + g3[1] + g3[2]) <= 0.0 || (n.dot(old) <= 0.0 && !each) {
                    return None;
                }
            }
        }
        Some((q, g))
    }

    /// Flips that improve shape among the edges of the triangles around
    /// `verts` (every triangle when `None`). Only triangles below
    /// `FLIP_BELOW` are looked at: a flip must raise the worse aspect
    /// ratio of its pair by 5 %, which a pair of triangles both above it
    /// rarely allows.
    fn flip_around(&mut self, verts: Option<&[u32]>) {
        let tris: Vec<u32> = match verts {
            None => (0..self.m.tris.len() as u32)
                .filter(|&i| self.m.tri_alive[i as usize])
                .collect(),
            Some(verts) => {
                let mut t: Vec<u32> = verts
                    .iter()
                    .flat_map(|&v| self.m.star[v as usize].iter().copied())
                    .collect();
                t.sort_unstable();
                t.dedup();
                t
            }
        };
        let mut edges: Vec<EdgeKey> = tris
            .into_iter()
            .filter(|&i| {
                let q = self.corners(i);
                aspect(q[0], q[1], q[2]) < FLIP_BELOW
            })
            .flat_map(|i| {
                let [a, b, c] = self.m.tris[i as usize];
                [key(a, b), key(b, c), key(c, a)]
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        for (a, b) in edges {
            self.try_flip(a, b);
        }
    }

    fn try_flip(&mut self, a: u32, b: u32) -> bool {
        self.flip_if(a, b, false)
    }

    /// Flips `a–b` if the flip improves shape (see the module doc) or, with
    /// `repair`, if it brings a triangle outside the tolerance within it
    /// (both new triangles measured within it, the worse aspect ratio kept
    /// above half the old one's).
    fn flip_if(&mut self, a: u32, b: u32, repair: bool) -> bool {
        if self.keep[a as usize] && self.keep[b as usize] {
            return false;
        }
        let Some((c, d, t1, t2)) = self.m.flip_quad(a, b) else {
            return false;
        };
        let [pa, pb, pc, pd] = [a, b, c, d].map(|v| self.pos(v));
        let old = aspect(pa, pb, pc).min(aspect(pb, pa, pd));
        let new = aspect(pa, pd, pc).min(aspect(pb, pc, pd));
        if (!repair && new <= old * 1.05) || (repair && new < 0.8 * old) {
            return false;
        }
        let n3 = (pd - pa).cross(pc - pa);
        let n4 = (pc - pb).cross(pd - pb);
        let g = |v: u32| self.unit_grad(v);
        if n3.dot(g(a) + g(d) + g(c)) <= 0.0 || n4.dot(g(b) + g(c) + g(d)) <= 0.0 {
            return false;
        }
        let (u3, u4) = (n3.normalize_or_zero(), n4.normalize_or_zero());
        let n1 = self.m.normal(t1).normalize_or_zero();
        let n2 = self.m.normal(t2).normalize_or_zero();
        if u3.dot(u4) < n1.dot(n2).min(FLIP_FOLD_COS) {
            return false;
        }
        let b4 = if self.checked || repair {
            let Some(b4) = self.within(&[[pa, pd, pc], [pb, pc, pd]]) else {
                return false;
            };
            [b4[0], b4[1]]
        } else {
            // Unmeasured, the flip may still not move the surface by more
            // than the tolerance: the distance between the two diagonals'
            // lines (0 for a flat quad, the fold's height for a bent one).
            let (u, w) = (pb - pa, pd - pc);
            let n = u.cross(w);
            if !at_most((pc - pa).dot(n).abs(), self.tol * n.length())
                || !self.aligned(n3, [a, d, c])
                || !self.aligned(n4, [b, c, d])
            {
                return false;
            }
            [UNKNOWN; 2]
        };
        if self.m.flip(a, b).is_none() {
            return false;
        }
        // `flip` rewrites t1 as [a, d, c] and t2 as [b, c, d].
        self.dev[t1 as usize] = b4[0];
        self.dev[t2 as usize] = b4[1];
        self.counts.flips += 1;
        true
    }

    /// Removes `r` into `k`, unmeasured (the size-driven iterations), if
    /// every condition of the module doc holds.
    fn try_collapse(&mut self, r: u32, k: u32) -> bool {
        if self.keep[r as usize] || !self.m.adjacent(r, k) {
            return false;
        }
        let pk = self.pos(k);
        let gk = self.unit_grad(k);
        let mut moved: Vec<(u32, [DVec3; 3])> = Vec::new();
        let mut old_aspect = 1.0f64;
        for &i in &self.m.star[r as usize] {
            let tri = self.m.tris[i as usize];
            let q = self.corners(i);
            old_aspect = old_aspect.min(aspect(q[0], q[1], q[2]));
            if tri.contains(&k) {
                continue;
            }
            let nq = tri.map(|v| if v == r { pk } else { self.pos(v) });
            moved.push((i, nq));
        }
        let floor = MIN_ASPECT.min(old_aspect);
        for &(i, nq) in &moved {
            let tri = self.m.tris[i as usize];
            let n = (nq[1] - nq[0]).cross(nq[2] - nq[0]);
            let gs: DVec3 = tri
                .iter()
                .map(|&v| if v == r { gk } else { self.unit_grad(v) })
                .sum();
            if n.dot(gs) <= 0.0 || n.dot(self.m.normal(i)) <= 0.0 {
                return false;
            }
            if aspect(nq[0], nq[1], nq[2]) < floor {
                return false;
            }
            if !self.aligned(n, tri.map(|v| if v == r { k } else { v })) {
                return false;
            }
        }
        // The dropped vertex stays within the tolerance of the new fan.
        let pr = self.pos(r);
        let near = moved
            .iter()
            .map(|(_, q)| point_triangle_distance(pr, *q))
            .fold(f64::INFINITY, f64::min);
        if !at_most(near, self.tol) || !self.m.can_collapse_topologically(k, r) {
            return false;
        }
        self.m.collapse(k, r, pk, self.m.grad[k as usize]);
        self.ambiguous[k as usize] |= self.ambiguous[r as usize];
        for (i, _) in &moved {
            self.dev[*i as usize] = UNKNOWN;
        }
        self.counts.collapses += 1;
        true
    }

    /// The share of live triangles deviating by more than twice the
    /// tolerance (measuring those not measured yet).
    fn far_share(&mut self) -> f64 {
        self.measure_unknown();
        let (mut live, mut far) = (0usize, 0usize);
        for i in 0..self.m.tris.len() {
            if self.m.tri_alive[i] {
                live += 1;
                far += usize::from(!at_most(worst(&self.dev[i]), 2.0 * self.tol));
            }
        }
        far as f64 / live.max(1) as f64
    }

    /// Per live vertex, the edge length its triangles should have: each
    /// triangle's longest edge scaled by `√(SIZE_SAFETY·tol / deviation)`
    /// (a chord error grows with the square of the size), within half and
    /// twice the current size, the least over the vertex's star, then
    /// limited so that it grows by at most [`GRADE`] per unit of distance
    /// along edges.
    fn sizing(&mut self) -> Vec<f64> {
        self.measure_unknown();
        let mut size = vec![0.0f64; self.m.pos.len()];
        let mut count = vec![0u32; self.m.pos.len()];
        for i in 0..self.m.tris.len() {
            if !self.m.tri_alive[i] {
                continue;
            }
            let l = longest(self.corners(i as u32));
            let d = worst(&self.dev[i]);
            let target = if !d.is_finite() {
                0.5 * l
            } else if d <= 0.0 {
                2.0 * l
            } else {
                (l * (SIZE_SAFETY * self.tol / d).sqrt()).clamp(0.25 * l, 2.0 * l)
            };
            for v in self.m.tris[i] {
                size[v as usize] += target.ln();
                count[v as usize] += 1;
            }
        }
        for (s, &c) in size.iter_mut().zip(&count) {
            *s = if c > 0 {
                (*s / c as f64).exp()
            } else {
                f64::INFINITY
            };
        }
        let edges = self.edges();
        // One smoothing pass of the size field (log scale, the vertex and
        // its neighbours' mean weighted alike): sizes that vary from vertex
        // to vertex make irregular triangles.
        {
            let mut sum = vec![0.0f64; size.len()];
            let mut n = vec![0u32; size.len()];
            for &(a, b) in &edges {
                let (sa, sb) = (size[a as usize], size[b as usize]);
                if sa.is_finite() && sb.is_finite() {
                    sum[a as usize] += sb.ln();
                    sum[b as usize] += sa.ln();
                    n[a as usize] += 1;
                    n[b as usize] += 1;
                }
            }
            for ((s, &t), &k) in size.iter_mut().zip(&sum).zip(&n) {
                if k > 0 && s.is_finite() {
                    *s = (0.5 * (s.ln() + t / f64::from(k))).exp();
                }
            }
        }
        for _ in 0..2 {
            for &(a, b) in &edges {
                let len = self.m.length((a, b));
                let (sa, sb) = (size[a as usize], size[b as usize]);
                size[a as usize] = sa.min(sb + GRADE * len);
                size[b as usize] = sb.min(sa + GRADE * len);
            }
        }
        size
    }

    /// Splits every edge longer than `4/3` of its ends' smaller size,
    /// longest (relative to its size) first; the new vertex takes that size.
    /// Returns the sizes with the new vertices'.
    fn split_long(&mut self, mut size: Vec<f64>) -> Vec<f64> {
        let mut long: Vec<(f64, EdgeKey)> = self
            .edges()
            .into_iter()
            .filter(|&(a, b)| !(self.keep[a as usize] && self.keep[b as usize]))
            .map(|e| {
                let s = size[e.0 as usize].min(size[e.1 as usize]);
                (self.m.length(e) / s, e)
            })
            .filter(|&(r, _)| r > 4.0 / 3.0)
            .collect();
        long.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        for (_, (a, b)) in long {
            let s = size[a as usize].min(size[b as usize]);
            if self.split(a, b).is_some() {
                size.push(s);
            }
        }
        size
    }

    /// Collapses every edge shorter than `4/5` of its ends' smaller size,
    /// shortest first, where the link condition holds, no triangle turns
    /// over or becomes a sliver, and no new edge is longer than `4/3` of
    /// its ends' sizes.
    fn collapse_short(&mut self, mut size: Vec<f64>) {
        size.resize(self.m.pos.len(), f64::INFINITY);
        let mut short: Vec<(f64, EdgeKey)> = self
            .edges()
            .into_iter()
            .map(|e| {
                let s = size[e.0 as usize].min(size[e.1 as usize]);
                (self.m.length(e) / s, e)
            })
            .filter(|&(r, _)| r < 0.8)
            .collect();
        short.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        for (_, (a, b)) in short {
            if !self.m.vert_alive[a as usize] || !self.m.vert_alive[b as usize] {
                continue;
            }
            let (r, k) = if self.m.star[a as usize].len() <= self.m.star[b as usize].len() {
                (a, b)
            } else {
                (b, a)
            };
            for (r, k) in [(r, k), (k, r)] {
                let pk = self.pos(k);
                let sk = size[k as usize].min(size[r as usize]);
                let fits = self.m.star[r as usize].iter().all(|&i| {
                    self.m.tris[i as usize].iter().all(|&w| {
                        w == k
                            || w == r
                            || pk.distance(self.pos(w)) <= 4.0 / 3.0 * sk.min(size[w as usize])
                    })
                });
                if fits && self.try_collapse(r, k) {
                    size[k as usize] = sk;
                    break;
                }
            }
        }
    }

    /// The live vertices among `verts` and their neighbours, sorted.
    fn around(&self, verts: &[u32]) -> Vec<u32> {
        let mut out: Vec<u32> = verts
            .iter()
            .filter(|&&v| self.m.vert_alive[v as usize])
            .flat_map(|&v| self.m.star[v as usize].iter())
            .flat_map(|&i| self.m.tris[i as usize])
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// One pass of tangential relaxation: every vertex not kept whose
    /// star holds a triangle of aspect ratio below `SETTLED` moves to
    /// its relaxation target (`relaxation_target`)
    /// projected onto the surface, if its star's worst aspect ratio
    /// improves, no triangle turns over and every triangle of the star
    /// stays within the tolerance. Returns the moves made.
    fn relax(&mut self, only: Option<&[u32]>) -> usize {
        let mut moves = 0;
        let all: Vec<u32>;
        let verts = match only {
            Some(v) => v,
            None => {
                all = (0..self.m.pos.len() as u32).collect();
                &all
            }
        };
        for &v in verts {
            if !self.m.vert_alive[v as usize] || self.keep[v as usize] {
                continue;
            }
            let star: Small<u32> = self.m.star[v as usize].iter().copied().collect();
            let p = self.pos(v);
            let Some(opposite) = star
                .iter()
                .map(|&i| {
                    let tri = self.m.tris[i as usize];
                    let s = tri.iter().position(|&w| w == v)?;
                    Some((self.pos(tri[(s + 1) % 3]), self.pos(tri[(s + 2) % 3])))
                })
                .collect::<Option<Small<_>>>()
            else {
                continue;
            };
            let worst_at = |q: DVec3| {
                opposite
                    .iter()
                    .fold(f64::INFINITY, |w, &(b, c)| w.min(aspect(q, b, c)))
            };
            let old = worst_at(p);
            if opposite.is_empty() || old >= SETTLED {
                continue;
            }
            let (q, reach) = super::smooth::relaxation_target(p, self.unit_grad(v), &opposite);
            if !exceeds(worst_at(q), old) {
                continue;
            }
            let Some((q, _)) = project_along(self.f, self.t, q, 0.5 * reach)
                .filter(|(q, _)| self.domain.contains(q.to_array()))
            else {
                continue;
            };
            if !exceeds(worst_at(q), old) {
                continue;
            }
            let (_, g) = self.f.point_grad(at(q, self.t));
            let g = DVec3::from_array(g);
            let gu = g.normalize_or_zero();
            if !g.is_finite() || gu == DVec3::ZERO || gu.dot(self.unit_grad(v)) <= 0.0 {
                continue;
            }
            let tris: Small<[DVec3; 3]> = opposite.iter().map(|&(b, c)| [q, b, c]).collect();
            let turns = star.iter().zip(&tris).any(|(&i, nq)| {
                let tri = self.m.tris[i as usize];
                let s = tri.iter().position(|&w| w == v).unwrap_or(0);
                let (b, c) = (tri[(s + 1) % 3], tri[(s + 2) % 3]);
                let n = (nq[1] - nq[0]).cross(nq[2] - nq[0]);
                n.dot(gu + self.unit_grad(b) + self.unit_grad(c)) <= 0.0
                    || n.dot(self.m.normal(i)) <= 0.0
            });
            if turns {
                continue;
            }
            let b4 = if self.checked {
                let Some(b4) = self.within_star(v, &star, q) else {
                    continue;
                };
                b4
            } else {
                vec![UNKNOWN; tris.len()]
            };
            self.m.pos[v as usize] = q;
            self.m.grad[v as usize] = g;
            for (&i, b) in star.iter().zip(b4) {
                // The star's triangles, each rotated to start at `v`: the
                // bounds were measured in that order.
                let tri = self.m.tris[i as usize];
                let s = tri.iter().position(|&w| w == v).unwrap_or(0);
                self.dev[i as usize] = rotate_bounds(b, s);
            }
            moves += 1;
        }
        moves
    }

    fn finish(mut self, mesh: &mut Mesh) -> Adapted {
        let remap = self.m.compact();
        let mut ambiguous = vec![false; self.m.pos.len()];
        for (old, &new) in remap.iter().enumerate() {
            if new != u32::MAX {
                ambiguous[new as usize] = self.ambiguous[old];
            }
        }
        *mesh = Mesh {
            normals: self.m.grad.iter().map(|g| g.normalize_or_zero()).collect(),
            ambiguous,
            positions: std::mem::take(&mut self.m.pos),
            triangles: std::mem::take(&mut self.m.tris),
        };
        self.counts
    }
}

/// Bounds measured on a triangle read from corner `s` (`[t[s], t[s+1],
/// t[s+2]]`), reordered to the triangle's own corner order.
fn rotate_bounds(b: Bounds4, s: usize) -> Bounds4 {
    // Sample 0 is the centroid; sample 1 + k is the edge from corner k of
    // the rotated triangle, which is corner (s + k) % 3 of the triangle.
    let mut out = [b[0], 0.0, 0.0, 0.0];
    for k in 0..3 {
        out[1 + (s + k) % 3] = b[1 + k];
    }
    out
}

/// How far the samples of `tris` are searched for the surface: twice the
/// longest edge (the corners lie on the surface).
fn reach(tris: &[[DVec3; 3]]) -> f64 {
    tris.iter()
        .map(|q| longest(*q))
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE)
        * 2.0
}

fn longest([a, b, c]: [DVec3; 3]) -> f64 {
    a.distance(b).max(b.distance(c)).max(c.distance(a))
}

/// Euclidean distance from `p` to the triangle `[a, b, c]` (Ericson,
/// *Real-Time Collision Detection* §5.1.5: the closest point by Voronoi
/// regions of the vertices, edges and face).
pub fn point_triangle_distance(p: DVec3, [a, b, c]: [DVec3; 3]) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return p.distance(a + ab * v);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return p.distance(a + ac * w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return p.distance(b + (c - b) * w);
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    p.distance(a + ab * v + ac * w)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closest-point distance against dense sampling of the triangle.
    #[test]
    fn point_triangle_distance_matches_sampling() {
        let tri = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.2, 0.0),
            DVec3::new(0.3, 0.9, 0.4),
        ];
        let mut rng = crate::testing::Rng::new(12345);
        let mut rnd = || rng.unit() * 3.0 - 1.0;
        for _ in 0..200 {
            let p = DVec3::new(rnd(), rnd(), rnd());
            let d = point_triangle_distance(p, tri);
            let n = 200;
            let mut best = f64::INFINITY;
            for i in 0..=n {
                for j in 0..=(n - i) {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let q = tri[0] + (tri[1] - tri[0]) * u + (tri[2] - tri[0]) * v;
                    best = best.min(p.distance(q));
                }
            }
            assert!(d <= best + 1e-12, "{d} > sampled {best}");
            assert!(best - d < 1e-2, "{d} far below sampled {best}");
        }
    }
}
