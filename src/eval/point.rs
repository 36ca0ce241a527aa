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
//! * `powi(a, n)` is the right-to-left binary method (see [`powi`]); the
//!   interval evaluator encloses exactly this chain.
//!
//! Together with [`crate::interval`], these satisfy: if every input lies in
//! an interval, the point result is NaN or lies in the interval result (the
//! property the shared test suite checks for whole programs).

use crate::ir::{BinOp, Op, Program, UnOp, Value};

/// `op(a)` in f64 with the IR's point semantics (NaN outside the domain).
pub fn unary(op: UnOp, a: f64) -> f64 {
    match op {
        UnOp::Neg => -a,
        UnOp::Abs => a.abs(),
        UnOp::Sqrt => {
            if a < 0.0 {
                f64::NAN
            } else {
                a.sqrt()
            }
        }
        UnOp::Square => a * a,
        UnOp::Exp => core_math::exp(a),
        UnOp::Log => {
            if a > 0.0 {
                core_math::log(a)
            } else {
                f64::NAN
            }
        }
        UnOp::Sin => core_math::sin(a),
        UnOp::Cos => core_math::cos(a),
        UnOp::Tan => core_math::tan(a),
        UnOp::Asin => {
            if (-1.0..=1.0).contains(&a) {
                core_math::asin(a)
            } else {
                f64::NAN
            }
        }
        UnOp::Acos => {
            if (-1.0..=1.0).contains(&a) {
                core_math::acos(a)
            } else {
                f64::NAN
            }
        }
        UnOp::Atan => core_math::atan(a),
        UnOp::Floor => a.floor(),
        UnOp::Ceil => a.ceil(),
        UnOp::Round => a.round(),
        UnOp::Not => {
            if a.is_nan() {
                f64::NAN
            } else if a == 0.0 {
                1.0
            } else {
                0.0
            }
        }
    }
}

/// `op(a, b)` in f64 with the IR's point semantics.
pub fn binary(op: BinOp, a: f64, b: f64) -> f64 {
    match op {
        BinOp::Add => a + b,
        BinOp::Sub => a - b,
        BinOp::Mul => a * b,
        BinOp::Div => {
            if b == 0.0 {
                f64::NAN
            } else {
                a / b
            }
        }
        // IEEE 754-2019 minimum/maximum: NaN if either operand is NaN, and
        // −0 < +0 (Rust's `f64::min`/`max` leave the zero of a ±0 tie
        // unspecified; the JIT's `fmin`/`fmax` order them like this).
        BinOp::Min => {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else if a == b {
                if a.is_sign_negative() { a } else { b }
            } else {
                a.min(b)
            }
        }
        BinOp::Max => {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else if a == b {
                if a.is_sign_positive() { a } else { b }
            } else {
                a.max(b)
            }
        }
        BinOp::Atan2 => {
            if a == 0.0 && b == 0.0 {
                f64::NAN
            } else {
                core_math::atan2(a, b)
            }
        }
        BinOp::Pow => {
            if a > 0.0 && !b.is_nan() {
                core_math::pow(a, b)
            } else {
                f64::NAN
            }
        }
        BinOp::Compare => {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else if a < b {
                -1.0
            } else if a > b {
                1.0
            } else {
                0.0
            }
        }
        // `%` is exact; NaN for b = 0 or an infinite a.
        BinOp::Mod => a.rem_euclid(b),
        BinOp::And => {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else if a == 0.0 {
                a
            } else {
                b
            }
        }
        BinOp::Or => {
            if a.is_nan() || b.is_nan() {
                f64::NAN
            } else if a != 0.0 {
                a
            } else {
                b
            }
        }
    }
}

/// `a^n` by repeated squaring, right to left: the accumulator starts as the
/// first base whose bit of `|n|` is set and is multiplied (`acc · base`) by
/// each later one, the base being squared (`base · base`) per bit. `n = 0`
/// gives 1 for every `a` (NaN included); `n < 0` gives `1 / a^|n|`, NaN when
/// that divides by zero.
pub fn powi(a: f64, n: i64) -> f64 {
    if n == 0 {
        return 1.0;
    }
    let mut e = n.unsigned_abs();
    let mut acc: Option<f64> = None;
    let mut base = a;
    loop {
        if e & 1 == 1 {
            acc = Some(match acc {
                None => base,
                Some(r) => r * base,
            });
        }
        e >>= 1;
        if e == 0 {
            break;
        }
        base = base * base;
    }
    let p = acc.unwrap_or(1.0);
    if n < 0 { binary(BinOp::Div, 1.0, p) } else { p }
}

/// The value of one instruction given the values before it.
/// An operand that does not refer to an earlier value (a malformed
/// program) reads as NaN rather than panicking.
pub fn step(op: &Op, vals: &[f64], input: [f64; 4]) -> f64 {
    let get = |v: Value| vals.get(v.index()).copied().unwrap_or(f64::NAN);
    match *op {
        Op::Var(v) => input[v.index()],
        Op::Const(c) => c.value,
        Op::Unary(u, a) => unary(u, get(a)),
        Op::Binary(b, x, y) => binary(b, get(x), get(y)),
        Op::Powi(a, n) => powi(get(a), n),
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
