//! Monotone transcendental functions: `exp`, `log`, `asin`, `acos`, `atan`,
//! `atan2`, `pow`.
//!
//! Each bound is a correctly rounded CORE-MATH value moved one ulp outward
//! ([`super::round::cr`]; exact only at the trivial points `exp 0 = 1`,
//! `log 1 = 0`, `asin 0 = atan 0 = 0`, `acos 1 = 0`), then clamped to the
//! function's true range. Inputs are normalised intervals.

use super::round::{self, Dir};
use super::{HALF_PI_HI, Interval, PI_HI, arith};

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

/// `exp(a)`, increasing, `≥ 0`.
pub fn exp(a: Interval) -> Interval {
    if a.is_empty() {
        return Interval::EMPTY;
    }
    let lo = bounds(core_math::exp, a.lo, 0.0).0;
    let hi = bounds(core_math::exp, a.hi, 0.0).1;
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
    let hi = bounds(core_math::log, a.hi, 1.0).1;
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
        clamp(Interval::new(lo, hi), -HALF_PI_HI, HALF_PI_HI),
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
    clamp(Interval::new(lo, hi), -HALF_PI_HI, HALF_PI_HI)
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
    (clamp(Interval::new(lo, hi), -PI_HI, PI_HI), true)
}

/// `pow(a, b) = exp(b · log a)` over the part of the box where `a > 0`.
pub fn pow(a: Interval, b: Interval) -> (Interval, bool) {
    if a.is_empty() || b.is_empty() {
        return (Interval::EMPTY, false);
    }
    let (l, defined) = log(a);
    if l.is_empty() {
        return (Interval::EMPTY, false);
    }
    (exp(arith::mul(b, l)), defined)
}
