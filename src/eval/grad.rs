//! Value and gradient by forward-mode automatic differentiation, in f64
//! ([`eval_point`], dual numbers) and in interval arithmetic ([`eval`], the
//! interval-gradient of Paiva, de Figueiredo & Stolfi 2006, §3: each value
//! carries `(F, ∂F/∂x, ∂F/∂y, ∂F/∂z)` as intervals).
//!
//! # One set of rules, two number types
//!
//! The derivative rules are written once, generically over [`Num`], and run
//! with `f64` (the IR's point semantics, [`crate::eval::point`]) and with
//! decorated intervals ([`crate::interval`]). Every primitive of [`Num`]
//! satisfies "point inputs inside interval inputs ⇒ point output NaN or
//! inside the interval output", so by induction over the *same* expression
//! the point gradient lies in the interval gradient: that is the soundness
//! argument, and the shared test suite checks it.
//!
//! Rules (`a'` is the derivative of an operand, `v` the op's value):
//! `sqrt: a'/(2v)`, `square: (2a)a'`, `exp: v a'`, `log: a'/a`,
//! `sin: cos(a) a'`, `cos: -sin(a) a'`, `tan: (1+v²) a'`,
//! `asin: a'/√(1-a²)`, `acos: -a'/√(1-a²)`, `atan: a'/(1+a²)`,
//! `mul: a'b + ab'`, `div: (a' - v b')/b`, `atan2(y,x): (x y' - y x')/(x²+y²)`,
//! `pow: v (b' log a + b a'/a)`, `powi n: n a^(n-1) a'`,
//! `mod: a' − q b'` with `q = (a − v)/b` (the integer `⌊a/|b|⌋·sign b`).
//! Piecewise-constant ops (`floor ceil round not compare`) have derivative
//! 0, flagged not defined (with the value) when a jump may lie in the box;
//! `and`/`or` take the derivative of the operand they surely choose, else
//! the hull of both, not defined.
//! Non-smooth ops: `abs'` is `a'` for `a > 0`, `-a'` for `a < 0` and the hull
//! `[-1, 1]·a'` when the interval touches or straddles 0 (the point rule
//! picks `a'` at `a = 0`); `min`/`max` take the derivative of the operand
//! that is strictly smaller/larger on the whole box, else the hull of both
//! (the point rule picks the first operand on ties). In the interval
//! version, `log`, `pow` and `asin`/`acos` operands are restricted to the
//! op's domain before differentiating. Where a derivative is unbounded (e.g.
//! `sqrt` at 0) the division by an interval containing 0 gives a half-line
//! or the entire line.
//!
//! # Flags and NaN
//!
//! [`GradEval::defined`] is false when any op on the output's dependency
//! path was not defined and continuous, or not differentiable, somewhere on
//! the box. In [`eval_point`], where an op's value is NaN its derivatives
//! are NaN too, and divisions by zero inside derivative rules give NaN
//! (e.g. the derivative of `sqrt` at 0): NaN means "no derivative here".
//! The variable `t` is not differentiated (its partials are not part of the
//! gradient).

use crate::interval::{self, DecInterval, Interval};
use crate::ir::{BinOp, Const, Op, Program, UnOp};

/// `(F, ∂F/∂x, ∂F/∂y, ∂F/∂z)` enclosed over a box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradEval {
    /// An enclosure of `F` over the box.
    pub value: Interval,
    /// Enclosures of `(∂F/∂x, ∂F/∂y, ∂F/∂z)` over the box.
    pub grad: [Interval; 3],
    /// False when some op was not defined and continuous (or not
    /// differentiable) somewhere on the box.
    pub defined: bool,
}

