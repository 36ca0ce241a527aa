//! Chord refinement: the edges of an extracted mesh whose midpoints stand
//! too far off the surface are split, the new vertex projected onto
//! `f = 0` (faithful `--level`, SPEC §2, between two octree levels).
//!
//! # Contract
//!
//! A round measures every edge's midpoint by its first-order distance
//! `|f| / ‖∇f‖` to the surface, splits the edges above the tolerance (a
//! [`Chord`]: its base, plus a share of the sagitta a uniform mesher's
//! chord has on the curvature `turn / length` the normals at the edge's
//! ends show) whose
//! midpoint projects onto `f = 0` within a quarter of the edge's length,
//! onto the sheet of the edge's ends (the normal there agrees with both
//! ends' normals), and
//! re-triangulates each triangle by the number of its split edges (one:
//! two triangles; two: the corner triangle and the remaining quad by its
//! shorter diagonal; three: four triangles). Every split vertex is shared
//! by the edge's triangles, so the mesh stays conforming: topology,
//! closedness and orientation are kept, a boundary edge stays on the
//! boundary. The decision and the new vertex depend on the edge alone,
//! so the result does not depend on the order of the edges. Edges with a
//! crease vertex for an end ([`super::crease`]) are left alone: between
//! two, the midpoint is off the crease; from one, a split changes the fan
//! of a crease point, whose normal is one side's and at a corner of three
//! faces lopsided already, and can turn the fan past 120° from it
//! (colonnade.vm at level 6, with the splits after smoothing). So are
//! boundary edges (on the domain's faces,
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
//! The mesher runs it after coarsening and smoothing (`split_after_smoothing`
//! in [`super`]): its triangles get two smoothing passes held to the
//! tolerance (`smooth::smooth_within`). Next to a crease
//! the faces keep the coarsened mesh's edges (on colonnade.vm at level 8
//! the chord error's 99.9th percentile is the same, 0.236 cells).

use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use smallvec::SmallVec;

use crate::cancel::{Cancel, Cancelled};
use crate::eval::Evaluator;
use crate::eval::sample::{grads_at, orient_at_kinks};
use crate::mesh::origin::Origins;
use crate::mesh::{Mesh, Star};
use crate::octree::Chord;
use crate::octree::criteria::turn;
use crate::roots::project_along_batch;

/// Rounds of splitting (each at most halves an edge).
pub const ROUNDS: usize = 3;

/// A midpoint is split only when it projects onto the surface within this
/// share of its edge's length, and the surface's normal there agrees with
/// the normals at both ends: a projection that would cross a thin wall
/// onto another sheet is refused.
const REACH: f64 = 0.25;

/// Splits, in up to [`ROUNDS`] rounds, the edges of `mesh` whose midpoint
/// stands farther than `tau` (at the edge's curvature: [`Chord::at`]) from
/// `f(·, t) = 0`; `feature` flags the
/// crease vertices (extended with `false` for the new ones). Returns how
/// many edges were split, or [`Cancelled`] when `cancel` was cancelled
/// before a round (the rounds done are kept). See the module doc.
pub fn split_edges<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    f: &E,
    t: f64,
    tau: Chord,
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
    tau: Chord,
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    let (mut total, mut fresh) = (0, 0);
    for round in 0..ROUNDS {
        cancel.check()?;
        let part = origins.as_deref_mut().map(|o| (o, round as u32));
        let before = mesh.positions.len() as u32;
        let n = split_round_from(mesh, feature, part, f, t, tau, fresh);
        if n == 0 {
            break;
        }
        // Every edge the round made has a new vertex for an end; the
        // others, and their ends, are as the round measured them.
        fresh = before;
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
    tau: Chord,
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
    tau: Chord,
) -> usize {
    split_round_from(mesh, feature, origins, f, t, tau, 0)
}

