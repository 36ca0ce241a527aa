//! An evaluator sampled at many independent points of space at one time
//! `t`: values and gradients at every point of a list, in parallel chunks
//! of batch calls ([`Evaluator::point_batch`],
//! [`Evaluator::point_grad_batch`]). The results are, point by point,
//! exactly the single calls' (the [`Evaluator`] contract), so callers may
//! switch between the two freely.

use glam::DVec3;
use rayon::prelude::*;

use crate::eval::Evaluator;

/// Points per batch call.
pub(crate) const CHUNK: usize = 256;

/// `f(p, t)` at every `p` of `pts`.
pub(crate) fn values_at<E: Evaluator + ?Sized>(f: &E, t: f64, pts: &[DVec3]) -> Vec<f64> {
    let mut out = vec![0.0; pts.len()];
    out.par_chunks_mut(CHUNK)
        .zip(pts.par_chunks(CHUNK))
        .for_each(|(out, pts)| {
            let col = |k: usize| pts.iter().map(|p| p[k]).collect::<Vec<f64>>();
            f.point_batch(&col(0), &col(1), &col(2), t, out);
        });
    out
}

/// `(f, ∇f)` at `(p, t)` for every `p` of `pts`.
pub(crate) fn grads_at<E: Evaluator + ?Sized>(f: &E, t: f64, pts: &[DVec3]) -> Vec<(f64, DVec3)> {
    let mut out = vec![(0.0, [0.0; 3]); pts.len()];
    out.par_chunks_mut(CHUNK)
        .zip(pts.par_chunks(CHUNK))
        .for_each(|(out, pts)| {
            let arr: Vec<[f64; 3]> = pts.iter().map(|p| p.to_array()).collect();
            f.point_grad_batch(&arr, t, out);
        });
    out.into_iter()
        .map(|(v, g)| (v, DVec3::from_array(g)))
        .collect()
}

/// `∇f/‖∇f‖` at `(p, t)` for every `p` of `pts` (zero where the gradient
/// vanishes or is not finite).
pub(crate) fn normals_at<E: Evaluator + ?Sized>(f: &E, t: f64, pts: &[DVec3]) -> Vec<DVec3> {
    grads_at(f, t, pts)
        .into_iter()
        .map(|(_, g)| g.normalize_or_zero())
        .collect()
}

/// Where `f` has a kink exactly at a point (a `min` or `max` whose two
/// sides tie there, as on a face two CSG primitives share), the gradient
/// there is one side's, and may point into the solid. For every `i` with
/// `normals[i]·outward[i] < 0` (`outward`: a direction in which `f`
/// grows across the surface at `pts[i]`, such as the sign change a root
/// was bracketed on), the normal is replaced by the one-sided gradient
/// just outside `pts[i]` along `outward[i]` — or just inside — that
/// agrees with it; it stays as it was when neither does. So is a zero
/// normal (a singular point of f, where `x y = 0`'s planes cross: there
/// the gradient vanishes, and just off the point it is one sheet's or
/// the bisector's). `outward` may be
/// shorter than `pts` (the points past it keep their normals).
pub(crate) fn orient_at_kinks<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    pts: &[DVec3],
    normals: &mut [DVec3],
    outward: &[DVec3],
) {
    let flipped: Vec<usize> = (0..outward.len())
        .filter(|&i| normals[i].dot(outward[i]) < 0.0 || normals[i] == DVec3::ZERO)
        .collect();
    if flipped.is_empty() {
        return;
    }
    // A step far below any cell, far above the rounding of the point.
    let step = |i: usize| {
        let d = outward[i].normalize_or_zero();
        d * (KINK_STEP * pts[i].abs().max_element().max(1.0))
    };
    let probes: Vec<DVec3> = flipped
        .iter()
        .flat_map(|&i| [pts[i] + step(i), pts[i] - step(i)])
        .collect();
    let sides = normals_at(f, t, &probes);
    for (&i, pair) in flipped.iter().zip(sides.chunks_exact(2)) {
        if let Some(&n) = pair.iter().find(|n| n.dot(outward[i]) > 0.0) {
            normals[i] = n;
        }
    }
}

/// The probe distance of [`orient_at_kinks`], relative to the point's
/// magnitude: about 4500 ulps.
const KINK_STEP: f64 = 1e-12;
