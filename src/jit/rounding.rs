//! Outward rounding in generated code.
//!
//! # Strategy
//!
//! Every kernel runs in the default rounding mode (round to nearest, ties to
//! even); nothing touches MXCSR (switching it is only legal inside one
//! `asm!` block around the whole kernel call, and then every helper call —
//! CORE-MATH — would run in the wrong mode).
//!
//! Each bound is computed in round to nearest, `r = RN(exact)`, together
//! with the sign of the error `e = exact − r`, obtained by an error-free
//! transformation:
//!
//! | op | error term (exact in f64) |
//! |---|---|
//! | `a + b` | TwoSum (Knuth): `s = a+b; b' = s−a; e = (a−(s−b')) + (b−b')` |
//! | `a · b` | `fma(a, b, −p)` |
//! | `√a` | `fma(−r, r, a)` (sign of `a − r²`) |
//!
//! A lower bound is `r` when `e ≥ 0` and the predecessor of `r` when
//! `e < 0`; an upper bound symmetrically. So bounds are exactly as tight as
//! hardware directed rounding (exact results stay exact: `[−1,2]² = [0,4]`,
//! `1⁸ = 1`, `√1 = 1` — which matters: a widened `√1` would push `asin`'s
//! argument out of its domain). The predecessor/successor is the branch-free
//! formula of Rump, Zimmermann, Boldo & Melquiond ("Computing predecessor
//! and successor in rounding to nearest", BIT 49, 2009, Algorithm 2):
//!
//! ```text
//! e    = φ·|c| + η        φ = 2^-53·(1 + 2^-52),  η = 2^-1074 (smallest subnormal)
//! up   = c + e            ∈ {succ(c), succ(succ(c))}
//! down = c − e            ∈ {pred(c), pred(pred(c))}
//! ```
//!
//! **Where the error term is not exact** the bound is widened
//! unconditionally: a product or square-root argument below `2^-960` (the
//! `fma` residual may underflow and lose its sign), and overflow (`r = ±∞`
//! from finite operands gives a NaN error term). Overflow of a lower bound
//! to `+∞` gives `MAX`, of an upper bound to `−∞` gives `−MAX`; a NaN error
//! term otherwise means "treat as exact", which only happens when `r` itself
//! is NaN or infinite.
//!
//! The FMA is a single instruction on x86-64 with FMA3 (Cranelift checks
//! the host); elsewhere Cranelift calls the C library's `fma`, which is
//! correctly rounded too.
//!
//! No float operation is ever emitted on two Cranelift constants (its
//! mid-end folds them in round-to-nearest): every operand here is computed.

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

/// Below this magnitude an `fma` residual may underflow.
pub const TINY: f64 = 1.0e-289; // < 2^-960

/// A round-to-nearest result and the error term `exact − r` (or NaN).
#[derive(Clone, Copy)]
pub struct Rounded {
    pub r: Value,
    pub e: Value,
}

/// `a + b` with its TwoSum error.
pub fn add(b: &mut FunctionBuilder, x: Value, y: Value) -> Rounded {
    let s = b.ins().fadd(x, y);
    let yv = b.ins().fsub(s, x);
    let xv = b.ins().fsub(s, yv);
    let dx = b.ins().fsub(x, xv);
    let dy = b.ins().fsub(y, yv);
    let e = b.ins().fadd(dx, dy);
    Rounded { r: s, e }
}

/// `a − b` with its error.
pub fn sub(b: &mut FunctionBuilder, x: Value, y: Value) -> Rounded {
    let ny = b.ins().fneg(y);
    add(b, x, ny)
}

/// `a · b` with its FMA error, and an i8 "the product is tiny" (the error
/// term may have underflowed: the caller must widen regardless).
pub fn mul(b: &mut FunctionBuilder, x: Value, y: Value) -> (Rounded, Value) {
    let p = b.ins().fmul(x, y);
    let np = b.ins().fneg(p);
    let e = b.ins().fma(x, y, np);
    let tiny = is_tiny(b, p);
    (Rounded { r: p, e }, tiny)
}

/// `√a` with the sign of `a − r²`.
pub fn sqrt(b: &mut FunctionBuilder, a: Value) -> (Rounded, Value) {
    let r = b.ins().sqrt(a);
    let nr = b.ins().fneg(r);
    let e = b.ins().fma(nr, r, a);
    let tiny = is_tiny(b, a);
    (Rounded { r, e }, tiny)
}

/// `|v| < TINY` (false for NaN).
fn is_tiny(b: &mut FunctionBuilder, v: Value) -> Value {
    let a = b.ins().fabs(v);
    let t = b.ins().f64const(TINY);
    b.ins().fcmp(FloatCC::LessThan, a, t)
}

/// The largest f64 ≤ the exact value, given its rounding `x` (`force`: an
/// i8 that, when 1, widens even if the error term says exact).
pub fn lower(b: &mut FunctionBuilder, x: Rounded, force: Option<Value>) -> Value {
    let zero = b.ins().f64const(0.0);
    let pinf = b.ins().f64const(f64::INFINITY);
    let neg = b.ins().fcmp(FloatCC::LessThan, x.e, zero);
    let ovf = b.ins().fcmp(FloatCC::Equal, x.r, pinf);
    let mut c = b.ins().bor(neg, ovf);
    if let Some(f) = force {
        c = b.ins().bor(c, f);
    }
    let d = down(b, x.r);
    b.ins().select(c, d, x.r)
}

/// The smallest f64 ≥ the exact value; see [`lower`].
pub fn upper(b: &mut FunctionBuilder, x: Rounded, force: Option<Value>) -> Value {
    let zero = b.ins().f64const(0.0);
    let ninf = b.ins().f64const(f64::NEG_INFINITY);
    let pos = b.ins().fcmp(FloatCC::GreaterThan, x.e, zero);
    let ovf = b.ins().fcmp(FloatCC::Equal, x.r, ninf);
    let mut c = b.ins().bor(pos, ovf);
    if let Some(f) = force {
        c = b.ins().bor(c, f);
    }
    let u = up(b, x.r);
    b.ins().select(c, u, x.r)
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
