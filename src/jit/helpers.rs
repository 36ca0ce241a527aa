//! `extern "C"` Rust helpers that the kernels call for the operations they
//! do not inline (transcendentals, division and a few others), registered
//! with `JITBuilder::symbol` under the names of [`Helper`].
//!
//! Operation codes are indices into [`UnOp::ALL`] / [`BinOp::ALL`]; a code
//! out of range gives NaN (point) or the whole real line, undefined
//! (interval), never a panic. Pointers are to arrays of f64 laid out as in
//! the kernels' ABI (see [`super`]): an interval is `[lo, hi]`, a gradient
//! record is `[F.lo, F.hi, Fx.lo, Fx.hi, Fy.lo, Fy.hi, Fz.lo, Fz.hi]`.
//! Interval helpers return the op's decoration (1 defined and continuous on
//! the operands, else 0); gradient helpers return two bits: bit 0 the
//! value's decoration, bit 1 the derivatives'. Operand decorations are
//! combined by the kernel, not here.
//!
//! The point helpers are the reference evaluator's own per-op functions
//! ([`crate::eval::point`]) and the interval helpers the interval module's
//! per-op enclosures ([`crate::interval`]), so the JIT and the interpreter
//! cannot disagree on them. The gradient helpers run the reference
//! gradient evaluator's own per-op rules ([`crate::eval::grad::step`]) on
//! decorated intervals. The point-gradient helper ([`PG_OP`]) runs the same
//! rules in f64 on `[v, dx, dy, dz]` records: one call gives an op's value
//! and its derivatives, bit for bit [`crate::eval::grad::eval_point`]'s.

use cranelift_codegen::ir::Type;

use super::mxcsr;
use crate::eval::grad::{self, Dual};
use crate::interval::{DecInterval, Interval};
use crate::ir::{BinOp, Op, UnOp, Value};

/// Every routine a kernel can call: its symbol (registered with
/// `JITBuilder::symbol`), its address and its Cranelift signature live
/// here, in one place.
///
/// The interval and gradient helpers are called from kernels running in
/// round-up mode, so their registered address is a trampoline
/// ([`super::mxcsr::trampoline!`]) that runs the Rust function in round to
/// nearest. The point and point-gradient helpers are called from kernels
/// in the default mode and are registered directly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Helper {
    /// `fn(code: u32, a: f64) -> f64`: a unary op's point value.
    PtUnary,
    /// `fn(code: u32, a: f64, b: f64) -> f64`.
    PtBinary,
    /// `fn(code: u32, lo, hi: f64, out: *mut [f64; 2]) -> u8` (decoration).
    IvUnary,
    /// `fn(code: u32, alo, ahi, blo, bhi: f64, out: *mut [f64; 2]) -> u8`.
    IvBinary,
    /// `fn(lo, hi: f64, n: i64, out: *mut [f64; 2]) -> u8`.
    IvPowi,
    /// `fn(code: u32, a: *const [f64; 8], out: *mut [f64; 8]) -> u8`
    /// (bit 0 value defined, bit 1 derivatives defined).
    GdUnary,
    /// `fn(code: u32, a, b: *const [f64; 8], n: i64, out: *mut [f64; 8]) -> u8`.
    GdBinary,
    /// `fn(code: u32, a, b: *const [f64; 4], out: *mut [f64; 4])`.
    PgOp,
    /// `fn(save: *mut u32)`: [`super::mxcsr::isoc_rm_enter`].
    RmEnter,
    /// `fn(save: *const u32)`: [`super::mxcsr::isoc_rm_leave`].
    RmLeave,
}

impl Helper {
    pub const ALL: [Helper; 10] = [
        Helper::PtUnary,
        Helper::PtBinary,
        Helper::IvUnary,
        Helper::IvBinary,
        Helper::IvPowi,
        Helper::GdUnary,
        Helper::GdBinary,
        Helper::PgOp,
        Helper::RmEnter,
        Helper::RmLeave,
    ];

