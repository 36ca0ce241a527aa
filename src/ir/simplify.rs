//! Algebraic simplification, applied by [`Builder`] as instructions are
//! built (after constant folding, before hash-consing).
//!
//! Every rule preserves the point value bit for bit for *every* input,
//! NaN and infinities included, and the interval meaning (an enclosure of
//! the same real function, never wider). That rules out tempting rewrites:
//! `a - a → 0` and `a * 0 → 0` are wrong where `a` is NaN or infinite, and
//! `(a^m)^n → a^(m·n)` changes overflow and rounding. The rules:
//!
//! | rule | why it is exact |
//! |---|---|
//! | `a + 0 → a`, `a - 0 → a` | IEEE: `a + 0 = a` except `-0 + 0 = +0`; for the zero set that is immaterial, and no op here distinguishes ±0 except `atan2` and `div` — so it is applied only when the other operand is `+0`… see note |
//! | `a * 1 → a`, `a / 1 → a` | exact in IEEE |
//! | `a * -1 → -a`, `0 - a` stays | exact |
//! | `a * a → square a` | same rounding, tighter interval (dependency) |
//! | `-(-a) → a`, `abs(-a) → abs a`, `square(-a) → square a`, `abs(abs a) → abs a`, `square(abs a) → square a` | exact |
//! | `a + (-b) → a - b`, `a - (-b) → a + b` | exact |
//! | `a^1 → a`, `a^2 → square a`, `a^0 → 1` | the point rule for `powi` |
//!
//! Note on `a + 0`: `-0 + 0 = +0`, so the rewrite may turn a `-0` into
//! `+0`. Only the sign of a zero differs; `atan2(±0, x<0)` and `1/±0` then
//! differ — but the IR defines `1/0` as NaN regardless of sign, and
//! `atan2` at `y = ±0, x < 0` is on the branch cut, flagged as not
//! continuous by the interval kernels. So the surface is unchanged.

use super::{BinOp, Builder, Op, UnOp, Value};

fn is_num(b: &Builder, v: Value, x: f64) -> bool {
    b.as_const(v).is_some_and(|c| {
        c.is_exact() && c.value == x && c.value.is_sign_positive() == x.is_sign_positive()
    })
}

fn negated(b: &Builder, v: Value) -> Option<Value> {
    match b.op(v) {
        Op::Unary(UnOp::Neg, a) => Some(a),
        _ => None,
    }
}

/// A cheaper equivalent of `op(a)`, if a rule applies.
pub fn unary(b: &mut Builder, op: UnOp, a: Value) -> Option<Value> {
    let inner = b.op(a);
    match (op, inner) {
        (UnOp::Neg, Op::Unary(UnOp::Neg, x)) => Some(x),
        (UnOp::Abs | UnOp::Square, Op::Unary(UnOp::Neg | UnOp::Abs, x)) => Some(b.unary(op, x)),
        (UnOp::Abs, Op::Unary(UnOp::Square, _)) => Some(a),
        _ => None,
    }
}

/// A cheaper equivalent of `op(x, y)`, if a rule applies.
pub fn binary(b: &mut Builder, op: BinOp, x: Value, y: Value) -> Option<Value> {
    match op {
        BinOp::Add => {
            if is_num(b, y, 0.0) {
                return Some(x);
            }
            if is_num(b, x, 0.0) {
                return Some(y);
            }
            if let Some(ny) = negated(b, y) {
                return Some(b.binary(BinOp::Sub, x, ny));
            }
            if let Some(nx) = negated(b, x) {
                return Some(b.binary(BinOp::Sub, y, nx));
            }
            None
        }
        BinOp::Sub => {
            if is_num(b, y, 0.0) {
                return Some(x);
            }
            if let Some(ny) = negated(b, y) {
                return Some(b.binary(BinOp::Add, x, ny));
            }
            None
        }
        BinOp::Mul => {
            if x == y {
                return Some(b.unary(UnOp::Square, x));
            }
            for (k, other) in [(x, y), (y, x)] {
                if is_num(b, k, 1.0) {
                    return Some(other);
                }
                if is_num(b, k, -1.0) {
                    return Some(b.unary(UnOp::Neg, other));
                }
            }
            None
        }
        BinOp::Div => is_num(b, y, 1.0).then_some(x),
        // `and a a = or a a = a` for every `a` (NaN included).
        BinOp::Min | BinOp::Max | BinOp::And | BinOp::Or => (x == y).then_some(x),
        // `pow(a, c)` is `exp(c·ln a)`, NaN for a < 0 even when c is an
        // integer: it is *not* `powi`. The language's `^` picks `powi` for
        // integer constants before it gets here ([`Builder::power`]).
        BinOp::Pow | BinOp::Atan2 | BinOp::Compare | BinOp::Mod => None,
    }
}

/// A cheaper equivalent of `a^n`, if a rule applies.
pub fn powi(b: &mut Builder, a: Value, n: i64) -> Option<Value> {
    match n {
        0 => Some(b.num(1.0)),
        1 => Some(a),
        2 => Some(b.unary(UnOp::Square, a)),
        _ if n % 2 == 0 => match b.op(a) {
            Op::Unary(UnOp::Neg | UnOp::Abs, x) => Some(b.powi(x, n)),
            _ => None,
        },
        _ => None,
    }
}
