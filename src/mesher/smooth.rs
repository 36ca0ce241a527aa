//! Mesh improvement after extraction: edge flips and tangential
//! relaxation with re-projection (Paiva et al. §4.3, end; issue 11 item 2).
//!
//! One pass
//!
//! 1. flips edges that improve the worse of their two triangles' aspect
//!    ratios ([`super::flip`]: connectivity only, topology and orientation
//!    kept);
//! 2. moves every vertex whose triangles are not all well shaped (aspect
//!    ratio 0.85 or more; the right isosceles triangles of flat regions,
//!    0.866, stay) towards a relaxation target: of the two points
//!    "average of the neighbours" (uniform Laplacian) and "area-weighted
//!    average of the star's triangle centroids", the one that gives the
//!    star the better worst aspect ratio. Only the component of the move in
//!    the tangent plane of the surface at the vertex is kept, and the point
//!    is projected back onto `f = 0` ([`crate::roots::project`], within half
//!    the star's reach).
//!
//! A move is **skipped** when it would flip or collapse an incident
//! triangle (its normal would turn by more than 90° or its area fall below
//! a fraction of the old), or fold one (its normal would disagree with the
//! surface's normal at a corner where it agreed before), or when the projection finds no zero near the
//! candidate. Vertices on a boundary, non-manifold or misoriented edge
//! (open surfaces cut by the domain) never move, and neither do the
//! vertices on a ridge line (two or more of their edges have triangles
//! that turn by more than the crease pass's [`SPLIT_DEG`]): a chamfer
//! across a crease the crease pass could not sharpen (two creases in one
//! cell, a wall a cell thin) would widen as its vertices slid off the
//! crease. After the last pass the
//! flips run once more. Smoothing never changes the vertex set or the
//! mesh's topology and orientation; every vertex stays on the surface (it
//! moves only to a projected point).
//!
//! The passes the mesher runs after the chord splits, which also even
//! out the sags and hold the edges to the chord tolerance, are
//! [`super::settle`]'s; they share this module's safety test, colouring
//! and relaxation target.
//!
//! The moves are Gauss–Seidel by colour class: the vertices are greedily
//! coloured so that no two neighbours share a colour; the candidates of
//! one class are computed in parallel from the current positions (the
//! costly part: projection), then accepted one by one, so each class sees
//! the moves of the classes before it (Jacobi moves, all from the old
//! positions, converge about half as fast on the stretched triangles of
//! anisotropic dual cells). Two neighbours never move at once, so they
//! cannot together flip a triangle that each alone would not.
//!
//! Evaluation: a colour class's targets are projected in batches
//! ([`crate::roots::project_along_batch`]: each step of the projection is
//! one batch call over the vertices still projecting; the batches run in
//! parallel). A moved vertex's
//! tangent plane in the next pass is the one at its relaxation target (the
//! gradient the projection starts from); after the last pass the normals
//! of every vertex that moved are one batch of point gradients at the
//! final positions ([`crate::eval::sample::grads_at`]; the others keep theirs,
//! already their positions' normals).
//!
//! # Limits
//!
//! Relaxation does not respect the octree's grading: it pulls vertex
//! density towards uniform on the star scale, which is what the aspect
//! ratio rewards but spreads small triangles of a refined region slightly
//! outward. Pinned boundary vertices keep the triangles along an open
//! surface's boundary as extracted. Nothing tests a moved triangle against
//! distant parts of the mesh (two sheets closer than a star's reach).

use glam::DVec3;
use rayon::prelude::*;
use smallvec::SmallVec;

use super::crease::SPLIT_DEG;
use super::flip::Flips;
use crate::cancel::{Cancel, Cancelled, uncancelled};
use crate::eval::Evaluator;
use crate::eval::sample::grads_at;
use crate::mesh::quality::{aspect, aspect_ratio};
use crate::mesh::{Mesh, Star};
use crate::roots::project_along_batch;

