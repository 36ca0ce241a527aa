//! The JIT: four Cranelift kernels per program behind `extern "C"` function
//! pointers — point, interval, interval-gradient and point-gradient — each
//! with a single and a batch entry point.
//!
//! # Contract
//!
//! [`Kernels::compile`] lowers an [`ir::Program`] to six machine-code
//! functions owned by the returned value (they are freed when it drops; the
//! function pointers must not outlive it). The kernels give every op the
//! meaning fixed in [`crate::ir`]:
//!
//! - **point**: bit for bit the reference evaluator [`crate::eval::point`]
//!   (same IEEE operations in the same order; transcendentals call the same
//!   Rust functions; one exception: the sign of a zero from `min`/`max`
//!   of `+0` and `−0`, where the kernels order `−0 < +0` and Rust's
//!   `f64::min`/`max` may return either);
//! - **interval**: an enclosure of the function over the box, outward
//!   rounded (see [`rounding`] for the strategy and why), plus the flag
//!   "defined and continuous on the whole box" (as [`DecInterval::defined`]);
//! - **interval-gradient**: enclosures of `(F, ∂F/∂x, ∂F/∂y, ∂F/∂z)` by
//!   forward-mode AD over intervals, plus the flag "defined, continuous and
//!   differentiable on the whole box" (as [`GradEval::defined`]);
//! - **point-gradient**: `(f, ∂f/∂x, ∂f/∂y, ∂f/∂z)` by forward-mode AD in
//!   f64, bit for bit [`crate::eval::grad::eval_point`] (see [`pgrad`]).
//!   It is compiled *lazily*, into its own module, on the first call of
//!   [`Kernels::point_grad`] (or its batch and raw forms) and kept in a
//!   `OnceLock`: [`Kernels::compile`] costs no more for programs whose
//!   point gradient is never asked for. A compilation failure is
//!   remembered and reported as a [`JitError`] by the fallible methods;
//!   [`Kernels::point_grad`] then falls back to the reference evaluator.
//!
//! Kernels never allocate, never unwind, and touch no memory but their
//! arguments, their stack and the constant pool owned by [`Kernels`].
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
//! | interval | `fn(input: *const f64, out: *mut f64) -> u8` | `input`: `[x.lo, x.hi, y.lo, y.hi, z.lo, z.hi, t.lo, t.hi]`; `out`: `[lo, hi]`; returns 1 when defined and continuous on the box, else 0 |
//! | interval batch | `fn(input: *const f64, out: *mut f64, defined: *mut u8, n: u64)` | `input`: `n` records of 8 f64 as above; `out`: `n` records of 2; `defined`: `n` bytes, each 0 or 1 |
//! | gradient | `fn(input: *const f64, out: *mut f64) -> u8` | `input` as for interval; `out`: `[F.lo, F.hi, Fx.lo, Fx.hi, Fy.lo, Fy.hi, Fz.lo, Fz.hi]` |
//! | gradient batch | `fn(input: *const f64, out: *mut f64, defined: *mut u8, n: u64)` | `input`: `n` records of 8; `out`: `n` records of 8; `defined`: `n` bytes |
//! | point gradient | `fn(x, y, z, t: f64, out: *mut f64)` | `out`: `[f, fx, fy, fz]` |
//! | point gradient batch | `fn(xs, ys, zs: *const f64, t: f64, out: *mut f64, n: u64)` | `xs ys zs`: `n` f64 each; `out`: `n` records of 4 as above |
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
//! aside). The single-point kernel stays scalar. Measured (`cargo bench
//! --bench kernels -- simd/`, 1024 points, release, 2-core machine shared
//! with a CI run), scalar-loop time / F64X2 time: sphere 1.19, heart 1.57,
//! torus_fig1 1.59, twotorus 1.50, chair_mid 1.51, blobs_merge (`exp`
//! helper calls dominate) 1.12. With `simd: false` the batch loop is the
//! scalar body once per point.
//!
//! (A second, noisier run: 1.35, 1.57, 1.76, 1.44, 1.31, 1.12.)
//!
//! Tried and dropped: interval `add`/`sub` as one `F64X2` TwoSum and
//! lane-wise Rump successor on `[-lo, hi]` (`-lower(lo) = upper(-lo)`),
//! packing before and unpacking after each op since the interval kernel
//! keeps `lo` and `hi` in scalar registers. Interval batch, scalar / F64X2:
//! sphere 1.28, heart 0.84, torus_fig1 1.01, twotorus 1.17, chair_mid 1.12,
//! blobs_merge 1.20 (under load) — mixed, and not bit for bit the scalar
//! bounds (`x − x` gave a lower bound `−0`). See `docs/jit.md` ("SIMD").
//!
//! # Constants
//!
//! Every [`ir::Const`] is stored in a constant pool (`[value, lo, hi]` per
//! instruction) that the kernels *load* from: Cranelift never sees two
//! float constants meeting in one operation, so its mid-end cannot fold
//! them in round-to-nearest behind the interval kernels' back. The point
//! kernel uses `value`, the interval kernels `[lo, hi]`.
//!
//! # Helpers
//!
//! Ops that are not inline call Rust functions in [`helpers`], registered
//! with `JITBuilder::symbol`: the reference evaluator's per-op point
//! functions and [`crate::interval`]'s per-op enclosures (CORE-MATH,
//! correctly rounded, widened by one ulp), and its per-op derivative rules
//! in f64 (point gradient). See [`point`], [`interval`], [`grad`] and
//! [`pgrad`] for which ops are inline.

