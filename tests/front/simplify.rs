//! Simplification preserves meaning: a random program rebuilt through the
//! [`Builder`] (constant folding, algebraic rules, hash-consing, dead-code
//! elimination) gives the same point values (bit for bit up to the sign of
//! zero; NaN where the original is NaN), and its interval enclosures still
//! contain the original's point values. Fixing `t` folds what depends on
//! it alone, with the same point values.

use crate::support::{arb_point, arb_program, cases, encloses, same};
use isoc::eval::{interval, point};
use isoc::interval::Interval;
use isoc::ir::{Builder, Var};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases()))]

    #[test]
    fn simplification_preserves_point_values(p in arb_program(), x in arb_point()) {
        let q = Builder::rebuild(&p);
        q.validate().unwrap();
        prop_assert!(q.len() <= p.len(), "rebuilding never grows a program");
        let (a, b) = (point::eval(&p, x), point::eval(&q, x));
        prop_assert!(same(a, b), "{a} vs {b}\noriginal:\n{p}\nsimplified:\n{q}");
    }

    #[test]
    fn substituting_t_preserves_point_values(p in arb_program(), x in arb_point()) {
        let q = Builder::substitute(&p, Var::T, x[3]);
        q.validate().unwrap();
        prop_assert!(!q.uses_var(Var::T) && q.len() <= p.len());
        // Any t: q no longer reads it.
        let y = [x[0], x[1], x[2], -x[3] + 1.0];
        let (a, b) = (point::eval(&p, x), point::eval(&q, y));
        prop_assert!(same(a, b), "{a} vs {b}\noriginal:\n{p}\nwith t = {}:\n{q}", x[3]);
    }

    #[test]
    fn simplified_enclosures_contain_original_points(p in arb_program(), x in arb_point()) {
        let q = Builder::rebuild(&p);
        let v = point::eval(&p, x);
        let b = x.map(|c| Interval { lo: c, hi: c });
        let iv = interval::eval(&q, b);
        prop_assert!(v.is_nan() || encloses(iv.iv, v), "{v} not in {:?}\n{q}", iv.iv);
    }
}
