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
//! coordinates. Every step costs one value-and-gradient evaluation
//! ([`Evaluator::point_grad`]); each depends on the last, so a walk is
//! sequential. [`newton_batch`] runs many walks in lock-step, each round's
//! evaluations one batch (the batch kernels' speed), with [`newton`]'s
//! results bit for bit.

use glam::DVec3;

use super::{Segment, at, bisect, bisect_batch};
use crate::eval::Evaluator;
use crate::eval::sample::grads_at;

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

/// `p0` moved onto `f(·, t) = 0`; see the module doc. One [`Walk`], its
/// evaluations one at a time.
pub(crate) fn newton<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    p0: DVec3,
    max_dist: f64,
    max_step: f64,
) -> Option<OnSurface> {
    let mut walk = Walk::new(p0, max_dist, max_step);
    loop {
        match walk.next {
            Next::Done(r) => return r,
            Next::Bisect(s) => {
                let pos = bisect(f, t, s.a, s.b, s.fa, s.fb);
                let grad = grad_at(f, t, pos).1;
                return Some(OnSurface { pos, grad });
            }
            Next::Start | Next::Probe => {
                let q = walk.wants().expect("a start or a probe wants a point");
                let (v, g) = grad_at(f, t, q);
                walk.take(v, g);
            }
        }
    }
}

/// A Newton walk (the module doc), cut where it evaluates: [`newton`]
/// drives one, [`newton_batch`] many in lock-step.
#[derive(Clone, Copy, Debug)]
struct Walk {
    p0: DVec3,
    max_dist: f64,
    max_step: f64,
    /// The walk's point and `f` there.
    p: DVec3,
    fp: f64,
    /// The step being tried from `p`, its rounding floor, and how often it
    /// was halved.
    step: DVec3,
    tiny: f64,
    halvings: u32,
    /// Steps begun.
    steps: u32,
    next: Next,
}

/// What a [`Walk`] waits for.
#[derive(Clone, Copy, Debug)]
enum Next {
    /// `(f, ∇f)` at its start.
    Start,
    /// `(f, ∇f)` at `p + step`.
    Probe,
    /// The zero on this segment, then `∇f` there.
    Bisect(Segment),
    /// Nothing: the walk is over, with this result.
    Done(Option<OnSurface>),
}

impl Walk {
    fn new(p0: DVec3, max_dist: f64, max_step: f64) -> Walk {
        Walk {
            p0,
            max_dist,
            max_step,
            p: p0,
            fp: 0.0,
            step: DVec3::ZERO,
            tiny: 0.0,
            halvings: 0,
            steps: 0,
            next: Next::Start,
        }
    }

    /// The point whose `(f, ∇f)` the walk waits for, if any.
    fn wants(&self) -> Option<DVec3> {
        match self.next {
            Next::Start => Some(self.p0),
            Next::Probe => Some(self.p + self.step),
            _ => None,
        }
    }

    /// Takes `(f, ∇f)` at [`Walk::wants`]'s point.
    fn take(&mut self, v: f64, grad: DVec3) {
        match self.next {
            Next::Start => {
                self.fp = v;
                self.begin_step(grad);
            }
            Next::Probe => self.probed(v, grad),
            _ => unreachable!("a walk takes a value only when it wants one"),
        }
    }

    /// A step from `p`, where `f` is `fp` and `∇f` is `g`: the walk ends
    /// (converged, or given up), or probes Newton's point.
    fn begin_step(&mut self, g: DVec3) {
        let fp = self.fp;
        self.next = if self.steps == 64 || !fp.is_finite() || !g.is_finite() {
            Next::Done(None)
        } else if fp == 0.0 {
            Next::Done(Some(OnSurface {
                pos: self.p,
                grad: g,
            }))
        } else if g.length_squared() == 0.0 {
            Next::Done(None)
        } else {
            self.steps += 1;
            let mut step = g * (-fp / g.length_squared());
            let len = step.length();
            if len <= CONVERGED * self.max_step {
                Next::Done(Some(OnSurface {
                    pos: self.p + step,
                    grad: g,
                }))
            } else {
                if len > self.max_step {
                    step *= self.max_step / len;
                }
                (self.step, self.tiny, self.halvings) = (step, tiny(self.p), 0);
                self.probe()
            }
        };
    }

    /// Probes `p + step`, unless it leaves the ball.
    fn probe(&self) -> Next {
        if (self.p + self.step).distance(self.p0) > self.max_dist {
            Next::Done(None)
        } else {
            Next::Probe
        }
    }

