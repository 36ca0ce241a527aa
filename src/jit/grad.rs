//! Lowering of a [`Program`] to the interval-gradient body: forward-mode
//! automatic differentiation over intervals.
//!
//! Each IR value becomes four intervals `(F, Fx, Fy, Fz)` (eight f64 SSA
//! values); `var x` is `(X, [1,1], [0,0], [0,0])` (likewise `y`, `z`; `t`
//! has a zero gradient), constants have a zero gradient. `add sub neg mul
//! square` and `var`/`const` are inline, with the interval kernel's outward
//! rounded rules ([`super::interval`]); every other op spills its operands
//! to a stack slot and calls a chain-rule helper ([`super::helpers`]) built
//! on [`crate::interval`]'s enclosures.
//!
//! The decoration is false when some op on the output's dependency path was
//! not defined, continuous *or differentiable* on the whole box (`abs`,
//! `min`, `max` at a kink, `sqrt` at 0, …). As in
//! [`crate::eval::grad`], each value carries a value flag and a derivative
//! flag: `a^0` has derivative 0 whatever `a`'s derivatives were, so only
//! `a`'s value flag reaches it.

use cranelift_codegen::ir::{InstBuilder, Value};

use super::{Env, rounding};
use super::interval::{self, Flag, Iv};
use crate::ir::{BinOp, Op, Program, UnOp};

/// `(F, Fx, Fy, Fz)`.
pub(super) type Dual = [Iv; 4];

/// Emits the body; returns the output tuple and the decoration (i8).
pub(super) fn lower(env: &mut Env, prog: &Program, input: [(Iv, Flag); 4]) -> (Dual, Value) {
    let flags_in: [Flag; 4] = input.map(|(_, f)| f);
    let input: [Iv; 4] = input.map(|(iv, _)| iv);
    let zero = env.b.ins().f64const(0.0);
    let one = env.b.ins().f64const(1.0);
    let z = (zero, zero);
    // Per value: the tuple, the value's flag F and the derivatives' flag D
    // (tracked apart as in the reference: `a^0` has derivative 0 whatever
    // `a`'s derivatives were).
    let mut vals: Vec<(Dual, Flag, Flag)> = Vec::with_capacity(prog.len());
    for (i, op) in prog.insts.iter().enumerate() {
        let (v, d): (Dual, Option<Value>) = match *op {
            Op::Var(var) => {
                let mut g = [input[var.index()], z, z, z];
                if var.index() < 3 {
                    g[1 + var.index()] = (one, one);
                }
                (g, None)
            }
            Op::Const(_) => {
                let (v, d) = interval::lower_op(env, i, op, &[], &input);
                ([v, z, z, z], d)
            }
            Op::Unary(UnOp::Neg, a) => {
                let a = vals[a.index()].0;
                (
                    a.map(|(l, h)| (env.b.ins().fneg(h), env.b.ins().fneg(l))),
                    None,
                )
            }
            Op::Unary(UnOp::Square, a) => {
                let a = vals[a.index()].0;
                let (f, _) = interval::unary(env, UnOp::Square, a[0]);
                // d(a²) = (2a)·da; doubling is exact but for overflow,
                // which must go outward: the lower bound rounded down.
                let two_a = (
                    rounding::add_down(&mut env.b, a[0].0, a[0].0),
                    rounding::add_up(&mut env.b, a[0].1, a[0].1),
                );
                let mut g = [f, z, z, z];
                for k in 1..4 {
                    g[k] = interval::mul(env, two_a, a[k]);
                }
                (g, None)
            }
            Op::Binary(op @ (BinOp::Add | BinOp::Sub | BinOp::Mul), a, b) => {
                let (a, b) = (vals[a.index()].0, vals[b.index()].0);
                let mut g = [z; 4];
                if op == BinOp::Mul {
                    g[0] = interval::mul(env, a[0], b[0]);
                    for k in 1..4 {
                        let p = interval::mul(env, a[0], b[k]);
                        let q = interval::mul(env, a[k], b[0]);
                        g[k] = interval::binary(env, BinOp::Add, p, q).0;
                    }
                } else {
                    for k in 0..4 {
                        g[k] = interval::binary(env, op, a[k], b[k]).0;
                    }
                }
                (g, None)
            }
            Op::Unary(u, a) => {
                env.call_gd(super::helpers::unop_code(u), vals[a.index()].0, None, 0)
            }
            Op::Binary(op, a, b) => env.call_gd(
                super::helpers::binop_code(op) + GD_BINARY_BASE,
                vals[a.index()].0,
                Some(vals[b.index()].0),
                0,
            ),
            Op::Powi(a, n) => env.call_gd(
                super::helpers::GD_POWI_CODE + GD_BINARY_BASE,
                vals[a.index()].0,
                None,
                n,
            ),
        };
        // Own flags: the helpers return bit 0 = value defined, bit 1 =
        // derivatives defined; inline ops only have a value flag.
        let (mut f, mut dd) = match (*op, d) {
            (Op::Var(var), _) => (flags_in[var.index()], None),
            (Op::Unary(..) | Op::Binary(..) | Op::Powi(..), Some(r))
                if !matches!(
                    op,
                    Op::Unary(UnOp::Neg | UnOp::Square, _)
                        | Op::Binary(BinOp::Add | BinOp::Sub | BinOp::Mul, _, _)
                ) =>
            {
                let b = &mut env.b;
                let fv = b.ins().band_imm_u(r, 1);
                let dv = b.ins().ushr_imm_u(r, 1);
                (Some(fv), Some(dv))
            }
            (_, d) => (d, None),
        };
        for a in op.args() {
            let (_, fa, da) = vals[a.index()];
            f = interval::and(env, f, fa);
            if !matches!(op, Op::Powi(_, 0)) {
                dd = interval::and(env, dd, da);
            }
        }
        vals.push((v, f, dd));
    }
    let (g, f, dd) = vals[prog.output.index()];
    let ok = interval::and(env, f, dd);
    (g, interval::flag_value(env, ok))
}

/// Codes at or above this go to the binary gradient helper (minus it).
pub(super) const GD_BINARY_BASE: u32 = 1 << 16;
