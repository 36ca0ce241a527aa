//! Watching for topology changes between two frames — beyond the paper,
//! whose §5 leaves them open.
//!
//! # Contract
//!
//! [`certify`] tries to *prove*, with the interval-gradient kernel taken
//! over space × the whole time interval `T = [t₀, t₁]`, that the surface
//! keeps its topology on `T`: it covers the domain Ω by octree cells `B`
//! and accepts a cell when, for all `t ∈ T`,
//!
//! - `0 ∉ F(B × T)` (no surface in `B` at any time of `T`), or
//! - `B` does not touch ∂Ω and some component of `∇ₓF(B × T)` excludes 0
//!   (no critical point of `F(·, t)` in `B`),
//!
//! (the first test on boxes where `F` is defined and continuous, the
//! second where it is also differentiable). If every
//! cell is accepted, the zero sets `Zₜ` have no critical point for any
//! `t ∈ T` and never meet ∂Ω, so the space-time surface
//! `{(x, t) : F(x, t) = 0}` is a manifold transverse to the time slices and
//! its projection to `T` is a proper submersion: by Ehresmann's theorem all
//! the `Zₜ`, `t ∈ T`, are isotopic (components and genus unchanged).
//! Cells that fail are subdivided down to `max_level`. Cells still
//! failing there make the answer [`Verdict::Local`]: the proof holds
//! everywhere but in them, so a topology change, if any, happens inside
//! them (every other cell is accepted for the whole interval), and the
//! tracker settles it with the robust mesher over a box around them. A
//! work budget spent makes the answer [`Verdict::Unproved`], with no
//! localisation.
//!
//! Any [`Evaluator`] will do; each level's cells are one
//! [`Evaluator::grad_batch`] call, and one [`Evaluator::interval_batch`]
//! over the cells whose gradient flag dropped.

use glam::DVec3;

use crate::eval::{Evaluator, WHOLE, WHOLE_GRAD};
use crate::geometry::Bounds;
use crate::interval::Interval;

/// What [`certify`] concluded.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// Topology proved unchanged over the interval.
    Proved,
    /// Proved outside these cells (at `max_level`), not inside them: the
    /// topology may change, only there.
    Local(Vec<Bounds>),
    /// No proof found within the budget (the topology may or may not
    /// change, anywhere).
    Unproved,
}

/// Counts from one [`certify`] call.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Whether the topology was proved unchanged.
    pub verdict: Verdict,
    /// Cells evaluated.
    pub cells: usize,
}

/// See the module doc. `budget` bounds the number of cells evaluated.
pub fn certify<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    t: Interval,
    max_level: u8,
    budget: usize,
) -> Report {
    let lo = DVec3::from_array(domain.lo);
    let size = DVec3::from_array(domain.hi) - lo;
    let corner = |level: u8, ijk: [u32; 3]| -> DVec3 {
        let n = (1u64 << level) as f64;
        DVec3::new(
            lo.x + size.x * ijk[0] as f64 / n,
            lo.y + size.y * ijk[1] as f64 / n,
            lo.z + size.z * ijk[2] as f64 / n,
        )
    };
    let mut level = 0u8;
    let mut cells: Vec<[u32; 3]> = vec![[0, 0, 0]];
    let mut evaluated = 0usize;
    let mut failed = Vec::new();
    while !cells.is_empty() {
        let n = 1u32 << level;
        let boxes: Vec<[Interval; 4]> = cells
            .iter()
            .map(|&ijk| {
                let a = corner(level, ijk);
                let b = corner(level, ijk.map(|i| i + 1));
                [
                    Interval { lo: a.x, hi: b.x },
                    Interval { lo: a.y, hi: b.y },
                    Interval { lo: a.z, hi: b.z },
                    t,
                ]
            })
            .collect();
        evaluated += boxes.len();
        let mut evals = vec![WHOLE_GRAD; boxes.len()];
        f.grad_batch(&boxes, &mut evals);
        // Where F is not differentiable on the whole box (e.g. `sqrt` at
        // 0), the value kernel may still prove the box empty.
        let undiff: Vec<[Interval; 4]> = boxes
            .iter()
            .zip(&evals)
            .filter(|(_, g)| !g.defined)
            .map(|(b, _)| *b)
            .collect();
        let mut values = vec![WHOLE; undiff.len()];
        f.interval_batch(&undiff, &mut values);
        let mut values = values.into_iter();
        let mut next = Vec::new();
        for (&ijk, g) in cells.iter().zip(&evals) {
            let empty = |v: Interval| v.excludes_zero();
            if g.defined && empty(g.value) {
                continue;
            }
            if !g.defined
                && values
                    .next()
                    .is_some_and(|v| v.defined && (empty(v.iv) || empty(g.value)))
            {
                continue;
            }
            let on_boundary = ijk.iter().any(|&i| i == 0 || i + 1 == n);
            let regular = g.grad.iter().any(|c| c.excludes_zero());
            if g.defined && !on_boundary && regular {
                continue;
            }
            if level >= max_level {
                failed.push(Bounds {
                    lo: corner(level, ijk).to_array(),
                    hi: corner(level, ijk.map(|i| i + 1)).to_array(),
                });
                continue;
            }
            if evaluated + 8 * (next.len() + 8) > budget {
                return Report {
                    verdict: Verdict::Unproved,
                    cells: evaluated,
                };
            }
            for c in 0..8u32 {
                next.push([
                    2 * ijk[0] + (c & 1),
                    2 * ijk[1] + ((c >> 1) & 1),
                    2 * ijk[2] + ((c >> 2) & 1),
                ]);
            }
        }
        cells = next;
        level += 1;
    }
    Report {
        verdict: if failed.is_empty() {
            Verdict::Proved
        } else {
            Verdict::Local(failed)
        },
        cells: evaluated,
    }
}
