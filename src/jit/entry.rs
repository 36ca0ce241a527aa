//! Entry points: signatures, names, the batch loop, and the rounding-mode
//! bracket of the interval kernels.
//!
//! Each kernel kind has a batch entry point, and every kind but the point
//! gradient a single one (ABI table in [`super`]). The batch entry point is
//! one loop over the records whose body is the single body
//! ([`super::batch_loop`]). The interval and gradient batch entry points
//! call `isoc_rm_enter` first and `isoc_rm_leave` before returning
//! ([`super::mxcsr`]): a batch switches the mode once, not once per box.
//! Their single entry points switch nothing: the safe single calls
//! bracket them with inline assembly ([`super::mxcsr::call_interval_up`]),
//! which does not read the MXCSR of a caller that rounds to nearest
//! (reading it stalls behind the previous call's restoring `ldmxcsr`).

use cranelift_codegen::ir as clif;
use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{AbiParam, InstBuilder, Signature, StackSlotData, StackSlotKind};
use cranelift_codegen::ir::{Value, types};

use super::helpers::Helper;
use super::{Env, JitOptions, Kind, batch_loop, grad, interval, pgrad, point, simd};
use crate::ir;

pub(super) fn entry_name(kind: Kind, batch: bool) -> &'static str {
    match (kind, batch) {
        (Kind::Point, false) => "point",
        (Kind::Point, true) => "point_batch",
        (Kind::Interval, false) => "interval",
        (Kind::Interval, true) => "interval_batch",
        (Kind::Grad, false) => "grad",
        (Kind::Grad, true) => "grad_batch",
        (Kind::PointGrad, false) => "point_grad",
        (Kind::PointGrad, true) => "point_grad_batch",
    }
}

pub(super) fn entry_sig(
    kind: Kind,
    batch: bool,
    cc: cranelift_codegen::isa::CallConv,
    ptr: clif::Type,
) -> Signature {
    use types::{F64, I64};
    let mut s = Signature::new(cc);
    let (params, ret): (Vec<clif::Type>, Option<clif::Type>) = match (kind, batch) {
        (Kind::Point, false) => (vec![F64; 4], Some(F64)),
        (Kind::Point, true) | (Kind::PointGrad, true) => (vec![ptr, ptr, ptr, F64, ptr, I64], None),
        // The point-gradient kind has no single entry point.
        (Kind::Interval, false) => {
            s.returns.push(AbiParam::new(F64));
            s.returns.push(AbiParam::new(F64));
            (vec![ptr, ptr], Some(types::I8))
        }
        (Kind::Grad, false) => (vec![ptr, ptr, ptr], Some(types::I8)),
        (_, _) => (vec![ptr, ptr, ptr, I64], None),
    };
    s.params.extend(params.into_iter().map(AbiParam::new));
    s.returns.extend(ret.map(AbiParam::new));
    s
}

/// Emits the entry point's body (loop for batch) into `env`, starting in
/// `entry`, whose parameters are the function's.
pub(super) fn emit_entry(
    env: &mut Env,
    prog: &ir::Program,
    kind: Kind,
    batch: bool,
    entry: clif::Block,
    opts: &JitOptions,
) {
    let params: Vec<Value> = env.b.block_params(entry).to_vec();
    match kind {
        Kind::PointGrad => pgrad::emit_batch(env, prog, &params, opts.simd),
        Kind::Point if batch && opts.simd => simd::emit_point_batch(env, prog, &params),
        Kind::Point if batch => {
            let f = Env::flags();
            batch_loop(env, params[5], |env, i| {
                let off = env.b.ins().imul_imm_s(i, 8);
                let [x, y, z] = [0, 1, 2].map(|k| {
                    let a = env.b.ins().iadd(params[k], off);
                    env.b.ins().load(types::F64, f, a, 0)
                });
                let r = point::lower::<point::Scalar>(env, prog, [x, y, z, params[3]]);
                let oa = env.b.ins().iadd(params[4], off);
                env.b.ins().store(f, r, oa, 0);
            });
            env.b.ins().return_(&[]);
        }
        Kind::Point => {
            let r = point::lower::<point::Scalar>(
                env,
                prog,
                [params[0], params[1], params[2], params[3]],
            );
            env.b.ins().return_(&[r]);
        }
        Kind::Interval | Kind::Grad if batch => emit_box_batch(env, prog, kind, &params),
        Kind::Interval | Kind::Grad => emit_box_single(env, prog, kind, &params),
    }
}

/// The variables the output of `prog` depends on (only those are loaded:
/// the others cannot change its value, nor its flag, which flows from
/// operands to results).
fn used_vars(prog: &ir::Program) -> [bool; 4] {
    let mut live = vec![false; prog.len()];
    if let Some(l) = live.get_mut(prog.output.index()) {
        *l = true;
    }
    let mut used = [false; 4];
    for i in (0..prog.len()).rev() {
        if !live[i] {
            continue;
        }
        match &prog.insts[i] {
            ir::Op::Var(v) => used[v.index()] = true,
            op => {
                for a in op.args() {
                    if let Some(l) = live.get_mut(a.index()) {
                        *l = true;
                    }
                }
            }
        }
    }
    used
}

/// One box: reads the record at `ia`, stores the result at `oa`, returns
/// the decoration.
fn emit_box_record(
    env: &mut Env,
    prog: &ir::Program,
    kind: Kind,
    used: [bool; 4],
    ia: Value,
    oa: Value,
) -> Value {
    let (input, ok) = box_input(env, used, ia);
    let d = store_box_result(env, prog, kind, input, oa);
    env.b.ins().band(d, ok)
}

