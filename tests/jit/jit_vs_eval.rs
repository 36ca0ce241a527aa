//! The JIT against the reference evaluators on random programs of every op
//! (the shared strategy of `tests/support`): the shared backend suite, and
//! tightness and decoration agreement with the reference interval and
//! gradient evaluators.

use isoc::eval::{Evaluator, Reference};
use isoc::ir::{BinOp, Op, Program, UnOp, Value, Var};
use isoc::jit::{JitOptions, Kernels};

/// Random programs compile with Cranelift's single-pass register
/// allocator: the kernels' semantics do not depend on the allocator, and
/// it keeps 10,000 compilations per property affordable. The default
/// allocator, with the IR verifier on, is exercised on every corpus file
/// by `tests/jit/jit_corpus.rs` and by the other tests.
fn jit(p: &Program) -> Kernels {
    let opts = JitOptions {
        fast_compile: true,
        ..JitOptions::default()
    };
    Kernels::compile_with(p, &opts).expect("JIT compile")
}

backend_suite!(jit_backend, |p: &Program| jit(p));

/// Two ulps below / above.
fn down2(x: f64) -> f64 {
    x.next_down().next_down()
}
fn up2(x: f64) -> f64 {
    x.next_up().next_up()
}

/// One op on the variables: `op(x)`, `op(x, y)` or `x^n`.
fn single_op() -> impl proptest::strategy::Strategy<Value = Op> {
    use proptest::prelude::*;
    prop_oneof![
        prop::sample::select(UnOp::ALL.to_vec()).prop_map(|u| Op::Unary(u, Value(0))),
        prop::sample::select(BinOp::ALL.to_vec()).prop_map(|b| Op::Binary(b, Value(0), Value(1))),
        (-12i64..13).prop_map(|n| Op::Powi(Value(0), n)),
    ]
}

fn single_program(op: Op) -> Program {
    Program {
        insts: vec![Op::Var(Var::X), Op::Var(Var::Y), op],
        output: Value(2),
    }
}

mod tightness {
    use super::*;
    use crate::support::{arb_box, arb_program, cases};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(cases()))]

        /// Tightness bound, per op: every JIT bound is at most 2 ulps
        /// outside the reference's (Rump's successor is 1–2 ulps where the
        /// reference moves 1 ulp, or 0 when its error-free transformation
        /// proves the result exact); ops computed by the shared helpers are
        /// identical. The decorations agree.
        #[test]
        fn single_op_within_two_ulps(op in single_op(), b in arb_box()) {
            let p = single_program(op);
            let r = Reference(p.clone()).interval(b);
            let j = jit(&p).interval(b);
            prop_assert_eq!(j.defined, r.defined, "flags: jit {:?} ref {:?} {:?} on {:?}", j, r, op, b);
            if !r.iv.is_empty() {
                prop_assert!(j.iv.lo >= down2(r.iv.lo) && j.iv.hi <= up2(r.iv.hi),
                    "jit {:?} wider than ref {:?} + 2 ulps: {:?} on {:?}", j.iv, r.iv, op, b);
            }
        }

        /// Whole programs: the JIT and the reference agree on the
        /// decoration of the interval and gradient kernels.
        #[test]
        fn same_decorations(p in arb_program(), b in arb_box()) {
            let k = jit(&p);
            let r = Reference(p.clone());
            let (ji, ri) = (k.interval(b), r.interval(b));
            if !ri.iv.is_empty() {
                prop_assert_eq!(ji.defined, ri.defined, "interval flags: jit {:?} ref {:?}\n{}\n{:?}", ji, ri, p, b);
            }
            let (jg, rg) = (k.grad(b), r.grad(b));
            if !rg.value.is_empty() {
                prop_assert_eq!(jg.defined, rg.defined, "grad flags: jit {:?} ref {:?}\n{}\n{:?}", jg, rg, p, b);
            }
        }
    }
}

