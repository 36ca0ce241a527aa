//! Interval-gradient evaluation by forward-mode automatic differentiation.

use crate::interval::Interval;
use crate::ir::Program;

/// `(F, ∂F/∂x, ∂F/∂y, ∂F/∂z)` enclosed over a box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradEval {
    pub value: Interval,
    pub grad: [Interval; 3],
    /// False when some op was not defined and continuous (or not
    /// differentiable) somewhere on the box.
    pub defined: bool,
}

/// Interval value and gradient over the box `[x, y, z, t]`.
pub fn eval(program: &Program, input: [Interval; 4]) -> GradEval {
    let _ = (program, input);
    todo!()
}

/// Point value and gradient at `[x, y, z, t]` (forward-mode AD in f64).
pub fn eval_point(program: &Program, input: [f64; 4]) -> (f64, [f64; 3]) {
    let _ = (program, input);
    todo!()
}