/// The four input intervals of the record at `ia`, normalised, and their
/// flag: 1 when every bound read is a number (the `i8` AND of the inputs'
/// flags). Only the variables the output depends on are loaded
/// ([`used_vars`]), so that flag is what the output's decoration gets from
/// the inputs: the intervals come with a statically true flag, and the
/// caller ANDs it into the decoration once.
///
/// Normalising a NaN bound (the entire line, undefined) takes two selects
/// a bound; so the common case, every bound a number, branches past them:
/// both paths join in a block whose parameters are the normalised bounds
/// ([`interval::normalize_ordered`] on the fast path,
/// [`interval::normalize`] on the other), and the body is emitted once.
fn box_input(
    env: &mut Env,
    used: [bool; 4],
    ia: Value,
) -> ([(interval::Iv, interval::Flag); 4], Value) {
    let raw: Vec<(usize, (Value, Value))> = (0..4)
        .filter(|&k| used[k])
        .map(|k| (k, env.read_lo_hi(ia, 16 * k as i32)))
        .collect();
    let zero = |env: &mut Env| {
        let z = env.b.ins().f64const(0.0);
        ((z, z), None)
    };
    if raw.is_empty() {
        let one = env.b.ins().iconst(types::I8, 1);
        return ([(); 4].map(|_| zero(env)), one);
    }
    let join = env.b.create_block();
    let slow = env.b.create_block();
    let mut all = None;
    let mut fast_args: Vec<clif::BlockArg> = Vec::new();
    for &(_, (lo, hi)) in &raw {
        let ok = env.b.ins().fcmp(FloatCC::Ordered, lo, hi);
        all = Some(match all {
            None => ok,
            Some(a) => env.b.ins().band(a, ok),
        });
        let (n, h) = interval::normalize_ordered(env, (lo, hi));
        fast_args.extend([n, h].map(clif::BlockArg::from));
        env.b.append_block_param(join, types::F64);
        env.b.append_block_param(join, types::F64);
    }
    let all = all.expect("some variable is read");
    env.b.ins().brif(all, join, &fast_args, slow, &[]);
    env.b.switch_to_block(slow);
    let mut slow_args: Vec<clif::BlockArg> = Vec::new();
    for &(_, lo_hi) in &raw {
        let ((n, h), _) = interval::normalize(env, lo_hi);
        slow_args.extend([n, h].map(clif::BlockArg::from));
    }
    env.b.ins().jump(join, &slow_args);
    env.b.switch_to_block(join);
    let params = env.b.block_params(join).to_vec();
    let mut out = [(); 4].map(|_| None);
    for (j, &(k, _)) in raw.iter().enumerate() {
        out[k] = Some(((params[2 * j], params[2 * j + 1]), None));
    }
    (out.map(|v| v.unwrap_or_else(|| zero(env))), all)
}

/// The single-box interval or gradient entry point. It does not switch
/// the rounding mode: its caller does, around the call
/// ([`super::mxcsr::call_interval_up`]), so the body runs in round-up mode
/// from entry to return and its results travel back in registers — the
/// bounds and the flag for the interval kind, the flag for the gradient,
/// whose eight bounds are stored at `out`.
fn emit_box_single(env: &mut Env, prog: &ir::Program, kind: Kind, params: &[Value]) {
    let used = used_vars(prog);
    if kind == Kind::Interval {
        let (input, ok) = box_input(env, used, params[0]);
        let ((n, h), d) = interval::lower(env, prog, input);
        let d = env.b.ins().band(d, ok);
        let lo = env.b.ins().fneg(n);
        env.b.ins().return_(&[lo, h, d]);
    } else {
        let d = emit_box_record(env, prog, kind, used, params[0], params[1]);
        env.b.ins().return_(&[d]);
    }
}

/// The interval or gradient batch entry point, bracketed by the
/// rounding-mode switch.
fn emit_box_batch(env: &mut Env, prog: &ir::Program, kind: Kind, params: &[Value]) {
    let save_slot =
        env.b
            .create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 8, 3));
    let save = env.b.ins().stack_addr(env.ptr, save_slot, 0);
    env.call_void(Helper::RmEnter, &[save]);
    let f = Env::flags();
    let stride = if kind == Kind::Interval { 16 } else { 64 };
    let used = used_vars(prog);
    batch_loop(env, params[3], |env, i| {
        let in_off = env.b.ins().imul_imm_s(i, 64);
        let ia = env.b.ins().iadd(params[0], in_off);
        let out_off = env.b.ins().imul_imm_s(i, stride);
        let oa = env.b.ins().iadd(params[1], out_off);
        let d = emit_box_record(env, prog, kind, used, ia, oa);
        let da = env.b.ins().iadd(params[2], i);
        env.b.ins().store(f, d, da, 0);
    });
    // The slot's address is recomputed rather than kept live across the
    // loop.
    let save = env.b.ins().stack_addr(env.ptr, save_slot, 0);
    env.call_void(Helper::RmLeave, &[save]);
    env.b.ins().return_(&[]);
}

/// Lowers the interval or gradient body and stores its result at `out`;
/// returns the decoration.
fn store_box_result(
    env: &mut Env,
    prog: &ir::Program,
    kind: Kind,
    input: [(interval::Iv, interval::Flag); 4],
    out: Value,
) -> Value {
    let (ivs, d): (Vec<interval::Iv>, Value) = if kind == Kind::Interval {
        let (iv, d) = interval::lower(env, prog, input);
        (vec![iv], d)
    } else {
        let (g, d) = grad::lower(env, prog, input);
        (g.to_vec(), d)
    };
    for (k, iv) in ivs.into_iter().enumerate() {
        env.store_iv(out, (16 * k) as i32, iv);
    }
    d
}
