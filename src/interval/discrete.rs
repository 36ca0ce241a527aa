//! Piecewise-constant and selecting ops (Fidget's `floor ceil round not
//! compare mod and or`): exact set-valued rules.
//!
//! Each function returns the enclosure and whether the op is *continuous*
//! on the whole input box; the flag is false whenever a jump (of `floor`
//! at an integer, of `compare` where `a = b`, of `and`/`or`/`not` where the
//! condition crosses zero, of `mod` at a multiple of `b`) may lie inside it.
//! Inputs are normalised intervals; an empty operand gives the empty set.
//!
//! | op | enclosure | continuous iff |
//! |---|---|---|
//! | `floor`, `ceil`, `round` | `[f lo, f hi]` (monotone, exact in f64) | `f lo = f hi` |
//! | `not a` | `[0,0]` if `0 ∉ a`, `[1,1]` if `a = [0,0]`, else `[0,1]` | not the last case |
//! | `compare a b` | `-1` if `a < b` surely, `1` if `a > b` surely, `0` if both are the same point, else the hull of the possible signs | one of the first three |
//! | `and a b` | `a` if `a = [0,0]`, `b` if `0 ∉ a`, else `b ∪ [0,0]` | not the last case |
//! | `or a b` | `a` if `0 ∉ a`, `b` if `a = [0,0]`, else `a ∪ b` | not the last case |
//! | `mod a b` | see [`rem_euclid`] | `a` within one period of a constant `b`, or `0 ≤ a < min abs b` |

use super::Interval;
use super::round::{self, Dir};

/// `[f(lo), f(hi)]` for a monotone non-decreasing integer-valued `f`
/// (floor, ceil, round): exact, continuous iff the two ends agree.
pub(crate) fn step_fn(a: Interval, f: fn(f64) -> f64) -> (Interval, bool) {
    if a.is_empty() {
        return (Interval::EMPTY, false);
    }
    let (lo, hi) = (f(a.lo), f(a.hi));
    (Interval::new(lo, hi), lo == hi)
}

/// `not a`: 1 where `a = 0`, else 0.
pub fn not(a: Interval) -> (Interval, bool) {
    if a.is_empty() {
        (Interval::EMPTY, false)
    } else if !a.contains(0.0) {
        (Interval::point(0.0), true)
    } else if a.lo == 0.0 && a.hi == 0.0 {
        (Interval::point(1.0), true)
    } else {
        (Interval::new(0.0, 1.0), false)
    }
}

/// `compare a b`: −1, 0 or 1 as `a < b`, `a = b`, `a > b`.
pub fn compare(a: Interval, b: Interval) -> (Interval, bool) {
    if a.is_empty() || b.is_empty() {
        return (Interval::EMPTY, false);
    }
    if a.hi < b.lo {
        return (Interval::point(-1.0), true);
    }
    if a.lo > b.hi {
        return (Interval::point(1.0), true);
    }
    if a.lo == a.hi && b.lo == b.hi && a.lo == b.lo {
        return (Interval::point(0.0), true);
    }
    // The intervals meet: 0 is possible; −1 when some x < some y, 1 when
    // some x > some y.
    let lo = if a.lo < b.hi { -1.0 } else { 0.0 };
    let hi = if a.hi > b.lo { 1.0 } else { 0.0 };
    (Interval::new(lo, hi), false)
}

/// `and a b`: `a` where `a = 0`, else `b`.
pub fn and(a: Interval, b: Interval) -> (Interval, bool) {
    if a.is_empty() || b.is_empty() {
        (Interval::EMPTY, false)
    } else if a.lo == 0.0 && a.hi == 0.0 {
        (a, true)
    } else if !a.contains(0.0) {
        (b, true)
    } else {
        (b.hull(Interval::point(0.0)), false)
    }
}

/// `or a b`: `a` where `a ≠ 0`, else `b`.
pub fn or(a: Interval, b: Interval) -> (Interval, bool) {
    if a.is_empty() || b.is_empty() {
        (Interval::EMPTY, false)
    } else if !a.contains(0.0) {
        (a, true)
    } else if a.lo == 0.0 && a.hi == 0.0 {
        (b, true)
    } else {
        (a.hull(b), false)
    }
}

/// `mod a b = a.rem_euclid(b)`, the least non-negative remainder, defined
/// for `b ≠ 0`, with values in `[0, |b|]` (the f64 result `r + |b|` of a
/// negative remainder `r` may round up to `|b|`).
///
/// * `b` a constant `c ≠ 0` and `a` inside one period `[k|c|, (k+1)|c|)`:
///   the increasing piece `a − k|c|`, bounds from the exact `%` plus an
///   outward-rounded `+ |c|`; continuous.
/// * `0 ≤ a < min |b|`: `a` itself; continuous.
/// * otherwise `[0, max |b|]`, not continuous (and not defined where
///   `0 ∈ b`; `b = [0, 0]` gives the empty set).
pub fn rem_euclid(a: Interval, b: Interval) -> (Interval, bool) {
    if a.is_empty() || b.is_empty() {
        return (Interval::EMPTY, false);
    }
    if b.lo == 0.0 && b.hi == 0.0 {
        return (Interval::EMPTY, false);
    }
    let mag = b.lo.abs().max(b.hi.abs());
    let general = (Interval::new(0.0, mag), false);
    if b.contains(0.0) {
        return general;
    }
    let mig = b.lo.abs().min(b.hi.abs());
    if a.lo >= 0.0 && a.hi < mig {
        return (a, true);
    }
    if b.lo != b.hi || !a.is_bounded() || !mig.is_finite() {
        return general;
    }
    let m = mig;
    // `%` is exact: t = a.lo − q·m with |t| < m and the sign of a.lo; the
    // real remainder is t (t ≥ 0) or t + m (t < 0).
    let t1 = a.lo % m;
    let w = round::sub(a.hi, a.lo, Dir::Up);
    let s = round::add(t1, w, Dir::Up);
    let same_period = if t1 < 0.0 { s < 0.0 } else { s < m };
    if !same_period {
        return general;
    }
    let t2 = a.hi % m;
    let lo = if t1 < 0.0 {
        round::add(t1, m, Dir::Down)
    } else {
        t1
    };
    let hi = if t2 < 0.0 {
        round::add(t2, m, Dir::Up)
    } else {
        t2
    };
    (Interval::new(lo.max(0.0), hi.min(m)), true)
}
