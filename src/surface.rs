//! A compiled surface: the simplified program of its function, its domain,
//! and the evaluators behind it. This is the library's front door:
//! [`Surface::compile`] turns source text into a `Surface`, whose methods
//! evaluate the function at points and over boxes.

use crate::error::Error;
use crate::eval;
use crate::interval::{DecInterval, Interval};
use crate::ir::Program;
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
#[derive(Clone, Debug)]
pub struct Surface {
    /// The file name diagnostics were reported against.
    pub file: String,
    /// The simplified SSA program of the function.
    pub program: Program,
    /// The domain Ω.
    pub domain: Bounds,
    /// The values of every `param`, after `--set` overrides.
    pub params: Vec<(String, f64)>,
}

impl Surface {
    /// Compiles source text. `file` names the source in diagnostics.
    pub fn compile(source: &str, file: &str, opts: &CompileOptions) -> Result<Surface, Error> {
        let lowered = syntax::front_end(source, file, opts)?;
        Ok(Surface {
            file: file.to_string(),
            program: lowered.program,
            domain: lowered.domain,
            params: lowered.params,
        })
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

    /// f at `[x, y, z, t]`.
    pub fn point(&self, p: [f64; 4]) -> f64 {
        eval::point::eval(&self.program, p)
    }

    /// f and ∇f at `[x, y, z, t]`.
    pub fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        eval::grad::eval_point(&self.program, p)
    }

    /// Enclosure of f over a box `[x, y, z, t]`.
    pub fn interval(&self, b: [Interval; 4]) -> DecInterval {
        eval::interval::eval(&self.program, b)
    }

    /// Enclosure of f and ∇f over a box `[x, y, z, t]`.
    pub fn grad(&self, b: [Interval; 4]) -> eval::grad::GradEval {
        eval::grad::eval(&self.program, b)
    }
}
