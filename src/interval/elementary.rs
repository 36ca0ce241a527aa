//! Monotone transcendental functions: `exp`, `log`, `asin`, `acos`, `atan`,
//! `atan2`, `pow`.
//!
//! Each bound is a correctly rounded CORE-MATH value moved one ulp outward
//! ([`super::round::cr`]; exact only at the trivial points `exp 0 = 1`,
//! `log 1 = 0`, `asin 0 = atan 0 = 0`, `acos 1 = 0`), then clamped to the
//! function's true range. Inputs are normalised intervals.

use super::round::{self, Dir};
use super::{HALF_PI_HI, HALF_PI_LO, Interval, PI_HI};

/// Lower and upper bound of `f(x)` for a correctly rounded `f`, exact when
/// `x == exact_at` (where `f(exact_at)` is a float).
fn bounds(f: fn(f64) -> f64, x: f64, exact_at: f64) -> (f64, f64) {
    let r = f(x);
    let exact = x == exact_at;
    (round::cr(r, exact, Dir::Down), round::cr(r, exact, Dir::Up))
}

fn clamp(r: Interval, lo: f64, hi: f64) -> Interval {
    if r.is_empty() {
        return r;
    }
    Interval::new(r.lo.max(lo), r.hi.min(hi))
}

/// For an odd increasing `f` (asin, atan): `f(x)` has the sign of `x`, so
/// the outward step never crosses 0.
fn same_sign(a: Interval, r: Interval) -> Interval {
    let lo = if a.lo >= 0.0 { r.lo.max(0.0) } else { r.lo };
    let hi = if a.hi <= 0.0 { r.hi.min(0.0) } else { r.hi };
    Interval::new(lo, hi)
}

/// `exp(a)`, increasing, `≥ 0`.
pub fn exp(a: Interval) -> Interval {
    if a.is_empty() {
        return Interval::EMPTY;
    }
    let mut lo = bounds(core_math::exp, a.lo, 0.0).0;
    let mut hi = bounds(core_math::exp, a.hi, 0.0).1;
    // exp x ≥ 1 for x ≥ 0 and ≤ 1 for x ≤ 0: keeps the one-ulp step from
    // crossing 1 (tighter, and monotone under shrinking).
    if a.lo >= 0.0 {
        lo = lo.max(1.0);
    }
    if a.hi <= 0.0 {
        hi = hi.min(1.0);
    }
    clamp(Interval::new(lo, hi), 0.0, f64::INFINITY)
}

/// `log(a)` over `a ∩ (0, ∞)`; not defined when `a` has members `≤ 0`
/// (then the lower bound is `-∞`; `log([0, 1]) = [-∞, 0]`).
pub fn log(a: Interval) -> (Interval, bool) {
    if a.is_empty() || a.hi <= 0.0 {
        return (Interval::EMPTY, false);
    }
    let defined = a.lo > 0.0;
    let lo = if defined {
        bounds(core_math::log, a.lo, 1.0).0
    } else {
        f64::NEG_INFINITY
    };
    let mut hi = bounds(core_math::log, a.hi, 1.0).1;
    // log x ≤ 0 for x ≤ 1 and ≥ 0 for x ≥ 1.
    if a.hi <= 1.0 {
        hi = hi.min(0.0);
    }
    let lo = if a.lo >= 1.0 { lo.max(0.0) } else { lo };
    (Interval::new(lo, hi), defined)
}

/// `asin(a)` over `a ∩ [-1, 1]`, increasing, in `[-π/2, π/2]`.
pub fn asin(a: Interval) -> (Interval, bool) {
    let d = a.intersect(Interval::new(-1.0, 1.0));
    if d.is_empty() {
        return (Interval::EMPTY, false);
    }
    let lo = bounds(core_math::asin, d.lo, 0.0).0;
    let hi = bounds(core_math::asin, d.hi, 0.0).1;
    (
        clamp(same_sign(d, Interval::new(lo, hi)), -HALF_PI_HI, HALF_PI_HI),
        d == a,
    )
}

/// `acos(a)` over `a ∩ [-1, 1]`, decreasing, in `[0, π]`.
pub fn acos(a: Interval) -> (Interval, bool) {
    let d = a.intersect(Interval::new(-1.0, 1.0));
    if d.is_empty() {
        return (Interval::EMPTY, false);
    }
    let lo = bounds(core_math::acos, d.hi, 1.0).0;
    let hi = bounds(core_math::acos, d.lo, 1.0).1;
    (clamp(Interval::new(lo, hi), 0.0, PI_HI), d == a)
}

/// `atan(a)`, increasing, in `[-π/2, π/2]`.
pub fn atan(a: Interval) -> Interval {
    if a.is_empty() {
        return Interval::EMPTY;
    }
    let lo = bounds(core_math::atan, a.lo, 0.0).0;
    let hi = bounds(core_math::atan, a.hi, 0.0).1;
    clamp(same_sign(a, Interval::new(lo, hi)), -HALF_PI_HI, HALF_PI_HI)
}

