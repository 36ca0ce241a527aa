//! Decimal literals and named constants as [`Const`]s with exact enclosures.
//!
//! A literal such as `0.1` denotes a real number that no f64 equals. Its
//! point value is the correctly rounded f64 (Rust's `str::parse`), and its
//! enclosure is the tightest f64 interval containing the real number: the
//! single point when the literal is exactly representable (`2`, `0.5`,
//! `1e3`), else the one-ulp interval between the f64 and its neighbour on
//! the side of the real number. Exactness and side are decided exactly, by
//! comparing the literal's decimal digits with the f64's exact decimal
//! expansion (every f64 has a finite one, at most 767 significant digits).

use std::cmp::Ordering;

use super::Const;

/// A positive decimal `0.DIGITS × 10^EXP` with no leading or trailing zero
/// digit; zero is the empty digit string.
#[derive(PartialEq, Eq)]
struct Decimal {
    exp: i64,
    digits: Vec<u8>,
}

impl Decimal {
    /// From an integer digit string `d` (ASCII digits) times `10^k`.
    fn new(d: &[u8], mut k: i64) -> Decimal {
        let start = d.iter().position(|&c| c != b'0').unwrap_or(d.len());
        let mut digits = d[start..].to_vec();
        while digits.last() == Some(&b'0') {
            digits.pop();
            k = k.saturating_add(1);
        }
        let exp = if digits.is_empty() {
            0
        } else {
            k.saturating_add(digits.len() as i64)
        };
        Decimal { exp, digits }
    }

    fn cmp(&self, other: &Decimal) -> Ordering {
        match (self.digits.is_empty(), other.digits.is_empty()) {
            (true, true) => Ordering::Equal,
            (true, false) => Ordering::Less,
            (false, true) => Ordering::Greater,
            // Same exponent: digit strings compare lexicographically, a
            // proper prefix being the smaller (no trailing zeros).
            (false, false) => self
                .exp
                .cmp(&other.exp)
                .then_with(|| self.digits.cmp(&other.digits)),
        }
    }

    /// Parses `INT[.FRAC][e[+-]EXP]` or `.FRAC[…]` (the lexer's number form).
    fn parse(text: &str) -> Option<Decimal> {
        let (mantissa, exp) = match text.find(['e', 'E']) {
            Some(i) => (&text[..i], parse_exponent(&text[i + 1..])?),
            None => (text, 0),
        };
        let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
        if int.is_empty() && frac.is_empty() {
            return None;
        }
        let digits: Vec<u8> = int.bytes().chain(frac.bytes()).collect();
        if !digits.iter().all(u8::is_ascii_digit) {
            return None;
        }
        Some(Decimal::new(&digits, exp.saturating_sub(frac.len() as i64)))
    }

    /// The exact decimal value of a finite, non-negative f64.
    fn of_f64(v: f64) -> Decimal {
        // 800 significant digits exceed the longest exact expansion (767).
        let s = format!("{:.800e}", v);
        let (mantissa, exp) = s.split_once('e').expect("exponent form");
        let exp: i64 = exp.parse().expect("exponent");
        let digits: Vec<u8> = mantissa.bytes().filter(|c| *c != b'.').collect();
        // mantissa is d.ddd…: value = ddd… × 10^(exp - 800).
        Decimal::new(&digits, exp - 800)
    }
}

fn parse_exponent(s: &str) -> Option<i64> {
    let (neg, digits) = match s.as_bytes().first()? {
        b'+' => (false, &s[1..]),
        b'-' => (true, &s[1..]),
        _ => (false, s),
    };
    if digits.is_empty() || !digits.bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    // Saturate: anything beyond ±10^15 is far outside f64 anyway.
    let mut e: i64 = 0;
    for c in digits.bytes() {
        e = (e * 10 + i64::from(c - b'0')).min(1_000_000_000_000_000);
    }
    Some(if neg { -e } else { e })
}

impl Const {
    /// The constant for a non-negative decimal literal, or `None` when the
    /// text is not a number or overflows to infinity.
    pub fn literal(text: &str) -> Option<Const> {
        let exact = Decimal::parse(text)?;
        let v: f64 = text.parse().ok()?;
        if !v.is_finite() {
            return None;
        }
        Some(match exact.cmp(&Decimal::of_f64(v)) {
            Ordering::Equal => Const::exact(v),
            Ordering::Greater => Const {
                value: v,
                lo: v,
                hi: v.next_up(),
                defined: true,
            },
            Ordering::Less => Const {
                value: v,
                lo: v.next_down(),
                hi: v,
                defined: true,
            },
        })
    }

    /// π: the nearest f64 (which is below π) and the one above.
    pub fn pi() -> Const {
        let p = std::f64::consts::PI;
        Const {
            value: p,
            lo: p,
            hi: p.next_up(),
            defined: true,
        }
    }

    /// The integer this constant is, when its value and enclosure are that
    /// one integer and it fits `i64`.
    pub fn as_integer(&self) -> Option<i64> {
        let v = self.value;
        (self.is_exact() && v.fract() == 0.0 && v.abs() < 9.2e18).then_some(v as i64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_literals_are_points() {
        for t in [
            "2",
            "0.5",
            "1e3",
            ".25",
            "1.",
            "0",
            "000",
            "4503599627370496",
            "1.5e-1",
        ] {
            let c = Const::literal(t).unwrap();
            if t == "1.5e-1" {
                assert!(!c.is_exact(), "{t}");
            } else {
                assert!(c.is_exact(), "{t}");
            }
        }
    }

    #[test]
    fn inexact_literals_enclose_the_real_number() {
        // 0.1 as f64 is 0.1000000000000000055511151231257827…, above 0.1.
        let c = Const::literal("0.1").unwrap();
        assert_eq!((c.lo, c.hi), (0.1f64.next_down(), 0.1));
        // 0.3 as f64 is 0.299999999999999988897769753748…, below 0.3.
        let c = Const::literal("0.3").unwrap();
        assert_eq!((c.lo, c.hi), (0.3, 0.3f64.next_up()));
        // 2^53 + 1 is not representable; the f64 is 2^53, below it.
        let c = Const::literal("9007199254740993").unwrap();
        assert_eq!((c.lo, c.hi), (9007199254740992.0, 9007199254740994.0));
    }

    #[test]
    fn tiny_and_huge_literals() {
        let c = Const::literal("1e-400").unwrap();
        assert_eq!((c.value, c.lo, c.hi), (0.0, 0.0, 0.0f64.next_up()));
        assert!(Const::literal("1e999").is_none());
        assert!(Const::literal("1e99999999999999999999").is_none());
        let c = Const::literal("1e-99999999999999999999").unwrap();
        assert_eq!(c.lo, 0.0);
    }

    #[test]
    fn integers() {
        assert_eq!(Const::literal("3").unwrap().as_integer(), Some(3));
        assert_eq!(Const::literal("3.5").unwrap().as_integer(), None);
        assert_eq!(Const::literal("0.1").unwrap().as_integer(), None);
        assert_eq!(Const::literal("1e30").unwrap().as_integer(), None);
    }
}
