//! JIT kernels against independent oracles: a random-program differential
//! suite (point bitwise, interval containment and tightness, gradient
//! containment), batch == single, and the constant-folding soundness trap.
//!
//! The oracles here cover the ops the kernels inline and are written from
//! the IR's documented semantics; `tests/jit/jit_vs_eval.rs` compares with the
//! reference evaluators for every op.

use isoc::interval::Interval;
use isoc::ir::{BinOp, Const, Op, Program, UnOp, Value, Var};
use isoc::jit::Kernels;
use proptest::prelude::*;

// ---------------------------------------------------------------- programs

/// Ops whose every kernel path is inline (no helper call).
#[derive(Clone, Copy, Debug)]
enum Pick {
    Var(Var),
    Const(f64, u8),
    Un(UnOp),
    Bin(BinOp),
    Powi(i64),
}

fn const_value() -> impl Strategy<Value = f64> {
    prop_oneof![
        (-4i32..5).prop_map(f64::from),
        Just(0.1),
        Just(-0.3),
        Just(std::f64::consts::PI),
        Just(1e300),
        Just(-1e-300),
        Just(1e-310),
        Just(-0.0),
        (-10.0f64..10.0),
    ]
}

fn pick(grad_safe: bool) -> impl Strategy<Value = Pick> {
    let un: Vec<UnOp> = if grad_safe {
        vec![UnOp::Neg, UnOp::Square]
    } else {
        vec![UnOp::Neg, UnOp::Abs, UnOp::Sqrt, UnOp::Square]
    };
    let bin: Vec<BinOp> = if grad_safe {
        vec![BinOp::Add, BinOp::Sub, BinOp::Mul]
    } else {
        vec![BinOp::Add, BinOp::Sub, BinOp::Mul, BinOp::Min, BinOp::Max]
    };
    let powi_max: i64 = if grad_safe { 0 } else { 12 };
    prop_oneof![
        2 => prop::sample::select(Var::ALL.to_vec()).prop_map(Pick::Var),
        2 => (const_value(), 0u8..3).prop_map(|(v, k)| Pick::Const(v, k)),
        3 => prop::sample::select(un).prop_map(Pick::Un),
        5 => prop::sample::select(bin).prop_map(Pick::Bin),
        1 => (1..=powi_max.max(1)).prop_map(move |n| if powi_max == 0 { Pick::Un(UnOp::Neg) } else { Pick::Powi(n) }),
    ]
}

/// A random program: each instruction reads earlier ones; the output is the
/// last instruction.
fn program(grad_safe: bool) -> impl Strategy<Value = Program> {
    prop::collection::vec((pick(grad_safe), any::<u32>(), any::<u32>()), 1..24).prop_map(|picks| {
        let mut insts = vec![Op::Var(Var::X), Op::Var(Var::Y), Op::Var(Var::Z)];
        for (p, a, b) in picks {
            let n = insts.len() as u32;
            // Bias towards recent values so that programs are deep.
            let a = Value(n - 1 - a % n.min(4));
            let b = Value(b % n);
            insts.push(match p {
                Pick::Var(v) => Op::Var(v),
                Pick::Const(v, k) => Op::Const(enclose(v, k)),
                Pick::Un(u) => Op::Unary(u, a),
                Pick::Bin(op) => Op::Binary(op, a, b),
                Pick::Powi(n) => Op::Powi(a, n),
            });
        }
        let output = Value(insts.len() as u32 - 1);
        Program { insts, output }
    })
}

/// A constant whose real value is `v` (k = 0), or a real number just below
/// (k = 1) or above (k = 2) the f64 `v`, like a decimal literal.
fn enclose(v: f64, k: u8) -> Const {
    match k {
        1 => Const {
            value: v,
            lo: v.next_down(),
            hi: v,
            defined: true,
        },
        2 => Const {
            value: v,
            lo: v,
            hi: v.next_up(),
            defined: true,
        },
        _ => Const::exact(v),
    }
}

fn bound() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -3.0f64..3.0,
        1 => -1e6f64..1e6,
        1 => Just(0.0),
        1 => -1e-300f64..1e-300,
        1 => prop::sample::select(vec![1e300, -1e300, 1e154, -1e154]),
    ]
}

fn interval_box() -> impl Strategy<Value = [Interval; 4]> {
    prop::array::uniform4((bound(), bound(), prop::bool::weighted(0.1))).prop_map(|a| {
        a.map(|(p, q, point)| {
            let (lo, hi) = if point { (p, p) } else { (p.min(q), p.max(q)) };
            Interval { lo, hi }
        })
    })
}

// ---------------------------------------------------------------- oracles

fn powi(a: f64, n: i64) -> f64 {
    if n == 0 {
        return 1.0;
    }
    let mut m = n.unsigned_abs();
    let mut acc: Option<f64> = None;
    let mut base = a;
    loop {
        if m & 1 == 1 {
            acc = Some(acc.map_or(base, |r| r * base));
        }
        m >>= 1;
        if m == 0 {
            break;
        }
        base *= base;
    }
    let p = acc.unwrap_or(a);
    if n < 0 { 1.0 / p } else { p }
}

/// IEEE minimum/maximum: NaN if either operand is NaN, −0 < +0.
fn min(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if a == b {
        if a.is_sign_negative() { a } else { b }
    } else {
        a.min(b)
    }
}

fn max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if a == b {
        if a.is_sign_positive() { a } else { b }
    } else {
        a.max(b)
    }
}

