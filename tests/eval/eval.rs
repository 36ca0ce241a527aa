//! The shared backend suite run against the reference interpreters, plus
//! tests showing the suite's checks catch broken backends.

use crate::support::{
    check_batches, check_degenerate, check_grad, check_interval, check_point_grad,
};
use isoc::eval::{Evaluator, GradEval, Reference};
use isoc::interval::{DecInterval, Interval};
use isoc::ir::{BinOp, Op, Program, UnOp, Value, Var};

backend_suite!(reference, |p: &Program| Reference(p.clone()));

/// A wrong backend: shrinks intervals by one ulp at the top, drops the
/// undefinedness flag and reports a zero gradient.
struct Broken(Reference, u8);

impl Evaluator for Broken {
    fn point(&self, p: [f64; 4]) -> f64 {
        self.0.point(p)
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        self.0.point_grad(p)
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        let r = self.0.interval(b);
        match self.1 {
            0 => DecInterval::new(Interval::new(r.iv.lo, r.iv.hi.next_down()), r.defined),
            _ => DecInterval::new(r.iv, true),
        }
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        let mut g = self.0.grad(b);
        g.grad = [Interval::point(0.0); 3];
        g
    }
}

fn prog(insts: Vec<Op>) -> Program {
    let output = Value(insts.len() as u32 - 1);
    Program { insts, output }
}

fn boxed(x: Interval) -> [Interval; 4] {
    [
        x,
        Interval::point(0.0),
        Interval::point(0.0),
        Interval::point(0.0),
    ]
}

#[test]
fn checks_catch_a_narrow_interval() {
    let p = prog(vec![Op::Var(Var::X)]);
    let b = boxed(Interval::new(0.0, 1.0));
    assert!(check_interval(&Reference(p.clone()), &p, &b, 1).is_ok());
    assert!(check_interval(&Broken(Reference(p.clone()), 0), &p, &b, 1).is_err());
    let d = [1.0, 0.0, 0.0, 0.0];
    assert!(check_degenerate(&Broken(Reference(p.clone()), 0), &p, d).is_err());
}

#[test]
fn checks_catch_a_false_defined_flag() {
    // sqrt(x) on [-1, 1]: undefined at the negative samples.
    let p = prog(vec![Op::Var(Var::X), Op::Unary(UnOp::Sqrt, Value(0))]);
    let b = boxed(Interval::new(-1.0, 1.0));
    assert!(check_interval(&Reference(p.clone()), &p, &b, 7).is_ok());
    assert!(check_interval(&Broken(Reference(p.clone()), 1), &p, &b, 7).is_err());
}

#[test]
fn checks_catch_a_wrong_gradient() {
    // x·x on [1, 2]: gradient 2x is never 0.
    let p = prog(vec![
        Op::Var(Var::X),
        Op::Binary(BinOp::Mul, Value(0), Value(0)),
    ]);
    let b = boxed(Interval::new(1.0, 2.0));
    assert!(check_grad(&Reference(p.clone()), &p, &b, 3).is_ok());
    assert!(check_grad(&Broken(Reference(p.clone()), 0), &p, &b, 3).is_err());
}

/// Wrong batch or point-gradient forms over a correct reference: mode 0
/// drops the last point of a point batch (leaves it 0), 1 swaps the last
/// two boxes of an interval batch, 2 returns the gradient with the wrong
/// sign, 3 a point-gradient value one ulp off.
struct BrokenBatch(Reference, u8);

impl Evaluator for BrokenBatch {
    fn point(&self, p: [f64; 4]) -> f64 {
        self.0.point(p)
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        let (v, g) = self.0.point_grad(p);
        match self.1 {
            2 => (v, g.map(|d| -d)),
            3 => (v.next_up(), g),
            _ => (v, g),
        }
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        self.0.interval(b)
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        self.0.grad(b)
    }
    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        self.0.point_batch(xs, ys, zs, t, out);
        if self.1 == 0
            && let Some(last) = out.last_mut()
        {
            *last = 0.0;
        }
    }
    fn interval_batch(&self, boxes: &[[Interval; 4]], out: &mut [DecInterval]) {
        self.0.interval_batch(boxes, out);
        if self.1 == 1 && out.len() >= 2 {
            let n = out.len();
            out.swap(n - 1, n - 2);
        }
    }
}

/// x·x + 1: never 0, gradient 2x.
fn x_squared_plus_one() -> Program {
    prog(vec![
        Op::Var(Var::X),
        Op::Binary(BinOp::Mul, Value(0), Value(0)),
        Op::Const(isoc::ir::Const {
            value: 1.0,
            lo: 1.0,
            hi: 1.0,
            defined: true,
        }),
        Op::Binary(BinOp::Add, Value(1), Value(2)),
    ])
}