    /// The symbol the kernels import.
    pub fn symbol(self) -> &'static str {
        match self {
            Helper::PtUnary => "isoc_pt_unary",
            Helper::PtBinary => "isoc_pt_binary",
            Helper::IvUnary => "isoc_iv_unary",
            Helper::IvBinary => "isoc_iv_binary",
            Helper::IvPowi => "isoc_iv_powi",
            Helper::GdUnary => "isoc_gd_unary",
            Helper::GdBinary => "isoc_gd_binary",
            Helper::PgOp => "isoc_pg_op",
            Helper::RmEnter => "isoc_rm_enter",
            Helper::RmLeave => "isoc_rm_leave",
        }
    }

    /// The address behind [`Helper::symbol`].
    pub fn address(self) -> *const u8 {
        match self {
            Helper::PtUnary => pt_unary as *const u8,
            Helper::PtBinary => pt_binary as *const u8,
            Helper::IvUnary => iv_unary_rn as *const u8,
            Helper::IvBinary => iv_binary_rn as *const u8,
            Helper::IvPowi => iv_powi_rn as *const u8,
            Helper::GdUnary => gd_unary_rn as *const u8,
            Helper::GdBinary => gd_binary_rn as *const u8,
            Helper::PgOp => pg_op as *const u8,
            Helper::RmEnter => mxcsr::isoc_rm_enter as *const u8,
            Helper::RmLeave => mxcsr::isoc_rm_leave as *const u8,
        }
    }

    /// Parameter and result types (`ptr` the pointer type).
    pub fn types(self, ptr: Type) -> (Vec<Type>, Option<Type>) {
        use cranelift_codegen::ir::types::{F64, I8, I32, I64};
        match self {
            Helper::PtUnary => (vec![I32, F64], Some(F64)),
            Helper::PtBinary => (vec![I32, F64, F64], Some(F64)),
            Helper::IvUnary => (vec![I32, F64, F64, ptr], Some(I8)),
            Helper::IvBinary => (vec![I32, F64, F64, F64, F64, ptr], Some(I8)),
            Helper::IvPowi => (vec![F64, F64, I64, ptr], Some(I8)),
            Helper::GdUnary => (vec![I32, ptr, ptr], Some(I8)),
            Helper::GdBinary => (vec![I32, ptr, ptr, I64, ptr], Some(I8)),
            Helper::PgOp => (vec![I32, ptr, ptr, ptr], None),
            Helper::RmEnter | Helper::RmLeave => (vec![ptr], None),
        }
    }

    /// `(symbol, address)` of every helper, for `JITBuilder::symbols`.
    pub fn symbols() -> impl Iterator<Item = (&'static str, *const u8)> {
        Helper::ALL.into_iter().map(|h| (h.symbol(), h.address()))
    }
}

// Round-to-nearest entry points of the helpers that round-up kernels call
// (every argument travels in registers, as the trampoline requires).
mxcsr::trampoline!(iv_unary_rn => iv_unary);
mxcsr::trampoline!(iv_binary_rn => iv_binary);
mxcsr::trampoline!(iv_powi_rn => iv_powi);
mxcsr::trampoline!(gd_unary_rn => gd_unary);
mxcsr::trampoline!(gd_binary_rn => gd_binary);

/// `pg_op` codes at or above this are binary ops (minus it), below unary.
pub(crate) const PG_BINARY_BASE: u32 = 1 << 16;
/// `gd_binary` op code standing for `powi` (with `n` passed as the second
/// operand's `F.lo`).
pub(crate) const GD_POWI_CODE: u32 = 1000;

/// The code of a unary op (its index in [`UnOp::ALL`]).
pub(crate) fn unop_code(op: UnOp) -> u32 {
    UnOp::ALL.iter().position(|&o| o == op).unwrap_or(0) as u32
}

/// The code of a binary op (its index in [`BinOp::ALL`]).
pub(crate) fn binop_code(op: BinOp) -> u32 {
    BinOp::ALL.iter().position(|&o| o == op).unwrap_or(0) as u32
}