/// Point value and, where the function is differentiable along the way,
/// the gradient (forward AD in f64, in the JIT's operation order).
fn point_grad(p: &Program, x: [f64; 4]) -> (f64, Option<[f64; 3]>) {
    let mut v: Vec<(f64, [f64; 3])> = Vec::new();
    let mut smooth = true;
    for op in &p.insts {
        let r = match *op {
            Op::Var(var) => {
                let mut d = [0.0; 3];
                if var.index() < 3 {
                    d[var.index()] = 1.0;
                }
                (x[var.index()], d)
            }
            Op::Const(c) => (c.value, [0.0; 3]),
            Op::Unary(u, a) => {
                let (a, da) = v[a.index()];
                match u {
                    UnOp::Neg => (-a, da.map(|d| -d)),
                    UnOp::Abs => {
                        smooth &= a != 0.0;
                        (a.abs(), da.map(|d| if a < 0.0 { -d } else { d }))
                    }
                    UnOp::Sqrt => {
                        smooth = false;
                        (a.sqrt(), [0.0; 3])
                    }
                    UnOp::Square => (a * a, da.map(|d| (a + a) * d)),
                    _ => unreachable!(),
                }
            }
            Op::Binary(op, a, b) => {
                let ((a, da), (b, db)) = (v[a.index()], v[b.index()]);
                match op {
                    BinOp::Add => (a + b, [0, 1, 2].map(|k| da[k] + db[k])),
                    BinOp::Sub => (a - b, [0, 1, 2].map(|k| da[k] - db[k])),
                    BinOp::Mul => (a * b, [0, 1, 2].map(|k| a * db[k] + da[k] * b)),
                    BinOp::Min | BinOp::Max => {
                        smooth &= a != b;
                        let r = if op == BinOp::Min {
                            min(a, b)
                        } else {
                            max(a, b)
                        };
                        (r, if r == a { da } else { db })
                    }
                    _ => unreachable!(),
                }
            }
            Op::Powi(a, n) => {
                smooth = false;
                (powi(v[a.index()].0, n), [0.0; 3])
            }
        };
        v.push(r);
    }
    let (f, d) = v[p.output.index()];
    (f, smooth.then_some(d))
}

fn contains(iv: Interval, v: f64) -> bool {
    v.is_nan() || (iv.lo <= v && v <= iv.hi)
}

/// Corners, centre and a few interior points of the box.
fn samples(b: &[Interval; 4], seed: u64) -> Vec<[f64; 4]> {
    let mut out = Vec::new();
    for c in 0..16u32 {
        out.push([0, 1, 2, 3].map(|k| if c >> k & 1 == 0 { b[k].lo } else { b[k].hi }));
    }
    let mid = |iv: Interval| {
        let m = 0.5 * iv.lo + 0.5 * iv.hi;
        m.clamp(iv.lo, iv.hi)
    };
    out.push(b.map(mid));
    let mut s = seed | 1;
    for _ in 0..16 {
        out.push(b.map(|iv| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            let p = iv.lo + (iv.hi - iv.lo) * u;
            if p.is_finite() {
                p.clamp(iv.lo, iv.hi)
            } else {
                mid(iv)
            }
        }));
    }
    out
}