mod evaluator;
mod grad;
pub mod helpers;
mod interval;
mod pgrad;
mod point;
pub mod rounding;
mod simd;

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use cranelift_codegen::ir as clif;
use cranelift_codegen::ir::{
    AbiParam, FuncRef, InstBuilder, MemFlagsData, Signature, StackSlotData, StackSlotKind, Value,
    types,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{Linkage, Module, default_libcall_names};

use crate::eval::grad::GradEval;
use crate::interval::{DecInterval, Interval};
use crate::ir::{self, BinOp, Op, UnOp};

/// Single-point kernel.
pub type PointFn = unsafe extern "C" fn(f64, f64, f64, f64) -> f64;
/// Batch point kernel (see the ABI table).
pub type PointBatchFn =
    unsafe extern "C" fn(*const f64, *const f64, *const f64, f64, *mut f64, u64);
/// Single-box interval or gradient kernel.
pub type BoxFn = unsafe extern "C" fn(*const f64, *mut f64) -> u8;
/// Batch interval or gradient kernel.
pub type BoxBatchFn = unsafe extern "C" fn(*const f64, *mut f64, *mut u8, u64);

/// Single-point value and gradient kernel: writes `[f, fx, fy, fz]` to
/// `out` (4 f64).
pub type PointGradFn = unsafe extern "C" fn(f64, f64, f64, f64, *mut f64);
/// Batch point-gradient kernel (see the ABI table): `out` gets `n` records
/// of 4 f64.
pub type PointGradBatchFn =
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
}

impl std::fmt::Display for JitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            JitError::InvalidProgram(m) => write!(f, "invalid IR program: {m}"),
            JitError::Target(m) => write!(f, "JIT target: {m}"),
            JitError::Codegen(m) => write!(f, "JIT code generation: {m}"),
            JitError::BufferLength(m) => write!(f, "batch buffers: {m}"),
        }
    }
}

impl std::error::Error for JitError {}

/// The kernel kinds: the three compiled by [`Kernels::compile`] and the
/// point gradient, compiled on first use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    Point,
    Interval,
    Grad,
    /// f64 value and gradient ([`pgrad`]); not in [`Kind::ALL`].
    PointGrad,
}

impl Kind {
    /// The kinds compiled eagerly by [`Kernels::compile`].
    pub const ALL: [Kind; 3] = [Kind::Point, Kind::Interval, Kind::Grad];

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
    /// Cranelift's single-pass register allocator: 2–4× faster compiles of
    /// the large interval/gradient kernels, somewhat slower code.
    pub fast_compile: bool,
    /// Emit the batch point kernel two points at a time in `F64X2`
    /// vectors (see [`simd`]); `false` gives the scalar loop. Same results
    /// either way. Default on.
    pub simd: bool,
}

impl Default for JitOptions {
    fn default() -> Self {
        JitOptions {
            keep_text: false,
            verify: false,
            fast_compile: false,
            simd: true,
        }
    }
}

