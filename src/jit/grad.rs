//! Lowering of a [`Program`] to the interval-gradient body: forward-mode
//! automatic differentiation over intervals.
//!
//! Each IR value becomes four intervals `(F, Fx, Fy, Fz)` (eight f64 SSA
//! values); `var x` is `(X, [1,1], [0,0], [0,0])` (likewise `y`, `z`; `t`
//! has a zero gradient), constants have a zero gradient. `add sub neg mul
//! square abs sqrt min max`, `powi` with `0 < n ≤ 8` and `var`/`const` are
//! inline, with the interval kernel's outward rounded rules
//! ([`super::interval`]) and the reference's derivative rules
//! ([`crate::eval::grad`]: `abs`, `min`, `max` take the derivative of the
//! certain branch or the hull, flagged not differentiable; `d√a = da/(2√a)`,
//! flagged where `2√a` may be 0); every other op spills its operands to a
//! stack slot and calls a chain-rule helper ([`super::helpers`]) built on
//! [`crate::interval`]'s enclosures.
//!
//! Derivative components known at compile time to be exactly 0 or 1 (of
//! constants and variables, and what inline rules make of them) emit no
//! code: `[0,0] + b = b`, `x·[0,0] = [0,0]`, `x·[1,1] = x` hold exactly in
//! the kernel's arithmetic, so results are those of the dense rules.
//!
//! The decoration is false when some op on the output's dependency path was
//! not defined, continuous *or differentiable* on the whole box (`abs`,
//! `min`, `max` at a kink, `sqrt` at 0, …). As in
//! [`crate::eval::grad`], each value carries a value flag and a derivative
//! flag: `a^0` has derivative 0 whatever `a`'s derivatives were, so only
//! `a`'s value flag reaches it.

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value, types};

use super::interval::{self, Flag, Iv};
use super::{Env, rounding};
use crate::ir::{BinOp, Op, Program, UnOp};

/// `(F, Fx, Fy, Fz)`.
pub(super) type Dual = [Iv; 4];

/// A derivative component as the lowering knows it: exactly 0 or 1 at
/// compile time (nothing emitted: forward-mode AD with static sparsity),
/// or computed.
#[derive(Clone, Copy)]
enum D {
    Zero,
    One,
    V(Iv),
}

/// A value and its three derivative components.
#[derive(Clone, Copy)]
struct G {
    v: Iv,
    d: [D; 3],
    /// The value's bounds when it is a constant of known sign.
    k: Option<interval::Konst>,
}

/// The component as an interval in the kernel's `(−lo, hi)` form
/// (`[0, 0]` and `[1, 1]` from the SSA constants `0` and `(−1, 1)`).
fn iv_of(d: D, zero: Value, one: Iv) -> Iv {
    match d {
        D::Zero => (zero, zero),
        D::One => one,
        D::V(iv) => iv,
    }
}

/// `a ± b` on components. `[0,0] + b = b` and `b − [0,0] = b` exactly; a
/// known `1` is materialised.
fn d_add(env: &mut Env, sub: bool, a: D, b: D, zero: Value, one: Iv) -> D {
    match (a, b) {
        (x, D::Zero) => x,
        (D::Zero, y) if !sub => y,
        (D::Zero, y) => D::V(neg(iv_of(y, zero, one))),
        (x, y) => {
            let op = if sub { BinOp::Sub } else { BinOp::Add };
            D::V(interval::binary(env, op, iv_of(x, zero, one), iv_of(y, zero, one)).0)
        }
    }
}

/// `x · d` for an interval `x` and a component: `x · [0, 0] = [0, 0]` (0·∞
/// counts as 0 in interval arithmetic, as the kernel's product rule does)
/// and `x · [1, 1] = x`, exactly.
fn d_scale(env: &mut Env, x: Iv, xk: Option<interval::Konst>, d: D) -> D {
    match d {
        D::Zero => D::Zero,
        D::One => D::V(x),
        D::V(iv) => D::V(interval::mul_known(env, x, xk, iv, None)),
    }
}

/// `−[lo, hi] = [−hi, −lo]`: in `(−lo, hi)` form, a swap.
fn neg((n, h): Iv) -> Iv {
    (h, n)
}

/// `x / t` for `t = (−t_lo, t_hi)` with `pos` (i8) saying `t_lo > 0`:
/// each bound one quotient rounded up, the divisor bound chosen by the
/// sign of the dividend bound (`hi = h_x / (h_x ≥ 0 ? t_lo : t_hi)`,
/// `−lo = n_x / (n_x ≤ 0 ? t_hi : t_lo)`); the whole line when `t` may
/// reach 0.
fn div_by_positive(env: &mut Env, x: Iv, t: Iv, t_lo: Value, pos: Value) -> Iv {
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    let h_nonneg = b.ins().fcmp(FloatCC::GreaterThanOrEqual, x.1, zero);
    let yh = b.ins().select(h_nonneg, t_lo, t.1);
    let h = b.ins().fdiv(x.1, yh);
    let lo_nonneg = b.ins().fcmp(FloatCC::LessThanOrEqual, x.0, zero);
    let yn = b.ins().select(lo_nonneg, t.1, t_lo);
    let n = b.ins().fdiv(x.0, yn);
    let inf = b.ins().f64const(f64::INFINITY);
    (b.ins().select(pos, n, inf), b.ins().select(pos, h, inf))
}