fn config() -> ProptestConfig {
    ProptestConfig {
        // At least 10,000 cases; `PROPTEST_CASES` overrides.
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(10_000),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    /// JIT point kernel == oracle, bitwise (every NaN equals every NaN),
    /// single and batch.
    #[test]
    fn point_matches_oracle(p in program(false), b in interval_box(), seed in any::<u64>()) {
        let k = Kernels::compile(&p).unwrap();
        let pts = samples(&b, seed);
        let mut out = vec![0.0; pts.len()];
        let col = |i: usize| pts.iter().map(|q| q[i]).collect::<Vec<_>>();
        k.point_batch(&col(0), &col(1), &col(2), b[3].lo, &mut out).unwrap();
        for (i, q) in pts.iter().enumerate() {
            let want = point_grad(&p, *q).0;
            let got = k.point(*q);
            prop_assert!(got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "at {q:?}: jit {got:e}, oracle {want:e}\n{p:?}");
            let want_t = point_grad(&p, [q[0], q[1], q[2], b[3].lo]).0;
            prop_assert!(out[i].to_bits() == want_t.to_bits() || (out[i].is_nan() && want_t.is_nan()),
                "batch at {q:?}: jit {}, oracle {want_t:e}", out[i]);
        }
    }

    /// The interval kernel encloses the point value at the corners, the
    /// centre and interior samples, and its batch form agrees with it.
    #[test]
    fn interval_encloses_points(p in program(false), b in interval_box(), seed in any::<u64>()) {
        let k = Kernels::compile(&p).unwrap();
        let r = k.interval(b);
        for q in samples(&b, seed) {
            let v = point_grad(&p, q).0;
            prop_assert!(contains(r.iv, v), "f{q:?} = {v:e} not in {:?}\n{p:?}", r.iv);
        }
        let flat: Vec<f64> = b.iter().flat_map(|iv| [iv.lo, iv.hi]).collect();
        let mut out = [0.0; 2];
        let mut d = [false];
        k.interval_batch(&flat, &mut out, &mut d).unwrap();
        prop_assert_eq!(out[0].to_bits(), r.iv.lo.to_bits());
        prop_assert_eq!(out[1].to_bits(), r.iv.hi.to_bits());
        prop_assert_eq!(d[0], r.defined);
    }

    /// The gradient kernel encloses sampled values and gradients.
    #[test]
    fn grad_encloses_gradients(p in program(true), b in interval_box(), seed in any::<u64>()) {
        let k = Kernels::compile(&p).unwrap();
        let g = k.grad(b);
        for q in samples(&b, seed) {
            let (v, d) = point_grad(&p, q);
            prop_assert!(contains(g.value, v), "f{q:?} = {v:e} not in {:?}", g.value);
            if let Some(d) = d {
                for (i, (di, gi)) in d.iter().zip(g.grad).enumerate() {
                    prop_assert!(contains(gi, *di),
                        "d{i} f{q:?} = {di:e} not in {gi:?}\n{p:?}");
                }
            }
        }
        let flat: Vec<f64> = b.iter().flat_map(|iv| [iv.lo, iv.hi]).collect();
        let mut out = [0.0; 8];
        let mut d = [false];
        k.grad_batch(&flat, &mut out, &mut d).unwrap();
        prop_assert_eq!(out[0].to_bits(), g.value.lo.to_bits());
        prop_assert_eq!(out[7].to_bits(), g.grad[2].hi.to_bits());
        prop_assert_eq!(d[0], g.defined);
    }
}

// ---------------------------------------------------------------- traps

fn decimal(v: f64) -> Const {
    // The f64 nearest to 0.1 and 0.2 lies above the real number.
    Const {
        value: v,
        lo: v.next_down(),
        hi: v,
        defined: true,
    }
}

/// `x + 0.1 + 0.2` and `0.1 + 0.2` on x = 0: the interval must enclose the
/// real 0.3, which lies strictly between the f64 0.3 and its successor; a
/// round-to-nearest fold gives 0.30000000000000004, whose lower bound is
/// above the real 0.3.
#[test]
fn constants_are_not_folded_unsoundly() {
    let zero = Interval { lo: 0.0, hi: 0.0 };
    let real_03_lo = 0.3f64; // < real 0.3
    let real_03_hi = 0.3f64.next_up(); // > real 0.3
    let progs = [
        Program {
            insts: vec![
                Op::Var(Var::X),
                Op::Const(decimal(0.1)),
                Op::Binary(BinOp::Add, Value(0), Value(1)),
                Op::Const(decimal(0.2)),
                Op::Binary(BinOp::Add, Value(2), Value(3)),
            ],
            output: Value(4),
        },
        Program {
            insts: vec![
                Op::Const(decimal(0.1)),
                Op::Const(decimal(0.2)),
                Op::Binary(BinOp::Add, Value(0), Value(1)),
            ],
            output: Value(2),
        },
        Program {
            insts: vec![
                Op::Const(Const::exact(3.0)),
                Op::Const(decimal(0.1)),
                Op::Binary(BinOp::Mul, Value(0), Value(1)),
            ],
            output: Value(2),
        },
    ];
    for (i, p) in progs.iter().enumerate() {
        let k = Kernels::compile(p).unwrap();
        let r = k.interval([zero; 4]);
        assert!(r.defined);
        assert!(
            r.iv.lo <= real_03_lo && r.iv.hi >= real_03_hi,
            "program {i}: {:?} does not enclose the real 0.3",
            r.iv
        );
        let g = k.grad([zero; 4]);
        assert!(g.value.lo <= real_03_lo && g.value.hi >= real_03_hi);
        // The point kernel uses the f64 values, as the interpreter does.
        assert_eq!(k.point([0.0; 4]), 0.1 + 0.2);
    }
}

/// Empty, mismatched batch buffers are errors, not panics.
#[test]
fn batch_length_mismatch_is_an_error() {
    let p = Program {
        insts: vec![Op::Var(Var::X)],
        output: Value(0),
    };
    let k = Kernels::compile(&p).unwrap();
    let mut out = [0.0; 3];
    assert!(
        k.point_batch(&[1.0; 3], &[1.0; 2], &[1.0; 3], 0.0, &mut out)
            .is_err()
    );
    assert!(
        k.interval_batch(&[0.0; 8], &mut [0.0; 4], &mut [false; 1])
            .is_err()
    );
    assert!(
        k.grad_batch(&[0.0; 16], &mut [0.0; 16], &mut [false; 2])
            .is_ok()
    );
    k.point_batch(&[], &[], &[], 0.0, &mut []).unwrap();
}

#[test]
fn invalid_program_is_an_error() {
    let p = Program {
        insts: vec![Op::Unary(UnOp::Neg, Value(3))],
        output: Value(0),
    };
    assert!(Kernels::compile(&p).is_err());
}

/// Tightness: on random inline-op programs, the JIT interval is within a
/// few ulps per op of a reference computed in Rust with `next_down`/`next_up`
/// after every rounded operation (the reference interpreter's method).
/// Bound tested: each JIT bound is at most `4·ops` ulps outside the
/// reference bound (Rump's widening is 1–2 ulps per op, and errors compound).
#[test]
fn sqrt_and_square_are_tight() {
    let p = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Unary(UnOp::Square, Value(0)),
            Op::Unary(UnOp::Sqrt, Value(1)),
        ],
        output: Value(2),
    };
    let k = Kernels::compile(&p).unwrap();
    let b = Interval { lo: -3.0, hi: 2.0 };
    let r = k.interval([b; 4]);
    assert!(r.defined);
    assert_eq!(r.iv.lo, 0.0);
    assert!(r.iv.hi >= 3.0 && r.iv.hi <= 3.0f64.next_up().next_up().next_up());
    // sqrt of a box reaching below 0 is not defined everywhere.
    let p2 = Program {
        insts: vec![Op::Var(Var::X), Op::Unary(UnOp::Sqrt, Value(0))],
        output: Value(1),
    };
    let k2 = Kernels::compile(&p2).unwrap();
    let r2 = k2.interval([b; 4]);
    assert!(!r2.defined);
    assert!(r2.iv.lo <= 0.0 && r2.iv.hi >= 2f64.sqrt());
    let r3 = k2.interval([Interval { lo: -2.0, hi: -1.0 }; 4]);
    assert!(!r3.defined && r3.iv.lo > r3.iv.hi, "empty: {:?}", r3.iv);
}

