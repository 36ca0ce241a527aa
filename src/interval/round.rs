//! Outward rounding of single floating-point operations.
//!
//! Every function here returns a float that is a guaranteed lower (`*_down`)
//! or upper (`*_up`) bound of the *exact* real result of one operation on
//! f64 operands, computed in the default round-to-nearest mode (no MXCSR
//! games).
//!
//! # Strategy
//!
//! The operation is computed in round-to-nearest, giving `r`. Then:
//!
//! * if the result is *provably exact* it is returned unchanged;
//! * if an error-free transformation tells the sign of the rounding error
//!   `exact − r`, only the bound on the wrong side is moved one ulp
//!   (`f64::next_down` / `f64::next_up`), so the bounds are as tight as
//!   hardware directed rounding would give;
//! * otherwise (overflow, underflow region, where the error-free
//!   transformations stop being exact) `r` is stepped one ulp outward, which
//!   is always sound because round-to-nearest is off by at most half an ulp.
//!
//! The error-free transformations are the classical ones (Knuth's TwoSum for
//! sums; `fma(a, b, −p)` for the error of a product, Dekker / Ogita, Rump &
//! Oishi 2005; `fma(−q, b, a)` for the remainder of a division and
//! `fma(−s, s, x)` for the residual of a square root, Boldo & Daumas 2003).
//! The FMA-based ones are exact only when no underflow occurs, hence the
//! [`SAFE`] threshold: below it products and square roots are computed
//! exactly by scaling (powers of two), quotients stepped outward.
//!
//! Infinite operands are bounds of unbounded intervals; a result that is
//! infinite because an operand is infinite is "exact" (the limit), while an
//! infinite result from finite operands is an overflow (the lower bound of
//! `+∞` becomes `f64::MAX`). A product with a zero factor is exactly zero,
//! even against an infinite bound (the zero is an actual member of its
//! interval). Callers never pass `∞ − ∞`, `0/0` or `∞/∞`: the interval
//! operations in [`super::arith`] are arranged so that these cannot occur.

/// Magnitude above which the FMA-based error terms are exact (well above
/// `2^-969`, where the product/remainder error could underflow).
pub(crate) const SAFE: f64 = 1.0e-270;

/// Rounding direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dir {
    /// Toward `-∞` (for lower bounds).
    Down,
    /// Toward `+∞` (for upper bounds).
    Up,
}

/// Moves `r` one ulp in direction `d` (an always-sound bound when `r` is a
/// round-to-nearest or correctly rounded result).
#[inline]
pub fn step(r: f64, d: Dir) -> f64 {
    match d {
        Dir::Down => r.next_down(),
        Dir::Up => r.next_up(),
    }
}

/// [`step`] for a product or quotient of two non-zero operands, whose exact
/// value has the sign `negative` and is not zero: the bound never crosses
/// zero (so `x·y` with `x, y > 0` keeps a non-negative lower bound even
/// when it underflows).
#[inline]
fn step_signed(r: f64, d: Dir, negative: bool) -> f64 {
    let s = step(r, d);
    if negative { s.min(0.0) } else { s.max(0.0) }
}

/// Given `r = RN(exact)` and the sign of `exact − r` (`err`; NaN when
/// unknown), the bound in direction `d`.
#[inline]
fn settle(r: f64, err: f64, d: Dir) -> f64 {
    if err == 0.0 {
        r
    } else if err.is_nan() {
        step(r, d)
    } else if (err > 0.0) == (d == Dir::Up) {
        // The exact value lies beyond r in direction d.
        step(r, d)
    } else {
        r
    }
}

/// Bound of `a + b`.
#[inline]
pub fn add(a: f64, b: f64, d: Dir) -> f64 {
    let s = a + b;
    if s.is_infinite() {
        return if a.is_infinite() || b.is_infinite() {
            s
        } else {
            step(s, d)
        };
    }
    // Knuth's TwoSum: e = (a + b) − s exactly, barring overflow.
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    if e.is_finite() {
        settle(s, e, d)
    } else {
        step(s, d)
    }
}

/// Bound of `a − b`.
#[inline]
pub fn sub(a: f64, b: f64, d: Dir) -> f64 {
    add(a, -b, d)
}

