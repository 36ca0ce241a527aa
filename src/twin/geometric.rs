//! The geometric mesh (Bouthors & Nesme §3): a copy of the mechanical
//! mesh, refined where the surface bends by more than α_r.
//!
//! # Contract
//!
//! Each pass (at most `N_p`) marks an edge when the unit gradients at its
//! two end vertices make an angle above α_r, and, when the normals of two
//! neighbouring triangles (∇f at their centroids) do, the *other* edges of
//! both triangles (Fig. 7b). The test is `n₁·n₂ < cos α_r`, so α_r = −π
//! marks nothing: with α_r = −π or `N_p = 0` the result is an exact copy
//! of the mechanical mesh. Each marked edge gets its midpoint projected
//! onto the surface by [`crate::roots::walk::newton`] (an edge whose midpoint
//! cannot be projected within the edge's length stays unmarked). A
//! triangle with one, two or three marked edges becomes two, three or
//! four triangles (Fig. 7a); with two, the quad left beside the corner
//! triangle is cut along the diagonal whose ends have the closer normals,
//! i.e. along the direction of least curvature. Marks are per edge, so
//! both triangles of an edge share its midpoint: no T-vertices, and a
//! closed oriented mesh stays closed and oriented. A pass that could take
//! the mesh beyond [`TRIANGLE_BUDGET`] times the mechanical mesh's size is
//! not started (sharp creases mark edges on every pass).
//!
//! Evaluation: the centroid gradients of a pass are one batch
//! ([`crate::eval::sample::grads_at`]); the midpoint projections are
//! sequential Newton walks, run in parallel.

use rustc_hash::{FxHashMap as HashMap, FxHashSet};

use glam::DVec3;
use rayon::prelude::*;

use crate::eval::Evaluator;
use crate::eval::sample::grads_at;
use crate::mesh::Mesh;
use crate::mesh::dynmesh::{EdgeKey, key};
use crate::roots::walk::newton;

/// What [`refine`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RefineStats {
    /// Passes that split at least one edge.
    pub passes: usize,
    /// Edges split (midpoints inserted), over all passes.
    pub splits: usize,
    /// Refinement stopped at the triangle budget rather than for lack of
    /// marked edges or passes.
    pub budget_hit: bool,
}

/// The geometric mesh never exceeds this many times the mechanical mesh's
/// triangles.
pub(crate) const TRIANGLE_BUDGET: usize = 64;

/// Refines `mech` (whose normals are the unit gradients at its vertices)
/// on the surface `f(·, t) = 0`; see the module doc.
pub fn refine<E: Evaluator + ?Sized>(
    mech: &Mesh,
    f: &E,
    t: f64,
    alpha_deg: f64,
    passes: usize,
) -> (Mesh, RefineStats) {
    let mut mesh = mech.clone();
    let mut stats = RefineStats::default();
    let cos_a = alpha_deg.to_radians().cos();
    if alpha_deg <= -180.0 || passes == 0 {
        return (mesh, stats);
    }
    // ∇f/‖∇f‖ at each triangle's centroid; NaN until computed (a
    // triangle that a pass leaves whole keeps its normal).
    let mut tri_n = vec![DVec3::NAN; mesh.triangles.len()];
    let budget = mech.triangles.len().saturating_mul(TRIANGLE_BUDGET);
    for _ in 0..passes {
        let marked = mark(&mesh, f, t, cos_a, &mut tri_n);
        // A pass adds at most 3 triangles per marked edge; stop before the
        // budget could be exceeded (a crease marks edges on every pass).
        if marked.is_empty() || mesh.triangles.len() + 3 * marked.len() > budget {
            stats.budget_hit = !marked.is_empty();
            break;
        }
        // Project the midpoints (in parallel).
        let mids: Vec<(EdgeKey, Option<(DVec3, DVec3)>)> = marked
            .par_iter()
            .map(|&(a, b)| {
                let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
                let len = pa.distance(pb);
                let s = newton(f, t, (pa + pb) * 0.5, len, 0.5 * len);
                ((a, b), s.map(|s| (s.pos, s.grad)))
            })
            .collect();
        let first_new = mesh.positions.len();
        let mut mid_of: HashMap<EdgeKey, u32> =
            HashMap::with_capacity_and_hasher(mids.len(), Default::default());
        for (e, s) in mids {
            if let Some((p, g)) = s {
                mid_of.insert(e, mesh.positions.len() as u32);
                mesh.positions.push(p);
                mesh.normals.push(g.normalize_or_zero());
                mesh.ambiguous.push(false);
            }
        }
        // Subdivide; an edge whose split would leave an inverted triangle
        // (the midpoint projected past a neighbour on a tight bend) is
        // unmarked and the triangles around it are redone.
        let old = std::mem::take(&mut mesh.triangles);
        let mut tris = Vec::with_capacity(old.len() * 2);
        let mut normals = Vec::with_capacity(old.len() * 2);
        loop {
            tris.clear();
            normals.clear();
            let mut undo = Vec::new();
            for (&t, &n) in old.iter().zip(&tri_n) {
                let start = tris.len();
                subdivide(&mesh, t, &mid_of, &mut tris);
                let kept = tris.len() == start + 1 && tris[start] == t;
                normals.resize(tris.len(), if kept { n } else { DVec3::NAN });
                if tris.len() > start + 1 && tris[start..].iter().any(|&n| inverted(&mesh, n)) {
                    for k in 0..3 {
                        undo.push(key(t[k], t[(k + 1) % 3]));
                    }
                }
            }
            if undo.is_empty() {
                break;
            }
            for e in undo {
                mid_of.remove(&e);
            }
        }
        mesh.triangles = tris;
        tri_n = normals;
        // Midpoints no edge kept stay in the vertex list unused; drop them.
        let used: FxHashSet<u32> = mid_of.values().copied().collect();
        compact_new(&mut mesh, first_new, &used);
        if mid_of.is_empty() {
            break;
        }
        stats.splits += mid_of.len();
        stats.passes += 1;
    }
    (mesh, stats)
}