#[test]
fn powi_exact_rules() {
    let mk = |n| Program {
        insts: vec![Op::Var(Var::X), Op::Powi(Value(0), n)],
        output: Value(1),
    };
    let b = Interval { lo: -2.0, hi: 1.0 };
    let k = Kernels::compile(&mk(2)).unwrap();
    let r = k.interval([b; 4]).iv;
    assert_eq!(r.lo, 0.0, "even power straddling 0 starts at 0");
    assert!(r.hi >= 4.0 && r.hi < 4.0000001);
    let k = Kernels::compile(&mk(3)).unwrap();
    let r = k.interval([b; 4]).iv;
    assert!(r.lo <= -8.0 && r.lo > -8.0000001 && r.hi >= 1.0 && r.hi < 1.0000001);
    let k = Kernels::compile(&mk(0)).unwrap();
    assert_eq!(k.interval([b; 4]).iv, Interval { lo: 1.0, hi: 1.0 });
    assert_eq!(k.point([f64::NAN; 4]), 1.0);
}

#[test]
fn compile_info_is_reported() {
    let p = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Var(Var::Y),
            Op::Binary(BinOp::Mul, Value(0), Value(1)),
        ],
        output: Value(2),
    };
    let k = Kernels::compile_with(
        &p,
        &isoc::jit::JitOptions {
            keep_text: true,
            ..Default::default()
        },
    )
    .unwrap();
    // Point, interval, gradient: single and batch.
    assert_eq!(k.info().len(), 6);
    for i in &k.info() {
        assert!(i.code_bytes > 0, "{}", i.name);
        assert!(
            i.clif.as_deref().unwrap_or("").contains("fmul"),
            "{}",
            i.name
        );
        assert!(!i.asm.as_deref().unwrap_or("").is_empty(), "{}", i.name);
    }
    for kind in isoc::jit::Kind::ALL {
        assert!(k.code_bytes(kind) > 0);
    }
}

/// Where round-to-nearest lands on the wrong side of the exact result the
/// kernels must step outward (sampled-point checks cannot see this: the
/// point value is rounded the same way).
#[test]
fn outward_rounding_is_applied() {
    let iv = |v: f64| Interval { lo: v, hi: v };
    let prog = |op: BinOp, c: f64| Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Const(Const::exact(c)),
            Op::Binary(op, Value(0), Value(1)),
        ],
        output: Value(2),
    };
    // 3 · 0.1 (the f64 0.1000000000000000055…) = 0.30000000000000001665…,
    // which rounds up to 0.30000000000000004.
    let k = Kernels::compile(&prog(BinOp::Mul, 3.0)).unwrap();
    let r = k.interval([iv(0.1); 4]).iv;
    assert_eq!(3.0 * 0.1, 0.30000000000000004);
    assert!(
        r.lo < 0.30000000000000004 && r.hi >= 0.30000000000000004,
        "{r:?}"
    );
    let g = k.grad([iv(0.1); 4]).value;
    assert!(g.lo < 0.30000000000000004, "{g:?}");
    // 1 + 2^-60 rounds down to 1.
    let k = Kernels::compile(&prog(BinOp::Add, 2f64.powi(-60))).unwrap();
    let r = k.interval([iv(1.0); 4]).iv;
    assert!(r.lo <= 1.0 && r.hi > 1.0, "{r:?}");
    // Exact results stay exact: 1.5 · 2 = 3.
    let k = Kernels::compile(&prog(BinOp::Mul, 2.0)).unwrap();
    assert_eq!(k.interval([iv(1.5); 4]).iv, iv(3.0));
    // sqrt(2) is inexact, sqrt(4) exact.
    let p = Program {
        insts: vec![Op::Var(Var::X), Op::Unary(UnOp::Sqrt, Value(0))],
        output: Value(1),
    };
    let k = Kernels::compile(&p).unwrap();
    let r = k.interval([iv(2.0); 4]).iv;
    assert!(r.lo < 2f64.sqrt() || r.hi > 2f64.sqrt(), "{r:?}");
    assert!(r.lo < r.hi && r.lo <= 2f64.sqrt() && r.hi >= 2f64.sqrt());
    assert_eq!(k.interval([iv(4.0); 4]).iv, iv(2.0));
}

/// The kernels are pure functions of their arguments: `Kernels` can be
/// shared between threads (the mesher evaluates in parallel).
#[test]
fn kernels_are_send_and_sync() {
    fn check<T: Send + Sync>(_: &T) {}
    let p = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Unary(UnOp::Sin, Value(0)),
            Op::Binary(BinOp::Mul, Value(1), Value(0)),
        ],
        output: Value(2),
    };
    let k = Kernels::compile(&p).unwrap();
    check(&k);
    let want: Vec<f64> = (0..64)
        .map(|i| k.point([i as f64, 0.0, 0.0, 0.0]))
        .collect();
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                for (i, w) in want.iter().enumerate() {
                    assert_eq!(k.point([i as f64, 0.0, 0.0, 0.0]).to_bits(), w.to_bits());
                }
            });
        }
    });
}

// ------------------------------------------- the rounding-mode bracket

use crate::support::exact;

use isoc::jit::mxcsr;

/// `exp(x)·y + sin(z)/(x + 2) + x·y` (helper calls between inline ops).
fn helper_sandwich() -> Program {
    Program {
        insts: vec![
            Op::Var(Var::X),                             // 0
            Op::Var(Var::Y),                             // 1
            Op::Var(Var::Z),                             // 2
            Op::Unary(UnOp::Exp, Value(0)),              // 3 helper
            Op::Binary(BinOp::Mul, Value(3), Value(1)),  // 4 inline
            Op::Unary(UnOp::Sin, Value(2)),              // 5 helper
            Op::Const(Const::exact(2.0)),                // 6
            Op::Binary(BinOp::Add, Value(0), Value(6)),  // 7 inline
            Op::Binary(BinOp::Div, Value(5), Value(7)),  // 8 helper
            Op::Binary(BinOp::Add, Value(4), Value(8)),  // 9 inline
            Op::Binary(BinOp::Mul, Value(0), Value(1)),  // 10 inline
            Op::Binary(BinOp::Add, Value(9), Value(10)), // 11 inline
        ],
        output: Value(11),
    }
}