#[test]
fn checks_catch_wrong_batches_and_point_gradients() {
    let p = x_squared_plus_one();
    let pts = [[1.0, 0.0, 0.0], [2.0, 5.0, 0.0], [3.0, 0.0, -1.0]];
    let boxes = [
        boxed(Interval::new(0.0, 1.0)),
        boxed(Interval::new(2.0, 3.0)),
    ];
    let good = Reference(p.clone());
    assert!(check_batches(&good, &pts, 0.0, &boxes).is_ok());
    assert!(check_batches(&BrokenBatch(good.clone(), 0), &pts, 0.0, &boxes).is_err());
    assert!(check_batches(&BrokenBatch(good.clone(), 1), &pts, 0.0, &boxes).is_err());
    // Empty batches are fine, and so is a one-box swap (nothing to swap).
    assert!(check_batches(&BrokenBatch(good.clone(), 1), &[], 0.0, &boxes[..1]).is_ok());
    let at = [1.5, 0.0, 0.0, 0.0];
    assert!(check_point_grad(&good, &p, at).is_ok());
    assert!(check_point_grad(&BrokenBatch(good.clone(), 2), &p, at).is_err());
    assert!(check_point_grad(&BrokenBatch(good, 3), &p, at).is_err());
}

fn decimal(v: f64) -> isoc::ir::Const {
    isoc::ir::Const {
        value: v,
        lo: v.next_down(),
        hi: v.next_up(),
        defined: true,
    }
}

#[test]
fn decimal_constants_stay_sound() {
    // x + 0.1 + 0.2 on x = [0, 0] must enclose the real 0.3.
    let p = prog(vec![
        Op::Var(Var::X),
        Op::Const(decimal(0.1)),
        Op::Binary(BinOp::Add, Value(0), Value(1)),
        Op::Const(decimal(0.2)),
        Op::Binary(BinOp::Add, Value(2), Value(3)),
    ]);
    let r = isoc::eval::interval::eval(&p, boxed(Interval::point(0.0)));
    assert!(r.defined);
    assert!(r.iv.lo <= 0.3 && 0.3f64.next_up() <= r.iv.hi, "{r:?}");
    assert!(r.iv.contains(isoc::eval::point::eval(&p, [0.0; 4])));
}

#[test]
fn dead_undefined_code_does_not_spoil_the_flag() {
    let p = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Unary(UnOp::Sqrt, Value(0)),
            Op::Unary(UnOp::Exp, Value(0)),
        ],
        output: Value(2),
    };
    let r = isoc::eval::interval::eval(&p, boxed(Interval::new(-2.0, -1.0)));
    assert!(r.defined);
    // … but a used one does.
    let p = Program {
        output: Value(1),
        ..p
    };
    let r = isoc::eval::interval::eval(&p, boxed(Interval::new(-2.0, -1.0)));
    assert!(!r.defined && r.iv.is_empty());
    assert!(isoc::eval::point::eval(&p, [-1.5, 0.0, 0.0, 0.0]).is_nan());
}

#[test]
fn log_of_shifted_variable() {
    // log(x - 1) on [0.5, 3]: undefined below 1, upper bound log 2.
    let p = prog(vec![
        Op::Var(Var::X),
        Op::Const(isoc::ir::Const::exact(1.0)),
        Op::Binary(BinOp::Sub, Value(0), Value(1)),
        Op::Unary(UnOp::Log, Value(2)),
    ]);
    let r = isoc::eval::interval::eval(&p, boxed(Interval::new(0.5, 3.0)));
    assert!(!r.defined);
    assert_eq!(r.iv.lo, f64::NEG_INFINITY);
    assert!(r.iv.hi >= 2f64.ln() && r.iv.hi < 0.7);
    assert!(isoc::eval::point::eval(&p, [1.0, 0.0, 0.0, 0.0]).is_nan());
}

#[test]
fn heart_surface_values() {
    // (2x² + y² + z² − 1)³ − (0.1x² + y²)z³, Paiva et al. Fig. 2.
    let c = isoc::ir::Const::exact;
    let p = prog(vec![
        Op::Var(Var::X),                              // 0
        Op::Var(Var::Y),                              // 1
        Op::Var(Var::Z),                              // 2
        Op::Unary(UnOp::Square, Value(0)),            // 3 x²
        Op::Unary(UnOp::Square, Value(1)),            // 4 y²
        Op::Unary(UnOp::Square, Value(2)),            // 5 z²
        Op::Const(c(2.0)),                            // 6
        Op::Binary(BinOp::Mul, Value(6), Value(3)),   // 7
        Op::Binary(BinOp::Add, Value(7), Value(4)),   // 8
        Op::Binary(BinOp::Add, Value(8), Value(5)),   // 9
        Op::Const(c(1.0)),                            // 10
        Op::Binary(BinOp::Sub, Value(9), Value(10)),  // 11
        Op::Powi(Value(11), 3),                       // 12
        Op::Const(decimal(0.1)),                      // 13
        Op::Binary(BinOp::Mul, Value(13), Value(3)),  // 14
        Op::Binary(BinOp::Add, Value(14), Value(4)),  // 15
        Op::Powi(Value(2), 3),                        // 16
        Op::Binary(BinOp::Mul, Value(15), Value(16)), // 17
        Op::Binary(BinOp::Sub, Value(12), Value(17)), // 18
    ]);
    // At the origin: (−1)³ − 0 = −1.
    assert_eq!(isoc::eval::point::eval(&p, [0.0; 4]), -1.0);
    // At (0, 0, 1): 0 − 0 = 0; at (0, 1, 1): 1 − 1 = 0.
    assert_eq!(isoc::eval::point::eval(&p, [0.0, 0.0, 1.0, 0.0]), 0.0);
    assert_eq!(isoc::eval::point::eval(&p, [0.0, 1.0, 1.0, 0.0]), 0.0);
    let (v, g) = isoc::eval::grad::eval_point(&p, [0.0, 1.0, 1.0, 0.0]);
    // ∂/∂y = 3(·)²·2y − 2y z³ = 6 − 2 = 4; ∂/∂z = 6 − 3 = 3; ∂/∂x = 0.
    assert_eq!((v, g), (0.0, [0.0, 4.0, 3.0]));
    let b = [
        Interval::new(-0.1, 0.1),
        Interval::new(-0.1, 0.1),
        Interval::new(-0.1, 0.1),
        Interval::point(0.0),
    ];
    let r = isoc::eval::interval::eval(&p, b);
    assert!(r.defined && r.iv.hi < 0.0, "{r:?}");
}

