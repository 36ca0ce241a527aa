//! Lowering of a [`Program`] to the interval body.
//!
//! Each IR value becomes two f64 SSA values `(−lo, hi)` — the lower bound
//! is held negated, so that with the kernel in round-toward-+∞ mode
//! ([`super::rounding`]) *both* bounds of a sum are one rounded-up
//! addition, `−(lo_a + lo_b) = (−lo_a) + (−lo_b)`, and negation is a swap
//! — plus one `i8` accumulator for the decoration "defined and continuous
//! on the whole box" (the AND of every op's flag). Memory (inputs, outputs,
//! helper arguments) holds `[lo, hi]`; the conversion is one `fneg` at the
//! boundary ([`Env::load_iv`], [`Env::store_iv`]). Below, `n = −lo`, `h =
//! hi`, and every operation rounds up:
//!
//! | op | rule |
//! |---|---|
//! | `neg` | `(h, n)` |
//! | `min`, `max` | `(max n, min h)`, `(min n, max h)`, exact |
//! | `abs` | `(min(n, h, 0), max(n, h))` = `(−mig, mag)`, exact |
//! | `add` | `(n_a + n_b, h_a + h_b)` |
//! | `sub` | `(n_a + h_b, h_a + n_b)` |
//! | `mul` | `(max RU(−x·y), max RU(x·y))` over the four bound pairs (a NaN product `0·∞` counts as 0) |
//! | `mul` by a constant of known sign | one product per bound ([`mul_by_konst`]) |
//! | `mul` by a value known to be `≥ 0` | one product per bound, the corner chosen by the other factor's signs ([`mul_by_nonneg`]) |
//! | `square` | `(RU(−mig·mig), RU(mag²))` |
//! | `sqrt` | `(−RD(√max(lo,0)), RU(√hi))`, empty when `hi < 0`; defined iff `lo ≥ 0` |
//! | `powi a n`, `1 ≤ n ≤ 8` | exact monotone rules on `mig`/`mag` (even `n`) or the signed bounds (odd `n`), each product of the repeated squaring rounded in its direction (the cube: one chain a bound, [`cube`]) |
//!
//! (`powi a 0` is the pool's `[1, 1]`.) Everything else (`div`, other
//! `powi`, transcendentals, `atan2`, `pow`) calls [`crate::interval`]'s
//! per-op enclosures through [`super::helpers`], which return the op's
//! decoration.
//!
//! Each rule is a function of this file on [`Iv`] (`add`, `mul_known`,
//! `sqrt`, …); [`IntervalNum`], the interval kind of the one lowering
//! ([`super::lower`]), calls them and carries the decorations and what is
//! known of each value at compile time (a constant's bounds, "`≥ 0`"). The
//! interval-gradient kind ([`super::grad`]) computes its values with the
//! same functions (without the "`≥ 0`" products).
//!
//! A kernel's input flags are not carried value by value: the entry point
//! ANDs them into the output's decoration once ([`super::entry`]), which is
//! the same flag because it loads only the variables the output depends
//! on.

use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{InstBuilder, Value, types};

use super::lower::{NumKind, body};
use super::{Env, rounding};
use crate::interval::Interval;
use crate::ir::{BinOp, Const, Program, UnOp, Var};

/// An interval as two SSA values `(−lo, hi)` (see the module doc).
pub(super) type Iv = (Value, Value);

/// An interval value in the interval kind: its bounds, its decoration
/// ("defined and continuous on the whole box"; as a rule's result, the
/// op's own) and, for a constant of known sign, its bounds at compile time.
#[derive(Clone, Copy)]
struct Val {
    iv: Iv,
    flag: Flag,
    k: Option<Konst>,
    /// Known at compile time: the lower bound is `≥ 0` (`n ≤ 0`) whenever
    /// the flag is true (a square, an absolute value, a root, an even
    /// power, or a sum or product of such values and nonnegative
    /// constants). With a false flag the bounds may be anything.
    nonneg: bool,
}