/// Whether moving vertex `v` to `p`, where the surface's normal is `n`,
/// keeps every incident triangle's orientation and a reasonable share of
/// its area, and folds no triangle that was not folded: a triangle whose
/// normal agreed with a corner's unit normal (`v`'s now `n`) still does.
pub(super) fn move_is_safe(mesh: &Mesh, star: &Star, v: usize, p: DVec3, n: DVec3) -> bool {
    star.of(v).iter().all(|&ti| {
        let t = mesh.triangles[ti as usize];
        let before = mesh.face_normal(t);
        let [a, b, c] = t.map(|i| {
            if i as usize == v {
                p
            } else {
                mesh.positions[i as usize]
            }
        });
        let after = (b - a).cross(c - a);
        let unfolded = t.iter().all(|&i| {
            let (old, new) = if i as usize == v {
                (mesh.normals[v], n)
            } else {
                (mesh.normals[i as usize], mesh.normals[i as usize])
            };
            before.dot(old) <= 0.0 || after.dot(new) > 0.0
        });
        unfolded && after.dot(before) > 0.0 && after.length() > 0.05 * before.length()
    })
}

/// A vertex whose triangles all have at least this aspect ratio stays.
pub(super) const SETTLED: f64 = 0.85;

/// Where relaxation would take vertex `v` (before projection), and the
/// largest distance from `v` to its star's corners (`None`: the vertex
/// stays, its star being empty or already [`SETTLED`] by the triangles'
/// aspect ratios `aspects`): [`relaxation_target`] of its star.
fn target(mesh: &Mesh, star: &Star, aspects: &[f64], v: usize) -> Option<(DVec3, f64)> {
    let tris = star.of(v);
    if tris.is_empty() || tris.iter().all(|&ti| aspects[ti as usize] >= SETTLED) {
        return None;
    }
    Some(relaxation_target(
        mesh.positions[v],
        mesh.normals[v],
        &opposite(mesh, star, v)?,
    ))
}

/// The edge opposite vertex `v` in each triangle of its star, in the
/// star's order (`None`: `v` is not a corner of one of them, a broken
/// star).
pub(super) fn opposite(
    mesh: &Mesh,
    star: &Star,
    v: usize,
) -> Option<SmallVec<[(DVec3, DVec3); 12]>> {
    star.of(v)
        .iter()
        .map(|&ti| {
            let tri = mesh.triangles[ti as usize];
            let s = tri.iter().position(|&w| w as usize == v)?;
            Some((
                mesh.positions[tri[(s + 1) % 3] as usize],
                mesh.positions[tri[(s + 2) % 3] as usize],
            ))
        })
        .collect()
}

/// The worst aspect ratio of a star whose centre is at `q` and whose
/// triangles are `(q, b, c)` for the edges `(b, c)` of `opposite`.
pub(super) fn worst_aspect(q: DVec3, opposite: &[(DVec3, DVec3)]) -> f64 {
    opposite
        .iter()
        .fold(f64::INFINITY, |w, &(b, c)| w.min(aspect(q, b, c)))
}

/// Where relaxation takes a vertex at `p` with unit normal `n` whose star's
/// triangles are `(p, b, c)` for the edges `(b, c)` of `opposite`, and the
/// largest distance from `p` to their corners: the better, by the star's
/// worst aspect ratio, of the tangential components of the moves towards
/// the neighbours' average (uniform Laplacian) and towards the
/// area-weighted average of the star's triangle centroids.
pub(crate) fn relaxation_target(p: DVec3, n: DVec3, opposite: &[(DVec3, DVec3)]) -> (DVec3, f64) {
    let worst = |q: DVec3| worst_aspect(q, opposite);
    let (mut bary, mut cent, mut weight, mut reach) = (DVec3::ZERO, DVec3::ZERO, 0.0, 0.0f64);
    for &(b, c) in opposite {
        bary += b + c;
        reach = reach.max((b - p).length()).max((c - p).length());
        let area = 0.5 * (b - p).cross(c - p).length();
        cent += (p + b + c) / 3.0 * area;
        weight += area;
    }
    let tangent = |q: DVec3| {
        let d = q - p;
        p + d - n * d.dot(n)
    };
    let bary = tangent(bary / (2 * opposite.len().max(1)) as f64);
    let cent = if weight > 0.0 {
        tangent(cent / weight)
    } else {
        bary
    };
    let q = if worst(bary) >= worst(cent) {
        bary
    } else {
        cent
    };
    (q, reach)
}

