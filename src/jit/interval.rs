//! Lowering of a [`Program`] to the interval body.
//!
//! Each IR value becomes two f64 SSA values `(lo, hi)`, plus one `i8`
//! accumulator for the decoration "defined and continuous on the whole box"
//! (the AND of every op's flag).
//!
//! Inline, outward rounded with [`super::rounding`] (the kernel runs in
//! round-toward-+∞ mode; a lower bound is `RD(x) = −RU(−x)`):
//!
//! | op | rule |
//! |---|---|
//! | `neg`, `min`, `max` | exact bound arithmetic |
//! | `abs` | `[max(0, lo, −hi), max(−lo, hi)]`, exact |
//! | `add`, `sub` | `[RD(al + bl), RU(ah + bh)]`, `[RD(al − bh), RU(ah − bl)]` |
//! | `mul` | `[−max RU(−x·y), max RU(x·y)]` over the four bound pairs (a NaN product `0·∞` counts as 0) |
//! | `square` | `[RD(mig²), RU(mag²)]` |
//! | `sqrt` | `[RD(√max(lo,0)), RU(√hi)]`, empty when `hi < 0`; defined iff `lo ≥ 0` |
//! | `powi a n`, `1 ≤ n ≤ 8` | exact monotone rules on `mig`/`mag` (even `n`) or the signed bounds (odd `n`), each product of the repeated squaring rounded in its direction |
//!
//! Everything else (`div`, other `powi`, transcendentals, `atan2`,
//! `pow`) calls [`crate::interval`]'s per-op enclosures through
//! [`super::helpers`], which return the op's decoration.

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value, types};

use super::{Env, rounding};
use crate::interval::Interval;
use crate::ir::{BinOp, Op, Program, UnOp};

/// An interval as two SSA values.
pub(super) type Iv = (Value, Value);

/// Emits the body; returns the output interval and the decoration (i8).
/// Each value carries its own flag (`None`: statically true), the AND of
/// its operands' flags and its op's, so that only ops the output depends
/// on can clear it — as in the reference evaluator.
pub(super) fn lower(env: &mut Env, prog: &Program, input: [(Iv, Flag); 4]) -> (Iv, Value) {
    let mut vals: Vec<(Iv, Flag)> = Vec::with_capacity(prog.len());
    let ivs: [Iv; 4] = input.map(|(iv, _)| iv);
    for (i, op) in prog.insts.iter().enumerate() {
        let (v, own) = match *op {
            Op::Binary(BinOp::Mul, a, b) => {
                let (x, y) = (vals[a.index()].0, vals[b.index()].0);
                (mul_known(env, x, konst(prog, a), y, konst(prog, b)), None)
            }
            _ => lower_op(env, i, op, &vals, &ivs),
        };
        let mut d = match *op {
            Op::Var(var) => input[var.index()].1,
            _ => own,
        };
        for a in op.args() {
            d = and(env, d, vals[a.index()].1);
        }
        vals.push((v, d));
    }
    let (iv, d) = vals[prog.output.index()];
    (iv, flag_value(env, d))
}

/// A decoration: `None` is statically true, else an i8 that is 0 or 1.
pub(super) type Flag = Option<Value>;

/// `a ∧ b`.
pub(super) fn and(env: &mut Env, a: Flag, b: Flag) -> Flag {
    match (a, b) {
        (None, x) | (x, None) => x,
        (Some(a), Some(b)) => Some(env.b.ins().band(a, b)),
    }
}

/// The flag as an i8 SSA value.
pub(super) fn flag_value(env: &mut Env, f: Flag) -> Value {
    match f {
        Some(v) => v,
        None => env.b.ins().iconst(types::I8, 1),
    }
}

/// Normalises an input interval as [`crate::interval::Interval::normalize`]
/// does: a NaN bound gives the entire line, undefined; `lo = +∞` becomes
/// `MAX`, `hi = −∞` becomes `−MAX`.
pub(super) fn normalize(env: &mut Env, (lo, hi): Iv) -> (Iv, Flag) {
    let b = &mut env.b;
    let ok = b.ins().fcmp(FloatCC::Ordered, lo, hi);
    let pinf = b.ins().f64const(f64::INFINITY);
    let ninf = b.ins().f64const(f64::NEG_INFINITY);
    let max = b.ins().f64const(f64::MAX);
    let nmax = b.ins().f64const(-f64::MAX);
    let lo_inf = b.ins().fcmp(FloatCC::Equal, lo, pinf);
    let hi_inf = b.ins().fcmp(FloatCC::Equal, hi, ninf);
    let l = b.ins().select(lo_inf, max, lo);
    let h = b.ins().select(hi_inf, nmax, hi);
    let l = b.ins().select(ok, l, ninf);
    let h = b.ins().select(ok, h, pinf);
    ((l, h), Some(ok))
}