fn some_boxes() -> Vec<[Interval; 4]> {
    let mut v = Vec::new();
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
    };
    for _ in 0..200 {
        let b: [Interval; 4] = std::array::from_fn(|_| {
            let (a, c) = (next(), next() * 1e-3);
            Interval {
                lo: a,
                hi: a + c.abs(),
            }
        });
        v.push(b);
    }
    v
}

/// A kernel gives the caller back its rounding mode and computes the same
/// bounds whatever the caller's mode was. Batch calls give back the whole
/// MXCSR — rounding, flush-to-zero, denormals-are-zero, sticky flags — bit
/// for bit. Single-box calls do too for a caller in a directed rounding
/// mode; a caller rounding to nearest gets the default MXCSR back (FTZ and
/// DAZ off, flags clear: what `isoc_rm_enter_probe` documents).
#[test]
fn kernels_restore_the_callers_rounding_mode() {
    let k = Kernels::compile(&helper_sandwich()).unwrap();
    let boxes = some_boxes();
    let want_iv: Vec<_> = boxes.iter().map(|b| k.interval(*b)).collect();
    let want_gd: Vec<_> = boxes.iter().map(|b| k.grad(*b)).collect();
    assert_eq!(mxcsr::current() & 0xFFC0, mxcsr::MXCSR_DEFAULT);
    let (ftz, daz) = (0x8000, 0x0040);
    // (caller's MXCSR, what a single call gives back)
    let modes = [
        // Round down (RC = 01) with FTZ and DAZ, flags clear.
        (0x3F80 | ftz | daz, 0x3F80 | ftz | daz),
        // Round up (RC = 10) with the inexact and invalid flags set.
        (0x5F80 | 0x21, 0x5F80 | 0x21),
        // Toward zero (RC = 11) with the underflow flag.
        (0x7F80 | 0x10, 0x7F80 | 0x10),
        // Nearest with FTZ, DAZ and every flag: the default comes back.
        (0x1F80 | ftz | daz | 0x3F, mxcsr::MXCSR_DEFAULT),
    ];
    let mut input = Vec::new();
    for b in &boxes {
        input.extend(b.iter().flat_map(|i| [i.lo, i.hi]));
    }
    for (mode, single_back) in modes {
        let mut got_iv = Vec::new();
        let mut got_gd = Vec::new();
        let mut seen = Vec::new();
        for b in &boxes {
            // SAFETY: only the kernel call and `stmxcsr` run in this mode;
            // the default is restored before any float work is checked.
            unsafe { mxcsr::set(mode) };
            let r = k.interval(*b);
            seen.push(mxcsr::current());
            unsafe { mxcsr::set(mode) };
            let g = k.grad(*b);
            seen.push(mxcsr::current());
            unsafe { mxcsr::set(mxcsr::MXCSR_DEFAULT) };
            got_iv.push(r);
            got_gd.push(g);
        }
        for m in seen {
            assert_eq!(
                m, single_back,
                "single call: caller's MXCSR {mode:#x} came back as {m:#x}"
            );
        }
        for (w, g) in want_iv.iter().zip(&got_iv) {
            assert_eq!(
                (w.iv.lo.to_bits(), w.iv.hi.to_bits(), w.defined),
                (g.iv.lo.to_bits(), g.iv.hi.to_bits(), g.defined),
                "caller's MXCSR {mode:#x}"
            );
        }
        for (w, g) in want_gd.iter().zip(&got_gd) {
            let bits = |e: &isoc::eval::GradEval| {
                std::iter::once(e.value)
                    .chain(e.grad)
                    .flat_map(|i| [i.lo.to_bits(), i.hi.to_bits()])
                    .chain([e.defined as u64])
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(w), bits(g), "caller's MXCSR {mode:#x}");
        }
        // The batch entry points give back every bit.
        let mut out = vec![0.0; 2 * boxes.len()];
        let mut def = vec![false; boxes.len()];
        let mut out8 = vec![0.0; 8 * boxes.len()];
        unsafe { mxcsr::set(mode) };
        k.interval_batch(&input, &mut out, &mut def).unwrap();
        let m = mxcsr::current();
        unsafe { mxcsr::set(mode) };
        k.grad_batch(&input, &mut out8, &mut def).unwrap();
        let m8 = mxcsr::current();
        unsafe { mxcsr::set(mxcsr::MXCSR_DEFAULT) };
        assert_eq!(
            (m, m8),
            (mode, mode),
            "batch call, caller's MXCSR {mode:#x}"
        );
        for (i, w) in want_iv.iter().enumerate() {
            assert_eq!(out[2 * i].to_bits(), w.iv.lo.to_bits());
            assert_eq!(out[2 * i + 1].to_bits(), w.iv.hi.to_bits());
        }
        for (i, w) in want_gd.iter().enumerate() {
            assert_eq!(out8[8 * i + 7].to_bits(), w.grad[2].hi.to_bits());
        }
    }
}

