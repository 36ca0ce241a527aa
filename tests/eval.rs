//! The shared backend suite run against the reference interpreters, plus
//! tests showing the suite's checks catch broken backends.

mod common;

use common::{check_batches, check_degenerate, check_grad, check_interval, check_point_grad};
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

#[test]
fn checks_catch_wrong_batches_and_point_gradients() {
    // x·x + 1: never 0, gradient 2x.
    let p = prog(vec![
        Op::Var(Var::X),
        Op::Binary(BinOp::Mul, Value(0), Value(0)),
        Op::Const(isoc::ir::Const {
            value: 1.0,
            lo: 1.0,
            hi: 1.0,
            defined: true,
        }),
        Op::Binary(BinOp::Add, Value(1), Value(2)),
    ]);
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
    use crate::common::{Rng, arb_box, arb_program, cases, sample};
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
