//! Lock-step bisection ([`bisect_batch`]) against the scalar [`bisect`]:
//! on many random edges of a few functions (smooth, with a crease, with a
//! hole in the domain, with a pole), through the JIT (batch kernel) and the
//! reference interpreters (default batch loop), every result is bit for
//! bit the scalar one; one segment's evaluated points are the scalar's, in
//! the same order; and the batch takes exactly as many rounds as its
//! longest segment needs.

use std::sync::Mutex;

use glam::DVec3;
use isoc::eval::{Evaluator, GradEval, Reference};
use isoc::interval::{DecInterval, Interval};
use isoc::roots::{
    Segment, bisect, bisect_batch, line_zero, project, project_along, project_along_batch,
};
use isoc::{CompileOptions, Surface};

const FUNCTIONS: [&str; 4] = [
    // Smooth.
    "domain [-1.3, 1.3]^3; surface x^2 + y^2 + z^2 - 1;",
    // A crease where the two tori meet (min), sqrt.
    "domain [-2.6, 2.6], [-1.5, 1.5], [-0.6, 0.6];
     fn torus(x, y, z) = (sqrt(x^2 + y^2) - 1)^2 + z^2 - 0.09;
     surface min(torus(x - 1.15, y, z), torus(x + 1.15, y, z));",
    // Undefined (NaN) for |x| < 0.5: brackets across the hole.
    "domain [-1, 1]^3; surface sqrt(x^2 - 0.25) - y - 0.3;",
    // A pole: the sign changes across x = 0 without a zero.
    "domain [-1, 1]^3; surface 1 / x - y;",
];

/// SplitMix64.
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn at(p: DVec3, t: f64) -> [f64; 4] {
    [p.x, p.y, p.z, t]
}

/// Random segments of `s`'s domain whose ends have opposite signs
/// (`f < 0` against not): long ones, short ones, axis-aligned ones like
/// the dual grid's.
fn segments(s: &Surface, n: usize, seed: u64) -> Vec<Segment> {
    let d = s.domain;
    let mut rng = Rng(seed);
    let point = |rng: &mut Rng| {
        DVec3::from_array(std::array::from_fn(|k| {
            d.lo[k] + (d.hi[k] - d.lo[k]) * rng.unit()
        }))
    };
    let mut out = Vec::new();
    let mut tries = 0;
    while out.len() < n && tries < 200 * n {
        tries += 1;
        let a = point(&mut rng);
        let b = match tries % 3 {
            0 => point(&mut rng),
            1 => a + (point(&mut rng) - a) * 1e-3,
            _ => {
                let mut b = a;
                let k = (rng.unit() * 3.0) as usize % 3;
                b[k] = d.lo[k] + (d.hi[k] - d.lo[k]) * rng.unit();
                b
            }
        };
        let (fa, fb) = (s.point(at(a, 0.0)), s.point(at(b, 0.0)));
        if (fa < 0.0) != (fb < 0.0) {
            out.push(Segment { a, b, fa, fb });
        }
    }
    assert!(out.len() == n, "only {} segments found", out.len());
    out
}

fn bits(p: DVec3) -> [u64; 3] {
    p.to_array().map(f64::to_bits)
}

#[test]
fn batch_bisection_is_scalar_bisection_bit_for_bit() {
    for (fi, src) in FUNCTIONS.iter().enumerate() {
        let s = Surface::compile(src, "roots.iso", &CompileOptions::default()).expect("compiles");
        let reference = Reference(s.program.clone());
        let segs = segments(&s, 600, 17 + fi as u64);
        let jit = bisect_batch(&s, 0.0, &segs);
        let interp = bisect_batch(&reference, 0.0, &segs);
        assert_eq!(jit.len(), segs.len());
        for (i, g) in segs.iter().enumerate() {
            let want = bisect(&s, 0.0, g.a, g.b, g.fa, g.fb);
            assert_eq!(
                bits(jit[i]),
                bits(want),
                "function {fi}, segment {i}: {g:?}"
            );
            let want = bisect(&reference, 0.0, g.a, g.b, g.fa, g.fb);
            assert_eq!(
                bits(interp[i]),
                bits(want),
                "function {fi}, segment {i} (reference)"
            );
        }
        // Batches of every small size, and the empty one.
        for n in [0, 1, 2, 3, 7] {
            let got = bisect_batch(&s, 0.0, &segs[..n]);
            assert_eq!(got.len(), n);
            for (p, q) in got.iter().zip(&jit) {
                assert_eq!(bits(*p), bits(*q), "function {fi}, batch of {n}");
            }
        }
    }
}

/// Records every point evaluated and every batch call.
struct Recorder {
    inner: Reference,
    points: Mutex<Vec<[f64; 4]>>,
    batches: Mutex<usize>,
}