/// `true` when `t` faces against the normals at all three corners (the
/// inversion test of [`super::fem::inverted`]).
fn inverted(mesh: &Mesh, t: [u32; 3]) -> bool {
    let n = mesh.face_normal(t);
    t.iter().all(|&v| n.dot(mesh.normals[v as usize]) < 0.0)
}

/// Removes the vertices from `first` on that are not in `used`,
/// renumbering the later ones in the triangles.
fn compact_new(mesh: &mut Mesh, first: usize, used: &FxHashSet<u32>) {
    let mut remap: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    let mut w = first;
    for (r, slot) in remap.iter_mut().enumerate().skip(first) {
        if used.contains(&(r as u32)) {
            mesh.positions[w] = mesh.positions[r];
            mesh.normals[w] = mesh.normals[r];
            mesh.ambiguous[w] = mesh.ambiguous[r];
            *slot = w as u32;
            w += 1;
        }
    }
    mesh.positions.truncate(w);
    mesh.normals.truncate(w);
    mesh.ambiguous.truncate(w);
    for t in &mut mesh.triangles {
        for v in t.iter_mut() {
            *v = remap[*v as usize];
        }
    }
}

/// The edges to refine in this pass (sorted, each once).
fn mark<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    f: &E,
    t: f64,
    cos_a: f64,
    tri_normals: &mut [DVec3],
) -> Vec<EdgeKey> {
    let n = &mesh.normals;
    let todo: Vec<usize> = (0..tri_normals.len())
        .filter(|&i| tri_normals[i].is_nan())
        .collect();
    let centroids: Vec<DVec3> = todo
        .iter()
        .map(|&i| {
            let tri = mesh.triangles[i];
            tri.iter()
                .map(|&v| mesh.positions[v as usize])
                .sum::<DVec3>()
                / 3.0
        })
        .collect();
    for (&i, (_, g)) in todo.iter().zip(grads_at(f, t, &centroids)) {
        let g = g.normalize_or_zero();
        tri_normals[i] = if g.is_finite() && g != DVec3::ZERO {
            g
        } else {
            mesh.face_normal(mesh.triangles[i]).normalize_or_zero()
        };
    }
    let mut edge_tris: HashMap<EdgeKey, [u32; 2]> =
        HashMap::with_capacity_and_hasher(mesh.triangles.len() * 2, Default::default());
    for (i, t) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let e = key(t[k], t[(k + 1) % 3]);
            edge_tris
                .entry(e)
                .and_modify(|s| s[1] = i as u32)
                .or_insert([i as u32, u32::MAX]);
        }
    }
    let mut out = Vec::new();
    for (&(a, b), &[t1, t2]) in &edge_tris {
        if n[a as usize].dot(n[b as usize]) < cos_a {
            out.push((a, b));
        }
        if t2 != u32::MAX && tri_normals[t1 as usize].dot(tri_normals[t2 as usize]) < cos_a {
            for ti in [t1, t2] {
                let t = mesh.triangles[ti as usize];
                for k in 0..3 {
                    let e = key(t[k], t[(k + 1) % 3]);
                    if e != (a, b) {
                        out.push(e);
                    }
                }
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Triangle `t` split by the midpoints of its marked edges (Fig. 7a).
fn subdivide(mesh: &Mesh, t: [u32; 3], mid_of: &HashMap<EdgeKey, u32>, out: &mut Vec<[u32; 3]>) {
    let m = |k: usize| mid_of.get(&key(t[k], t[(k + 1) % 3])).copied();
    let ms = [m(0), m(1), m(2)];
    let count = ms.iter().filter(|x| x.is_some()).count();
    match count {
        0 => out.push(t),
        1 => {
            let k = (0..3).find(|&k| ms[k].is_some()).unwrap_or(0);
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let mid = ms[k].unwrap_or(a);
            out.push([a, mid, c]);
            out.push([mid, b, c]);
        }
        2 => {
            // Rotate so that the unmarked edge is b–c: marked a–b (m1) and
            // c–a (m2).
            let k = (0..3).find(|&k| ms[(k + 1) % 3].is_none()).unwrap_or(0);
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let (Some(m1), Some(m2)) = (ms[k], ms[(k + 2) % 3]) else {
                out.push(t);
                return;
            };
            out.push([a, m1, m2]);
            let nrm = |v: u32| mesh.normals[v as usize];
            if nrm(m1).dot(nrm(c)) >= nrm(b).dot(nrm(m2)) {
                out.push([m1, b, c]);
                out.push([m1, c, m2]);
            } else {
                out.push([m1, b, m2]);
                out.push([b, c, m2]);
            }
        }
        _ => {
            let (Some(m1), Some(m2), Some(m3)) = (ms[0], ms[1], ms[2]) else {
                out.push(t);
                return;
            };
            let [a, b, c] = t;
            out.push([a, m1, m3]);
            out.push([m1, b, m2]);
            out.push([m3, m2, c]);
            out.push([m1, m2, m3]);
        }
    }
}