    /// The step's probe `q = p + step` read, `(fq, gq)` there: the walk
    /// ends, bisects the bracket `[p, q]`, moves to `q` for the next step
    /// (`|f|` fell), or halves the step.
    fn probed(&mut self, fq: f64, gq: DVec3) {
        let q = self.p + self.step;
        let on = |pos| Next::Done(Some(OnSurface { pos, grad: gq }));
        self.next = if fq.is_nan() {
            Next::Done(None)
        } else if fq == 0.0 {
            on(q)
        } else if (fq < 0.0) != (self.fp < 0.0) {
            Next::Bisect(Segment {
                a: self.p,
                b: q,
                fa: self.fp,
                fb: fq,
            })
        } else if self.step.length() <= self.tiny {
            on(q)
        } else if fq.abs() < self.fp.abs() {
            (self.p, self.fp) = (q, fq);
            return self.begin_step(gq);
        } else if self.halvings == 30 {
            Next::Done(None)
        } else {
            self.halvings += 1;
            self.step *= 0.5;
            self.probe()
        };
    }
}

/// [`newton`] from every `(p0, max_dist, max_step)` of `starts`, with the
/// same results bit for bit: the walks advance in lock-step, each round's
/// evaluations one [`Evaluator::point_grad_batch`] call, and the brackets
/// of the walks that cross the surface go to [`bisect_batch`] (then one
/// batch for the gradients at their zeros). Each walk evaluates the
/// points [`newton`] would, in the same order.
pub(crate) fn newton_batch<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    starts: &[(DVec3, f64, f64)],
) -> Vec<Option<OnSurface>> {
    let mut walks: Vec<Walk> = starts
        .iter()
        .map(|&(p0, max_dist, max_step)| Walk::new(p0, max_dist, max_step))
        .collect();
    let mut pts = Vec::new();
    let mut out = Vec::new();
    loop {
        let waiting: Vec<(usize, DVec3)> = walks
            .iter()
            .enumerate()
            .filter_map(|(i, w)| w.wants().map(|q| (i, q)))
            .collect();
        if waiting.is_empty() {
            break;
        }
        pts.clear();
        pts.extend(waiting.iter().map(|&(_, q)| q.to_array()));
        out.resize(pts.len(), (0.0, [0.0; 3]));
        f.point_grad_batch(&pts, t, &mut out);
        for (&(i, _), &(v, g)) in waiting.iter().zip(&out) {
            walks[i].take(v, DVec3::from_array(g));
        }
    }
    let crossing: Vec<(usize, Segment)> = walks
        .iter()
        .enumerate()
        .filter_map(|(i, w)| match w.next {
            Next::Bisect(s) => Some((i, s)),
            _ => None,
        })
        .collect();
    let segments: Vec<Segment> = crossing.iter().map(|&(_, s)| s).collect();
    let zeros = bisect_batch(f, t, &segments);
    let grads = grads_at(f, t, &zeros);
    for ((&(i, _), &pos), (_, grad)) in crossing.iter().zip(&zeros).zip(grads) {
        walks[i].next = Next::Done(Some(OnSurface { pos, grad }));
    }
    walks
        .into_iter()
        .map(|w| match w.next {
            Next::Done(r) => r,
            _ => unreachable!("every walk ends"),
        })
        .collect()
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

    /// The lock-step walks end where the sequential ones do, bit for bit,
    /// over starts that converge, cross the surface (bisection), leave
    /// their ball, meet a zero gradient (a sphere's centre), or sit on
    /// the surface already.
    #[test]
    fn batch_walks_are_the_sequential_ones() {
        let f = Spheres;
        let mut starts = vec![
            (DVec3::new(1.5, 0.0, 0.0), 2.0, 0.5),
            (DVec3::new(2.5, 0.0, 0.0), 2.0, 0.5),
            (DVec3::new(1.5, 0.0, 4.0), 1.0, 0.5),
        ];
        for i in 0..400 {
            let u = f64::from(i);
            let p = DVec3::new(
                3.0 * (0.37 * u).sin(),
                2.0 * (0.11 * u).cos(),
                (0.23 * u).sin(),
            );
            let reach = [0.05, 0.3, 1.0, 4.0][i as usize % 4];
            let step = [0.01, 0.1, 0.5, 2.0][(i as usize / 4) % 4];
            starts.push((p, reach, step));
        }
        let batch = newton_batch(&f, 0.0, &starts);
        let (mut some, mut none) = (0, 0);
        for (&(p, reach, step), got) in starts.iter().zip(&batch) {
            let want = newton(&f, 0.0, p, reach, step);
            match (want, got) {
                (None, None) => none += 1,
                (Some(a), Some(b)) => {
                    some += 1;
                    assert_eq!(
                        a.pos.to_array().map(f64::to_bits),
                        b.pos.to_array().map(f64::to_bits),
                        "{p}"
                    );
                    assert_eq!(
                        a.grad.to_array().map(f64::to_bits),
                        b.grad.to_array().map(f64::to_bits),
                        "{p}"
                    );
                }
                _ => panic!("{p} {reach} {step}: {want:?} against {got:?}"),
            }
        }
        assert!(some > 100 && none > 10, "{some} landed, {none} refused");
        assert!(batch[0].is_none() && batch[1].is_some() && batch[2].is_none());
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
