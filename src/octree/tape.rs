//! The program a subtree is evaluated with (the module doc's "Pruning"):
//! pruned on the subtree's root box, interpreted or compiled, within a
//! store limit and an interpretation budget.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::eval::{Evaluator, Reference, prune};
use crate::interval::Interval;
use crate::ir::Program;

/// A pruned program is run by the reference interpreters once it has at
/// most `1/INTERPRET_RATIO` of the full program's instructions. The JIT's
/// batch kernels are faster than that per instruction: 20 to 34 times on
/// an interval, 11 to 45 times on an interval gradient (random CSG
/// scenes, colonnade.vm; `docs/faithful.md`, session 58). But the ratio
/// also decides what the budget below is spent on: at 16 and 32,
/// colonnade.vm's octree took 1.08 and 1.56 times as long (its budget
/// then closes), where a random CSG scene's took at best 0.84 times.
pub(super) const INTERPRET_RATIO: usize = 8;

/// With pruning, cells whose program is still long are interpreted too,
/// until the interpreters have run the equivalent of this many full
/// programs: compiling the JIT's value and gradient kernels (on first use,
/// ≈ 40 µs an instruction) costs about as much as interpreting both
/// (≈ 55 ns an instruction) this many times, so a model whose programs
/// shrink fast never compiles them.
pub(super) const INTERPRET_BUDGET: u64 = 512;

/// Most instructions the live pruned programs of one octree may hold
/// together (about 40 bytes each; counted anew after each level: the
/// leaves' and the frontier's): past it, subtrees keep their parent's
/// program.
pub(super) const STORE_LIMIT: u64 = 1 << 23;

/// After a build that gave some level's long programs to the given
/// evaluator, the points ([`keep_for_points`]) keep the leaves' programs
/// of at most `1/POINT_RATIO` of the full program's instructions. A point
/// gradient costs the reference interpreter 5.6-8.7 ns an instruction,
/// the JIT's two-point kernel 0.6-1.4 ns and its one-point kernel 0.9-3.2
/// ns (random CSG scenes, colonnade.vm, heart): 6 to 11 and 3 to 7 times
/// less; the leaf's descent comes on top. Measured in `docs/faithful.md`,
/// session 58.
pub(super) const POINT_RATIO: usize = 16;

/// Keeps, of the leaves' pruned programs `tapes`, those that the points
/// are evaluated with after the build ([`super::Field`]; see
/// [`Octree::tapes`]): every one when the interpretation budget lasted to
/// the end (`compiled` false: on this model, by the budget's own measure,
/// compiling the given evaluator's kernels does not pay, and a model
/// whose programs shrink fast then never compiles its point kernels
/// either); else, those kernels being in use, only the programs of at
/// most `1/POINT_RATIO` of the full program's `full_len` instructions,
/// and none at all (an empty vector, which the field passes by without
/// looking for a point's leaf) when no leaf has one.
///
/// A brick's tree decides on its own leaves, with the whole run's budget
/// (it closes, or not, before a brick's tree parts from the whole run's).
/// So where the full program overflows inside a branch its pruned one
/// dropped (the one case in which their point values differ, see
/// [`prune`]), a brick's point there may differ from the whole run's.
///
/// [`Octree::tapes`]: super::Octree::tapes
pub(super) fn keep_for_points(
    tapes: &mut Vec<Option<Arc<Reference>>>,
    full_len: usize,
    compiled: bool,
) {
    if !compiled {
        return;
    }
    for t in tapes.iter_mut() {
        if t.as_ref()
            .is_some_and(|r| r.0.insts.len() * POINT_RATIO > full_len)
        {
            *t = None;
        }
    }
    if tapes.iter().all(Option::is_none) {
        tapes.clear();
    }
}

/// Whether a pruned program of `len` instructions is short enough for the
/// interpreters, against the full program's `full_len`
/// ([`INTERPRET_RATIO`]).
fn short(len: usize, full_len: usize) -> bool {
    len * INTERPRET_RATIO <= full_len
}

