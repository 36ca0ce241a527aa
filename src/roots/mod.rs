//! Putting points on the surface `f(·, t) = 0` at a fixed time `t`, for
//! every stage that needs it (the mesher's vertices, smoothing, the
//! deviation measure, the twinned meshes): one bracket solver, two ways to
//! reach a bracket.
//!
//! - [`bisect`]: the zero on a segment whose ends have opposite signs, by
//!   bisection to machine precision: the returned point is one of two
//!   adjacent floating-point points of the segment's parametrisation that
//!   straddle the sign change (Paiva et al. §4.3: vertices placed on the
//!   exact function, not by linear interpolation). Each step takes the
//!   secant point when it is strictly inside the bracket (Illinois-style
//!   safeguard: the stale end's weight is halved); when the secant point
//!   lies within rounding of an end (the zero is there, as on a linear
//!   piece) a point a few ulps from that end, the distance doubling while
//!   the zero is not reached; the midpoint otherwise or when three steps
//!   have not halved the bracket. A point where `f` is exactly 0 ends the
//!   search. Convergence is fast on smooth and on piecewise-linear
//!   functions; in the worst case every fourth step halves the bracket,
//!   so at most four times bisection's step count (and never more than
//!   `MAX_STEPS`).
//! - [`bisect_batch`]: [`bisect`] on many segments in lock-step, one
//!   [`Evaluator::point_batch`] call per step over the segments still
//!   running. Per segment it evaluates the same points in the same order
//!   and stops at the same step as [`bisect`], so its results are bit for
//!   bit [`bisect`]'s (the evaluator's batch equals its single calls).
//! - [`project`]: a point near the surface moved onto it along the gradient
//!   line (Newton's step; the segment to Newton's point when the sign
//!   changes on it, else a sign-change bracket grown around that point;
//!   refined by [`bisect`]), refusing to move farther than a given distance, so that a
//!   point never jumps to another sheet of the surface. Each evaluation
//!   depends on the last, so it evaluates one point at a time;
//!   [`project_along_batch`] projects many points in lock-step (one batch
//!   call for the gradients at the starts, one for Newton's points, then
//!   [`bisect_batch`]) with [`project_along`]'s results bit for bit.
//! - [`line_zero`]: a zero along a given line (the mesher's splits, where
//!   the gradient line would fold a triangle over).
//! - [`keeps_sign`]: whether `f` keeps one sign at samples along a
//!   segment (no sheet crosses it): the check that a tunnel through a
//!   dual cell, or the way to a crease's tip, is the function's.
//! - [`walk::newton`]: a Newton walk with bounded steps (the twinned
//!   meshes' projection), ending in [`bisect`] once a step crosses the
//!   surface; `walk::newton_batch` runs many in lock-step.

use glam::DVec3;

use crate::eval::Evaluator;

pub mod walk;

/// The evaluator's input at `p` and time `t`.
pub fn at(p: DVec3, t: f64) -> [f64; 4] {
    [p.x, p.y, p.z, t]
}

/// Most steps of one bisection.
const MAX_STEPS: u32 = 200;

/// A sign-change bracket `[a, b]` and the state of the Illinois safeguard.
#[derive(Clone, Copy, Debug)]
struct Bracket {
    a: DVec3,
    b: DVec3,
    fa: f64,
    fb: f64,
    /// The values at `a` and `b` as evaluated (`fa`, `fb` are the
    /// secant's weights, halved by the safeguard).
    va: f64,
    vb: f64,
    side: i8,
    /// Steps since `width` was recorded, and that width: when three steps
    /// have not halved the bracket, the next step is a midpoint.
    since: u8,
    width: f64,
    force_mid: bool,
    /// Consecutive steps taken next to an end (see [`Bracket::probe`]).
    nudges: u32,
}

/// `a` moved by one float towards `b` in every coordinate where they
/// differ.
fn toward(a: DVec3, b: DVec3) -> DVec3 {
    let step = |x: f64, y: f64| {
        if y > x {
            x.next_up()
        } else if y < x {
            x.next_down()
        } else {
            x
        }
    };
    DVec3::new(step(a.x, b.x), step(a.y, b.y), step(a.z, b.z))
}

impl Bracket {
    fn new(a: DVec3, b: DVec3, fa: f64, fb: f64) -> Bracket {
        debug_assert!((fa < 0.0) != (fb < 0.0));
        Bracket {
            a,
            b,
            fa,
            fb,
            va: fa,
            vb: fb,
            side: 0,
            since: 0,
            width: (b - a).abs().max_element(),
            force_mid: false,
            nudges: 0,
        }
    }

