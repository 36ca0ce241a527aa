//! Lowering of a [`Program`] to the f64 point body.
//!
//! `neg abs sqrt square add sub mul div min max powi` are inline IEEE
//! operations (with the IR's NaN rules: `a / ±0` is NaN, `min`/`max`
//! propagate NaN); `exp log sin cos tan asin acos atan atan2 pow` call the
//! reference evaluator's per-op functions through [`super::helpers`], so the
//! JIT's point values are bit for bit the interpreter's.
//!
//! `powi a n` is computed by right-to-left binary exponentiation: the
//! running product starts at the lowest set bit's power of `a` and each
//! further set bit multiplies it by the current square, `a^-n = 1 / a^n`,
//! `a^0 = 1`.

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value};

use super::Env;
use crate::ir::{BinOp, Op, Program, UnOp};

/// Emits the body; returns the output value.
pub(super) fn lower(env: &mut Env, prog: &Program, input: [Value; 4]) -> Value {
    let mut vals: Vec<Value> = Vec::with_capacity(prog.len());
    for (i, op) in prog.insts.iter().enumerate() {
        let v = match *op {
            Op::Var(var) => input[var.index()],
            Op::Const(_) => env.pool_load(i, 0),
            Op::Unary(u, a) => {
                let a = vals[a.index()];
                match u {
                    UnOp::Neg => env.b.ins().fneg(a),
                    UnOp::Abs => env.b.ins().fabs(a),
                    UnOp::Sqrt => env.b.ins().sqrt(a),
                    UnOp::Square => env.b.ins().fmul(a, a),
                    _ => env.call_pt_unary(u, a),
                }
            }
            Op::Binary(op, a, b) => {
                let (a, b) = (vals[a.index()], vals[b.index()]);
                let ins = env.b.ins();
                match op {
                    BinOp::Add => ins.fadd(a, b),
                    BinOp::Sub => ins.fsub(a, b),
                    BinOp::Mul => ins.fmul(a, b),
                    BinOp::Div => div_nan(env, a, b),
                    BinOp::Min => ins.fmin(a, b),
                    BinOp::Max => ins.fmax(a, b),
                    BinOp::Atan2
                    | BinOp::Pow
                    | BinOp::Compare
                    | BinOp::Mod
                    | BinOp::And
                    | BinOp::Or => env.call_pt_binary(op, a, b),
                }
            }
            Op::Powi(a, n) => {
                let a = vals[a.index()];
                if n == 0 {
                    env.pool_load(i, 0)
                } else {
                    let p = powi_chain(env, a, n.unsigned_abs());
                    if n < 0 {
                        let one = env.pool_load(i, 0);
                        div_nan(env, one, p)
                    } else {
                        p
                    }
                }
            }
        };
        vals.push(v);
    }
    vals[prog.output.index()]
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