impl Val {
    fn new(iv: Iv, flag: Flag) -> Val {
        Val {
            iv,
            flag,
            k: None,
            nonneg: false,
        }
    }
    fn nonneg(iv: Iv, flag: Flag) -> Val {
        Val {
            nonneg: true,
            ..Val::new(iv, flag)
        }
    }
}

/// The interval kind of the one lowering ([`super::lower`]): each rule is
/// the function of this file of the same name, or a helper call.
struct IntervalNum;

impl NumKind for IntervalNum {
    type In = (Iv, Flag);
    type V = Val;
    type Out = Val;

    fn var(&self, _env: &mut Env, _var: Var, (iv, flag): (Iv, Flag)) -> Val {
        Val::new(iv, flag)
    }
    fn konst(&self, env: &mut Env, i: usize, c: Const) -> Val {
        let (iv, flag) = constant(env, i, c);
        Val {
            iv,
            flag,
            k: Konst::of(c),
            nonneg: Interval::new(c.lo, c.hi).normalize().0.lo >= 0.0,
        }
    }
    fn neg(&self, _env: &mut Env, a: Val) -> Val {
        Val::new(neg(a.iv), None)
    }
    fn abs(&self, env: &mut Env, a: Val) -> Val {
        Val::nonneg(abs(env, a.iv), None)
    }
    fn sqrt(&self, env: &mut Env, a: Val) -> Val {
        let (iv, flag) = sqrt(env, a.iv);
        Val::nonneg(iv, flag)
    }
    fn square(&self, env: &mut Env, a: Val) -> Val {
        Val::nonneg(square(env, a.iv), None)
    }
    fn add(&self, env: &mut Env, a: Val, b: Val) -> Val {
        Val {
            nonneg: a.nonneg && b.nonneg,
            ..Val::new(add(env, a.iv, b.iv), None)
        }
    }
    fn sub(&self, env: &mut Env, a: Val, b: Val) -> Val {
        Val::new(sub(env, a.iv, b.iv), None)
    }
    fn mul(&self, env: &mut Env, a: Val, b: Val) -> Val {
        let iv = match (a.k, b.k, a.nonneg, b.nonneg) {
            (None, None, _, true) => mul_by_nonneg(env, a.iv, b.iv),
            (None, None, true, false) => mul_by_nonneg(env, b.iv, a.iv),
            _ => mul_known(env, a.iv, a.k, b.iv, b.k),
        };
        Val {
            nonneg: a.nonneg && b.nonneg,
            ..Val::new(iv, None)
        }
    }
    fn min(&self, env: &mut Env, a: Val, b: Val) -> Val {
        Val::new(min(env, a.iv, b.iv), None)
    }
    fn max(&self, env: &mut Env, a: Val, b: Val) -> Val {
        Val::new(max(env, a.iv, b.iv), None)
    }
    fn powi(&self, env: &mut Env, i: usize, a: Val, n: i64) -> Val {
        let (iv, flag) = if n == 0 {
            (pool_iv(env, i), None)
        } else if (1..=INLINE_POWI_MAX).contains(&n) {
            (powi(env, a.iv, n as u64), None)
        } else {
            env.call_iv_powi(a.iv, n)
        };
        // x⁰ = 1; even powers are ≥ 0 (inline and helper enclosures
        // alike); odd powers keep the sign.
        Val {
            nonneg: n == 0 || (n > 0 && n % 2 == 0) || (n > 0 && a.nonneg),
            ..Val::new(iv, flag)
        }
    }
    fn unary_call(&self, env: &mut Env, u: UnOp, a: Val) -> Val {
        let (iv, flag) = env.call_iv_unary(u, a.iv);
        Val::new(iv, flag)
    }
    fn binary_call(&self, env: &mut Env, op: BinOp, a: Val, b: Val) -> Val {
        let (iv, flag) = env.call_iv_binary(op, a.iv, b.iv);
        Val::new(iv, flag)
    }
    /// The op's own flag AND its operands' flags, so that only ops the
    /// output depends on can clear it — as in the reference evaluator.
    fn finish(&self, env: &mut Env, r: Val, args: impl Iterator<Item = Val>) -> Val {
        let mut flag = r.flag;
        for a in args {
            flag = and(env, flag, a.flag);
        }
        Val { flag, ..r }
    }
}

