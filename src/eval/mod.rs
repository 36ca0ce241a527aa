//! Reference evaluators: simple, obviously correct interpreters over the IR
//! (`point`, `interval`, `grad`), the oracles that the JIT and the mesher are
//! tested against, and [`Evaluator`], the one trait through which everything
//! downstream (octree, extraction, mesher, twin tracker) evaluates a
//! function.
//!
//! # Contract
//!
//! * [`point::eval`]: the IR's point semantics in f64 (IEEE operations,
//!   correctly rounded transcendentals, NaN outside every op's domain).
//! * [`interval::eval`]: a guaranteed enclosure of the program over a box,
//!   with the decoration "defined and continuous everywhere on the box"
//!   (see [`crate::interval`] for the op-level contract). In particular the
//!   interval of a degenerate box `[p, p]` contains the point value at `p`
//!   whenever that is not NaN, and if the point value at a point of the box
//!   is NaN because an op left its domain, the flag is false.
//! * [`grad::eval`]: enclosures of the value and of `∂/∂x, ∂/∂y, ∂/∂z` by
//!   forward-mode AD in interval arithmetic; [`grad::eval_point`]: the same
//!   rules in f64. Point gradients lie in the interval gradients.
//!
//! Each evaluator walks the instruction list once, front to back (no
//! recursion), holding one value per instruction.
//!
//! # The evaluator trait
//!
//! [`Evaluator`] is the common face of every implementation of the kernels:
//! the reference interpreters ([`Reference`]), the JIT
//! ([`crate::jit::Kernels`]) and a compiled [`crate::Surface`]. One test
//! suite (`tests/common`, `backend_suite!`) runs against all of them. Inputs
//! are `[x, y, z, t]`. Each batch method must give, element by element,
//! exactly what the single method gives (bit for bit, every NaN equal to
//! every NaN); the default bodies are loops over the single methods, and an
//! implementation overrides them only with something faster that keeps that
//! promise. Batch methods panic when `out` and the inputs differ in length
//! (a caller's bug, not a data condition). Batch shapes:
//!
//! * [`Evaluator::point_batch`]: struct of arrays, `xs ys zs` and one `t`,
//!   as the JIT's batch point kernel reads them;
//! * [`Evaluator::point_grad_batch`]: array of points `[x, y, z]` and one
//!   `t`, results `(f, ∇f)` per point (the mesher's positions are points);
//! * [`Evaluator::interval_batch`], [`Evaluator::grad_batch`]: array of
//!   boxes.
//!
//! Implementations are `Sync`: the octree and the mesher evaluate from
//! several threads at once.

pub mod grad;
pub mod interval;
pub mod point;
pub mod prune;
pub mod sample;
pub mod within;

pub use grad::GradEval;

use crate::interval::{DecInterval, Interval};
use crate::ir::Program;

