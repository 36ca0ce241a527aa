//! Lowering of a [`Program`] to the interval body.
//!
//! Each IR value becomes two f64 SSA values `(lo, hi)`, plus one `i8`
//! accumulator for the decoration "defined and continuous on the whole box"
//! (the AND of every op's flag).
//!
//! Inline, outward rounded with [`super::rounding`]:
//!
//! | op | rule |
//! |---|---|
//! | `neg`, `min`, `max` | exact bound arithmetic |
//! | `abs` | `[max(0, lo, −hi), max(−lo, hi)]`, exact |
//! | `add`, `sub` | `[down(al + bl), up(ah + bh)]`, `[down(al − bh), up(ah − bl)]` |
//! | `mul` | min/max of the four products (a NaN product `0·∞` counts as 0), widened |
//! | `square` | `[down(mig²) ∨ 0, up(mag²)]` |
//! | `sqrt` | `[down(√max(lo,0)) ∨ 0, up(√hi)]`, empty when `hi < 0`; defined iff `lo ≥ 0` |
//! | `powi a n`, `n > 0` | exact monotone rules on `mig`/`mag` (even `n`) or the signed bounds (odd `n`), each product of the repeated squaring widened in its direction |
//!
//! Everything else (`div`, `powi` with `n < 0`, transcendentals, `atan2`,
//! `pow`) calls [`crate::interval`]'s per-op enclosures through
//! [`super::helpers`], which return the op's decoration.

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value, types};

use super::{Env, rounding};
use crate::ir::{BinOp, Op, Program, UnOp};

/// An interval as two SSA values.
pub(super) type Iv = (Value, Value);

/// Emits the body; returns the output interval and the decoration (i8).
pub(super) fn lower(env: &mut Env, prog: &Program, input: [Iv; 4]) -> (Iv, Value) {
    let mut ok = env.b.ins().iconst(types::I8, 1);
    let mut vals: Vec<Iv> = Vec::with_capacity(prog.len());
    for (i, op) in prog.insts.iter().enumerate() {
        let (v, d) = lower_op(env, i, op, &vals, &input);
        if let Some(d) = d {
            ok = env.b.ins().band(ok, d);
        }
        vals.push(v);
    }
    (vals[prog.output.index()], ok)
}

/// One op: its interval and, when the op can be undefined, its flag.
pub(super) fn lower_op(
    env: &mut Env,
    i: usize,
    op: &Op,
    vals: &[Iv],
    input: &[Iv; 4],
) -> (Iv, Option<Value>) {
    match *op {
        Op::Var(var) => (input[var.index()], None),
        Op::Const(c) => {
            let iv = (env.pool_load(i, 1), env.pool_load(i, 2));
            let d = if c.defined {
                None
            } else {
                Some(env.b.ins().iconst(types::I8, 0))
            };
            (iv, d)
        }
        Op::Unary(u, a) => unary(env, u, vals[a.index()]),
        Op::Binary(op, a, b) => binary(env, op, vals[a.index()], vals[b.index()]),
        Op::Powi(a, n) => {
            let a = vals[a.index()];
            if n == 0 {
                ((env.pool_load(i, 1), env.pool_load(i, 2)), None)
            } else if n > 0 {
                (powi(env, a, n as u64), None)
            } else {
                env.call_iv_powi(a, n)
            }
        }
    }
}

pub(super) fn unary(env: &mut Env, u: UnOp, (lo, hi): Iv) -> (Iv, Option<Value>) {
    match u {
        UnOp::Neg => {
            let b = &mut env.b;
            ((b.ins().fneg(hi), b.ins().fneg(lo)), None)
        }
        UnOp::Abs => {
            let (mig, mag) = mig_mag(env, (lo, hi));
            ((mig, mag), None)
        }
        UnOp::Square => {
            let (mig, mag) = mig_mag(env, (lo, hi));
            let b = &mut env.b;
            let l = b.ins().fmul(mig, mig);
            let h = b.ins().fmul(mag, mag);
            let l = rounding::down(b, l);
            let l = clamp0(b, l);
            let h = rounding::up(b, h);
            ((l, h), None)
        }
        UnOp::Sqrt => {
            let b = &mut env.b;
            let zero = b.ins().f64const(0.0);
            let defined = b.ins().fcmp(FloatCC::GreaterThanOrEqual, lo, zero);
            let l0 = b.ins().fmax(lo, zero);
            let l = b.ins().sqrt(l0);
            let l = rounding::down(b, l);
            let l = clamp0(b, l);
            let h = b.ins().sqrt(hi);
            let h = rounding::up(b, h);
            // hi < 0: nowhere defined, the empty interval [+∞, −∞].
            let empty = b.ins().fcmp(FloatCC::LessThan, hi, zero);
            let pinf = b.ins().f64const(f64::INFINITY);
            let ninf = b.ins().f64const(f64::NEG_INFINITY);
            let l = b.ins().select(empty, pinf, l);
            let h = b.ins().select(empty, ninf, h);
            ((l, h), Some(defined))
        }
        _ => env.call_iv_unary(u, (lo, hi)),
    }
}

