//! Lowering of a [`Program`] to the f64 point body.
//!
//! `neg abs sqrt square add sub mul div min max powi` are inline IEEE
//! operations (with the IR's NaN rules: `a / ±0` is NaN, `min`/`max`
//! propagate NaN); every other op (`exp log sin … atan2 pow` and the `.vm`
//! ops) calls the reference evaluator's per-op functions through
//! [`super::helpers`], so the JIT's point values are bit for bit the
//! interpreter's.
//!
//! The rules are [`PointNum`]'s, the point kind of the one lowering
//! ([`super::lower`]), written once for both the scalar body and the
//! `F64X2` body of the batch loop ([`super::simd`]), generic over the lane
//! width [`Width`]. The point-gradient kind ([`super::pgrad`]) computes its
//! values with the same rules.
//!
//! `powi a n` is computed by right-to-left binary exponentiation: the
//! running product starts at the lowest set bit's power of `a` and each
//! further set bit multiplies it by the current square, `a^-n = 1 / a^n`,
//! `a^0 = 1`.

use std::marker::PhantomData;

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value};

use super::Env;
use super::lower::{NumKind, body};
use crate::ir::{BinOp, Const, Program, UnOp, Var};

/// What differs between the scalar body and the `F64X2` body
/// ([`super::simd`]): how a pool constant enters, how `a / ±0 = NaN` is
/// selected, and how a helper op is called. Every inline op is the same
/// Cranelift instruction at either width (the instructions are
/// polymorphic over the lane count), so [`PointNum`]'s rules are written
/// once for both.
pub(super) trait Width {
    /// Entry 0 (the point value) of instruction `i`'s pool record.
    fn constant(env: &mut Env, i: usize) -> Value;
    /// `a / b`, NaN where `b` is ±0.
    fn div_nan(env: &mut Env, a: Value, b: Value) -> Value;
    /// A unary op computed by its helper.
    fn unary_helper(env: &mut Env, u: UnOp, a: Value) -> Value;
    /// A binary op computed by its helper.
    fn binary_helper(env: &mut Env, op: BinOp, a: Value, b: Value) -> Value;
    /// The f64 `x` in every lane.
    fn splat(env: &mut Env, x: Value) -> Value;
    /// Per lane, whether `x cc y` holds, as [`Width::pick`] reads it.
    fn test(env: &mut Env, cc: FloatCC, x: Value, y: Value) -> Value;
    /// Per lane, `a` where the test `c` ([`Width::test`]) held, else `b`.
    fn pick(env: &mut Env, c: Value, a: Value, b: Value) -> Value;
    /// `f` applied to each lane of `args` (scalars in, scalars out), its
    /// results joined lane by lane: how the point-gradient kind calls its
    /// scalar helper.
    fn per_lane(
        env: &mut Env,
        args: &[Value],
        f: impl FnMut(&mut Env, &[Value]) -> Vec<Value>,
    ) -> Vec<Value>;
}

/// One f64 per value: the single-point kernel and the scalar batch loop.
pub(super) struct Scalar;

impl Width for Scalar {
    fn constant(env: &mut Env, i: usize) -> Value {
        env.pool_load(i, 0)
    }
    fn div_nan(env: &mut Env, a: Value, b: Value) -> Value {
        div_nan(env, a, b)
    }
    fn unary_helper(env: &mut Env, u: UnOp, a: Value) -> Value {
        env.call_pt_unary(u, a)
    }
    fn binary_helper(env: &mut Env, op: BinOp, a: Value, b: Value) -> Value {
        env.call_pt_binary(op, a, b)
    }
    fn splat(_env: &mut Env, x: Value) -> Value {
        x
    }
    fn test(env: &mut Env, cc: FloatCC, x: Value, y: Value) -> Value {
        env.b.ins().fcmp(cc, x, y)
    }
    fn pick(env: &mut Env, c: Value, a: Value, b: Value) -> Value {
        env.b.ins().select(c, a, b)
    }
    fn per_lane(
        env: &mut Env,
        args: &[Value],
        mut f: impl FnMut(&mut Env, &[Value]) -> Vec<Value>,
    ) -> Vec<Value> {
        f(env, args)
    }
}

