//! Interval arithmetic: per-op soundness properties (point containment and,
//! for the algebraic ops, containment of the *exact* real result) and unit
//! tests of the tricky cases.

use crate::support::exact::Dyadic;
use crate::support::{Rng, arb_exponent, arb_interval, encloses, sample};

use isoc::interval::{self, HALF_PI_HI, Interval, PI_HI};
use isoc::ir::{BinOp, UnOp};
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

fn iv(lo: f64, hi: f64) -> Interval {
    Interval::new(lo, hi)
}

/// Sample points of an interval: both ends, then random ones.
fn points(a: Interval, seed: u64, n: usize) -> Vec<f64> {
    let mut rng = Rng(seed);
    let mut v = vec![a.lo, a.hi];
    v.extend((0..n).map(|_| sample(a, &mut rng)));
    if a.is_empty() {
        return Vec::new();
    }
    v.retain(|x| !x.is_nan());
    v
}

fn cfg() -> ProptestConfig {
    ProptestConfig::with_cases(crate::support::cases())
}

proptest! {
    #![proptest_config(cfg())]

    /// Every unary op: point values at points of `a` lie in `op(a)`; a NaN
    /// at a finite point means the op left its domain, so `defined` must be
    /// false.
    #[test]
    fn unary_ops_enclose_point_values(op in prop::sample::select(UnOp::ALL.to_vec()),
                                      a in arb_interval(), seed in any::<u64>()) {
        let (r, defined) = isoc::ir::semantics::enclose_unary(op, a);
        for x in points(a, seed, 16) {
            let v = isoc::ir::semantics::point_unary(op, x);
            prop_assert!(encloses(r, v), "{op:?}({a:?}) = {r:?} misses {op:?}({x:e}) = {v:e}");
            if x.is_finite() && v.is_nan() {
                prop_assert!(!defined, "{op:?}({a:?}) claims defined, NaN at {x:e}");
            }
        }
    }

    #[test]
    fn binary_ops_enclose_point_values(op in prop::sample::select(BinOp::ALL.to_vec()),
                                       a in arb_interval(), b in arb_interval(), seed in any::<u64>()) {
        let (r, defined) = isoc::ir::semantics::enclose_binary(op, a, b);
        let (xs, ys) = (points(a, seed, 6), points(b, seed ^ 0x5555, 6));
        for &x in &xs {
            for &y in &ys {
                let v = isoc::ir::semantics::point_binary(op, x, y);
                prop_assert!(encloses(r, v), "{op:?}({a:?}, {b:?}) = {r:?} misses {op:?}({x:e}, {y:e}) = {v:e}");
                if x.is_finite() && y.is_finite() && v.is_nan() {
                    prop_assert!(!defined, "{op:?}({a:?}, {b:?}) claims defined, NaN at ({x:e}, {y:e})");
                }
            }
        }
    }

    #[test]
    fn powi_encloses_point_values(n in arb_exponent(), a in arb_interval(), seed in any::<u64>()) {
        let (r, defined) = isoc::ir::semantics::enclose_powi(a, n);
        for x in points(a, seed, 16) {
            let v = isoc::ir::semantics::point_powi(x, n);
            prop_assert!(encloses(r, v), "powi({a:?}, {n}) = {r:?} misses {x:e}^{n} = {v:e}");
            if x.is_finite() && v.is_nan() {
                prop_assert!(!defined, "powi({a:?}, {n}) claims defined, NaN at {x:e}");
            }
        }
    }

    /// `+ − × /` and `sqrt` on degenerate intervals enclose the exact real
    /// result (decided in exact dyadic arithmetic), so a missing outward
    /// step is caught even where the point value is inside.
    #[test]
    fn arithmetic_encloses_exact_results(x in -1e6f64..1e6, y in -1e6f64..1e6,
                                         sx in -30i32..30, sy in -30i32..30) {
        let a = x * 2f64.powi(sx);
        let b = y * 2f64.powi(sy);
        let (da, db) = (Dyadic::of(a), Dyadic::of(b));
        let (pa, pb) = (Interval::point(a), Interval::point(b));
        let (s, _) = isoc::ir::semantics::enclose_binary(BinOp::Add, pa, pb);
        if let Some(e) = da.add(db) {
            prop_assert!(e.within(s.lo, s.hi), "{a:e} + {b:e} ∉ {s:?}");
        }
        let (d, _) = isoc::ir::semantics::enclose_binary(BinOp::Sub, pa, pb);
        if let Some(e) = da.add(Dyadic::of(-b)) {
            prop_assert!(e.within(d.lo, d.hi), "{a:e} - {b:e} ∉ {d:?}");
        }
        let (p, _) = isoc::ir::semantics::enclose_binary(BinOp::Mul, pa, pb);
        prop_assert!(da.mul(db).within(p.lo, p.hi), "{a:e} * {b:e} ∉ {p:?}");
        let (sq, _) = isoc::ir::semantics::enclose_unary(UnOp::Square, pa);
        prop_assert!(da.mul(da).within(sq.lo, sq.hi), "{a:e}² ∉ {sq:?}");
        if b > 0.0 {
            // a/b ∈ [lo, hi] ⟺ lo·b ≤ a ≤ hi·b for b > 0.
            let (q, _) = isoc::ir::semantics::enclose_binary(BinOp::Div, pa, pb);
            let lo_b = Dyadic::of(q.lo).mul(db);
            let hi_b = Dyadic::of(q.hi).mul(db);
            prop_assert!(lo_b.cmp(da).is_le() && da.cmp(hi_b).is_le(), "{a:e} / {b:e} ∉ {q:?}");
        }
        // Tightness: the error-free transformations give at most one ulp.
        for r in [s, d, p, sq] {
            prop_assert!(r.hi <= r.lo.next_up(), "{a:e}, {b:e}: {r:?} wider than one ulp");
        }
        if a > 0.0 {
            let (r, _) = isoc::ir::semantics::enclose_unary(UnOp::Sqrt, pa);
            prop_assert!(r.hi <= r.lo.next_up(), "√{a:e}: {r:?} wider than one ulp");
            let (l, h) = (Dyadic::of(r.lo), Dyadic::of(r.hi));
            prop_assert!(l.mul(l).cmp(da).is_le() && da.cmp(h.mul(h)).is_le(), "√{a:e} ∉ {r:?}");
        }
    }

    /// Products and square roots in the underflow range are as tight as
    /// directed rounding: the exact product lies in `[lo, hi]` and in
    /// neither `[lo⁺, hi]` nor `[lo, hi⁻]` (no bound can move inward).
    #[test]
    fn tiny_products_and_roots_are_exact_bounds(x in -1e6f64..1e6, y in -1e6f64..1e6,
                                               sx in -560i32..-440, sy in -620i32..-500) {
        let a = x * 2f64.powi(sx);
        let b = y * 2f64.powi(sy);
        prop_assume!(a != 0.0 && b != 0.0);
        let exact = Dyadic::of(a).mul(Dyadic::of(b));
        let (p, _) = isoc::ir::semantics::enclose_binary(BinOp::Mul, Interval::point(a), Interval::point(b));
        prop_assert!(exact.within(p.lo, p.hi), "{a:e} * {b:e} ∉ {p:?}");
        if p.lo != p.hi {
            prop_assert!(!exact.within(p.lo.next_up(), p.hi), "{a:e} * {b:e}: lo of {p:?}");
            prop_assert!(!exact.within(p.lo, p.hi.next_down()), "{a:e} * {b:e}: hi of {p:?}");
        }
        let t = a.abs() * 2f64.powi(-400);
        if t > 0.0 {
            let (r, _) = isoc::ir::semantics::enclose_unary(UnOp::Sqrt, Interval::point(t));
            let (l, h) = (Dyadic::of(r.lo), Dyadic::of(r.hi));
            let dt = Dyadic::of(t);
            prop_assert!(l.mul(l).cmp(dt).is_le() && dt.cmp(h.mul(h)).is_le(), "√{t:e} ∉ {r:?}");
            prop_assert!(r.hi <= r.lo.next_up(), "√{t:e}: {r:?} wider than one ulp");
        }
    }

    /// Transcendental bounds are strictly outside the correctly rounded
    /// value (the one-ulp step), except at the trivial exact points.
    #[test]
    fn transcendental_bounds_step_outward(op in prop::sample::select(vec![
        UnOp::Exp, UnOp::Log, UnOp::Sin, UnOp::Cos, UnOp::Tan, UnOp::Asin, UnOp::Acos, UnOp::Atan,
    ]), x in -1.0f64..1.0, scale in prop::sample::select(vec![1e-3, 1.0, 0.999, 30.0, 700.0])) {
        let x = x * scale;
        let v = isoc::ir::semantics::point_unary(op, x);
        if !(v.is_finite() && v != 0.0 && v.abs() != 1.0 && x != 0.0) {
            return Ok(());
        }
        let (r, _) = isoc::ir::semantics::enclose_unary(op, Interval::point(x));
        prop_assert!(r.lo < v && v < r.hi, "{op:?}({x:e}) = {v:e}, bounds {r:?}");
        // … and not wider than that (two ulps around the rounded value).
        prop_assert!(r.lo.next_up() == v && r.hi.next_down() == v, "{op:?}({x:e}): {r:?} too wide");
    }
}

