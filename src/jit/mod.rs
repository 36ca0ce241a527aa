//! The JIT: four Cranelift kernels per program behind `extern "C"` function
//! pointers — point, interval, interval-gradient and point-gradient — each
//! with a batch entry point, and all but the point-gradient with a single
//! one.
//!
//! # Contract
//!
//! [`Kernels::lazy`] checks an [`ir::Program`] and builds its constant
//! pool; each kernel kind is compiled into its own module on first use, or
//! ahead of time, several kinds in parallel, by [`Kernels::prepare`] (what
//! a command needs: `eval X Y Z` point and point-gradient, `mesh` all
//! four, `compile --emit ir` none). [`Kernels::compile`] compiles the
//! point, interval and gradient kinds at once and fails if one cannot be
//! compiled (the tests use it, so that they test native code). The
//! machine code is freed when the [`Kernels`] drops. The kernels give
//! every op the meaning fixed in [`crate::ir`]:
//!
//! - **point**: bit for bit the reference evaluator [`crate::eval::point`]
//!   (same IEEE operations in the same order; transcendentals call the same
//!   Rust functions; `min`/`max` are IEEE minimum/maximum, `−0 < +0`, in
//!   both);
//! - **interval**: an enclosure of the function over the box, outward
//!   rounded by hardware rounding toward +∞ (see [`rounding`] and
//!   [`mxcsr`]), plus the flag "defined and continuous on the whole box"
//!   (as [`crate::interval::DecInterval::defined`]);
//! - **interval-gradient**: enclosures of `(F, ∂F/∂x, ∂F/∂y, ∂F/∂z)` by
//!   forward-mode AD over intervals, plus the flag "defined, continuous and
//!   differentiable on the whole box" (as [`crate::eval::GradEval::defined`]);
//! - **point-gradient**: `(f, ∂f/∂x, ∂f/∂y, ∂f/∂z)` by forward-mode AD in
//!   f64, bit for bit [`crate::eval::grad::eval_point`] (see [`pgrad`]).
//!
//! Kernels never allocate, never unwind, and touch no memory but their
//! arguments, their stack and the constant pool owned by [`Kernels`]. The
//! interval batch kernels give the caller back its MXCSR (rounding mode
//! and exception flags) unchanged; the single-box calls give back the
//! caller's rounding direction — bit for bit its MXCSR unless it rounds to
//! nearest, when it gets the default one (see
//! [`mxcsr::call_interval_up`]).
//!
//! # Size and compile time
//!
//! Code size is linear in the program: every inline op is a handful of
//! instructions (one a bound for `+ − ×`), every other op one helper
//! call. Cranelift's backtracking register allocator is used up to
//! [`JitOptions::single_pass_above`] instructions and its single-pass
//! allocator beyond (linear time, somewhat slower code). Programs longer
//! than [`JitOptions::jit_limit`] are not compiled at all: the reference
//! interpreters evaluate them ([`Engine::Interpreter`]), in time and
//! memory linear in the program. Figures: `docs/jit.md`.
//!
//! # ABI (System V on x86-64, `extern "C"` in Rust)
//!
//! All buffers are arrays of `f64` (8-byte aligned) unless said otherwise;
//! `n` is a count of records, not of f64.
//!
//! | kernel | signature | buffers |
//! |---|---|---|
//! | point | `fn(x, y, z, t: f64) -> f64` | — |
//! | point batch | `fn(xs, ys, zs: *const f64, t: f64, out: *mut f64, n: u64)` | `xs ys zs out`: `n` f64 each (structure of arrays, 8-byte alignment suffices); `out[i] = f(xs[i], ys[i], zs[i], t)` |
//! | interval batch | `fn(input: *const f64, out: *mut f64, defined: *mut u8, n: u64)` | `input`: `n` records of 8 f64 `[x.lo, x.hi, y.lo, y.hi, z.lo, z.hi, t.lo, t.hi]`; `out`: `n` records `[lo, hi]`; `defined`: `n` bytes, 1 when defined and continuous on the box, else 0 |
//! | gradient batch | `fn(input: *const f64, out: *mut f64, defined: *mut u8, n: u64)` | `input`: `n` records of 8 as above; `out`: `n` records `[F.lo, F.hi, Fx.lo, Fx.hi, Fy.lo, Fy.hi, Fz.lo, Fz.hi]`; `defined`: `n` bytes |
//! | interval (one box) | `fn(input, pool: *const f64) -> (lo, hi: f64, defined: u8)` | one input record as in the batch form; `pool` the constant pool; `lo` returned in `xmm0`, `hi` in `xmm1`, the flag in `al` |
//! | gradient (one box) | `fn(input: *const f64, out: *mut f64, pool: *const f64) -> u8` | one record of each as in the batch form; returns the `defined` byte |
//!
//! The single-box kernels run in round-up mode from entry to return and
//! switch nothing: the safe calls bracket them ([`mxcsr::call_interval_up`],
//! [`mxcsr::call_grad_up`]).
//! | point gradient batch | `fn(xs, ys, zs: *const f64, t: f64, out: *mut f64, n: u64)` | `xs ys zs`: `n` f64 each; `out`: `n` records `[f, fx, fy, fz]` |
//!
//! The single-box entry points live in a module of their own, compiled on
//! the first single call ([`Kernels::interval`], [`Kernels::grad`]) — the
//! mesher only makes batch calls, so `mesh` never compiles them — or by
//! [`Kernels::compile`]. The point gradient has no single entry point: a
//! single call is a batch of one.
//!
//! The safe methods ([`Kernels::point`], [`Kernels::interval_batch`], …)
//! check buffer lengths and call these.
//!
//! # SIMD
//!
//! The x86-64 backend has 128-bit vectors (`F64X2`), not `F64X4`. The
//! *batch point* kernel uses them ([`simd`], on by default,
//! [`JitOptions::simd`]): two points per loop iteration, every inline op a
//! vector op with the scalar op's semantics lane-wise, helper ops called
//! once per lane, an odd last point evaluated in both lanes of the same
//! body; results are bit for bit the single-point kernel's (NaN payloads
//! aside). The single-point kernel stays scalar. The point gradient's
//! batch kernel has a two-point form too, its second tier, compiled once
//! enough points have gone through the first
//! ([`JitOptions::point_grad_wide_after`]; [`Kernels`]' module doc).
//! Measurements and what was tried and dropped: `docs/jit.md` ("SIMD",
//! "The point gradient's two tiers").
//!
//! # Constants
//!
//! Every [`ir::Const`] is stored in a constant pool (`[value, −lo, hi]` per
//! instruction) that the kernels *load* from: Cranelift never sees two
//! float constants meeting in one operation, so its mid-end cannot fold
//! them in round-to-nearest behind the interval kernels' back. The point
//! kernel uses `value`, the interval kernels `[lo, hi]`.
//!
//! # Helpers
//!
//! Ops that are not inline call Rust functions in [`helpers`] (each a
//! [`helpers::Helper`], which owns its symbol, address and signature): the
//! reference evaluator's per-op point functions and [`crate::interval`]'s
//! per-op enclosures (CORE-MATH, correctly rounded, widened by one ulp),
//! and its per-op derivative rules. Interval kernels reach them through
//! round-to-nearest trampolines ([`mxcsr`]). See [`point`], [`interval`],
//! [`grad`] and [`pgrad`] for which ops are inline.
//!
//! # Lowering
//!
//! Every kernel body is one lowering ([`lower`]): the dispatch on the IR
//! op is written once, over a number kind in generated code, and each
//! kind ([`point`] at two lane widths, [`interval`], [`grad`], [`pgrad`])
//! writes each op's rule once.

