//! Point evaluation in f64: the IR's point semantics, one instruction at a
//! time.
//!
//! # Contract
//!
//! * `+ − ×`, `sqrt`, `neg`, `abs`, `square = a·a` are the IEEE 754
//!   round-to-nearest operations; `exp log sin cos tan asin acos atan atan2
//!   pow` are the correctly rounded CORE-MATH functions.
//! * Outside an op's domain the value is NaN, never an infinity: `sqrt` of a
//!   negative, `log` of a non-positive (`log 0` is NaN, not `-∞`), division
//!   by (either) zero, `pow` with a base `≤ 0`, `asin`/`acos` outside
//!   `[-1, 1]`, `atan2(0, 0)`.
//! * `floor ceil round` are `f64`'s (round: ties away from zero, as
//!   Fidget); `not a` is 1 at `a = 0`, else 0; `compare a b` is −1/0/1;
//!   `mod a b` is `a.rem_euclid(b)` (Fidget's `mod`, in `[0, |b|]`, NaN for
//!   `b = 0`); `and a b` is `a` if `a == 0` else `b`; `or a b` is `a` if
//!   `a != 0` else `b`.
//! * NaN propagates through every op (`min`/`max` included, unlike
//!   `f64::min`), with one exception fixed by the IR: `a^0 = 1` for every
//!   `a`. `min`/`max` order `−0 < +0` (IEEE 754-2019 minimum/maximum).
//! * `powi(a, n)` is the right-to-left binary method (see [`crate::ir::semantics::point_powi`]); the
//!   interval evaluator encloses exactly this chain.
//!
//! Together with [`crate::interval`], these satisfy: if every input lies in
//! an interval, the point result is NaN or lies in the interval result (the
//! property the shared test suite checks for whole programs).

use crate::ir::semantics::{point_binary, point_powi, point_unary};
use crate::ir::{Op, Program, Value};

/// The value of one instruction given the values before it.
/// An operand that does not refer to an earlier value (a malformed
/// program) reads as NaN rather than panicking.
pub fn step(op: &Op, vals: &[f64], input: [f64; 4]) -> f64 {
    let get = |v: Value| vals.get(v.index()).copied().unwrap_or(f64::NAN);
    match *op {
        Op::Var(v) => input[v.index()],
        Op::Const(c) => c.value,
        Op::Unary(u, a) => point_unary(u, get(a)),
        Op::Binary(b, x, y) => point_binary(b, get(x), get(y)),
        Op::Powi(a, n) => point_powi(get(a), n),
    }
}

/// The values of all instructions at `[x, y, z, t]`, in program order.
pub fn eval_all(program: &Program, input: [f64; 4]) -> Vec<f64> {
    let mut vals = Vec::with_capacity(program.insts.len());
    for op in &program.insts {
        let v = step(op, &vals, input);
        vals.push(v);
    }
    vals
}

/// Programs up to this length are evaluated in a buffer on the stack
/// (pruned programs are short; no allocation per point).
const STACK: usize = 32;

/// Value of the program at `[x, y, z, t]`.
pub fn eval(program: &Program, input: [f64; 4]) -> f64 {
    let n = program.insts.len();
    if n <= STACK {
        let mut vals = [0.0f64; STACK];
        for (i, op) in program.insts.iter().enumerate() {
            vals[i] = step(op, &vals[..i], input);
        }
        return vals[..n]
            .get(program.output.index())
            .copied()
            .unwrap_or(f64::NAN);
    }
    eval_all(program, input)
        .get(program.output.index())
        .copied()
        .unwrap_or(f64::NAN)
}