#[test]
fn malformed_programs_do_not_panic() {
    // v0 uses v5, which does not exist; the output is out of range too.
    let p = Program {
        insts: vec![Op::Unary(UnOp::Sin, Value(5))],
        output: Value(0),
    };
    assert!(isoc::eval::point::eval(&p, [0.0; 4]).is_nan());
    assert!(!isoc::eval::interval::eval(&p, boxed(Interval::point(0.0))).defined);
    assert!(!isoc::eval::grad::eval(&p, boxed(Interval::point(0.0))).defined);
    let q = Program {
        output: Value(9),
        ..p
    };
    assert!(isoc::eval::point::eval(&q, [0.0; 4]).is_nan());
    assert!(!isoc::eval::interval::eval(&q, boxed(Interval::point(0.0))).defined);
    assert!(isoc::eval::grad::eval_point(&q, [0.0; 4]).0.is_nan());
}

mod isotonicity {
    //! Inclusion isotonicity of the reference interval evaluator: a sub-box
    //! never gets a wider enclosure, nor a weaker flag. Not needed for
    //! soundness, but the octree relies on refinement never losing
    //! information (and it caught one-ulp steps crossing 0 or 1).
    use crate::support::{Rng, arb_box, arb_program, cases, sample};
    use isoc::interval::Interval;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(cases()))]

        #[test]
        fn sub_boxes_get_sub_intervals(program in arb_program(), b in arb_box(), seed in any::<u64>()) {
            let mut rng = Rng(seed);
            let sub: [Interval; 4] = std::array::from_fn(|i| {
                let (x, y) = (sample(b[i], &mut rng), sample(b[i], &mut rng));
                Interval::new(x.min(y), x.max(y))
            });
            let r = isoc::eval::interval::eval(&program, b);
            let s = isoc::eval::interval::eval(&program, sub);
            prop_assert!(s.iv.subset_of(&r.iv), "{s:?} on {sub:?} is not inside {r:?} on {b:?}\n{program:?}");
            prop_assert!(!r.defined || s.defined, "flag lost on a sub-box {sub:?} of {b:?}\n{program:?}");
        }
    }
}

mod vm_ops {
    //! Fidget's ops (`floor ceil round not compare mod and or`): interval
    //! enclosures over random boxes, the "defined and continuous" flag
    //! false whenever two samples of the box straddle a jump, gradient
    //! enclosures against finite differences where continuous, and the JIT
    //! equal to the reference interpreter on programs using them.
    use crate::support::cases;
    use isoc::eval::{grad, point};
    use isoc::interval::Interval;
    use isoc::ir::{BinOp, Builder, Program, UnOp, Var};
    use proptest::prelude::*;

    const UNARY: [UnOp; 4] = [UnOp::Floor, UnOp::Ceil, UnOp::Round, UnOp::Not];
    const BINARY: [BinOp; 4] = [BinOp::Compare, BinOp::Mod, BinOp::And, BinOp::Or];

    /// A bound: often an integer, a half-integer or zero (where the jumps
    /// are), else any value in [-6, 6].
    fn arb_bound() -> impl Strategy<Value = f64> {
        prop_oneof![
            2 => (-6i32..=6).prop_map(f64::from),
            1 => (-12i32..=12).prop_map(|k| f64::from(k) / 2.0),
            1 => Just(0.0),
            4 => -6.0f64..6.0,
        ]
    }

    /// An interval; a quarter of them degenerate.
    fn arb_iv() -> impl Strategy<Value = Interval> {
        prop_oneof![
            3 => (arb_bound(), arb_bound()).prop_map(|(a, b)| Interval::new(a.min(b), a.max(b))),
            1 => arb_bound().prop_map(Interval::point),
        ]
    }

    /// Samples of `iv`: both ends, the midpoint and random points.
    fn samples(iv: Interval, seed: u64) -> Vec<f64> {
        let mut rng = crate::support::Rng(seed);
        let mut v = vec![iv.lo, iv.hi, 0.5 * (iv.lo + iv.hi)];
        for _ in 0..20 {
            v.push(iv.lo + (iv.hi - iv.lo) * rng.unit());
        }
        for k in (iv.lo.ceil() as i64)..=(iv.hi.floor() as i64) {
            v.push(k as f64);
        }
        v.retain(|x| iv.contains(*x));
        v
    }

