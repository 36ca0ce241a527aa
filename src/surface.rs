//! A compiled surface: the simplified program of its function, its domain,
//! and the JIT kernels that evaluate it. This is the library's front door:
//! [`Surface::compile`] turns source text into a `Surface`, whose methods
//! evaluate the function at points and over boxes — single calls and
//! batches — through the three Cranelift kernels ([`crate::jit`]). The
//! reference interpreters ([`crate::eval`]) stay available on
//! [`Surface::program`] as the oracle.

use std::sync::Arc;

use crate::error::Error;
use crate::eval::Evaluator;
use crate::eval::grad::GradEval;
use crate::interval::{DecInterval, Interval};
use crate::ir::Program;
use crate::jit::Kernels;
use crate::syntax;

/// An axis-aligned box `[lo, hi]` in space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

impl Bounds {
    /// Parses `a,b,c,d,e,f` (the command line's `--domain` and `--box`) as
    /// `[a,b]×[c,d]×[e,f]`; checks that every side is finite and `a <= b`.
    pub fn parse(text: &str) -> Result<Bounds, Error> {
        let nums: Vec<f64> = text
            .split(',')
            .map(|w| w.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| Error::Usage(format!("`{text}` is not six comma-separated numbers")))?;
        if nums.len() != 6 {
            return Err(Error::Usage(format!(
                "`{text}` has {} numbers; a box needs six: a,b,c,d,e,f",
                nums.len()
            )));
        }
        let b = Bounds {
            lo: [nums[0], nums[2], nums[4]],
            hi: [nums[1], nums[3], nums[5]],
        };
        for k in 0..3 {
            if !(b.lo[k].is_finite() && b.hi[k].is_finite()) {
                return Err(Error::Usage(format!("`{text}`: the box is not finite")));
            }
            if b.lo[k] > b.hi[k] {
                return Err(Error::Usage(format!(
                    "`{text}`: side {} is inverted ({} > {})",
                    ["x", "y", "z"][k],
                    b.lo[k],
                    b.hi[k]
                )));
            }
        }
        Ok(b)
    }

    /// The box's sides as intervals `[x, y, z]`.
    pub fn sides(&self) -> [Interval; 3] {
        std::array::from_fn(|k| Interval {
            lo: self.lo[k],
            hi: self.hi[k],
        })
    }
}

/// Options of [`Surface::compile`].
#[derive(Clone, Debug, Default)]
pub struct CompileOptions {
    /// `--set NAME=VALUE` overrides of `param`s, in command-line order.
    pub params: Vec<(String, f64)>,
    /// `--domain`: replaces the file's `domain` (and makes it optional).
    pub domain: Option<Bounds>,
}

/// A compiled surface.
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
    pub fn compile(source: &str, file: &str, opts: &CompileOptions) -> Result<Surface, Error> {
        let lowered = syntax::front_end_for(source, file, opts)?;
        Surface::from_program(file, lowered.program, lowered.domain, lowered.params)
    }

    /// Compiles a Fidget `.vm` model whatever `file` is called (see
    /// [`crate::syntax::vm`]).
    pub fn compile_vm(source: &str, file: &str, opts: &CompileOptions) -> Result<Surface, Error> {
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
    ) -> Result<Surface, Error> {
        // Nothing is compiled yet: each kernel kind on first use (or by
        // `Kernels::prepare`).
        let kernels =
            Kernels::lazy(&program, &crate::jit::JitOptions::default()).map_err(Error::Jit)?;
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
    ) -> Result<Surface, Error> {
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
    ) -> Result<(), Error> {
        self.kernels
            .point_batch(xs, ys, zs, t, out)
            .map_err(Error::Jit)
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
