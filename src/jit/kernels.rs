//! [`Kernels`]: the public face of the JIT — the compiled entry points of
//! one program, compiled lazily per kind, with safe single and batch calls.
//!
//! Each kind (point, interval, interval-gradient, point-gradient) lives in
//! its own JIT module behind a `OnceLock`, compiled on first use or by
//! [`Kernels::prepare`] (several kinds in parallel). A program longer than
//! [`JitOptions::jit_limit`] is never compiled: every call then runs the
//! reference interpreters of [`crate::eval`], whose time and memory are
//! linear in the program (same results; the point kinds bit for bit, the
//! interval kinds enclosures at least as sound). A compilation failure is
//! remembered; the safe methods fall back to the interpreters as well, and
//! [`Kernels::engine`] says which ran.
//!
//! The point gradient has two tiers. Its first kernel evaluates one point
//! per iteration and compiles fast; once its batches of two or more points
//! have evaluated [`JitOptions::point_grad_wide_after`] points in all (over
//! every run that shares the kernels), the call that crosses the count
//! compiles a second, two points per iteration in `F64X2`, which later
//! batches use (the other threads go on with the first meanwhile). A
//! single point stays on the first. Both give the same bits, so a mesh
//! does not depend on when the switch happens. A small model never pays
//! for the second compile; a large one, or a surface meshed again (an
//! animation, a library user's loop), runs its point gradients about
//! twice as fast. `compile --emit` compiles the second at once
//! ([`Kernels::prepare_second_tier`]) to list it.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use super::module::{ModuleOwner, build};
use super::{
    BoxBatchFn, BoxFn, IntervalFn, JitError, JitOptions, KernelInfo, Kind, POOL_STRIDE,
    PointBatchFn, PointFn, PointGradBatchFn,
};
use crate::eval::grad::GradEval;
use crate::interval::{DecInterval, Interval};
use crate::ir::{self, Op};

/// The compiled entry points of one kind's module: a batch entry point,
/// and for the point kind a single one (`S = ()` otherwise: the interval
/// and gradient kinds' single-box entry points are in a [`One`], and a
/// single point-gradient call is a batch of one).
struct Entry<S, B> {
    single: S,
    batch: B,
    info: Vec<KernelInfo>,
    _module: ModuleOwner,
}

type Lazy<S, B> = OnceLock<Result<Entry<S, B>, JitError>>;

/// The single-box entry point of the interval or gradient kind, in a
/// module of its own (only single calls need it).
struct One<F> {
    f: F,
    info: Vec<KernelInfo>,
    _module: ModuleOwner,
}

/// Which implementation serves a kind.
#[derive(Clone, Debug, PartialEq)]
pub enum Engine {
    /// Native code compiled by Cranelift.
    Jit,
    /// The reference interpreters ([`crate::eval`]), because the kind could
    /// not or should not be compiled (the reason).
    Interpreter(JitError),
}

/// The kernels of one program. See the module doc.
pub struct Kernels {
    program: ir::Program,
    opts: JitOptions,
    point: Lazy<PointFn, PointBatchFn>,
    interval: Lazy<(), BoxBatchFn>,
    grad: Lazy<(), BoxBatchFn>,
    pgrad: Lazy<(), PointGradBatchFn>,
    /// The point gradient's second tier: two points per iteration, compiled
    /// once [`JitOptions::point_grad_wide_after`] points have gone through
    /// `pgrad`'s batches (see [`Kernels::point_grad_batch`]).
    pgrad_wide: Lazy<(), PointGradBatchFn>,
    /// Points evaluated by batch calls of two or more, until `pgrad_wide`
    /// is started.
    pgrad_points: AtomicUsize,
    /// Whether a caller has taken on compiling `pgrad_wide` (the others
    /// go on with `pgrad` meanwhile).
    pgrad_wide_started: AtomicBool,
    interval_one: OnceLock<Result<One<IntervalFn>, JitError>>,
    grad_one: OnceLock<Result<One<BoxFn>, JitError>>,
    // Field order matters: the modules (code) are dropped before the pool,
    // and neither is touched but by the kernels.
    pool: Box<[f64]>,
}