mod entry;
mod evaluator;
mod grad;
pub mod helpers;
mod interval;
mod kernels;
mod lower;
mod module;
pub mod mxcsr;
mod pgrad;
mod point;
pub mod rounding;
mod sign_mask;
mod simd;

use cranelift_codegen::ir as clif;
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::{
    FuncRef, InstBuilder, MemFlagsData, StackSlotData, StackSlotKind, Value, types,
};
use cranelift_frontend::FunctionBuilder;
use std::time::Duration;

pub use kernels::{Engine, Kernels};

use crate::ir::{BinOp, UnOp};
use helpers::Helper;

/// Single-point kernel.
pub(crate) type PointFn = unsafe extern "C" fn(f64, f64, f64, f64) -> f64;
/// Batch point kernel (see the ABI table).
pub(crate) type PointBatchFn =
    unsafe extern "C" fn(*const f64, *const f64, *const f64, f64, *mut f64, u64);
/// Batch interval or gradient kernel.
pub(crate) type BoxBatchFn = unsafe extern "C" fn(*const f64, *mut f64, *mut u8, u64);
/// Single-box gradient kernel: one input record, one output record,
/// returns the decoration (0 or 1). Runs in round-up mode: called only
/// through [`mxcsr::call_grad_up`].
pub(crate) type BoxFn = unsafe extern "C" fn(*const f64, *mut f64, *const f64) -> u8;
/// Single-box interval kernel: one input record; returns `lo` in `xmm0`,
/// `hi` in `xmm1` and the decoration in `al` (three return values, which
/// no Rust signature expresses: the type only carries the address; it is
/// called only through [`mxcsr::call_interval_up`]).
pub(crate) type IntervalFn = unsafe extern "C" fn(*const f64, *const f64);