/// Measures (and prints, with `--nocapture`) how the JIT's interval bounds
/// compare with the reference's on 2,000 random programs and boxes where
/// both are defined and finite: the share of identical bounds and the
/// largest excess in ulps. Asserts only that the JIT is never tighter than
/// a sound bound could be on the *point* samples (done by the suite) and
/// that most bounds are identical.
#[test]
fn tightness_report() {
    use proptest::strategy::{Strategy, ValueTree};
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let strat = (crate::support::arb_program(), crate::support::arb_box());
    let (mut same, mut total, mut worse, mut max_ulps) = (0u64, 0u64, 0u64, 0u64);
    let ulps = |a: f64, b: f64| -> u64 {
        let key = |x: f64| {
            let i = x.to_bits() as i64;
            if i < 0 { i64::MIN - i } else { i }
        };
        key(a).abs_diff(key(b))
    };
    for _ in 0..2000 {
        let (p, b) = strat.new_tree(&mut runner).expect("tree").current();
        let r = Reference(p.clone()).interval(b);
        if !r.defined || !r.iv.lo.is_finite() || !r.iv.hi.is_finite() {
            continue;
        }
        let j = jit(&p).interval(b);
        for (jb, rb) in [(j.iv.lo, r.iv.lo), (j.iv.hi, r.iv.hi)] {
            total += 1;
            if jb == rb {
                same += 1;
            } else {
                worse += 1;
                max_ulps = max_ulps.max(ulps(jb, rb));
            }
        }
    }
    println!(
        "tightness: {same}/{total} bounds identical to the reference, {worse} differ, max {max_ulps} ulps"
    );
    assert!(total > 0 && same * 2 > total);
}

/// The batch point kernel, F64X2 (`simd`, the default) and scalar, on
/// random programs of every op: each output is bit for bit the single-point
/// kernel's and the reference interpreter's (every NaN equals every NaN),
/// for batch lengths 0, 1, 2, 3, 17 and others, odd and even, with NaN,
/// ±inf and -0.0 among the coordinates. (The reference is compared with
/// `==` for zeros: a check kept from when Rust's `f64::min` left the zero
/// of a `min`/`max` tie unspecified; the reference now orders `-0 < +0`
/// like the kernels.)
mod batch {
    use super::*;
    use proptest::prelude::*;

    fn len() -> impl Strategy<Value = usize> {
        prop_oneof![prop::sample::select(vec![0usize, 1, 2, 3, 17]), 0usize..40]
    }

    fn bits_eq(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 600,
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        #[test]
        fn batch_is_single_and_reference(
            p in crate::support::arb_program(),
            pts in len().prop_flat_map(|n| prop::collection::vec([crate::support::arb_batch_coord(), crate::support::arb_batch_coord(), crate::support::arb_batch_coord()], n)),
            t in crate::support::arb_batch_coord(),
        ) {
            let xs: Vec<f64> = pts.iter().map(|q| q[0]).collect();
            let ys: Vec<f64> = pts.iter().map(|q| q[1]).collect();
            let zs: Vec<f64> = pts.iter().map(|q| q[2]).collect();
            for simd in [true, false] {
                let opts = JitOptions { fast_compile: true, simd, ..JitOptions::default() };
                let k = Kernels::compile_with(&p, &opts).expect("JIT compile");
                // One slot more than needed, to catch a write past `n`.
                let mut out = vec![1.5; pts.len() + 1];
                let n = pts.len();
                k.point_batch(&xs, &ys, &zs, t, &mut out[..n]).unwrap();
                prop_assert_eq!(out[n].to_bits(), 1.5f64.to_bits(), "wrote past n (simd {})", simd);
                for (i, q) in pts.iter().enumerate() {
                    let at = [q[0], q[1], q[2], t];
                    let single = k.point(at);
                    let reference = isoc::eval::point::eval(&p, at);
                    prop_assert!(bits_eq(out[i], single),
                        "simd {simd}, n {n}, i {i}, at {at:?}: batch {:e} single {single:e}\n{p}", out[i]);
                    let zeros = out[i] == 0.0 && reference == 0.0;
                    prop_assert!(bits_eq(out[i], reference) || zeros,
                        "simd {simd}, n {n}, i {i}, at {at:?}: batch {:e} reference {reference:e}\n{p}", out[i]);
                }
            }
        }
    }
}
