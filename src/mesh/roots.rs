//! Putting points on the surface `f = 0`, using only point evaluations.
//!
//! - [`bisect`]: the zero on a segment whose ends have opposite signs, by
//!   bisection to machine precision: the returned point is one of two
//!   adjacent floating-point points of the segment's parametrisation that
//!   straddle the sign change (Paiva et al. §4.3: vertices placed on the
//!   exact function, not by linear interpolation). Each step takes the
//!   secant point when it is safely inside the bracket (Illinois-style
//!   safeguard), otherwise the midpoint, so convergence is fast on smooth
//!   functions and never worse than bisection.
//! - [`project`]: a point near the surface moved onto it along the gradient
//!   line (Newton's method, then a sign-change bracket refined by
//!   [`bisect`]), refusing to move farther than a given distance, so that a
//!   point never jumps to another sheet of the surface.

use glam::DVec3;

/// A point evaluation: `f(p)`.
pub trait Field: Sync {
    fn value(&self, p: DVec3) -> f64;
    fn gradient(&self, p: DVec3) -> (f64, DVec3);
}

/// The zero of `f` on `[a, b]`, given `fa = f(a) < 0 <= fb = f(b)` or the
/// reverse. See the module doc.
pub fn bisect(f: &dyn Field, mut a: DVec3, mut b: DVec3, mut fa: f64, mut fb: f64) -> DVec3 {
    debug_assert!((fa < 0.0) != (fb < 0.0));
    let mut side = 0i8;
    for _ in 0..200 {
        let mid = (a + b) * 0.5;
        if mid == a || mid == b {
            break;
        }
        // Secant point, kept away from the ends; midpoint otherwise.
        let s = fa / (fa - fb);
        let p = if s.is_finite() && (0.05..=0.95).contains(&s) {
            a + (b - a) * s
        } else {
            mid
        };
        let p = if p == a || p == b { mid } else { p };
        let fp = f.value(p);
        if fp.is_nan() {
            // Undefined inside the bracket: fall back to the midpoint rule.
            let fm = f.value(mid);
            if fm.is_nan() || (fm < 0.0) == (fa < 0.0) {
                a = mid;
                fa = if fm.is_nan() { fa } else { fm };
            } else {
                b = mid;
                fb = fm;
            }
            continue;
        }
        if (fp < 0.0) == (fa < 0.0) {
            a = p;
            fa = fp;
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        } else {
            b = p;
            fb = fp;
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        }
        if (b - a).abs().max_element() <= f64::EPSILON * a.abs().max(b.abs()).max_element() {
            break;
        }
    }
    // The end whose value is nearer zero — but not an end where f is
    // exactly 0 when the other is not: such an end is usually a sample
    // point (a leaf centre) shared by several brackets, and returning it
    // would put several vertices at one position. The other end is within
    // the bracket's final width (an ulp or so) of it.
    let (va, vb) = (f.value(a), f.value(b));
    match (va == 0.0, vb == 0.0) {
        (true, false) => b,
        (false, true) => a,
        _ if va.abs() <= vb.abs() => a,
        _ => b,
    }
}

/// `p` moved onto `f = 0` along its gradient line, or `None` when no zero
/// lies within `max_dist` of `p` along that line.
pub fn project(f: &dyn Field, p: DVec3, max_dist: f64) -> Option<DVec3> {
    let (fp, g) = f.gradient(p);
    if !fp.is_finite() || !g.is_finite() || g.length_squared() == 0.0 {
        return None;
    }
    if fp == 0.0 {
        return Some(p);
    }
    let dir = g.normalize();
    // Newton's guess of the signed distance along the gradient line.
    let guess = (-fp / g.length()).clamp(-max_dist, max_dist);
    let sign = |x: f64| x < 0.0;
    // Grow a bracket around the guess until the sign changes.
    let mut step = (guess.abs() * 0.25).max(max_dist * 1e-6);
    for _ in 0..40 {
        let lo = (guess - step).max(-max_dist);
        let hi = (guess + step).min(max_dist);
        let (a, b) = (p + dir * lo, p + dir * hi);
        let (fa, fb) = (f.value(a), f.value(b));
        if fa.is_finite() && fb.is_finite() && sign(fa) != sign(fb) {
            return Some(bisect(f, a, b, fa, fb));
        }
        if lo <= -max_dist && hi >= max_dist {
            return None;
        }
        step *= 2.0;
    }
    None
}