/// What was compiled for one entry point.
#[derive(Clone, Debug)]
pub struct KernelInfo {
    pub kind: Kind,
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

/// Owns the JIT module; only touched at construction and drop.
struct ModuleOwner(Option<JITModule>);

// SAFETY: the module is never accessed through `&self` after construction
// (no method of `Kernels` or of its point-gradient kernels reaches it); it
// is only moved and finally freed in `Drop`, which has exclusive access.
unsafe impl Sync for ModuleOwner {}
// SAFETY: as above; moving the module between threads is not observable
// by the kernels, which only depend on the memory it keeps mapped.
unsafe impl Send for ModuleOwner {}

impl Drop for ModuleOwner {
    fn drop(&mut self) {
        if let Some(m) = self.0.take() {
            // SAFETY: the function pointers into this memory are held only
            // by the `Kernels` (or its point-gradient kernels) being
            // dropped, or by nobody when a compilation failed half-way;
            // they cannot be called after.
            unsafe { m.free_memory() };
        }
    }
}

/// The point-gradient entry points, in their own module (compiled on first
/// use, see [`Kernels::point_grad`]).
struct PointGradKernels {
    single: PointGradFn,
    batch: PointGradBatchFn,
    info: Vec<KernelInfo>,
    _module: ModuleOwner,
}

impl PointGradKernels {
    /// Compiles both entry points; `pool_addr` is the constant pool of the
    /// [`Kernels`] that will own the result.
    fn compile(
        prog: &ir::Program,
        pool_addr: i64,
        opts: &JitOptions,
    ) -> Result<PointGradKernels, JitError> {
        let (module, p, info) = build(prog, pool_addr, opts, &[Kind::PointGrad])?;
        // SAFETY: as in `Kernels::compile_with`: the pointers are the
        // finalized code of functions declared with `entry_sig`'s
        // signatures, matching these types, and live as long as `module`.
        let (single, batch) = unsafe {
            (
                std::mem::transmute::<*const u8, PointGradFn>(p[0]),
                std::mem::transmute::<*const u8, PointGradBatchFn>(p[1]),
            )
        };
        Ok(PointGradKernels {
            single,
            batch,
            info,
            _module: module,
        })
    }
}

/// The compiled kernels of one program. See the module doc.
pub struct Kernels {
    point: PointFn,
    point_batch: PointBatchFn,
    interval: BoxFn,
    interval_batch: BoxBatchFn,
    grad: BoxFn,
    grad_batch: BoxBatchFn,
    info: Vec<KernelInfo>,
    ir_len: usize,
    /// The program and options, for compiling the point-gradient kernel
    /// on first use.
    program: ir::Program,
    opts: JitOptions,
    pgrad: OnceLock<Result<PointGradKernels, JitError>>,
    // Field order matters: the modules (code) are dropped before the pool,
    // and neither is touched but by the kernels.
    _module: ModuleOwner,
    pool: Box<[f64]>,
}

impl std::fmt::Debug for Kernels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Kernels")
            .field("ir_len", &self.ir_len)
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

/// Helper signatures, in [`helpers::symbols`] order.
fn helper_sigs(cc: cranelift_codegen::isa::CallConv, ptr: clif::Type) -> [Signature; 8] {
    use types::{F64, I8, I32, I64};
    let sig = |params: &[clif::Type], ret: clif::Type| {
        let mut s = Signature::new(cc);
        s.params.extend(params.iter().map(|&t| AbiParam::new(t)));
        s.returns.push(AbiParam::new(ret));
        s
    };
    [
        sig(&[I32, F64], F64),
        sig(&[I32, F64, F64], F64),
        sig(&[I32, F64, F64, ptr], I8),
        sig(&[I32, F64, F64, F64, F64, ptr], I8),
        sig(&[F64, F64, I64, ptr], I8),
        sig(&[I32, ptr, ptr], I8),
        sig(&[I32, ptr, ptr, I64, ptr], I8),
        {
            let mut s = Signature::new(cc);
            s.params
                .extend([I32, ptr, ptr, ptr].iter().map(|&t| AbiParam::new(t)));
            s
        },
    ]
}

/// Lowering state of one kernel function.
pub(crate) struct Env<'a> {
    b: FunctionBuilder<'a>,
    pool: Value,
    helpers: Vec<FuncRef>,
    ptr: clif::Type,
    iv_slot: Option<clif::StackSlot>,
    gd_slots: Option<[clif::StackSlot; 3]>,
    pg_slot: Option<clif::StackSlot>,
}

const POOL_STRIDE: usize = 3;

