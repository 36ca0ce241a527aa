//! Building a [`Program`]: hash-consing (CSE), constant folding and algebraic
//! simplification happen as each instruction is added, so the program is
//! simplified by construction; [`Builder::finish`] then removes dead code.
//!
//! Order of work for a new instruction: (1) operands of commutative ops are
//! put in a canonical order; (2) [`super::fold`] folds an op whose operands
//! are all constants (soundly, see that module); (3) [`super::simplify`]
//! rewrites it into something cheaper, possibly adding instructions through
//! this builder; (4) hash-consing returns the existing value if the same
//! instruction was built before.

use std::collections::HashMap;

use super::{BinOp, Const, Op, Program, UnOp, Value, Var, dce, fold, simplify};

/// Incremental program builder. See the module doc.
///
/// # Example
///
/// Build `x² + y² − 1` (constants fold as they are built), evaluate it
/// with the reference interpreter, and round-trip its text form
/// (`isoc compile --emit ir`):
///
/// ```
/// use isoc::ir::{BinOp, Builder, Var, text};
///
/// let mut b = Builder::new();
/// let (x, y) = (b.var(Var::X), b.var(Var::Y));
/// let (x2, y2) = (b.powi(x, 2), b.powi(y, 2));
/// let sum = b.binary(BinOp::Add, x2, y2);
/// let one = b.num(1.0);
/// let f = b.binary(BinOp::Sub, sum, one);
/// let program = b.finish(f);
/// assert_eq!(isoc::eval::point::eval(&program, [3.0, 4.0, 0.0, 0.0]), 24.0);
/// let printed = program.to_string();
/// assert_eq!(text::parse(&printed).unwrap().to_string(), printed);
/// ```
#[derive(Default)]
pub struct Builder {
    insts: Vec<Op>,
    seen: HashMap<Op, Value>,
}

impl Builder {
    /// An empty builder.
    pub fn new() -> Self {
        Builder::default()
    }

    /// The input variable `v`.
    pub fn var(&mut self, v: Var) -> Value {
        self.intern(Op::Var(v))
    }

    /// A constant (see [`Const`]; literals come from [`Const::literal`]).
    pub fn constant(&mut self, c: Const) -> Value {
        self.intern(Op::Const(c))
    }

    /// The exact constant `v`.
    pub fn num(&mut self, v: f64) -> Value {
        self.constant(Const::exact(v))
    }

    /// `op(a)`, folded and simplified.
    pub fn unary(&mut self, op: UnOp, a: Value) -> Value {
        if let Some(ca) = self.as_const(a) {
            return self.constant(fold::unary(op, ca));
        }
        match simplify::unary(self, op, a) {
            Some(v) => v,
            None => self.intern(Op::Unary(op, a)),
        }
    }

    /// `op(a, b)`, folded and simplified.
    pub fn binary(&mut self, op: BinOp, a: Value, b: Value) -> Value {
        let (a, b) = if op.is_commutative() && b < a {
            (b, a)
        } else {
            (a, b)
        };
        if let (Some(ca), Some(cb)) = (self.as_const(a), self.as_const(b)) {
            return self.constant(fold::binary(op, ca, cb));
        }
        match simplify::binary(self, op, a, b) {
            Some(v) => v,
            None => self.intern(Op::Binary(op, a, b)),
        }
    }

    /// `a^n` for an integer `n`.
    pub fn powi(&mut self, a: Value, n: i64) -> Value {
        if let Some(ca) = self.as_const(a) {
            return self.constant(fold::powi(ca, n));
        }
        match simplify::powi(self, a, n) {
            Some(v) => v,
            None => self.intern(Op::Powi(a, n)),
        }
    }

    /// The language's `a ^ b`: an integer power when `b` is a constant
    /// integer that fits `i64` exactly (its point value and enclosure are
    /// that integer), else `pow(a, b) = exp(b·ln a)`, defined for `a > 0`.
    pub fn power(&mut self, a: Value, b: Value) -> Value {
        if let Some(n) = self.as_const(b).and_then(|c| c.as_integer()) {
            return self.powi(a, n);
        }
        self.binary(BinOp::Pow, a, b)
    }

    /// The constant behind `v`, if `v` is one.
    pub fn as_const(&self, v: Value) -> Option<Const> {
        match self.insts[v.index()] {
            Op::Const(c) => Some(c),
            _ => None,
        }
    }

    /// The instruction that defines `v`.
    pub fn op(&self, v: Value) -> Op {
        self.insts[v.index()]
    }

    /// Number of instructions built so far (dead ones included).
    pub fn len(&self) -> usize {
        self.insts.len()
    }

    /// True before the first instruction.
    pub fn is_empty(&self) -> bool {
        self.insts.is_empty()
    }

    /// Adds `op` unless an identical instruction exists (hash-consing).
    fn intern(&mut self, op: Op) -> Value {
        if let Some(&v) = self.seen.get(&op) {
            return v;
        }
        let v = Value(self.insts.len() as u32);
        self.insts.push(op);
        self.seen.insert(op, v);
        v
    }

    /// The finished program with output `output`, dead code removed.
    pub fn finish(self, output: Value) -> Program {
        dce::eliminate(&Program {
            insts: self.insts,
            output,
        })
    }

    /// Rebuilds an existing program through a fresh builder: every
    /// instruction is folded, simplified and hash-consed again, then dead
    /// code is removed. Used for programs that did not come from a builder
    /// (the text form, the fuzzer).
    pub fn rebuild(program: &Program) -> Program {
        Builder::rebuild_with(program, |b, v| b.var(v))
    }

    /// `program` with the variable `var` fixed at `value`, rebuilt as by
    /// [`Builder::rebuild`], so that whatever depends on `var` alone is
    /// folded. Folding computes each op as the point evaluator does, so
    /// the result's point values are the original's at `var = value`, bit
    /// for bit up to the sign of zero.
    pub fn substitute(program: &Program, var: Var, value: f64) -> Program {
        Builder::rebuild_with(program, |b, v| {
            if v == var {
                b.constant(Const::exact(value))
            } else {
                b.var(v)
            }
        })
    }

    fn rebuild_with(program: &Program, mut var: impl FnMut(&mut Builder, Var) -> Value) -> Program {
        let mut b = Builder::new();
        let mut map: Vec<Value> = Vec::with_capacity(program.insts.len());
        for op in &program.insts {
            let v = match op.map_args(|a| map[a.index()]) {
                Op::Var(v) => var(&mut b, v),
                Op::Const(c) => b.constant(c),
                Op::Unary(u, a) => b.unary(u, a),
                Op::Binary(o, x, y) => b.binary(o, x, y),
                Op::Powi(a, n) => b.powi(a, n),
            };
            map.push(v);
        }
        b.finish(map[program.output.index()])
    }
}