impl Evaluator for Recorder {
    fn point(&self, p: [f64; 4]) -> f64 {
        self.points.lock().unwrap().push(p);
        self.inner.point(p)
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        self.inner.point_grad(p)
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        self.inner.interval(b)
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        self.inner.grad(b)
    }
    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        *self.batches.lock().unwrap() += 1;
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.point([xs[i], ys[i], zs[i], t]);
        }
    }
}

impl Recorder {
    fn take(&self) -> (Vec<[u64; 4]>, usize) {
        let pts = std::mem::take(&mut *self.points.lock().unwrap());
        let batches = std::mem::take(&mut *self.batches.lock().unwrap());
        (pts.iter().map(|p| p.map(f64::to_bits)).collect(), batches)
    }
}

#[test]
fn batch_bisection_asks_for_the_scalar_points_in_lock_step() {
    for (fi, src) in FUNCTIONS.iter().enumerate() {
        let s = Surface::compile(src, "roots.iso", &CompileOptions::default()).expect("compiles");
        let rec = Recorder {
            inner: Reference(s.program.clone()),
            points: Mutex::new(Vec::new()),
            batches: Mutex::new(0),
        };
        let segs = segments(&s, 60, 99 + fi as u64);
        let mut longest = 0;
        for g in &segs {
            bisect(&rec, 0.0, g.a, g.b, g.fa, g.fb);
            let (scalar, _) = rec.take();
            bisect_batch(&rec, 0.0, std::slice::from_ref(g));
            let (batch, rounds) = rec.take();
            assert_eq!(batch, scalar, "function {fi}: {g:?}");
            // One round per value (the result needs no further one).
            assert_eq!(rounds, scalar.len(), "function {fi}: {g:?}");
            longest = longest.max(rounds);
        }
        bisect_batch(&rec, 0.0, &segs);
        let (_, rounds) = rec.take();
        assert_eq!(
            rounds, longest,
            "function {fi}: one round per step of the longest"
        );
    }
}

/// The steps a bisection takes: a few on a linear function (the secant
/// lands on the zero, a step of a few ulps closes the bracket), about ten
/// on a sphere, a few across a `max` crease of planes — plain bisection
/// takes about 55 on these segments; every result is a zero to rounding:
/// `|f|` within a few ulps' worth of the gradient.
#[test]
fn bisection_converges_fast_and_onto_the_zero() {
    let cases: [(&str, f64, f64); 3] = [
        ("domain [-1, 1]^3; surface x + 2*y - 0.3*z - 0.1;", 8.0, 4.0),
        (
            "domain [-1.3, 1.3]^3; surface x^2 + y^2 + z^2 - 1;",
            20.0,
            12.0,
        ),
        (
            "domain [-1, 1]^3; surface max(x - 0.2, 0.5*y - 0.1);",
            24.0,
            4.0,
        ),
    ];
    for (src, worst, mean) in cases {
        let s = Surface::compile(src, "roots.iso", &CompileOptions::default()).expect("compiles");
        let rec = Recorder {
            inner: Reference(s.program.clone()),
            points: Mutex::new(Vec::new()),
            batches: Mutex::new(0),
        };
        let segs = segments(&s, 300, 5);
        let mut total = 0;
        for g in &segs {
            let p = bisect(&rec, 0.0, g.a, g.b, g.fa, g.fb);
            let (asked, _) = rec.take();
            assert!(
                asked.len() as f64 <= worst,
                "{src}: {} steps on {g:?}",
                asked.len()
            );
            total += asked.len();
            let (v, grad) = s.point_grad(at(p, 0.0));
            let scale = DVec3::from_array(grad).length() * p.abs().max_element().max(1.0);
            assert!(
                v.abs() <= 8.0 * f64::EPSILON * scale,
                "{src}: f = {v:e} at {p}"
            );
        }
        let avg = total as f64 / segs.len() as f64;
        assert!(avg <= mean, "{src}: {avg} steps on average");
    }
}

/// Projection onto the unit sphere from random points near it: the result
/// is on the surface (to rounding), on the gradient line of the start (the
/// radius through it), within the allowed distance, with the start's
/// gradient returned; and no zero within reach gives `None`.
#[test]
fn projection_lands_on_the_gradient_line_within_reach() {
    let s =
        Surface::compile(FUNCTIONS[0], "sphere.iso", &CompileOptions::default()).expect("compiles");
    let mut rng = Rng(7);
    for _ in 0..500 {
        let d = DVec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5);
        if d.length() < 1e-3 {
            continue;
        }
        let dir = d.normalize();
        let r = 0.6 + 0.8 * rng.unit();
        let p = dir * r;
        let (q, g) = project_along(&s, 0.0, p, 0.5).expect("the sphere is within reach");
        assert!((q.length() - 1.0).abs() < 1e-14, "{p} → {q}");
        assert!(
            q.normalize().dot(dir) > 1.0 - 1e-12,
            "off the radius: {p} → {q}"
        );
        assert!((q - p).length() <= 0.5 + 1e-12);
        assert!(
            (g - 2.0 * p).length() < 1e-12 * (1.0 + g.length()),
            "{g} at {p}"
        );
        assert_eq!(project(&s, 0.0, p, 0.5), Some(q));
        // The sphere is farther than the reach allows.
        if (r - 1.0).abs() > 0.2 {
            assert_eq!(project(&s, 0.0, p, 0.1), None, "{p}");
        }
    }
}