proptest! {
    #![proptest_config(cfg())]

    /// Intervals around a critical point `kπ/2` of sin/cos/tan (extremum or
    /// pole), for `k` up to ±10⁷: the values at the floats nearest to the
    /// critical point must be enclosed, so a missed extremum is caught.
    #[test]
    fn trig_near_critical_points(k in -10_000_000i64..10_000_000, small in any::<bool>(),
                                 w1 in 0.0f64..1e-3, w2 in 0.0f64..1e-3,
                                 op in prop::sample::select(vec![UnOp::Sin, UnOp::Cos, UnOp::Tan])) {
        let k = if small { k % 16 } else { k };
        let x0 = k as f64 * FRAC_PI_2;
        let a = iv(x0 - w1, x0 + w2);
        let (r, defined) = isoc::ir::semantics::enclose_unary(op, a);
        let mut x = x0;
        for _ in 0..4 {
            x = x.next_down();
        }
        for _ in 0..9 {
            if a.contains(x) {
                let v = isoc::ir::semantics::point_unary(op, x);
                prop_assert!(encloses(r, v), "{op:?}({a:?}) = {r:?} misses {op:?}({x:e}) = {v:e}");
                if op == UnOp::Tan && k % 2 != 0 && w1 > 1e-6 && w2 > 1e-6 {
                    prop_assert!(!defined, "tan over a pole claims defined: {a:?}");
                }
            }
            x = x.next_up();
        }
    }
}

