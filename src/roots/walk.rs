//! A Newton walk onto `f(·, t) = 0` along the gradient (Bouthors & Nesme
//! §2.4, eq. 3), with a safeguard: the twinned meshes' projection, whose
//! steps are bounded by an edge length.
//!
//! # Contract
//!
//! [`newton`] moves `p₀` by Newton steps `p ← p − f(p) ∇f(p)/‖∇f(p)‖²`.
//! Each step is limited to `max_step`; the walk gives up (returns `None`)
//! when it would leave the ball of radius `max_dist` around `p₀`, when `f`
//! or `∇f` is not finite, or when a step fails to reduce `|f|` even after
//! halving. As soon as a step crosses the surface (the sign of `f`
//! changes), the zero is bracketed by that one short step and found by
//! [`super::bisect`] (the same bracket solver as the mesher's vertices), so
//! the point lands on the sheet it was walking towards and never jumps to
//! another one. A Newton step shorter than [`CONVERGED`] × `max_step` ends
//! the walk at the point it leads to, unevaluated: Newton's error is
//! quadratic where `f` is smooth, so that point is about `κ·step² ≤
//! (κ·max_step)·10⁻¹²·max_step` off the surface (κ its curvature) — at
//! rounding level wherever the steps resolve the curvature, `κ·max_step ≲
//! 1` — and the gradient returned is the one at the step's start (`step`
//! away). This saves the one or two evaluations that only confirm
//! convergence. Otherwise the result is on the surface to machine
//! precision: the last Newton step (or the bracket) is a few ulps of the
//! coordinates. Every step costs one value-and-gradient evaluation ([`Evaluator::point_grad`]); each depends on the last, so the
//! walk is sequential (callers run many walks in parallel).

use glam::DVec3;

use super::{at, bisect};
use crate::eval::Evaluator;

/// `(f, ∇f)` at `(p, t)`.
fn grad_at<E: Evaluator + ?Sized>(f: &E, t: f64, p: DVec3) -> (f64, DVec3) {
    let (v, g) = f.point_grad(at(p, t));
    (v, DVec3::from_array(g))
}

/// A Newton step this short, relative to `max_step`, is the last: see the
/// module doc.
pub const CONVERGED: f64 = 1e-6;

/// A point on the surface and ∇f there.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OnSurface {
    pub pos: DVec3,
    pub grad: DVec3,
}

/// `p0` moved onto `f(·, t) = 0`; see the module doc.
pub(crate) fn newton<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    p0: DVec3,
    max_dist: f64,
    max_step: f64,
) -> Option<OnSurface> {
    let mut p = p0;
    let (mut fp, mut g) = grad_at(f, t, p);
    for _ in 0..64 {
        if !fp.is_finite() || !g.is_finite() {
            return None;
        }
        if fp == 0.0 {
            return Some(OnSurface { pos: p, grad: g });
        }
        let g2 = g.length_squared();
        if g2 == 0.0 {
            return None;
        }
        let mut step = g * (-fp / g2);
        let len = step.length();
        if len <= CONVERGED * max_step {
            return Some(OnSurface {
                pos: p + step,
                grad: g,
            });
        }
        if len > max_step {
            step *= max_step / len;
        }
        let tiny = tiny(p);
        let mut halvings = 0;
        loop {
            let q = p + step;
            if q.distance(p0) > max_dist {
                return None;
            }
            let (fq, gq) = grad_at(f, t, q);
            if fq.is_nan() {
                return None;
            }
            if fq == 0.0 {
                return Some(OnSurface { pos: q, grad: gq });
            }
            if (fq < 0.0) != (fp < 0.0) {
                let r = bisect(f, t, p, q, fp, fq);
                return Some(OnSurface {
                    pos: r,
                    grad: grad_at(f, t, r).1,
                });
            }
            if step.length() <= tiny {
                return Some(OnSurface { pos: q, grad: gq });
            }
            if fq.abs() < fp.abs() {
                (p, fp, g) = (q, fq, gq);
                break;
            }
            halvings += 1;
            if halvings > 30 {
                return None;
            }
            step *= 0.5;
        }
    }
    None
}

/// A few ulps of `p`'s largest coordinate: steps below this are noise.
fn tiny(p: DVec3) -> f64 {
    4.0 * f64::EPSILON * p.abs().max_element().max(f64::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::{GradEval, WHOLE, WHOLE_GRAD};
    use crate::interval::{DecInterval, Interval};

    /// Two unit spheres at x = ±1.5. Only the point methods are used here;
    /// the box methods answer the whole line, flagged not defined (sound,
    /// and never asked).
    struct Spheres;
    impl Evaluator for Spheres {
        fn point(&self, p: [f64; 4]) -> f64 {
            self.point_grad(p).0
        }
        fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
            let p = DVec3::new(p[0], p[1], p[2]);
            let a = (p - DVec3::X * 1.5).length_squared() - 1.0;
            let b = (p + DVec3::X * 1.5).length_squared() - 1.0;
            if a <= b {
                (a, (2.0 * (p - DVec3::X * 1.5)).to_array())
            } else {
                (b, (2.0 * (p + DVec3::X * 1.5)).to_array())
            }
        }
        fn interval(&self, _: [Interval; 4]) -> DecInterval {
            WHOLE
        }
        fn grad(&self, _: [Interval; 4]) -> GradEval {
            WHOLE_GRAD
        }
    }

    #[test]
    fn lands_on_the_surface_and_stays_within_reach() {
        let f = Spheres;
        for p in [
            DVec3::new(1.5, 0.3, 0.1),
            DVec3::new(3.0, 0.5, -0.2),
            DVec3::new(-1.5, 0.0, 2.5),
        ] {
            let s = newton(&f, 0.0, p, 10.0, 0.5).unwrap();
            assert!(f.point(at(s.pos, 0.0)).abs() < 1e-14, "{p} → {}", s.pos);
        }
        // Too far: refused.
        assert!(newton(&f, 0.0, DVec3::new(1.5, 0.0, 4.0), 1.0, 0.5).is_none());
    }

    #[test]
    fn never_jumps_to_the_other_sphere() {
        // From near the gap, the walk ends on the sphere whose side the
        // point is on.
        let f = Spheres;
        let p = DVec3::new(0.2, 0.0, 0.0);
        let s = newton(&f, 0.0, p, 3.0, 0.1).unwrap();
        assert!(s.pos.x > 0.0, "{}", s.pos);
    }
}