/// One op: its interval and, when the op can be undefined, its flag.
pub(super) fn lower_op(
    env: &mut Env,
    i: usize,
    op: &Op,
    vals: &[(Iv, Flag)],
    input: &[Iv; 4],
) -> (Iv, Option<Value>) {
    match *op {
        Op::Var(var) => (input[var.index()], None),
        Op::Const(c) => {
            let iv = (env.pool_load(i, 1), env.pool_load(i, 2));
            let d = if c.defined && Interval::new(c.lo, c.hi).normalize().1 {
                None
            } else {
                Some(env.b.ins().iconst(types::I8, 0))
            };
            (iv, d)
        }
        Op::Unary(u, a) => unary(env, u, vals[a.index()].0),
        Op::Binary(op, a, b) => binary(env, op, vals[a.index()].0, vals[b.index()].0),
        Op::Powi(a, n) => {
            let a = vals[a.index()].0;
            if n == 0 {
                ((env.pool_load(i, 1), env.pool_load(i, 2)), None)
            } else if (1..=INLINE_POWI_MAX).contains(&n) {
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
            let l = rounding::mul_down(b, mig, mig);
            let h = rounding::mul_up(b, mag, mag);
            ((l, h), None)
        }
        UnOp::Sqrt => {
            let b = &mut env.b;
            let zero = b.ins().f64const(0.0);
            let defined = b.ins().fcmp(FloatCC::GreaterThanOrEqual, lo, zero);
            let l0 = b.ins().fmax(lo, zero);
            let l = rounding::sqrt_down(b, l0);
            let h = rounding::sqrt_up(b, hi);
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
        BinOp::Add => (
            (
                rounding::add_down(b, a.0, bv.0),
                rounding::add_up(b, a.1, bv.1),
            ),
            None,
        ),
        BinOp::Sub => (
            (
                rounding::sub_down(b, a.0, bv.1),
                rounding::sub_up(b, a.1, bv.0),
            ),
            None,
        ),
        BinOp::Mul => (mul(env, a, bv), None),
        BinOp::Min => ((b.ins().fmin(a.0, bv.0), b.ins().fmin(a.1, bv.1)), None),
        BinOp::Max => ((b.ins().fmax(a.0, bv.0), b.ins().fmax(a.1, bv.1)), None),
        BinOp::Div
        | BinOp::Atan2
        | BinOp::Pow
        | BinOp::Compare
        | BinOp::Mod
        | BinOp::And
        | BinOp::Or => env.call_iv_binary(op, a, bv),
    }
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

/// Interval product, outward rounded: the largest of the four products
/// rounded up is the upper bound; the lower bound is `−max RU(−x·y)` over
/// the same four.
///
/// A NaN product (`0·∞`) stands for 0 in interval arithmetic. The maxima
/// use the one-instruction "pseudo-max" [`pmax`], which skips a NaN first
/// operand, and only the chain's seed (the product of the two upper
/// bounds) is made 0 when NaN. Skipping the other NaN products is exact:
/// a NaN corner `0·(±∞)` means a bound of one factor is 0 and of the other
/// infinite; if the other factor's other bound is finite, its corner with
/// that 0 is 0 and counted; if it is infinite too, the other corners give
/// `±∞` (the hull is the whole line) unless the first factor is `[0, 0]`,
/// where every corner is NaN and the seed gives `[0, 0]`.
pub(super) fn mul(env: &mut Env, a: Iv, c: Iv) -> Iv {
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    let na = (b.ins().fneg(a.0), b.ins().fneg(a.1));
    let seed = |b: &mut cranelift_frontend::FunctionBuilder, x: Value, y: Value| {
        let p = b.ins().fmul(x, y);
        let nan = b.ins().fcmp(FloatCC::Unordered, p, p);
        b.ins().select(nan, zero, p)
    };
    let chain = |b: &mut cranelift_frontend::FunctionBuilder, mut acc: Value, rest: [Iv; 3]| {
        for (x, y) in rest {
            let p = b.ins().fmul(x, y);
            acc = pmax(b, p, acc);
        }
        acc
    };
    let hi0 = seed(b, a.1, c.1);
    let hi = chain(b, hi0, [(a.0, c.0), (a.0, c.1), (a.1, c.0)]);
    let nlo0 = seed(b, na.1, c.1);
    let nlo = chain(b, nlo0, [(na.0, c.0), (na.0, c.1), (na.1, c.0)]);
    (b.ins().fneg(nlo), hi)
}

/// A constant's enclosure `[lo, hi]` as known at compile time (the
/// values the pool holds), when its sign is known: `0 < lo` or `hi < 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Konst {
    pub lo: f64,
    pub hi: f64,
}

/// [`Konst`] of value `v` of `prog`, if `v` is such a constant.
pub(super) fn konst(prog: &Program, v: crate::ir::Value) -> Option<Konst> {
    match prog.insts[v.index()] {
        Op::Const(c) => {
            let (iv, _) = Interval::new(c.lo, c.hi).normalize();
            (iv.lo > 0.0 || iv.hi < 0.0).then_some(Konst {
                lo: iv.lo,
                hi: iv.hi,
            })
        }
        _ => None,
    }
}

/// `x · y`, by [`mul_by_konst`] when either factor is a constant of known
/// sign, else [`mul`].
pub(super) fn mul_known(env: &mut Env, x: Iv, kx: Option<Konst>, y: Iv, ky: Option<Konst>) -> Iv {
    match (kx, ky) {
        (_, Some(k)) => mul_by_konst(env, x, y, k),
        (Some(k), None) => mul_by_konst(env, y, x, k),
        (None, None) => mul(env, x, y),
    }
}

/// `x · c` for a constant `c ⊆ [k.lo, k.hi]` of known sign (`c` the SSA
/// values of those bounds). `c·x` is monotone in `x` with the sign of `c`,
/// so each bound is one product, with the factor bound chosen by the sign
/// of the `x` bound when `c` is not a point; no product is `0·∞` (`c` is
/// finite and non-zero).
pub(super) fn mul_by_konst(env: &mut Env, x: Iv, c: Iv, k: Konst) -> Iv {
    let b = &mut env.b;
    let point = k.lo == k.hi;
    // The factor bound to use against an `x` bound `v`: `big` when `v ≥ 0`,
    // `small` otherwise.
    let pick = |b: &mut cranelift_frontend::FunctionBuilder, v: Value, big: Value, small: Value| {
        if point {
            big
        } else {
            let zero = b.ins().f64const(0.0);
            let nonneg = b.ins().fcmp(FloatCC::GreaterThanOrEqual, v, zero);
            b.ins().select(nonneg, big, small)
        }
    };
    if k.lo > 0.0 {
        // Increasing: hi from x.hi, lo from x.lo.
        let ch = pick(b, x.1, c.1, c.0);
        let cl = pick(b, x.0, c.0, c.1);
        (rounding::mul_down(b, cl, x.0), rounding::mul_up(b, ch, x.1))
    } else {
        // Decreasing: hi from x.lo (larger |c| when x.lo ≤ 0), lo from x.hi.
        let ch = pick(b, x.0, c.1, c.0);
        let cl = pick(b, x.1, c.0, c.1);
        (rounding::mul_down(b, cl, x.1), rounding::mul_up(b, ch, x.0))
    }
}

/// `acc < p ? p : acc`: the larger of `p` and `acc`, and `acc` when `p` is
/// NaN (one `maxsd` on x86-64; `acc` must not be NaN for a maximum).
fn pmax(b: &mut cranelift_frontend::FunctionBuilder, p: Value, acc: Value) -> Value {
    let lt = b.ins().fcmp(FloatCC::LessThan, acc, p);
    b.ins().select(lt, p, acc)
}

/// Bounds of `x^n` for `x ≥ 0` (`x` an exact bound), `n ≥ 1`: the repeated
/// squaring with every product rounded in direction `up` (products of
/// nonnegative numbers are monotone, so the chain bounds the exact power).
fn pow_bound(env: &mut Env, x: Value, mut n: u64, up: bool) -> Value {
    let b = &mut env.b;
    let mul_round = |b: &mut cranelift_frontend::FunctionBuilder, x: Value, y: Value| {
        if up {
            rounding::mul_up(b, x, y)
        } else {
            rounding::mul_down(b, x, y)
        }
    };
    let mut acc: Option<Value> = None;
    let mut base = x;
    loop {
        if n & 1 == 1 {
            acc = Some(match acc {
                None => base,
                Some(r) => mul_round(b, r, base),
            });
        }
        n >>= 1;
        if n == 0 {
            break;
        }
        base = mul_round(b, base, base);
    }
    acc.unwrap_or(x)
}

/// Largest exponent computed inline. Each squaring can double the
/// relative width of a rounded bound, so long chains call the helper,
/// whose error-free transformations keep exact products exact
/// (`1^(10^10) = 1`).
pub(super) const INLINE_POWI_MAX: i64 = 8;

/// `[lo, hi]^n`, `n ≥ 1`.
fn powi(env: &mut Env, (lo, hi): Iv, n: u64) -> Iv {
    if n == 1 {
        return (lo, hi);
    }
    if n.is_multiple_of(2) {
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