proptest! {
    #![proptest_config(cfg())]

    /// The nine-case product rounds only the extremal bound products: it
    /// must give the hull of all four rounded products, bound for bound
    /// (a zero's sign aside), whatever the signs, zeros and infinities.
    #[test]
    fn product_by_sign_cases_is_the_four_product_hull(a in arb_interval(), b in arb_interval()) {
        use isoc::interval::round::{self, Dir};
        let r = interval::arith::mul(a, b);
        if a.is_empty() || b.is_empty() {
            prop_assert!(r.is_empty());
        } else {
            let mut lo = f64::INFINITY;
            let mut hi = f64::NEG_INFINITY;
            for x in [a.lo, a.hi] {
                for y in [b.lo, b.hi] {
                    lo = lo.min(round::mul(x, y, Dir::Down));
                    hi = hi.max(round::mul(x, y, Dir::Up));
                }
            }
            prop_assert!(r.lo == lo && r.hi == hi, "{a:?} * {b:?} = {r:?}, four products give [{lo:e}, {hi:e}]");
        }
    }
}

// ---------------------------------------------------------------- unit tests

#[test]
fn pi_constants_bracket_pi() {
    assert_eq!(PI_HI, PI.next_up());
    assert_eq!(HALF_PI_HI, FRAC_PI_2.next_up());
    // f64 π is below the real π: 3.14159265358979311… < 3.14159265358979323…
    assert!(format!("{:.20}", PI).starts_with("3.14159265358979311"));
}

#[test]
fn square_of_straddling_interval_starts_at_zero() {
    assert_eq!(
        isoc::ir::semantics::enclose_powi(iv(-1.0, 2.0), 2),
        (iv(0.0, 4.0), true)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Square, iv(-1.0, 2.0)),
        (iv(0.0, 4.0), true)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_powi(iv(-3.0, -2.0), 2),
        (iv(4.0, 9.0), true)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_powi(iv(-1.0, 2.0), 3),
        (iv(-1.0, 8.0), true)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_powi(iv(-2.0, 1.0), 4),
        (iv(0.0, 16.0), true)
    );
}

