//! Reference evaluators: simple, obviously correct interpreters over the IR
//! (`point`, `interval`, `grad`), the oracles that the JIT and the mesher are
//! tested against.
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
//! [`Backend`] is the common face of every implementation of the three
//! kernels (the reference interpreters here, the JIT later), so that one
//! test suite (`tests/common`) runs against all of them.

pub mod grad;
pub mod interval;
pub mod point;

pub use grad::GradEval;

use crate::interval::{DecInterval, Interval};
use crate::ir::Program;

/// The three kernels of a compiled surface. Inputs are `[x, y, z, t]`.
pub trait Backend {
    /// Point value (NaN outside the domain).
    fn point(&self, p: [f64; 4]) -> f64;
    /// Decorated enclosure over a box.
    fn interval(&self, b: [Interval; 4]) -> DecInterval;
    /// Interval value and interval gradient over a box.
    fn grad(&self, b: [Interval; 4]) -> GradEval;
}

/// The reference interpreters over a program.
#[derive(Clone, Debug)]
pub struct Reference(pub Program);

impl Backend for Reference {
    fn point(&self, p: [f64; 4]) -> f64 {
        point::eval(&self.0, p)
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        interval::eval(&self.0, b)
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        grad::eval(&self.0, b)
    }
}

impl<B: Backend + ?Sized> Backend for &B {
    fn point(&self, p: [f64; 4]) -> f64 {
        (**self).point(p)
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        (**self).interval(b)
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        (**self).grad(b)
    }
}
