//! The JIT point-gradient kernel (`Kernels::point_grad`, compiled on first
//! use): bit for bit the reference forward-mode evaluator
//! `eval::grad::eval_point` on random programs of every op, its value bit
//! for bit the point kernel's, batch == single, inside the interval-gradient
//! kernel's enclosure on the degenerate box; and hand-computed gradients.
//! The batch kernel's second tier (two points per iteration) is held to
//! the first's bits, and switched to when its count says.

#![allow(clippy::needless_range_loop)]

use isoc::eval::grad;
use isoc::interval::Interval;
use isoc::ir::{BinOp, Builder, Const, Op, Program, UnOp, Value, Var};
use isoc::jit::{JitError, JitOptions, Kernels, Kind};
use proptest::prelude::*;

/// Bitwise equal, any NaN equal to any NaN.
fn bits_eq(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fn encloses(iv: Interval, v: f64) -> bool {
    v.is_nan() || (iv.lo <= v && v <= iv.hi)
}

/// Compares the JIT's point gradient at `p` with the reference and with the
/// point kernel; and checks the gradient kernel's enclosure of it on the
/// degenerate box.
fn check_point(k: &Kernels, prog: &Program, p: [f64; 4]) -> Result<(f64, [f64; 3]), String> {
    let (v, d) = k.point_grad(p);
    let (rv, rd) = grad::eval_point(prog, p);
    let pv = k.point(p);
    if !bits_eq(v, pv) {
        return Err(format!("value {v:e} != point kernel {pv:e} at {p:?}"));
    }
    // The point kernel's min/max may pick the other zero of a ±0 tie than
    // Rust's f64::min; that is the point kernel's business (see
    // tests/jit/jit_vs_eval.rs), so compare the value with `==` here.
    if !(v == rv || (v.is_nan() && rv.is_nan())) {
        return Err(format!("value {v:e} != reference {rv:e} at {p:?}"));
    }
    for i in 0..3 {
        if !bits_eq(d[i], rd[i]) {
            return Err(format!(
                "∂{i}: jit {:e} != reference {:e} at {p:?} (jit {d:?}, reference {rd:?})",
                d[i], rd[i]
            ));
        }
    }
    let g = k.grad(p.map(Interval::point));
    if !encloses(g.value, v) {
        return Err(format!(
            "grad kernel value {:?} misses {v:e} at {p:?}",
            g.value
        ));
    }
    for i in 0..3 {
        if !encloses(g.grad[i], d[i]) {
            return Err(format!(
                "grad kernel ∂{i} {:?} misses {:e} at {p:?}",
                g.grad[i], d[i]
            ));
        }
    }
    Ok((v, d))
}

fn show(prog: &Program) -> String {
    prog.insts
        .iter()
        .enumerate()
        .map(|(i, op)| format!("  v{i} = {op:?}\n"))
        .collect()
}

fn jit(p: &Program) -> Kernels {
    jit_with(p, JitOptions::default().point_grad_wide_after)
}

/// [`jit`] whose point gradient switches to its second tier once `after`
/// points have gone through batches of two or more.
fn jit_with(p: &Program, after: usize) -> Kernels {
    let opts = JitOptions {
        fast_compile: true,
        verify: true,
        point_grad_wide_after: after,
        ..JitOptions::default()
    };
    Kernels::compile_with(p, &opts).expect("JIT compile")
}

/// The point-gradient entry points compiled so far (one per tier).
fn pgrad_tiers(k: &Kernels) -> usize {
    k.info()
        .iter()
        .filter(|i| i.kind == Kind::PointGrad)
        .count()
}

/// `k`'s batch point gradient at `pts` (time `t`), as records.
fn batch(k: &Kernels, pts: &[[f64; 4]], t: f64) -> Vec<f64> {
    let col = |i: usize| pts.iter().map(|q| q[i]).collect::<Vec<_>>();
    let mut out = vec![0.0; 4 * pts.len()];
    k.point_grad_batch(&col(0), &col(1), &col(2), t, &mut out)
        .unwrap();
    out
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: crate::support::cases().min(500),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Random programs of every op at special and ordinary points: value
    /// and gradient bit for bit the reference, batch bit for bit single
    /// (by either tier: two points per iteration, and an odd last one),
    /// inside the interval-gradient kernel's enclosure.
    #[test]
    fn matches_reference(
        prog in crate::support::arb_program(),
        pts in prop::collection::vec(crate::support::arb_point(), 1..10),
        t in crate::support::arb_coord(),
    ) {
        let k = jit(&prog);
        for p in &pts {
            if let Err(e) = check_point(&k, &prog, *p) {
                prop_assert!(false, "{}\n{}", e, show(&prog));
            }
        }
        let wide = jit_with(&prog, 0);
        // A single point, on the first tier: not counted.
        wide.point_grad(pts[0]);
        for (tier, out) in [("first", batch(&k, &pts, t)), ("second", batch(&wide, &pts, t))] {
            for (i, p) in pts.iter().enumerate() {
                let (v, d) = k.point_grad([p[0], p[1], p[2], t]);
                let want = [v, d[0], d[1], d[2]];
                for j in 0..4 {
                    prop_assert!(bits_eq(out[4 * i + j], want[j]),
                        "{tier} tier: batch record {i}[{j}] {:e} != single {:e}\n{}",
                        out[4 * i + j], want[j], show(&prog));
                }
            }
        }
        prop_assert_eq!(pgrad_tiers(&wide), if pts.len() >= 2 { 2 } else { 1 });
    }
}

// ---------------------------------------------------------------- by hand

struct B(Builder);

impl B {
    fn new() -> B {
        B(Builder::new())
    }
    fn var(&mut self, v: Var) -> Value {
        self.0.var(v)
    }
    fn un(&mut self, u: UnOp, a: Value) -> Value {
        self.0.unary(u, a)
    }
    fn bin(&mut self, o: BinOp, a: Value, b: Value) -> Value {
        self.0.binary(o, a, b)
    }
}

/// Compiles a program and checks it against the reference at `p`.
fn at(prog: &Program, p: [f64; 4]) -> (f64, [f64; 3]) {
    let k = jit(prog);
    check_point(&k, prog, p).unwrap_or_else(|e| panic!("{e}\n{}", show(prog)))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-14 * b.abs().max(1.0)
}

#[test]
fn sphere() {
    let mut b = B::new();
    let (x, y, z) = (b.var(Var::X), b.var(Var::Y), b.var(Var::Z));
    let [x2, y2, z2] = [x, y, z].map(|v| b.un(UnOp::Square, v));
    let s = b.bin(BinOp::Add, x2, y2);
    let s = b.bin(BinOp::Add, s, z2);
    let prog = b.0.finish(s);
    for p in [[1.0, 2.0, 3.0, 0.0], [-0.5, 0.25, 7.0, 9.0], [0.0; 4]] {
        let (v, d) = at(&prog, p);
        assert_eq!(v, p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        assert_eq!(d, [2.0 * p[0], 2.0 * p[1], 2.0 * p[2]]);
    }
}

#[test]
fn sin_x_times_exp_y() {
    let mut b = B::new();
    let (x, y) = (b.var(Var::X), b.var(Var::Y));
    let s = b.un(UnOp::Sin, x);
    let e = b.un(UnOp::Exp, y);
    let f = b.bin(BinOp::Mul, s, e);
    let prog = b.0.finish(f);
    let (v, d) = at(&prog, [0.7, -0.3, 5.0, 0.0]);
    assert!(close(v, 0.7f64.sin() * (-0.3f64).exp()));
    assert!(close(d[0], 0.7f64.cos() * (-0.3f64).exp()), "{d:?}");
    assert!(close(d[1], v), "{d:?}");
    assert_eq!(d[2], 0.0);
}

#[test]
fn powi_rules() {
    for n in [-3i64, -1, 0, 1, 2, 3, 5, 8] {
        let prog = Program {
            insts: vec![Op::Var(Var::X), Op::Powi(Value(0), n)],
            output: Value(1),
        };
        let (v, d) = at(&prog, [1.5, 0.0, 0.0, 0.0]);
        assert!(close(v, 1.5f64.powi(n as i32)), "n={n}");
        let want = n as f64 * 1.5f64.powi(n as i32 - 1);
        assert!(close(d[0], want), "n={n}: {} vs {want}", d[0]);
        assert_eq!(d[1], 0.0);
        // At 0: x^-1 is undefined, x^0 has derivative 0, x^1 derivative 1.
        let (v0, d0) = at(&prog, [0.0; 4]);
        match n {
            n if n < 0 => assert!(v0.is_nan() && d0[0].is_nan(), "n={n}"),
            0 => assert_eq!((v0, d0[0]), (1.0, 0.0)),
            1 => assert_eq!(d0[0], 1.0),
            _ => assert_eq!(d0[0], 0.0),
        }
    }
    // x^0 at NaN is 1 with derivative 0.
    let prog = Program {
        insts: vec![Op::Var(Var::X), Op::Powi(Value(0), 0)],
        output: Value(1),
    };
    assert_eq!(at(&prog, [f64::NAN, 0.0, 0.0, 0.0]), (1.0, [0.0; 3]));
}

#[test]
fn kinks_follow_the_reference() {
    let mut b = B::new();
    let x = b.var(Var::X);
    let y = b.var(Var::Y);
    let a = b.un(UnOp::Abs, x);
    let prog = b.0.finish(a);
    assert_eq!(at(&prog, [-2.0, 0.0, 0.0, 0.0]).1, [-1.0, 0.0, 0.0]);
    assert_eq!(at(&prog, [2.0, 0.0, 0.0, 0.0]).1, [1.0, 0.0, 0.0]);
    // abs' at 0 is the operand's derivative.
    assert_eq!(at(&prog, [0.0, 0.0, 0.0, 0.0]).1, [1.0, 0.0, 0.0]);
    assert_eq!(at(&prog, [-0.0, 0.0, 0.0, 0.0]).1, [1.0, 0.0, 0.0]);

    for op in [BinOp::Min, BinOp::Max] {
        let prog = Program {
            insts: vec![
                Op::Var(Var::X),
                Op::Var(Var::Y),
                Op::Binary(op, Value(0), Value(1)),
            ],
            output: Value(2),
        };
        let lo = if op == BinOp::Min {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let hi = if op == BinOp::Min {
            [0.0, 1.0, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        assert_eq!(at(&prog, [1.0, 2.0, 0.0, 0.0]).1, lo, "{op:?}");
        assert_eq!(at(&prog, [3.0, 2.0, 0.0, 0.0]).1, hi, "{op:?}");
        // Ties pick the first operand.
        assert_eq!(at(&prog, [2.0, 2.0, 0.0, 0.0]).1, [1.0, 0.0, 0.0], "{op:?}");
        let (v, d) = at(&prog, [f64::NAN, 2.0, 0.0, 0.0]);
        assert!(v.is_nan() && d.iter().all(|g| g.is_nan()));
    }
    let _ = y;
}

#[test]
fn atan2_and_domains() {
    let prog = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Var(Var::Y),
            Op::Binary(BinOp::Atan2, Value(1), Value(0)),
        ],
        output: Value(2),
    };
    // atan2(y, x): ∇ = (−y, x)/(x² + y²).
    let (_, d) = at(&prog, [1.0, 2.0, 0.0, 0.0]);
    assert!(close(d[0], -2.0 / 5.0) && close(d[1], 1.0 / 5.0), "{d:?}");
    let (v, d) = at(&prog, [0.0, 0.0, 0.0, 0.0]);
    assert!(v.is_nan() && d.iter().all(|g| g.is_nan()));

    // sqrt at 0 has no derivative; log, asin outside the domain are NaN.
    for (u, x) in [
        (UnOp::Sqrt, 0.0),
        (UnOp::Log, -1.0),
        (UnOp::Asin, 2.0),
        (UnOp::Acos, 1.0),
    ] {
        let prog = Program {
            insts: vec![Op::Var(Var::X), Op::Unary(u, Value(0))],
            output: Value(1),
        };
        let (_, d) = at(&prog, [x, 0.0, 0.0, 0.0]);
        assert!(d[0].is_nan(), "{u:?} at {x}: {d:?}");
    }
    // pow(x, y) = x^y: ∇ = (y x^(y−1), x^y ln x).
    let prog = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Var(Var::Y),
            Op::Binary(BinOp::Pow, Value(0), Value(1)),
        ],
        output: Value(2),
    };
    let (v, d) = at(&prog, [2.0, 0.5, 0.0, 0.0]);
    assert!(close(v, 2f64.sqrt()));
    assert!(
        close(d[0], 0.5 / 2f64.sqrt()) && close(d[1], v * 2f64.ln()),
        "{d:?}"
    );
}

#[test]
fn t_has_no_gradient_component() {
    // f = x·t + sin(t)
    let mut b = B::new();
    let x = b.var(Var::X);
    let t = b.var(Var::T);
    let xt = b.bin(BinOp::Mul, x, t);
    let st = b.un(UnOp::Sin, t);
    let f = b.bin(BinOp::Add, xt, st);
    let prog = b.0.finish(f);
    let (v, d) = at(&prog, [2.0, 5.0, 6.0, 0.5]);
    assert!(close(v, 1.0 + 0.5f64.sin()));
    assert_eq!(d, [0.5, 0.0, 0.0]);
    // A program of t alone: zero gradient, and NaN t poisons it.
    let prog = Program {
        insts: vec![Op::Var(Var::T), Op::Unary(UnOp::Cos, Value(0))],
        output: Value(1),
    };
    assert_eq!(at(&prog, [1.0, 2.0, 3.0, 0.0]), (1.0, [0.0; 3]));
    assert!(at(&prog, [1.0, 2.0, 3.0, f64::NAN]).1[0].is_nan());
    // A NaN constant has NaN derivatives.
    let prog = Program {
        insts: vec![Op::Const(Const {
            value: f64::NAN,
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
            defined: false,
        })],
        output: Value(0),
    };
    assert!(at(&prog, [0.0; 4]).1.iter().all(|g| g.is_nan()));
}

#[test]
fn batch_equals_single_and_checks_lengths() {
    let s = crate::support::surface(
        "domain [-2, 2]^3; surface sin(x)*exp(y) + abs(z) - min(x, y)^3 + atan(x*y*z) + t;",
    );
    let pts: Vec<[f64; 3]> = (0..100)
        .map(|i| {
            let u = i as f64 / 7.0;
            [u.sin() * 2.0, (1.3 * u).cos(), u.fract() - 0.5]
        })
        .collect();
    let batch = s.point_grad_batch(&pts, 0.25);
    assert_eq!(batch.len(), pts.len());
    for (p, (v, d)) in pts.iter().zip(&batch) {
        let q = [p[0], p[1], p[2], 0.25];
        let (sv, sd) = s.point_grad(q);
        assert!(bits_eq(*v, sv));
        for i in 0..3 {
            assert!(bits_eq(d[i], sd[i]));
        }
        let (rv, rd) = grad::eval_point(&s.program, q);
        assert!(bits_eq(sv, rv) && (0..3).all(|i| bits_eq(sd[i], rd[i])));
        assert!(bits_eq(sv, s.point(q)));
    }
    assert!(s.point_grad_batch(&[], 0.0).is_empty());

    let k = s.kernels();
    let mut out = vec![0.0; 8];
    let e = k.point_grad_batch(&[0.0; 2], &[0.0; 2], &[0.0; 1], 0.0, &mut out);
    assert!(matches!(e, Err(JitError::BufferLength(_))), "{e:?}");
    let e = k.point_grad_batch(&[0.0; 2], &[0.0; 2], &[0.0; 2], 0.0, &mut out[..7]);
    assert!(matches!(e, Err(JitError::BufferLength(_))), "{e:?}");
}

#[test]
fn compiled_lazily_and_shareable() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<Kernels>();
    let prog = Program {
        insts: vec![Op::Var(Var::X), Op::Unary(UnOp::Exp, Value(0))],
        output: Value(1),
    };
    let k = Kernels::compile(&prog).unwrap();
    // The eager kernels only: point, interval and gradient (single and
    // batch entry points).
    assert_eq!(k.info().len(), 6);
    assert!(k.info().iter().all(|i| i.kind != Kind::PointGrad));
    // Concurrent first uses compile once and agree.
    let r: Vec<(f64, [f64; 3])> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..4)
            .map(|_| s.spawn(|| k.point_grad([1.0, 0.0, 0.0, 0.0])))
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert!(r.iter().all(|&x| x == r[0]));
    assert_eq!(r[0].0, r[0].1[0]);
    let info = k.point_grad_info().unwrap();
    assert_eq!(info.len(), 1);
    assert!(
        info.iter()
            .all(|i| i.kind == Kind::PointGrad && i.code_bytes > 0)
    );
    assert_eq!(info[0].name, "point_grad_batch");
    let f = k.point_grad_batch_fn().unwrap();
    let mut out = [0.0; 4];
    // SAFETY: the ABI of the batch point-gradient kernel, one record; `k`
    // is alive.
    unsafe { f(&1.0, &0.0, &0.0, 0.0, out.as_mut_ptr(), 1) };
    assert_eq!(out, [r[0].0, r[0].1[0], r[0].1[1], r[0].1[2]]);
}