impl Env<'_> {
    fn flags() -> MemFlagsData {
        MemFlagsData::trusted()
    }

    /// Entry `k` (0 value, 1 lo, 2 hi) of instruction `i`'s pool record.
    fn pool_load(&mut self, i: usize, k: usize) -> Value {
        let off = ((i * POOL_STRIDE + k) * 8) as i64;
        let addr = self.b.ins().iadd_imm_s(self.pool, off);
        self.b
            .ins()
            .load(types::F64, Self::flags().with_readonly(), addr, 0)
    }

    fn call(&mut self, h: usize, args: &[Value]) -> Value {
        let inst = self.b.ins().call(self.helpers[h], args);
        self.b.inst_results(inst)[0]
    }

    fn code(&mut self, c: u32) -> Value {
        self.b.ins().iconst(types::I32, c as i64)
    }

    fn call_pt_unary(&mut self, u: UnOp, a: Value) -> Value {
        let c = self.code(helpers::unop_code(u));
        self.call(0, &[c, a])
    }

    fn call_pt_binary(&mut self, op: BinOp, a: Value, b: Value) -> Value {
        let c = self.code(helpers::binop_code(op));
        self.call(1, &[c, a, b])
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

    fn read_iv(&mut self, p: Value, off: i32) -> interval::Iv {
        let f = Self::flags();
        (
            self.b.ins().load(types::F64, f, p, off),
            self.b.ins().load(types::F64, f, p, off + 8),
        )
    }

    fn call_iv_unary(&mut self, u: UnOp, a: interval::Iv) -> (interval::Iv, Option<Value>) {
        let c = self.code(helpers::unop_code(u));
        let out = self.iv_out();
        let d = self.call(2, &[c, a.0, a.1, out]);
        (self.read_iv(out, 0), Some(d))
    }

    fn call_iv_binary(
        &mut self,
        op: BinOp,
        a: interval::Iv,
        b: interval::Iv,
    ) -> (interval::Iv, Option<Value>) {
        let c = self.code(helpers::binop_code(op));
        let out = self.iv_out();
        let d = self.call(3, &[c, a.0, a.1, b.0, b.1, out]);
        (self.read_iv(out, 0), Some(d))
    }

    fn call_iv_powi(&mut self, a: interval::Iv, n: i64) -> (interval::Iv, Option<Value>) {
        let n = self.b.ins().iconst(types::I64, n);
        let out = self.iv_out();
        let d = self.call(4, &[a.0, a.1, n, out]);
        (self.read_iv(out, 0), Some(d))
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
        let f = Self::flags();
        let addr = [slots[0], slots[1], slots[2]].map(|s| self.b.ins().stack_addr(self.ptr, s, 0));
        for (k, (lo, hi)) in a.iter().enumerate() {
            self.b.ins().store(f, *lo, addr[0], (16 * k) as i32);
            self.b.ins().store(f, *hi, addr[0], (16 * k + 8) as i32);
        }
        if let Some(b) = b {
            for (k, (lo, hi)) in b.iter().enumerate() {
                self.b.ins().store(f, *lo, addr[1], (16 * k) as i32);
                self.b.ins().store(f, *hi, addr[1], (16 * k + 8) as i32);
            }
        }
        let d = if code >= grad::GD_BINARY_BASE {
            let c = self.code(code - grad::GD_BINARY_BASE);
            let n = self.b.ins().iconst(types::I64, n);
            self.call(6, &[c, addr[0], addr[1], n, addr[2]])
        } else {
            let c = self.code(code);
            self.call(5, &[c, addr[0], addr[2]])
        };
        let out = addr[2];

        let g = [0, 1, 2, 3].map(|k| self.read_iv(out, 16 * k));
        (g, Some(d))
    }
}

impl Kernels {
    /// Compiles the point, interval and gradient kernels (single and batch
    /// entry points) of `prog`; the point-gradient kernel is compiled on
    /// first use.
    pub fn compile(prog: &ir::Program) -> Result<Kernels, JitError> {
        Kernels::compile_with(prog, &JitOptions::default())
    }

    /// [`Kernels::compile`] with options.
    pub fn compile_with(prog: &ir::Program, opts: &JitOptions) -> Result<Kernels, JitError> {
        prog.validate().map_err(JitError::InvalidProgram)?;
        if prog.len() > (i32::MAX as usize) / (8 * POOL_STRIDE) {
            return Err(JitError::InvalidProgram("program too large".into()));
        }
        let mut pool = vec![0.0f64; prog.len() * POOL_STRIDE].into_boxed_slice();
        for (i, op) in prog.insts.iter().enumerate() {
            let rec = &mut pool[i * POOL_STRIDE..(i + 1) * POOL_STRIDE];
            match op {
                Op::Const(c) => {
                    let (iv, _) = Interval::new(c.lo, c.hi).normalize();
                    rec.copy_from_slice(&[c.value, iv.lo, iv.hi]);
                }
                Op::Powi(..) => rec.copy_from_slice(&[1.0; 3]),
                _ => {}
            }
        }

        let pool_addr = pool.as_ptr() as i64;
        let (module, p, info) = build(prog, pool_addr, opts, &Kind::ALL)?;
        // SAFETY: each pointer is the finalized code of a function declared
        // with the signature `entry_sig` gives, which is the Rust type it is
        // transmuted to (System V `extern "C"`; u8/u64 are i8/i64). The code
        // lives as long as `module`, which the returned value owns.
        let (point, point_batch, interval, interval_batch, grad, grad_batch) = unsafe {
            (
                std::mem::transmute::<*const u8, PointFn>(p[0]),
                std::mem::transmute::<*const u8, PointBatchFn>(p[1]),
                std::mem::transmute::<*const u8, BoxFn>(p[2]),
                std::mem::transmute::<*const u8, BoxBatchFn>(p[3]),
                std::mem::transmute::<*const u8, BoxFn>(p[4]),
                std::mem::transmute::<*const u8, BoxBatchFn>(p[5]),
            )
        };
        Ok(Kernels {
            point,
            point_batch,
            interval,
            interval_batch,
            grad,
            grad_batch,
            info,
            ir_len: prog.len(),
            program: prog.clone(),
            opts: *opts,
            pgrad: OnceLock::new(),
            _module: module,
            pool,
        })
    }