impl std::fmt::Debug for Kernels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Kernels")
            .field("ir_len", &self.program.len())
            .field("info", &self.info())
            .finish_non_exhaustive()
    }
}

/// Reinterprets a finalized code pointer as the entry point type `F`.
///
/// # Safety
/// `p` is the finalized code of a function declared with the signature
/// that [`super::entry::entry_sig`] gives for the kind `F` stands for, and
/// the code outlives every use of the result.
unsafe fn entry_fn<F: Copy>(p: *const u8) -> F {
    assert_eq!(std::mem::size_of::<F>(), std::mem::size_of::<*const u8>());
    // SAFETY: same size (checked); validity of the pointer as `F` is the
    // caller's promise.
    unsafe { std::mem::transmute_copy::<*const u8, F>(&p) }
}

/// The single entry point of a kind, if it has one.
trait Single: Sized {
    /// # Safety
    /// As [`entry_fn`] for the first of `p` when `p` has two entries.
    unsafe fn from_code(p: &[*const u8]) -> Self;
}

impl Single for () {
    unsafe fn from_code(_: &[*const u8]) {}
}

impl Single for PointFn {
    unsafe fn from_code(p: &[*const u8]) -> PointFn {
        // SAFETY: the caller's promise.
        unsafe { entry_fn::<PointFn>(p[0]) }
    }
}

impl Kernels {
    /// Checks `prog` and compiles the point, interval and gradient kernels
    /// now, batch and single-box entry points (the point gradient on first
    /// use), with default options. An error if any of them cannot be
    /// compiled — including a program over [`JitOptions::jit_limit`];
    /// [`Kernels::lazy`] never fails for that.
    pub fn compile(prog: &ir::Program) -> Result<Kernels, JitError> {
        Kernels::compile_with(prog, &JitOptions::default())
    }

    /// [`Kernels::compile`] with options.
    pub fn compile_with(prog: &ir::Program, opts: &JitOptions) -> Result<Kernels, JitError> {
        let k = Kernels::lazy(prog, opts)?;
        rayon::join(|| k.prepare(&Kind::ALL), || k.grad_one_k().is_ok());
        for kind in Kind::ALL {
            if let Engine::Interpreter(e) = k.engine(kind) {
                return Err(e);
            }
        }
        if super::mxcsr::single_box_bracket_runs() {
            k.interval_one_k()?;
            k.grad_one_k()?;
        }
        Ok(k)
    }

