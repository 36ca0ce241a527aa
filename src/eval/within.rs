//! A function restricted to the domain: [`Within`] is `f` inside the box Ω
//! and not defined (NaN) outside it.
//!
//! The surface is `f = 0` in Ω only. The mesher's stages that move
//! vertices or add them (coarsening, smoothing, the chord splits,
//! settling) project
//! points onto `f = 0` by Newton steps and brackets, which follow the
//! surface wherever it goes, and out through a face of Ω where the surface
//! leaves it. Given [`Within`], they meet NaN there instead, and every
//! projection in [`crate::roots`] refuses a point where `f` is NaN, so no
//! vertex leaves Ω.
//!
//! # Contract
//!
//! - A point in the closed box gets exactly `f`'s value (and gradient); a
//!   point outside it, or with a NaN coordinate, gets NaN (and a NaN
//!   gradient).
//! - A box not inside Ω gets `f`'s enclosure flagged not defined, which
//!   stays sound: it encloses every value where the function is defined.
//! - [`Evaluator::program`] is `None`: a caller that would interpret the
//!   program itself would bypass the restriction (so nothing is pruned
//!   through this adaptor; the octree prunes with `f` itself).
//!
//! ```
//! use isoc::eval::{Evaluator, within::Within};
//! use isoc::{Bounds, CompileOptions, Surface};
//!
//! let src = "domain [-1, 1]^3; surface x^2 + y^2 + z^2 - 4;";
//! let s = Surface::compile(src, "big.iso", &CompileOptions::default())?;
//! let omega = Bounds { lo: [-1.0; 3], hi: [1.0; 3] };
//! let f = Within::new(&s, omega);
//! assert_eq!(f.point([1.0, 0.0, 0.0, 0.0]), -3.0);
//! assert!(f.point([2.0, 0.0, 0.0, 0.0]).is_nan());
//! # Ok::<(), isoc::CompileError>(())
//! ```

use super::{Evaluator, GradEval, check_len};
use crate::geometry::Bounds;
use crate::interval::{DecInterval, Interval};

/// `f` on the closed box `domain`, NaN off it (see the module doc).
pub struct Within<'a, E: ?Sized> {
    f: &'a E,
    domain: Bounds,
}

impl<'a, E: Evaluator + ?Sized> Within<'a, E> {
    /// `f` restricted to `domain`.
    pub fn new(f: &'a E, domain: Bounds) -> Self {
        Within { f, domain }
    }

    fn holds(&self, x: f64, y: f64, z: f64) -> bool {
        self.domain.contains([x, y, z])
    }

    fn holds_box(&self, b: &[Interval; 4]) -> bool {
        let corner = |end: fn(&Interval) -> f64| [end(&b[0]), end(&b[1]), end(&b[2])];
        self.domain.contains(corner(|i| i.lo)) && self.domain.contains(corner(|i| i.hi))
    }
}

const NAN_GRAD: (f64, [f64; 3]) = (f64::NAN, [f64::NAN; 3]);

impl<E: Evaluator + ?Sized> Evaluator for Within<'_, E> {
    fn point(&self, p: [f64; 4]) -> f64 {
        if self.holds(p[0], p[1], p[2]) {
            self.f.point(p)
        } else {
            f64::NAN
        }
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        if self.holds(p[0], p[1], p[2]) {
            self.f.point_grad(p)
        } else {
            NAN_GRAD
        }
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        let r = self.f.interval(b);
        DecInterval {
            defined: r.defined && self.holds_box(&b),
            ..r
        }
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        let r = self.f.grad(b);
        GradEval {
            defined: r.defined && self.holds_box(&b),
            ..r
        }
    }
    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        check_len(out.len(), &[xs.len(), ys.len(), zs.len()]);
        self.f.point_batch(xs, ys, zs, t, out);
        for (i, o) in out.iter_mut().enumerate() {
            if !self.holds(xs[i], ys[i], zs[i]) {
                *o = f64::NAN;
            }
        }
    }
    fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64, out: &mut [(f64, [f64; 3])]) {
        check_len(out.len(), &[pts.len()]);
        self.f.point_grad_batch(pts, t, out);
        for (o, p) in out.iter_mut().zip(pts) {
            if !self.holds(p[0], p[1], p[2]) {
                *o = NAN_GRAD;
            }
        }
    }
}
