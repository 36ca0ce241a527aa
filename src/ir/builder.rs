//! Building a [`Program`]: hash-consing (CSE), constant folding and algebraic
//! simplification happen as each instruction is added, so the program is
//! simplified by construction; [`Builder::finish`] then removes dead code.

use super::{BinOp, Const, Op, Program, UnOp, Value, Var};

/// Incremental program builder. See the module doc.
#[derive(Default)]
pub struct Builder {
    insts: Vec<Op>,
}

impl Builder {
    pub fn new() -> Self {
        Builder::default()
    }

    /// The input variable `v`.
    pub fn var(&mut self, v: Var) -> Value {
        self.push(Op::Var(v))
    }

    /// A constant (see [`Const`]; literals come from [`Const::literal`]).
    pub fn constant(&mut self, c: Const) -> Value {
        self.push(Op::Const(c))
    }

    /// `op(a)`, folded and simplified.
    pub fn unary(&mut self, op: UnOp, a: Value) -> Value {
        self.push(Op::Unary(op, a))
    }

    /// `op(a, b)`, folded and simplified.
    pub fn binary(&mut self, op: BinOp, a: Value, b: Value) -> Value {
        self.push(Op::Binary(op, a, b))
    }

    /// `a^n` for an integer `n`.
    pub fn powi(&mut self, a: Value, n: i64) -> Value {
        self.push(Op::Powi(a, n))
    }

    /// The language's `a ^ b`: an integer power when `b` is a constant
    /// integer, else `pow(a, b)`.
    pub fn power(&mut self, a: Value, b: Value) -> Value {
        self.binary(BinOp::Pow, a, b)
    }

    /// The constant behind `v`, if `v` is one.
    pub fn as_const(&self, v: Value) -> Option<Const> {
        match self.insts[v.index()] {
            Op::Const(c) => Some(c),
            _ => None,
        }
    }

    fn push(&mut self, op: Op) -> Value {
        let v = Value(self.insts.len() as u32);
        self.insts.push(op);
        v
    }

    /// The finished program with output `output`, dead code removed.
    pub fn finish(self, output: Value) -> Program {
        Program {
            insts: self.insts,
            output,
        }
    }
}