    /// Checks `prog` and builds the constant pool; compiles nothing yet.
    /// Each kind is compiled on first use (or by [`Kernels::prepare`]).
    pub fn lazy(prog: &ir::Program, opts: &JitOptions) -> Result<Kernels, JitError> {
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
                    // The interval kernels hold `(−lo, hi)`.
                    rec.copy_from_slice(&[c.value, -iv.lo, iv.hi]);
                }
                Op::Powi(..) => rec.copy_from_slice(&[1.0, -1.0, 1.0]),
                _ => {}
            }
        }
        Ok(Kernels {
            program: prog.clone(),
            opts: *opts,
            point: OnceLock::new(),
            interval: OnceLock::new(),
            grad: OnceLock::new(),
            pgrad: OnceLock::new(),
            pgrad_wide: OnceLock::new(),
            pgrad_points: AtomicUsize::new(0),
            pgrad_wide_started: AtomicBool::new(false),
            interval_one: OnceLock::new(),
            grad_one: OnceLock::new(),
            pool,
        })
    }

    /// Compiles the given kinds now, in parallel (on rayon's pool), so
    /// that later calls do not pay for it: their batch entry points, and
    /// for the interval kind the single-box entry point too (single calls,
    /// [`Kernels::interval`]), which `--emit` then lists; the gradient's
    /// single-box entry point is compiled on its first call. Failures are
    /// remembered (see [`Kernels::engine`]).
    pub fn prepare(&self, kinds: &[Kind]) {
        rayon::scope(|s| {
            for &kind in kinds {
                s.spawn(move |_| {
                    let _ = self.engine(kind);
                });
                if kind == Kind::Interval {
                    s.spawn(move |_| {
                        let _ = self.interval_one_k();
                    });
                }
            }
        });
    }

    /// Which implementation serves `kind` (compiling it if needed).
    pub fn engine(&self, kind: Kind) -> Engine {
        let r = match kind {
            Kind::Point => self.point_k().map(|_| ()),
            Kind::Interval => self.interval_k().map(|_| ()),
            Kind::Grad => self.grad_k().map(|_| ()),
            Kind::PointGrad => self.pgrad_k().map(|_| ()),
        };
        match r {
            Ok(()) => Engine::Jit,
            Err(e) => Engine::Interpreter(e),
        }
    }

    /// The module and entry points of `kind` named by `batches` (see
    /// [`build`]), unless the program is over the JIT limit.
    fn build(
        &self,
        kind: Kind,
        batches: &[bool],
        opts: &JitOptions,
    ) -> Result<(ModuleOwner, Vec<*const u8>, Vec<KernelInfo>), JitError> {
        if self.program.len() > self.opts.jit_limit {
            return Err(JitError::TooLarge {
                len: self.program.len(),
                limit: self.opts.jit_limit,
            });
        }
        build(
            &self.program,
            self.pool.as_ptr() as i64,
            opts,
            kind,
            batches,
        )
    }

    /// The entry points of `kind`, compiled with `opts` (the kernels'
    /// options, or the point gradient's tier's).
    fn compile_kind<S: Single, B: Copy>(
        &self,
        kind: Kind,
        opts: &JitOptions,
    ) -> Result<Entry<S, B>, JitError> {
        let batches: &[bool] = if kind == Kind::Point {
            &[false, true]
        } else {
            &[true]
        };
        let (module, p, info) = self.build(kind, batches, opts)?;
        // SAFETY: `p` are the finalized entry points of `kind` (single then
        // batch for the point kind, batch only otherwise: `S::from_code`
        // takes the first of two or none), declared with `entry_sig`'s
        // signatures, which are the types `S` and `B` stand for at every
        // caller below; the code lives as long as `module`, which the
        // entry owns.
        let (single, batch) = unsafe {
            let last = *p
                .last()
                .ok_or_else(|| JitError::Codegen("no entry".into()))?;
            (S::from_code(&p), entry_fn::<B>(last))
        };
        Ok(Entry {
            single,
            batch,
            info,
            _module: module,
        })
    }

    /// The single-box entry point of the interval or gradient kind (an
    /// error on a processor without SSE4.1, which its mode bracket needs:
    /// single calls then make batches of one).
    fn compile_one<F: Copy>(&self, kind: Kind) -> Result<One<F>, JitError> {
        if !super::mxcsr::single_box_bracket_runs() {
            return Err(JitError::Target(
                "no SSE4.1 for the single-box bracket".into(),
            ));
        }
        let (module, p, info) = self.build(kind, &[false], &self.opts)?;
        // SAFETY: `p[0]` is the finalized single-box entry point of `kind`,
        // declared with `entry_sig(kind, false)`: `IntervalFn` for the
        // interval kind and `BoxFn` for the gradient, the types `F` stands
        // for in `interval_one_k` and `grad_one_k`; the code lives as long
        // as `module`, which `One` owns.
        let f = unsafe { entry_fn::<F>(p[0]) };
        Ok(One {
            f,
            info,
            _module: module,
        })
    }

    #[inline]
    fn interval_one_k(&self) -> Result<&One<IntervalFn>, JitError> {
        let r = self
            .interval_one
            .get_or_init(|| self.compile_one(Kind::Interval));
        r.as_ref().map_err(Clone::clone)
    }
    #[inline]
    fn grad_one_k(&self) -> Result<&One<BoxFn>, JitError> {
        let r = self.grad_one.get_or_init(|| self.compile_one(Kind::Grad));
        r.as_ref().map_err(Clone::clone)
    }

    fn point_k(&self) -> Result<&Entry<PointFn, PointBatchFn>, JitError> {
        let r = self
            .point
            .get_or_init(|| self.compile_kind(Kind::Point, &self.opts));
        r.as_ref().map_err(Clone::clone)
    }
    fn interval_k(&self) -> Result<&Entry<(), BoxBatchFn>, JitError> {
        let r = self
            .interval
            .get_or_init(|| self.compile_kind(Kind::Interval, &self.opts));
        r.as_ref().map_err(Clone::clone)
    }
    fn grad_k(&self) -> Result<&Entry<(), BoxBatchFn>, JitError> {
        let r = self
            .grad
            .get_or_init(|| self.compile_kind(Kind::Grad, &self.opts));
        r.as_ref().map_err(Clone::clone)
    }
    /// The point gradient's first tier: one point per iteration (the
    /// faster compile).
    fn pgrad_k(&self) -> Result<&Entry<(), PointGradBatchFn>, JitError> {
        let r = self.pgrad.get_or_init(|| {
            let one_lane = JitOptions {
                simd: false,
                ..self.opts
            };
            self.compile_kind(Kind::PointGrad, &one_lane)
        });
        r.as_ref().map_err(Clone::clone)
    }

    /// The batch point-gradient kernel for a batch of `n` points: the
    /// second tier once it is compiled — by this call, when it brings the
    /// points counted past [`JitOptions::point_grad_wide_after`] — else
    /// the first. A batch of one stays on the first tier, which evaluates
    /// one point per iteration anyway (the second would evaluate a spare
    /// lane), and is not counted.
    fn pgrad_batch_for(&self, n: usize) -> Result<PointGradBatchFn, JitError> {
        if let Some(Ok(e)) = self.pgrad_wide.get() {
            return Ok(e.batch);
        }
        if n >= 2 && self.second_tier_used() {
            let seen = self.pgrad_points.fetch_add(n, Ordering::Relaxed) + n;
            if seen > self.opts.point_grad_wide_after
                && !self.pgrad_wide_started.swap(true, Ordering::Relaxed)
                && let Ok(e) = self.pgrad_wide_k()
            {
                return Ok(e.batch);
            }
        }
        self.pgrad_k().map(|k| k.batch)
    }

    /// The point gradient's second tier, compiled on the first call
    /// (`pgrad_batch_for` and [`Kernels::prepare_second_tier`] decide
    /// when); its entry point is named `point_grad_batch_x2`.
    fn pgrad_wide_k(&self) -> Result<&Entry<(), PointGradBatchFn>, JitError> {
        let r = self.pgrad_wide.get_or_init(|| {
            let mut e: Entry<(), PointGradBatchFn> =
                self.compile_kind(Kind::PointGrad, &self.opts)?;
            for i in &mut e.info {
                i.name = "point_grad_batch_x2";
            }
            Ok(e)
        });
        r.as_ref().map_err(Clone::clone)
    }

    /// Whether the options ever use the point gradient's second tier:
    /// `simd` on and [`JitOptions::point_grad_wide_after`] not
    /// `usize::MAX`.
    fn second_tier_used(&self) -> bool {
        self.opts.simd && self.opts.point_grad_wide_after != usize::MAX
    }

    /// Compiles the point gradient's second tier now, as `compile --emit`
    /// lists it, unless the options never use it (`simd` off, or
    /// [`JitOptions::point_grad_wide_after`] at `usize::MAX`); later
    /// batches of two or more points use it at once. Failures are
    /// remembered, and the first tier serves.
    pub fn prepare_second_tier(&self) {
        if self.second_tier_used() {
            self.pgrad_wide_started.store(true, Ordering::Relaxed);
            let _ = self.pgrad_wide_k();
        }
    }

    /// Info on every entry point compiled so far (name, code size, compile
    /// time, text), in kind order.
    pub fn info(&self) -> Vec<KernelInfo> {
        let mut v = Vec::new();
        if let Some(Ok(e)) = self.point.get() {
            v.extend(e.info.iter().cloned());
        }
        if let Some(Ok(e)) = self.interval_one.get() {
            v.extend(e.info.iter().cloned());
        }
        if let Some(Ok(e)) = self.interval.get() {
            v.extend(e.info.iter().cloned());
        }
        if let Some(Ok(e)) = self.grad_one.get() {
            v.extend(e.info.iter().cloned());
        }
        if let Some(Ok(e)) = self.grad.get() {
            v.extend(e.info.iter().cloned());
        }
        for tier in [&self.pgrad, &self.pgrad_wide] {
            if let Some(Ok(e)) = tier.get() {
                v.extend(e.info.iter().cloned());
            }
        }
        v
    }

    /// Number of IR instructions.
    pub fn ir_len(&self) -> usize {
        self.program.len()
    }

    /// The program the kernels evaluate.
    pub fn program(&self) -> &ir::Program {
        &self.program
    }

    /// Machine-code bytes of the single and batch entry points of `kind`
    /// (0 if not compiled).
    pub fn code_bytes(&self, kind: Kind) -> usize {
        self.info()
            .iter()
            .filter(|i| i.kind == kind)
            .map(|i| i.code_bytes)
            .sum()
    }

    /// Compile time of the single and batch entry points of `kind` (zero if
    /// not compiled).
    pub fn compile_time(&self, kind: Kind) -> Duration {
        self.info()
            .iter()
            .filter(|i| i.kind == kind)
            .map(|i| i.compile_time)
            .sum()
    }

    /// Info on the point-gradient entry points (compiling them if needed).
    pub fn point_grad_info(&self) -> Result<&[KernelInfo], JitError> {
        Ok(&self.pgrad_k()?.info)
    }

    /// The raw single-point kernel (see the ABI in [`super`]).
    pub fn point_fn(&self) -> Result<PointFn, JitError> {
        Ok(self.point_k()?.single)
    }
    /// The raw batch point kernel.
    pub fn point_batch_fn(&self) -> Result<PointBatchFn, JitError> {
        Ok(self.point_k()?.batch)
    }
    /// The raw batch interval kernel.
    pub fn interval_batch_fn(&self) -> Result<BoxBatchFn, JitError> {
        Ok(self.interval_k()?.batch)
    }
    /// The raw batch gradient kernel.
    pub fn grad_batch_fn(&self) -> Result<BoxBatchFn, JitError> {
        Ok(self.grad_k()?.batch)
    }
    /// The raw batch point-gradient kernel (the first tier's: see the
    /// module doc).
    pub fn point_grad_batch_fn(&self) -> Result<PointGradBatchFn, JitError> {
        Ok(self.pgrad_k()?.batch)
    }

    /// `f(x, y, z, t)`.
    pub fn point(&self, p: [f64; 4]) -> f64 {
        match self.point_k() {
            // SAFETY: the kernel takes four f64 by value and reads no
            // memory but the constant pool, which `self` keeps alive.
            Ok(k) => unsafe { (k.single)(p[0], p[1], p[2], p[3]) },
            Err(_) => crate::eval::point::eval(&self.program, p),
        }
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
        let k = self.point_k().map(|k| k.batch);
        columns_batch(k, [xs, ys, zs], t, out, 1, |p, o| {
            o[0] = crate::eval::point::eval(&self.program, p);
        })
    }

    /// Enclosure of `f` over the box `[x, y, z, t]`, by the single-box
    /// entry point (compiled on the first call); the same bounds and flag
    /// as [`Kernels::interval_batch`] on one record.
    #[inline]
    pub fn interval(&self, input: [Interval; 4]) -> DecInterval {
        match self.interval_one_k() {
            Ok(k) => {
                let b = flatten(input);
                // SAFETY: `k.f` is the single-box interval kernel (SSE4.1
                // checked when it was compiled), `b` one input record (8
                // f64); the kernel reads only that and the pool `self`
                // keeps alive.
                let (lo, hi, d) = unsafe {
                    super::mxcsr::call_interval_up(k.f as *const u8, b.as_ptr(), self.pool.as_ptr())
                };
                DecInterval {
                    iv: Interval { lo, hi },
                    defined: d != 0,
                }
            }
            // A batch of one (which falls back to the interpreter if the
            // batch kernel is not compiled either).
            Err(_) => {
                let mut out = [0.0; 2];
                let mut d = [false];
                self.interval_batch(&flatten(input), &mut out, &mut d)
                    .expect("one record");
                DecInterval {
                    iv: Interval {
                        lo: out[0],
                        hi: out[1],
                    },
                    defined: d[0],
                }
            }
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
        box_batch(self.interval_k(), input, out, defined, 2, |b, o| {
            let r = crate::eval::interval::eval(&self.program, b);
            o.copy_from_slice(&[r.iv.lo, r.iv.hi]);
            r.defined
        })
    }

    /// `(F, ∂F/∂x, ∂F/∂y, ∂F/∂z)` enclosed over the box `[x, y, z, t]`,
    /// by the single-box entry point (as [`Kernels::interval`]).
    #[inline]
    pub fn grad(&self, input: [Interval; 4]) -> GradEval {
        match self.grad_one_k() {
            Ok(k) => {
                let b = flatten(input);
                let mut out = [0.0; 8];
                // SAFETY: the single-box gradient kernel, one input record
                // (8 f64) and one output record (8 f64), as for `interval`.
                let d = unsafe {
                    super::mxcsr::call_grad_up(
                        k.f as *const u8,
                        b.as_ptr(),
                        out.as_mut_ptr(),
                        self.pool.as_ptr(),
                    )
                };
                grad_record(&out, d != 0)
            }
            Err(_) => {
                let mut out = [0.0; 8];
                let mut d = [false];
                self.grad_batch(&flatten(input), &mut out, &mut d)
                    .expect("one record");
                grad_record(&out, d[0])
            }
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
        box_batch(self.grad_k(), input, out, defined, 8, |b, o| {
            let g = crate::eval::grad::eval(&self.program, b);
            for (k, iv) in std::iter::once(g.value).chain(g.grad).enumerate() {
                o[2 * k] = iv.lo;
                o[2 * k + 1] = iv.hi;
            }
            g.defined
        })
    }

    /// `f` and `(∂f/∂x, ∂f/∂y, ∂f/∂z)` at `[x, y, z, t]`, as
    /// [`crate::eval::grad::eval_point`] (the value bit for bit the point
    /// kernel's).
    pub fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        match self.pgrad_k() {
            Ok(k) => {
                let mut out = [0.0; 4];
                // SAFETY: one record: each coordinate pointer is valid for
                // 1 f64 and `out` for 4; the kernel reads only those and
                // the constant pool, which `self` keeps alive.
                unsafe { (k.batch)(&p[0], &p[1], &p[2], p[3], out.as_mut_ptr(), 1) };
                (out[0], [out[1], out[2], out[3]])
            }
            Err(_) => crate::eval::grad::eval_point(&self.program, p),
        }
    }

    /// `out[4i..4i+4] = [f, fx, fy, fz]` at `(xs[i], ys[i], zs[i], t)`;
    /// `xs ys zs` of one length `n`, `out` of `4n`. By either tier of the
    /// kernel (the module doc), with the same results.
    pub fn point_grad_batch(
        &self,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        t: f64,
        out: &mut [f64],
    ) -> Result<(), JitError> {
        let k = self.pgrad_batch_for(xs.len());
        columns_batch(k, [xs, ys, zs], t, out, 4, |p, o| {
            let (v, g) = crate::eval::grad::eval_point(&self.program, p);
            o.copy_from_slice(&[v, g[0], g[1], g[2]]);
        })
    }
}