/// Batch point-gradient kernel (see the ABI table): `out` gets `n` records
/// of 4 f64.
pub(crate) type PointGradBatchFn =
    unsafe extern "C" fn(*const f64, *const f64, *const f64, f64, *mut f64, u64);

/// A failure to compile (or to call with mismatched buffers).
#[derive(Debug, Clone, PartialEq)]
pub enum JitError {
    /// The program breaks the SSA invariant ([`ir::Program::validate`]).
    InvalidProgram(String),
    /// Cranelift could not be set up for this machine.
    Target(String),
    /// Cranelift rejected or failed on the generated code.
    Codegen(String),
    /// Buffers given to a batch call have inconsistent lengths.
    BufferLength(String),
    /// The program is longer than [`JitOptions::jit_limit`]: it is
    /// interpreted, not compiled.
    TooLarge {
        /// Instructions in the program.
        len: usize,
        /// The limit it exceeds.
        limit: usize,
    },
}

impl std::fmt::Display for JitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            JitError::InvalidProgram(m) => write!(f, "invalid IR program: {m}"),
            JitError::Target(m) => write!(f, "JIT target: {m}"),
            JitError::Codegen(m) => write!(f, "JIT code generation: {m}"),
            JitError::BufferLength(m) => write!(f, "batch buffers: {m}"),
            JitError::TooLarge { len, limit } => write!(
                f,
                "{len} instructions exceed the JIT limit of {limit}: interpreted"
            ),
        }
    }
}

impl std::error::Error for JitError {}

/// The kernel kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// f64 value.
    Point,
    /// Interval enclosure of the value, with the "defined" flag.
    Interval,
    /// Interval enclosures of value and gradient, with the "defined" flag.
    Grad,
    /// f64 value and gradient ([`pgrad`]); not in [`Kind::ALL`].
    PointGrad,
}

impl Kind {
    /// The kinds compiled eagerly by [`Kernels::compile`].
    pub const ALL: [Kind; 3] = [Kind::Point, Kind::Interval, Kind::Grad];
    /// Every kind, as `mesh` needs them.
    pub const EVERY: [Kind; 4] = [Kind::Point, Kind::Interval, Kind::Grad, Kind::PointGrad];

    /// The kind's name, as its single entry point is called (`"point"`,
    /// `"interval"`, `"grad"`, `"point_grad"`).
    pub fn name(self) -> &'static str {
        match self {
            Kind::Point => "point",
            Kind::Interval => "interval",
            Kind::Grad => "grad",
            Kind::PointGrad => "point_grad",
        }
    }
}

/// Options of [`Kernels::compile_with`].
#[derive(Clone, Copy, Debug)]
pub struct JitOptions {
    /// Keep the CLIF text and disassembly of every kernel (`--emit clif|asm`);
    /// costs compile time.
    pub keep_text: bool,
    /// Run Cranelift's IR verifier on every kernel (slower compiles; the
    /// tests turn it on).
    pub verify: bool,
    /// Cranelift's single-pass register allocator for every program
    /// (faster compiles, somewhat slower code).
    pub fast_compile: bool,
    /// Programs with more instructions than this use the single-pass
    /// register allocator (linear time) whatever `fast_compile` says.
    pub single_pass_above: usize,
    /// Programs with more instructions than this are not compiled: the
    /// reference interpreters run them ([`Engine::Interpreter`]).
    pub jit_limit: usize,
    /// Emit the batch point kernel two points at a time in `F64X2`
    /// vectors (see [`simd`]); `false` gives the scalar loop, and no
    /// second tier for the point gradient. Same results either way.
    /// Default on.
    pub simd: bool,
    /// With `simd`, the batch point-gradient calls switch to a second
    /// kernel, two points per iteration, once this many points have been
    /// evaluated in batches of two or more by the first, one point per
    /// iteration; the call that crosses the count compiles it. Same
    /// results either way. `0`: from the first such batch; `usize::MAX`:
    /// never. Default [`POINT_GRAD_WIDE_AFTER`].
    pub point_grad_wide_after: usize,
}

/// The default of [`JitOptions::point_grad_wide_after`]: the point count
/// past which the second tier has repaid its compile time
/// (`docs/jit.md`, "The point gradient's two tiers").
pub const POINT_GRAD_WIDE_AFTER: usize = 100_000;