/// Helpers called in the middle of a kernel run in round to nearest (their
/// enclosures are bit for bit the reference interpreter's, which runs in
/// the default mode), and the inline ops after them in round up again
/// (directed rounding gives exactly the reference's bounds for `+` and `·`
/// in the normal range; round to nearest would fall inside them on an
/// inexact sum, which the enclosure checks below would catch).
#[test]
fn helpers_run_in_nearest_and_inline_ops_in_up() {
    let p = helper_sandwich();
    let k = Kernels::compile(&p).unwrap();
    for b in some_boxes() {
        let r = k.interval(b);
        let want = isoc::eval::interval::eval(&p, b);
        assert_eq!(
            (r.iv.lo.to_bits(), r.iv.hi.to_bits()),
            (want.iv.lo.to_bits(), want.iv.hi.to_bits()),
            "{b:?}: jit {:?}, reference {:?}",
            r.iv,
            want.iv
        );
        let g = k.grad(b);
        let gw = isoc::eval::grad::eval(&p, b);
        for (x, y) in std::iter::once(g.value)
            .chain(g.grad)
            .zip(std::iter::once(gw.value).chain(gw.grad))
        {
            assert!(
                x.lo <= y.lo.max(x.lo) && x.lo <= y.hi && x.hi >= y.lo,
                "{x:?} vs {y:?}"
            );
        }
    }
}

/// The single-box entry points compute everything before they restore the
/// caller's mode — also a flag that depends on a value nothing else uses.
/// In `√(x·y)⁰` the value is `[1, 1]` whatever `x·y` is, and the flag is
/// "`x·y ≥ 0` on the box". With `x·y`'s lower bound `−10⁻⁶⁰⁰` (the
/// corner `−10⁻³⁰⁰ · 10⁻³⁰⁰`), rounded
/// outward it is the smallest negative subnormal (not defined); rounded to
/// nearest it would be `−0`, which a product computed after the restore
/// would give, and the flag would wrongly say "defined".
#[test]
fn single_box_kernels_finish_before_restoring_the_mode() {
    let p = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Var(Var::Y),
            Op::Binary(BinOp::Mul, Value(0), Value(1)),
            Op::Unary(UnOp::Sqrt, Value(2)),
            Op::Powi(Value(3), 0),
        ],
        output: Value(4),
    };
    let k = Kernels::compile(&p).unwrap();
    let b = [
        Interval::new(-1e-300, 1.0),
        Interval::point(1e-300),
        Interval::point(0.0),
        Interval::point(0.0),
    ];
    assert!(!isoc::eval::interval::eval(&p, b).defined);
    assert!(!k.interval(b).defined);
    assert!(!k.grad(b).defined);
    // Inside the domain the flag is true: the test can tell the two apart.
    let inside = [Interval::new(1e-300, 1.0), b[1], b[2], b[3]];
    assert!(k.interval(inside).defined);
    assert!(k.grad(inside).defined);
}