/// [`split_round_in`] on the edges with an end numbered `fresh` or more
/// (the rest measured by the last round, unchanged since).
fn split_round_from<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    origins: Option<(&mut Origins, u32)>,
    f: &E,
    t: f64,
    tau: Chord,
    fresh: u32,
) -> usize {
    let part = origins.as_ref().map(|(o, _)| &**o);
    let splits = splits(mesh, feature, part, f, t, tau, fresh);
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
    tau: Chord,
    fresh: u32,
) -> Vec<((u32, u32), DVec3, DVec3)> {
    let edges = inner_edges(mesh, feature, part, fresh);
    let (p, n) = (&mesh.positions, &mesh.normals);
    edges
        .par_chunks(EDGES_PER_TASK)
        .flat_map_iter(|chunk| {
            let mids: Vec<DVec3> = chunk
                .iter()
                .map(|&(a, b)| (p[a as usize] + p[b as usize]) * 0.5)
                .collect();
            let measured = grads_at(f, t, &mids);
            let far: Vec<((u32, u32), (DVec3, f64))> = chunk
                .iter()
                .zip(mids)
                .zip(measured)
                // NaN (no gradient) is not a measurement: no split.
                .filter(|&((&(a, b), _), (v, g))| {
                    let (a, b) = (a as usize, b as usize);
                    let (_, tol) = midpoint_tolerance(tau, (p[a], n[a]), (p[b], n[b]));
                    beyond(v, g, tol)
                })
                .map(|((&(a, b), mid), _)| {
                    let reach = REACH * p[a as usize].distance(p[b as usize]);
                    ((a, b), (mid, reach))
                })
                .collect();
            let starts: Vec<(DVec3, f64)> = far.iter().map(|&(_, s)| s).collect();
            let projected: Vec<((u32, u32), DVec3)> = far
                .iter()
                .zip(project_along_batch(f, t, &starts))
                .filter_map(|(&(e, _), r)| r.map(|(q, _)| (e, q)))
                .collect();
            // The gradient at each new vertex itself (its normal): on the
            // sheet of the edge's ends, not across a thin wall.
            let qs: Vec<DVec3> = projected.iter().map(|&(_, q)| q).collect();
            let mut gs: Vec<DVec3> = grads_at(f, t, &qs).into_iter().map(|(_, g)| g).collect();
            // Where two sides of a kink tie at the new vertex, the side
            // the ends' normals agree with.
            let outward: Vec<DVec3> = projected
                .iter()
                .map(|&((a, b), _)| n[a as usize] + n[b as usize])
                .collect();
            orient_at_kinks(f, t, &qs, &mut gs, &outward);
            projected
                .into_iter()
                .zip(gs)
                .filter(|&(((a, b), _), g)| {
                    g.is_finite() && g.dot(n[a as usize]) > 0.0 && g.dot(n[b as usize]) > 0.0
                })
                .map(|((e, q), g)| (e, q, g))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The midpoint of the edge `a–b`, given its ends' positions and unit
/// normals, and the tolerance for it: `tau` at the normals' turn over the
/// edge's length.
pub(crate) fn midpoint_tolerance(
    tau: Chord,
    (pa, na): (DVec3, DVec3),
    (pb, nb): (DVec3, DVec3),
) -> (DVec3, f64) {
    let bend = turn(na.to_array(), nb.to_array());
    ((pa + pb) * 0.5, tau.at(bend, pa.distance(pb)))
}

/// Whether a point where `f` is `v` and ∇f is `g` stands farther than
/// `tol` off `f = 0`, to first order (`|f| / ‖∇f‖`); false where there is
/// no gradient (NaN is not a measurement).
pub(crate) fn beyond(v: f64, g: DVec3, tol: f64) -> bool {
    v.abs() / g.length() > tol
}

/// The edges (smaller index first, sorted) with exactly two triangles and
/// no end on a crease, among those with an end numbered `fresh` or
/// more. A boundary edge lies on the domain's face, where a projected
/// midpoint would not. In a `part` of a mesh, also the edges with one
/// triangle off ∂Ω (a seam: see the module doc).
fn inner_edges(
    mesh: &Mesh,
    feature: &[bool],
    part: Option<&Origins>,
    fresh: u32,
) -> Vec<(u32, u32)> {
    let crease = |v: u32| feature.get(v as usize).copied().unwrap_or(false);
    let star = Star::new(mesh);
    let tris = &mesh.triangles;
    (0..mesh.positions.len() as u32)
        .into_par_iter()
        .flat_map_iter(|a| {
            // The uses of the edges whose smaller end is `a` (a triangle's
            // sides, as many times as it has them: once per triangle but
            // for one with a repeated corner), sorted.
            let mut uses: SmallVec<[u32; 16]> = SmallVec::new();
            let mut last = None;
            for &ti in star.of(a as usize) {
                if last.replace(ti) == Some(ti) {
                    // The star lists a triangle once per corner it is.
                    continue;
                }
                let t = tris[ti as usize];
                for k in 0..3 {
                    let (x, y) = (t[k], t[(k + 1) % 3]);
                    let (lo, hi) = (x.min(y), x.max(y));
                    if lo == a && hi >= fresh && !(crease(lo) || crease(hi)) {
                        uses.push(hi);
                    }
                }
            }
            uses.sort_unstable();
            // The edges used exactly twice (once, on a part's seam).
            let mut kept: SmallVec<[(u32, u32); 8]> = SmallVec::new();
            for run in uses.chunk_by(|x, y| x == y) {
                let b = run[0];
                let seam = run.len() == 1 && part.is_some_and(|o| !o.on_boundary(a, b));
                if run.len() == 2 || seam {
                    kept.push((a, b));
                }
            }
            kept
        })
        .collect()
}

/// Splits `mesh`'s edges at the given vertices (see the module doc).
fn apply(mesh: &mut Mesh, feature: &mut Vec<bool>, splits: &[((u32, u32), DVec3, DVec3)]) {
    feature.resize(mesh.positions.len(), false);
    if splits.is_empty() {
        return;
    }
    let mut at: HashMap<(u32, u32), u32> = HashMap::default();
    at.reserve(splits.len());
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