impl Default for JitOptions {
    fn default() -> Self {
        JitOptions {
            keep_text: false,
            verify: false,
            fast_compile: false,
            single_pass_above: 2_000,
            jit_limit: 200_000,
            simd: true,
            point_grad_wide_after: POINT_GRAD_WIDE_AFTER,
        }
    }
}

/// What was compiled for one entry point.
#[derive(Clone, Debug)]
pub struct KernelInfo {
    /// The kernel kind.
    pub kind: Kind,
    /// Whether this is the batch entry point (else the single one).
    pub batch: bool,
    /// `"point"`, `"point_batch"`, `"interval"`, …
    pub name: &'static str,
    /// Machine code size in bytes.
    pub code_bytes: usize,
    /// Time spent lowering and compiling this entry point.
    pub compile_time: Duration,
    /// Cranelift IR after optimisation (with [`JitOptions::keep_text`]).
    pub clif: Option<String>,
    /// Cranelift's disassembly of the machine code (with
    /// [`JitOptions::keep_text`]).
    pub asm: Option<String>,
}

/// Lowering state of one kernel function.
pub(crate) struct Env<'a> {
    b: FunctionBuilder<'a>,
    pool: Value,
    /// Indexed by [`Helper`] discriminant.
    helpers: Vec<FuncRef>,
    ptr: clif::Type,
    iv_slot: Option<clif::StackSlot>,
    gd_slots: Option<[clif::StackSlot; 3]>,
    pg_slot: Option<clif::StackSlot>,
    /// The backtracking register allocator compiles this function, so a
    /// branch that joins again costs a few moves; the single-pass
    /// allocator spills every live value at a join, and the lowering then
    /// selects instead of branching per op.
    cheap_joins: bool,
}

pub(crate) const POOL_STRIDE: usize = 3;

