//! The F64X2 batch loop, two points per iteration: the batch point
//! kernel's, and the point gradient's second tier
//! ([`super::pgrad`], whose derivative rules run at the same width).
//!
//! The point kernel's body is [`super::point::lower`] (the point kind's
//! rules) at width [`X2`]: every inline op is the same IEEE operation on
//! an `F64X2` (`fneg fabs sqrt fadd fsub fmul fdiv fmin fmax`, whose
//! Cranelift semantics are per lane those of the scalar forms:
//! `fmin`/`fmax` propagate NaN and order `-0 < +0`), `a / ±0` is NaN by
//! a lane mask (`fcmp eq` + `bitselect`), `powi` is the same
//! multiplication chain per lane, and the ops that call a helper extract
//! both lanes, call the scalar helper twice and rebuild the vector. So
//! every lane is bit for bit the scalar kernel's value (NaN payloads
//! aside: a NaN is a NaN).
//!
//! The loop ([`emit_loop`]): while at least two points remain, load two
//! `x`, `y`, `z` (unaligned), evaluate, store two results (a kind with
//! several outputs per point, as the point gradient's four, stores them
//! lane by lane into each point's record); an odd last point is splatted
//! into both lanes, evaluated by the same body, and lane 0 stored. `t` is
//! splatted once.

use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{InstBuilder, MemFlagsData, Value, types};

use super::Env;
use super::point::{Width, lower};
use crate::ir::{BinOp, Program, UnOp};

const VT: cranelift_codegen::ir::Type = types::F64X2;

/// Flags of the vector loads and stores: not trapping, but *not* claimed
/// 16-byte aligned (the buffers are only 8-byte aligned).
fn vflags() -> MemFlagsData {
    MemFlagsData::new().with_notrap()
}

/// Emits the point kernel's batch loop; `params` are the batch entry's
/// `(xs, ys, zs, t, out, n)`.
pub(super) fn emit_point_batch(env: &mut Env, prog: &Program, params: &[Value]) {
    emit_loop(env, params, |env, input| {
        vec![lower::<X2>(env, prog, input)]
    });
}

/// Emits a batch loop of two points per iteration (see the module doc)
/// whose `body` maps the inputs `[x, y, z, t]` (two lanes each) to the
/// outputs of a point, in their order in `out` (two lanes each: `out`
/// holds, per point, one f64 per output); `params` are the batch entry's
/// `(xs, ys, zs, t, out, n)`.
pub(super) fn emit_loop(
    env: &mut Env,
    params: &[Value],
    body: impl FnOnce(&mut Env, [Value; 4]) -> Vec<Value>,
) {
    let (xs, ys, zs, t, out, n) = (
        params[0], params[1], params[2], params[3], params[4], params[5],
    );
    let sf = Env::flags();
    let vf = vflags();
    let tv = env.b.ins().splat(VT, t);

    let header = env.b.create_block();
    let load2 = env.b.create_block();
    let check1 = env.b.create_block();
    let load1 = env.b.create_block();
    let eval = env.b.create_block();
    let store2 = env.b.create_block();
    let store1 = env.b.create_block();
    let exit = env.b.create_block();
    env.b.append_block_param(header, types::I64);
    for _ in 0..3 {
        env.b.append_block_param(eval, VT);
    }
    env.b.append_block_param(eval, types::I64); // byte offset 8i
    env.b.append_block_param(eval, types::I8); // 1: two points, 0: one

    let zero = env.b.ins().iconst(types::I64, 0);
    env.b.ins().jump(header, &[zero.into()]);

    // header(i): two or more left → load2; else check1. Invariant i ≤ n.
    env.b.switch_to_block(header);
    let i = env.b.block_params(header)[0];
    let rem = env.b.ins().isub(n, i);
    let two_left = env
        .b
        .ins()
        .icmp_imm_u(IntCC::UnsignedGreaterThanOrEqual, rem, 2);
    env.b.ins().brif(two_left, load2, &[], check1, &[]);

    let addrs = |env: &mut Env, off: Value| [xs, ys, zs].map(|base| env.b.ins().iadd(base, off));

    env.b.switch_to_block(load2);
    let off = env.b.ins().imul_imm_s(i, 8);
    let a = addrs(env, off);
    let v = a.map(|p| env.b.ins().load(VT, vf, p, 0));
    let one = env.b.ins().iconst(types::I8, 1);
    env.b.ins().jump(
        eval,
        &[
            v[0].into(),
            v[1].into(),
            v[2].into(),
            off.into(),
            one.into(),
        ],
    );

    env.b.switch_to_block(check1);
    let more = env.b.ins().icmp(IntCC::UnsignedLessThan, i, n);
    env.b.ins().brif(more, load1, &[], exit, &[]);

    env.b.switch_to_block(load1);
    let off1 = env.b.ins().imul_imm_s(i, 8);
    let a = addrs(env, off1);
    let v = a.map(|p| {
        let s = env.b.ins().load(types::F64, sf, p, 0);
        env.b.ins().splat(VT, s)
    });
    let zero8 = env.b.ins().iconst(types::I8, 0);
    env.b.ins().jump(
        eval,
        &[
            v[0].into(),
            v[1].into(),
            v[2].into(),
            off1.into(),
            zero8.into(),
        ],
    );

    env.b.switch_to_block(eval);
    let bp: Vec<Value> = env.b.block_params(eval).to_vec();
    let r = body(env, [bp[0], bp[1], bp[2], tv]);
    // Point i's outputs start at out + 8·len(r)·i.
    let stride = 8 * r.len() as i64;
    let out_off = env.b.ins().imul_imm_s(bp[3], r.len() as i64);
    let oa = env.b.ins().iadd(out, out_off);
    env.b.ins().brif(bp[4], store2, &[], store1, &[]);

    env.b.switch_to_block(store2);
    if let [r] = r[..] {
        env.b.ins().store(vf, r, oa, 0);
    } else {
        for (k, &v) in r.iter().enumerate() {
            for lane in 0..2u8 {
                let x = env.b.ins().extractlane(v, lane);
                let at = i64::from(lane) * stride + 8 * k as i64;
                env.b.ins().store(sf, x, oa, at as i32);
            }
        }
    }
    let next = env.b.ins().iadd_imm_s(i, 2);
    env.b.ins().jump(header, &[next.into()]);

    env.b.switch_to_block(store1);
    for (k, &v) in r.iter().enumerate() {
        let x = env.b.ins().extractlane(v, 0);
        env.b.ins().store(sf, x, oa, 8 * k as i32);
    }
    env.b.ins().jump(exit, &[]);

    env.b.switch_to_block(exit);
    env.b.ins().return_(&[]);
}