/// `c ? x : y` on intervals.
fn select_iv(env: &mut Env, c: Value, x: Iv, y: Iv) -> Iv {
    (
        env.b.ins().select(c, x.0, y.0),
        env.b.ins().select(c, x.1, y.1),
    )
}

/// An inline rule's own flags in the helpers' encoding: bit 0 the value's
/// (`None`: true), bit 1 the derivatives' (an i8, 0 or 1).
fn own_flags(env: &mut Env, value: Option<Value>, deriv: Value) -> Value {
    let fv = value.unwrap_or_else(|| env.b.ins().iconst(types::I8, 1));
    let dv = env.b.ins().ishl_imm_u(deriv, 1);
    env.b.ins().bor(fv, dv)
}

/// Emits the body; returns the output tuple and the decoration (i8).
pub(super) fn lower(env: &mut Env, prog: &Program, input: [(Iv, Flag); 4]) -> (Dual, Value) {
    let flags_in: [Flag; 4] = input.map(|(_, f)| f);
    let input: [Iv; 4] = input.map(|(iv, _)| iv);
    let zero = env.b.ins().f64const(0.0);
    let one = (env.b.ins().f64const(-1.0), env.b.ins().f64const(1.0));
    let full = |g: G| -> Dual {
        [
            g.v,
            iv_of(g.d[0], zero, one),
            iv_of(g.d[1], zero, one),
            iv_of(g.d[2], zero, one),
        ]
    };
    let from = |r: Dual| G {
        v: r[0],
        d: [D::V(r[1]), D::V(r[2]), D::V(r[3])],
        k: None,
    };
    // Per value: the tuple, the value's flag F and the derivatives' flag D
    // (tracked apart as in the reference: `a^0` has derivative 0 whatever
    // `a`'s derivatives were).
    let mut vals: Vec<(G, Flag, Flag)> = Vec::with_capacity(prog.len());
    for (i, op) in prog.insts.iter().enumerate() {
        let (v, d): (G, Option<Value>) = match *op {
            Op::Var(var) => {
                let mut g = G {
                    v: input[var.index()],
                    d: [D::Zero; 3],
                    k: None,
                };
                if var.index() < 3 {
                    g.d[var.index()] = D::One;
                }
                (g, None)
            }
            Op::Const(_) => {
                let (v, d) = interval::lower_op(env, i, op, &[], &input);
                let k = interval::konst(prog, crate::ir::Value(i as u32));
                (
                    G {
                        v,
                        d: [D::Zero; 3],
                        k,
                    },
                    d,
                )
            }
            Op::Unary(UnOp::Neg, a) => {
                let a = vals[a.index()].0;
                let v = neg(a.v);
                let d = a.d.map(|c| match c {
                    D::Zero => D::Zero,
                    c => D::V(neg(iv_of(c, zero, one))),
                });
                (G { v, d, k: None }, None)
            }
            Op::Unary(UnOp::Square, a) => {
                let a = vals[a.index()].0;
                let (f, _) = interval::unary(env, UnOp::Square, a.v);
                // d(a²) = (2a)·da; doubling is exact but for overflow,
                // which goes outward: both `(−lo, hi)` halves round up.
                let two_a = (
                    rounding::add_up(&mut env.b, a.v.0, a.v.0),
                    rounding::add_up(&mut env.b, a.v.1, a.v.1),
                );
                let d = a.d.map(|c| d_scale(env, two_a, None, c));
                (G { v: f, d, k: None }, None)
            }
            Op::Binary(op @ (BinOp::Add | BinOp::Sub | BinOp::Mul), a, b) => {
                let (a, b) = (vals[a.index()].0, vals[b.index()].0);
                let g = if op == BinOp::Mul {
                    let v = interval::mul_known(env, a.v, a.k, b.v, b.k);
                    let d = std::array::from_fn(|k| {
                        let p = d_scale(env, a.v, a.k, b.d[k]);
                        let q = d_scale(env, b.v, b.k, a.d[k]);
                        d_add(env, false, p, q, zero, one)
                    });
                    G { v, d, k: None }
                } else {
                    let v = interval::binary(env, op, a.v, b.v).0;
                    let d = std::array::from_fn(|k| {
                        d_add(env, op == BinOp::Sub, a.d[k], b.d[k], zero, one)
                    });
                    G { v, d, k: None }
                };
                (g, None)
            }
            Op::Powi(a, n) if (1..=interval::INLINE_POWI_MAX).contains(&n) => {
                // d(aⁿ) = (n·aⁿ⁻¹)·da, with the interval kernel's inline
                // powers (the reference's rule, inline).
                let a = vals[a.index()].0;
                let v = interval::powi(env, a.v, n as u64);
                let d = if n == 1 {
                    a.d
                } else {
                    let p = interval::powi(env, a.v, (n - 1) as u64);
                    let c = (
                        env.b.ins().f64const(-(n as f64)),
                        env.b.ins().f64const(n as f64),
                    );
                    let k = interval::Konst {
                        lo: n as f64,
                        hi: n as f64,
                    };
                    let f = interval::mul_by_konst(env, p, c, k);
                    a.d.map(|c| d_scale(env, f, None, c))
                };
                (G { v, d, k: None }, None)
            }
            Op::Unary(UnOp::Abs, a) => {
                // The reference's rule: `da` where a > 0, `−da` where
                // a < 0, else `[−m, m]` with `m = max |da|`, not
                // differentiable.
                let a = vals[a.index()].0;
                let (v, _) = interval::unary(env, UnOp::Abs, a.v);
                let zero = env.b.ins().f64const(0.0);
                let lo = env.b.ins().fneg(a.v.0);
                let pos = env.b.ins().fcmp(FloatCC::GreaterThan, lo, zero);
                let neg_ = env.b.ins().fcmp(FloatCC::LessThan, a.v.1, zero);
                let sure = env.b.ins().bor(pos, neg_);
                let d = a.d.map(|c| match c {
                    D::Zero => D::Zero,
                    c => {
                        let x = iv_of(c, zero, one);
                        let m = env.b.ins().fmax(x.0, x.1);
                        let nx = neg(x);
                        let r = select_iv(env, neg_, nx, (m, m));
                        D::V(select_iv(env, pos, x, r))
                    }
                });
                (G { v, d, k: None }, Some(own_flags(env, None, sure)))
            }
            Op::Binary(op @ (BinOp::Min | BinOp::Max), a, b) => {
                // The reference's rule: the derivative of the operand
                // that is certainly chosen, else the hull of both, not
                // differentiable.
                let (a, b) = (vals[a.index()].0, vals[b.index()].0);
                let (v, _) = interval::binary(env, op, a.v, b.v);
                let (lo_a, lo_b) = (env.b.ins().fneg(a.v.0), env.b.ins().fneg(b.v.0));
                let (first, second) = if op == BinOp::Min {
                    (
                        env.b.ins().fcmp(FloatCC::LessThan, a.v.1, lo_b),
                        env.b.ins().fcmp(FloatCC::LessThan, b.v.1, lo_a),
                    )
                } else {
                    (
                        env.b.ins().fcmp(FloatCC::GreaterThan, lo_a, b.v.1),
                        env.b.ins().fcmp(FloatCC::GreaterThan, lo_b, a.v.1),
                    )
                };
                let sure = env.b.ins().bor(first, second);
                let zero = env.b.ins().f64const(0.0);
                let d = std::array::from_fn(|k| match (a.d[k], b.d[k]) {
                    (D::Zero, D::Zero) => D::Zero,
                    (x, y) => {
                        let (x, y) = (iv_of(x, zero, one), iv_of(y, zero, one));
                        let hull = (env.b.ins().fmax(x.0, y.0), env.b.ins().fmax(x.1, y.1));
                        let r = select_iv(env, second, y, hull);
                        D::V(select_iv(env, first, x, r))
                    }
                });
                (G { v, d, k: None }, Some(own_flags(env, None, sure)))
            }
            Op::Unary(UnOp::Sqrt, a) => {
                // d√a = da / (2√a), the reference's rule, inline: value
                // flag "a ≥ 0 on the box", derivative flag "2√a > 0".
                let a = vals[a.index()].0;
                let (v, fv) = interval::unary(env, UnOp::Sqrt, a.v);
                let t = (
                    rounding::add_up(&mut env.b, v.0, v.0),
                    rounding::add_up(&mut env.b, v.1, v.1),
                );
                let zero = env.b.ins().f64const(0.0);
                let t_lo = env.b.ins().fneg(t.0);
                let pos = env.b.ins().fcmp(
                    cranelift_codegen::ir::condcodes::FloatCC::GreaterThan,
                    t_lo,
                    zero,
                );
                let d = a.d.map(|c| match c {
                    D::Zero => D::Zero,
                    c => D::V(div_by_positive(env, iv_of(c, zero, one), t, t_lo, pos)),
                });
                (G { v, d, k: None }, Some(own_flags(env, fv, pos)))
            }
            Op::Unary(u, a) => {
                let (r, d) = env.call_gd(
                    super::helpers::unop_code(u),
                    full(vals[a.index()].0),
                    None,
                    0,
                );
                (from(r), d)
            }
            Op::Binary(op, a, b) => {
                let (r, d) = env.call_gd(
                    super::helpers::binop_code(op) + GD_BINARY_BASE,
                    full(vals[a.index()].0),
                    Some(full(vals[b.index()].0)),
                    0,
                );
                (from(r), d)
            }
            Op::Powi(a, n) => {
                let (r, d) = env.call_gd(
                    super::helpers::GD_POWI_CODE + GD_BINARY_BASE,
                    full(vals[a.index()].0),
                    None,
                    n,
                );
                (from(r), d)
            }
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
    (full(g), interval::flag_value(env, ok))
}

/// Codes at or above this go to the binary gradient helper (minus it).
pub(super) const GD_BINARY_BASE: u32 = 1 << 16;
