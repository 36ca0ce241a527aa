//! Keeping the mechanical mesh uniform (Bouthors & Nesme §2.5, §2.6.1):
//! edge splits, edge collapses and — beyond the paper — edge flips.
//!
//! # Rules
//!
//! With ê the target edge length and `Δ = ‖e‖ₜ − ‖e‖ₜ₋₁` the change of an
//! edge's length since the last frame:
//!
//! - **split** when `‖e‖ > e_max·ê` and the edge is not shrinking
//!   (`Δ > −ε_e·ê`), unless one of its triangles is inverted (§2.6.1,
//!   case 4). The new vertex is the midpoint projected onto the surface by
//!   [`crate::roots::walk::newton`]; if that fails the edge is left alone.
//! - **collapse** when `‖e‖ < e_min·ê` and the edge is not growing
//!   (`Δ < ε_e·ê`): both ends merge at the projected midpoint, only if the
//!   link condition holds (no non-manifold result, Fig. 3), no surviving
//!   triangle turns over (faces against ∇f or against its old normal,
//!   §2.6.1 case 2), and no new edge is longer than `e_max·ê` (which would
//!   only call for a split next frame).
//! - **flip** (not in the paper; the paper's quality goal of near-
//!   equilateral triangles needs it where vertex valences are uneven, as
//!   marching cubes leaves them): an edge whose two opposite angles sum to
//!   more than π is replaced by the other diagonal of its quad (the
//!   Delaunay criterion), if both new triangles face along ∇f and the new
//!   fold is gentle.
//!
//! The paper reads the split and collapse tests as "still stretching" /
//! "still shrinking" (Fig. 2's caption: *has not been compressed / has not
//! stretched since the last time step*); the tolerance ε_e keeps edges at
//! rest eligible. Every edge an operation creates or changes is *frozen*:
//! it is neither split nor collapsed during the next frame's remeshing
//! (§2.5); flips may still act on it (Delaunay flips cannot oscillate:
//! each one strictly improves the quad), so that the triangles a split
//! leaves behind are repaired at once. No vertex is touched twice in one
//! sweep.
//!
//! Evaluation: each projection is one sequential Newton walk
//! ([`newton`]) and each operation changes the mesh the next one sees, so
//! the function is evaluated one point at a time here.

use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use glam::DVec3;

use crate::cancel::{Cancel, Cancelled};
use crate::eval::Evaluator;
use crate::mesh::dynmesh::{DynMesh, EdgeKey, key};
use crate::roots::walk::newton;

/// Thresholds of [`remesh`].
#[derive(Clone, Copy, Debug)]
pub struct Params {
    /// ê.
    pub edge: f64,
    /// e_min: edges shorter than `e_min·ê` are collapsed.
    pub e_min: f64,
    /// e_max: edges longer than `e_max·ê` are split.
    pub e_max: f64,
    /// ε_e: tolerance on an edge's length change since the last frame, in
    /// units of ê.
    pub eps_e: f64,
    /// Whether edge flips run (beyond the paper).
    pub flips: bool,
    /// Sweeps over the edges per call.
    pub sweeps: usize,
}

/// What [`remesh`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Edges split.
    pub splits: usize,
    /// Edges collapsed.
    pub collapses: usize,
    /// Edges flipped.
    pub flips: usize,
}

/// Why an edge outside `[e_min, e_max]·ê` was left as it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Held {
    /// Modified by the last frame or this one (§2.5).
    Frozen,
    /// Too long but shrinking, or too short but growing (§2.5).
    Trend,
    /// A split next to an inverted triangle (§2.6.1, case 4).
    Inverted,
    /// A collapse that would break the link condition (Fig. 3).
    Topology,
    /// A collapse that would turn a triangle over, leave a sliver, or make
    /// an edge longer than `e_max·ê`.
    Shape,
    /// The new point could not be projected onto the surface.
    Projection,
    /// A neighbour was modified in every sweep.
    Busy,
}

/// What remeshing remembers about edges between frames.
#[derive(Clone, Debug, Default)]
pub struct EdgeState {
    /// Edge lengths at the end of the last frame (for Δ).
    pub prev_len: HashMap<EdgeKey, f64>,
    /// Edges the last frame modified: not split or collapsed now.
    pub frozen: HashSet<EdgeKey>,
    /// Edges modified now (frozen for the next frame).
    pub new_frozen: HashSet<EdgeKey>,
    /// For edges still outside the band that an operation was refused,
    /// why (the last refusal).
    pub held: HashMap<EdgeKey, Held>,
}