    /// Per entry point: name, code size, compile time, text.
    pub fn info(&self) -> &[KernelInfo] {
        &self.info
    }

    /// Number of IR instructions compiled.
    pub fn ir_len(&self) -> usize {
        self.ir_len
    }

    /// Machine-code bytes of the single and batch entry points of `kind`.
    pub fn code_bytes(&self, kind: Kind) -> usize {
        self.info
            .iter()
            .filter(|i| i.kind == kind)
            .map(|i| i.code_bytes)
            .sum()
    }

    /// Compile time of the single and batch entry points of `kind`.
    pub fn compile_time(&self, kind: Kind) -> Duration {
        self.info
            .iter()
            .filter(|i| i.kind == kind)
            .map(|i| i.compile_time)
            .sum()
    }

    /// The point-gradient kernels, compiled on the first call (by one
    /// thread; others wait). A failure is remembered and returned again.
    fn pgrad(&self) -> Result<&PointGradKernels, JitError> {
        self.pgrad
            .get_or_init(|| {
                PointGradKernels::compile(&self.program, self.pool.as_ptr() as i64, &self.opts)
            })
            .as_ref()
            .map_err(Clone::clone)
    }

    /// The raw single point-gradient kernel (compiled on first use).
    pub fn point_grad_fn(&self) -> Result<PointGradFn, JitError> {
        Ok(self.pgrad()?.single)
    }
    /// The raw batch point-gradient kernel (compiled on first use).
    pub fn point_grad_batch_fn(&self) -> Result<PointGradBatchFn, JitError> {
        Ok(self.pgrad()?.batch)
    }
    /// Info on the point-gradient entry points (compiling them if needed).
    pub fn point_grad_info(&self) -> Result<&[KernelInfo], JitError> {
        Ok(&self.pgrad()?.info)
    }

