//! A compiled surface: the simplified program of its function, its domain,
//! and the JIT kernels that evaluate it. This is the library's front door:
//! [`Surface::compile`] turns source text into a `Surface`, whose methods
//! evaluate the function at points and over boxes — single calls and
//! batches — through the three Cranelift kernels ([`crate::jit`]). The
//! reference interpreters ([`crate::eval`]) stay available on
//! [`Surface::program`] as the oracle.

use std::sync::Arc;

use crate::eval::Evaluator;
use crate::eval::grad::GradEval;
use crate::geometry::Bounds;
use crate::interval::{DecInterval, Interval};
use crate::ir::Program;
use crate::jit::{JitError, Kernels};
use crate::syntax::{self, CompileOptions, FrontError};

/// Why a surface could not be compiled: its source (or the options), or
/// the JIT.
#[derive(Debug)]
pub enum CompileError {
    /// The front end rejected the source or the options.
    Front(FrontError),
    /// The JIT could not compile the kernels.
    Jit(JitError),
}

impl CompileError {
    /// The source diagnostics rendered (`FILE:LINE:COL: error: …` with a
    /// caret), or `error: MESSAGE` for anything else.
    pub fn render(&self) -> String {
        match self {
            CompileError::Front(e) => e.render(),
            CompileError::Jit(e) => format!("error: {e}\n"),
        }
    }
}