    /// The next point to evaluate and the midpoint, or `None` when the
    /// bracket can no longer be split.
    fn probe(&mut self) -> Option<(DVec3, DVec3)> {
        let (a, b) = (self.a, self.b);
        let mid = (a + b) * 0.5;
        if mid == a || mid == b {
            return None;
        }
        // The secant point as a fraction of the bracket from each end
        // (each accurate when small); the midpoint when the secant steps
        // stall.
        let (sa, sb) = (self.fa / (self.fa - self.fb), self.fb / (self.fb - self.fa));
        if self.force_mid || !(sa.is_finite() && sb.is_finite() && sa >= 0.0 && sb >= 0.0) {
            self.nudges = 0;
            return Some((mid, mid));
        }
        let (from, to, frac) = if sa <= sb { (a, b, sa) } else { (b, a, sb) };
        // A secant point within rounding of an end says the zero is there
        // (on a linear piece the secant is exact): step a small distance
        // from that end instead — a few ulps of the coordinates, doubling
        // while the zero is not reached — so the bracket closes in a few
        // steps rather than by crawling.
        let width = (b - a).abs().max_element();
        let tol = f64::EPSILON
            * a.abs().max(b.abs()).max_element()
            * f64::from(1u32 << self.nudges.min(30));
        let t = tol / width;
        let p = if t >= 0.5 {
            self.nudges = 0;
            mid
        } else if frac < t {
            self.nudges += 1;
            let p = from + (to - from) * t;
            if p == from { toward(from, to) } else { p }
        } else {
            self.nudges = 0;
            from + (to - from) * frac
        };
        let p = if p == a || p == b { mid } else { p };
        Some((p, mid))
    }

    /// Takes `fp = f(p)` (not NaN); returns whether the bracket has
    /// converged.
    fn take(&mut self, p: DVec3, fp: f64) -> bool {
        if fp == 0.0 {
            // A zero: the bracket closes on it.
            (self.a, self.b, self.va, self.vb) = (p, p, fp, fp);
            return true;
        }
        if (fp < 0.0) == (self.fa < 0.0) {
            self.a = p;
            self.fa = fp;
            self.va = fp;
            if self.side == -1 {
                self.fb *= 0.5;
            }
            self.side = -1;
        } else {
            self.b = p;
            self.fb = fp;
            self.vb = fp;
            if self.side == 1 {
                self.fa *= 0.5;
            }
            self.side = 1;
        }
        let (a, b) = (self.a, self.b);
        let width = (b - a).abs().max_element();
        self.since += 1;
        self.force_mid = false;
        if self.since == 3 {
            self.force_mid = width > 0.5 * self.width;
            self.width = width;
            self.since = 0;
        }
        width <= f64::EPSILON * a.abs().max(b.abs()).max_element()
    }

    /// Takes `fm = f(mid)` after `f` was NaN at the probe: undefined inside
    /// the bracket, fall back to the midpoint rule.
    fn take_mid(&mut self, mid: DVec3, fm: f64) {
        if fm.is_nan() || (fm < 0.0) == (self.fa < 0.0) {
            self.a = mid;
            self.fa = if fm.is_nan() { self.fa } else { fm };
            self.va = fm;
        } else {
            self.b = mid;
            self.fb = fm;
            self.vb = fm;
        }
    }

    /// The result, from `va = f(a)` and `vb = f(b)`: the end whose value is
    /// nearer zero — but not an end where f is exactly 0 when the other is
    /// not: such an end is usually a sample point (a leaf centre) shared by
    /// several brackets, and returning it would put several vertices at one
    /// position. The other end is within the bracket's final width (an ulp
    /// or so) of it.
    fn pick(&self) -> DVec3 {
        let (va, vb) = (self.va, self.vb);
        match (va == 0.0, vb == 0.0) {
            (true, false) => self.b,
            (false, true) => self.a,
            _ if va.abs() <= vb.abs() => self.a,
            _ => self.b,
        }
    }
}

/// The zero of `f(·, t)` on `[a, b]`, given `fa = f(a) < 0 <= fb = f(b)` or
/// the reverse. See the module doc.
pub fn bisect<E: Evaluator + ?Sized>(f: &E, t: f64, a: DVec3, b: DVec3, fa: f64, fb: f64) -> DVec3 {
    let mut br = Bracket::new(a, b, fa, fb);
    for _ in 0..MAX_STEPS {
        let Some((p, mid)) = br.probe() else {
            break;
        };
        let fp = f.point(at(p, t));
        if fp.is_nan() {
            let fm = f.point(at(mid, t));
            br.take_mid(mid, fm);
            continue;
        }
        if br.take(p, fp) {
            break;
        }
    }
    br.pick()
}

