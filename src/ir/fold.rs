//! Sound constant folding.
//!
//! Folding an operation on constants computes both halves of a [`Const`]:
//! the point value with the point evaluator's own per-op function (so a
//! folded program gives bit-for-bit the point values of the unfolded one),
//! and the enclosure with the interval evaluator's per-op function (so the
//! enclosure of the real result stays guaranteed — a value folded in
//! round-to-nearest is *not* a valid interval bound). Both come from the
//! same functions that [`crate::eval`] uses, so there is one definition of
//! each op.

use super::{BinOp, Const, UnOp};
use crate::eval::point;
use crate::interval::{self, Interval};

fn enclosure(c: Const) -> Interval {
    Interval { lo: c.lo, hi: c.hi }
}

fn make(value: f64, iv: Interval, defined: bool) -> Const {
    Const {
        value,
        lo: iv.lo,
        hi: iv.hi,
        defined: defined && !value.is_nan(),
    }
}

/// `op(a)` folded.
pub fn unary(op: UnOp, a: Const) -> Const {
    let (iv, def) = interval::unary(op, enclosure(a));
    make(point::unary(op, a.value), iv, a.defined && def)
}

/// `op(a, b)` folded.
pub fn binary(op: BinOp, a: Const, b: Const) -> Const {
    let (iv, def) = interval::binary(op, enclosure(a), enclosure(b));
    make(
        point::binary(op, a.value, b.value),
        iv,
        a.defined && b.defined && def,
    )
}

/// `a^n` folded.
pub fn powi(a: Const, n: i64) -> Const {
    let (iv, def) = interval::powi(enclosure(a), n);
    make(point::powi(a.value, n), iv, a.defined && def)
}