/// The primitives the derivative rules are built from.
pub trait Num: Copy {
    /// An exactly representable constant.
    fn cst(c: f64) -> Self;
    /// The IR constant `c` (its value, or its enclosure and flag).
    fn konst(c: &Const) -> Self;
    /// The integer `n` (enclosed when not exactly representable).
    fn int(n: i64) -> Self;
    /// The unary op `op` applied to `a` (point value or enclosure).
    fn un(op: UnOp, a: Self) -> Self;
    /// The binary op `op` applied to `a` and `b` (point value or enclosure).
    fn bin(op: BinOp, a: Self, b: Self) -> Self;
    /// `bin(Add, a, b)`, `bin(Sub, a, b)`, `bin(Mul, a, b)`, `un(Neg, a)`:
    /// the derivative rules' arithmetic, which an implementation may
    /// provide without the dispatch on the op (same results).
    fn add(a: Self, b: Self) -> Self {
        Self::bin(BinOp::Add, a, b)
    }
    /// `bin(Sub, a, b)` (see [`Num::add`]).
    fn sub(a: Self, b: Self) -> Self {
        Self::bin(BinOp::Sub, a, b)
    }
    /// `bin(Mul, a, b)` (see [`Num::add`]).
    fn mul(a: Self, b: Self) -> Self {
        Self::bin(BinOp::Mul, a, b)
    }
    /// `un(Neg, a)` (see [`Num::add`]).
    fn neg(a: Self) -> Self {
        Self::un(UnOp::Neg, a)
    }
    /// `a` to the integer power `n` (the IR's `powi`).
    fn powi(a: Self, n: i64) -> Self;
    /// A value with no meaning (`NaN`, or entire and undefined).
    fn unknown() -> Self;
    /// `a` restricted to `[lo, hi]` (intervals; points are left alone: a
    /// point outside the domain has a NaN value and is poisoned anyway).
    fn restrict(a: Self, lo: f64, hi: f64) -> Self;
    /// Derivative of `|a|` given `a' = da`.
    fn abs_d(a: Self, da: Self) -> Self;
    /// Derivative of `min(a, b)` (`MIN`) or `max(a, b)`.
    fn select_d(is_min: bool, a: Self, b: Self, da: Self, db: Self) -> Self;
    /// The zero derivative of a piecewise-constant op whose value is `v`
    /// and operand derivative `da` (`floor`, `not`, `compare`, …): NaN
    /// where `v` or `da` is, and for intervals carrying both flags (false
    /// across a jump; an operand's flag is kept, as the JIT's kernels do).
    fn flat_d(v: Self, da: Self) -> Self;
    /// Derivative of `and(a, b)` (`is_and`) or `or(a, b)`: the chosen
    /// operand's, the hull of both (not defined) when the choice is open.
    fn logic_d(is_and: bool, a: Self, b: Self, da: Self, db: Self) -> Self;
}

impl Num for f64 {
    fn cst(c: f64) -> Self {
        c
    }
    fn konst(c: &Const) -> Self {
        c.value
    }
    fn int(n: i64) -> Self {
        n as f64
    }
    fn un(op: UnOp, a: Self) -> Self {
        crate::ir::semantics::point_unary(op, a)
    }
    fn bin(op: BinOp, a: Self, b: Self) -> Self {
        crate::ir::semantics::point_binary(op, a, b)
    }
    fn powi(a: Self, n: i64) -> Self {
        crate::ir::semantics::point_powi(a, n)
    }
    fn unknown() -> Self {
        f64::NAN
    }
    fn restrict(a: Self, _lo: f64, _hi: f64) -> Self {
        a
    }
    fn abs_d(a: Self, da: Self) -> Self {
        if a.is_nan() {
            f64::NAN
        } else if a < 0.0 {
            -da
        } else {
            da
        }
    }
    fn select_d(is_min: bool, a: Self, b: Self, da: Self, db: Self) -> Self {
        let second = if is_min { b < a } else { b > a };
        if a.is_nan() || b.is_nan() {
            f64::NAN
        } else if second {
            db
        } else {
            da
        }
    }
    fn flat_d(v: Self, da: Self) -> Self {
        if v.is_nan() || da.is_nan() {
            f64::NAN
        } else {
            0.0
        }
    }
    fn logic_d(is_and: bool, a: Self, b: Self, da: Self, db: Self) -> Self {
        if a.is_nan() || b.is_nan() {
            f64::NAN
        } else if (a == 0.0) == is_and {
            da
        } else {
            db
        }
    }
}

/// The derivative of an op that picks one of two operands: `da` when the
/// first is certainly picked, `db` when the second is, else the hull of
/// both, not defined (the choice is open on the box).
fn choose(first: bool, second: bool, da: DecInterval, db: DecInterval, ok: bool) -> DecInterval {
    if first {
        DecInterval::new(da.iv, ok)
    } else if second {
        DecInterval::new(db.iv, ok)
    } else {
        DecInterval::new(da.iv.hull(db.iv), false)
    }
}

fn dec(iv: (Interval, bool), ok: bool) -> DecInterval {
    DecInterval::new(iv.0, iv.1 && ok)
}

/// A total binary op's rule applied directly ([`interval::binary_with`]).
#[inline]
fn total(
    a: DecInterval,
    b: DecInterval,
    rule: impl Fn(Interval, Interval) -> Interval,
) -> DecInterval {
    dec(
        interval::binary_with(a.iv, b.iv, rule),
        a.defined && b.defined,
    )
}

