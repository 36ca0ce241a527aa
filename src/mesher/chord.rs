//! Chord refinement: the edges of an extracted mesh whose midpoints stand
//! too far off the surface are split, the new vertex projected onto
//! `f = 0` (faithful `--level`, SPEC §2, between two octree levels).
//!
//! # Contract
//!
//! A round measures every edge's midpoint by its first-order distance
//! `|f| / ‖∇f‖` to the surface, splits the edges above the tolerance whose
//! midpoint projects onto `f = 0` within a quarter of the edge's length,
//! onto the sheet of the edge's ends (the normal there agrees with both
//! ends' normals), and
//! re-triangulates each triangle by the number of its split edges (one:
//! two triangles; two: the corner triangle and the remaining quad by its
//! shorter diagonal; three: four triangles). Every split vertex is shared
//! by the edge's triangles, so the mesh stays conforming: topology,
//! closedness and orientation are kept, a boundary edge stays on the
//! boundary. The decision and the new vertex depend on the edge alone,
//! so the result does not depend on the order of the edges. Edges between
//! two crease vertices ([`super::crease`]) are left alone (their midpoint
//! is off the crease), and so are boundary edges (on the domain's faces,
//! where a projected midpoint would not be) and any edge without exactly
//! two triangles; new vertices are not crease vertices, and are ambiguous
//! when an end of their edge is.
//!
//! A part of a mesh (a brick of a bricked run, with its vertices'
//! [`Origins`]: [`split_edges_in`]) also splits its edges with one
//! triangle that do not lie on ∂Ω: their other triangle is in the next
//! brick, which decides the same edge the same way, and the new vertex
//! gets the same id on both sides.
//!
//! # Limits
//!
//! The measure is first order and at midpoints only: a triangle whose
//! centroid stands off while its edges do not is not split. The octree's
//! chord criterion ([`crate::octree::OctreeOptions::chord`]) decides the
//! coarse sizes; this pass only corrects the last factor below a level.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use crate::cancel::{Cancel, Cancelled};
use crate::eval::Evaluator;
use crate::eval::sample::grads_at;
use crate::mesh::Mesh;
use crate::mesh::origin::Origins;
use crate::roots::project_along;

/// Rounds of splitting (each at most halves an edge).
pub const ROUNDS: usize = 3;

/// A midpoint is split only when it projects onto the surface within this
/// share of its edge's length, and the surface's normal there agrees with
/// the normals at both ends: a projection that would cross a thin wall
/// onto another sheet is refused.
const REACH: f64 = 0.25;

/// Splits, in up to [`ROUNDS`] rounds, the edges of `mesh` whose midpoint
/// stands farther than `tau` from `f(·, t) = 0`; `feature` flags the
/// crease vertices (extended with `false` for the new ones). Returns how
/// many edges were split, or [`Cancelled`] when `cancel` was cancelled
/// before a round (the rounds done are kept). See the module doc.
pub fn split_edges<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    f: &E,
    t: f64,
    tau: f64,
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    split_edges_in(mesh, feature, None, f, t, tau, cancel)
}

/// [`split_edges`] on a part of a mesh whose vertices have `origins` (see
/// the module doc), kept in step; `None` is [`split_edges`].
pub fn split_edges_in<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    mut origins: Option<&mut Origins>,
    f: &E,
    t: f64,
    tau: f64,
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    let mut total = 0;
    for round in 0..ROUNDS {
        cancel.check()?;
        let part = origins.as_deref_mut().map(|o| (o, round as u32));
        let n = split_round_in(mesh, feature, part, f, t, tau);
        if n == 0 {
            break;
        }
        total += n;
    }
    Ok(total)
}

/// One round of [`split_edges`]; returns how many edges it split.
pub fn split_round<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    f: &E,
    t: f64,
    tau: f64,
) -> usize {
    split_round_in(mesh, feature, None, f, t, tau)
}

/// [`split_round`] on a part of a mesh (see [`split_edges_in`]) whose
/// vertices have `origins`, as its round number `round` (the ids of the
/// new vertices depend on it: [`Origins::push_split`]).
pub fn split_round_in<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    origins: Option<(&mut Origins, u32)>,
    f: &E,
    t: f64,
    tau: f64,
) -> usize {
    let splits = splits(
        mesh,
        feature,
        origins.as_ref().map(|(o, _)| &**o),
        f,
        t,
        tau,
    );
    apply(mesh, feature, &splits);
    if let Some((o, round)) = origins {
        for &((a, b), _, _) in &splits {
            o.push_split(a, b, round);
        }
    }
    splits.len()
}

/// Edges measured per task: the midpoints and their gradients exist for
/// one task's edges at a time, not for the whole mesh.
const EDGES_PER_TASK: usize = 4096;

