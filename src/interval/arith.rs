//! Algebraic interval operations: `+ − × /`, `min`, `max`, `neg`, `abs`,
//! `sqrt`, `square`, integer powers.
//!
//! Inputs are normalised intervals (see [`super::Interval::normalize`]):
//! `lo < +∞`, `hi > -∞`, or empty. Every function returns an enclosure of
//! the exact range with bounds from [`super::round`]; those returning a
//! `bool` also report whether the operation is defined on the whole input.

use super::Interval;
use super::round::{self, Dir};

/// `[-hi, -lo]` (exact).
#[inline]
pub fn neg(a: Interval) -> Interval {
    if a.is_empty() {
        return Interval::EMPTY;
    }
    Interval::new(-a.hi, -a.lo)
}

/// `{|x| : x ∈ a}` (exact).
pub fn abs(a: Interval) -> Interval {
    if a.is_empty() {
        Interval::EMPTY
    } else if a.lo >= 0.0 {
        a
    } else if a.hi <= 0.0 {
        neg(a)
    } else {
        Interval::new(0.0, (-a.lo).max(a.hi))
    }
}

/// `[0, 0]` (either sign of zero).
#[inline]
fn is_zero(a: Interval) -> bool {
    a.lo == 0.0 && a.hi == 0.0
}

/// `a + b`.
#[inline]
pub fn add(a: Interval, b: Interval) -> Interval {
    if a.is_empty() || b.is_empty() {
        return Interval::EMPTY;
    }
    // A zero operand (derivatives are often exactly zero): the sums are
    // exact, and these are the very floats the rounded sums give.
    if is_zero(a) || is_zero(b) {
        return Interval::new(a.lo + b.lo, a.hi + b.hi);
    }
    Interval::new(
        round::add(a.lo, b.lo, Dir::Down),
        round::add(a.hi, b.hi, Dir::Up),
    )
}

/// `a − b`.
#[inline]
pub fn sub(a: Interval, b: Interval) -> Interval {
    add(a, neg(b))
}

/// `a · b`: the hull of the four bound products, with `0 · ∞ = 0` (a zero
/// bound is a real member of its interval, an infinite one is not).
///
/// The signs of the operands say which products are extremal (the
/// classical nine cases), so only those are rounded: directed rounding is
/// monotone, so the bound of the extremal product is the extremum of the
/// rounded bounds of all four — the same interval as rounding all four.
#[inline]
pub fn mul(a: Interval, b: Interval) -> Interval {
    if a.is_empty() || b.is_empty() {
        return Interval::EMPTY;
    }
    // A zero factor gives exactly zero (`0 · ∞ = 0`), a unit factor the
    // other operand (zeros as `+0`, as the rounded products give them):
    // the common cases of derivatives, short-cut.
    if is_zero(a) || is_zero(b) {
        return Interval::point(0.0);
    }
    let plus = |x: f64| if x == 0.0 { 0.0 } else { x };
    if a.lo == 1.0 && a.hi == 1.0 {
        return Interval::new(plus(b.lo), plus(b.hi));
    }
    if b.lo == 1.0 && b.hi == 1.0 {
        return Interval::new(plus(a.lo), plus(a.hi));
    }
    let d = |x: f64, y: f64| round::mul(x, y, Dir::Down);
    let u = |x: f64, y: f64| round::mul(x, y, Dir::Up);
    // P: non-negative, N: non-positive (and not P), M: straddles 0.
    #[derive(Clone, Copy)]
    enum S {
        P,
        N,
        M,
    }
    let sign = |i: Interval| {
        if i.lo >= 0.0 {
            S::P
        } else if i.hi <= 0.0 {
            S::N
        } else {
            S::M
        }
    };
    let (lo, hi) = match (sign(a), sign(b)) {
        (S::P, S::P) => (d(a.lo, b.lo), u(a.hi, b.hi)),
        (S::P, S::N) => (d(a.hi, b.lo), u(a.lo, b.hi)),
        (S::P, S::M) => (d(a.hi, b.lo), u(a.hi, b.hi)),
        (S::N, S::P) => (d(a.lo, b.hi), u(a.hi, b.lo)),
        (S::N, S::N) => (d(a.hi, b.hi), u(a.lo, b.lo)),
        (S::N, S::M) => (d(a.lo, b.hi), u(a.lo, b.lo)),
        (S::M, S::P) => (d(a.lo, b.hi), u(a.hi, b.hi)),
        (S::M, S::N) => (d(a.hi, b.lo), u(a.lo, b.lo)),
        (S::M, S::M) => (
            d(a.lo, b.hi).min(d(a.hi, b.lo)),
            u(a.lo, b.lo).max(u(a.hi, b.hi)),
        ),
    };
    Interval::new(lo, hi)
}

