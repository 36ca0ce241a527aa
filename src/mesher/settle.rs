//! The passes after the chord splits: shapes and sags evened out, every
//! edge held within the chord tolerance.
//!
//! The chord splits ([`super::chord`]) leave the coarsened, smoothed mesh
//! within the tolerance, but with the split triangles badly shaped (a
//! split halves an equilateral triangle into two of aspect ratio 0.75)
//! and with its sags uneven: a coarsened mesh's chord error is set by its
//! largest sags and its size by the average one (on sphere.iso at depth 8
//! the centroids' sags spread from 0.016 to 0.036 cells, 1st to 99.9th
//! percentile). [`settle`] moves each vertex, in its tangent plane, for
//! one of two goals, chosen from its star (the triangles around it):
//!
//! - **a better shape**: a star with a triangle whose aspect ratio is
//!   below [`GOOD`], or below smoothing's settled 0.85 with its sags
//!   already low, relaxes as smoothing does
//!   ([`super::smooth::relaxation_target`]) when that raises its worst
//!   aspect ratio and raises its largest sag ([`super::sag`]) past neither
//!   what it was nor [`SAG_FLOOR`] of the tolerance's base;
//! - **lower sags**: a well-shaped star whose largest sag is above that
//!   floor moves down a soft maximum of its sags
//!   ([`super::sag::Sags::steps`]) when that lowers the largest and keeps
//!   every triangle at [`GOOD`] or above (or where it was, if lower).
//!   Repeated over the mesh, the largest sags come down towards the
//!   average: the chord error falls at the same triangle count.
//!
//! Each move is read again at the projected point with its own normal,
//! and must be as safe as smoothing's ([`super::smooth`]'s module doc).
//! No flip or shape move stretches an edge past the tolerance: a flip is
//! refused, or a move skipped, when the midpoint of its new edge, or of
//! one of the moved vertex's edges, would stand farther than the tolerance
//! (at the edge's curvature, first order, as [`super::chord`] measures)
//! off `f = 0`. Relaxed freely, the split triangles stretched edges that
//! another round split again (cyclide at level 8: 8.4k more triangles,
//! 0.62× Fidget's count instead of 0.55×). A sag move lowers its star's
//! largest sag, the edges' midpoints among them, by its own measure, and
//! is not measured on `f`.
//!
//! The moves are Gauss–Seidel by colour class, as smoothing's; the first
//! pass visits every vertex, each later one the stars of the vertices
//! that moved in the one before.
//!
//! # Limits
//!
//! The sags are second order ([`super::sag`]): a star across a crease or
//! next to a singular point has none, and only relaxes. A sag move's
//! measure is not `f`'s: on a surface whose curvature changes within a
//! star, an edge near the tolerance may end a little past it, for the last
//! split round to split.

use glam::DVec3;
use rayon::prelude::*;
use smallvec::SmallVec;

use super::chord::{beyond, midpoint_tolerance};
use super::flip::Flips;
use super::sag::Sags;
use super::smooth::{
    SETTLED, colour_classes, move_is_safe, opposite, pinned, refresh_normals, relaxation_target,
    worst_aspect,
};
use crate::cancel::{Cancel, Cancelled};
use crate::eval::Evaluator;
use crate::eval::sample::grads_at;
use crate::mesh::quality::aspect_ratio;
use crate::mesh::{Mesh, Star};
use crate::octree::Chord;
use crate::roots::walk::newton_batch;

/// Passes of [`settle`]: on sphere.iso at depth 8 the 99.9th percentile of
/// the chord error is 0.036 cells with none (two shape passes on the split
/// triangles only, before), 0.033 with two, 0.032 with three at a third
/// more time (`docs/faithful.md`).
const PASSES: usize = 2;

/// The aspect ratio [`settle`] keeps every triangle of a star at when it
/// lowers the star's sags (or at what it was, if lower): the threshold of
/// `aspect_good` (SPEC §2).
const GOOD: f64 = 0.8;

/// The share of the tolerance's base up to which [`settle`] leaves a
/// star's largest sag as it is: on sphere.iso at depth 8, 0.7 lowers the
/// 99.9th percentile as far as 0.5 does with half the moves, 0.8 stops
/// short (`docs/faithful.md`).
const SAG_FLOOR: f64 = 0.7;

