//! Outward rounding in generated code.
//!
//! # Strategy
//!
//! Every kernel runs in the default rounding mode (round to nearest, ties to
//! even); nothing touches MXCSR. After each inexact-capable operation the
//! lower bound is pushed down and the upper bound up by the branch-free
//! successor/predecessor of Rump, Zimmermann, Boldo & Melquiond ("Computing
//! predecessor and successor in rounding to nearest", BIT 49, 2009,
//! Algorithm 2):
//!
//! ```text
//! e    = φ·|c| + η        φ = 2^-53·(1 + 2^-52),  η = 2^-1074 (smallest subnormal)
//! up   = c + e            ∈ {succ(c), succ(succ(c))}
//! down = c − e            ∈ {pred(c), pred(pred(c))}
//! ```
//!
//! all three operations in round-to-nearest. Since a correctly rounded
//! operation is within half an ulp of the exact result, `succ` of the rounded
//! result is an upper bound of the exact one: the kernels are sound whatever
//! the operation's rounding direction was, and at most two ulps wider than
//! hardware directed rounding (one ulp in the common case).
//!
//! Why this and not the alternatives: switching MXCSR is only legal inside
//! one `asm!` block around the whole kernel call, and then every helper call
//! (CORE-MATH) would run in the wrong mode; error-free transformations
//! (TwoSum, `fma(a, b, -p)`) would give hardware tightness but cost 6–10
//! dependent operations per bound plus a select, against 4 here (abs, mul,
//! add, add) that pipeline well.
//!
//! Infinities: `c = −∞` as an upper bound (an overflow of a negative result)
//! would give `−∞ + ∞ = NaN`; it is replaced by `−MAX`, still an upper bound
//! of every finite result. Symmetrically `+∞` as a lower bound becomes `MAX`.
//! A NaN bound stays NaN.
//!
//! No float operation is ever emitted on two Cranelift constants (its
//! mid-end folds them in round-to-nearest): `c` is always computed.

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value};
use cranelift_frontend::FunctionBuilder;

/// φ = 2^-53·(1 + 2^-52).
pub const PHI: f64 = f64::from_bits(0x3CA0_0000_0000_0001);
/// η = 2^-1074.
pub const ETA: f64 = f64::from_bits(1);

fn margin(b: &mut FunctionBuilder, c: Value) -> Value {
    let a = b.ins().fabs(c);
    let phi = b.ins().f64const(PHI);
    let eta = b.ins().f64const(ETA);
    let e = b.ins().fmul(a, phi);
    b.ins().fadd(e, eta)
}

/// An f64 ≥ the exact result that `c` is the round-to-nearest of.
pub fn up(b: &mut FunctionBuilder, c: Value) -> Value {
    let e = margin(b, c);
    let r = b.ins().fadd(c, e);
    let ninf = b.ins().f64const(f64::NEG_INFINITY);
    let is_ninf = b.ins().fcmp(FloatCC::Equal, c, ninf);
    let m = b.ins().f64const(-f64::MAX);
    b.ins().select(is_ninf, m, r)
}

/// An f64 ≤ the exact result that `c` is the round-to-nearest of.
pub fn down(b: &mut FunctionBuilder, c: Value) -> Value {
    let e = margin(b, c);
    let r = b.ins().fsub(c, e);
    let pinf = b.ins().f64const(f64::INFINITY);
    let is_pinf = b.ins().fcmp(FloatCC::Equal, c, pinf);
    let m = b.ins().f64const(f64::MAX);
    b.ins().select(is_pinf, m, r)
}

/// The same widening in Rust, for tests and the tightness measurement.
pub fn up_f64(c: f64) -> f64 {
    if c == f64::NEG_INFINITY {
        -f64::MAX
    } else {
        c + (c.abs() * PHI + ETA)
    }
}

/// See [`up_f64`].
pub fn down_f64(c: f64) -> f64 {
    if c == f64::INFINITY {
        f64::MAX
    } else {
        c - (c.abs() * PHI + ETA)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widening_is_strict_and_tight() {
        let samples = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.1,
            2.0f64.powi(-1022),
            f64::from_bits(1),
            f64::MAX,
            -f64::MAX,
            1.9999999999999998,
            3.0,
            -7.5e-300,
            123456.789,
        ];
        for &c in &samples {
            let u = up_f64(c);
            let d = down_f64(c);
            assert!(u > c && u <= c.next_up().next_up(), "{c}: {u}");
            assert!(d < c && d >= c.next_down().next_down(), "{c}: {d}");
        }
        assert_eq!(up_f64(f64::INFINITY), f64::INFINITY);
        assert_eq!(down_f64(f64::NEG_INFINITY), f64::NEG_INFINITY);
        assert_eq!(up_f64(f64::NEG_INFINITY), -f64::MAX);
        assert_eq!(down_f64(f64::INFINITY), f64::MAX);
    }
}