#[test]
fn negative_powers() {
    // x^-2 on [-1, 1]: 1/[0, 1] = [1, ∞], not defined at 0.
    assert_eq!(
        isoc::ir::semantics::enclose_powi(iv(-1.0, 1.0), -2),
        (iv(1.0, f64::INFINITY), false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_powi(iv(2.0, 4.0), -1),
        (iv(0.25, 0.5), true)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_powi(iv(-1.0, 1.0), -1),
        (Interval::ENTIRE, false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_powi(iv(0.0, 0.0), -1).0,
        Interval::EMPTY
    );
    assert_eq!(
        isoc::ir::semantics::point_powi(0.0, -1).to_bits(),
        f64::NAN.to_bits()
    );
    // a^0 = 1 everywhere, even on the empty set (point value 1 for NaN).
    assert_eq!(
        isoc::ir::semantics::enclose_powi(Interval::EMPTY, 0).0,
        Interval::point(1.0)
    );
    assert_eq!(isoc::ir::semantics::point_powi(f64::NAN, 0), 1.0);
}

#[test]
fn sqrt_and_log_domains() {
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Sqrt, iv(-4.0, -1.0)),
        (Interval::EMPTY, false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Sqrt, iv(-4.0, 4.0)),
        (iv(0.0, 2.0), false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Sqrt, iv(0.0, 4.0)),
        (iv(0.0, 2.0), true)
    );
    let (r, d) = isoc::ir::semantics::enclose_unary(UnOp::Log, iv(0.0, 1.0));
    assert_eq!(r, iv(f64::NEG_INFINITY, 0.0));
    assert!(!d);
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Log, iv(-2.0, 0.0)),
        (Interval::EMPTY, false)
    );
    assert!(isoc::ir::semantics::point_unary(UnOp::Log, 0.0).is_nan());
    assert!(isoc::ir::semantics::point_unary(UnOp::Sqrt, -1e-300).is_nan());
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Exp, iv(0.0, 0.0)),
        (iv(1.0, 1.0), true)
    );
}

#[test]
fn division_by_intervals_containing_zero() {
    let e = Interval::ENTIRE;
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Div, iv(1.0, 2.0), iv(-1.0, 1.0)),
        (e, false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Div, iv(1.0, 2.0), iv(0.0, 4.0)),
        (iv(0.25, f64::INFINITY), false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Div, iv(1.0, 2.0), iv(-4.0, 0.0)),
        (iv(f64::NEG_INFINITY, -0.25), false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Div, iv(-2.0, -1.0), iv(0.0, 4.0)),
        (iv(f64::NEG_INFINITY, -0.25), false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Div, iv(0.0, 0.0), iv(0.0, 0.0)),
        (Interval::EMPTY, false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Div, iv(1.0, 2.0), iv(0.0, 0.0)),
        (Interval::EMPTY, false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Div, iv(0.0, 0.0), iv(-1.0, 1.0)),
        (iv(0.0, 0.0), false)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Div, iv(1.0, 2.0), iv(2.0, 4.0)),
        (iv(0.25, 1.0), true)
    );
    assert!(isoc::ir::semantics::point_binary(BinOp::Div, 1.0, 0.0).is_nan());
    assert!(isoc::ir::semantics::point_binary(BinOp::Div, 1.0, -0.0).is_nan());
}

#[test]
fn decimal_sum_encloses_the_real_sum() {
    // [0.1] and [0.2] enclose the reals 0.1 and 0.2; their sum must enclose
    // the real 0.3, which lies strictly between the f64 0.3 and its successor.
    let enc = |v: f64| iv(v.next_down(), v.next_up());
    let (r, _) = isoc::ir::semantics::enclose_binary(BinOp::Add, enc(0.1), enc(0.2));
    assert!(r.lo <= 0.3 && 0.3f64.next_up() <= r.hi, "{r:?}");
    assert!(r.contains(0.1 + 0.2));
    // Degenerate floats: 0.1f64 + 0.2f64 is inexact, the interval brackets it.
    let (r, _) =
        isoc::ir::semantics::enclose_binary(BinOp::Add, Interval::point(0.1), Interval::point(0.2));
    assert!(r.lo < r.hi && r.contains(0.1 + 0.2));
    let e = Dyadic::of(0.1).add(Dyadic::of(0.2)).unwrap();
    assert!(e.within(r.lo, r.hi));
}

