//! Gradient evaluators: every derivative rule checked against central
//! finite differences of the point evaluator (so a wrong rule cannot hide
//! behind the point/interval agreement of the shared suite), and the
//! non-smooth cases of the interval rules.

use isoc::eval::{grad, point};
use isoc::interval::Interval;
use isoc::ir::{BinOp, Const, Op, Program, UnOp, Value, Var};
use proptest::prelude::*;

fn prog(insts: Vec<Op>) -> Program {
    let output = Value(insts.len() as u32 - 1);
    Program { insts, output }
}

fn unary(op: UnOp) -> Program {
    prog(vec![Op::Var(Var::X), Op::Unary(op, Value(0))])
}

fn binary(op: BinOp) -> Program {
    prog(vec![
        Op::Var(Var::X),
        Op::Var(Var::Y),
        Op::Binary(op, Value(0), Value(1)),
    ])
}

/// Central difference of `f` along coordinate `k` at `p`.
fn central(program: &Program, p: [f64; 4], k: usize) -> f64 {
    let h = 1e-6 * p[k].abs().max(1.0);
    let (mut a, mut b) = (p, p);
    a[k] += h;
    b[k] -= h;
    (point::eval(program, a) - point::eval(program, b)) / (a[k] - b[k])
}

fn close(ad: f64, fd: f64) -> bool {
    (ad - fd).abs() <= 1e-4 * (1.0 + ad.abs().max(fd.abs()))
}

fn cfg() -> ProptestConfig {
    ProptestConfig::with_cases(crate::support::cases())
}

proptest! {
    #![proptest_config(cfg())]

    /// `∂op/∂x` from forward-mode AD matches finite differences at points
    /// well inside the domain (away from poles, kinks and domain edges).
    #[test]
    fn unary_rules_match_finite_differences(op in prop::sample::select(UnOp::ALL.to_vec()),
                                            x in -3.0f64..3.0) {
        let safe = match op {
            UnOp::Sqrt | UnOp::Log => x > 0.05,
            UnOp::Asin | UnOp::Acos => x.abs() < 0.95,
            UnOp::Tan => x.cos().abs() > 0.1,
            UnOp::Abs | UnOp::Not => x.abs() > 0.01,
            // Away from the jumps.
            UnOp::Floor | UnOp::Ceil => (x - x.round()).abs() > 0.01,
            UnOp::Round => ((x - x.floor()) - 0.5).abs() > 0.01,
            _ => true,
        };
        if !safe {
            return Ok(());
        }
        let p = unary(op);
        let pt = [x, 0.0, 0.0, 0.0];
        let (_, g) = grad::eval_point(&p, pt);
        let fd = central(&p, pt, 0);
        prop_assert!(close(g[0], fd), "{op:?}'({x}) = {} vs finite difference {fd}", g[0]);
        prop_assert_eq!(g[1], 0.0);
        prop_assert_eq!(g[2], 0.0);
    }

    #[test]
    fn binary_rules_match_finite_differences(op in prop::sample::select(BinOp::ALL.to_vec()),
                                             x in -3.0f64..3.0, y in -3.0f64..3.0) {
        let safe = match op {
            BinOp::Div => y.abs() > 0.1,
            BinOp::Min | BinOp::Max => (x - y).abs() > 0.01,
            BinOp::Atan2 => x.hypot(y) > 0.1 && !(y < 0.0 && x.abs() < 0.05),
            BinOp::Pow => x > 0.1,
            BinOp::Compare => (x - y).abs() > 0.01,
            // The choice of operand flips at x = 0.
            BinOp::And | BinOp::Or => x.abs() > 0.01,
            // Away from b = 0 and from the jumps at integer x/y.
            BinOp::Mod => y.abs() > 0.1 && ((x / y) - (x / y).round()).abs() > 0.01,
            _ => true,
        };
        if !safe {
            return Ok(());
        }
        let p = binary(op);
        let pt = [x, y, 0.0, 0.0];
        let (_, g) = grad::eval_point(&p, pt);
        for (k, &gk) in g.iter().enumerate().take(2) {
            let fd = central(&p, pt, k);
            prop_assert!(close(gk, fd), "{op:?} ∂{k} at ({x}, {y}) = {gk} vs {fd}");
        }
    }

    #[test]
    fn powi_rule_matches_finite_differences(n in -6i64..8, x in 0.2f64..2.0, neg in any::<bool>()) {
        let x = if neg { -x } else { x };
        let p = prog(vec![Op::Var(Var::X), Op::Powi(Value(0), n)]);
        let pt = [x, 0.0, 0.0, 0.0];
        let (_, g) = grad::eval_point(&p, pt);
        let fd = central(&p, pt, 0);
        prop_assert!(close(g[0], fd), "d/dx x^{n} at {x} = {} vs {fd}", g[0]);
    }
}