/// A segment for [`bisect_batch`]: ends `a`, `b` with values `fa`, `fb` of
/// opposite signs (as [`bisect`] takes them).
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    /// First end.
    pub a: DVec3,
    /// Second end.
    pub b: DVec3,
    /// `f(a)`.
    pub fa: f64,
    /// `f(b)`, of the sign opposite to `fa`.
    pub fb: f64,
}

/// Where one segment of [`bisect_batch`] is in [`bisect`]'s loop.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// About to take a step (or to finish, when none is left).
    Probe,
    /// Waiting for `f` at the probe.
    AwaitProbe,
    /// `f` was NaN at the probe: `f` at the midpoint is asked next.
    NeedMid,
    AwaitMid,
    /// Finished: the result is out.
    Done,
}

#[derive(Clone, Copy, Debug)]
struct Job {
    br: Bracket,
    steps: u32,
    phase: Phase,
    probe: DVec3,
    mid: DVec3,
}

/// [`bisect`] on every segment, in lock-step (see the module doc).
pub fn bisect_batch<E: Evaluator + ?Sized>(f: &E, t: f64, segments: &[Segment]) -> Vec<DVec3> {
    let mut out = vec![DVec3::ZERO; segments.len()];
    let mut jobs: Vec<Job> = segments
        .iter()
        .map(|s| Job {
            br: Bracket::new(s.a, s.b, s.fa, s.fb),
            steps: 0,
            phase: Phase::Probe,
            probe: DVec3::ZERO,
            mid: DVec3::ZERO,
        })
        .collect();
    let mut running: Vec<usize> = (0..segments.len()).collect();
    let (mut xs, mut ys, mut zs, mut vals) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    while !running.is_empty() {
        xs.clear();
        ys.clear();
        zs.clear();
        let mut ask = |p: DVec3| {
            xs.push(p.x);
            ys.push(p.y);
            zs.push(p.z);
        };
        for &i in &running {
            let job = &mut jobs[i];
            match job.phase {
                Phase::Probe => match job.br.probe().filter(|_| job.steps < MAX_STEPS) {
                    Some((p, mid)) => {
                        (job.probe, job.mid) = (p, mid);
                        job.phase = Phase::AwaitProbe;
                        ask(p);
                    }
                    None => {
                        out[i] = job.br.pick();
                        job.phase = Phase::Done;
                    }
                },
                Phase::NeedMid => {
                    job.phase = Phase::AwaitMid;
                    ask(job.mid);
                }
                _ => unreachable!("every running job asks for a value each round"),
            }
        }
        vals.clear();
        vals.resize(xs.len(), 0.0);
        if !xs.is_empty() {
            f.point_batch(&xs, &ys, &zs, t, &mut vals);
        }
        let mut next = vals.iter().copied();
        let mut value = || next.next().expect("one value per point asked");
        running.retain(|&i| {
            let job = &mut jobs[i];
            match job.phase {
                Phase::AwaitProbe => {
                    let fp = value();
                    if fp.is_nan() {
                        job.phase = Phase::NeedMid;
                    } else {
                        let converged = job.br.take(job.probe, fp);
                        job.steps += 1;
                        job.phase = Phase::Probe;
                        if converged {
                            // As `break`: no further step.
                            job.steps = MAX_STEPS;
                        }
                    }
                    true
                }
                Phase::AwaitMid => {
                    let fm = value();
                    job.br.take_mid(job.mid, fm);
                    job.steps += 1;
                    job.phase = Phase::Probe;
                    true
                }
                Phase::Done => false,
                _ => unreachable!("every running job asked for a value"),
            }
        });
    }
    out
}

/// Whether `f(·, t)` has one strict sign — negative when `negative`, else
/// positive — at the [`SEGMENT_SAMPLES`] − 1 points that split the segment
/// `[a, b]` into equal parts (its ends are not sampled): no sheet of the
/// surface crosses it, as far as samples this far apart can tell. A zero
/// or a NaN on the way fails.
pub fn keeps_sign<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    [a, b]: [DVec3; 2],
    negative: bool,
) -> bool {
    (1..SEGMENT_SAMPLES).all(|k| {
        let v = f.point(at(a.lerp(b, k as f64 / SEGMENT_SAMPLES as f64), t));
        if negative { v < 0.0 } else { v > 0.0 }
    })
}

