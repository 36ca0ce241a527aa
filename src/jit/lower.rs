//! The one lowering of a [`Program`]: the dispatch on the IR op, written
//! once ([`body`]) over a number kind in generated code ([`NumKind`]), as
//! [`crate::eval::grad::step`] writes its rules once over
//! [`crate::eval::grad::Num`].
//!
//! # Contract
//!
//! [`body`] walks the program in order and, for each instruction, calls
//! the kind's rule for that op — `var`, `const`, the inline ops `neg abs
//! sqrt square add sub mul div min max powi`, and one rule for every other
//! unary or binary op (a helper call) — then [`NumKind::finish`], which
//! combines what the rule returned with the operands' values (decorations,
//! NaN poisoning). It emits nothing itself: every instruction comes from a
//! kind's rule, in the order the instructions are read, so a kind's kernel
//! is exactly what its rules say.
//!
//! The kinds, each with its rules in its own file:
//!
//! | kind | file | a value | `finish` |
//! |---|---|---|---|
//! | `PointNum<Scalar>`, `PointNum<X2>` | `point.rs` (lane width: `simd.rs`) | one f64 (or `F64X2`) | nothing |
//! | `IntervalNum` | `interval.rs` | `(−lo, hi)`, decoration, known constant sign | decoration ∧ operands' |
//! | `GradNum` | `grad.rs` | interval and three sparse derivatives, value and derivative flags | flags ∧ operands' |
//! | `PointGradNum` | `pgrad.rs` | f64 and three derivatives | derivatives NaN where the value is |
//!
//! A kind that does not inline an op computes it in its `unary_call` or
//! `binary_call` rule (`div` defaults to `binary_call`).
//!
//! # Why forward AD is a kind of its own, not `Dual<N>`
//!
//! The two AD kinds are not one derivative rule set over two base kinds.
//! The point-gradient kind must repeat the reference's f64 operations in
//! the reference's order, densely (`0·∞` is NaN, so a known-zero
//! derivative cannot be skipped), and poison with NaN; the
//! interval-gradient kind skips derivatives known to be 0 or 1 at compile
//! time, multiplies by constants of known sign with one product a bound,
//! tracks value and derivative flags apart, and divides by `2√a` inline
//! with a positivity test. Their inline sets differ too (`div`, `powi 0`
//! and negative powers only in the point one), and `abs`, `min`, `max`
//! have kind-specific rules. A `Dual<N>` would have to move nearly every
//! derivative rule into the base kind (as [`crate::eval::grad::Num`] does
//! with `abs_d`, `select_d`, …) and, where a rule were shared, change the
//! emitted instruction order (`a'·b + a·b'` against `a·b' + b·a'`). So each
//! AD kind is a [`NumKind`] whose value half calls its base kind's rules
//! (the point kind's, the interval functions), and whose derivative rules
//! are its own: every value rule is written once, every derivative rule
//! once per AD kind, and the op dispatch once.

use super::Env;
use crate::ir::{BinOp, Const, Op, Program, UnOp, Var};

/// A number kind in generated code: how each op is lowered for one kernel
/// kind (see the module doc). Every rule emits into `env` and returns
/// [`NumKind::Out`], which [`NumKind::finish`] turns into the value.
pub(super) trait NumKind {
    /// An input variable as the entry point provides it.
    type In: Copy;
    /// An IR value in generated code.
    type V: Copy;
    /// What a rule returns, before [`NumKind::finish`].
    type Out;

    /// The input variable `var`, given as `x`.
    fn var(&self, env: &mut Env, var: Var, x: Self::In) -> Self::Out;
    /// The constant `c` of instruction `i` (its pool record).
    fn konst(&self, env: &mut Env, i: usize, c: Const) -> Self::Out;
    /// `−a`.
    fn neg(&self, env: &mut Env, a: Self::V) -> Self::Out;
    /// `|a|`.
    fn abs(&self, env: &mut Env, a: Self::V) -> Self::Out;
    /// `√a`.
    fn sqrt(&self, env: &mut Env, a: Self::V) -> Self::Out;
    /// `a²`.
    fn square(&self, env: &mut Env, a: Self::V) -> Self::Out;
    /// `a + b`.
    fn add(&self, env: &mut Env, a: Self::V, b: Self::V) -> Self::Out;
    /// `a − b`.
    fn sub(&self, env: &mut Env, a: Self::V, b: Self::V) -> Self::Out;
    /// `a · b`.
    fn mul(&self, env: &mut Env, a: Self::V, b: Self::V) -> Self::Out;
    /// `a / b`; by default the helper ([`NumKind::binary_call`]).
    fn div(&self, env: &mut Env, a: Self::V, b: Self::V) -> Self::Out {
        self.binary_call(env, BinOp::Div, a, b)
    }
    /// `min(a, b)`.
    fn min(&self, env: &mut Env, a: Self::V, b: Self::V) -> Self::Out;
    /// `max(a, b)`.
    fn max(&self, env: &mut Env, a: Self::V, b: Self::V) -> Self::Out;
    /// `a^n` (instruction `i`, whose pool record holds `1`).
    fn powi(&self, env: &mut Env, i: usize, a: Self::V, n: i64) -> Self::Out;
    /// A unary op without an inline rule in this kind.
    fn unary_call(&self, env: &mut Env, u: UnOp, a: Self::V) -> Self::Out;
    /// A binary op without an inline rule in this kind.
    fn binary_call(&self, env: &mut Env, op: BinOp, a: Self::V, b: Self::V) -> Self::Out;
    /// The value of an instruction whose rule returned `r`, given its
    /// operands' values in operand order.
    fn finish(&self, env: &mut Env, r: Self::Out, args: impl Iterator<Item = Self::V>) -> Self::V;
}

/// Emits the body of `prog` in kind `k`; returns the output's value.
pub(super) fn body<K: NumKind>(env: &mut Env, k: &K, prog: &Program, input: [K::In; 4]) -> K::V {
    let mut vals: Vec<K::V> = Vec::with_capacity(prog.len());
    for (i, op) in prog.insts.iter().enumerate() {
        let get = |v: crate::ir::Value| vals[v.index()];
        let r = match *op {
            Op::Var(var) => k.var(env, var, input[var.index()]),
            Op::Const(c) => k.konst(env, i, c),
            Op::Unary(u, a) => {
                let a = get(a);
                match u {
                    UnOp::Neg => k.neg(env, a),
                    UnOp::Abs => k.abs(env, a),
                    UnOp::Sqrt => k.sqrt(env, a),
                    UnOp::Square => k.square(env, a),
                    _ => k.unary_call(env, u, a),
                }
            }
            Op::Binary(op, a, b) => {
                let (a, b) = (get(a), get(b));
                match op {
                    BinOp::Add => k.add(env, a, b),
                    BinOp::Sub => k.sub(env, a, b),
                    BinOp::Mul => k.mul(env, a, b),
                    BinOp::Div => k.div(env, a, b),
                    BinOp::Min => k.min(env, a, b),
                    BinOp::Max => k.max(env, a, b),
                    _ => k.binary_call(env, op, a, b),
                }
            }
            Op::Powi(a, n) => k.powi(env, i, get(a), n),
        };
        let v = k.finish(env, r, op.args().map(get));
        vals.push(v);
    }
    vals[prog.output.index()]
}