/// [`PASSES`] passes over `mesh` (see the module doc) within the chord
/// tolerance `tau`. The vertices smoothing pins stay, and so do those
/// flagged in `keep` (crease points, whose edges are not flipped either)
/// or `still` (a brick's seam: no flip joins two of them). Returns the
/// moves made. Stops with [`Cancelled`] soon after `cancel` is cancelled
/// (polled per colour class); the mesh is then valid (every move made is
/// a safe one) but its moved vertices' normals are not yet refreshed.
pub fn settle<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    f: &E,
    t: f64,
    keep: &[bool],
    still: &[bool],
    tau: Chord,
    cancel: &Cancel,
) -> Result<usize, Cancelled> {
    if mesh.triangles.is_empty() {
        return Ok(0);
    }
    let floor = SAG_FLOOR * tau.base;
    let mut flips = Flips::new(mesh);
    flips.keep_edges_between(keep);
    flips.keep_apart(still);
    let pinned = pinned(&flips, mesh, keep, still);
    let allow = |m: &Mesh, c: u32, d: u32| edge_within(m, f, t, tau, c, d);
    let mut active: Vec<bool> = pinned.iter().map(|&p| !p).collect();
    let mut moved = vec![false; mesh.positions.len()];
    let mut accepted = 0;
    for _ in 0..PASSES {
        flips.run_where(mesh, &allow);
        let star = Star::new(mesh);
        let mut aspects = flips.aspects().to_vec();
        let mut next = vec![false; mesh.positions.len()];
        for class in colour_classes(mesh, &star, |v| active[v]) {
            cancel.check()?;
            let targets: Vec<(u32, DVec3, f64, Goal)> = class
                .par_iter()
                .filter_map(|&v| {
                    let (q, reach, goal) = target(mesh, &star, &aspects, v as usize, floor)?;
                    Some((v, q, 0.5 * reach, goal))
                })
                .collect();
            for (v, p, n, goal) in candidates(mesh, &star, f, t, tau, &targets) {
                let Some(opposite) = opposite(mesh, &star, v) else {
                    continue;
                };
                let worst = worst_aspect(p, &opposite);
                let sag = Sags::of(mesh, &star, v, (p, n)).map(|s| s.largest(DVec3::ZERO));
                if goal.met(worst, sag) && move_is_safe(mesh, &star, v, p, n) {
                    mesh.positions[v] = p;
                    mesh.normals[v] = n;
                    moved[v] = true;
                    accepted += 1;
                    for &ti in star.of(v) {
                        let tri = mesh.triangles[ti as usize];
                        aspects[ti as usize] = aspect_ratio(mesh, tri);
                        for w in tri {
                            next[w as usize] = !pinned[w as usize];
                        }
                    }
                }
            }
        }
        active = next;
    }
    flips.run_where(mesh, &allow);
    drop((flips, pinned));
    refresh_normals(mesh, f, t, &moved);
    Ok(accepted)
}

/// The `targets` (vertex, target, reach, goal) projected onto `f(·, t) =
/// 0` (a Newton walk each, in lock-step batches), the shape moves among
/// them held within `tau` ([`within_chord`]): (vertex, position, unit
/// normal, goal).
fn candidates<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    star: &Star,
    f: &E,
    t: f64,
    tau: Chord,
    targets: &[(u32, DVec3, f64, Goal)],
) -> Vec<(usize, DVec3, DVec3, Goal)> {
    let projected: Vec<(usize, DVec3, DVec3, Goal)> = targets
        .par_chunks(WALKS_PER_TASK)
        .flat_map_iter(|chunk| {
            let starts: Vec<(DVec3, f64, f64)> = chunk
                .iter()
                .map(|&(_, q, reach, _)| (q, reach, reach))
                .collect();
            let walks = newton_batch(f, t, &starts);
            chunk
                .iter()
                .zip(walks)
                .filter_map(|(&(v, _, _, goal), on)| {
                    let on = on?;
                    Some((v as usize, on.pos, on.grad.normalize_or_zero(), goal))
                })
        })
        .collect();
    let (shapes, sags): (Vec<_>, Vec<_>) = projected
        .into_iter()
        .partition(|c| matches!(c.3, Goal::Shape { .. }));
    let mut held = within_chord(mesh, star, f, t, tau, shapes);
    held.extend(sags);
    held
}

/// Newton walks per task in [`candidates`], in lock-step (batches of the
/// point gradient).
const WALKS_PER_TASK: usize = 512;

/// What a move of [`settle`] is for, read before it.
#[derive(Clone, Copy, Debug)]
enum Goal {
    /// A better shape: the star's worst aspect ratio rises above `worst`,
    /// its largest sag stays at most `cap` (no cap: the star has no sags).
    Shape { worst: f64, cap: Option<f64> },
    /// Lower sags: the star's largest sag falls below `sag`, and its worst
    /// aspect ratio stays at least `worst` or [`GOOD`], the lower.
    Sag { worst: f64, sag: f64 },
}

impl Goal {
    /// Whether a star whose worst aspect ratio is `worst` and largest sag
    /// `sag` (`None`: it has none) meets the goal.
    fn met(&self, worst: f64, sag: Option<f64>) -> bool {
        match *self {
            Goal::Shape { worst: was, cap } => {
                worst > was && cap.is_none_or(|c| sag.is_some_and(|s| s <= c))
            }
            Goal::Sag {
                worst: was,
                sag: high,
            } => worst >= was.min(GOOD) && sag.is_some_and(|s| s < high),
        }
    }
}