/// The parts [`keeps_sign`] splits a segment into.
pub const SEGMENT_SAMPLES: usize = 8;

/// A zero of `f(·, t)` on the line through `p` along `dir`, within `reach`
/// of `p`: the line is stepped outward on both sides in eighths of
/// `reach` until the sign changes, nearest first, and the bracket is
/// refined by [`bisect`]. `None` when `dir` is zero, `f(p)` is not finite
/// or no sign change lies within `reach` (a zero the steps straddle twice
/// is missed).
pub fn line_zero<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    p: DVec3,
    dir: DVec3,
    reach: f64,
) -> Option<DVec3> {
    let dir = dir.normalize_or_zero();
    let fp = f.point(at(p, t));
    if dir == DVec3::ZERO || !fp.is_finite() {
        return None;
    }
    if fp == 0.0 {
        return Some(p);
    }
    let mut last = [(p, fp); 2];
    let mut s = reach / 8.0;
    while s <= reach * (1.0 + 1e-12) {
        for (k, side) in [1.0, -1.0].into_iter().enumerate() {
            let q = p + dir * (side * s);
            let fq = f.point(at(q, t));
            if fq == 0.0 {
                return Some(q);
            }
            if fq.is_finite() && (fq < 0.0) != (fp < 0.0) {
                let (a, fa) = last[k];
                return Some(bisect(f, t, a, q, fa, fq));
            }
            if fq.is_finite() {
                last[k] = (q, fq);
            }
        }
        s += reach / 8.0;
    }
    None
}

/// `p` moved onto `f(·, t) = 0` along its gradient line, or `None` when no
/// zero lies within `max_dist` of `p` along that line.
///
/// A point where `f` is 0 is its own projection, even where the gradient
/// vanishes there (a singular point: where `x y = 0`'s planes cross).
pub fn project<E: Evaluator + ?Sized>(f: &E, t: f64, p: DVec3, max_dist: f64) -> Option<DVec3> {
    let (fp, g) = f.point_grad(at(p, t));
    if fp == 0.0 {
        return Some(p);
    }
    along_line(f, t, p, max_dist, fp, g).map(|(q, _)| q)
}

/// [`project`], also returning the gradient of `f` at `p` (the start of
/// the line; finite and non-zero).
pub fn project_along<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    p: DVec3,
    max_dist: f64,
) -> Option<(DVec3, DVec3)> {
    let (fp, g) = f.point_grad(at(p, t));
    along_line(f, t, p, max_dist, fp, g)
}

/// [`project_along`] given `f(p) = fp` and its gradient `g` there.
fn along_line<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    p: DVec3,
    max_dist: f64,
    fp: f64,
    g: [f64; 3],
) -> Option<(DVec3, DVec3)> {
    let line = match GradientLine::start(p, max_dist, fp, g) {
        Err(done) => return done,
        Ok(line) => line,
    };
    let fn_ = f.point(at(line.newton(), t));
    match line.after_newton(fn_) {
        AfterNewton::Done(q) => Some((q, line.g)),
        AfterNewton::Bisect(s) => Some((bisect(f, t, s.a, s.b, s.fa, s.fb), line.g)),
        AfterNewton::Grow => line.grow(f, t).map(|q| (q, line.g)),
    }
}