impl Env<'_> {
    fn flags() -> MemFlagsData {
        MemFlagsData::trusted()
    }

    /// Entry `k` (0 value, 1 −lo, 2 hi) of instruction `i`'s pool record.
    fn pool_load(&mut self, i: usize, k: usize) -> Value {
        let off = ((i * POOL_STRIDE + k) * 8) as i64;
        let addr = self.b.ins().iadd_imm_s(self.pool, off);
        self.b
            .ins()
            .load(types::F64, Self::flags().with_readonly(), addr, 0)
    }

    /// Calls helper `h`; returns its result.
    fn call(&mut self, h: Helper, args: &[Value]) -> Value {
        let inst = self.b.ins().call(self.helpers[h as usize], args);
        self.b.inst_results(inst)[0]
    }

    /// Calls helper `h`, which returns nothing.
    fn call_void(&mut self, h: Helper, args: &[Value]) {
        self.b.ins().call(self.helpers[h as usize], args);
    }

    fn code(&mut self, c: u32) -> Value {
        self.b.ins().iconst(types::I32, c as i64)
    }

    fn call_pt_unary(&mut self, u: UnOp, a: Value) -> Value {
        let c = self.code(helpers::unop_code(u));
        self.call(Helper::PtUnary, &[c, a])
    }

    fn call_pt_binary(&mut self, op: BinOp, a: Value, b: Value) -> Value {
        let c = self.code(helpers::binop_code(op));
        self.call(Helper::PtBinary, &[c, a, b])
    }

    /// The stack slot cached in `cache`, created (`size` bytes, 16-byte
    /// aligned) on first use, so a kernel has one whatever the number of
    /// helper calls.
    fn lazy_slot(
        b: &mut FunctionBuilder,
        cache: &mut Option<clif::StackSlot>,
        size: u32,
    ) -> clif::StackSlot {
        *cache.get_or_insert_with(|| {
            b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, size, 4))
        })
    }

    fn iv_out(&mut self) -> Value {
        let slot = Self::lazy_slot(&mut self.b, &mut self.iv_slot, 16);
        self.b.ins().stack_addr(self.ptr, slot, 0)
    }

    /// `[lo, hi]` as stored in memory at `p + off`.
    fn read_lo_hi(&mut self, p: Value, off: i32) -> (Value, Value) {
        let f = Self::flags();
        (
            self.b.ins().load(types::F64, f, p, off),
            self.b.ins().load(types::F64, f, p, off + 8),
        )
    }

    /// The interval stored as `[lo, hi]` at `p + off`, in the kernels'
    /// `(−lo, hi)` form ([`interval::Iv`]).
    fn load_iv(&mut self, p: Value, off: i32) -> interval::Iv {
        let (lo, hi) = self.read_lo_hi(p, off);
        (self.b.ins().fneg(lo), hi)
    }

    /// Stores `(−lo, hi)` as `[lo, hi]` at `p + off`.
    fn store_iv(&mut self, p: Value, off: i32, (n, hi): interval::Iv) {
        let f = Self::flags();
        let lo = self.b.ins().fneg(n);
        self.b.ins().store(f, lo, p, off);
        self.b.ins().store(f, hi, p, off + 8);
    }

    fn call_iv_unary(&mut self, u: UnOp, a: interval::Iv) -> (interval::Iv, Option<Value>) {
        let c = self.code(helpers::unop_code(u));
        let out = self.iv_out();
        let lo = self.b.ins().fneg(a.0);
        let d = self.call(Helper::IvUnary, &[c, lo, a.1, out]);
        (self.load_iv(out, 0), Some(d))
    }

    fn call_iv_binary(
        &mut self,
        op: BinOp,
        a: interval::Iv,
        b: interval::Iv,
    ) -> (interval::Iv, Option<Value>) {
        let c = self.code(helpers::binop_code(op));
        let out = self.iv_out();
        let alo = self.b.ins().fneg(a.0);
        let blo = self.b.ins().fneg(b.0);
        let d = self.call(Helper::IvBinary, &[c, alo, a.1, blo, b.1, out]);
        (self.load_iv(out, 0), Some(d))
    }

    fn call_iv_powi(&mut self, a: interval::Iv, n: i64) -> (interval::Iv, Option<Value>) {
        let n = self.b.ins().iconst(types::I64, n);
        let out = self.iv_out();
        let lo = self.b.ins().fneg(a.0);
        let d = self.call(Helper::IvPowi, &[lo, a.1, n, out]);
        (self.load_iv(out, 0), Some(d))
    }

    /// Calls the gradient helper: `code` below [`grad::GD_BINARY_BASE`] is
    /// unary, else binary (or powi) with `code - GD_BINARY_BASE`.
    fn call_gd(
        &mut self,
        code: u32,
        a: grad::Dual,
        b: Option<grad::Dual>,
        n: i64,
    ) -> (grad::Dual, Option<Value>) {
        let slots = match self.gd_slots {
            Some(s) => s,
            None => {
                let mk = |b: &mut FunctionBuilder| {
                    b.create_sized_stack_slot(StackSlotData::new(
                        StackSlotKind::ExplicitSlot,
                        64,
                        4,
                    ))
                };
                let s = [mk(&mut self.b), mk(&mut self.b), mk(&mut self.b)];
                self.gd_slots = Some(s);
                s
            }
        };
        let addr = [slots[0], slots[1], slots[2]].map(|s| self.b.ins().stack_addr(self.ptr, s, 0));
        for (k, iv) in a.iter().enumerate() {
            self.store_iv(addr[0], (16 * k) as i32, *iv);
        }
        if let Some(b) = b {
            for (k, iv) in b.iter().enumerate() {
                self.store_iv(addr[1], (16 * k) as i32, *iv);
            }
        }
        let d = if code >= grad::GD_BINARY_BASE {
            let c = self.code(code - grad::GD_BINARY_BASE);
            let n = self.b.ins().iconst(types::I64, n);
            self.call(Helper::GdBinary, &[c, addr[0], addr[1], n, addr[2]])
        } else {
            let c = self.code(code);
            self.call(Helper::GdUnary, &[c, addr[0], addr[2]])
        };
        let out = addr[2];

        let g = [0, 1, 2, 3].map(|k| self.load_iv(out, 16 * k));
        (g, Some(d))
    }
}

/// `for i in 0..n { body(env, i) }` in the current block; leaves the
/// builder in the (empty) exit block.
fn batch_loop(env: &mut Env, n: Value, body: impl FnOnce(&mut Env, Value)) {
    let header = env.b.create_block();
    let inner = env.b.create_block();
    let exit = env.b.create_block();
    env.b.append_block_param(header, types::I64);
    let zero = env.b.ins().iconst(types::I64, 0);
    env.b.ins().jump(header, &[zero.into()]);
    env.b.switch_to_block(header);
    let i = env.b.block_params(header)[0];
    let more = env.b.ins().icmp(IntCC::UnsignedLessThan, i, n);
    env.b.ins().brif(more, inner, &[], exit, &[]);
    env.b.switch_to_block(inner);
    body(env, i);
    let next = env.b.ins().iadd_imm_s(i, 1);
    env.b.ins().jump(header, &[next.into()]);
    env.b.switch_to_block(exit);
}
