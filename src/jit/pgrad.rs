//! Lowering of a [`Program`] to the f64 point-gradient body: forward-mode
//! automatic differentiation (dual numbers; Griewank & Walther,
//! *Evaluating Derivatives*, 2nd ed., SIAM 2008, ch. 3) in plain f64.
//!
//! Each IR value becomes four f64 SSA values `(v, ∂x, ∂y, ∂z)`: `var x` is
//! `(x, 1, 0, 0)` (likewise `y`, `z`), `var t` and constants have a zero
//! gradient. The kernel computes exactly what the reference
//! [`crate::eval::grad::eval_point`] computes, with the same IEEE
//! operations in the same order, so results agree bit for bit (up to NaN
//! payloads):
//!
//! - **values** are lowered by the point kernel's own rules
//!   ([`super::point::PointNum`]): same inline operations, same
//!   constant-pool loads, same helpers;
//! - **inline derivative rules** (`a'` the operand's derivative, `v` the
//!   op's value, `÷` the IR's division, NaN for a zero divisor):
//!   `neg: -a'`; `abs: -a'` if `a < 0` else `a'` (so `a'` at 0);
//!   `sqrt: a' ÷ (2v)` (NaN at 0); `square: (2a)·a'`; `add/sub: a' ± b'`;
//!   `mul: a'·b + a·b'`; `div: (a' − v·b') ÷ b`; `min`: `b'` if `b < a` else
//!   `a'`, `max`: `b'` if `b > a` else `a'` (the first operand on ties);
//!   `powi n: (n·a^(n−1))·a'` with `a^(n−1)` by the point kernel's binary
//!   method (`a^0 = 1`, negative powers `1 ÷ a^|m|`), `powi 0: 0`,
//!   `powi i64::MIN`: NaN;
//! - **transcendentals** (`exp log sin cos tan asin acos atan atan2 pow`)
//!   spill their operands' duals to a stack slot and make one call to
//!   [`super::helpers`]' `isoc_pg_op`, which runs the reference's own rule
//!   ([`crate::eval::grad::step`] on `f64`) and returns value and
//!   derivatives together;
//! - **NaN**: as in the reference, where a value is NaN its derivatives are
//!   set to NaN ("no derivative here"); that select is omitted after `neg
//!   abs sqrt square const powi 0`, whose derivatives are already NaN
//!   whenever their value is (given operands with that property).
//!
//! Without the sparsity of the derivatives being exploited (a known-zero
//! `b'` still costs `a·0`, which is NaN for infinite `a`), the reference's
//! results are reproduced exactly.
//!
//! The rules are [`PointGradNum`]'s, the point-gradient kind of the one
//! lowering ([`super::lower`]), at either lane width of the point kind
//! ([`super::point::Width`]): one point per iteration of the batch loop,
//! or two in `F64X2` ([`super::simd`]; selects by lane masks, each helper
//! called once per lane), each lane bit for bit the one-point form. The
//! two-point form is the second tier of [`super::Kernels`]' point
//! gradient: it runs about twice as fast per point and takes two to three
//! times as long to compile (`docs/jit.md`, "The point gradient's two
//! tiers").

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value, types};

use std::marker::PhantomData;

use super::helpers::{self, Helper, PG_BINARY_BASE};
use super::lower::{NumKind, body};
use super::point::{PointNum, Scalar, Width, powi_chain};
use super::simd::{X2, emit_loop};
use super::{Env, batch_loop};
use crate::ir::{BinOp, Const, Program, UnOp, Var};

/// `(v, ∂x, ∂y, ∂z)`.
pub(super) type Dual = [Value; 4];

/// The point-gradient kind of the one lowering ([`super::lower`]) at lane
/// width `W` (one point, or two in the batch loop's `F64X2` body): values
/// by the point kind's rules ([`PointNum`]), derivatives by the rules of
/// the module doc, the same IEEE operations in every lane. It holds the
/// SSA constants its rules share.
struct PointGradNum<W> {
    zero: Value,
    one: Value,
    two: Value,
    nan: Value,
    p: PointNum<W>,
    _w: PhantomData<W>,
}

impl<W: Width> PointGradNum<W> {
    /// Emits the constants.
    fn new(env: &mut Env) -> PointGradNum<W> {
        let mut splat = |x: f64| {
            let s = env.b.ins().f64const(x);
            W::splat(env, s)
        };
        PointGradNum {
            zero: splat(0.0),
            one: splat(1.0),
            two: splat(2.0),
            nan: splat(f64::NAN),
            p: PointNum::new(),
            _w: PhantomData,
        }
    }
}