    /// `f` and `(∂f/∂x, ∂f/∂y, ∂f/∂z)` at `[x, y, z, t]`, as
    /// [`crate::eval::grad::eval_point`] (the value bit for bit the point
    /// kernel's). Compiles the point-gradient kernel on the first call;
    /// should that fail, falls back to the reference evaluator (same
    /// results, slower).
    pub fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        match self.pgrad() {
            Ok(k) => {
                let mut out = [0.0; 4];
                // SAFETY: the kernel takes four f64 by value and writes 4
                // f64 to `out`; it reads only the constant pool, which
                // `self` keeps alive.
                unsafe { (k.single)(p[0], p[1], p[2], p[3], out.as_mut_ptr()) };
                (out[0], [out[1], out[2], out[3]])
            }
            Err(_) => crate::eval::grad::eval_point(&self.program, p),
        }
    }

    /// `out[4i..4i+4] = [f, fx, fy, fz]` at `(xs[i], ys[i], zs[i], t)`;
    /// `xs ys zs` of one length `n`, `out` of `4n`. Errors on mismatched
    /// lengths or if the kernel cannot be compiled.
    pub fn point_grad_batch(
        &self,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        t: f64,
        out: &mut [f64],
    ) -> Result<(), JitError> {
        let n = xs.len();
        if ys.len() != n || zs.len() != n || out.len() != 4 * n {
            return Err(JitError::BufferLength(format!(
                "xs {n}, ys {}, zs {}, out {} (want {})",
                ys.len(),
                zs.len(),
                out.len(),
                4 * n
            )));
        }
        let k = self.pgrad()?;
        // SAFETY: `xs ys zs` are valid for `n` f64 and `out` for `4n`
        // (checked above), `out` is exclusively borrowed; the kernel
        // touches only those indices and the pool `self` keeps alive.
        unsafe {
            (k.batch)(
                xs.as_ptr(),
                ys.as_ptr(),
                zs.as_ptr(),
                t,
                out.as_mut_ptr(),
                n as u64,
            )
        };
        Ok(())
    }

    /// The raw single-point kernel (see the ABI in the module doc).
    pub fn point_fn(&self) -> PointFn {
        self.point
    }
    /// The raw batch point kernel.
    pub fn point_batch_fn(&self) -> PointBatchFn {
        self.point_batch
    }
    /// The raw single-box interval kernel.
    pub fn interval_fn(&self) -> BoxFn {
        self.interval
    }
    /// The raw batch interval kernel.
    pub fn interval_batch_fn(&self) -> BoxBatchFn {
        self.interval_batch
    }
    /// The raw single-box gradient kernel.
    pub fn grad_fn(&self) -> BoxFn {
        self.grad
    }
    /// The raw batch gradient kernel.
    pub fn grad_batch_fn(&self) -> BoxBatchFn {
        self.grad_batch
    }

    /// `f(x, y, z, t)`.
    pub fn point(&self, p: [f64; 4]) -> f64 {
        // SAFETY: the kernel takes four f64 by value and reads no memory
        // but the constant pool, which `self` keeps alive.
        unsafe { (self.point)(p[0], p[1], p[2], p[3]) }
    }

    /// `out[i] = f(xs[i], ys[i], zs[i], t)`; all four slices of one length.
    pub fn point_batch(
        &self,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        t: f64,
        out: &mut [f64],
    ) -> Result<(), JitError> {
        let n = out.len();
        if xs.len() != n || ys.len() != n || zs.len() != n {
            return Err(JitError::BufferLength(format!(
                "xs {}, ys {}, zs {}, out {n}",
                xs.len(),
                ys.len(),
                zs.len()
            )));
        }
        // SAFETY: every pointer is valid for `n` f64 (checked above), `out`
        // is exclusively borrowed, the kernel reads/writes only indices < n.
        unsafe {
            (self.point_batch)(
                xs.as_ptr(),
                ys.as_ptr(),
                zs.as_ptr(),
                t,
                out.as_mut_ptr(),
                n as u64,
            )
        };
        Ok(())
    }

    /// Enclosure of `f` over the box `[x, y, z, t]`.
    pub fn interval(&self, input: [Interval; 4]) -> DecInterval {
        let inp = flatten(input);
        let mut out = [0.0; 2];
        // SAFETY: `inp` holds 8 f64 and `out` 2, as the ABI requires.
        let d = unsafe { (self.interval)(inp.as_ptr(), out.as_mut_ptr()) };
        DecInterval {
            iv: Interval {
                lo: out[0],
                hi: out[1],
            },
            defined: d != 0,
        }
    }

    /// Batch interval: `input` is `n` records of 8 f64 (`[x.lo, x.hi, …,
    /// t.hi]`), `out` `n` records of 2, `defined` `n` flags.
    pub fn interval_batch(
        &self,
        input: &[f64],
        out: &mut [f64],
        defined: &mut [bool],
    ) -> Result<(), JitError> {
        let n = check_box_batch(input, out, defined, 2)?;
        // SAFETY: lengths checked above; the kernel writes only 0 or 1 into
        // `defined`, valid `bool` values.
        unsafe {
            (self.interval_batch)(
                input.as_ptr(),
                out.as_mut_ptr(),
                defined.as_mut_ptr().cast::<u8>(),
                n as u64,
            )
        };
        Ok(())
    }

    /// `(F, ∂F/∂x, ∂F/∂y, ∂F/∂z)` enclosed over the box `[x, y, z, t]`.
    pub fn grad(&self, input: [Interval; 4]) -> GradEval {
        let inp = flatten(input);
        let mut out = [0.0; 8];
        // SAFETY: `inp` holds 8 f64 and `out` 8, as the ABI requires.
        let d = unsafe { (self.grad)(inp.as_ptr(), out.as_mut_ptr()) };
        let iv = |k: usize| Interval {
            lo: out[2 * k],
            hi: out[2 * k + 1],
        };
        GradEval {
            value: iv(0),
            grad: [iv(1), iv(2), iv(3)],
            defined: d != 0,
        }
    }

    /// Batch gradient: `input` `n` records of 8 f64, `out` `n` records of 8
    /// (`[F.lo, F.hi, Fx.lo, …, Fz.hi]`), `defined` `n` flags.
    pub fn grad_batch(
        &self,
        input: &[f64],
        out: &mut [f64],
        defined: &mut [bool],
    ) -> Result<(), JitError> {
        let n = check_box_batch(input, out, defined, 8)?;
        // SAFETY: as in `interval_batch`.
        unsafe {
            (self.grad_batch)(
                input.as_ptr(),
                out.as_mut_ptr(),
                defined.as_mut_ptr().cast::<u8>(),
                n as u64,
            )
        };
        Ok(())
    }
}

/// A fresh JIT module for `opts` with the helpers registered.
fn new_module(opts: &JitOptions) -> Result<JITModule, JitError> {
    let mut flags = settings::builder();
    let set = |f: &mut settings::Builder, k: &str, v: &str| {
        f.set(k, v).map_err(|e| JitError::Target(e.to_string()))
    };
    set(&mut flags, "opt_level", "speed")?;
    let ra = if opts.fast_compile {
        "single_pass"
    } else {
        "backtracking"
    };
    set(&mut flags, "regalloc_algorithm", ra)?;
    set(&mut flags, "use_colocated_libcalls", "false")?;
    set(&mut flags, "is_pic", "false")?;
    set(
        &mut flags,
        "enable_verifier",
        if opts.verify { "true" } else { "false" },
    )?;
    let isa = cranelift_native::builder()
        .map_err(|e| JitError::Target(e.to_string()))?
        .finish(settings::Flags::new(flags))
        .map_err(|e| JitError::Target(e.to_string()))?;
    let mut jb = JITBuilder::with_isa(isa, default_libcall_names());
    jb.symbols(helpers::symbols());
    Ok(JITModule::new(jb))
}

