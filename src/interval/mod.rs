//! Interval arithmetic with outward rounding: the soundness core of isoc.
//!
//! (Helper B: write the full contract here — rounding strategy, decoration
//! semantics, empty-interval representation.)

use crate::ir::{BinOp, UnOp};

/// A closed interval `[lo, hi]` of reals, bounds possibly infinite.
/// The empty interval is `lo = +∞, hi = -∞`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

/// An interval plus the decoration "the function was defined and continuous
/// on the whole input box" (IEEE 1788 `dac`/`com` collapsed into one flag).
/// When `defined` is false, `iv` still encloses the range over the part of
/// the box where the function is defined (possibly empty).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecInterval {
    pub iv: Interval,
    pub defined: bool,
}

/// Enclosure of `op(a)` for every `x ∈ a` where `op` is defined, and whether
/// `op` is defined and continuous on all of `a`.
pub fn unary(op: UnOp, a: Interval) -> (Interval, bool) {
    let _ = (op, a);
    todo!()
}

/// Enclosure of `op(a, b)`, as [`unary`].
pub fn binary(op: BinOp, a: Interval, b: Interval) -> (Interval, bool) {
    let _ = (op, a, b);
    todo!()
}

/// Enclosure of `a^n` (exact monotone rules, outward rounded).
pub fn powi(a: Interval, n: i64) -> (Interval, bool) {
    let _ = (a, n);
    todo!()
}