    /// `⌊x/|y|⌋`, or None too close to a jump to tell in f64.
    fn period(x: f64, y: f64) -> Option<f64> {
        let q = x / y.abs();
        ((q - q.round()).abs() > 1e-9).then(|| q.floor())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(cases()))]

        #[test]
        fn unary_enclosure_and_jumps(k in 0usize..4, a in arb_iv(), seed in any::<u64>()) {
            let op = UNARY[k];
            let (r, defined) = isoc::ir::semantics::enclose_unary(op, a);
            let xs = samples(a, seed);
            let vals: Vec<f64> = xs.iter().map(|&x| isoc::ir::semantics::point_unary(op, x)).collect();
            for (x, v) in xs.iter().zip(&vals) {
                prop_assert!(r.contains(*v), "{op:?} {a:?} = {r:?} misses {v} at {x}");
            }
            if vals.iter().any(|v| *v != vals[0]) {
                prop_assert!(!defined, "{op:?} {a:?}: a jump inside, yet continuous");
            }
        }

        #[test]
        fn binary_enclosure_and_jumps(k in 0usize..4, a in arb_iv(), b in arb_iv(), seed in any::<u64>()) {
            let op = BINARY[k];
            let (r, defined) = isoc::ir::semantics::enclose_binary(op, a, b);
            let xs = samples(a, seed);
            let ys = samples(b, seed ^ 0x5555);
            let mut seen: Vec<(f64, f64, f64)> = Vec::new();
            for &x in &xs {
                for &y in &ys {
                    let v = isoc::ir::semantics::point_binary(op, x, y);
                    if v.is_nan() {
                        prop_assert!(!defined, "{op:?} {a:?} {b:?}: NaN at ({x}, {y}), yet defined");
                        continue;
                    }
                    prop_assert!(r.contains(v), "{op:?} {a:?} {b:?} = {r:?} misses {v} at ({x}, {y})");
                    seen.push((x, y, v));
                }
            }
            // Two samples on both sides of a jump: the flag must be false.
            let jump = |p: &(f64, f64, f64), q: &(f64, f64, f64)| match op {
                BinOp::Compare => p.2 != q.2,
                BinOp::And | BinOp::Or => (p.0 == 0.0) != (q.0 == 0.0),
                _ => matches!((period(p.0, p.1), period(q.0, q.1)), (Some(s), Some(t)) if s != t),
            };
            if let Some(first) = seen.first()
                && seen.iter().any(|q| jump(first, q))
            {
                prop_assert!(!defined, "{op:?} {a:?} {b:?}: a jump inside, yet continuous");
            }
        }

        #[test]
        fn gradient_contains_finite_differences(
            k in 0usize..8,
            cx in -2.0f64..2.0, cy in -2.0f64..2.0,
            w in 1e-3f64..0.5, c in arb_bound(),
            seed in any::<u64>(),
        ) {
            let prog = two_var_program(k, c);
            let bx = [
                Interval::new(cx - w, cx + w),
                Interval::new(cy - w, cy + w),
                Interval::point(0.0),
                Interval::point(0.0),
            ];
            let g = grad::eval(&prog, bx);
            let jit = isoc::Surface::from_program("t", prog.clone(), isoc::Bounds { lo: [-1.0; 3], hi: [1.0; 3] }, vec![]).unwrap();
            let gj = jit.grad(bx);
            let mut rng = crate::support::Rng(seed);
            let h = 1e-7;
            for _ in 0..8 {
                let p = [cx + 0.9 * w * (2.0 * rng.unit() - 1.0), cy + 0.9 * w * (2.0 * rng.unit() - 1.0)];
                let f = |x: f64, y: f64| point::eval(&prog, [x, y, 0.0, 0.0]);
                let (_, dv) = grad::eval_point(&prog, [p[0], p[1], 0.0, 0.0]);
                for (gg, name) in [(&g, "reference"), (&gj, "jit")] {
                    for (i, d) in dv.iter().take(2).enumerate() {
                        prop_assert!(gg.grad[i].contains(*d) || d.is_nan(), "{name}: AD {d} outside {:?}\n{prog}", gg.grad[i]);
                    }
                    if !gg.defined {
                        continue;
                    }
                    let fd = [
                        (f(p[0] + h, p[1]) - f(p[0] - h, p[1])) / (2.0 * h),
                        (f(p[0], p[1] + h) - f(p[0], p[1] - h)) / (2.0 * h),
                    ];
                    for (i, &fdi) in fd.iter().enumerate() {
                        let iv = gg.grad[i];
                        let tol = 1e-5 * (1.0 + fdi.abs());
                        prop_assert!(
                            iv.lo - tol <= fdi && fdi <= iv.hi + tol,
                            "{name}: finite difference {} outside {iv:?} at {p:?} on {bx:?}\n{prog}", fdi
                        );
                    }
                }
            }
        }

        #[test]
        fn jit_equals_reference(k in 0usize..8, c in arb_bound(), pts in prop::collection::vec((-3.0f64..3.0, -3.0f64..3.0), 1..20)) {
            let prog = two_var_program(k, c);
            let s = isoc::Surface::from_program("t", prog.clone(), isoc::Bounds { lo: [-1.0; 3], hi: [1.0; 3] }, vec![]).unwrap();
            for &(x, y) in &pts {
                let p = [x, y, 0.0, 0.0];
                let (a, b) = (s.point(p), point::eval(&prog, p));
                prop_assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "point {a} != {b}\n{prog}");
                let (v, d) = s.point_grad(p);
                let (v2, d2) = grad::eval_point(&prog, p);
                for (u, w) in std::iter::once((v, v2)).chain(d.into_iter().zip(d2)) {
                    prop_assert!(u.to_bits() == w.to_bits() || (u.is_nan() && w.is_nan()), "point_grad {u} != {w}\n{prog}");
                }
                let iv = s.interval(p.map(Interval::point));
                prop_assert!(b.is_nan() || iv.iv.contains(b), "{iv:?} misses {b}\n{prog}");
            }
        }
    }

    /// Programs in `x`, `y` exercising the new ops on non-trivial operands
    /// (`c` a constant).
    fn two_var_program(k: usize, c: f64) -> Program {
        let mut b = Builder::new();
        let x = b.var(Var::X);
        let y = b.var(Var::Y);
        let three = b.num(3.0);
        let cc = b.num(c);
        let t = b.binary(BinOp::Mul, three, x);
        let g = b.binary(BinOp::Add, t, y); // 3x + y
        let h0 = b.binary(BinOp::Mul, x, y);
        let h = b.binary(BinOp::Sub, h0, cc); // xy − c
        let out = match k {
            0 => b.unary(UnOp::Floor, g),
            1 => {
                let r = b.unary(UnOp::Round, g);
                b.binary(BinOp::Add, r, x)
            }
            2 => {
                let n = b.unary(UnOp::Not, h);
                b.binary(BinOp::Mul, n, y)
            }
            3 => {
                let cmp = b.binary(BinOp::Compare, g, h);
                b.binary(BinOp::Add, cmp, h)
            }
            4 => {
                let m = if c == 0.0 { b.num(0.7) } else { cc };
                b.binary(BinOp::Mod, g, m)
            }
            5 => {
                let sq = b.unary(UnOp::Square, y);
                let one = b.num(1.0);
                let m = b.binary(BinOp::Add, sq, one);
                b.binary(BinOp::Mod, h, m)
            }
            6 => {
                let f = b.unary(UnOp::Ceil, x);
                let a = b.binary(BinOp::And, f, h);
                b.binary(BinOp::Add, a, g)
            }
            _ => {
                let f = b.unary(UnOp::Floor, y);
                b.binary(BinOp::Or, f, h)
            }
        };
        b.finish(out)
    }

    #[test]
    fn fidget_semantics_at_points() {
        use isoc::ir::semantics::{point_binary as binary, point_unary as unary};
        assert_eq!(unary(UnOp::Round, 2.5), 3.0);
        assert_eq!(unary(UnOp::Round, -2.5), -3.0);
        assert_eq!(unary(UnOp::Round, 0.49999999999999994), 0.0);
        assert_eq!(unary(UnOp::Floor, -0.5), -1.0);
        assert_eq!(unary(UnOp::Ceil, -0.5), -0.0);
        assert_eq!(unary(UnOp::Not, 0.0), 1.0);
        assert_eq!(unary(UnOp::Not, -0.0), 1.0);
        assert_eq!(unary(UnOp::Not, 3.0), 0.0);
        assert!(unary(UnOp::Not, f64::NAN).is_nan());
        assert_eq!(binary(BinOp::Compare, 1.0, 2.0), -1.0);
        assert_eq!(binary(BinOp::Compare, 2.0, 2.0), 0.0);
        assert_eq!(binary(BinOp::Compare, 3.0, 2.0), 1.0);
        assert!(binary(BinOp::Compare, f64::NAN, 2.0).is_nan());
        assert_eq!(binary(BinOp::Mod, -1.0, 3.0), 2.0);
        assert_eq!(binary(BinOp::Mod, -1.0, -3.0), 2.0);
        assert_eq!(binary(BinOp::Mod, 7.5, 2.0), 1.5);
        assert!(binary(BinOp::Mod, 1.0, 0.0).is_nan());
        assert_eq!(binary(BinOp::And, 0.0, 5.0), 0.0);
        assert_eq!(binary(BinOp::And, 2.0, 5.0), 5.0);
        assert_eq!(binary(BinOp::Or, 0.0, 5.0), 5.0);
        assert_eq!(binary(BinOp::Or, 2.0, 5.0), 2.0);
        // Interval rules at a glance.
        let iv = |a: f64, b: f64| Interval::new(a, b);
        assert_eq!(
            isoc::ir::semantics::enclose_unary(UnOp::Floor, iv(0.2, 0.9)),
            (iv(0.0, 0.0), true)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_unary(UnOp::Floor, iv(0.2, 1.0)),
            (iv(0.0, 1.0), false)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_binary(BinOp::Mod, iv(2.25, 2.75), iv(1.0, 1.0)),
            (iv(0.25, 0.75), true)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_binary(BinOp::Mod, iv(2.25, 3.25), iv(1.0, 1.0)),
            (iv(0.0, 1.0), false)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_binary(BinOp::Compare, iv(0.0, 1.0), iv(2.0, 3.0)),
            (iv(-1.0, -1.0), true)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_binary(BinOp::Compare, iv(0.0, 2.0), iv(2.0, 3.0)),
            (iv(-1.0, 0.0), false)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_binary(BinOp::And, iv(1.0, 2.0), iv(5.0, 6.0)),
            (iv(5.0, 6.0), true)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_binary(BinOp::And, iv(-1.0, 2.0), iv(5.0, 6.0)),
            (iv(0.0, 6.0), false)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_binary(BinOp::Or, iv(0.0, 0.0), iv(5.0, 6.0)),
            (iv(5.0, 6.0), true)
        );
        assert_eq!(
            isoc::ir::semantics::enclose_unary(UnOp::Not, iv(-1.0, 1.0)),
            (iv(0.0, 1.0), false)
        );
    }
}