const ENTIRE: Interval = Interval {
    lo: f64::NEG_INFINITY,
    hi: f64::INFINITY,
};

extern "C" fn pt_unary(op: u32, a: f64) -> f64 {
    match UnOp::ALL.get(op as usize) {
        Some(&op) => crate::ir::semantics::point_unary(op, a),
        None => f64::NAN,
    }
}

extern "C" fn pt_binary(op: u32, a: f64, b: f64) -> f64 {
    match BinOp::ALL.get(op as usize) {
        Some(&op) => crate::ir::semantics::point_binary(op, a, b),
        None => f64::NAN,
    }
}

/// # Safety
/// `out` points to 2 writable f64.
unsafe extern "C" fn iv_unary(op: u32, lo: f64, hi: f64, out: *mut f64) -> u8 {
    let (r, d) = match UnOp::ALL.get(op as usize) {
        Some(&op) => crate::ir::semantics::enclose_unary(op, Interval { lo, hi }),
        None => (ENTIRE, false),
    };
    // SAFETY: the kernel passes a 16-byte aligned stack slot of 2 f64.
    unsafe { write_iv(out, r) };
    d as u8
}

/// # Safety
/// `out` points to 2 writable f64.
unsafe extern "C" fn iv_binary(
    op: u32,
    alo: f64,
    ahi: f64,
    blo: f64,
    bhi: f64,
    out: *mut f64,
) -> u8 {
    let a = Interval { lo: alo, hi: ahi };
    let b = Interval { lo: blo, hi: bhi };
    let (r, d) = match BinOp::ALL.get(op as usize) {
        Some(&op) => crate::ir::semantics::enclose_binary(op, a, b),
        None => (ENTIRE, false),
    };
    // SAFETY: as in `iv_unary`.
    unsafe { write_iv(out, r) };
    d as u8
}

/// # Safety
/// `out` points to 2 writable f64.
unsafe extern "C" fn iv_powi(lo: f64, hi: f64, n: i64, out: *mut f64) -> u8 {
    let (r, d) = crate::ir::semantics::enclose_powi(Interval { lo, hi }, n);
    // SAFETY: as in `iv_unary`.
    unsafe { write_iv(out, r) };
    d as u8
}

/// # Safety
/// `out` points to 2 writable f64.
unsafe fn write_iv(out: *mut f64, r: Interval) {
    // SAFETY: guaranteed by the caller.
    unsafe {
        *out = r.lo;
        *out.add(1) = r.hi;
    }
}

/// # Safety
/// `p` points to 8 readable f64.
unsafe fn read_dual(p: *const f64) -> Dual<DecInterval> {
    // SAFETY: guaranteed by the caller.
    let r = unsafe { std::slice::from_raw_parts(p, 8) };
    // Operand flags are tracked by the kernel; here every operand is
    // "defined" and the result's flags are the op's own.
    let iv = |i: usize| DecInterval::new(Interval::new(r[2 * i], r[2 * i + 1]), true);
    Dual {
        v: iv(0),
        d: [iv(1), iv(2), iv(3)],
    }
}

/// # Safety
/// `p` points to 8 writable f64.
unsafe fn write_dual(p: *mut f64, g: &Dual<DecInterval>) -> u8 {
    // SAFETY: guaranteed by the caller.
    let w = unsafe { std::slice::from_raw_parts_mut(p, 8) };
    let mut d_ok = true;
    for (i, iv) in std::iter::once(g.v).chain(g.d).enumerate() {
        w[2 * i] = iv.iv.lo;
        w[2 * i + 1] = iv.iv.hi;
        if i > 0 {
            d_ok &= iv.defined;
        }
    }
    // Bit 0: the value is defined; bit 1: the derivatives are.
    g.v.defined as u8 | (d_ok as u8) << 1
}