/// The program a subtree's cells are evaluated with.
#[derive(Clone)]
pub(super) struct Tape {
    /// The program pruned on the subtree's root box; `None` without
    /// pruning.
    pub(super) program: Option<Arc<Reference>>,
    /// Evaluate with `program` (the interpreters) rather than the given
    /// evaluator.
    interpret: bool,
    /// The last prune removed nothing: skip one attempt.
    skip: bool,
}

impl Tape {
    /// The root's tape: the full program `full` when pruning applies
    /// (evaluated with the given evaluator, not interpreted).
    pub(super) fn root(full: Option<&Program>) -> Tape {
        Tape {
            program: full.map(|p| Arc::new(Reference(p.clone()))),
            interpret: false,
            skip: false,
        }
    }

    pub(super) fn same(&self, other: &Tape) -> bool {
        match (&self.program, &other.program) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b) && self.interpret == other.interpret,
            (None, None) => true,
            _ => false,
        }
    }

    /// Runs `job` with the evaluator for this tape (and whether it is the
    /// interpreters): the interpreters on a short program, or on a long
    /// one when `long` says so (decided per level, see [`Budget`]); `f`
    /// otherwise.
    pub(super) fn with<E: Evaluator + ?Sized, R>(
        &self,
        f: &E,
        long: bool,
        job: impl FnOnce(&dyn Evaluator, bool) -> R,
    ) -> R {
        match &self.program {
            Some(r) if self.interpret || long => job(r.as_ref(), true),
            // `&E` is a sized evaluator (the blanket impl), so it can be a
            // trait object whatever `E` is.
            _ => job(&f, false),
        }
    }

    /// Instructions this tape costs per cell when it is long (pruned but
    /// not short), else 0.
    pub(super) fn long_cost(&self) -> u64 {
        match &self.program {
            Some(r) if !self.interpret => r.0.insts.len() as u64,
            _ => 0,
        }
    }

    /// The tape for the children of a node with box `cell`
    /// that this tape evaluated; `own` is this tape's program pruned on
    /// `cell` when that was done already. `full_len` is the full program's
    /// length.
    pub(super) fn child(
        &self,
        cell: [Interval; 4],
        own: Option<Program>,
        full_len: usize,
        store: &AtomicU64,
    ) -> Tape {
        let Some(current) = &self.program else {
            return self.clone();
        };
        let stored = store.load(Ordering::Relaxed);
        if self.skip || stored >= STORE_LIMIT || !prune::has_choices(&current.0) {
            return Tape {
                skip: false,
                interpret: short(current.0.insts.len(), full_len),
                program: self.program.clone(),
            };
        }
        let pruned: Program = own.unwrap_or_else(|| prune::prune(&current.0, cell));
        // A new program only when it is a tenth shorter: the programs along
        // a path from the root shrink geometrically, and the memory they
        // hold stays within `STORE_LIMIT` instructions.
        if 10 * pruned.insts.len() > 9 * current.0.insts.len() {
            return Tape {
                // Nothing at all came off: the next level is unlikely to
                // do better, skip its attempt.
                skip: pruned.insts.len() >= current.0.insts.len(),
                interpret: short(current.0.insts.len(), full_len),
                program: self.program.clone(),
            };
        }
        store.fetch_add(pruned.insts.len() as u64, Ordering::Relaxed);
        Tape {
            interpret: short(pruned.insts.len(), full_len),
            program: Some(Arc::new(Reference(pruned))),
            skip: false,
        }
    }
}

/// The interpretation budget for long pruned programs, spent a level at a
/// time (so the choice of evaluator never depends on thread timing): a
/// level whose long programs fit in what is left is interpreted; the first
/// that does not, and every one after it, goes to the given evaluator.
#[derive(Clone, Copy)]
pub(super) struct Budget {
    left: u64,
    pub(super) open: bool,
}

impl Budget {
    /// [`INTERPRET_BUDGET`] full programs of `full_len` instructions.
    pub(super) fn new(full_len: usize) -> Budget {
        Budget {
            left: INTERPRET_BUDGET * full_len as u64,
            open: true,
        }
    }