impl Num for DecInterval {
    fn cst(c: f64) -> Self {
        DecInterval::new(Interval::point(c), true)
    }
    fn konst(c: &Const) -> Self {
        let (iv, ok) = Interval::new(c.lo, c.hi).normalize();
        DecInterval::new(iv, ok && c.defined)
    }
    fn int(n: i64) -> Self {
        DecInterval::new(Interval::from_i64(n), true)
    }
    fn un(op: UnOp, a: Self) -> Self {
        dec(crate::ir::semantics::enclose_unary(op, a.iv), a.defined)
    }
    fn bin(op: BinOp, a: Self, b: Self) -> Self {
        dec(
            crate::ir::semantics::enclose_binary(op, a.iv, b.iv),
            a.defined && b.defined,
        )
    }
    #[inline]
    fn add(a: Self, b: Self) -> Self {
        total(a, b, interval::arith::add)
    }
    #[inline]
    fn sub(a: Self, b: Self) -> Self {
        total(a, b, interval::arith::sub)
    }
    #[inline]
    fn mul(a: Self, b: Self) -> Self {
        total(a, b, interval::arith::mul)
    }
    #[inline]
    fn neg(a: Self) -> Self {
        dec(interval::unary_with(a.iv, interval::arith::neg), a.defined)
    }
    fn powi(a: Self, n: i64) -> Self {
        dec(crate::ir::semantics::enclose_powi(a.iv, n), a.defined)
    }
    fn unknown() -> Self {
        DecInterval::new(Interval::ENTIRE, false)
    }
    fn restrict(a: Self, lo: f64, hi: f64) -> Self {
        DecInterval::new(a.iv.intersect(Interval::new(lo, hi)), a.defined)
    }
    fn abs_d(a: Self, da: Self) -> Self {
        let ok = a.defined && da.defined;
        if a.iv.is_empty() {
            DecInterval::new(Interval::EMPTY, false)
        } else if a.iv.lo > 0.0 {
            DecInterval::new(da.iv, ok)
        } else if a.iv.hi < 0.0 {
            DecInterval::new(interval::arith::neg(da.iv), ok)
        } else {
            let m = interval::arith::abs(da.iv).hi;
            DecInterval::new(Interval::new(-m, m), false)
        }
    }
    fn select_d(is_min: bool, a: Self, b: Self, da: Self, db: Self) -> Self {
        let ok = a.defined && b.defined && da.defined && db.defined;
        let (a, b) = (a.iv, b.iv);
        if a.is_empty() || b.is_empty() {
            return DecInterval::new(Interval::EMPTY, false);
        }
        let (first, second) = if is_min {
            (a.hi < b.lo, b.hi < a.lo)
        } else {
            (a.lo > b.hi, b.lo > a.hi)
        };
        choose(first, second, da, db, ok)
    }
    fn flat_d(v: Self, da: Self) -> Self {
        DecInterval::new(Interval::point(0.0), v.defined && da.defined)
    }
    fn logic_d(is_and: bool, a: Self, b: Self, da: Self, db: Self) -> Self {
        let ok = a.defined && b.defined && da.defined && db.defined;
        let (a, b) = (a.iv, b.iv);
        if a.is_empty() || b.is_empty() {
            return DecInterval::new(Interval::EMPTY, false);
        }
        let zero = a.lo == 0.0 && a.hi == 0.0;
        let nonzero = !a.contains(0.0);
        let (first, second) = if is_and {
            (zero, nonzero)
        } else {
            (nonzero, zero)
        };
        choose(first, second, da, db, ok)
    }
}

/// A value and its three partial derivatives.
#[derive(Clone, Copy, Debug)]
pub struct Dual<N> {
    /// The value.
    pub v: N,
    /// The partial derivatives with respect to x, y and z.
    pub d: [N; 3],
}

fn map3<N: Num>(f: impl Fn(usize) -> N) -> [N; 3] {
    [f(0), f(1), f(2)]
}

/// Three directions of differentiation: the partials of `x`, `y` and `z`
/// (rows) along each of them (columns). Partials taken in a frame are the
/// derivatives along its columns, `∂F/∂uₖ = Σᵢ frame[i][k]·∂F/∂xᵢ`.
pub type Frame = [[f64; 3]; 3];

