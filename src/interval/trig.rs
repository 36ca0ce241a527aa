//! `sin`, `cos`, `tan` with conservative range reduction.
//!
//! The critical points of all three are the multiples `kπ/2`: extrema of
//! `sin` at odd `k` (`+1` for `k ≡ 1`, `-1` for `k ≡ 3 (mod 4)`), of `cos` at
//! even `k` (`+1` for `k ≡ 0`, `-1` for `k ≡ 2`), poles of `tan` at odd `k`.
//! Between two consecutive critical points each function is monotone, so its
//! range over `[lo, hi]` is the hull of its values at `lo`, `hi` and at the
//! critical points inside.
//!
//! Which `k` are inside is decided by an outward-rounded enclosure
//! `[t_lo, t_hi] ⊇ {x·2/π : x ∈ [lo, hi]}` (with `2/π` itself enclosed
//! between two floats). Every integer in `[t_lo, t_hi]` is treated as a
//! critical point of the argument: a `kπ/2` that floating point cannot place
//! on one side of a bound is included — wider, never narrower. Arguments
//! beyond `|x·2/π| > 2^52` (where consecutive floats are further apart than
//! the critical points' spacing), infinite bounds, or a reduced interval
//! holding four or more integers give the full range (`[-1, 1]`; entire and
//! not defined for `tan`).

use super::Interval;
use super::round::{self, Dir};

const TWO_POW_52: f64 = 4_503_599_627_370_496.0;

/// The integers `k` with `kπ/2` possibly in `a`, as `(first, last)` floats
/// (empty when `first > last`), or `None` when there are too many to matter
/// (four or more) or the argument is unbounded or huge.
fn critical(a: Interval) -> Option<(f64, f64)> {
    if !a.lo.is_finite() || !a.hi.is_finite() {
        return None;
    }
    let c = std::f64::consts::FRAC_2_PI;
    let (c_lo, c_hi) = (c.next_down(), c.next_up());
    let t_lo = round::mul(a.lo, if a.lo >= 0.0 { c_lo } else { c_hi }, Dir::Down);
    let t_hi = round::mul(a.hi, if a.hi >= 0.0 { c_hi } else { c_lo }, Dir::Up);
    if !(t_lo.abs() <= TWO_POW_52 && t_hi.abs() <= TWO_POW_52) {
        return None;
    }
    let (first, last) = (t_lo.ceil(), t_hi.floor());
    if last - first >= 3.0 {
        return None;
    }
    Some((first, last))
}

/// Lower and upper bounds of a correctly rounded `f(x)`, exact at `x = 0`
/// when `exact_at_zero`.
fn bounds(f: fn(f64) -> f64, x: f64, exact_at_zero: bool) -> (f64, f64) {
    let r = f(x);
    let exact = exact_at_zero && x == 0.0;
    (round::cr(r, exact, Dir::Down), round::cr(r, exact, Dir::Up))
}

/// Shared body of `sin` and `cos`: `max_at`/`min_at` are the residues of
/// `k mod 4` where the function is `+1`/`-1`.
fn sin_cos(a: Interval, f: fn(f64) -> f64, max_at: f64, min_at: f64) -> Interval {
    if a.is_empty() {
        return Interval::EMPTY;
    }
    let full = Interval::new(-1.0, 1.0);
    let Some((first, last)) = critical(a) else {
        return full;
    };
    let (l1, h1) = bounds(f, a.lo, true);
    let (l2, h2) = bounds(f, a.hi, true);
    let (mut lo, mut hi) = (l1.min(l2), h1.max(h2));
    let mut k = first;
    while k <= last {
        let m = k.rem_euclid(4.0);
        if m == max_at {
            hi = 1.0;
        }
        if m == min_at {
            lo = -1.0;
        }
        k += 1.0;
    }
    Interval::new(lo.max(-1.0), hi.min(1.0))
}

/// `sin(a)`, in `[-1, 1]`.
pub fn sin(a: Interval) -> Interval {
    sin_cos(a, core_math::sin, 1.0, 3.0)
}

/// `cos(a)`, in `[-1, 1]` (`cos 0 = 1` is exact, so not stepped).
pub fn cos(a: Interval) -> Interval {
    sin_cos(a, core_math::cos, 0.0, 2.0)
}

/// `tan(a)`: increasing between poles; entire and not defined when `a` may
/// contain a pole `(2j+1)π/2`.
pub fn tan(a: Interval) -> (Interval, bool) {
    if a.is_empty() {
        return (Interval::EMPTY, false);
    }
    let Some((first, last)) = critical(a) else {
        return (Interval::ENTIRE, false);
    };
    let mut k = first;
    while k <= last {
        if k.rem_euclid(2.0) == 1.0 {
            return (Interval::ENTIRE, false);
        }
        k += 1.0;
    }
    let lo = bounds(core_math::tan, a.lo, true).0;
    let hi = bounds(core_math::tan, a.hi, true).1;
    (Interval::new(lo, hi), true)
}