impl<W: Width> NumKind for PointGradNum<W> {
    type In = Value;
    type V = Dual;
    /// The dual and whether it needs the NaN select.
    type Out = (Dual, bool);

    fn var(&self, _env: &mut Env, var: Var, x: Value) -> (Dual, bool) {
        let mut r = [x, self.zero, self.zero, self.zero];
        if var.index() < 3 {
            r[1 + var.index()] = self.one;
        }
        (r, true)
    }

    fn konst(&self, env: &mut Env, i: usize, c: Const) -> (Dual, bool) {
        let v = self.p.konst(env, i, c);
        let d = if c.value.is_nan() {
            self.nan
        } else {
            self.zero
        };
        ([v, d, d, d], false)
    }

    fn neg(&self, env: &mut Env, a: Dual) -> (Dual, bool) {
        (a.map(|x| self.p.neg(env, x)), false)
    }

    fn abs(&self, env: &mut Env, a: Dual) -> (Dual, bool) {
        let v = self.p.abs(env, a[0]);
        let neg = W::test(env, FloatCC::LessThan, a[0], self.zero);
        let d = [1, 2, 3].map(|k| {
            let m = env.b.ins().fneg(a[k]);
            W::pick(env, neg, m, a[k])
        });
        ([v, d[0], d[1], d[2]], false)
    }

    fn sqrt(&self, env: &mut Env, a: Dual) -> (Dual, bool) {
        let v = self.p.sqrt(env, a[0]);
        let two_v = env.b.ins().fmul(self.two, v);
        let d = [1, 2, 3].map(|k| W::div_nan(env, a[k], two_v));
        ([v, d[0], d[1], d[2]], false)
    }

    fn square(&self, env: &mut Env, a: Dual) -> (Dual, bool) {
        let v = self.p.square(env, a[0]);
        let two_a = env.b.ins().fmul(self.two, a[0]);
        let d = [1, 2, 3].map(|k| env.b.ins().fmul(two_a, a[k]));
        ([v, d[0], d[1], d[2]], false)
    }

    fn add(&self, env: &mut Env, a: Dual, b: Dual) -> (Dual, bool) {
        ([0, 1, 2, 3].map(|k| self.p.add(env, a[k], b[k])), true)
    }

    fn sub(&self, env: &mut Env, a: Dual, b: Dual) -> (Dual, bool) {
        ([0, 1, 2, 3].map(|k| self.p.sub(env, a[k], b[k])), true)
    }

    fn mul(&self, env: &mut Env, a: Dual, b: Dual) -> (Dual, bool) {
        let v = self.p.mul(env, a[0], b[0]);
        let d = [1, 2, 3].map(|k| {
            let p = env.b.ins().fmul(a[k], b[0]);
            let q = env.b.ins().fmul(a[0], b[k]);
            env.b.ins().fadd(p, q)
        });
        ([v, d[0], d[1], d[2]], true)
    }

    fn div(&self, env: &mut Env, a: Dual, b: Dual) -> (Dual, bool) {
        let v = self.p.div(env, a[0], b[0]);
        let d = [1, 2, 3].map(|k| {
            let p = env.b.ins().fmul(v, b[k]);
            let q = env.b.ins().fsub(a[k], p);
            W::div_nan(env, q, b[0])
        });
        ([v, d[0], d[1], d[2]], true)
    }

    fn min(&self, env: &mut Env, a: Dual, b: Dual) -> (Dual, bool) {
        let v = self.p.min(env, a[0], b[0]);
        (select::<W>(env, v, FloatCC::LessThan, a, b), true)
    }

    fn max(&self, env: &mut Env, a: Dual, b: Dual) -> (Dual, bool) {
        let v = self.p.max(env, a[0], b[0]);
        (select::<W>(env, v, FloatCC::GreaterThan, a, b), true)
    }

    fn powi(&self, env: &mut Env, i: usize, a: Dual, n: i64) -> (Dual, bool) {
        let v = self.p.powi(env, i, a[0], n);
        if n == 0 {
            return ([v, self.zero, self.zero, self.zero], false);
        }
        let Some(m) = n.checked_sub(1) else {
            return ([v, self.nan, self.nan, self.nan], true);
        };
        let p = match m {
            0 => self.one,
            m if m > 0 => powi_chain(env, a[0], m as u64),
            m => {
                let q = powi_chain(env, a[0], m.unsigned_abs());
                W::div_nan(env, self.one, q)
            }
        };
        let nf = env.b.ins().f64const(n as f64);
        let nf = W::splat(env, nf);
        let f = env.b.ins().fmul(nf, p);
        let d = [1, 2, 3].map(|k| env.b.ins().fmul(f, a[k]));
        ([v, d[0], d[1], d[2]], true)
    }