/// Two f64 lanes per value: the body of the batch loop.
pub(super) struct X2;

impl Width for X2 {
    fn constant(env: &mut Env, i: usize) -> Value {
        splat_pool(env, i)
    }
    fn div_nan(env: &mut Env, a: Value, b: Value) -> Value {
        div_nan(env, a, b)
    }
    fn unary_helper(env: &mut Env, u: UnOp, a: Value) -> Value {
        let [a0, a1] = lanes(env, a);
        let r0 = env.call_pt_unary(u, a0);
        let r1 = env.call_pt_unary(u, a1);
        join(env, r0, r1)
    }
    fn binary_helper(env: &mut Env, op: BinOp, a: Value, b: Value) -> Value {
        let [a0, a1] = lanes(env, a);
        let [b0, b1] = lanes(env, b);
        let r0 = env.call_pt_binary(op, a0, b0);
        let r1 = env.call_pt_binary(op, a1, b1);
        join(env, r0, r1)
    }
    fn splat(env: &mut Env, x: Value) -> Value {
        env.b.ins().splat(VT, x)
    }
    fn test(env: &mut Env, cc: FloatCC, x: Value, y: Value) -> Value {
        let c = env.b.ins().fcmp(cc, x, y);
        env.b.ins().bitcast(VT, MemFlagsData::new(), c)
    }
    fn pick(env: &mut Env, c: Value, a: Value, b: Value) -> Value {
        env.b.ins().bitselect(c, a, b)
    }
    fn per_lane(
        env: &mut Env,
        args: &[Value],
        mut f: impl FnMut(&mut Env, &[Value]) -> Vec<Value>,
    ) -> Vec<Value> {
        let split: Vec<[Value; 2]> = args.iter().map(|&a| lanes(env, a)).collect();
        let mut out: [Vec<Value>; 2] = Default::default();
        for (k, o) in out.iter_mut().enumerate() {
            let lane: Vec<Value> = split.iter().map(|l| l[k]).collect();
            *o = f(env, &lane);
        }
        let [r0, r1] = out;
        r0.into_iter()
            .zip(r1)
            .map(|(a, b)| join(env, a, b))
            .collect()
    }
}

/// The pool's point value of instruction `i` in both lanes.
fn splat_pool(env: &mut Env, i: usize) -> Value {
    let s = env.pool_load(i, 0);
    env.b.ins().splat(VT, s)
}

fn lanes(env: &mut Env, v: Value) -> [Value; 2] {
    [0u8, 1].map(|k| env.b.ins().extractlane(v, k))
}

fn join(env: &mut Env, r0: Value, r1: Value) -> Value {
    let v = env.b.ins().scalar_to_vector(VT, r0);
    env.b.ins().insertlane(v, r1, 1)
}

/// Lane-wise `a / b`, NaN in the lanes where `b` is ±0.
fn div_nan(env: &mut Env, a: Value, b: Value) -> Value {
    let q = env.b.ins().fdiv(a, b);
    let zero_s = env.b.ins().f64const(0.0);
    let zero = env.b.ins().splat(VT, zero_s);
    let nan_s = env.b.ins().f64const(f64::NAN);
    let nan = env.b.ins().splat(VT, nan_s);
    let is0 = env.b.ins().fcmp(FloatCC::Equal, b, zero);
    let mask = env.b.ins().bitcast(VT, MemFlagsData::new(), is0);
    env.b.ins().bitselect(mask, nan, q)
}