/// Bound of `a · b`, with `0 · x = 0` for every `x` (including `±∞`).
#[inline]
pub fn mul(a: f64, b: f64, d: Dir) -> f64 {
    if a == 0.0 || b == 0.0 {
        return 0.0;
    }
    let p = a * b;
    if p.is_infinite() {
        return if a.is_infinite() || b.is_infinite() {
            p
        } else {
            step(p, d)
        };
    }
    if p.abs() < SAFE {
        return mul_tiny(a, b, d);
    }
    settle(p, a.mul_add(b, -p), d)
}

/// `x = m·2^e` with `1 ≤ |m| < 2` (finite, non-zero `x`), exactly.
fn split(x: f64) -> (f64, i32) {
    let (x, bias) = if x.abs() < f64::MIN_POSITIVE {
        (x * pow2(64), 64)
    } else {
        (x, 0)
    };
    let bits = x.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let m = f64::from_bits((bits & !(0x7ff << 52)) | (1023 << 52));
    (m, e - bias)
}

/// `2^k` for `−1074 ≤ k ≤ 1023` (subnormal powers included).
fn pow2(k: i32) -> f64 {
    if k >= -1022 {
        f64::from_bits(((k + 1023) as u64) << 52)
    } else {
        f64::from_bits(1 << (k + 1074))
    }
}

/// `x·2^k` for `k ≥ 0`, exact while no overflow (powers of two at most
/// `2^1000` a step, each product exact since the result only grows).
fn scale_up(mut x: f64, mut k: i32) -> f64 {
    while k > 1000 {
        x *= pow2(1000);
        k -= 1000;
    }
    x * pow2(k)
}

/// Bound of `a·b` (finite, non-zero factors) whose round-to-nearest value
/// is below [`SAFE`] in magnitude, where `fma(a, b, −p)` may underflow:
/// exact by scaling. With `a = m_a·2^e_a`, `b = m_b·2^e_b`, the exact
/// product is `(q + e)·2^E` for `q = RN(m_a·m_b)`, `e = fma(m_a, m_b, −q)`
/// (both exact: `|q| ∈ [1, 4)`), `E = e_a + e_b`. The candidate `c =
/// RN(q·2^E)` is computed with one rounding (`q·2^-1000` is exact and
/// normal); `c'= c·2^-E` is exact, and by Sterbenz `δ = c' − q` too (`c'`
/// lies within a factor 2 of `q`, or `c = 0`), so the sign of `δ − e` is
/// the sign of `c − a·b`. Then `c` is moved one step if it is on the wrong
/// side — the correctly rounded directed bound.
fn mul_tiny(a: f64, b: f64, d: Dir) -> f64 {
    let negative = (a < 0.0) != (b < 0.0);
    let (ma, ea) = split(a);
    let (mb, eb) = split(b);
    let q = ma * mb;
    let e = ma.mul_add(mb, -q);
    let big_e = ea + eb;
    // |a·b| < 2^(E+2) ≤ 2^-1075 rounds to 0 (or the smallest subnormal).
    let c = if big_e + 2 <= -1075 {
        0.0
    } else if big_e >= -1022 {
        q * pow2(big_e)
    } else {
        (q * pow2(-1000)) * pow2(big_e + 1000)
    };
    if c == 0.0 {
        // |a·b| ≤ 2^-1075 and non-zero: between 0 and the smallest
        // subnormal of its sign.
        let tiny = if negative { -pow2(-1074) } else { pow2(-1074) };
        return match (d, negative) {
            (Dir::Up, false) | (Dir::Down, true) => tiny,
            _ => 0.0,
        };
    }
    let delta = scale_up(c, -big_e) - q;
    let s = delta - e;
    if s == 0.0 {
        return c;
    }
    // s > 0: c is above the exact product.
    match d {
        Dir::Up if s < 0.0 => c.next_up(),
        Dir::Down if s > 0.0 => c.next_down(),
        _ => c,
    }
}

/// Bound of `a / b` for `b ≠ 0` (callers exclude zero divisors and `∞/∞`).
pub fn div(a: f64, b: f64, d: Dir) -> f64 {
    if a == 0.0 {
        return 0.0;
    }
    let q = a / b;
    if a.is_infinite() || b.is_infinite() {
        // ∞/finite = ±∞ and finite/∞ = ±0 are exact limits.
        return q;
    }
    if q.is_infinite() || q.abs() < SAFE || a.abs() < SAFE {
        return step_signed(q, d, (a < 0.0) != (b < 0.0));
    }
    // a/b − q = r/b with r = a − q·b exact.
    let r = (-q).mul_add(b, a);
    let err = if r == 0.0 {
        0.0
    } else if (r > 0.0) == (b > 0.0) {
        1.0
    } else {
        -1.0
    };
    if r.is_nan() {
        return step(q, d);
    }
    settle(q, err, d)
}