/// A greedy colouring of the vertices (no two joined by an edge share a
/// colour): the vertices of each colour, in order.
pub(super) fn colour_classes(
    mesh: &Mesh,
    star: &Star,
    active: impl Fn(usize) -> bool,
) -> Vec<Vec<u32>> {
    let n = mesh.positions.len();
    let mut colour = vec![u32::MAX; n];
    let mut classes: Vec<Vec<u32>> = Vec::new();
    let mut used: Vec<u32> = Vec::new();
    for v in 0..n {
        if star.of(v).is_empty() || !active(v) {
            continue;
        }
        // Colours below 64 as a bit set, the rest (rare) in `used`.
        let (mut low, mut high) = (0u64, false);
        used.clear();
        for &ti in star.of(v) {
            for &w in &mesh.triangles[ti as usize] {
                let c = colour[w as usize];
                if c < 64 {
                    low |= 1 << c;
                } else if c != u32::MAX {
                    used.push(c);
                    high = true;
                }
            }
        }
        let c = if low != u64::MAX {
            low.trailing_ones()
        } else if !high {
            64
        } else {
            (64..).find(|c| !used.contains(c)).unwrap_or(64)
        };
        colour[v] = c;
        if classes.len() <= c as usize {
            classes.resize_with(c as usize + 1, Vec::new);
        }
        classes[c as usize].push(v as u32);
    }
    classes
}

/// Runs `passes` smoothing passes on the surface `f(·, t) = 0`; returns how
/// many moves were accepted.
pub fn smooth<E: Evaluator + ?Sized>(mesh: &mut Mesh, f: &E, t: f64, passes: usize) -> usize {
    uncancelled(|never| smooth_keeping(mesh, f, t, passes, &[], never))
}

/// [`smooth`], keeping the vertices flagged in `keep` (crease points,
/// [`super::crease`]) where they are and every edge between two of them
/// unflipped (a shorter `keep` flags nothing past its end). Stops with
/// [`Cancelled`] soon after `cancel` is cancelled (polled per batch of
/// each colour class); the mesh is then valid but partly smoothed (every move made is
/// a safe one) and its moved vertices' normals are not yet refreshed.
pub fn smooth_keeping<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    f: &E,
    t: f64,
    passes: usize,
    keep: &[bool],
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    smooth_part(mesh, f, t, passes, keep, &[], cancel)
}

/// [`smooth_keeping`] on a brick's part of a mesh: the vertices flagged in
/// `seam` stay where they are, and no flip joins two of them (the next
/// brick may join them already), so the seam stays closed and 2-manifold.
pub fn smooth_part<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    f: &E,
    t: f64,
    passes: usize,
    keep: &[bool],
    seam: &[bool],
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    smooth_with(mesh, f, t, passes, keep, seam, cancel)
}