/// `atan2(y, x)`, the angle of the point `(x, y)` in `(-π, π]`.
///
/// * Box meets the open negative x-axis (`x < 0, y = 0`, the branch cut):
///   `[-π, π]`, not continuous.
/// * Box touches the origin (where atan2 is not defined) but not the cut:
///   it lies in the closed right half-plane, so the angle is in
///   `[-π/2, π/2]` (narrowed to one quadrant by the sign of `y`); not
///   defined.
/// * Otherwise the box is a convex set away from the cut and the origin, so
///   its angles form an interval whose ends are angles of corners (the
///   supporting rays from the origin touch vertices; an infinite corner is
///   the IEEE limit, e.g. `atan2(1, ∞) = 0`).
pub fn atan2(y: Interval, x: Interval) -> (Interval, bool) {
    if y.is_empty() || x.is_empty() {
        return (Interval::EMPTY, false);
    }
    let full = Interval::new(-PI_HI, PI_HI);
    let y_has_zero = y.lo <= 0.0 && y.hi >= 0.0;
    if y_has_zero && x.lo < 0.0 {
        return (full, false);
    }
    if y_has_zero && x.lo <= 0.0 {
        // x.lo == 0: the origin is on the box's left edge.
        let r = if y.lo == 0.0 && y.hi == 0.0 && x.hi == 0.0 {
            Interval::EMPTY
        } else if y.lo == 0.0 && y.hi == 0.0 {
            Interval::point(0.0)
        } else if y.lo >= 0.0 {
            Interval::new(0.0, HALF_PI_HI)
        } else if y.hi <= 0.0 {
            Interval::new(-HALF_PI_HI, 0.0)
        } else {
            Interval::new(-HALF_PI_HI, HALF_PI_HI)
        };
        return (r, false);
    }
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for yy in [y.lo, y.hi] {
        for xx in [x.lo, x.hi] {
            // Signed zeros cannot flip a result here: y ≠ 0 at every corner,
            // or else x > 0 everywhere.
            let (xx, yy) = (xx + 0.0, yy + 0.0);
            let r = core_math::atan2(yy, xx);
            let exact = yy == 0.0 && xx > 0.0;
            lo = lo.min(round::cr(r, exact, Dir::Down));
            hi = hi.max(round::cr(r, exact, Dir::Up));
        }
    }
    // The quadrant is known from the signs (here y = 0 only where x > 0):
    // keep the one-ulp steps inside it (real π/2 > HALF_PI_LO).
    if y.lo >= 0.0 {
        lo = lo.max(if x.hi < 0.0 { HALF_PI_LO } else { 0.0 });
    }
    if y.hi <= 0.0 {
        hi = hi.min(if x.hi < 0.0 { -HALF_PI_LO } else { 0.0 });
    }
    if x.lo >= 0.0 {
        (lo, hi) = (lo.max(-HALF_PI_HI), hi.min(HALF_PI_HI));
    }
    (clamp(Interval::new(lo, hi), -PI_HI, PI_HI), true)
}

/// `pow(a, b) = exp(b · log a)` over the part of the box where `a > 0`.
///
/// For `a > 0`, `a^b` is monotone in `a` for each fixed `b` and monotone in
/// `b` for each fixed `a` (the directions depend on the signs of `b` and of
/// `log a`, but that does not matter): so its extremes over a rectangle are
/// at corners, each enclosed by the correctly rounded `pow` one ulp outward.
/// A lower corner `a = 0` (the box reaches the edge of the domain) stands
/// for the limit `a → 0⁺`, and infinite corners for the limits at infinity,
/// which is what IEEE `pow` returns there (`0^b` is `0`, `1` or `+∞`,
/// `1^b = 1`, `a^0 = 1`, …); those limit values are exact.
pub fn pow(a: Interval, b: Interval) -> (Interval, bool) {
    if a.is_empty() || b.is_empty() || a.hi <= 0.0 {
        return (Interval::EMPTY, false);
    }
    let defined = a.lo > 0.0;
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    // +0, never -0: IEEE pow(-0, -3) is -∞, the limit from a > 0 is +∞.
    let a_lo = if a.lo > 0.0 { a.lo } else { 0.0 };
    for x in [a_lo, a.hi] {
        for y in [b.lo, b.hi] {
            let r = core_math::pow(x, y);
            let exact = x == 0.0 || x == 1.0 || y == 0.0 || x.is_infinite() || y.is_infinite();
            let mut l = round::cr(r, exact, Dir::Down);
            let mut h = round::cr(r, exact, Dir::Up);
            // x^y ≤ 1 when log x and y have opposite signs, ≥ 1 otherwise.
            if (x <= 1.0 && y >= 0.0) || (x >= 1.0 && y <= 0.0) {
                h = h.min(1.0);
            }
            if (x >= 1.0 && y >= 0.0) || (x <= 1.0 && y <= 0.0) {
                l = l.max(1.0);
            }
            lo = lo.min(l);
            hi = hi.max(h);
        }
    }
    (clamp(Interval::new(lo, hi), 0.0, f64::INFINITY), defined)
}