/// Emits the body; returns the output interval and the decoration (i8).
pub(super) fn lower(env: &mut Env, prog: &Program, input: [(Iv, Flag); 4]) -> (Iv, Value) {
    let out = body(env, &IntervalNum, prog, input);
    (out.iv, flag_value(env, out.flag))
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

/// Normalises an input interval `[lo, hi]` (as read from memory) as
/// [`crate::interval::Interval::normalize`] does — a NaN bound gives the
/// entire line, undefined; `lo = +∞` becomes `MAX`, `hi = −∞` becomes
/// `−MAX` — and returns it in `(−lo, hi)` form.
pub(super) fn normalize(env: &mut Env, (lo, hi): (Value, Value)) -> (Iv, Flag) {
    // −lo = −∞ (lo = +∞) and hi = −∞ become −MAX; NaN (not ordered)
    // becomes +∞ on both sides, the entire line.
    let (n, h) = normalize_ordered(env, (lo, hi));
    let b = &mut env.b;
    let ok = b.ins().fcmp(FloatCC::Ordered, lo, hi);
    let pinf = b.ins().f64const(f64::INFINITY);
    let n = b.ins().select(ok, n, pinf);
    let h = b.ins().select(ok, h, pinf);
    ((n, h), Some(ok))
}

/// [`normalize`] of an interval whose bounds are both numbers (not NaN):
/// `(−lo, hi)` with `lo = +∞` made `MAX` and `hi = −∞` made `−MAX`; its
/// flag is true.
pub(super) fn normalize_ordered(env: &mut Env, (lo, hi): (Value, Value)) -> Iv {
    let b = &mut env.b;
    let nmax = b.ins().f64const(-f64::MAX);
    let nlo = b.ins().fneg(lo);
    (pmax(b, nlo, nmax), pmax(b, hi, nmax))
}

/// Instruction `i`'s pool enclosure `[lo, hi]` as `(−lo, hi)`.
fn pool_iv(env: &mut Env, i: usize) -> Iv {
    (env.pool_load(i, 1), env.pool_load(i, 2))
}

/// The constant `c` of instruction `i`: its pool enclosure, and the flag
/// `0` when it is not defined (or its bounds are not a real interval).
pub(super) fn constant(env: &mut Env, i: usize, c: Const) -> (Iv, Flag) {
    let iv = pool_iv(env, i);
    let d = if c.defined && Interval::new(c.lo, c.hi).normalize().1 {
        None
    } else {
        Some(env.b.ins().iconst(types::I8, 0))
    };
    (iv, d)
}

/// `−[lo, hi] = [−hi, −lo]`: in `(−lo, hi)` form, a swap.
pub(super) fn neg((n, h): Iv) -> Iv {
    (h, n)
}

/// `|a| = (−mig, mag)`.
pub(super) fn abs(env: &mut Env, a: Iv) -> Iv {
    nmig_mag(env, a)
}

/// `a² = (RU(−mig·mig), RU(mag²))`.
pub(super) fn square(env: &mut Env, a: Iv) -> Iv {
    let (nmig, mag) = nmig_mag(env, a);
    let b = &mut env.b;
    let mig = b.ins().fneg(nmig);
    // RU(−mig·mig) = −RD(mig²).
    let nl = b.ins().fmul(nmig, mig);
    let hh = rounding::mul_up(b, mag, mag);
    (nl, hh)
}

/// `√a` and its flag "`lo ≥ 0`".
pub(super) fn sqrt(env: &mut Env, (n, h): Iv) -> (Iv, Flag) {
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    let lo = b.ins().fneg(n);
    let defined = b.ins().fcmp(FloatCC::GreaterThanOrEqual, lo, zero);
    let l0 = b.ins().fmax(lo, zero);
    let l = rounding::sqrt_down(b, l0);
    let nl = b.ins().fneg(l);
    let hh = rounding::sqrt_up(b, h);
    // hi < 0: nowhere defined, the empty interval [+∞, −∞].
    let empty = b.ins().fcmp(FloatCC::LessThan, h, zero);
    let ninf = b.ins().f64const(f64::NEG_INFINITY);
    let nl = b.ins().select(empty, ninf, nl);
    let hh = b.ins().select(empty, ninf, hh);
    ((nl, hh), Some(defined))
}

/// `a + c = (n_a + n_c, h_a + h_c)`.
pub(super) fn add(env: &mut Env, a: Iv, c: Iv) -> Iv {
    let b = &mut env.b;
    (rounding::add_up(b, a.0, c.0), rounding::add_up(b, a.1, c.1))
}

/// `a − c = (n_a + h_c, h_a + n_c)`.
pub(super) fn sub(env: &mut Env, a: Iv, c: Iv) -> Iv {
    let b = &mut env.b;
    (rounding::add_up(b, a.0, c.1), rounding::add_up(b, a.1, c.0))
}

/// `min(a, c) = (max n, min h)`, exact.
pub(super) fn min(env: &mut Env, a: Iv, c: Iv) -> Iv {
    let b = &mut env.b;
    (b.ins().fmax(a.0, c.0), b.ins().fmin(a.1, c.1))
}

/// `max(a, c) = (min n, max h)`, exact.
pub(super) fn max(env: &mut Env, a: Iv, c: Iv) -> Iv {
    let b = &mut env.b;
    (b.ins().fmin(a.0, c.0), b.ins().fmax(a.1, c.1))
}

/// `(−mig, mag)`: the smallest and largest `|x|` on `[lo, hi]` (`mig` held
/// negated), exact: `mig = max(lo, −hi, 0)`, so `−mig = min(n, h, 0)`;
/// `mag = max(−lo, hi) = max(n, h)`.
///
/// The minima and maxima are one-instruction pseudo-min/max: a NaN bound
/// only comes from arithmetic on an empty interval (`[+∞, −∞]`, a value
/// defined nowhere on the box, with its decoration false), whose result
/// may then be any interval.
fn nmig_mag(env: &mut Env, (n, h): Iv) -> Iv {
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    let m = pmin(b, n, h);
    let nmig = pmin(b, m, zero);
    let mag = pmax(b, n, h);
    (nmig, mag)
}

/// `p < acc ? p : acc` (one `minsd` on x86-64).
fn pmin(b: &mut cranelift_frontend::FunctionBuilder, p: Value, acc: Value) -> Value {
    let lt = b.ins().fcmp(FloatCC::LessThan, p, acc);
    b.ins().select(lt, p, acc)
}

/// Interval product, outward rounded: the largest of the four products
/// rounded up is the upper bound, the largest of the four negated products
/// rounded up is `−lo`. With `l = −n` the lower bounds:
/// `x·y` over `{l_a, h_a} × {l_c, h_c}` is `{n_a·n_c, l_a·h_c, h_a·l_c,
/// h_a·h_c}` and `−x·y` is `{n_a·l_c, n_a·h_c, h_a·n_c, (−h_a)·h_c}`.
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
    let la = b.ins().fneg(a.0);
    let lc = b.ins().fneg(c.0);
    let nha = b.ins().fneg(a.1);
    let seed = |b: &mut cranelift_frontend::FunctionBuilder, x: Value, y: Value| {
        product_or_zero(b, x, y, zero)
    };
    let chain = |b: &mut cranelift_frontend::FunctionBuilder, mut acc: Value, rest: [Iv; 3]| {
        for (x, y) in rest {
            let p = b.ins().fmul(x, y);
            acc = pmax(b, p, acc);
        }
        acc
    };
    let h0 = seed(b, a.1, c.1);
    let h = chain(b, h0, [(a.0, c.0), (la, c.1), (a.1, lc)]);
    let n0 = seed(b, nha, c.1);
    let n = chain(b, n0, [(a.0, lc), (a.0, c.1), (a.1, c.0)]);
    (n, h)
}