/// The edges to split (smaller index first) and their new vertices'
/// positions and gradients.
fn splits<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    feature: &[bool],
    part: Option<&Origins>,
    f: &E,
    t: f64,
    tau: f64,
) -> Vec<((u32, u32), DVec3, DVec3)> {
    let edges = inner_edges(mesh, feature, part);
    let (p, n) = (&mesh.positions, &mesh.normals);
    edges
        .par_chunks(EDGES_PER_TASK)
        .flat_map_iter(|chunk| {
            let mids: Vec<DVec3> = chunk
                .iter()
                .map(|&(a, b)| (p[a as usize] + p[b as usize]) * 0.5)
                .collect();
            let measured = grads_at(f, t, &mids);
            let far = chunk.iter().zip(mids).zip(measured).filter(|(_, (v, g))| {
                // NaN (no gradient) is not a measurement: no split.
                v.abs() / g.length() > tau
            });
            far.filter_map(|((&(a, b), mid), _)| {
                let (a, b) = (a as usize, b as usize);
                let reach = REACH * p[a].distance(p[b]);
                let (q, _) = project_along(f, t, mid, reach)?;
                // The gradient at the new vertex itself (its normal): on
                // the sheet of the edge's ends, not across a thin wall.
                let (_, g) = f.point_grad([q.x, q.y, q.z, t]);
                let g = DVec3::from_array(g);
                let same_sheet = g.dot(n[a]) > 0.0 && g.dot(n[b]) > 0.0;
                (g.is_finite() && same_sheet).then_some(((a as u32, b as u32), q, g))
            })
            .collect::<Vec<_>>()
        })
        .collect()
}

/// The edges (smaller index first, sorted) with exactly two triangles and
/// not both ends on a crease. A boundary edge lies on the domain's face,
/// where a projected midpoint would not. In a `part` of a mesh, also the
/// edges with one triangle off ∂Ω (a seam: see the module doc).
fn inner_edges(mesh: &Mesh, feature: &[bool], part: Option<&Origins>) -> Vec<(u32, u32)> {
    let crease = |v: u32| feature.get(v as usize).copied().unwrap_or(false);
    let mut uses: Vec<(u32, u32)> = mesh
        .triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .filter(|&(a, b)| !(crease(a) && crease(b)))
        .collect();
    uses.par_sort_unstable();
    // In place: the first of each run of exactly two.
    let mut kept = 0;
    let mut i = 0;
    while i < uses.len() {
        let mut j = i + 1;
        while j < uses.len() && uses[j] == uses[i] {
            j += 1;
        }
        let (a, b) = uses[i];
        let seam = j - i == 1 && part.is_some_and(|o| !o.on_boundary(a, b));
        if j - i == 2 || seam {
            uses[kept] = uses[i];
            kept += 1;
        }
        i = j;
    }
    uses.truncate(kept);
    uses.shrink_to_fit();
    uses
}

/// Splits `mesh`'s edges at the given vertices (see the module doc).
fn apply(mesh: &mut Mesh, feature: &mut Vec<bool>, splits: &[((u32, u32), DVec3, DVec3)]) {
    feature.resize(mesh.positions.len(), false);
    let mut at: HashMap<(u32, u32), u32> = HashMap::with_capacity(splits.len());
    for &((a, b), q, g) in splits {
        at.insert((a, b), mesh.positions.len() as u32);
        let ambiguous = mesh.ambiguous[a as usize] || mesh.ambiguous[b as usize];
        mesh.positions.push(q);
        mesh.normals.push(g.normalize());
        mesh.ambiguous.push(ambiguous);
        feature.push(false);
    }
    let mid = |a: u32, b: u32| at.get(&(a.min(b), a.max(b))).copied();
    // Each triangle is replaced by its first piece in place; the others
    // are appended (no second copy of the triangle list).
    let p = &mesh.positions;
    let d2 = |a: u32, b: u32| p[a as usize].distance_squared(p[b as usize]);
    let mut extra = Vec::with_capacity(3 * splits.len());
    for t in mesh.triangles.iter_mut() {
        let m = [0, 1, 2].map(|k| mid(t[k], t[(k + 1) % 3]));
        let (pieces, count) = pieces(*t, m, d2);
        *t = pieces[0];
        extra.extend_from_slice(&pieces[1..count]);
    }
    mesh.triangles.append(&mut extra);
}

/// The triangles that replace `t = [a, b, c]` given the split vertices
/// `m[k]` of its edges `t[k]→t[k+1]` (see the module doc); `d2` measures
/// a squared length, to cut a quad by its shorter diagonal. Returns the
/// pieces (the first `count` of the array).
fn pieces(
    t: [u32; 3],
    m: [Option<u32>; 3],
    d2: impl Fn(u32, u32) -> f64,
) -> ([[u32; 3]; 4], usize) {
    let pad = |p: &[[u32; 3]]| {
        let mut out = [t; 4];
        out[..p.len()].copy_from_slice(p);
        (out, p.len())
    };
    match m.iter().filter(|x| x.is_some()).count() {
        0 => pad(&[t]),
        3 => {
            let [ab, bc, ca] = m.map(|x| x.expect("three splits"));
            let [a, b, c] = t;
            pad(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]])
        }
        n => {
            // Rotate so that edge 0 (a→b) is split and, with two splits,
            // edge 1 (b→c) too.
            let r = (0..3)
                .find(|&r| m[r].is_some() && (n == 1 || m[(r + 1) % 3].is_some()))
                .expect("a split edge");
            let [a, b, c] = [t[r], t[(r + 1) % 3], t[(r + 2) % 3]];
            let ab = m[r].expect("split");
            if n == 1 {
                return pad(&[[a, ab, c], [ab, b, c]]);
            }
            let bc = m[(r + 1) % 3].expect("split");
            // The quad a, ab, bc, c by its shorter diagonal.
            if d2(a, bc) <= d2(ab, c) {
                pad(&[[ab, b, bc], [a, ab, bc], [a, bc, c]])
            } else {
                pad(&[[ab, b, bc], [a, ab, c], [ab, bc, c]])
            }
        }
    }
}
