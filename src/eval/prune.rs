//! Per-cell program pruning: the shorter program that equals the full one
//! on a box (Fidget's tape simplification; Keeter, *Massively Parallel
//! Rendering of Complex Closed-Form Implicit Surfaces*, SIGGRAPH 2020).
//!
//! # Contract
//!
//! [`prune`] evaluates a program's enclosures over a box `B` and, for every
//! selecting instruction whose choice is certain on `B`, replaces its uses
//! by the operand it selects; dead code then goes. The decisions:
//!
//! | op | replaced by `a` when | replaced by `b` when |
//! |---|---|---|
//! | `min a b` | `a.hi < b.lo` | `b.hi < a.lo` |
//! | `max a b` | `a.lo > b.hi` | `b.lo > a.hi` |
//! | `and a b` | `a = [0, 0]` | `0 ∉ a` |
//! | `or a b` | `0 ∉ a` | `a = [0, 0]` |
//!
//! and in every case the operand dropped is non-empty and *defined* on `B`
//! (its interval flag): an undefined operand may be NaN somewhere, and NaN
//! propagates through `min`, so it cannot be dropped. A decision taken on
//! `B` holds on every sub-box of `B` and at every point of `B` (enclosures
//! only shrink), so the pruned program may be used for a whole subtree of
//! cells, and pruned again deeper down.
//!
//! What "equals" means, for every box `B' ⊆ B` and every point `p ∈ B`,
//! with the reference evaluators ([`crate::eval`]):
//!
//! * **points:** the pruned program's value is the full one's, bit for
//!   bit, except where the dropped operand's *floating-point* value is NaN
//!   although its interval is defined — an overflow inside it (`∞ − ∞`):
//!   there the full program is NaN and the pruned one the selected value;
//! * **enclosures:** interval values are identical, flag included (the
//!   full `min`'s enclosure is exactly its winner's when the choice is
//!   certain, and the dropped operand's flag is true);
//! * **gradients:** identical enclosures wherever the function is defined
//!   somewhere on the box (over a box where it is nowhere defined, the
//!   value is empty and the derivatives mean nothing); the pruned program's flag may be
//!   *true* where the full one's is false, when the dropped operand was
//!   defined but not differentiable: the function is the winner on the
//!   whole box, so the pruned flag is the right one.
//!
//! A property test (`tests/eval/eval.rs`) checks all three on random CSG
//! programs and random boxes.
//!
//! # Limits
//!
//! Only the four selecting ops are pruned; `abs`, `compare` and the other
//! piecewise ops are left whole (their value is not one of their operands).
//! A prune costs one reference interval evaluation of the program being
//! pruned; the octree ([`crate::octree`]) decides when that pays.
//!
//! # Example
//!
//! ```
//! use isoc::eval::prune::prune;
//! use isoc::interval::Interval;
//! use isoc::ir::{BinOp, Builder, Var};
//!
//! // min(x, y + 10): on x ∈ [0, 1], y ∈ [0, 1] the first operand wins.
//! let mut b = Builder::new();
//! let x = b.var(Var::X);
//! let y = b.var(Var::Y);
//! let ten = b.num(10.0);
//! let y10 = b.binary(BinOp::Add, y, ten);
//! let m = b.binary(BinOp::Min, x, y10);
//! let program = b.finish(m);
//! let unit = Interval { lo: 0.0, hi: 1.0 };
//! let pruned = prune(&program, [unit, unit, unit, Interval::point(0.0)]);
//! assert_eq!(pruned.insts.len(), 1); // just `var x`
//! ```

use crate::interval::{DecInterval, Interval};
use crate::ir::{BinOp, Op, Program, Value};

use super::interval::eval_all;

/// Which operand a selecting op surely picks on a box, if it surely picks
/// one and the other may be dropped (see the module doc's table).
fn decide(op: &Op, vals: &[DecInterval]) -> Option<Value> {
    let Op::Binary(bop, a, b) = *op else {
        return None;
    };
    let (x, y) = (vals[a.index()], vals[b.index()]);
    if x.iv.is_empty() || y.iv.is_empty() {
        return None;
    }
    let zero = |i: Interval| i.lo == 0.0 && i.hi == 0.0;
    let nonzero = |i: Interval| !i.contains(0.0);
    let (first, second) = match bop {
        BinOp::Min => (x.iv.hi < y.iv.lo, y.iv.hi < x.iv.lo),
        BinOp::Max => (x.iv.lo > y.iv.hi, y.iv.lo > x.iv.hi),
        BinOp::And => (zero(x.iv), nonzero(x.iv)),
        BinOp::Or => (nonzero(x.iv), zero(x.iv)),
        _ => return None,
    };
    if first && y.defined {
        Some(a)
    } else if second && x.defined {
        Some(b)
    } else {
        None
    }
}

/// Whether `program` has an instruction [`prune`] could remove a branch of.
pub fn has_choices(program: &Program) -> bool {
    program.insts.iter().any(|op| {
        matches!(
            op,
            Op::Binary(BinOp::Min | BinOp::Max | BinOp::And | BinOp::Or, _, _)
        )
    })
}

/// The program `program` restricted to the box `input` (see the module
/// doc). Never longer than `program`; equal to its dead-code-eliminated
/// form when no choice is certain.
pub fn prune(program: &Program, input: [Interval; 4]) -> Program {
    let n = program.insts.len();
    if n == 0 || program.output.index() >= n {
        return program.clone();
    }
    let vals = eval_all(program, input);
    // alias[i]: the instruction whose value instruction i's value is.
    let mut alias: Vec<u32> = (0..n as u32).collect();
    for (i, op) in program.insts.iter().enumerate() {
        if let Some(v) = decide(op, &vals) {
            alias[i] = alias[v.index()];
        }
    }
    let resolve = |v: Value| alias[v.index()] as usize;
    let out = resolve(program.output);
    // Operands precede their users: one backward sweep marks the live
    // instructions, following aliases.
    let mut live = vec![false; n];
    live[out] = true;
    for i in (0..n).rev() {
        if live[i] && alias[i] as usize == i {
            for a in program.insts[i].args() {
                live[resolve(a)] = true;
            }
        }
    }
    let mut rename = vec![Value(u32::MAX); n];
    let mut insts = Vec::with_capacity(live.iter().filter(|l| **l).count());
    for (i, op) in program.insts.iter().enumerate() {
        if live[i] {
            rename[i] = Value(insts.len() as u32);
            insts.push(op.map_args(|a| rename[resolve(a)]));
        }
    }
    Program {
        insts,
        output: rename[out],
    }
}