/// Odd powers (the cube has its own one-chain rule), single and batch,
/// give the reference's bounds and flags on intervals with signed zero,
/// subnormal, tiny, huge and infinite bounds, in every sign pattern: equal
/// as numbers (a zero bound's sign may differ: `[−5e−324]³` has upper
/// bound `−0` in the kernels and `+0` in the reference, as before the
/// cube rule), and bit for bit between the single and batch kernels.
#[test]
fn odd_powers_are_the_references_bit_for_bit() {
    let ends = [
        0.0,
        -0.0,
        5e-324,
        -5e-324,
        1e-110,
        -1e-110,
        0.75,
        -0.75,
        1.0,
        -1.0,
        3.0,
        -3.0,
        1e103,
        -1e103,
        f64::MAX,
        -f64::MAX,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for k in [3, 5, 7] {
        let p = Program {
            insts: vec![Op::Var(Var::X), Op::Powi(Value(0), k)],
            output: Value(1),
        };
        let kern = Kernels::compile(&p).unwrap();
        let mut checked = 0;
        for &lo in &ends {
            for &hi in &ends {
                if lo > hi {
                    continue;
                }
                let b = [
                    Interval::new(lo, hi),
                    Interval::point(0.0),
                    Interval::point(0.0),
                    Interval::point(0.0),
                ];
                let r = isoc::eval::interval::eval(&p, b);
                let single = kern.interval(b);
                let mut out = [0.0; 2];
                let mut d = [false];
                let input: Vec<f64> = b.iter().flat_map(|i| [i.lo, i.hi]).collect();
                kern.interval_batch(&input, &mut out, &mut d).unwrap();
                assert_eq!(
                    (
                        single.iv.lo.to_bits(),
                        single.iv.hi.to_bits(),
                        single.defined
                    ),
                    (out[0].to_bits(), out[1].to_bits(), d[0]),
                    "x^{k} on [{lo:e}, {hi:e}]: single and batch"
                );
                assert!(
                    single.iv.lo == r.iv.lo
                        && single.iv.hi == r.iv.hi
                        && single.defined == r.defined,
                    "x^{k} on [{lo:e}, {hi:e}]: jit {:?}, reference {:?}",
                    single,
                    r
                );
                checked += 1;
            }
        }
        assert!(checked > 100);
    }
}

/// `+`, `−`, `·`, `√`, squares and small powers whose results are
/// subnormal, tiny or overflow: the bounds enclose the exact result (exact
/// dyadic arithmetic) and are the nearest floats around it.
#[test]
fn directed_rounding_at_the_edges_of_the_range() {
    use exact::Dyadic;
    let bin = |op: BinOp| Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Var(Var::Y),
            Op::Binary(op, Value(0), Value(1)),
        ],
        output: Value(2),
    };
    let mul = Kernels::compile(&bin(BinOp::Mul)).unwrap();
    let add = Kernels::compile(&bin(BinOp::Add)).unwrap();
    let sub = Kernels::compile(&bin(BinOp::Sub)).unwrap();
    let pt = |v: f64| Interval { lo: v, hi: v };
    let tiny = [
        f64::from_bits(1),
        f64::from_bits(3),
        2.5e-320,
        1.0e-310,
        2f64.powi(-1022),
        3.0e-200,
        7.0e-170,
        1.0e-160,
        0.1,
        1.0 / 3.0,
        -1.0e-300,
        -3.3e-160,
        1.0e200,
        -2.0e250,
        1.7e308,
        f64::MAX,
    ];
    for &x in &tiny {
        for &y in &tiny {
            let b = [pt(x), pt(y), pt(0.0), pt(0.0)];
            let r = mul.interval(b).iv;
            let exact = Dyadic::of(x).mul(Dyadic::of(y));
            assert!(exact.within(r.lo, r.hi), "{x:e}·{y:e} ∉ {r:?}");
            // Tight: one float step at most on either side.
            if r.lo.is_finite() && r.lo != r.hi {
                assert!(
                    !exact.within(r.lo.next_up(), r.hi),
                    "{x:e}·{y:e}: lo {r:?} not tight"
                );
                assert!(
                    !exact.within(r.lo, r.hi.next_down()),
                    "{x:e}·{y:e}: hi {r:?} not tight"
                );
            }
            if x * y == 0.0 && x != 0.0 && y != 0.0 {
                assert!(
                    r.lo < 0.0 || r.hi > 0.0,
                    "an underflowed product keeps its sign's side"
                );
            }
            for (k, neg) in [(&add, false), (&sub, true)] {
                let r = k.interval(b).iv;
                let y2 = if neg { -y } else { y };
                if let Some(e) = Dyadic::of(x).add(Dyadic::of(y2)) {
                    assert!(e.within(r.lo, r.hi), "{x:e} ± {y:e} ∉ {r:?}");
                    if r.lo.is_finite() && r.hi.is_finite() && r.lo != r.hi {
                        assert!(!e.within(r.lo.next_up(), r.hi), "{x:e}±{y:e}: {r:?}");
                        assert!(!e.within(r.lo, r.hi.next_down()), "{x:e}±{y:e}: {r:?}");
                    }
                }
            }
        }
    }
    // Overflow: an upper bound goes to +∞, a lower bound of a positive
    // overflowing product stays finite (MAX), and vice versa.
    let r = mul.interval([pt(1e300), pt(1e300), pt(0.0), pt(0.0)]).iv;
    assert_eq!((r.lo, r.hi), (f64::MAX, f64::INFINITY));
    let r = mul.interval([pt(-1e300), pt(1e300), pt(0.0), pt(0.0)]).iv;
    assert_eq!((r.lo, r.hi), (f64::NEG_INFINITY, -f64::MAX));
    // √ of subnormals and of exact squares.
    let sq = Kernels::compile(&Program {
        insts: vec![Op::Var(Var::X), Op::Unary(UnOp::Sqrt, Value(0))],
        output: Value(1),
    })
    .unwrap();
    for &x in &[
        f64::from_bits(1),
        2.5e-320,
        1.0e-310,
        4.0e-320,
        2.0,
        0.25,
        1.0,
    ] {
        let r = sq.interval([pt(x), pt(0.0), pt(0.0), pt(0.0)]).iv;
        let (lo2, hi2) = (
            Dyadic::of(r.lo).mul(Dyadic::of(r.lo)),
            Dyadic::of(r.hi).mul(Dyadic::of(r.hi)),
        );
        let xd = Dyadic::of(x);
        assert!(lo2.cmp(xd).is_le() && hi2.cmp(xd).is_ge(), "√{x:e}: {r:?}");
        assert!(
            r.lo == r.hi || r.lo.next_up() == r.hi,
            "√{x:e}: {r:?} not tight"
        );
    }
}

/// NaN and infinite inputs: a NaN bound means the whole line, undefined;
/// infinite bounds give infinite enclosures, `0·∞` counts as 0.
#[test]
fn nan_and_infinite_inputs() {
    let p = Program {
        insts: vec![
            Op::Var(Var::X),
            Op::Var(Var::Y),
            Op::Binary(BinOp::Mul, Value(0), Value(1)),
            Op::Unary(UnOp::Exp, Value(2)),
            Op::Binary(BinOp::Add, Value(3), Value(0)),
        ],
        output: Value(4),
    };
    let k = Kernels::compile(&p).unwrap();
    let iv = |lo: f64, hi: f64| Interval { lo, hi };
    let z = iv(0.0, 0.0);
    let inf = f64::INFINITY;
    let cases = [
        [iv(f64::NAN, 1.0), iv(1.0, 2.0), z, z],
        [iv(0.0, 1.0), iv(f64::NAN, f64::NAN), z, z],
        [iv(0.0, 0.0), iv(-inf, inf), z, z],
        [iv(0.0, 1.0), iv(1.0, inf), z, z],
        [iv(-inf, inf), iv(-inf, inf), z, z],
        [iv(-1.0, 0.0), iv(-inf, -1.0), z, z],
    ];
    for b in cases {
        let r = k.interval(b);
        let want = isoc::eval::interval::eval(&p, b);
        assert_eq!(r.defined, want.defined, "{b:?}");
        assert!(
            r.iv.lo <= want.iv.lo && r.iv.hi >= want.iv.hi
                || (r.iv.lo.is_nan() && want.iv.lo.is_nan()),
            "{b:?}: jit {:?} ⊉ reference {:?}",
            r.iv,
            want.iv
        );
    }
    // [0,0]·[−∞,∞] = [0,0]: exp gives [1,1], plus x = [1, 1].
    let r = k.interval([z, iv(-inf, inf), z, z]).iv;
    assert_eq!((r.lo, r.hi), (1.0, 1.0));
}

// ------------------------------------------------------------ large inputs