/// The f64 point kind at lane width `W` (see [`super::lower`]).
pub(super) struct PointNum<W>(PhantomData<W>);

impl<W> PointNum<W> {
    pub(super) const fn new() -> Self {
        PointNum(PhantomData)
    }
}

impl<W: Width> NumKind for PointNum<W> {
    type In = Value;
    type V = Value;
    type Out = Value;

    fn var(&self, _env: &mut Env, _var: Var, x: Value) -> Value {
        x
    }
    fn konst(&self, env: &mut Env, i: usize, _c: Const) -> Value {
        W::constant(env, i)
    }
    fn neg(&self, env: &mut Env, a: Value) -> Value {
        env.b.ins().fneg(a)
    }
    fn abs(&self, env: &mut Env, a: Value) -> Value {
        env.b.ins().fabs(a)
    }
    fn sqrt(&self, env: &mut Env, a: Value) -> Value {
        env.b.ins().sqrt(a)
    }
    fn square(&self, env: &mut Env, a: Value) -> Value {
        env.b.ins().fmul(a, a)
    }
    fn add(&self, env: &mut Env, a: Value, b: Value) -> Value {
        env.b.ins().fadd(a, b)
    }
    fn sub(&self, env: &mut Env, a: Value, b: Value) -> Value {
        env.b.ins().fsub(a, b)
    }
    fn mul(&self, env: &mut Env, a: Value, b: Value) -> Value {
        env.b.ins().fmul(a, b)
    }
    fn div(&self, env: &mut Env, a: Value, b: Value) -> Value {
        W::div_nan(env, a, b)
    }
    fn min(&self, env: &mut Env, a: Value, b: Value) -> Value {
        env.b.ins().fmin(a, b)
    }
    fn max(&self, env: &mut Env, a: Value, b: Value) -> Value {
        env.b.ins().fmax(a, b)
    }
    fn powi(&self, env: &mut Env, i: usize, a: Value, n: i64) -> Value {
        if n == 0 {
            return W::constant(env, i);
        }
        let p = powi_chain(env, a, n.unsigned_abs());
        if n < 0 {
            let one = W::constant(env, i);
            W::div_nan(env, one, p)
        } else {
            p
        }
    }
    fn unary_call(&self, env: &mut Env, u: UnOp, a: Value) -> Value {
        W::unary_helper(env, u, a)
    }
    fn binary_call(&self, env: &mut Env, op: BinOp, a: Value, b: Value) -> Value {
        W::binary_helper(env, op, a, b)
    }
    fn finish(&self, _env: &mut Env, r: Value, _args: impl Iterator<Item = Value>) -> Value {
        r
    }
}

/// Emits the body at width `W`; returns the output value.
pub(super) fn lower<W: Width>(env: &mut Env, prog: &Program, input: [Value; 4]) -> Value {
    body(env, &PointNum::<W>::new(), prog, input)
}

/// `a / b`, NaN when `b` is ±0 (the IR's point semantics).
pub(super) fn div_nan(env: &mut Env, a: Value, b: Value) -> Value {
    let ins = &mut env.b;
    let q = ins.ins().fdiv(a, b);
    let zero = ins.ins().f64const(0.0);
    let nan = ins.ins().f64const(f64::NAN);
    let is0 = ins.ins().fcmp(FloatCC::Equal, b, zero);
    ins.ins().select(is0, nan, q)
}

/// `a^n`, `n ≥ 1`, right-to-left binary exponentiation in round to nearest.
pub(super) fn powi_chain(env: &mut Env, a: Value, mut n: u64) -> Value {
    let mut acc: Option<Value> = None;
    let mut base = a;
    loop {
        if n & 1 == 1 {
            acc = Some(match acc {
                None => base,
                Some(r) => env.b.ins().fmul(r, base),
            });
        }
        n >>= 1;
        if n == 0 {
            break;
        }
        base = env.b.ins().fmul(base, base);
    }
    acc.unwrap_or(a)
}
