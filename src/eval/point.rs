//! Point evaluation in f64.

use crate::ir::{BinOp, Program, UnOp};

/// `op(a)` in f64 with the IR's point semantics (NaN outside the domain).
pub fn unary(op: UnOp, a: f64) -> f64 {
    let _ = (op, a);
    todo!()
}

/// `op(a, b)` in f64 with the IR's point semantics.
pub fn binary(op: BinOp, a: f64, b: f64) -> f64 {
    let _ = (op, a, b);
    todo!()
}

/// `a^n` by repeated squaring.
pub fn powi(a: f64, n: i64) -> f64 {
    let _ = (a, n);
    todo!()
}

/// Value of the program at `[x, y, z, t]`.
pub fn eval(program: &Program, input: [f64; 4]) -> f64 {
    let _ = (program, input);
    todo!()
}
