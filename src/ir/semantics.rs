//! What each op means: its value at a point and its enclosure over a box.
//!
//! These are the definitions behind the table in [`crate::ir`]: the
//! reference interpreters ([`crate::eval`]), constant folding
//! ([`super::fold`]) and the JIT's helper calls all use these functions, so
//! each op is defined once.
//!
//! * `point_*`: f64 with the IR's point semantics (the contract is in
//!   [`crate::eval::point`]'s module doc): NaN outside an op's domain.
//! * `enclose_*`: an interval containing `op` of every point of the inputs
//!   where `op` is defined, outward rounded (the arithmetic is
//!   [`crate::interval`]'s), and whether `op` is defined and continuous on
//!   the whole input.

use super::{BinOp, UnOp};
use crate::interval::{self, Interval};

/// `op(a)` in f64 with the IR's point semantics (NaN outside the domain).
#[inline]
pub fn point_unary(op: UnOp, a: f64) -> f64 {
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
#[inline]
pub fn point_binary(op: BinOp, a: f64, b: f64) -> f64 {
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
#[inline]
pub fn point_powi(a: f64, n: i64) -> f64 {
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
    if n < 0 {
        point_binary(BinOp::Div, 1.0, p)
    } else {
        p
    }
}

/// Enclosure of `op(a)` for every `x ∈ a` where `op` is defined, and whether
/// `op` is defined and continuous on all of `a`.
#[inline]
pub fn enclose_unary(op: UnOp, a: Interval) -> (Interval, bool) {
    let (a, ok) = a.normalize();
    let (r, def) = match op {
        UnOp::Neg => (interval::arith::neg(a), true),
        UnOp::Abs => (interval::arith::abs(a), true),
        UnOp::Sqrt => interval::arith::sqrt(a),
        UnOp::Square => (interval::arith::square(a), true),
        UnOp::Exp => (interval::elementary::exp(a), true),
        UnOp::Log => interval::elementary::log(a),
        UnOp::Sin => (interval::trig::sin(a), true),
        UnOp::Cos => (interval::trig::cos(a), true),
        UnOp::Tan => interval::trig::tan(a),
        UnOp::Asin => interval::elementary::asin(a),
        UnOp::Acos => interval::elementary::acos(a),
        UnOp::Atan => (interval::elementary::atan(a), true),
        UnOp::Floor => interval::discrete::step_fn(a, f64::floor),
        UnOp::Ceil => interval::discrete::step_fn(a, f64::ceil),
        UnOp::Round => interval::discrete::step_fn(a, f64::round),
        UnOp::Not => interval::discrete::not(a),
    };
    (r, def && ok && !a.is_empty())
}

/// Enclosure of `op(a, b)`, as [`enclose_unary`].
#[inline]
pub fn enclose_binary(op: BinOp, a: Interval, b: Interval) -> (Interval, bool) {
    let (a, oka) = a.normalize();
    let (b, okb) = b.normalize();
    let (r, def) = match op {
        BinOp::Add => (interval::arith::add(a, b), true),
        BinOp::Sub => (interval::arith::sub(a, b), true),
        BinOp::Mul => (interval::arith::mul(a, b), true),
        BinOp::Div => interval::arith::div(a, b),
        BinOp::Min => (interval::arith::min(a, b), true),
        BinOp::Max => (interval::arith::max(a, b), true),
        BinOp::Atan2 => interval::elementary::atan2(a, b),
        BinOp::Pow => interval::elementary::pow(a, b),
        BinOp::Compare => interval::discrete::compare(a, b),
        BinOp::Mod => interval::discrete::rem_euclid(a, b),
        BinOp::And => interval::discrete::and(a, b),
        BinOp::Or => interval::discrete::or(a, b),
    };
    (r, def && oka && okb && !a.is_empty() && !b.is_empty())
}

/// Enclosure of `a^n` (exact monotone rules, outward rounded).
pub fn enclose_powi(a: Interval, n: i64) -> (Interval, bool) {
    let (a, ok) = a.normalize();
    if n == 0 {
        // 1 for every input, NaN and empty included (point semantics).
        return (Interval::point(1.0), ok);
    }
    let (r, def) = interval::arith::powi(a, n);
    (r, def && ok && !a.is_empty())
}