    fn unary_call(&self, env: &mut Env, u: UnOp, a: Dual) -> (Dual, bool) {
        (
            call_pg_lanes::<W>(env, helpers::unop_code(u), a, None),
            true,
        )
    }

    fn binary_call(&self, env: &mut Env, op: BinOp, a: Dual, b: Dual) -> (Dual, bool) {
        let code = helpers::binop_code(op) + PG_BINARY_BASE;
        (call_pg_lanes::<W>(env, code, a, Some(b)), true)
    }

    /// Where the value is NaN, the derivatives are NaN (when the rule
    /// asks for the select).
    fn finish(
        &self,
        env: &mut Env,
        (r, poison): (Dual, bool),
        _args: impl Iterator<Item = Dual>,
    ) -> Dual {
        if !poison {
            return r;
        }
        let isnan = W::test(env, FloatCC::Unordered, r[0], r[0]);
        let d = [1, 2, 3].map(|k| W::pick(env, isnan, self.nan, r[k]));
        [r[0], d[0], d[1], d[2]]
    }
}

/// The derivatives of `min`/`max` of value `v`: `b'` where `b cc a`
/// (`<` for `min`, `>` for `max`), else `a'` (the first operand on ties).
fn select<W: Width>(env: &mut Env, v: Value, cc: FloatCC, a: Dual, b: Dual) -> Dual {
    let second = W::test(env, cc, b[0], a[0]);
    let d = [1, 2, 3].map(|k| W::pick(env, second, b[k], a[k]));
    [v, d[0], d[1], d[2]]
}

/// Emits the body at width `W`; returns the output's dual.
fn lower<W: Width>(env: &mut Env, prog: &Program, input: [Value; 4]) -> Dual {
    let k = PointGradNum::<W>::new(env);
    body(env, &k, prog, input)
}

/// [`call_pg`] in each lane.
fn call_pg_lanes<W: Width>(env: &mut Env, code: u32, a: Dual, b: Option<Dual>) -> Dual {
    let args: Vec<Value> = a.iter().chain(b.iter().flatten()).copied().collect();
    let r = W::per_lane(env, &args, |env, lane| {
        let a = [lane[0], lane[1], lane[2], lane[3]];
        let b = b.map(|_| [lane[4], lane[5], lane[6], lane[7]]);
        call_pg(env, code, a, b).to_vec()
    });
    [r[0], r[1], r[2], r[3]]
}

/// Calls `isoc_pg_op(code, a, b, out)` through a 96-byte stack slot (`a` at
/// 0, `b` at 32, `out` at 64).
fn call_pg(env: &mut Env, code: u32, a: Dual, b: Option<Dual>) -> Dual {
    let slot = Env::lazy_slot(&mut env.b, &mut env.pg_slot, 96);
    let f = Env::flags();
    let ptr = env.ptr;
    let pa = env.b.ins().stack_addr(ptr, slot, 0);
    let pb = env.b.ins().stack_addr(ptr, slot, 32);
    let po = env.b.ins().stack_addr(ptr, slot, 64);
    for (k, &x) in a.iter().enumerate() {
        env.b.ins().store(f, x, pa, (8 * k) as i32);
    }
    if let Some(b) = b {
        for (k, &x) in b.iter().enumerate() {
            env.b.ins().store(f, x, pb, (8 * k) as i32);
        }
    }
    let c = env.code(code);
    env.call_void(Helper::PgOp, &[c, pa, pb, po]);
    [0, 1, 2, 3].map(|k| env.b.ins().load(types::F64, f, po, 8 * k))
}

/// Emits the batch entry point's body (`fn(xs, ys, zs, t, out, n)`): two
/// points per iteration with `simd` ([`super::simd`]'s loop), else one.
pub(super) fn emit_batch(env: &mut Env, prog: &Program, params: &[Value], simd: bool) {
    if simd {
        return emit_loop(env, params, |env, input| {
            lower::<X2>(env, prog, input).to_vec()
        });
    }
    let f = Env::flags();
    batch_loop(env, params[5], |env, i| {
        let off = env.b.ins().imul_imm_s(i, 8);
        let xyz = [0, 1, 2].map(|k| {
            let a = env.b.ins().iadd(params[k], off);
            env.b.ins().load(types::F64, f, a, 0)
        });
        let r = lower::<Scalar>(env, prog, [xyz[0], xyz[1], xyz[2], params[3]]);
        let out_off = env.b.ins().imul_imm_s(i, 32);
        let oa = env.b.ins().iadd(params[4], out_off);
        for (k, &x) in r.iter().enumerate() {
            env.b.ins().store(f, x, oa, (8 * k) as i32);
        }
    });
    env.b.ins().return_(&[]);
}