/// The second tier is compiled by the batch that brings the points of
/// batches of two or more past the count, and serves the batches after it
/// with the first tier's bits; single points are not counted, and without
/// `simd` (or with the count at `usize::MAX`) there is no second tier.
#[test]
fn second_tier_after_its_count() {
    let s = crate::support::surface(
        "domain [-2, 2]^3; surface max(min(x*y, z), abs(x) - sqrt(y*y + 1)) + exp(z)/3;",
    );
    let pts: Vec<[f64; 4]> = (0..8)
        .map(|i| {
            let u = i as f64 / 3.0;
            [u.sin(), (1.7 * u).cos(), u - 1.2, 0.0]
        })
        .collect();
    let k = jit_with(&s.program, 10);
    let first = batch(&k, &pts, 0.0);
    for p in &pts {
        k.point_grad(*p);
    }
    assert_eq!(pgrad_tiers(&k), 1, "8 points of batches, and singles");
    let second = batch(&k, &pts, 0.0);
    assert_eq!(pgrad_tiers(&k), 2, "16 points");
    assert!(first.iter().zip(&second).all(|(a, b)| bits_eq(*a, *b)));
    for never in [
        JitOptions {
            simd: false,
            point_grad_wide_after: 0,
            ..JitOptions::default()
        },
        JitOptions {
            point_grad_wide_after: usize::MAX,
            ..JitOptions::default()
        },
    ] {
        let k = Kernels::compile_with(&s.program, &never).unwrap();
        for _ in 0..3 {
            assert_eq!(batch(&k, &pts, 0.0), first);
        }
        assert_eq!(pgrad_tiers(&k), 1, "{never:?}");
    }
}