/// `a / b` over the part of `b` that is not zero; `defined` is false when
/// `0 ∈ b`. A divisor straddling zero gives the entire line (the hull of
/// two half-lines) unless `a = [0, 0]`; a divisor with a zero bound gives a
/// half-line; `b = [0, 0]` gives the empty set.
pub fn div(a: Interval, b: Interval) -> (Interval, bool) {
    if a.is_empty() || b.is_empty() {
        return (Interval::EMPTY, false);
    }
    let d = |x: f64, y: f64| round::div(x, y, Dir::Down);
    let u = |x: f64, y: f64| round::div(x, y, Dir::Up);
    let zero_a = a.lo == 0.0 && a.hi == 0.0;
    if b.lo > 0.0 {
        let r = if a.lo >= 0.0 {
            Interval::new(d(a.lo, b.hi), u(a.hi, b.lo))
        } else if a.hi <= 0.0 {
            Interval::new(d(a.lo, b.lo), u(a.hi, b.hi))
        } else {
            Interval::new(d(a.lo, b.lo), u(a.hi, b.lo))
        };
        return (r, true);
    }
    if b.hi < 0.0 {
        let r = if a.lo >= 0.0 {
            Interval::new(d(a.hi, b.hi), u(a.lo, b.lo))
        } else if a.hi <= 0.0 {
            Interval::new(d(a.hi, b.lo), u(a.lo, b.hi))
        } else {
            Interval::new(d(a.hi, b.hi), u(a.lo, b.hi))
        };
        return (r, true);
    }
    // 0 ∈ b from here on.
    let r = if b.lo == 0.0 && b.hi == 0.0 {
        Interval::EMPTY
    } else if zero_a {
        Interval::point(0.0)
    } else if b.lo < 0.0 && b.hi > 0.0 {
        Interval::ENTIRE
    } else if b.lo == 0.0 {
        // Divisor in (0, b.hi].
        if a.lo >= 0.0 {
            Interval::new(d(a.lo, b.hi), f64::INFINITY)
        } else if a.hi <= 0.0 {
            Interval::new(f64::NEG_INFINITY, u(a.hi, b.hi))
        } else {
            Interval::ENTIRE
        }
    } else {
        // Divisor in [b.lo, 0).
        if a.lo >= 0.0 {
            Interval::new(f64::NEG_INFINITY, u(a.lo, b.lo))
        } else if a.hi <= 0.0 {
            Interval::new(d(a.hi, b.lo), f64::INFINITY)
        } else {
            Interval::ENTIRE
        }
    };
    (r, false)
}

/// `min(a, b)` (exact).
#[inline]
pub fn min(a: Interval, b: Interval) -> Interval {
    if a.is_empty() || b.is_empty() {
        return Interval::EMPTY;
    }
    Interval::new(a.lo.min(b.lo), a.hi.min(b.hi))
}

/// `max(a, b)` (exact).
#[inline]
pub fn max(a: Interval, b: Interval) -> Interval {
    if a.is_empty() || b.is_empty() {
        return Interval::EMPTY;
    }
    Interval::new(a.lo.max(b.lo), a.hi.max(b.hi))
}

/// `√a` over `a ∩ [0, ∞)`; `defined` is false when `a` has negative
/// members (`sqrt([-4, -1])` is empty).
pub fn sqrt(a: Interval) -> (Interval, bool) {
    if a.is_empty() || a.hi < 0.0 {
        return (Interval::EMPTY, false);
    }
    let lo = a.lo.max(0.0);
    let r = Interval::new(
        round::sqrt(lo, Dir::Down).max(0.0),
        round::sqrt(a.hi, Dir::Up),
    );
    (r, a.lo >= 0.0)
}

/// `a²` (even-power rule: `[-1, 2]² = [0, 4]`).
pub fn square(a: Interval) -> Interval {
    powi(a, 2).0
}

/// The point evaluator's repeated-squaring chain for `x^n`, `n ≥ 1`, run in
/// interval arithmetic on `[x, x]`: encloses both the real `x^n` and the
/// float chain of [`crate::eval::point::powi`] (same operations, each
/// outward rounded). Right-to-left binary method: the accumulator takes the
/// current base when a bit of `n` is set; the base is squared per bit.
fn chain(x: f64, n: u64) -> Interval {
    let mut acc: Option<Interval> = None;
    let mut base = Interval::point(x);
    let mut e = n;
    loop {
        if e & 1 == 1 {
            acc = Some(match acc {
                None => base,
                Some(r) => mul(r, base),
            });
        }
        e >>= 1;
        if e == 0 {
            break;
        }
        base = mul(base, base);
    }
    acc.unwrap_or(Interval::point(1.0))
}

/// `a^n` for a non-negative exponent: monotone rules on the bounds.
fn powi_pos(a: Interval, n: u64) -> Interval {
    if a.is_empty() {
        return Interval::EMPTY;
    }
    if n == 0 {
        return Interval::point(1.0);
    }
    let even = n.is_multiple_of(2);
    if !even {
        // Odd powers are increasing.
        return Interval::new(chain(a.lo, n).lo, chain(a.hi, n).hi);
    }
    let r = if a.lo >= 0.0 {
        Interval::new(chain(a.lo, n).lo, chain(a.hi, n).hi)
    } else if a.hi <= 0.0 {
        Interval::new(chain(a.hi, n).lo, chain(a.lo, n).hi)
    } else {
        Interval::new(0.0, chain(a.lo, n).hi.max(chain(a.hi, n).hi))
    };
    // Even powers are non-negative even where the chain underflowed.
    Interval::new(r.lo.max(0.0), r.hi)
}

/// `a^n` for any integer `n`; `n < 0` is `1 / a^|n|` (not defined at 0).
pub fn powi(a: Interval, n: i64) -> (Interval, bool) {
    if a.is_empty() {
        return (Interval::EMPTY, false);
    }
    let p = powi_pos(a, n.unsigned_abs());
    if n >= 0 {
        (p, true)
    } else {
        div(Interval::point(1.0), p)
    }
}
