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
//! - **values** are lowered as in the point kernel ([`super::point`]):
//!   same inline operations, same constant-pool loads, same helpers;
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

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value, types};

use super::Env;
use super::batch_loop;
use super::helpers::{self, Helper, PG_BINARY_BASE};
use super::point::{div_nan, powi_chain};
use crate::ir::{BinOp, Op, Program, UnOp};

/// `(v, ∂x, ∂y, ∂z)`.
pub(super) type Dual = [Value; 4];

/// Emits the body; returns the output's dual.
pub(super) fn lower(env: &mut Env, prog: &Program, input: [Value; 4]) -> Dual {
    let zero = env.b.ins().f64const(0.0);
    let one = env.b.ins().f64const(1.0);
    let two = env.b.ins().f64const(2.0);
    let nan = env.b.ins().f64const(f64::NAN);
    let mut vals: Vec<Dual> = Vec::with_capacity(prog.len());
    for (i, op) in prog.insts.iter().enumerate() {
        let (r, poison) = match *op {
            Op::Var(var) => {
                let mut r = [input[var.index()], zero, zero, zero];
                if var.index() < 3 {
                    r[1 + var.index()] = one;
                }
                (r, true)
            }
            Op::Const(c) => {
                let v = env.pool_load(i, 0);
                let d = if c.value.is_nan() { nan } else { zero };
                ([v, d, d, d], false)
            }
            Op::Unary(u, a) => {
                let a = vals[a.index()];
                unary(env, u, a, two)
            }
            Op::Binary(op, a, b) => {
                let (a, b) = (vals[a.index()], vals[b.index()]);
                (binary(env, op, a, b), true)
            }
            Op::Powi(a, n) => {
                let a = vals[a.index()];
                let v = if n == 0 {
                    env.pool_load(i, 0)
                } else {
                    let p = powi_chain(env, a[0], n.unsigned_abs());
                    if n < 0 {
                        let one = env.pool_load(i, 0);
                        div_nan(env, one, p)
                    } else {
                        p
                    }
                };
                if n == 0 {
                    ([v, zero, zero, zero], false)
                } else if let Some(m) = n.checked_sub(1) {
                    let p = match m {
                        0 => one,
                        m if m > 0 => powi_chain(env, a[0], m as u64),
                        m => {
                            let q = powi_chain(env, a[0], m.unsigned_abs());
                            div_nan(env, one, q)
                        }
                    };
                    let nf = env.b.ins().f64const(n as f64);
                    let f = env.b.ins().fmul(nf, p);
                    let d = [1, 2, 3].map(|k| env.b.ins().fmul(f, a[k]));
                    ([v, d[0], d[1], d[2]], true)
                } else {
                    ([v, nan, nan, nan], true)
                }
            }
        };
        let r = if poison {
            let isnan = env.b.ins().fcmp(FloatCC::Unordered, r[0], r[0]);
            let d = [1, 2, 3].map(|k| env.b.ins().select(isnan, nan, r[k]));
            [r[0], d[0], d[1], d[2]]
        } else {
            r
        };
        vals.push(r);
    }
    vals[prog.output.index()]
}

/// A unary op; returns the dual and whether it needs the NaN select.
fn unary(env: &mut Env, u: UnOp, a: Dual, two: Value) -> (Dual, bool) {
    match u {
        UnOp::Neg => (a.map(|x| env.b.ins().fneg(x)), false),
        UnOp::Abs => {
            let v = env.b.ins().fabs(a[0]);
            let zero = env.b.ins().f64const(0.0);
            let neg = env.b.ins().fcmp(FloatCC::LessThan, a[0], zero);
            let d = [1, 2, 3].map(|k| {
                let m = env.b.ins().fneg(a[k]);
                env.b.ins().select(neg, m, a[k])
            });
            ([v, d[0], d[1], d[2]], false)
        }
        UnOp::Sqrt => {
            let v = env.b.ins().sqrt(a[0]);
            let two_v = env.b.ins().fmul(two, v);
            let d = [1, 2, 3].map(|k| div_nan(env, a[k], two_v));
            ([v, d[0], d[1], d[2]], false)
        }
        UnOp::Square => {
            let v = env.b.ins().fmul(a[0], a[0]);
            let two_a = env.b.ins().fmul(two, a[0]);
            let d = [1, 2, 3].map(|k| env.b.ins().fmul(two_a, a[k]));
            ([v, d[0], d[1], d[2]], false)
        }
        _ => (call_pg(env, helpers::unop_code(u), a, None), true),
    }
}

/// A binary op (always followed by the NaN select).
fn binary(env: &mut Env, op: BinOp, a: Dual, b: Dual) -> Dual {
    let mut r = [a[0]; 4];
    match op {
        BinOp::Add | BinOp::Sub => {
            for k in 0..4 {
                r[k] = if op == BinOp::Add {
                    env.b.ins().fadd(a[k], b[k])
                } else {
                    env.b.ins().fsub(a[k], b[k])
                };
            }
        }
        BinOp::Mul => {
            r[0] = env.b.ins().fmul(a[0], b[0]);
            for k in 1..4 {
                let p = env.b.ins().fmul(a[k], b[0]);
                let q = env.b.ins().fmul(a[0], b[k]);
                r[k] = env.b.ins().fadd(p, q);
            }
        }
        BinOp::Div => {
            r[0] = div_nan(env, a[0], b[0]);
            for k in 1..4 {
                let p = env.b.ins().fmul(r[0], b[k]);
                let q = env.b.ins().fsub(a[k], p);
                r[k] = div_nan(env, q, b[0]);
            }
        }
        BinOp::Min | BinOp::Max => {
            let (v, cc) = if op == BinOp::Min {
                (env.b.ins().fmin(a[0], b[0]), FloatCC::LessThan)
            } else {
                (env.b.ins().fmax(a[0], b[0]), FloatCC::GreaterThan)
            };
            r[0] = v;
            let second = env.b.ins().fcmp(cc, b[0], a[0]);
            for k in 1..4 {
                r[k] = env.b.ins().select(second, b[k], a[k]);
            }
        }
        BinOp::Atan2 | BinOp::Pow | BinOp::Compare | BinOp::Mod | BinOp::And | BinOp::Or => {
            r = call_pg(env, helpers::binop_code(op) + PG_BINARY_BASE, a, Some(b));
        }
    }
    r
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

/// Emits the batch entry point's body (`fn(xs, ys, zs, t, out, n)`).
pub(super) fn emit_batch(env: &mut Env, prog: &Program, params: &[Value]) {
    let f = Env::flags();
    batch_loop(env, params[5], |env, i| {
        let off = env.b.ins().imul_imm_s(i, 8);
        let xyz = [0, 1, 2].map(|k| {
            let a = env.b.ins().iadd(params[k], off);
            env.b.ins().load(types::F64, f, a, 0)
        });
        let r = lower(env, prog, [xyz[0], xyz[1], xyz[2], params[3]]);
        let out_off = env.b.ins().imul_imm_s(i, 32);
        let oa = env.b.ins().iadd(params[4], out_off);
        for (k, &x) in r.iter().enumerate() {
            env.b.ins().store(f, x, oa, (8 * k) as i32);
        }
    });
    env.b.ins().return_(&[]);
}