/// [`smooth_part`].
fn smooth_with<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    f: &E,
    t: f64,
    passes: usize,
    keep: &[bool],
    seam: &[bool],
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    if passes == 0 || mesh.triangles.is_empty() {
        return Ok(0);
    }
    let mut accepted = 0;
    let mut flips = Flips::new(mesh);
    flips.keep_edges_between(keep);
    flips.keep_apart(seam);
    let pinned = pinned(&flips, mesh, keep, seam);
    let mut moved = vec![false; mesh.positions.len()];
    for _ in 0..passes {
        flips.run(mesh);
        let star = Star::new(mesh);
        let mut aspects = flips.aspects().to_vec();
        for class in colour_classes(mesh, &star, |_| true) {
            let targets: Vec<(u32, DVec3, f64)> = class
                .par_iter()
                .filter(|&&v| !pinned[v as usize])
                .filter_map(|&v| {
                    let (q, reach) = target(mesh, &star, &aspects, v as usize)?;
                    Some((v, q, 0.5 * reach))
                })
                .collect();
            for (v, p, g) in projected(f, t, &targets, cancel)? {
                if move_is_safe(mesh, &star, v as usize, p, g.normalize_or_zero()) {
                    mesh.positions[v as usize] = p;
                    // The tangent plane for the next pass: the normal at
                    // the relaxation target, a point within rounding of
                    // the projected one's normal line.
                    mesh.normals[v as usize] = g.normalize();
                    moved[v as usize] = true;
                    accepted += 1;
                    for &ti in star.of(v as usize) {
                        aspects[ti as usize] = aspect_ratio(mesh, mesh.triangles[ti as usize]);
                    }
                }
            }
        }
    }
    flips.run(mesh);
    drop((flips, pinned));
    refresh_normals(mesh, f, t, &moved);
    Ok(accepted)
}

/// The vertices smoothing keeps where they are: those `flips` pins (on a
/// boundary, non-manifold or misoriented edge), those on a ridge line the
/// crease pass left (a chamfer across a crease it could not sharpen would
/// widen as they slid across it), and those flagged in `keep` or `seam`.
pub(super) fn pinned(flips: &Flips, mesh: &Mesh, keep: &[bool], seam: &[bool]) -> Vec<bool> {
    let mut pinned = flips.pinned(mesh);
    let ridges = flips.on_ridge_lines(mesh, SPLIT_DEG.to_radians().cos());
    for flags in [&ridges[..], keep, seam] {
        for (p, &k) in pinned.iter_mut().zip(flags) {
            *p |= k;
        }
    }
    pinned
}

/// The `targets` (vertex, target, reach of the projection) projected onto
/// `f(·, t) = 0` in batches, as (vertex, projected position, gradient
/// there).
fn projected<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    targets: &[(u32, DVec3, f64)],
    cancel: &Cancel,
) -> Result<Vec<(u32, DVec3, DVec3)>, Cancelled> {
    cancel.check()?;
    let projected = targets
        .par_chunks(PROJECT_CHUNK)
        .filter(|_| !cancel.is_cancelled())
        .flat_map_iter(|part| {
            let starts: Vec<(DVec3, f64)> = part.iter().map(|&(_, q, d)| (q, d)).collect();
            let projected = project_along_batch(f, t, &starts);
            part.iter()
                .zip(projected)
                .filter_map(|(&(v, _, _), r)| r.map(|(p, g)| (v, p, g)))
                .collect::<Vec<_>>()
        })
        .collect();
    cancel.check()?;
    Ok(projected)
}

/// The normals at the final positions of the vertices flagged in `moved`
/// (the others' are their positions' already), a slice of vertices at a
/// time.
pub(super) fn refresh_normals<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    f: &E,
    t: f64,
    moved: &[bool],
) {
    let moved: Vec<u32> = (0..moved.len() as u32)
        .filter(|&v| moved[v as usize])
        .collect();
    for part in moved.chunks(REFRESH_CHUNK) {
        let at: Vec<DVec3> = part.iter().map(|&v| mesh.positions[v as usize]).collect();
        for (&v, (_, g)) in part.iter().zip(grads_at(f, t, &at)) {
            if g.is_finite() && g.length_squared() > 0.0 {
                mesh.normals[v as usize] = g.normalize();
            }
        }
    }
}

/// Relaxation targets projected together (one batch of each evaluation;
/// many batches for the threads).
const PROJECT_CHUNK: usize = 256;

/// Vertices whose normals are refreshed together (bounds the transient
/// position and gradient arrays; still many batches for the threads).
const REFRESH_CHUNK: usize = 1 << 16;