/// Runs the reference evaluator's derivative rules ([`grad::step`]) on one
/// op whose operands are `v0` (and `v1`).
fn step(op: &Op, vals: &[Dual<DecInterval>]) -> Dual<DecInterval> {
    // The op reads no input variable; `input` is never consulted.
    let input = [DecInterval::new(Interval::ENTIRE, false); 4];
    grad::step(op, vals, input)
}

/// # Safety
/// `a` points to 8 readable f64, `out` to 8 writable f64.
unsafe extern "C" fn gd_unary(op: u32, a: *const f64, out: *mut f64) -> u8 {
    // SAFETY: the kernel passes stack slots of 8 f64.
    let a = unsafe { read_dual(a) };
    let r = match UnOp::ALL.get(op as usize) {
        Some(&u) => step(&Op::Unary(u, Value(0)), &[a]),
        None => unknown(),
    };
    // SAFETY: as above.
    unsafe { write_dual(out, &r) }
}

fn unknown() -> Dual<DecInterval> {
    let e = DecInterval::new(Interval::ENTIRE, false);
    Dual { v: e, d: [e; 3] }
}

/// # Safety
/// `a`, `b` point to 8 readable f64, `out` to 8 writable f64. For
/// [`GD_POWI_CODE`], `n` is the exponent and `b` is not read.
unsafe extern "C" fn gd_binary(op: u32, a: *const f64, b: *const f64, n: i64, out: *mut f64) -> u8 {
    // SAFETY: the kernel passes stack slots of 8 f64.
    let a = unsafe { read_dual(a) };
    let r = if op == GD_POWI_CODE {
        step(&Op::Powi(Value(0), n), &[a])
    } else {
        match BinOp::ALL.get(op as usize) {
            Some(&bop) => {
                // SAFETY: as above; `b` is valid for every binary code.
                let b = unsafe { read_dual(b) };
                step(&Op::Binary(bop, Value(0), Value(1)), &[a, b])
            }
            None => unknown(),
        }
    };
    // SAFETY: as above.
    unsafe { write_dual(out, &r) }
}

/// # Safety
/// `p` points to 4 readable f64.
unsafe fn read_pdual(p: *const f64) -> Dual<f64> {
    // SAFETY: guaranteed by the caller.
    let r = unsafe { std::slice::from_raw_parts(p, 4) };
    Dual {
        v: r[0],
        d: [r[1], r[2], r[3]],
    }
}

/// Value and derivatives of one op in f64 by the reference evaluator's
/// rules ([`grad::step`] on `f64`; the NaN poisoning of
/// [`grad::eval_point`] is the kernel's job). `code` below
/// [`PG_BINARY_BASE`] is a unary op (`b` not read), else the binary op
/// `code - PG_BINARY_BASE`; an unknown code gives NaN.
///
/// # Safety
/// `a` and `b` point to 4 readable f64 (`[v, dx, dy, dz]`), `out` to 4
/// writable f64.
unsafe extern "C" fn pg_op(code: u32, a: *const f64, b: *const f64, out: *mut f64) {
    // SAFETY: the kernel passes a stack slot of 4 f64.
    let a = unsafe { read_pdual(a) };
    let input = [f64::NAN; 4];
    let nan = Dual {
        v: f64::NAN,
        d: [f64::NAN; 3],
    };
    let r = if code >= PG_BINARY_BASE {
        match BinOp::ALL.get((code - PG_BINARY_BASE) as usize) {
            Some(&op) => {
                // SAFETY: as above; `b` is valid for binary codes.
                let b = unsafe { read_pdual(b) };
                grad::step(&Op::Binary(op, Value(0), Value(1)), &[a, b], input)
            }
            None => nan,
        }
    } else {
        match UnOp::ALL.get(code as usize) {
            Some(&op) => grad::step(&Op::Unary(op, Value(0)), &[a], input),
            None => nan,
        }
    };
    // SAFETY: the kernel passes a stack slot of 4 writable f64.
    let w = unsafe { std::slice::from_raw_parts_mut(out, 4) };
    w[0] = r.v;
    w[1..].copy_from_slice(&r.d);
}