/// Bound of `√x` for `x ≥ 0`.
pub fn sqrt(x: f64, d: Dir) -> f64 {
    let s = x.sqrt();
    if x == 0.0 || x.is_infinite() {
        return s;
    }
    if x < SAFE {
        // √x = √(x·2^600)·2^-300, both scalings exact (x·2^600 is normal
        // and well above SAFE, the root of a float ≥ 2^-1074 is normal).
        return sqrt(x * pow2(600), d) * pow2(-300);
    }
    // x − s² exactly; positive means √x > s.
    settle(s, (-s).mul_add(s, x), d)
}

/// Bound of a correctly rounded function value `r = RN(f(x))`: one ulp
/// outward unless the caller knows the value is exact.
pub(crate) fn cr(r: f64, exact: bool, d: Dir) -> f64 {
    // An infinite result is a valid bound on its own side (overflow or an
    // exact infinite limit); on the other side it steps to ±f64::MAX.
    let keep =
        exact || (r == f64::INFINITY && d == Dir::Up) || (r == f64::NEG_INFINITY && d == Dir::Down);
    if keep { r } else { step(r, d) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_results_stay_tight() {
        assert_eq!(add(1.0, 2.0, Dir::Down), 3.0);
        assert_eq!(add(1.0, 2.0, Dir::Up), 3.0);
        assert_eq!(mul(2.0, 2.0, Dir::Up), 4.0);
        assert_eq!(div(1.0, 4.0, Dir::Down), 0.25);
        assert_eq!(sqrt(4.0, Dir::Up), 2.0);
    }

    #[test]
    fn inexact_results_bracket() {
        let lo = add(0.1, 0.2, Dir::Down);
        let hi = add(0.1, 0.2, Dir::Up);
        assert!(lo < hi);
        assert_eq!(hi, lo.next_up());
        let lo = div(1.0, 3.0, Dir::Down);
        let hi = div(1.0, 3.0, Dir::Up);
        assert_eq!(hi, lo.next_up());
        assert!(lo * 3.0 <= 1.0);
        let lo = sqrt(2.0, Dir::Down);
        let hi = sqrt(2.0, Dir::Up);
        assert_eq!(hi, lo.next_up());
        assert!(lo * lo < 2.0 && hi * hi > 2.0);
    }

    #[test]
    fn overflow_and_zero() {
        assert_eq!(mul(1e300, 1e300, Dir::Down), f64::MAX);
        assert_eq!(mul(1e300, 1e300, Dir::Up), f64::INFINITY);
        assert_eq!(mul(0.0, f64::INFINITY, Dir::Up), 0.0);
        assert_eq!(add(f64::MAX, f64::MAX, Dir::Down), f64::MAX);
        // Underflow: bracketed, without crossing zero, as tight as
        // directed rounding.
        assert_eq!(mul(1e-200, 1e-200, Dir::Down), 0.0);
        assert_eq!(mul(1e-200, 1e-200, Dir::Up), f64::from_bits(1));
        assert_eq!(mul(-1e-200, 1e-200, Dir::Down), -f64::from_bits(1));
        assert_eq!(mul(-1e-200, 1e-200, Dir::Up), 0.0);
        assert_eq!(mul(f64::from_bits(1), 0.5, Dir::Up), f64::from_bits(1));
        assert_eq!(mul(f64::from_bits(1), 0.5, Dir::Down), 0.0);
        assert_eq!(mul(f64::from_bits(3), 0.5, Dir::Down), f64::from_bits(1));
        assert_eq!(mul(f64::from_bits(3), 0.5, Dir::Up), f64::from_bits(2));
        assert_eq!(mul(f64::from_bits(4), 0.5, Dir::Down), f64::from_bits(2));
        assert_eq!(mul(f64::from_bits(4), 0.5, Dir::Up), f64::from_bits(2));
        assert_eq!(div(-5e-324, 3.0, Dir::Up), 0.0);
        assert!(div(-5e-324, 3.0, Dir::Down) < 0.0);
    }
}