/// `x · y` for a `y` known to be nonnegative ([`Val::nonneg`]): `x·y` is
/// monotone in `y` with the sign of `x`'s bound, so each bound of the
/// product is one product, `hi = RU(h_x · (h_x ≥ 0 ? h_y : l_y))` and
/// `−lo = RU(n_x · (n_x > 0 ? h_y : l_y))` (`l_y = −n_y ≥ 0`) — the corner
/// [`mul`] would find largest, rounded the same way. A NaN product
/// (`0·∞`) stands for 0, as in [`mul`]: with `y ≥ 0` it comes from `h_x =
/// 0, h_y = ∞` (then `x ≤ 0` and the supremum is 0) or from `y = [0, 0]`.
pub(super) fn mul_by_nonneg(env: &mut Env, x: Iv, y: Iv) -> Iv {
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    let ly = b.ins().fneg(y.0);
    let h_nonneg = b.ins().fcmp(FloatCC::GreaterThanOrEqual, x.1, zero);
    let yh = b.ins().select(h_nonneg, y.1, ly);
    let lo_neg = b.ins().fcmp(FloatCC::GreaterThan, x.0, zero);
    let yn = b.ins().select(lo_neg, y.1, ly);
    let n = product_or_zero(b, x.0, yn, zero);
    let h = product_or_zero(b, x.1, yh, zero);
    (n, h)
}

