//! Sound constant folding.
//!
//! Folding an operation on constants computes both halves of a [`Const`]:
//! the point value with the point evaluator's own per-op function (so a
//! folded program gives bit-for-bit the point values of the unfolded one),
//! and the enclosure with the interval evaluator's per-op function (so the
//! enclosure of the real result stays guaranteed — a value folded in
//! round-to-nearest is *not* a valid interval bound). Both come from
//! [`super::semantics`], which [`crate::eval`] uses too, so there is one
//! definition of each op.

use super::semantics::{
    enclose_binary, enclose_powi, enclose_unary, point_binary, point_powi, point_unary,
};
use super::{BinOp, Const, UnOp};
use crate::interval::Interval;

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
    let (iv, def) = enclose_unary(op, enclosure(a));
    make(point_unary(op, a.value), iv, a.defined && def)
}

/// `op(a, b)` folded.
pub fn binary(op: BinOp, a: Const, b: Const) -> Const {
    let (iv, def) = enclose_binary(op, enclosure(a), enclosure(b));
    make(
        point_binary(op, a.value, b.value),
        iv,
        a.defined && b.defined && def,
    )
}

/// `a^n` folded.
pub fn powi(a: Const, n: i64) -> Const {
    let (iv, def) = enclose_powi(enclosure(a), n);
    make(point_powi(a.value, n), iv, a.defined && def)
}