mod vm_models {
    //! Each shared `.vm` model: box enclosures from `Surface::interval`
    //! contain dense samples of `Surface::point` (soundness), and the point
    //! values agree with the independent interpreter of the text.
    use crate::support::vmref;
    use isoc::interval::Interval;
    use isoc::{CompileOptions, Surface};

    /// The enclosure over the whole domain (prospero's 7,866 instructions
    /// included) holds a 9³ grid of point values, and is not the entire
    /// line: the interval kernels handle the largest box a mesh starts
    /// from.
    #[test]
    fn whole_domain_enclosures_contain_samples() {
        for model in vmref::MODELS {
            let text = std::fs::read_to_string(vmref::models_dir().join(model)).unwrap();
            let s = Surface::compile(&text, model, &CompileOptions::default())
                .unwrap_or_else(|e| panic!("{}", e.render()));
            let side = |k: usize| Interval::new(s.domain.lo[k], s.domain.hi[k]);
            let b4 = [side(0), side(1), side(2), Interval::point(0.0)];
            let (r, g) = (s.interval(b4), s.grad(b4));
            assert!(
                r.iv.lo.is_finite() && r.iv.hi.is_finite(),
                "{model}: {r:?} over the whole domain"
            );
            let n = 8;
            let at = |k: usize, t: usize| {
                s.domain.lo[k] + (s.domain.hi[k] - s.domain.lo[k]) * t as f64 / n as f64
            };
            for i in 0..=n {
                for j in 0..=n {
                    for k in 0..=n {
                        let p = [at(0, i), at(1, j), at(2, k), 0.0];
                        let v = s.point(p);
                        assert!(
                            v.is_nan() || (r.iv.contains(v) && g.value.contains(v)),
                            "{model}: {r:?} / {:?} over the domain miss {v} at {p:?}",
                            g.value
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn enclosures_contain_samples() {
        for (m, model) in vmref::MODELS.iter().enumerate() {
            let text = std::fs::read_to_string(vmref::models_dir().join(model)).unwrap();
            let s = Surface::compile(&text, model, &CompileOptions::default())
                .unwrap_or_else(|e| panic!("{}", e.render()));
            assert_eq!(s.domain.lo, [-1.0; 3]);
            assert_eq!(s.domain.hi, [1.0; 3]);
            let mut rng = vmref::Lcg(12345 + m as u64);
            for _ in 0..30 {
                let w = [0.5, 0.1, 0.01][(rng.unit() * 3.0) as usize % 3];
                let bx: [Interval; 3] = std::array::from_fn(|_| {
                    let lo = rng.range(-1.0, 1.0 - w);
                    Interval::new(lo, lo + w * rng.range(0.2, 1.0))
                });
                let b4 = [bx[0], bx[1], bx[2], Interval::point(0.0)];
                let r = s.interval(b4);
                let g = s.grad(b4);
                let n = 6;
                for i in 0..=n {
                    for j in 0..=n {
                        for k in 0..=n {
                            let at = |iv: Interval, t: usize| {
                                (iv.lo + (iv.hi - iv.lo) * t as f64 / n as f64).clamp(iv.lo, iv.hi)
                            };
                            let p = [at(bx[0], i), at(bx[1], j), at(bx[2], k), 0.0];
                            let v = s.point(p);
                            assert!(
                                v.is_nan() || r.iv.contains(v),
                                "{model}: {r:?} on {bx:?} misses {v} at {p:?}"
                            );
                            assert!(
                                v.is_nan() || g.value.contains(v),
                                "{model}: grad value {:?} misses {v}",
                                g.value
                            );
                            if i == 3 && j == 3 {
                                let want = vmref::eval(&text, p[0], p[1], p[2]);
                                assert!(
                                    vmref::agree(v, want),
                                    "{model} at {p:?}: {v} vs reference {want}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}

// ------------------------------------------------------------ pruning

mod prune {
    use crate::support::{Rng, arb_box, arb_program, cases, sample};
    use isoc::eval::prune::{has_choices, prune};
    use isoc::eval::{Evaluator, Reference, point};
    use isoc::interval::Interval;
    use isoc::ir::{BinOp, Builder, Op, Program, UnOp, Value, Var};
    use proptest::prelude::*;

    /// A random CSG solid over spheres and planes: `min` (union), `max`
    /// (intersection), `max(a, −b)` (difference), and now and then
    /// Fidget's `and`/`or` of two operands.
    #[derive(Clone, Debug)]
    enum Csg {
        Sphere([f64; 3], f64),
        Plane([f64; 3], f64),
        Node(u8, Box<Csg>, Box<Csg>),
    }

    fn arb_csg() -> impl Strategy<Value = Csg> {
        let c = -1.0f64..1.0;
        let leaf = prop_oneof![
            ([c.clone(), c.clone(), c.clone()], 0.05f64..0.8).prop_map(|(p, r)| Csg::Sphere(p, r)),
            ([c.clone(), c.clone(), c.clone()], c).prop_map(|(n, d)| Csg::Plane(n, d)),
        ];
        leaf.prop_recursive(5, 40, 2, |inner| {
            (0u8..5, inner.clone(), inner)
                .prop_map(|(k, a, b)| Csg::Node(k, Box::new(a), Box::new(b)))
        })
    }

    fn lower(c: &Csg, b: &mut Builder) -> Value {
        let var = |b: &mut Builder, k: usize| b.var([Var::X, Var::Y, Var::Z][k]);
        match c {
            Csg::Sphere(p, r) => {
                let mut acc = b.num(-r * r);
                for (k, &pk) in p.iter().enumerate() {
                    let v = var(b, k);
                    let o = b.num(pk);
                    let d = b.binary(BinOp::Sub, v, o);
                    let sq = b.unary(UnOp::Square, d);
                    acc = b.binary(BinOp::Add, acc, sq);
                }
                acc
            }
            Csg::Plane(n, d) => {
                let mut acc = b.num(*d);
                for (k, &nk) in n.iter().enumerate() {
                    let v = var(b, k);
                    let c = b.num(nk);
                    let t = b.binary(BinOp::Mul, c, v);
                    acc = b.binary(BinOp::Add, acc, t);
                }
                acc
            }
            Csg::Node(k, l, r) => {
                let (l, r) = (lower(l, b), lower(r, b));
                match k {
                    0 => b.binary(BinOp::Min, l, r),
                    1 => b.binary(BinOp::Max, l, r),
                    2 => {
                        let nr = b.unary(UnOp::Neg, r);
                        b.binary(BinOp::Max, l, nr)
                    }
                    3 => b.binary(BinOp::And, l, r),
                    _ => b.binary(BinOp::Or, l, r),
                }
            }
        }
    }

    fn program_of(c: &Csg) -> Program {
        let mut b = Builder::new();
        let out = lower(c, &mut b);
        b.finish(out)
    }

    /// A cube of side `2^-k` in [-1, 1]³ (as the octree's cells), `t = 0`.
    fn arb_cell() -> impl Strategy<Value = [Interval; 4]> {
        (0u32..6, [0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0]).prop_map(|(k, u)| {
            let n = (1u32 << k) as f64;
            let side = |u: f64| {
                let i = (u * n).floor();
                Interval::new(-1.0 + 2.0 * i / n, -1.0 + 2.0 * (i + 1.0) / n)
            };
            [side(u[0]), side(u[1]), side(u[2]), Interval::point(0.0)]
        })
    }

    /// A random sub-box of `b` (on x, y, z).
    fn sub_box(b: &[Interval; 4], rng: &mut Rng) -> [Interval; 4] {
        let mut s = *b;
        for side in s.iter_mut().take(3) {
            let (u, v) = (sample(*side, rng), sample(*side, rng));
            if u.is_finite() && v.is_finite() {
                *side = Interval::new(u.min(v), u.max(v));
            }
        }
        s
    }

    /// Whether the full program's value at `p` is NaN because a selecting
    /// instruction has a NaN operand (the documented exception: an
    /// overflow inside a dropped branch).
    fn nan_in_choice(program: &Program, p: [f64; 4]) -> bool {
        let vals = point::eval_all(program, p);
        program.insts.iter().any(|op| match *op {
            Op::Binary(BinOp::Min | BinOp::Max | BinOp::And | BinOp::Or, a, b) => {
                vals[a.index()].is_nan() || vals[b.index()].is_nan()
            }
            _ => false,
        })
    }

    /// The pruned program on `b` against the full one on sub-boxes and
    /// points of `b` (the contract of `isoc::eval::prune`).
    fn check(program: &Program, b: [Interval; 4], seed: u64) -> Result<(), TestCaseError> {
        let pruned = prune(program, b);
        prop_assert!(pruned.insts.len() <= program.insts.len());
        let (full, short) = (Reference(program.clone()), Reference(pruned.clone()));
        let mut rng = Rng(seed);
        for k in 0..8 {
            let s = if k == 0 { b } else { sub_box(&b, &mut rng) };
            let (fi, si) = (full.interval(s), short.interval(s));
            prop_assert!(
                fi.iv.lo.to_bits() == si.iv.lo.to_bits()
                    && fi.iv.hi.to_bits() == si.iv.hi.to_bits()
                    && fi.defined == si.defined,
                "interval on {s:?}: full {fi:?}, pruned {si:?}\n{program}\npruned:\n{pruned}"
            );
            let (fg, sg) = (full.grad(s), short.grad(s));
            // Over a box where the function is nowhere defined (an empty
            // value) the derivative enclosures carry no meaning.
            prop_assert!(
                fg.value.is_empty()
                    || (fg.value == sg.value && fg.grad == sg.grad && (!fg.defined || sg.defined)),
                "gradient on {s:?}: full {fg:?}, pruned {sg:?}\n{program}\npruned:\n{pruned}"
            );
            let p = [0, 1, 2, 3].map(|i| sample(s[i], &mut rng));
            if p.iter().any(|c| c.is_nan()) {
                continue;
            }
            let (fv, sv) = (full.point(p), short.point(p));
            let same = fv.to_bits() == sv.to_bits() || (fv.is_nan() && sv.is_nan());
            prop_assert!(
                same || (fv.is_nan() && nan_in_choice(program, p)),
                "point {p:?}: full {fv:e}, pruned {sv:e}\n{program}\npruned:\n{pruned}"
            );
            if same {
                let (fd, sd) = (full.point_grad(p).1, short.point_grad(p).1);
                let eq = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
                prop_assert!(
                    (0..3).all(|i| eq(fd[i], sd[i])),
                    "point gradient {p:?}: full {fd:?}, pruned {sd:?}\n{program}"
                );
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(cases()))]

        /// Random CSG solids on octree-like cells: where pruning bites.
        #[test]
        fn pruned_equals_full_on_csg(c in arb_csg(), b in arb_cell(), seed in any::<u64>()) {
            check(&program_of(&c), b, seed)?;
        }

        /// Random programs of every op on random boxes (infinite and NaN
        /// sides, domain edges).
        #[test]
        fn pruned_equals_full_on_any_program(program in arb_program(), b in arb_box(), seed in any::<u64>()) {
            check(&program, b, seed)?;
        }
    }

    /// Pruning bites: the union of two far-apart spheres is one sphere
    /// near either, and stays whole where both could win.
    #[test]
    fn union_of_far_spheres_prunes_to_one() {
        let s = |x: f64| Csg::Sphere([x, 0.0, 0.0], 0.3);
        let c = Csg::Node(0, Box::new(s(-0.6)), Box::new(s(0.6)));
        let program = program_of(&c);
        assert!(has_choices(&program));
        let cell = |lo: f64, hi: f64| {
            [
                Interval::new(lo, hi),
                Interval::new(-0.2, 0.2),
                Interval::new(-0.2, 0.2),
                Interval::point(0.0),
            ]
        };
        let near_left = prune(&program, cell(-0.8, -0.5));
        assert!(!has_choices(&near_left), "{near_left}");
        assert_eq!(near_left.insts.len(), program_of(&s(-0.6)).insts.len());
        let whole = prune(&program, cell(-1.0, 1.0));
        assert_eq!(whole.insts.len(), program.insts.len());
    }

    /// An undefined operand is never dropped: `min(x, sqrt(y))` on a box
    /// where `sqrt(y)` is partly undefined keeps both branches although
    /// `x` is smaller.
    #[test]
    fn undefined_branch_is_kept() {
        let mut b = Builder::new();
        let x = b.var(Var::X);
        let y = b.var(Var::Y);
        let r = b.unary(UnOp::Sqrt, y);
        let ten = b.num(10.0);
        let r10 = b.binary(BinOp::Add, r, ten);
        let m = b.binary(BinOp::Min, x, r10);
        let program = b.finish(m);
        let cell = |ylo: f64| {
            [
                Interval::new(0.0, 1.0),
                Interval::new(ylo, 1.0),
                Interval::new(0.0, 1.0),
                Interval::point(0.0),
            ]
        };
        assert_eq!(prune(&program, cell(-1.0)).insts.len(), program.insts.len());
        assert_eq!(prune(&program, cell(0.0)).insts.len(), 1);
    }
}

/// `eval::within::Within` is the function on the closed box and NaN off
/// it (a NaN coordinate included), bit for bit the reference's inside;
/// its batches equal its single calls; a box that leaves Ω keeps the
/// reference's enclosure, flagged not defined.
#[test]
fn within_is_the_function_on_its_box_and_nan_off_it() {
    use isoc::Bounds;
    use isoc::eval::within::Within;
    let r = Reference(x_squared_plus_one());
    let omega = Bounds {
        lo: [-1.0, -2.0, 0.0],
        hi: [1.0, 2.0, 0.5],
    };
    let w = Within::new(&r, omega);
    let pts = [
        [0.5, 0.0, 0.25],
        [1.0, -2.0, 0.5],
        [-1.0, 2.0, 0.0],
        [1.0f64.next_up(), 0.0, 0.25],
        [0.0, 0.0, -1e-300],
        [0.0, f64::NAN, 0.25],
        [-3.0, 5.0, 9.0],
    ];
    for q in pts {
        let at = [q[0], q[1], q[2], 0.0];
        let inside = omega.contains(q);
        let ((v, g), (rv, rg)) = (w.point_grad(at), r.point_grad(at));
        if inside {
            assert_eq!(w.point(at).to_bits(), r.point(at).to_bits(), "{q:?}");
            assert_eq!(
                (v.to_bits(), g.map(f64::to_bits)),
                (rv.to_bits(), rg.map(f64::to_bits))
            );
        } else {
            assert!(
                w.point(at).is_nan() && v.is_nan() && g.iter().all(|x| x.is_nan()),
                "{q:?}"
            );
        }
    }
    assert_eq!(pts.iter().filter(|q| omega.contains(**q)).count(), 3);
    let inside = [
        Interval::new(0.0, 1.0),
        Interval::new(-2.0, 2.0),
        Interval::new(0.0, 0.5),
        Interval::point(0.0),
    ];
    let leaving = [
        Interval::new(0.5, 1.5),
        Interval::new(-1.0, 1.0),
        Interval::new(0.0, 0.5),
        Interval::point(0.0),
    ];
    assert_eq!(w.interval(inside), r.interval(inside));
    let (wl, rl) = (w.interval(leaving), r.interval(leaving));
    assert!(rl.defined && !wl.defined && wl.iv == rl.iv);
    assert!(!w.grad(leaving).defined && w.grad(inside).defined);
    check_batches(&w, &pts, 0.0, &[inside, leaving]).expect("batches");
}