fn gbox(x: Interval) -> [Interval; 4] {
    [
        x,
        Interval::point(0.0),
        Interval::point(0.0),
        Interval::point(0.0),
    ]
}

#[test]
fn sqrt_derivative_is_unbounded_at_zero() {
    let g = grad::eval(&unary(UnOp::Sqrt), gbox(Interval::new(0.0, 4.0)));
    assert_eq!(g.grad[0].hi, f64::INFINITY);
    assert!(g.grad[0].lo <= 0.25);
    assert!(!g.defined);
    let (_, d) = grad::eval_point(&unary(UnOp::Sqrt), [0.0; 4]);
    assert!(d[0].is_nan());
}

#[test]
fn abs_derivative_straddling_zero() {
    let g = grad::eval(&unary(UnOp::Abs), gbox(Interval::new(-1.0, 2.0)));
    assert_eq!(g.grad[0], Interval::new(-1.0, 1.0));
    assert!(!g.defined);
    let g = grad::eval(&unary(UnOp::Abs), gbox(Interval::new(-3.0, -1.0)));
    assert_eq!(g.grad[0], Interval::point(-1.0));
    assert!(g.defined);
}

#[test]
fn min_max_derivatives() {
    let b = [
        Interval::new(0.0, 2.0),
        Interval::new(1.0, 3.0),
        Interval::point(0.0),
        Interval::point(0.0),
    ];
    let g = grad::eval(&binary(BinOp::Min), b);
    assert_eq!(g.grad[0], Interval::new(0.0, 1.0));
    assert_eq!(g.grad[1], Interval::new(0.0, 1.0));
    assert!(!g.defined);
    let b = [
        Interval::new(0.0, 1.0),
        Interval::new(2.0, 3.0),
        Interval::point(0.0),
        Interval::point(0.0),
    ];
    let g = grad::eval(&binary(BinOp::Max), b);
    assert_eq!(
        g.grad,
        [
            Interval::point(0.0),
            Interval::point(1.0),
            Interval::point(0.0)
        ]
    );
    assert!(g.defined);
}

#[test]
fn gradient_of_a_sphere() {
    // x² + y² + z² − 1 on [1, 2]³: gradient (2x, 2y, 2z) ∈ [2, 4]³.
    let p = prog(vec![
        Op::Var(Var::X),
        Op::Var(Var::Y),
        Op::Var(Var::Z),
        Op::Unary(UnOp::Square, Value(0)),
        Op::Unary(UnOp::Square, Value(1)),
        Op::Unary(UnOp::Square, Value(2)),
        Op::Binary(BinOp::Add, Value(3), Value(4)),
        Op::Binary(BinOp::Add, Value(6), Value(5)),
        Op::Const(Const::exact(1.0)),
        Op::Binary(BinOp::Sub, Value(7), Value(8)),
    ]);
    let b = [
        Interval::new(1.0, 2.0),
        Interval::new(1.0, 2.0),
        Interval::new(1.0, 2.0),
        Interval::point(0.0),
    ];
    let g = grad::eval(&p, b);
    assert_eq!(g.value, Interval::new(2.0, 11.0));
    assert_eq!(g.grad, [Interval::new(2.0, 4.0); 3]);
    assert!(g.defined);
    let (v, d) = grad::eval_point(&p, [1.0, 2.0, 3.0, 0.0]);
    assert_eq!(v, 13.0);
    assert_eq!(d, [2.0, 4.0, 6.0]);
}