/// [`project_along`] from every `(p, max_dist)` of `starts`, with the same
/// results bit for bit: the gradients at the starts are one
/// [`Evaluator::point_grad_batch`] call, Newton's points one
/// [`Evaluator::point_batch`] call, and the segments they bracket go to
/// [`bisect_batch`]; a start whose Newton point falls short of the surface
/// (rare) grows its bracket alone, as [`project_along`] does.
pub fn project_along_batch<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    starts: &[(DVec3, f64)],
) -> Vec<Option<(DVec3, DVec3)>> {
    let pts: Vec<[f64; 3]> = starts.iter().map(|(p, _)| p.to_array()).collect();
    let mut grads = vec![(0.0, [0.0; 3]); pts.len()];
    f.point_grad_batch(&pts, t, &mut grads);
    let mut out = vec![None; starts.len()];
    let mut lines = Vec::new();
    for (i, (&(p, max_dist), &(fp, g))) in starts.iter().zip(&grads).enumerate() {
        match GradientLine::start(p, max_dist, fp, g) {
            Err(done) => out[i] = done,
            Ok(line) => lines.push((i, line)),
        }
    }
    let newton: Vec<DVec3> = lines.iter().map(|(_, l)| l.newton()).collect();
    let mut values = vec![0.0; newton.len()];
    let coord = |k: usize| newton.iter().map(|q| q[k]).collect::<Vec<f64>>();
    f.point_batch(&coord(0), &coord(1), &coord(2), t, &mut values);
    let mut segments = Vec::new();
    for ((i, line), fn_) in lines.iter().zip(values) {
        match line.after_newton(fn_) {
            AfterNewton::Done(q) => out[*i] = Some((q, line.g)),
            AfterNewton::Bisect(s) => segments.push((*i, line.g, s)),
            AfterNewton::Grow => out[*i] = line.grow(f, t).map(|q| (q, line.g)),
        }
    }
    let ends: Vec<Segment> = segments.iter().map(|&(_, _, s)| s).collect();
    for ((i, g, _), q) in segments.into_iter().zip(bisect_batch(f, t, &ends)) {
        out[i] = Some((q, g));
    }
    out
}

/// [`project_along`]'s line: from `p` along the unit gradient `dir`, with
/// Newton's guess `guess` of the signed distance to the zero, within
/// `max_dist`.
#[derive(Clone, Copy, Debug)]
struct GradientLine {
    p: DVec3,
    fp: f64,
    g: DVec3,
    dir: DVec3,
    guess: f64,
    max_dist: f64,
}

/// What `f` at Newton's point says.
enum AfterNewton {
    /// The point is on the surface.
    Done(DVec3),
    /// The zero lies between the start and Newton's point.
    Bisect(Segment),
    /// Newton's point falls short: a bracket must be grown around it.
    Grow,
}

impl GradientLine {
    /// The line from `p`, given `f(p) = fp` and its gradient `g`; `Err` with
    /// the projection when it needs no line: `None` where the value or the
    /// gradient is not finite or the gradient is zero, `p` itself where
    /// `f(p) = 0`.
    fn start(
        p: DVec3,
        max_dist: f64,
        fp: f64,
        g: [f64; 3],
    ) -> Result<Self, Option<(DVec3, DVec3)>> {
        let g = DVec3::from_array(g);
        if !fp.is_finite() || !g.is_finite() || g.length_squared() == 0.0 {
            return Err(None);
        }
        if fp == 0.0 {
            return Err(Some((p, g)));
        }
        Ok(Self {
            p,
            fp,
            g,
            dir: g.normalize(),
            // Newton's guess of the signed distance along the gradient line.
            guess: (-fp / g.length()).clamp(-max_dist, max_dist),
            max_dist,
        })
    }

    /// Newton's point itself: on the surface, or past it (the zero lies
    /// between `p` and it), or short of it.
    fn newton(&self) -> DVec3 {
        self.p + self.dir * self.guess
    }

    /// The next step, given `f` at [`Self::newton`].
    fn after_newton(&self, fn_: f64) -> AfterNewton {
        let newton = self.newton();
        if fn_ == 0.0 {
            AfterNewton::Done(newton)
        } else if fn_.is_finite() && (fn_ < 0.0) != (self.fp < 0.0) {
            AfterNewton::Bisect(Segment {
                a: self.p,
                b: newton,
                fa: self.fp,
                fb: fn_,
            })
        } else {
            AfterNewton::Grow
        }
    }

    /// Short of the zero: a bracket grown around the guess until the sign
    /// changes, then bisected; `None` when it reaches `max_dist` both ways
    /// first.
    fn grow<E: Evaluator + ?Sized>(&self, f: &E, t: f64) -> Option<DVec3> {
        let (guess, max_dist) = (self.guess, self.max_dist);
        let mut step = (guess.abs() * 0.25).max(max_dist * 1e-6);
        for _ in 0..40 {
            let lo = (guess - step).max(-max_dist);
            let hi = (guess + step).min(max_dist);
            let (a, b) = (self.p + self.dir * lo, self.p + self.dir * hi);
            let (fa, fb) = (f.point(at(a, t)), f.point(at(b, t)));
            if fa.is_finite() && fb.is_finite() && (fa < 0.0) != (fb < 0.0) {
                return Some(bisect(f, t, a, b, fa, fb));
            }
            if lo <= -max_dist && hi >= max_dist {
                return None;
            }
            step *= 2.0;
        }
        None
    }
}