/// `x·y` rounded up, `zero` (an SSA `0.0`) where it is NaN: a `0·∞`
/// corner stands for 0 in interval arithmetic.
fn product_or_zero(
    b: &mut cranelift_frontend::FunctionBuilder,
    x: Value,
    y: Value,
    zero: Value,
) -> Value {
    let p = b.ins().fmul(x, y);
    let nan = b.ins().fcmp(FloatCC::Unordered, p, p);
    b.ins().select(nan, zero, p)
}

/// A constant's enclosure `[lo, hi]` as known at compile time (the
/// values the pool holds), when its sign is known: `0 < lo` or `hi < 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Konst {
    pub lo: f64,
    pub hi: f64,
}

impl Konst {
    /// The bounds of the constant `c`, if its sign is known.
    pub(super) fn of(c: Const) -> Option<Konst> {
        let (iv, _) = Interval::new(c.lo, c.hi).normalize();
        (iv.lo > 0.0 || iv.hi < 0.0).then_some(Konst {
            lo: iv.lo,
            hi: iv.hi,
        })
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

/// `x · c` for a constant `c ⊆ [k.lo, k.hi]` of known sign (`c` its SSA
/// `(−lo, hi)`). `c·x` is monotone in `x` with the sign of `c`, so each
/// bound is one product of an `x` bound and a bound of `|c|` — chosen by
/// the sign of that `x` bound when `c` is not a point; no product is
/// `0·∞` (`c` is finite and non-zero). With `|c| ∈ [s, g]`:
///
/// - `c > 0`: `hi = RU(|c|·h_x)` (`g` when `h_x ≥ 0`, else `s`), `−lo =
///   RU(|c|·n_x)` (`s` when `n_x ≤ 0`, i.e. `lo ≥ 0`, else `g`);
/// - `c < 0`: `hi = RU(|c|·n_x)` (`g` when `n_x ≥ 0`, else `s`), `−lo =
///   RU(|c|·h_x)` (`g` when `h_x ≥ 0`, else `s`).
pub(super) fn mul_by_konst(env: &mut Env, x: Iv, c: Iv, k: Konst) -> Iv {
    let b = &mut env.b;
    let point = k.lo == k.hi;
    let pos = k.lo > 0.0;
    // |c| ∈ [s, g]: for c > 0, [lo, hi] = [−n_c, h_c]; for c < 0,
    // [−hi, −lo] = [−h_c, n_c].
    let (s, g) = match (pos, point) {
        (true, true) => (c.1, c.1),
        (false, true) => (c.0, c.0),
        (true, false) => (b.ins().fneg(c.0), c.1),
        (false, false) => (b.ins().fneg(c.1), c.0),
    };
    let zero = b.ins().f64const(0.0);
    // `g` when `v cc 0`, else `s`.
    let pick = |b: &mut cranelift_frontend::FunctionBuilder, v: Value, cc: FloatCC| {
        if point {
            g
        } else {
            let t = b.ins().fcmp(cc, v, zero);
            b.ins().select(t, g, s)
        }
    };
    use FloatCC::{GreaterThan as Gt, GreaterThanOrEqual as Ge};
    if pos {
        let mh = pick(b, x.1, Ge);
        let mn = pick(b, x.0, Gt);
        (b.ins().fmul(mn, x.0), b.ins().fmul(mh, x.1))
    } else {
        let mh = pick(b, x.0, Ge);
        let mn = pick(b, x.1, Ge);
        (b.ins().fmul(mn, x.1), b.ins().fmul(mh, x.0))
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
/// `[lo, hi]³`, bit for bit the odd rule of [`powi`] with one chain a
/// bound instead of two and a select.
///
/// That rule takes, with `a = |n|`, `−lo = RU(a·RU(a·a))` when `n > 0` and
/// `−RD(a·RD(a·a))` otherwise, computed as `RU(a·q)` with `q = RU((−a)·a)`
/// (`rounding::mul_down` twice: `(−a)·(−q) = a·q` exactly). Both are
/// `RU(a·RU(a′·a))` with `a′ = a` or `−a`: here `a′` is `a` with the sign
/// of `max(n, −0)` — set exactly when `n ≤ 0`, zeros included. Likewise
/// `hi` with the sign of `min(h, +0)`, set exactly when `h < 0`.
fn cube(env: &mut Env, (n, h): Iv) -> Iv {
    let b = &mut env.b;
    let neg_zero = b.ins().f64const(-0.0);
    let zero = b.ins().f64const(0.0);
    let n_sign = pmax(b, n, neg_zero);
    let h_sign = pmin(b, h, zero);
    // `−0.0` is the sign bit alone: `band` with it keeps a sign.
    let bound = |b: &mut cranelift_frontend::FunctionBuilder, v: Value, sign_of: Value| {
        let a = b.ins().fabs(v);
        let s = b.ins().band(sign_of, neg_zero);
        let a_signed = b.ins().bxor(a, s);
        let t = b.ins().fmul(a_signed, a);
        b.ins().fmul(a, t)
    };
    (bound(b, n, n_sign), bound(b, h, h_sign))
}

pub(super) fn powi(env: &mut Env, (n, h): Iv, k: u64) -> Iv {
    if k == 1 {
        return (n, h);
    }
    if k.is_multiple_of(2) {
        let (nmig, mag) = nmig_mag(env, (n, h));
        let mig = env.b.ins().fneg(nmig);
        let l = pow_bound(env, mig, k, false);
        let nl = env.b.ins().fneg(l);
        let hh = pow_bound(env, mag, k, true);
        return (nl, hh);
    }
    if k == 3 {
        return cube(env, (n, h));
    }
    // Odd: monotone increasing; x^k = sign(x)·|x|^k.
    let alo = env.b.ins().fabs(n);
    let ahi = env.b.ins().fabs(h);
    let lo_dn = pow_bound(env, alo, k, false);
    let lo_up = pow_bound(env, alo, k, true);
    let hi_dn = pow_bound(env, ahi, k, false);
    let hi_up = pow_bound(env, ahi, k, true);
    let b = &mut env.b;
    let zero = b.ins().f64const(0.0);
    // lo < 0 ⇔ n > 0: lo = −|lo|^k, so −lo = RU(|lo|^k); else −lo =
    // −RD(lo^k).
    let lo_neg = b.ins().fcmp(FloatCC::GreaterThan, n, zero);
    let hi_neg = b.ins().fcmp(FloatCC::LessThan, h, zero);
    let nlo_dn = b.ins().fneg(lo_dn);
    let nhi_dn = b.ins().fneg(hi_dn);
    let nl = b.ins().select(lo_neg, lo_up, nlo_dn);
    let hh = b.ins().select(hi_neg, nhi_dn, hi_up);
    (nl, hh)
}