/// The frame of the axes: partials are `(∂/∂x, ∂/∂y, ∂/∂z)`.
pub const AXES: Frame = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// The value and partials of one instruction, from those before it.
pub fn step<N: Num>(op: &Op, vals: &[Dual<N>], input: [N; 4]) -> Dual<N> {
    step_in(op, vals, input, &AXES)
}

/// [`step`] with the partials taken along the columns of `frame`.
#[inline]
pub fn step_in<N: Num>(op: &Op, vals: &[Dual<N>], input: [N; 4], frame: &Frame) -> Dual<N> {
    use BinOp as B;
    use UnOp as U;
    let zero = N::cst(0.0);
    let mul = N::mul;
    let div = |a, b| N::bin(B::Div, a, b);
    let add = N::add;
    let sub = N::sub;
    let neg = N::neg;
    let sq = |a| N::un(U::Square, a);
    // A malformed operand (not an earlier value) reads as unknown.
    let unknown = Dual {
        v: N::unknown(),
        d: [N::unknown(); 3],
    };
    // Operands are read in place (a value and its partials are 4 `N`s).
    let get = |v: crate::ir::Value| vals.get(v.index()).unwrap_or(&unknown);
    match *op {
        Op::Var(v) => {
            let i = v.index();
            // `t` (index 3) is not differentiated.
            let seed = frame.get(i).copied().unwrap_or([0.0; 3]);
            Dual {
                v: input[i],
                d: map3(|k| N::cst(seed[k])),
            }
        }
        Op::Const(c) => Dual {
            v: N::konst(&c),
            d: [zero; 3],
        },
        Op::Unary(u, a) => {
            let Dual { v: a, d: da } = get(a);
            let a = *a;
            let v = N::un(u, a);
            let d = match u {
                U::Neg => map3(|k| neg(da[k])),
                U::Abs => map3(|k| N::abs_d(a, da[k])),
                U::Sqrt => {
                    let two_v = mul(N::cst(2.0), v);
                    map3(|k| div(da[k], two_v))
                }
                U::Square => {
                    let two_a = mul(N::cst(2.0), a);
                    map3(|k| mul(two_a, da[k]))
                }
                U::Exp => map3(|k| mul(v, da[k])),
                U::Log => {
                    let a = N::restrict(a, 0.0, f64::INFINITY);
                    map3(|k| div(da[k], a))
                }
                U::Sin => {
                    let c = N::un(U::Cos, a);
                    map3(|k| mul(c, da[k]))
                }
                U::Cos => {
                    let s = neg(N::un(U::Sin, a));
                    map3(|k| mul(s, da[k]))
                }
                U::Tan => {
                    let s = add(N::cst(1.0), sq(v));
                    map3(|k| mul(s, da[k]))
                }
                U::Asin | U::Acos => {
                    let a = N::restrict(a, -1.0, 1.0);
                    let r = N::un(U::Sqrt, sub(N::cst(1.0), sq(a)));
                    if u == U::Asin {
                        map3(|k| div(da[k], r))
                    } else {
                        map3(|k| neg(div(da[k], r)))
                    }
                }
                U::Atan => {
                    let s = add(N::cst(1.0), sq(a));
                    map3(|k| div(da[k], s))
                }
                U::Floor | U::Ceil | U::Round | U::Not => map3(|k| N::flat_d(v, da[k])),
            };
            Dual { v, d }
        }
        Op::Binary(bop, x, y) => {
            let Dual { v: a, d: da } = get(x);
            let Dual { v: b, d: db } = get(y);
            let (a, b) = (*a, *b);
            let v = N::bin(bop, a, b);
            let d = match bop {
                B::Add => map3(|k| add(da[k], db[k])),
                B::Sub => map3(|k| sub(da[k], db[k])),
                B::Mul => map3(|k| add(mul(da[k], b), mul(a, db[k]))),
                B::Div => map3(|k| div(sub(da[k], mul(v, db[k])), b)),
                B::Min => map3(|k| N::select_d(true, a, b, da[k], db[k])),
                B::Max => map3(|k| N::select_d(false, a, b, da[k], db[k])),
                B::Atan2 => {
                    // a = y, b = x: (x·y' − y·x')/(x² + y²).
                    let r2 = add(sq(b), sq(a));
                    map3(|k| div(sub(mul(b, da[k]), mul(a, db[k])), r2))
                }
                B::Pow => {
                    let pa = N::restrict(a, 0.0, f64::INFINITY);
                    let la = N::un(U::Log, pa);
                    map3(|k| mul(v, add(mul(db[k], la), mul(b, div(da[k], pa)))))
                }
                B::Compare => map3(|k| N::flat_d(N::flat_d(v, da[k]), db[k])),
                B::And => map3(|k| N::logic_d(true, a, b, da[k], db[k])),
                B::Or => map3(|k| N::logic_d(false, a, b, da[k], db[k])),
                B::Mod => {
                    // v = a − |b|·⌊a/|b|⌋, so dv = da − q·db with the
                    // (locally constant) q = (a − v)/b.
                    let q = div(sub(a, v), b);
                    map3(|k| sub(da[k], mul(q, db[k])))
                }
            };
            Dual { v, d }
        }
        Op::Powi(a, n) => {
            let Dual { v: a, d: da } = get(a);
            let a = *a;
            let v = N::powi(a, n);
            let d = if n == 0 {
                [zero; 3]
            } else if let Some(m) = n.checked_sub(1) {
                let f = mul(N::int(n), N::powi(a, m));
                map3(|k| mul(f, da[k]))
            } else {
                [N::unknown(); 3]
            };
            Dual { v, d }
        }
    }
}

