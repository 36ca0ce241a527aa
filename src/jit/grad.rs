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
//! certain branch or the hull, flagged not differentiable — `min`/`max`
//! by a branch to the certain operand's components, the hull on the rare
//! third path, or by selects under the single-pass register allocator,
//! which spills at every join; `d√a = da/(2√a)`,
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
//!
//! The rules are [`GradNum`]'s, the interval-gradient kind of the one
//! lowering ([`super::lower`]): each op's value by the interval kind's
//! functions ([`super::interval`]), its derivatives by the rules here.

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{BlockArg, InstBuilder, Value, types};

use super::interval::{self, Flag, Iv};
use super::lower::{NumKind, body};
use super::{Env, helpers, rounding};
use crate::ir::{BinOp, Const, Program, UnOp, Var};

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

/// A value: its interval, its three derivative components, its value and
/// derivative flags (as a rule's result, the op's own) and, for a constant
/// of known sign, its bounds at compile time.
#[derive(Clone, Copy)]
struct G {
    v: Iv,
    d: [D; 3],
    k: Option<interval::Konst>,
    /// "Defined and continuous on the box".
    fv: Flag,
    /// "Derivatives defined", tracked apart as in the reference: `a^0` has
    /// derivative 0 whatever `a`'s derivatives were.
    fd: Flag,
}

