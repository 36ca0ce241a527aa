//! One sign mask per kernel: every scalar `fneg` and `fabs` becomes one
//! bitwise instruction.
//!
//! The interval kernels hold a value as `(−lo, hi)` and negate all the
//! time (a product negates three bounds, a square one, every stored lower
//! bound one; odd powers take absolute values). Cranelift's x86-64 backend
//! lowers each `fneg.f64` (`fabs.f64`) to `movabs` + `movq` + `xorpd`
//! (`andpd`): the mask `0x8000…` (`0x7FFF…`) is rebuilt through a general
//! register at every use. [`share`] rewrites a built function so that each
//! mask it needs is loaded once, at the top of the entry block, from a
//! static, and every scalar `fneg` is `bxor` with the sign mask, every
//! `fabs` `band` with the magnitude mask — bit for bit the same results
//! (both only touch the sign bit, NaN payloads included), in one
//! instruction while the mask stays in a register.
//!
//! It runs after an entry point is built and before Cranelift compiles
//! it. Vector negations and absolute values (`F64X2`, the batch point
//! kernel) are left alone: their lowering needs no general register.

use cranelift_codegen::cursor::{Cursor, FuncCursor};
use cranelift_codegen::ir::{Function, Inst, InstBuilder, MemFlagsData, Opcode, Value, types};

/// The sign bit and its complement, read by the kernels.
static MASKS: [u64; 2] = [0x8000_0000_0000_0000, 0x7FFF_FFFF_FFFF_FFFF];

/// Rewrites every `fneg.f64` of `func` as `bxor` with the sign mask and
/// every `fabs.f64` as `band` with the magnitude mask, each mask loaded
/// once at the start of the entry block (only the masks used).
pub(super) fn share(func: &mut Function, ptr: types::Type) {
    let of = |func: &Function, op: Opcode| -> Vec<Inst> {
        func.layout
            .blocks()
            .flat_map(|b| func.layout.block_insts(b))
            .filter(|&i| {
                func.dfg.insts[i].opcode() == op
                    && func.dfg.value_type(func.dfg.inst_args(i)[0]) == types::F64
            })
            .collect()
    };
    let (negs, abss) = (of(func, Opcode::Fneg), of(func, Opcode::Fabs));
    let Some(first) = func
        .layout
        .entry_block()
        .and_then(|b| func.layout.first_inst(b))
    else {
        return;
    };
    let mask = |func: &mut Function, k: usize| -> Value {
        let mut cur = FuncCursor::new(func).at_inst(first);
        let addr = cur.ins().iconst(ptr, &MASKS[k] as *const u64 as i64);
        cur.ins()
            .load(types::F64, MemFlagsData::trusted().with_readonly(), addr, 0)
    };
    if !negs.is_empty() {
        let m = mask(func, 0);
        for inst in negs {
            let x = func.dfg.inst_args(inst)[0];
            func.replace(inst).bxor(x, m);
        }
    }
    if !abss.is_empty() {
        let m = mask(func, 1);
        for inst in abss {
            let x = func.dfg.inst_args(inst)[0];
            func.replace(inst).band(x, m);
        }
    }
}