pub(super) fn binary(env: &mut Env, op: BinOp, a: Iv, bv: Iv) -> (Iv, Option<Value>) {
    let b = &mut env.b;
    match op {
        BinOp::Add => {
            let l = b.ins().fadd(a.0, bv.0);
            let h = b.ins().fadd(a.1, bv.1);
            ((rounding::down(b, l), rounding::up(b, h)), None)
        }
        BinOp::Sub => {
            let l = b.ins().fsub(a.0, bv.1);
            let h = b.ins().fsub(a.1, bv.0);
            ((rounding::down(b, l), rounding::up(b, h)), None)
        }
        BinOp::Mul => (mul(env, a, bv), None),
        BinOp::Min => ((b.ins().fmin(a.0, bv.0), b.ins().fmin(a.1, bv.1)), None),
        BinOp::Max => ((b.ins().fmax(a.0, bv.0), b.ins().fmax(a.1, bv.1)), None),
        BinOp::Div | BinOp::Atan2 | BinOp::Pow => env.call_iv_binary(op, a, bv),
    }
}

/// `max(x, 0)` (sound for a lower bound of a nonnegative quantity).
fn clamp0(b: &mut cranelift_frontend::FunctionBuilder, x: Value) -> Value {
    let zero = b.ins().f64const(0.0);
    b.ins().fmax(x, zero)
}

/// `(mig, mag)`: the smallest and largest `|x|` on `[lo, hi]`, exact.
fn mig_mag(env: &mut Env, (lo, hi): Iv) -> Iv {
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    let nlo = b.ins().fneg(lo);
    let nhi = b.ins().fneg(hi);
    let m = b.ins().fmax(lo, nhi);
    let mig = b.ins().fmax(m, zero);
    let mag = b.ins().fmax(nlo, hi);
    (mig, mag)
}

/// Interval product, outward rounded.
pub(super) fn mul(env: &mut Env, a: Iv, c: Iv) -> Iv {
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    let mut ps = [(a.0, c.0), (a.0, c.1), (a.1, c.0), (a.1, c.1)].map(|(x, y)| {
        let p = b.ins().fmul(x, y);
        // 0·∞ = NaN stands for 0 in interval arithmetic.
        let nan = b.ins().fcmp(FloatCC::Unordered, p, p);
        b.ins().select(nan, zero, p)
    });
    let lo01 = b.ins().fmin(ps[0], ps[1]);
    let lo23 = b.ins().fmin(ps[2], ps[3]);
    let lo = b.ins().fmin(lo01, lo23);
    let hi01 = b.ins().fmax(ps[0], ps[1]);
    ps[0] = b.ins().fmax(ps[2], ps[3]);
    let hi = b.ins().fmax(hi01, ps[0]);
    (rounding::down(b, lo), rounding::up(b, hi))
}

/// Bounds of `x^n` for `x ≥ 0` (`x` an exact bound), `n ≥ 1`: the repeated
/// squaring with every product widened in direction `up`.
fn pow_bound(env: &mut Env, x: Value, mut n: u64, up: bool) -> Value {
    let b = &mut env.b;
    let round = |b: &mut cranelift_frontend::FunctionBuilder, v: Value| {
        if up {
            rounding::up(b, v)
        } else {
            let d = rounding::down(b, v);
            clamp0(b, d)
        }
    };
    let mut acc: Option<Value> = None;
    let mut base = x;
    loop {
        if n & 1 == 1 {
            acc = Some(match acc {
                None => base,
                Some(r) => {
                    let p = b.ins().fmul(r, base);
                    round(b, p)
                }
            });
        }
        n >>= 1;
        if n == 0 {
            break;
        }
        let sq = b.ins().fmul(base, base);
        base = round(b, sq);
    }
    acc.unwrap_or(x)
}

/// `[lo, hi]^n`, `n ≥ 1`.
fn powi(env: &mut Env, (lo, hi): Iv, n: u64) -> Iv {
    if n == 1 {
        return (lo, hi);
    }
    if n % 2 == 0 {
        let (mig, mag) = mig_mag(env, (lo, hi));
        let l = pow_bound(env, mig, n, false);
        let h = pow_bound(env, mag, n, true);
        return (l, h);
    }
    // Odd: monotone increasing; x^n = sign(x)·|x|^n.
    let alo = env.b.ins().fabs(lo);
    let ahi = env.b.ins().fabs(hi);
    let lo_dn = pow_bound(env, alo, n, false);
    let lo_up = pow_bound(env, alo, n, true);
    let hi_dn = pow_bound(env, ahi, n, false);
    let hi_up = pow_bound(env, ahi, n, true);
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    let lo_neg = b.ins().fcmp(FloatCC::LessThan, lo, zero);
    let hi_neg = b.ins().fcmp(FloatCC::LessThan, hi, zero);
    let nlo = b.ins().fneg(lo_up);
    let nhi = b.ins().fneg(hi_dn);
    let l = b.ins().select(lo_neg, nlo, lo_dn);
    let h = b.ins().select(hi_neg, nhi, hi_up);
    (l, h)
}