/// Edges between two polls of the cancel token.
const POLL_EDGES: usize = 4096;

/// One remeshing pass; see the module doc. `inverted[i]` flags triangle
/// `i` (triangles created here are not). Stops with [`Cancelled`] when
/// `cancel` is cancelled (polled every few thousand edges); the mesh is
/// then valid (every operation done is whole) but partly remeshed.
pub fn remesh<E: Evaluator + ?Sized>(
    mesh: &mut DynMesh,
    f: &E,
    t: f64,
    p: &Params,
    edges: &mut EdgeState,
    inverted: &mut Vec<bool>,
    cancel: &Cancel,
) -> Result<Counts, Cancelled> {
    let EdgeState {
        prev_len,
        frozen,
        new_frozen,
        held,
    } = edges;
    let mut counts = Counts::default();
    held.clear();
    for _ in 0..p.sweeps {
        let before = counts;
        let mut dirty = vec![false; mesh.pos.len()];
        let is_frozen = |e: &EdgeKey, nf: &HashSet<EdgeKey>| frozen.contains(e) || nf.contains(e);
        let delta = |mesh: &DynMesh, e: EdgeKey| {
            let len = mesh.length(e);
            len - prev_len.get(&e).copied().unwrap_or(len)
        };
        let mut lens: Vec<(EdgeKey, f64)> = mesh
            .edges()
            .into_iter()
            .map(|e| (e, mesh.length(e)))
            .collect();

        // Splits, longest first.
        lens.sort_by(|a, b| b.1.total_cmp(&a.1));
        for (i, &(e, len)) in lens.iter().enumerate() {
            if len <= p.e_max * p.edge {
                break;
            }
            if i % POLL_EDGES == 0 {
                cancel.check()?;
            }
            let (a, b) = e;
            if dirty[a as usize] || dirty[b as usize] {
                held.insert(e, Held::Busy);
                continue;
            }
            if is_frozen(&e, new_frozen) {
                held.insert(e, Held::Frozen);
                continue;
            }
            if delta(mesh, e) <= -p.eps_e * p.edge {
                held.insert(e, Held::Trend);
                continue;
            }
            let tris = mesh.edge_tris(a, b);
            if tris.len() != 2 || tris.iter().any(|(i, _)| inverted[*i as usize]) {
                held.insert(e, Held::Inverted);
                continue;
            }
            let mid = (mesh.pos[a as usize] + mesh.pos[b as usize]) * 0.5;
            let Some(s) = newton(f, t, mid, 0.5 * len, 0.25 * len) else {
                held.insert(e, Held::Projection);
                continue;
            };
            held.remove(&e);
            let m = mesh.split(a, b, s.pos, s.grad);
            inverted.resize(mesh.tris.len(), false);
            dirty.resize(mesh.pos.len(), false);
            for w in mesh.neighbours(m) {
                dirty[w as usize] = true;
                new_frozen.insert(key(m, w));
            }
            dirty[m as usize] = true;
            counts.splits += 1;
        }

        // Collapses, shortest first.
        lens.reverse();
        for (i, &(e, len)) in lens.iter().enumerate() {
            if len >= p.e_min * p.edge {
                break;
            }
            if i % POLL_EDGES == 0 {
                cancel.check()?;
            }
            let (a, b) = e;
            if dirty[a as usize]
                || dirty[b as usize]
                || !mesh.vert_alive[a as usize]
                || !mesh.vert_alive[b as usize]
            {
                held.insert(e, Held::Busy);
                continue;
            }
            if is_frozen(&e, new_frozen) {
                held.insert(e, Held::Frozen);
                continue;
            }
            if delta(mesh, e) >= p.eps_e * p.edge {
                held.insert(e, Held::Trend);
                continue;
            }
            if !mesh.can_collapse_topologically(a, b) {
                held.insert(e, Held::Topology);
                continue;
            }
            let mid = (mesh.pos[a as usize] + mesh.pos[b as usize]) * 0.5;
            let Some(s) = newton(f, t, mid, p.edge, 0.25 * p.edge) else {
                held.insert(e, Held::Projection);
                continue;
            };
            if !collapse_keeps_shape(mesh, a, b, s.pos, s.grad, p.e_max * p.edge) {
                held.insert(e, Held::Shape);
                continue;
            }
            held.remove(&e);
            let around: Vec<u32> = mesh
                .neighbours(a)
                .into_iter()
                .chain(mesh.neighbours(b))
                .collect();
            mesh.collapse(a, b, s.pos, s.grad);
            for w in around {
                dirty[w as usize] = true;
                if w != a && w != b {
                    new_frozen.insert(key(a, w));
                }
            }
            dirty[a as usize] = true;
            dirty[b as usize] = true;
            counts.collapses += 1;
        }

        // Flips.
        if p.flips {
            for (i, e) in mesh.edges().into_iter().enumerate() {
                if i % POLL_EDGES == 0 {
                    cancel.check()?;
                }
                let (a, b) = e;
                if dirty[a as usize] || dirty[b as usize] {
                    continue;
                }
                let Some((c, d, t1, t2)) = mesh.flip_quad(a, b) else {
                    continue;
                };
                if inverted[t1 as usize]
                    || inverted[t2 as usize]
                    || dirty[c as usize]
                    || dirty[d as usize]
                    || !flip_improves(mesh, a, b, c, d)
                {
                    continue;
                }
                if let Some(ne) = mesh.flip(a, b) {
                    for v in [a, b, c, d] {
                        dirty[v as usize] = true;
                    }
                    new_frozen.insert(ne);
                    counts.flips += 1;
                }
            }
        }
        if counts == before {
            break;
        }
    }
    Ok(counts)
}