/// The kernels of a compiled function. See the module doc.
pub trait Evaluator: Sync {
    /// Point value (NaN outside the domain).
    fn point(&self, p: [f64; 4]) -> f64;
    /// Point value and gradient `(∂/∂x, ∂/∂y, ∂/∂z)` by forward-mode AD in
    /// f64 ([`grad::eval_point`]); the value is [`Evaluator::point`]'s.
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]);
    /// Decorated enclosure over a box.
    fn interval(&self, b: [Interval; 4]) -> DecInterval;
    /// Interval value and interval gradient over a box.
    fn grad(&self, b: [Interval; 4]) -> GradEval;

    /// The program this evaluator runs, when it has one: the octree prunes
    /// it per cell ([`prune`]) and evaluates the pruned programs with the
    /// reference interpreters. `None` (the default) disables pruning.
    fn program(&self) -> Option<&Program> {
        None
    }

    /// Interval value and derivatives along the columns of `frame` over a
    /// box ([`grad::eval_in`]), which the octree asks across `min`/`max`
    /// creases only. The default interprets [`Evaluator::program`] (the
    /// JIT has no kernel for it); without a program it answers the whole
    /// line, not defined, which certifies nothing.
    fn grad_in(&self, b: [Interval; 4], frame: &grad::Frame) -> GradEval {
        match self.program() {
            Some(p) => grad::eval_in(p, b, frame),
            None => WHOLE_GRAD,
        }
    }

    /// `out[i] = point([xs[i], ys[i], zs[i], t])`; all four slices of one
    /// length.
    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        check_len(out.len(), &[xs.len(), ys.len(), zs.len()]);
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.point([xs[i], ys[i], zs[i], t]);
        }
    }
    /// `out[i] = point_grad([pts[i][0], pts[i][1], pts[i][2], t])`.
    fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64, out: &mut [(f64, [f64; 3])]) {
        check_len(out.len(), &[pts.len()]);
        for (o, p) in out.iter_mut().zip(pts) {
            *o = self.point_grad([p[0], p[1], p[2], t]);
        }
    }
    /// `out[i] = interval(boxes[i])`.
    fn interval_batch(&self, boxes: &[[Interval; 4]], out: &mut [DecInterval]) {
        check_len(out.len(), &[boxes.len()]);
        for (o, b) in out.iter_mut().zip(boxes) {
            *o = self.interval(*b);
        }
    }
    /// `out[i] = grad(boxes[i])`.
    fn grad_batch(&self, boxes: &[[Interval; 4]], out: &mut [GradEval]) {
        check_len(out.len(), &[boxes.len()]);
        for (o, b) in out.iter_mut().zip(boxes) {
            *o = self.grad(*b);
        }
    }
}

/// The whole line, flagged not defined: a sound enclosure of anything (an
/// evaluator that cannot enclose may answer it; also a filler for output
/// buffers).
pub const WHOLE: DecInterval = DecInterval {
    iv: Interval::ENTIRE,
    defined: false,
};

/// [`WHOLE`] for the value and every partial derivative.
pub const WHOLE_GRAD: GradEval = GradEval {
    value: Interval::ENTIRE,
    grad: [Interval::ENTIRE; 3],
    defined: false,
};

/// Panics unless every input length is `n` (see the module doc).
pub(crate) fn check_len(n: usize, inputs: &[usize]) {
    assert!(
        inputs.iter().all(|&m| m == n),
        "batch lengths differ: inputs {inputs:?}, output {n}"
    );
}

/// The reference interpreters over a program.
#[derive(Clone, Debug)]
pub struct Reference(pub Program);

impl Evaluator for Reference {
    fn point(&self, p: [f64; 4]) -> f64 {
        point::eval(&self.0, p)
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        grad::eval_point(&self.0, p)
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        interval::eval(&self.0, b)
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        grad::eval(&self.0, b)
    }
    fn program(&self) -> Option<&Program> {
        Some(&self.0)
    }
}

impl<E: Evaluator + ?Sized> Evaluator for &E {
    fn point(&self, p: [f64; 4]) -> f64 {
        (**self).point(p)
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        (**self).point_grad(p)
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        (**self).interval(b)
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        (**self).grad(b)
    }
    fn program(&self) -> Option<&Program> {
        (**self).program()
    }
    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        (**self).point_batch(xs, ys, zs, t, out)
    }
    fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64, out: &mut [(f64, [f64; 3])]) {
        (**self).point_grad_batch(pts, t, out)
    }
    fn interval_batch(&self, boxes: &[[Interval; 4]], out: &mut [DecInterval]) {
        (**self).interval_batch(boxes, out)
    }
    fn grad_batch(&self, boxes: &[[Interval; 4]], out: &mut [GradEval]) {
        (**self).grad_batch(boxes, out)
    }
    fn grad_in(&self, b: [Interval; 4], frame: &grad::Frame) -> GradEval {
        (**self).grad_in(b, frame)
    }
}