/// `k0·x·y + k1·y·z + …` with `n` terms (distinct coefficients), and the
/// same function evaluated directly in f64.
fn big_sum(n: usize) -> (String, impl Fn([f64; 3]) -> f64) {
    let coef = |i: usize| ((i * 7919) % 1000) as f64 / 100.0 + 0.5;
    let terms: Vec<String> = (0..n)
        .map(|i| format!("{}*{}", coef(i), ["x*y", "y*z", "x*z"][i % 3]))
        .collect();
    let src = format!("domain [-1, 1]^3;\nsurface {} - 1;\n", terms.join(" + "));
    let f = move |p: [f64; 3]| {
        let uv = [p[0] * p[1], p[1] * p[2], p[0] * p[2]];
        (0..n).map(|i| coef(i) * uv[i % 3]).sum::<f64>() - 1.0
    };
    (src, f)
}

/// A 40,000-term sum (a 470 KB file, 46,001 IR instructions) compiles to
/// native code for every kind and evaluates correctly: points against a
/// direct f64 sum, enclosures against samples and the reference
/// interpreter. (Its compile time is a benchmark: `cargo bench --bench
/// kernels -- compile_scaling/`.)
#[test]
fn a_40000_term_sum_compiles_and_evaluates() {
    use isoc::jit::{Engine, Kind};
    let (src, f) = big_sum(40_000);
    let s = isoc::Surface::compile(&src, "sum.iso", &Default::default()).unwrap();
    let k = s.kernels();
    k.prepare(&Kind::EVERY);
    for kind in Kind::EVERY {
        assert_eq!(k.engine(kind), Engine::Jit, "{kind:?}");
    }
    let scale: f64 = (0..40_000)
        .map(|i| ((i * 7919) % 1000) as f64 / 100.0 + 0.5)
        .sum();
    for p in [[0.3, -0.2, 0.5], [1.0, 1.0, 1.0], [-0.7, 0.1, 0.9]] {
        let v = s.point([p[0], p[1], p[2], 0.0]);
        let want = f(p);
        assert!((v - want).abs() <= 1e-12 * scale, "{p:?}: {v} vs {want}");
        assert_eq!(
            v.to_bits(),
            isoc::eval::point::eval(&s.program, [p[0], p[1], p[2], 0.0]).to_bits()
        );
        let (gv, g) = s.point_grad([p[0], p[1], p[2], 0.0]);
        assert_eq!(gv.to_bits(), v.to_bits());
        let h = 1e-6;
        let fd = (f([p[0] + h, p[1], p[2]]) - f([p[0] - h, p[1], p[2]])) / (2.0 * h);
        assert!((g[0] - fd).abs() <= 1e-6 * scale, "∂x {} vs {fd}", g[0]);
    }
    let b = [
        Interval { lo: 0.1, hi: 0.3 },
        Interval { lo: -0.4, hi: 0.2 },
        Interval { lo: 0.5, hi: 0.6 },
        Interval::point(0.0),
    ];
    let r = s.interval(b);
    let want = isoc::eval::interval::eval(&s.program, b);
    assert!(r.defined && want.defined);
    let tol = 1e-12 * scale;
    assert!((r.iv.lo - want.iv.lo).abs() <= tol && (r.iv.hi - want.iv.hi).abs() <= tol);
    let g = s.grad(b);
    for i in 0..=10 {
        for j in 0..=10 {
            let p = [
                0.1 + 0.02 * i as f64,
                -0.4 + 0.06 * j as f64,
                0.5 + 0.01 * ((i + j) % 11) as f64,
            ];
            let v = s.point([p[0], p[1], p[2], 0.0]);
            assert!(r.iv.lo <= v && v <= r.iv.hi, "{v} ∉ {:?}", r.iv);
            assert!(g.value.lo <= v && v <= g.value.hi);
            let (_, d) = s.point_grad([p[0], p[1], p[2], 0.0]);
            for (gc, dc) in g.grad.iter().zip(d) {
                assert!(gc.lo <= dc && dc <= gc.hi);
            }
        }
    }
}

/// A program over [`JitOptions::jit_limit`] is interpreted, with the
/// reference's results, and says so.
#[test]
fn programs_over_the_limit_are_interpreted() {
    use isoc::jit::{Engine, JitOptions, Kind};
    let (src, _) = big_sum(50);
    let s = isoc::Surface::compile(&src, "sum.iso", &Default::default()).unwrap();
    let opts = JitOptions {
        jit_limit: 10,
        ..Default::default()
    };
    let k = Kernels::lazy(&s.program, &opts).unwrap();
    for kind in Kind::EVERY {
        assert!(matches!(k.engine(kind), Engine::Interpreter(_)), "{kind:?}");
    }
    assert!(Kernels::compile_with(&s.program, &opts).is_err());
    assert!(k.info().is_empty());
    let b = [
        Interval { lo: 0.1, hi: 0.3 },
        Interval { lo: -0.4, hi: 0.2 },
        Interval { lo: 0.5, hi: 0.6 },
        Interval::point(0.0),
    ];
    let (r, w) = (k.interval(b), isoc::eval::interval::eval(&s.program, b));
    assert_eq!(
        (r.iv.lo.to_bits(), r.iv.hi.to_bits()),
        (w.iv.lo.to_bits(), w.iv.hi.to_bits())
    );
    let p = [0.3, -0.2, 0.5, 0.0];
    assert_eq!(
        k.point(p).to_bits(),
        isoc::eval::point::eval(&s.program, p).to_bits()
    );
    let g = k.grad(b);
    let gw = isoc::eval::grad::eval(&s.program, b);
    assert_eq!(g.value, gw.value);
    assert_eq!(g.grad, gw.grad);
    let mut out = vec![0.0; 8];
    let mut def = vec![false];
    let flat: Vec<f64> = b.iter().flat_map(|i| [i.lo, i.hi]).collect();
    k.grad_batch(&flat, &mut out, &mut def).unwrap();
    assert_eq!(out[0].to_bits(), gw.value.lo.to_bits());
}
