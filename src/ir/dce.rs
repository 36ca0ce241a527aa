//! Dead-code elimination: keeps only the instructions the output depends
//! on, renumbered densely in their original order (so the SSA invariant
//! "operands come first" still holds).

use super::{Program, Value};

/// The live part of `program`.
pub(crate) fn eliminate(program: &Program) -> Program {
    let n = program.insts.len();
    let mut live = vec![false; n];
    live[program.output.index()] = true;
    // Operands precede their users, so one backward sweep marks everything.
    for i in (0..n).rev() {
        if live[i] {
            for a in program.insts[i].args() {
                live[a.index()] = true;
            }
        }
    }
    let mut rename = vec![Value(u32::MAX); n];
    let mut insts = Vec::with_capacity(live.iter().filter(|l| **l).count());
    for (i, op) in program.insts.iter().enumerate() {
        if live[i] {
            rename[i] = Value(insts.len() as u32);
            insts.push(op.map_args(|a| rename[a.index()]));
        }
    }
    Program {
        insts,
        output: rename[program.output.index()],
    }
}