/// Compiles the single and batch entry points of each of `kinds` into one
/// new module; returns it with the finalized entry points (in `kinds`
/// order, single then batch) and their info. The module's memory is freed
/// if anything fails.
#[allow(clippy::type_complexity)]
fn build(
    prog: &ir::Program,
    pool_addr: i64,
    opts: &JitOptions,
    kinds: &[Kind],
) -> Result<(ModuleOwner, Vec<*const u8>, Vec<KernelInfo>), JitError> {
    let mut owner = ModuleOwner(Some(new_module(opts)?));
    let Some(module) = owner.0.as_mut() else {
        return Err(JitError::Target("no module".into()));
    };
    let (p, info) = define_entries(module, prog, pool_addr, opts, kinds)?;
    Ok((owner, p, info))
}

fn define_entries(
    module: &mut JITModule,
    prog: &ir::Program,
    pool_addr: i64,
    opts: &JitOptions,
    kinds: &[Kind],
) -> Result<(Vec<*const u8>, Vec<KernelInfo>), JitError> {
    let ptr = module.target_config().pointer_type();
    let cc = module.isa().default_call_conv();
    let mut helper_ids = Vec::with_capacity(helpers::symbols().len());
    for ((name, _), sig) in helpers::symbols().iter().zip(helper_sigs(cc, ptr)) {
        let id = module
            .declare_function(name, Linkage::Import, &sig)
            .map_err(|e| JitError::Codegen(e.to_string()))?;
        helper_ids.push(id);
    }

    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let mut ids = Vec::new();
    let mut info = Vec::new();
    for &kind in kinds {
        for batch in [false, true] {
            let t0 = Instant::now();
            let name = entry_name(kind, batch);
            let sig = entry_sig(kind, batch, cc, ptr);
            let id = module
                .declare_function(name, Linkage::Local, &sig)
                .map_err(|e| JitError::Codegen(e.to_string()))?;
            ctx.func.signature = sig;
            {
                let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
                let refs: Vec<FuncRef> = helper_ids
                    .iter()
                    .map(|&h| module.declare_func_in_func(h, b.func))
                    .collect();
                let entry = b.create_block();
                b.append_block_params_for_function_params(entry);
                b.switch_to_block(entry);
                let pool_v = b.ins().iconst(ptr, pool_addr);
                let mut env = Env {
                    b,
                    pool: pool_v,
                    helpers: refs,
                    ptr,
                    iv_slot: None,
                    gd_slots: None,
                    pg_slot: None,
                };
                emit_entry(&mut env, prog, kind, batch, entry, opts);
                env.b.seal_all_blocks();
                env.b.finalize(module.target_config());
            }
            ctx.set_disasm(opts.keep_text);
            module
                .define_function(id, &mut ctx)
                .map_err(|e| JitError::Codegen(format!("{e:?}")))?;
            let code = ctx.compiled_code();
            let code_bytes = code.map_or(0, |c| c.code_buffer().len());
            let asm = if opts.keep_text {
                code.and_then(|c| c.vcode.clone())
            } else {
                None
            };
            let clif = opts.keep_text.then(|| ctx.func.display().to_string());
            module.clear_context(&mut ctx);
            ids.push(id);
            info.push(KernelInfo {
                kind,
                batch,
                name,
                code_bytes,
                compile_time: t0.elapsed(),
                clif,
                asm,
            });
        }
    }
    let t0 = Instant::now();
    module
        .finalize_definitions()
        .map_err(|e| JitError::Codegen(e.to_string()))?;
    // Attribute finalisation (relocation, mprotect) evenly.
    let share = t0.elapsed() / info.len() as u32;
    for i in &mut info {
        i.compile_time += share;
    }
    let p: Vec<*const u8> = ids
        .iter()
        .map(|&id| module.get_finalized_function(id))
        .collect();
    Ok((p, info))
}

fn flatten(input: [Interval; 4]) -> [f64; 8] {
    let mut r = [0.0; 8];
    for (k, iv) in input.iter().enumerate() {
        r[2 * k] = iv.lo;
        r[2 * k + 1] = iv.hi;
    }
    r
}

fn check_box_batch(
    input: &[f64],
    out: &[f64],
    defined: &[bool],
    out_stride: usize,
) -> Result<usize, JitError> {
    let n = defined.len();
    if input.len() != 8 * n || out.len() != out_stride * n {
        return Err(JitError::BufferLength(format!(
            "input {} f64 (want {}), out {} f64 (want {}), defined {n}",
            input.len(),
            8 * n,
            out.len(),
            out_stride * n
        )));
    }
    Ok(n)
}

fn entry_name(kind: Kind, batch: bool) -> &'static str {
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