#[test]
fn sin_range_reduction() {
    let s = |lo: f64, hi: f64| isoc::ir::semantics::enclose_unary(UnOp::Sin, iv(lo, hi)).0;
    let c = |lo: f64, hi: f64| isoc::ir::semantics::enclose_unary(UnOp::Cos, iv(lo, hi)).0;
    // Around π/2: the maximum 1 must be included.
    assert_eq!(s(1.5, 1.6).hi, 1.0);
    assert_eq!(s(FRAC_PI_2, FRAC_PI_2.next_up()).hi, 1.0);
    // f64 π/2 is just below the real π/2: the max may not be excluded by
    // accident; [1.0, π/2 f64] can't contain it, but bounds must still
    // enclose sin(π/2 f64), which rounds to 1.
    let r = s(1.0, FRAC_PI_2);
    assert!(r.contains(core_math::sin(FRAC_PI_2)) && r.hi == 1.0);
    // Monotone piece: no extremum.
    let r = s(0.1, 1.0);
    assert!(
        r.lo < 0.1f64.sin() && r.hi > 1.0f64.sin() && r.hi < 0.85,
        "{r:?}"
    );
    // Huge arguments and wide intervals: the full range.
    assert_eq!(s(1e300, 1e300 + 1e285), iv(-1.0, 1.0));
    assert_eq!(s(1e300, 1e300), iv(-1.0, 1.0));
    assert_eq!(s(0.0, 7.0), iv(-1.0, 1.0));
    assert_eq!(s(f64::NEG_INFINITY, 0.0), iv(-1.0, 1.0));
    // Degenerate boxes contain the correctly rounded value, also at large x.
    for x in [1e5, 1e10, 1e15, 3.0, -2.5, 1e-300] {
        assert!(s(x, x).contains(core_math::sin(x)), "{x}");
        assert!(c(x, x).contains(core_math::cos(x)), "{x}");
    }
    // Cosine: max at 0, min at π.
    assert_eq!(c(-0.1, 0.1).hi, 1.0);
    assert_eq!(c(3.0, 3.2).lo, -1.0);
    assert_eq!(c(0.0, 0.0), iv(1.0, 1.0));
    assert_eq!(s(0.0, 0.0), iv(0.0, 0.0));
    // Near a minimum of sin (3π/2) at moderately large k.
    let k = 1_000_000.0;
    let x = (2.0 * k + 1.5) * PI;
    assert_eq!(s(x - 0.01, x + 0.01).lo, -1.0);
}

#[test]
fn tan_poles() {
    let t = |lo: f64, hi: f64| isoc::ir::semantics::enclose_unary(UnOp::Tan, iv(lo, hi));
    assert_eq!(t(1.5, 1.6), (Interval::ENTIRE, false));
    assert_eq!(t(FRAC_PI_2, FRAC_PI_2), (Interval::ENTIRE, false));
    let (r, d) = t(-1.0, 1.0);
    assert!(d && r.lo < -1.55 && r.hi > 1.55 && r.hi < 1.56);
    assert_eq!(t(0.0, 0.0), (iv(0.0, 0.0), true));
    assert_eq!(t(0.0, f64::INFINITY), (Interval::ENTIRE, false));
}

#[test]
fn atan2_branch_cut_and_origin() {
    let a = |y: Interval, x: Interval| isoc::ir::semantics::enclose_binary(BinOp::Atan2, y, x);
    let full = iv(-PI_HI, PI_HI);
    // Crossing the negative x axis: the full range, not continuous.
    assert_eq!(a(iv(-1.0, 1.0), iv(-2.0, -1.0)), (full, false));
    assert_eq!(a(iv(0.0, 0.0), iv(-2.0, -1.0)), (full, false));
    // The box touches the origin: not defined there.
    let (r, d) = a(iv(-1.0, 1.0), iv(0.0, 1.0));
    assert!(!d && r.lo >= -HALF_PI_HI && r.hi <= HALF_PI_HI);
    assert_eq!(a(iv(0.0, 0.0), iv(0.0, 0.0)), (Interval::EMPTY, false));
    assert!(isoc::ir::semantics::point_binary(BinOp::Atan2, 0.0, 0.0).is_nan());
    // Right half-plane, straddling y = 0: continuous.
    let (r, d) = a(iv(-1.0, 1.0), iv(1.0, 2.0));
    assert!(
        d && r.lo < -0.785 && r.lo > -0.786 && r.hi > 0.785 && r.hi < 0.786,
        "{r:?}"
    );
    // Upper half-plane over negative x: up to π but not beyond.
    let (r, d) = a(iv(1.0, 2.0), iv(-1e300, -1.0));
    assert!(d && r.hi >= PI && r.hi <= PI_HI && r.lo < 2.1, "{r:?}");
    // Point values on both sides of the cut are in the full range.
    assert!(full.contains(isoc::ir::semantics::point_binary(BinOp::Atan2, 0.0, -1.0)));
    assert!(full.contains(isoc::ir::semantics::point_binary(BinOp::Atan2, -0.0, -1.0)));
}