#[test]
fn time_is_not_differentiated() {
    let p = prog(vec![Op::Var(Var::T), Op::Unary(UnOp::Sin, Value(0))]);
    let (_, d) = grad::eval_point(&p, [0.0, 0.0, 0.0, 1.0]);
    assert_eq!(d, [0.0; 3]);
}

/// Programs with creases and folds, for the derivatives in a frame: a
/// rotated box's `max` of `abs`, a `min` union of a ball and a slab, and
/// a smooth product, each over `x, y, z`; compiled once for all cases.
static FRAME_PROGRAMS: std::sync::LazyLock<Vec<Program>> = std::sync::LazyLock::new(|| {
    let src = [
        "max(max(abs(0.8*x + 0.6*y), abs(z - 0.1)), abs(0.6*x - 0.8*y)) = 0.5;",
        "min(x^2 + y^2 + z^2 - 0.4, max(z - 0.2, -z - 0.3)) = 0;",
        "sin(2*x) * exp(y) - z = 0;",
    ];
    src.iter()
        .map(|s| {
            let opts = isoc::CompileOptions::default();
            let src = format!("domain [-1, 1]^3; surface {s}");
            isoc::Surface::compile(&src, "frame.iso", &opts)
                .expect("a valid surface")
                .program
        })
        .collect()
});

proptest! {
    #![proptest_config(cfg())]

    /// Derivatives in a frame whose first column is a random unit vector
    /// `d` enclose `d·∇F` at points of the box (where `F` has a gradient
    /// there), and in the axes' frame they are [`grad::eval`]'s bit for
    /// bit.
    #[test]
    fn derivatives_in_a_frame_enclose_the_directional_derivative(
        which in 0usize..3,
        lo in prop::array::uniform3(-1.0f64..0.8),
        side in 0.01f64..0.6,
        dir in prop::array::uniform3(-1.0f64..1.0),
        ts in prop::collection::vec(prop::array::uniform3(0.0f64..=1.0), 16),
    ) {
        let p = &FRAME_PROGRAMS[which];
        let d = glam::DVec3::from_array(dir);
        prop_assume!(d.length() > 0.1);
        let d = d.normalize();
        let (e1, e2) = d.any_orthonormal_pair();
        let frame: grad::Frame = std::array::from_fn(|i| [d[i], e1[i], e2[i]]);
        let b = [0, 1, 2].map(|k| Interval::new(lo[k], lo[k] + side));
        let input = [b[0], b[1], b[2], Interval::point(0.0)];
        prop_assert_eq!(grad::eval_in(p, input, &grad::AXES), grad::eval(p, input));
        let along = grad::eval_in(p, input, &frame).grad[0];
        for t in ts {
            let q = [0, 1, 2].map(|k| lo[k] + side * t[k]);
            let (_, g) = grad::eval_point(p, [q[0], q[1], q[2], 0.0]);
            let dd = d.dot(glam::DVec3::from_array(g));
            if dd.is_finite() {
                // The dot product here rounds; the enclosure is of the
                // exact one.
                let slack = 1e-12 * (1.0 + dd.abs());
                prop_assert!(along.lo - slack <= dd && dd <= along.hi + slack,
                    "d·∇F{q:?} = {dd:e} not in {along:?}");
            }
        }
    }
}

/// Across a right-angled crease (`max(x, y)` about the origin) the box
/// hull of the gradient holds the zero vector, but the derivative along
/// the bisector is `1/√2` on both faces: the enclosure along it excludes
/// zero (what the octree's crease look relies on).
#[test]
fn along_the_bisector_a_crease_has_no_zero_derivative() {
    let p = binary(BinOp::Max);
    let b = [
        Interval::new(-0.1, 0.1),
        Interval::new(-0.1, 0.1),
        Interval::point(0.0),
        Interval::point(0.0),
    ];
    let g = grad::eval(&p, b);
    assert!(g.grad.iter().all(|c| c.contains(0.0)));
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let frame: grad::Frame = [[h, -h, 0.0], [h, h, 0.0], [0.0, 0.0, 1.0]];
    let along = grad::eval_in(&p, b, &frame).grad[0];
    assert!(along.lo > 0.7 && along.hi < 0.71, "{along:?}");
}