#[inline]
fn flatten(input: [Interval; 4]) -> [f64; 8] {
    let mut r = [0.0; 8];
    for (k, iv) in input.iter().enumerate() {
        r[2 * k] = iv.lo;
        r[2 * k + 1] = iv.hi;
    }
    r
}

fn unflatten(r: &[f64]) -> [Interval; 4] {
    std::array::from_fn(|k| Interval {
        lo: r[2 * k],
        hi: r[2 * k + 1],
    })
}

fn grad_record(out: &[f64], defined: bool) -> GradEval {
    let iv = |k: usize| Interval {
        lo: out[2 * k],
        hi: out[2 * k + 1],
    };
    GradEval {
        value: iv(0),
        grad: [iv(1), iv(2), iv(3)],
        defined,
    }
}

/// Runs a batch kernel over structure-of-arrays coordinates (`n` points,
/// `stride` f64 of output each: the point and point-gradient kinds), or,
/// when it is not compiled, `interp` on each point `[x, y, z, t]`, which
/// writes the point's output record.
fn columns_batch(
    k: Result<PointBatchFn, JitError>,
    [xs, ys, zs]: [&[f64]; 3],
    t: f64,
    out: &mut [f64],
    stride: usize,
    interp: impl Fn([f64; 4], &mut [f64]),
) -> Result<(), JitError> {
    let n = xs.len();
    if ys.len() != n || zs.len() != n || out.len() != stride * n {
        return Err(JitError::BufferLength(format!(
            "xs {n}, ys {}, zs {}, out {} (want {})",
            ys.len(),
            zs.len(),
            out.len(),
            stride * n
        )));
    }
    match k {
        // SAFETY: `xs ys zs` are valid for `n` f64 and `out` for
        // `stride·n` (checked above), `out` is exclusively borrowed; the
        // kernel touches only those indices and the pool its `Kernels`
        // keeps alive.
        Ok(f) => unsafe {
            f(
                xs.as_ptr(),
                ys.as_ptr(),
                zs.as_ptr(),
                t,
                out.as_mut_ptr(),
                n as u64,
            )
        },
        Err(_) => {
            for (i, o) in out.chunks_exact_mut(stride).enumerate() {
                interp([xs[i], ys[i], zs[i], t], o);
            }
        }
    }
    Ok(())
}

/// Runs a box kernel (`k`) over the records of `input`, or, when it is not
/// compiled, `interp` on each box, which writes the `stride` f64 of its
/// output record and returns the flag.
fn box_batch(
    k: Result<&Entry<(), BoxBatchFn>, JitError>,
    input: &[f64],
    out: &mut [f64],
    defined: &mut [bool],
    stride: usize,
    interp: impl Fn([Interval; 4], &mut [f64]) -> bool,
) -> Result<(), JitError> {
    let n = check_box_batch(input, out, defined, stride)?;
    match k {
        // SAFETY: lengths checked above (`n` records of 8 f64 in, `stride`
        // out, `n` flags); the kernel writes only 0 or 1 into `defined`,
        // valid `bool` values, and reads the pool its `Kernels` keeps.
        Ok(k) => unsafe {
            (k.batch)(
                input.as_ptr(),
                out.as_mut_ptr(),
                defined.as_mut_ptr().cast::<u8>(),
                n as u64,
            )
        },
        Err(_) => {
            for (i, d) in defined.iter_mut().enumerate() {
                *d = interp(
                    unflatten(&input[8 * i..]),
                    &mut out[stride * i..stride * (i + 1)],
                );
            }
        }
    }
    Ok(())
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