#[test]
fn asin_acos_clamp_to_domain() {
    let (r, d) = isoc::ir::semantics::enclose_unary(UnOp::Asin, iv(-2.0, 2.0));
    assert!(!d && r.lo >= -HALF_PI_HI && r.hi <= HALF_PI_HI && r.hi >= FRAC_PI_2);
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Asin, iv(1.5, 2.0)),
        (Interval::EMPTY, false)
    );
    let (r, d) = isoc::ir::semantics::enclose_unary(UnOp::Acos, iv(-1.0, 1.0));
    assert!(d && r.lo == 0.0 && r.hi >= PI && r.hi <= PI_HI);
}

#[test]
fn pow_is_defined_for_positive_bases_only() {
    let (r, d) = isoc::ir::semantics::enclose_binary(BinOp::Pow, iv(2.0, 4.0), iv(0.5, 0.5));
    assert!(d && r.lo <= 2f64.sqrt() && r.hi >= 2.0 && r.hi < 2.001);
    let (r, d) = isoc::ir::semantics::enclose_binary(BinOp::Pow, iv(-1.0, 4.0), iv(2.0, 2.0));
    assert!(!d && r.lo <= 0.0 && r.hi >= 16.0);
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Pow, iv(-4.0, 0.0), iv(2.0, 2.0)),
        (Interval::EMPTY, false)
    );
    assert!(isoc::ir::semantics::point_binary(BinOp::Pow, -8.0, 1.0 / 3.0).is_nan());
    // Reaching the domain edge from a signed zero: a^-3 → +∞ as a → 0⁺.
    let (r, d) = isoc::ir::semantics::enclose_binary(BinOp::Pow, iv(-0.0, 2.0), iv(-3.0, -3.0));
    assert!(!d && r.hi == f64::INFINITY && r.lo <= 0.125, "{r:?}");
    let (r, _) = isoc::ir::semantics::enclose_binary(BinOp::Pow, iv(0.0, 2.0), iv(-1.0, 2.0));
    assert_eq!(r, iv(0.0, f64::INFINITY));
    // Exact corners stay tight.
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Pow, iv(1.0, 1.0), iv(-5.0, 7.0)),
        (iv(1.0, 1.0), true)
    );
    assert!(isoc::ir::semantics::point_binary(BinOp::Pow, 0.0, 2.0).is_nan());
}

#[test]
fn nan_and_infinite_inputs() {
    let nan = iv(f64::NAN, 1.0);
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Neg, nan),
        (Interval::ENTIRE, false)
    );
    let (r, d) = isoc::ir::semantics::enclose_binary(BinOp::Add, nan, iv(1.0, 1.0));
    assert!(!d && r == Interval::ENTIRE);
    let (r, d) = isoc::ir::semantics::enclose_unary(UnOp::Exp, iv(f64::NEG_INFINITY, 0.0));
    assert!(d && r == iv(0.0, 1.0));
    let (r, _) = isoc::ir::semantics::enclose_binary(BinOp::Mul, iv(0.0, 0.0), Interval::ENTIRE);
    assert_eq!(r, iv(0.0, 0.0));
    // [+∞, +∞] is read as the ray [MAX, +∞].
    let (r, _) = isoc::ir::semantics::enclose_unary(UnOp::Atan, iv(f64::INFINITY, f64::INFINITY));
    assert!(r.contains(core_math::atan(f64::INFINITY)));
    assert!(encloses(r, f64::NAN));
}

#[test]
fn min_max_abs_neg() {
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Min, iv(-1.0, 3.0), iv(0.0, 2.0)),
        (iv(-1.0, 2.0), true)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_binary(BinOp::Max, iv(-1.0, 3.0), iv(0.0, 2.0)),
        (iv(0.0, 3.0), true)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Abs, iv(-3.0, 2.0)),
        (iv(0.0, 3.0), true)
    );
    assert_eq!(
        isoc::ir::semantics::enclose_unary(UnOp::Neg, iv(-3.0, 2.0)),
        (iv(-2.0, 3.0), true)
    );
    assert!(isoc::ir::semantics::point_binary(BinOp::Min, f64::NAN, 1.0).is_nan());
}