/// Lock-step projection ([`project_along_batch`]) against the scalar
/// [`project_along`], through the JIT and the reference interpreters: from
/// random points of every function's domain, with reaches from a
/// thousandth of the domain to all of it (so that Newton's point lands on
/// the surface, past it, short of it, and nothing is within reach), every
/// result, `None` included, is the scalar one bit for bit; and both
/// outcomes (a zero, none within reach) occur over a thousand times.
#[test]
fn batch_projection_is_scalar_projection_bit_for_bit() {
    let key = |r: Option<(DVec3, DVec3)>| r.map(|(q, g)| (bits(q), bits(g)));
    let (mut found, mut none) = (0, 0);
    for (fi, src) in FUNCTIONS.iter().enumerate() {
        let s = Surface::compile(src, "roots.iso", &CompileOptions::default()).expect("compiles");
        let reference = Reference(s.program.clone());
        let d = s.domain;
        let mut rng = Rng(41 + fi as u64);
        let size = (0..3).map(|k| d.hi[k] - d.lo[k]).fold(0.0, f64::max);
        let starts: Vec<(DVec3, f64)> = (0..800)
            .map(|i| {
                let p = DVec3::from_array(std::array::from_fn(|k| {
                    d.lo[k] + (d.hi[k] - d.lo[k]) * rng.unit()
                }));
                (p, size * [1e-3, 1e-2, 0.1, 1.0][i % 4])
            })
            .collect();
        for (name, f) in [("jit", &s as &dyn Evaluator), ("reference", &reference)] {
            let got = project_along_batch(f, 0.0, &starts);
            assert_eq!(got.len(), starts.len());
            for (i, (&(p, reach), r)) in starts.iter().zip(&got).enumerate() {
                let want = project_along(f, 0.0, p, reach);
                assert_eq!(
                    key(*r),
                    key(want),
                    "function {fi} ({name}), start {i}: {p} within {reach}"
                );
                if r.is_some() { found += 1 } else { none += 1 }
            }
        }
        assert!(project_along_batch(&s, 0.0, &[]).is_empty());
    }
    assert!(found > 1000 && none > 1000, "found {found}, none {none}");
}

/// `line_zero` finds the zero nearest to the start along a line (either
/// direction), on the surface to bisection precision, and nothing when no
/// sign change lies within reach or the direction is zero.
#[test]
fn line_zero_finds_the_nearest_zero_along_a_line() {
    let s = Surface::compile(
        "domain [-2, 2]^3; surface x^2 + y^2 + z^2 - 1;",
        "t.iso",
        &CompileOptions::default(),
    )
    .unwrap();
    // From inside, along +x and -x: the nearer crossing is at x = +1
    // (start at x = 0.3); the sphere is 0.7 away that way and 1.3 the other.
    let p = DVec3::new(0.3, 0.0, 0.0);
    for dir in [DVec3::X, DVec3::NEG_X] {
        let q = line_zero(&s, 0.0, p, dir, 1.0).expect("a zero within reach");
        assert!(
            (q.x - 1.0).abs() < 1e-12 && q.y == 0.0 && q.z == 0.0,
            "{q:?}"
        );
    }
    // Tangent line at distance 0.5 from the sphere: no crossing.
    let p = DVec3::new(0.0, 1.5, 0.0);
    assert!(line_zero(&s, 0.0, p, DVec3::X, 1.0).is_none());
    // Too short a reach, and a zero direction.
    assert!(line_zero(&s, 0.0, DVec3::ZERO, DVec3::X, 0.5).is_none());
    assert!(line_zero(&s, 0.0, DVec3::new(0.9, 0.0, 0.0), DVec3::ZERO, 1.0).is_none());
    // An oblique line from outside: the point found is on the sphere and on
    // the line.
    let (p, d) = (DVec3::new(1.2, 0.3, -0.1), DVec3::new(-1.0, 0.2, 0.1));
    let q = line_zero(&s, 0.0, p, d, 1.0).expect("a crossing");
    assert!((q.length() - 1.0).abs() < 1e-12, "{q:?}");
    let off = (q - p).cross(d.normalize()).length();
    assert!(off < 1e-12, "{q:?} is {off:e} off the line");
}