fn entry_sig(
    kind: Kind,
    batch: bool,
    cc: cranelift_codegen::isa::CallConv,
    ptr: clif::Type,
) -> Signature {
    use types::{F64, I8, I64};
    let mut s = Signature::new(cc);
    let (params, ret): (Vec<clif::Type>, Option<clif::Type>) = match (kind, batch) {
        (Kind::Point, false) => (vec![F64; 4], Some(F64)),
        (Kind::Point, true) | (Kind::PointGrad, true) => (vec![ptr, ptr, ptr, F64, ptr, I64], None),
        (Kind::PointGrad, false) => (vec![F64, F64, F64, F64, ptr], None),
        (_, false) => (vec![ptr, ptr], Some(I8)),
        (_, true) => (vec![ptr, ptr, ptr, I64], None),
    };
    s.params.extend(params.into_iter().map(AbiParam::new));
    s.returns.extend(ret.map(AbiParam::new));
    s
}

/// Emits the entry point's body (loop for batch) into `env`, starting in
/// `entry`, whose parameters are the function's.
fn emit_entry(
    env: &mut Env,
    prog: &ir::Program,
    kind: Kind,
    batch: bool,
    entry: clif::Block,
    opts: &JitOptions,
) {
    if kind == Kind::PointGrad {
        pgrad::emit_entry(env, prog, batch, entry);
        return;
    }
    let params: Vec<Value> = env.b.block_params(entry).to_vec();
    if kind == Kind::Point && batch && opts.simd {
        simd::emit_point_batch(env, prog, &params);
        return;
    }
    let f = Env::flags();
    if !batch {
        match kind {
            Kind::Point => {
                let r = point::lower(env, prog, [params[0], params[1], params[2], params[3]]);
                env.b.ins().return_(&[r]);
            }
            Kind::Interval | Kind::Grad | Kind::PointGrad => {
                let input = [0, 1, 2, 3].map(|k| {
                    let iv = env.read_iv(params[0], 16 * k);
                    interval::normalize(env, iv)
                });
                let out = params[1];
                let d = store_box_result(env, prog, kind, input, out);
                env.b.ins().return_(&[d]);
            }
        }
        return;
    }
    let n = *params.last().unwrap_or(&params[0]);
    let header = env.b.create_block();
    let body = env.b.create_block();
    let exit = env.b.create_block();
    env.b.append_block_param(header, types::I64);
    let zero = env.b.ins().iconst(types::I64, 0);
    env.b.ins().jump(header, &[zero.into()]);
    env.b.switch_to_block(header);
    let i = env.b.block_params(header)[0];
    let more = env
        .b
        .ins()
        .icmp(clif::condcodes::IntCC::UnsignedLessThan, i, n);
    env.b.ins().brif(more, body, &[], exit, &[]);
    env.b.switch_to_block(body);
    match kind {
        Kind::Point => {
            let off = env.b.ins().imul_imm_s(i, 8);
            let at = |env: &mut Env, base: Value| env.b.ins().iadd(base, off);
            let xa = at(env, params[0]);
            let ya = at(env, params[1]);
            let za = at(env, params[2]);
            let x = env.b.ins().load(types::F64, f, xa, 0);
            let y = env.b.ins().load(types::F64, f, ya, 0);
            let z = env.b.ins().load(types::F64, f, za, 0);
            let r = point::lower(env, prog, [x, y, z, params[3]]);
            let oa = at(env, params[4]);
            env.b.ins().store(f, r, oa, 0);
        }
        Kind::Interval | Kind::Grad | Kind::PointGrad => {
            let in_off = env.b.ins().imul_imm_s(i, 64);
            let ia = env.b.ins().iadd(params[0], in_off);
            let input = [0, 1, 2, 3].map(|k| {
                let iv = env.read_iv(ia, 16 * k);
                interval::normalize(env, iv)
            });
            let stride = if kind == Kind::Interval { 16 } else { 64 };
            let out_off = env.b.ins().imul_imm_s(i, stride);
            let oa = env.b.ins().iadd(params[1], out_off);
            let d = store_box_result(env, prog, kind, input, oa);
            let da = env.b.ins().iadd(params[2], i);
            env.b.ins().store(f, d, da, 0);
        }
    }
    let next = env.b.ins().iadd_imm_s(i, 1);
    env.b.ins().jump(header, &[next.into()]);
    env.b.switch_to_block(exit);
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
    let f = Env::flags();
    let (ivs, d): (Vec<interval::Iv>, Value) = if kind == Kind::Interval {
        let (iv, d) = interval::lower(env, prog, input);
        (vec![iv], d)
    } else {
        let (g, d) = grad::lower(env, prog, input);
        (g.to_vec(), d)
    };
    for (k, (lo, hi)) in ivs.into_iter().enumerate() {
        env.b.ins().store(f, lo, out, (16 * k) as i32);
        env.b.ins().store(f, hi, out, (16 * k + 8) as i32);
    }
    d
}