impl G {
    fn new(v: Iv, d: [D; 3]) -> G {
        G {
            v,
            d,
            k: None,
            fv: None,
            fd: None,
        }
    }
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
        (D::Zero, y) => D::V(interval::neg(iv_of(y, zero, one))),
        (x, y) => {
            let (x, y) = (iv_of(x, zero, one), iv_of(y, zero, one));
            D::V(if sub {
                interval::sub(env, x, y)
            } else {
                interval::add(env, x, y)
            })
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

/// The hull of two intervals in `(−lo, hi)` form: the larger of each.
fn hull_iv(env: &mut Env, x: Iv, y: Iv) -> Iv {
    (env.b.ins().fmax(x.0, y.0), env.b.ins().fmax(x.1, y.1))
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

/// `g` with the own flags `r` in the helpers' encoding (bit 0 the value's,
/// bit 1 the derivatives').
fn with_flags(env: &mut Env, g: G, r: Value) -> G {
    let b = &mut env.b;
    let fv = b.ins().band_imm_u(r, 1);
    let fd = b.ins().ushr_imm_u(r, 1);
    G {
        fv: Some(fv),
        fd: Some(fd),
        ..g
    }
}

/// The interval-gradient kind of the one lowering ([`super::lower`]),
/// holding the SSA constants `0` and `[1, 1]` that known components
/// materialise as.
struct GradNum {
    zero: Value,
    one: Iv,
}

impl GradNum {
    /// Emits the constants.
    fn new(env: &mut Env) -> GradNum {
        let zero = env.b.ins().f64const(0.0);
        let one = (env.b.ins().f64const(-1.0), env.b.ins().f64const(1.0));
        GradNum { zero, one }
    }

    /// The tuple as four intervals.
    fn full(&self, g: G) -> Dual {
        let c = |d| iv_of(d, self.zero, self.one);
        [g.v, c(g.d[0]), c(g.d[1]), c(g.d[2])]
    }

    /// A helper's result `r` with its flags `f` (helpers' encoding).
    fn from(&self, env: &mut Env, (r, f): (Dual, Option<Value>)) -> G {
        let g = G::new(r[0], [D::V(r[1]), D::V(r[2]), D::V(r[3])]);
        match f {
            Some(f) => with_flags(env, g, f),
            None => g,
        }
    }

    /// `min` (`is_min`) or `max`, the reference's rule: the derivative of
    /// the operand that is certainly chosen, else the hull of both, not
    /// differentiable.
    fn select(&self, env: &mut Env, is_min: bool, a: G, b: G) -> (G, bool) {
        let v = if is_min {
            interval::min(env, a.v, b.v)
        } else {
            interval::max(env, a.v, b.v)
        };
        let (lo_a, lo_b) = (env.b.ins().fneg(a.v.0), env.b.ins().fneg(b.v.0));
        let (first, second) = if is_min {
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
        // The components to choose between (both known zero: nothing to
        // choose).
        let live: Vec<(usize, Iv, Iv)> = (0..3)
            .filter(|&k| !matches!((a.d[k], b.d[k]), (D::Zero, D::Zero)))
            .map(|k| {
                (
                    k,
                    iv_of(a.d[k], zero, self.one),
                    iv_of(b.d[k], zero, self.one),
                )
            })
            .collect();
        let mut d = [D::Zero; 3];
        if !env.cheap_joins {
            // Selects: under the single-pass register allocator every
            // join would spill all live values.
            for &(k, x, y) in &live {
                let hull = hull_iv(env, x, y);
                let r = select_iv(env, second, y, hull);
                d[k] = D::V(select_iv(env, first, x, r));
            }
        } else if !live.is_empty() {
            // A branch, not selects: in a CSG model one operand is
            // nearly always the certain one, and the hull is the rare
            // case. All three paths join with the chosen components as
            // block parameters.
            let join = env.b.create_block();
            let pick_b = env.b.create_block();
            let not_a = env.b.create_block();
            let hull = env.b.create_block();
            for _ in 0..2 * live.len() {
                env.b.append_block_param(join, types::F64);
            }
            let args = |ivs: &mut dyn Iterator<Item = Iv>| -> Vec<BlockArg> {
                ivs.flat_map(|(n, h)| [BlockArg::from(n), BlockArg::from(h)])
                    .collect()
            };
            let from_a = args(&mut live.iter().map(|c| c.1));
            env.b.ins().brif(first, join, &from_a, not_a, &[]);
            env.b.switch_to_block(not_a);
            env.b.ins().brif(second, pick_b, &[], hull, &[]);
            env.b.switch_to_block(pick_b);
            let from_b = args(&mut live.iter().map(|c| c.2));
            env.b.ins().jump(join, &from_b);
            env.b.switch_to_block(hull);
            let hulls: Vec<Iv> = live.iter().map(|&(_, x, y)| hull_iv(env, x, y)).collect();
            env.b.ins().jump(join, &args(&mut hulls.into_iter()));
            env.b.switch_to_block(join);
            let params = env.b.block_params(join).to_vec();
            for (j, &(k, _, _)) in live.iter().enumerate() {
                d[k] = D::V((params[2 * j], params[2 * j + 1]));
            }
        }
        // Own flags: the value is always defined; the derivatives where
        // the choice is certain.
        let g = G {
            fv: None,
            fd: Some(sure),
            ..G::new(v, d)
        };
        (g, true)
    }
}

impl NumKind for GradNum {
    type In = (Iv, Flag);
    type V = G;
    /// The rule's tuple with its own flags, and whether the operands'
    /// derivative flags reach it (not for `a^0`).
    type Out = (G, bool);

    fn var(&self, _env: &mut Env, var: Var, (v, fv): (Iv, Flag)) -> (G, bool) {
        let mut d = [D::Zero; 3];
        if var.index() < 3 {
            d[var.index()] = D::One;
        }
        (G { fv, ..G::new(v, d) }, true)
    }

    fn konst(&self, env: &mut Env, i: usize, c: Const) -> (G, bool) {
        let (v, fv) = interval::constant(env, i, c);
        let g = G {
            k: interval::Konst::of(c),
            fv,
            ..G::new(v, [D::Zero; 3])
        };
        (g, true)
    }

    fn neg(&self, _env: &mut Env, a: G) -> (G, bool) {
        let d = a.d.map(|c| match c {
            D::Zero => D::Zero,
            c => D::V(interval::neg(iv_of(c, self.zero, self.one))),
        });
        (G::new(interval::neg(a.v), d), true)
    }

    fn square(&self, env: &mut Env, a: G) -> (G, bool) {
        let f = interval::square(env, a.v);
        // d(a²) = (2a)·da; doubling is exact but for overflow, which goes
        // outward: both `(−lo, hi)` halves round up.
        let two_a = (
            rounding::add_up(&mut env.b, a.v.0, a.v.0),
            rounding::add_up(&mut env.b, a.v.1, a.v.1),
        );
        let d = a.d.map(|c| d_scale(env, two_a, None, c));
        (G::new(f, d), true)
    }

    fn add(&self, env: &mut Env, a: G, b: G) -> (G, bool) {
        let v = interval::add(env, a.v, b.v);
        let d = std::array::from_fn(|k| d_add(env, false, a.d[k], b.d[k], self.zero, self.one));
        (G::new(v, d), true)
    }

    fn sub(&self, env: &mut Env, a: G, b: G) -> (G, bool) {
        let v = interval::sub(env, a.v, b.v);
        let d = std::array::from_fn(|k| d_add(env, true, a.d[k], b.d[k], self.zero, self.one));
        (G::new(v, d), true)
    }

    /// `(ab)' = a·b' + b·a'`.
    fn mul(&self, env: &mut Env, a: G, b: G) -> (G, bool) {
        let v = interval::mul_known(env, a.v, a.k, b.v, b.k);
        let d = std::array::from_fn(|k| {
            let p = d_scale(env, a.v, a.k, b.d[k]);
            let q = d_scale(env, b.v, b.k, a.d[k]);
            d_add(env, false, p, q, self.zero, self.one)
        });
        (G::new(v, d), true)
    }

    /// d(aⁿ) = (n·aⁿ⁻¹)·da with the interval kernel's inline powers for
    /// `1 ≤ n ≤ 8` (the reference's rule, inline), else the helper.
    fn powi(&self, env: &mut Env, _i: usize, a: G, n: i64) -> (G, bool) {
        if !(1..=interval::INLINE_POWI_MAX).contains(&n) {
            let r = env.call_gd(
                helpers::GD_POWI_CODE + GD_BINARY_BASE,
                self.full(a),
                None,
                n,
            );
            return (self.from(env, r), n != 0);
        }
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
        (G::new(v, d), true)
    }

    /// The reference's rule: `da` where a > 0, `−da` where a < 0, else
    /// `[−m, m]` with `m = max |da|`, not differentiable.
    fn abs(&self, env: &mut Env, a: G) -> (G, bool) {
        let v = interval::abs(env, a.v);
        let zero = env.b.ins().f64const(0.0);
        let lo = env.b.ins().fneg(a.v.0);
        let pos = env.b.ins().fcmp(FloatCC::GreaterThan, lo, zero);
        let neg_ = env.b.ins().fcmp(FloatCC::LessThan, a.v.1, zero);
        let sure = env.b.ins().bor(pos, neg_);
        let d = a.d.map(|c| match c {
            D::Zero => D::Zero,
            c => {
                let x = iv_of(c, zero, self.one);
                let m = env.b.ins().fmax(x.0, x.1);
                let nx = interval::neg(x);
                let r = select_iv(env, neg_, nx, (m, m));
                D::V(select_iv(env, pos, x, r))
            }
        });
        let f = own_flags(env, None, sure);
        (with_flags(env, G::new(v, d), f), true)
    }

    fn min(&self, env: &mut Env, a: G, b: G) -> (G, bool) {
        self.select(env, true, a, b)
    }

    fn max(&self, env: &mut Env, a: G, b: G) -> (G, bool) {
        self.select(env, false, a, b)
    }

    /// d√a = da / (2√a), the reference's rule, inline: value flag "a ≥ 0
    /// on the box", derivative flag "2√a > 0".
    fn sqrt(&self, env: &mut Env, a: G) -> (G, bool) {
        let (v, fv) = interval::sqrt(env, a.v);
        let t = (
            rounding::add_up(&mut env.b, v.0, v.0),
            rounding::add_up(&mut env.b, v.1, v.1),
        );
        let zero = env.b.ins().f64const(0.0);
        let t_lo = env.b.ins().fneg(t.0);
        let pos = env.b.ins().fcmp(FloatCC::GreaterThan, t_lo, zero);
        let d = a.d.map(|c| match c {
            D::Zero => D::Zero,
            c => D::V(div_by_positive(env, iv_of(c, zero, self.one), t, t_lo, pos)),
        });
        let f = own_flags(env, fv, pos);
        (with_flags(env, G::new(v, d), f), true)
    }

    fn unary_call(&self, env: &mut Env, u: UnOp, a: G) -> (G, bool) {
        let r = env.call_gd(helpers::unop_code(u), self.full(a), None, 0);
        (self.from(env, r), true)
    }

    fn binary_call(&self, env: &mut Env, op: BinOp, a: G, b: G) -> (G, bool) {
        let r = env.call_gd(
            helpers::binop_code(op) + GD_BINARY_BASE,
            self.full(a),
            Some(self.full(b)),
            0,
        );
        (self.from(env, r), true)
    }

    /// The own flags AND the operands' (value flags always, derivative
    /// flags unless the rule said otherwise).
    fn finish(&self, env: &mut Env, (g, reads_d): (G, bool), args: impl Iterator<Item = G>) -> G {
        let (mut fv, mut fd) = (g.fv, g.fd);
        for a in args {
            fv = interval::and(env, fv, a.fv);
            if reads_d {
                fd = interval::and(env, fd, a.fd);
            }
        }
        G { fv, fd, ..g }
    }
}

/// Emits the body; returns the output tuple and the decoration (i8).
pub(super) fn lower(env: &mut Env, prog: &Program, input: [(Iv, Flag); 4]) -> (Dual, Value) {
    let k = GradNum::new(env);
    let g = body(env, &k, prog, input);
    let ok = interval::and(env, g.fv, g.fd);
    (k.full(g), interval::flag_value(env, ok))
}

/// Codes at or above this go to the binary gradient helper (minus it).
pub(super) const GD_BINARY_BASE: u32 = 1 << 16;
