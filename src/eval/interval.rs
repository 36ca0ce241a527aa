//! Interval evaluation: every instruction's enclosure, front to back.
//!
//! Each value carries its own decoration: an instruction is `defined` when
//! its op is defined and continuous on its operands' enclosures *and* its
//! operands are defined, so an unused undefined value (dead code) does not
//! spoil the output's flag. Inputs are normalised with
//! [`Interval::normalize`] (a NaN bound gives an entire, undefined input).

use crate::interval::{DecInterval, Interval};
use crate::ir::{Op, Program, Value};

/// The enclosure of one instruction given the enclosures before it.
/// An operand that does not refer to an earlier value (a malformed
/// program) reads as entire and undefined rather than panicking.
pub fn step(op: &Op, vals: &[DecInterval], input: [Interval; 4]) -> DecInterval {
    let get = |v: Value| {
        vals.get(v.index())
            .copied()
            .unwrap_or(DecInterval::new(Interval::ENTIRE, false))
    };
    match *op {
        Op::Var(v) => {
            let (iv, ok) = input[v.index()].normalize();
            DecInterval::new(iv, ok)
        }
        Op::Const(c) => {
            let (iv, ok) = Interval::new(c.lo, c.hi).normalize();
            DecInterval::new(iv, ok && c.defined)
        }
        Op::Unary(u, a) => {
            let a = get(a);
            let (iv, ok) = crate::ir::semantics::enclose_unary(u, a.iv);
            DecInterval::new(iv, ok && a.defined)
        }
        Op::Binary(b, x, y) => {
            let (x, y) = (get(x), get(y));
            let (iv, ok) = crate::ir::semantics::enclose_binary(b, x.iv, y.iv);
            DecInterval::new(iv, ok && x.defined && y.defined)
        }
        Op::Powi(a, n) => {
            let a = get(a);
            let (iv, ok) = crate::ir::semantics::enclose_powi(a.iv, n);
            DecInterval::new(iv, ok && a.defined)
        }
    }
}

/// Enclosures of all instructions over the box, in program order.
pub fn eval_all(program: &Program, input: [Interval; 4]) -> Vec<DecInterval> {
    let mut vals = Vec::with_capacity(program.insts.len());
    for op in &program.insts {
        let v = step(op, &vals, input);
        vals.push(v);
    }
    vals
}

/// Enclosure of the program over the box `[x, y, z, t]`.
pub fn eval(program: &Program, input: [Interval; 4]) -> DecInterval {
    // Short (pruned) programs run in a buffer on the stack, sized to the
    // program (filling it is part of the cost).
    let out = match program.insts.len() {
        0..=8 => eval_on_stack::<8>(program, input),
        9..=16 => eval_on_stack::<16>(program, input),
        17..=32 => eval_on_stack::<32>(program, input),
        _ => eval_all(program, input)
            .get(program.output.index())
            .copied(),
    };
    out.unwrap_or(DecInterval::new(Interval::ENTIRE, false))
}

/// [`eval`] for programs of at most `S` instructions.
fn eval_on_stack<const S: usize>(program: &Program, input: [Interval; 4]) -> Option<DecInterval> {
    let mut vals = [DecInterval::new(Interval::ENTIRE, false); S];
    for (i, op) in program.insts.iter().enumerate() {
        vals[i] = step(op, &vals[..i], input);
    }
    vals[..program.insts.len()]
        .get(program.output.index())
        .copied()
}
