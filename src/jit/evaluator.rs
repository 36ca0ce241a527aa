//! The JIT kernels as an [`Evaluator`]: single calls go to the single
//! entry points, batch calls to the batch entry points (one kernel call per
//! batch), whose results are bit for bit the single ones (tested by the
//! shared suite in `tests/jit/jit_vs_eval.rs`).
//!
//! Should the point-gradient kernels fail to compile, `point_grad` and
//! `point_grad_batch` fall back to the reference evaluator
//! ([`Kernels::point_grad`]'s contract), so the results do not change.

use super::Kernels;
use crate::eval::{Evaluator, GradEval, check_len};
use crate::interval::{DecInterval, Interval};

impl Evaluator for Kernels {
    fn point(&self, p: [f64; 4]) -> f64 {
        Kernels::point(self, p)
    }

    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        Kernels::point_grad(self, p)
    }

    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        Kernels::interval(self, b)
    }

    fn grad(&self, b: [Interval; 4]) -> GradEval {
        Kernels::grad(self, b)
    }

    fn program(&self) -> Option<&crate::ir::Program> {
        Some(Kernels::program(self))
    }

    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        check_len(out.len(), &[xs.len(), ys.len(), zs.len()]);
        Kernels::point_batch(self, xs, ys, zs, t, out).expect("lengths checked");
    }

    fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64, out: &mut [(f64, [f64; 3])]) {
        check_len(out.len(), &[pts.len()]);
        let col = |k: usize| pts.iter().map(|p| p[k]).collect::<Vec<f64>>();
        let (xs, ys, zs) = (col(0), col(1), col(2));
        let mut flat = vec![0.0; 4 * pts.len()];
        match Kernels::point_grad_batch(self, &xs, &ys, &zs, t, &mut flat) {
            Ok(()) => {
                for (o, r) in out.iter_mut().zip(flat.chunks_exact(4)) {
                    *o = (r[0], [r[1], r[2], r[3]]);
                }
            }
            // The kernel failed to compile: the single path falls back to
            // the reference evaluator.
            Err(_) => {
                for (o, p) in out.iter_mut().zip(pts) {
                    *o = Kernels::point_grad(self, [p[0], p[1], p[2], t]);
                }
            }
        }
    }

    fn interval_batch(&self, boxes: &[[Interval; 4]], out: &mut [DecInterval]) {
        check_len(out.len(), &[boxes.len()]);
        let input = flatten_boxes(boxes);
        let mut flat = vec![0.0; 2 * boxes.len()];
        let mut defined = vec![false; boxes.len()];
        Kernels::interval_batch(self, &input, &mut flat, &mut defined).expect("lengths checked");
        for ((o, r), d) in out.iter_mut().zip(flat.chunks_exact(2)).zip(defined) {
            *o = DecInterval {
                iv: Interval { lo: r[0], hi: r[1] },
                defined: d,
            };
        }
    }

    fn grad_batch(&self, boxes: &[[Interval; 4]], out: &mut [GradEval]) {
        check_len(out.len(), &[boxes.len()]);
        let input = flatten_boxes(boxes);
        let mut flat = vec![0.0; 8 * boxes.len()];
        let mut defined = vec![false; boxes.len()];
        Kernels::grad_batch(self, &input, &mut flat, &mut defined).expect("lengths checked");
        for ((o, r), d) in out.iter_mut().zip(flat.chunks_exact(8)).zip(defined) {
            let iv = |k: usize| Interval {
                lo: r[2 * k],
                hi: r[2 * k + 1],
            };
            *o = GradEval {
                value: iv(0),
                grad: [iv(1), iv(2), iv(3)],
                defined: d,
            };
        }
    }
}

/// Boxes as the batch kernels read them: 8 f64 per box,
/// `[x.lo, x.hi, y.lo, y.hi, z.lo, z.hi, t.lo, t.hi]`.
fn flatten_boxes(boxes: &[[Interval; 4]]) -> Vec<f64> {
    // A loop over fixed-size arrays: a nested `flat_map` has no size hint
    // and cost as much as a cheap kernel.
    let mut out = Vec::with_capacity(8 * boxes.len());
    for b in boxes {
        out.extend_from_slice(&[
            b[0].lo, b[0].hi, b[1].lo, b[1].hi, b[2].lo, b[2].hi, b[3].lo, b[3].hi,
        ]);
    }
    out
}
