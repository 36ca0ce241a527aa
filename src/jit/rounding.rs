//! Outward rounding in generated code: hardware rounding toward +∞.
//!
//! # Strategy
//!
//! The interval and interval-gradient kernels run with MXCSR set to round
//! toward +∞ (switched at entry and exit, and back to nearest around every
//! call into Rust: see [`super::mxcsr`]). Then one instruction gives each
//! bound, correctly rounded in its direction:
//!
//! | bound | computed as |
//! |---|---|
//! | upper `RU(a ∘ b)` | `a ∘ b` |
//! | lower `RD(a + b)` | `−((−a) + (−b))` — with intervals held as `(−lo, hi)` ([`super::interval`]) just `(−a) + (−b)` |
//! | lower `RD(a · b)` | `−((−a) · b)` |
//! | lower `RD(√a)` | `r = √a`; `pred(r)` if `r·r > a` (rounded up, so exactly when `r² > a`), else `r` |
//!
//! using `RD(x) = −RU(−x)`. The bounds are exactly as tight as the
//! reference interpreter's error-free transformations ([`crate::interval`])
//! in the normal range and tighter where those must widen blindly
//! (underflow): exact results stay exact (`[−1,2]² = [0,4]`, `1⁸ = 1`,
//! `√1 = 1`, which matters: a widened `√1` would push `asin`'s argument out
//! of its domain). Overflow is handled by the hardware: an upper bound
//! overflows to `+∞`, a lower bound computed as `−RU(−x)` to `−∞`; a lower
//! bound never becomes `+∞` nor an upper bound `−∞` from finite operands.
//!
//! # Why this scheme (measured, see `docs/jit.md`)
//!
//! The previous scheme computed each bound in round to nearest with an
//! error-free transformation (TwoSum, FMA residual), a sign test, a
//! predecessor/successor and underflow/overflow guards: about 45 IR
//! instructions a product bound, ≈ 1 KB of machine code an interval
//! product, and register allocation over that code made compile time
//! super-linear. Directed rounding needs one instruction a bound (plus the
//! `0·∞` rule for products), so code size and compile time are linear and
//! small.
//!
//! # What Cranelift may do to it
//!
//! Cranelift's mid-end rewrites float code only where the rewrite is exact
//! in every rounding mode (`−(−x) → x`, `(−x)·(−y) → x·y`) — checked
//! against cranelift-codegen 0.135's ISLE rules — except constant folding,
//! which is done in round to nearest: so no float operation is ever
//! emitted on two Cranelift constants (constants are loaded from the pool,
//! see [`super`]).

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, MemFlagsData, Value, types};
use cranelift_frontend::FunctionBuilder;

/// `RU(x + y)`.
pub(crate) fn add_up(b: &mut FunctionBuilder, x: Value, y: Value) -> Value {
    b.ins().fadd(x, y)
}

/// `RU(x · y)`.
pub(crate) fn mul_up(b: &mut FunctionBuilder, x: Value, y: Value) -> Value {
    b.ins().fmul(x, y)
}

/// `RD(x · y) = −RU((−x) · y)`.
pub(crate) fn mul_down(b: &mut FunctionBuilder, x: Value, y: Value) -> Value {
    let nx = b.ins().fneg(x);
    let p = b.ins().fmul(nx, y);
    b.ins().fneg(p)
}

/// `RU(√a)`.
pub(crate) fn sqrt_up(b: &mut FunctionBuilder, a: Value) -> Value {
    b.ins().sqrt(a)
}

/// `RD(√a)` for `a ≥ 0` (finite or `+∞`): `r = RU(√a)`, and its
/// predecessor when inexact. `r·r` rounded up exceeds `a` exactly when
/// `r² > a` (`a` is a float, so `RU(r²) ≤ a` when `r² ≤ a`); the
/// predecessor of a positive finite float is its bit pattern minus one.
pub(crate) fn sqrt_down(b: &mut FunctionBuilder, a: Value) -> Value {
    let r = b.ins().sqrt(a);
    let rr = b.ins().fmul(r, r);
    let inexact = b.ins().fcmp(FloatCC::GreaterThan, rr, a);
    let bits = b.ins().bitcast(types::I64, MemFlagsData::new(), r);
    let pbits = b.ins().iadd_imm_s(bits, -1);
    let pred = b.ins().bitcast(types::F64, MemFlagsData::new(), pbits);
    b.ins().select(inexact, pred, r)
}