fn run<N: Num>(
    program: &Program,
    input: [N; 4],
    frame: &Frame,
    fixup: impl Fn(Dual<N>) -> Dual<N>,
) -> Option<Dual<N>> {
    // Short (pruned) programs run in a buffer on the stack, sized to the
    // program (filling it is part of the cost).
    match program.insts.len() {
        0..=8 => run_on_stack::<N, 8>(program, input, frame, fixup),
        9..=16 => run_on_stack::<N, 16>(program, input, frame, fixup),
        17..=32 => run_on_stack::<N, 32>(program, input, frame, fixup),
        _ => {
            let mut vals: Vec<Dual<N>> = Vec::with_capacity(program.insts.len());
            for op in &program.insts {
                let d = fixup(step_in(op, &vals, input, frame));
                vals.push(d);
            }
            vals.get(program.output.index()).copied()
        }
    }
}

/// [`run`] for programs of at most `S` instructions.
#[inline]
fn run_on_stack<N: Num, const S: usize>(
    program: &Program,
    input: [N; 4],
    frame: &Frame,
    fixup: impl Fn(Dual<N>) -> Dual<N>,
) -> Option<Dual<N>> {
    let n = program.insts.len();
    let unknown = Dual {
        v: N::unknown(),
        d: [N::unknown(); 3],
    };
    let mut vals = [unknown; S];
    for (i, op) in program.insts.iter().enumerate() {
        vals[i] = fixup(step_in(op, &vals[..i], input, frame));
    }
    vals[..n].get(program.output.index()).copied()
}

/// Interval value and gradient over the box `[x, y, z, t]`.
pub fn eval(program: &Program, input: [Interval; 4]) -> GradEval {
    eval_in(program, input, &AXES)
}

/// Interval value and derivatives along the columns of `frame` over the
/// box `[x, y, z, t]` (`grad[k]` encloses `Σᵢ frame[i][k]·∂F/∂xᵢ`, the
/// hull of the one-sided derivatives where `F` has a kink): the same
/// rules as [`eval`], seeded with the frame instead of the axes, so along
/// a direction across a `min`/`max` crease the enclosure is the hull of
/// the two faces' derivatives along it, not the projection of the hull of
/// their gradients.
pub fn eval_in(program: &Program, input: [Interval; 4], frame: &Frame) -> GradEval {
    let input = input.map(|b| {
        let (iv, ok) = b.normalize();
        DecInterval::new(iv, ok)
    });
    let out = run(program, input, frame, |d| d);
    match out {
        Some(Dual { v, d }) => GradEval {
            value: v.iv,
            grad: d.map(|g| g.iv),
            defined: v.defined && d.iter().all(|g| g.defined),
        },
        None => GradEval {
            value: Interval::ENTIRE,
            grad: [Interval::ENTIRE; 3],
            defined: false,
        },
    }
}

/// Point value and gradient at `[x, y, z, t]` (forward-mode AD in f64).
/// Where the value is NaN the gradient is NaN.
pub fn eval_point(program: &Program, input: [f64; 4]) -> (f64, [f64; 3]) {
    let out = run(program, input, &AXES, |d| {
        if d.v.is_nan() {
            Dual {
                v: d.v,
                d: [f64::NAN; 3],
            }
        } else {
            d
        }
    });
    match out {
        Some(d) => (d.v, d.d),
        None => (f64::NAN, [f64::NAN; 3]),
    }
}
