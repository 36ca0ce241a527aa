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