    /// Whether the long programs of a stage costing `cost` instructions are
    /// interpreted.
    pub(super) fn spend(&mut self, cost: u64) -> bool {
        if self.open && cost <= self.left {
            self.left -= cost;
        } else if cost > 0 {
            self.open = false;
        }
        self.open
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::surface;

    /// With the budget closed, the points keep the programs of at most
    /// `1/POINT_RATIO` of the full program's length (at the limit too),
    /// and none at all, the vector emptied, when no leaf has one; with
    /// the budget open, every program.
    #[test]
    fn points_keep_only_programs_that_beat_the_kernels() {
        let program = |src: &str| Some(Arc::new(Reference(surface(src).program)));
        let short = program("domain [-1, 1]^3; surface x - 0.5;");
        let long = program("domain [-1, 1]^3; surface sqrt(x^2 + y^2 + z^2) - 0.5;");
        let len = |t: &Option<Arc<Reference>>| t.as_ref().map_or(0, |r| r.0.insts.len());
        // The short one exactly at the limit.
        let full = POINT_RATIO * len(&short);
        assert!(len(&long) * POINT_RATIO > full);
        let tapes = vec![short.clone(), long.clone(), None, long.clone()];
        let mut open = tapes.clone();
        keep_for_points(&mut open, full, false);
        assert_eq!(
            open.iter().map(len).collect::<Vec<_>>(),
            tapes.iter().map(len).collect::<Vec<_>>()
        );
        let mut closed = tapes.clone();
        keep_for_points(&mut closed, full, true);
        assert_eq!(
            closed.iter().map(len).collect::<Vec<_>>(),
            vec![len(&short), 0, 0, 0]
        );
        let mut none = vec![long.clone(), None];
        keep_for_points(&mut none, full, true);
        assert!(none.is_empty());
    }

    /// The builds that decide [`keep_for_points`]'s `compiled`. Where a
    /// `min`'s choice is never certain (two branches that differ by
    /// `1e-12`), every cell keeps the full program, too long to interpret:
    /// the budget closes on the first levels of hundreds of cells, the
    /// kernels of the given evaluator serve the rest of the build and the
    /// points, and no tape is kept. Where the programs shrink fast (a
    /// sphere among far balls, which never win), the budget lasts and
    /// every surface leaf keeps its short program, also where it is more
    /// than `1/POINT_RATIO` of the full one.
    #[test]
    fn tapes_are_kept_for_points_while_the_budget_lasts() {
        let opts = crate::OctreeOptions {
            max_level: 6,
            ..Default::default()
        };
        let build = |src: &str| {
            let s = surface(src);
            let tree = crate::octree::Octree::build(&s, s.domain, &opts, &|_, _| {});
            (tree, s.program.insts.len())
        };
        let (tied, _) = build(
            "domain [-1, 1]^3; surface min(x^2 + y^2 + z^2 - 0.5, \
             x^2 + y^2 + z^2 - 0.5 + 1e-12);",
        );
        assert!(tied.tapes.is_empty(), "{} tapes", tied.tapes.len());
        let (shrunk, full) = build(
            "domain [-1, 1]^3; \
             fn ball(x, y, z, c) = sqrt((x - c)^2 + y^2 + z^2) - 1; \
             fn four(x, y, z, c) = min(min(ball(x, y, z, c), ball(x, y, z, c + 2)), \
                 min(ball(x, y, z, c + 4), ball(x, y, z, c + 6))); \
             surface min(x^2 + y^2 + z^2 - 0.5, \
                 min(four(x, y, z, 5), min(four(x, y, z, 13), four(x, y, z, 21))));",
        );
        let leaves = shrunk
            .nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| n.kind == crate::octree::Kind::Leaf(crate::octree::Leaf::Surface));
        let mut kept = 0;
        for (i, _) in leaves {
            let tape = shrunk.tapes.get(i).and_then(|t| t.as_ref());
            let len = tape.map_or(full, |t| t.0.insts.len());
            // Short, and longer than the closed budget's points keep.
            assert!(
                short(len, full) && len * POINT_RATIO > full,
                "leaf {i}: {len} of {full} instructions"
            );
            kept += 1;
        }
        assert!(kept > 100, "{kept} surface leaves");
    }
}