/// The geometric conditions of a collapse of `a–b` to `p` (see the module
/// doc).
fn collapse_keeps_shape(mesh: &DynMesh, a: u32, b: u32, p: DVec3, g: DVec3, max_len: f64) -> bool {
    for v in [a, b] {
        for &ti in &mesh.star[v as usize] {
            let t = mesh.tris[ti as usize];
            if t.contains(&a) && t.contains(&b) {
                continue;
            }
            let old = mesh.normal(ti);
            let q = t.map(|w| {
                if w == a || w == b {
                    p
                } else {
                    mesh.pos[w as usize]
                }
            });
            let new = (q[1] - q[0]).cross(q[2] - q[0]);
            let gs: DVec3 = t
                .iter()
                .map(|&w| {
                    if w == a || w == b {
                        g
                    } else {
                        mesh.grad[w as usize]
                    }
                })
                .map(|x| x.normalize_or_zero())
                .sum();
            if new.dot(old) <= 0.0 || new.dot(gs) <= 0.0 {
                return false;
            }
            // Quality floor: no sliver.
            if aspect(q) < 0.2 {
                return false;
            }
        }
        for w in mesh.neighbours(v) {
            if w != a && w != b && mesh.pos[w as usize].distance(p) > max_len {
                return false;
            }
        }
    }
    true
}

/// 4√3·area / Σ‖edge‖² (1 for an equilateral triangle).
pub fn aspect(q: [DVec3; 3]) -> f64 {
    let area2 = (q[1] - q[0]).cross(q[2] - q[0]).length();
    let s = q[0].distance_squared(q[1]) + q[1].distance_squared(q[2]) + q[2].distance_squared(q[0]);
    if s == 0.0 {
        0.0
    } else {
        2.0 * 3f64.sqrt() * area2 / s
    }
}

fn angle(at: DVec3, p: DVec3, q: DVec3) -> f64 {
    (p - at).angle_between(q - at)
}

/// The Delaunay test on the quad `[a, b, c]`, `[b, a, d]`, plus the
/// geometric checks of the module doc.
fn flip_improves(mesh: &DynMesh, a: u32, b: u32, c: u32, d: u32) -> bool {
    let [pa, pb, pc, pd] = [a, b, c, d].map(|v| mesh.pos[v as usize]);
    if angle(pc, pa, pb) + angle(pd, pa, pb) <= std::f64::consts::PI + 1e-9 {
        return false;
    }
    let n3 = (pd - pa).cross(pc - pa);
    let n4 = (pc - pb).cross(pd - pb);
    let gsum = |ts: [u32; 3]| -> DVec3 {
        ts.iter()
            .map(|&v| mesh.grad[v as usize].normalize_or_zero())
            .sum()
    };
    if n3.dot(gsum([a, d, c])) <= 0.0 || n4.dot(gsum([b, c, d])) <= 0.0 {
        return false;
    }
    let (u3, u4) = (n3.normalize_or_zero(), n4.normalize_or_zero());
    let n1 = (pb - pa).cross(pc - pa).normalize_or_zero();
    let n2 = (pa - pb).cross(pd - pb).normalize_or_zero();
    // The new fold is no sharper than the old one or than 30°.
    u3.dot(u4) >= n1.dot(n2).min(30f64.to_radians().cos())
}
