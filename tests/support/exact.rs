//! Exact dyadic arithmetic for checking outward rounding: a finite f64 is
//! `m·2^e` with an integer `m`; sums (when the exponents are close) and
//! products of two floats are exact in `i128`, so "the exact real result
//! lies in `[lo, hi]`" can be decided without any rounding.

use std::cmp::Ordering;

/// `m · 2^e`, exactly.
#[derive(Clone, Copy, Debug)]
pub struct Dyadic {
    pub m: i128,
    pub e: i32,
}

impl Dyadic {
    /// The exact value of a finite float.
    pub fn of(x: f64) -> Dyadic {
        assert!(x.is_finite());
        if x == 0.0 {
            return Dyadic { m: 0, e: 0 };
        }
        let bits = x.to_bits();
        let exp = ((bits >> 52) & 0x7ff) as i32;
        let frac = (bits & ((1u64 << 52) - 1)) as i128;
        let (m, e) = if exp == 0 {
            (frac, -1074)
        } else {
            (frac | (1 << 52), exp - 1075)
        };
        Dyadic {
            m: if x < 0.0 { -m } else { m },
            e,
        }
    }

    /// Exact product (53 × 53 bits fit in an i128).
    pub fn mul(self, o: Dyadic) -> Dyadic {
        Dyadic {
            m: self.m * o.m,
            e: self.e + o.e,
        }
    }

    /// Exact sum, when the exponents are within 60 of each other and the
    /// mantissas small enough (`None` otherwise).
    pub fn add(self, o: Dyadic) -> Option<Dyadic> {
        if self.m == 0 {
            return Some(o);
        }
        if o.m == 0 {
            return Some(self);
        }
        let (hi, lo) = if self.e >= o.e { (self, o) } else { (o, self) };
        let shift = (hi.e - lo.e) as u32;
        if shift > 60 || hi.m.unsigned_abs() >= 1u128 << 66 || lo.m.unsigned_abs() >= 1u128 << 126 {
            return None;
        }
        Some(Dyadic {
            m: (hi.m << shift) + lo.m,
            e: lo.e,
        })
    }

    fn bitlen(m: i128) -> i32 {
        128 - m.unsigned_abs().leading_zeros() as i32
    }

    /// Exact comparison.
    pub fn cmp(self, o: Dyadic) -> Ordering {
        let (sa, sb) = (self.m.signum(), o.m.signum());
        if sa != sb || sa == 0 {
            return sa.cmp(&sb);
        }
        // Same sign, both non-zero: compare magnitudes.
        let (la, lb) = (Self::bitlen(self.m) + self.e, Self::bitlen(o.m) + o.e);
        let mag = if la != lb {
            la.cmp(&lb)
        } else {
            let (a, b) = (self.m.unsigned_abs(), o.m.unsigned_abs());
            if self.e >= o.e {
                (a << (self.e - o.e) as u32).cmp(&b)
            } else {
                a.cmp(&(b << (o.e - self.e) as u32))
            }
        };
        if sa > 0 { mag } else { mag.reverse() }
    }

    /// `lo ≤ self ≤ hi` for float bounds (infinite bounds allowed).
    pub fn within(self, lo: f64, hi: f64) -> bool {
        let above = lo == f64::NEG_INFINITY
            || (lo.is_finite() && Dyadic::of(lo).cmp(self) != Ordering::Greater);
        let below = hi == f64::INFINITY
            || (hi.is_finite() && self.cmp(Dyadic::of(hi)) != Ordering::Greater);
        above && below
    }
}