/// Where [`settle`] moves vertex `v` (before projection), the largest
/// distance from `v` to its star's corners, and what the move is for;
/// `None` when the star is settled (every aspect ratio, read from
/// `aspects`, at least [`SETTLED`], and its largest sag at most `floor`)
/// or no candidate meets its goal.
fn target(
    mesh: &Mesh,
    star: &Star,
    aspects: &[f64],
    v: usize,
    floor: f64,
) -> Option<(DVec3, f64, Goal)> {
    let tris = star.of(v);
    let worst = tris
        .iter()
        .fold(f64::INFINITY, |w, &ti| w.min(aspects[ti as usize]));
    if !worst.is_finite() {
        return None;
    }
    let (p, n) = (mesh.positions[v], mesh.normals[v]);
    let sags = Sags::of(mesh, star, v, (p, n));
    let sag = sags.as_ref().map(|s| s.largest(DVec3::ZERO));
    let goal = match sag {
        Some(s) if worst >= GOOD && s > floor => Goal::Sag { worst, sag: s },
        _ if worst < SETTLED => Goal::Shape {
            worst,
            cap: sag.map(|s| s.max(floor)),
        },
        _ => return None,
    };
    let opposite = opposite(mesh, star, v)?;
    let reach = opposite
        .iter()
        .fold(0.0f64, |r, &(b, c)| r.max(b.distance(p)).max(c.distance(p)));
    let worst_at = |d: DVec3| worst_aspect(p + d, &opposite);
    let sag_at = |d: DVec3| sags.as_ref().map(|s| s.largest(d));
    // The candidates, the lowest sag first (a shape has one); the first
    // that meets the goal is taken.
    let mut moves: SmallVec<[(f64, DVec3); 4]> = match goal {
        Goal::Shape { .. } => [(0.0, relaxation_target(p, n, &opposite).0 - p)]
            .into_iter()
            .collect(),
        Goal::Sag { .. } => sags
            .as_ref()?
            .steps(n)
            .map(|d| (sag_at(d).unwrap_or(f64::INFINITY), d))
            .collect(),
    };
    moves.sort_by(|a, b| a.0.total_cmp(&b.0));
    let d = moves
        .into_iter()
        .map(|(_, d)| d)
        .find(|&d| goal.met(worst_at(d), sag_at(d)))?;
    Some((p + d, reach, goal))
}

/// Whether the midpoint of the edge `c–d` of `m` stands within `tau` of
/// `f(·, t) = 0` (as [`super::chord`] measures it; no gradient there
/// passes).
fn edge_within<E: Evaluator + ?Sized>(m: &Mesh, f: &E, t: f64, tau: Chord, c: u32, d: u32) -> bool {
    let end = |v: u32| (m.positions[v as usize], m.normals[v as usize]);
    let (mid, tol) = midpoint_tolerance(tau, end(c), end(d));
    let (v, g) = f.point_grad([mid.x, mid.y, mid.z, t]);
    !beyond(v, DVec3::from_array(g), tol)
}

/// The `candidates` (vertex, projected position, unit normal there, goal)
/// whose every edge, from the new position, has its midpoint within `tau` of
/// `f(·, t) = 0` (first order; a midpoint without a gradient passes, as
/// the chord splits pass it).
fn within_chord<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    star: &Star,
    f: &E,
    t: f64,
    tau: Chord,
    candidates: Vec<(usize, DVec3, DVec3, Goal)>,
) -> Vec<(usize, DVec3, DVec3, Goal)> {
    let (pos, normals) = (&mesh.positions, &mesh.normals);
    // Per candidate, its neighbours' midpoints and tolerances.
    let edges: Vec<Vec<(DVec3, f64)>> = candidates
        .iter()
        .map(|&(v, p, n, _)| {
            let mut around: SmallVec<[u32; 16]> = star
                .of(v)
                .iter()
                .flat_map(|&ti| mesh.triangles[ti as usize])
                .filter(|&w| w as usize != v)
                .collect();
            around.sort_unstable();
            around.dedup();
            let at = (p, n);
            around
                .iter()
                .map(|&w| midpoint_tolerance(tau, at, (pos[w as usize], normals[w as usize])))
                .collect()
        })
        .collect();
    let mids: Vec<DVec3> = edges.iter().flatten().map(|&(m, _)| m).collect();
    let mut measured = grads_at(f, t, &mids).into_iter();
    candidates
        .into_iter()
        .zip(&edges)
        .filter(|(_, edges)| {
            // Every measurement is consumed, whatever the verdict.
            let far = edges
                .iter()
                .zip(measured.by_ref())
                .filter(|&(&(_, tol), (v, g))| beyond(v, g, tol))
                .count();
            far == 0
        })
        .map(|(c, _)| c)
        .collect()
}