impl std::fmt::Display for CompileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CompileError::Front(e) => e.fmt(f),
            CompileError::Jit(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for CompileError {}

impl From<FrontError> for CompileError {
    fn from(e: FrontError) -> CompileError {
        CompileError::Front(e)
    }
}

impl From<JitError> for CompileError {
    fn from(e: JitError) -> CompileError {
        CompileError::Jit(e)
    }
}

/// A compiled surface.
///
/// # Example
///
/// ```
/// use isoc::{CompileOptions, Interval, Surface};
///
/// // A torus whose tube radius is a param, overridden to 0.25.
/// let src = "domain [-2, 2]^3; param r = 0.5;
///            surface (sqrt(x^2 + y^2) - 1)^2 + z^2 = r^2;";
/// let opts = CompileOptions { params: vec![("r".into(), 0.25)], domain: None };
/// let torus = Surface::compile(src, "torus.iso", &opts)?;
/// assert_eq!(torus.params, vec![("r".to_string(), 0.25)]);
/// // Value and gradient on the outer equator: f = 0, ∇f = (0.5, 0, 0).
/// let (v, g) = torus.point_grad([1.25, 0.0, 0.0, 0.0]);
/// assert_eq!((v, g), (0.0, [0.5, 0.0, 0.0]));
/// // A batch of points in one kernel call, bit for bit the single calls.
/// let mut out = [0.0; 3];
/// torus.point_batch(&[0.0, 1.0, 1.25], &[0.0; 3], &[0.0; 3], 0.0, &mut out)?;
/// assert_eq!(out[1], torus.point([1.0, 0.0, 0.0, 0.0]));
/// // A guaranteed enclosure of f and ∇f over a box around that point.
/// let near = |c: f64| Interval { lo: c - 0.01, hi: c + 0.01 };
/// let e = torus.grad([near(1.25), near(0.0), near(0.0), Interval::point(0.0)]);
/// assert!(e.value.lo <= 0.0 && 0.0 <= e.value.hi && e.grad[0].lo > 0.0);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone)]
pub struct Surface {
    /// The file name diagnostics were reported against.
    pub file: String,
    /// The simplified SSA program of the function.
    pub program: Program,
    /// The domain Ω.
    pub domain: Bounds,
    /// The values of every `param`, after `--set` overrides.
    pub params: Vec<(String, f64)>,
    /// The JIT kernels of `program` (shared by clones).
    kernels: Arc<Kernels>,
}

impl std::fmt::Debug for Surface {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Surface")
            .field("file", &self.file)
            .field("program", &self.program)
            .field("domain", &self.domain)
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

impl Surface {
    /// Compiles source text. `file` names the source in diagnostics and
    /// chooses the language: a `.vm` file is a Fidget text-SSA model
    /// ([`crate::syntax::vm`]), anything else `.iso`.
    pub fn compile(
        source: &str,
        file: &str,
        opts: &CompileOptions,
    ) -> Result<Surface, CompileError> {
        let lowered = syntax::front_end_for(source, file, opts)?;
        Surface::from_program(file, lowered.program, lowered.domain, lowered.params)
    }

    /// Compiles a Fidget `.vm` model whatever `file` is called (see
    /// [`crate::syntax::vm`]).
    pub fn compile_vm(
        source: &str,
        file: &str,
        opts: &CompileOptions,
    ) -> Result<Surface, CompileError> {
        let lowered = syntax::vm::front_end(source, file, opts)?;
        Surface::from_program(file, lowered.program, lowered.domain, lowered.params)
    }

    /// A surface from an IR program built elsewhere (e.g. with
    /// [`crate::ir::Builder`]).
    pub fn from_program(
        file: &str,
        program: Program,
        domain: Bounds,
        params: Vec<(String, f64)>,
    ) -> Result<Surface, CompileError> {
        // Nothing is compiled yet: each kernel kind on first use (or by
        // `Kernels::prepare`).
        let kernels = Kernels::lazy(&program, &crate::jit::JitOptions::default())?;
        Ok(Surface {
            file: file.to_string(),
            program,
            domain,
            params,
            kernels: Arc::new(kernels),
        })
    }

    /// The JIT kernels (function pointers, batch entry points, code sizes,
    /// compile times, CLIF and disassembly).
    pub fn kernels(&self) -> &Kernels {
        &self.kernels
    }

    /// Compiles a file's bytes (which need not be valid UTF-8: invalid text
    /// is a located error like any other).
    pub fn compile_bytes(
        bytes: &[u8],
        file: &str,
        opts: &CompileOptions,
    ) -> Result<Surface, CompileError> {
        let source = syntax::source_from_bytes(bytes, file)?;
        Surface::compile(&source, file, opts)
    }

    /// f at `[x, y, z, t]` (point kernel).
    pub fn point(&self, p: [f64; 4]) -> f64 {
        self.kernels.point(p)
    }

    /// f and ∇f = `(∂f/∂x, ∂f/∂y, ∂f/∂z)` at `[x, y, z, t]` (point-gradient
    /// kernel, compiled on first use): forward-mode AD in f64, bit for bit
    /// [`crate::eval::grad::eval_point`]; the value is the point kernel's.
    /// Where there is no derivative (the value is NaN, `sqrt` at 0, …) the
    /// gradient is NaN.
    pub fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        self.kernels.point_grad(p)
    }

    /// [`Surface::point_grad`] at every `[x, y, z]` of `pts` at time `t`
    /// (batch point-gradient kernel).
    pub fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64) -> Vec<(f64, [f64; 3])> {
        let mut out = vec![(0.0, [0.0; 3]); pts.len()];
        Evaluator::point_grad_batch(self.kernels(), pts, t, &mut out);
        out
    }

    /// Enclosure of f over a box `[x, y, z, t]` (interval kernel).
    pub fn interval(&self, b: [Interval; 4]) -> DecInterval {
        self.kernels.interval(b)
    }

    /// Enclosure of f and ∇f over a box `[x, y, z, t]` (interval-gradient
    /// kernel).
    pub fn grad(&self, b: [Interval; 4]) -> GradEval {
        self.kernels.grad(b)
    }

    /// `out[i] = f(xs[i], ys[i], zs[i], t)` (batch point kernel).
    pub fn point_batch(
        &self,
        xs: &[f64],
        ys: &[f64],
        zs: &[f64],
        t: f64,
        out: &mut [f64],
    ) -> Result<(), JitError> {
        self.kernels.point_batch(xs, ys, zs, t, out)
    }

    /// Interval-gradient enclosures over many boxes (batch kernel).
    pub fn grad_batch(&self, boxes: &[[Interval; 4]]) -> Vec<GradEval> {
        let mut out = vec![crate::eval::WHOLE_GRAD; boxes.len()];
        Evaluator::grad_batch(self.kernels(), boxes, &mut out);
        out
    }

    /// Interval enclosures over many boxes (batch kernel).
    pub fn interval_batch(&self, boxes: &[[Interval; 4]]) -> Vec<DecInterval> {
        let mut out = vec![crate::eval::WHOLE; boxes.len()];
        Evaluator::interval_batch(self.kernels(), boxes, &mut out);
        out
    }
}

/// A surface evaluates through its JIT kernels (see [`crate::eval`]); the
/// inherent methods above stay as they are.
impl Evaluator for Surface {
    fn point(&self, p: [f64; 4]) -> f64 {
        Surface::point(self, p)
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        Surface::point_grad(self, p)
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        Surface::interval(self, b)
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        Surface::grad(self, b)
    }
    fn program(&self) -> Option<&crate::ir::Program> {
        Some(&self.program)
    }
    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        Evaluator::point_batch(self.kernels(), xs, ys, zs, t, out)
    }
    fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64, out: &mut [(f64, [f64; 3])]) {
        Evaluator::point_grad_batch(self.kernels(), pts, t, out)
    }
    fn interval_batch(&self, boxes: &[[Interval; 4]], out: &mut [DecInterval]) {
        Evaluator::interval_batch(self.kernels(), boxes, out)
    }
    fn grad_batch(&self, boxes: &[[Interval; 4]], out: &mut [GradEval]) {
        Evaluator::grad_batch(self.kernels(), boxes, out)
    }
}
