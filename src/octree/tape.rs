//! The program a subtree is evaluated with (the module doc's "Pruning"):
//! pruned on the subtree's root box, interpreted or compiled, within a
//! store limit and an interpretation budget.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::eval::{Evaluator, Reference, prune};
use crate::interval::Interval;
use crate::ir::Program;

/// A pruned program is run by the reference interpreters once it has at
/// most `1/INTERPRET_RATIO` of the full program's instructions (the JIT is
/// roughly this many times faster per instruction; see `docs/jit.md`).
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

/// Past this many full programs' worth of instructions in the leaves'
/// long pruned programs (more than `1/INTERPRET_RATIO` of the full one),
/// the points evaluated after the build ([`super::Field`]) go to the given
/// evaluator in those leaves: compiling its point kernels once then costs
/// less than interpreting the pruned programs at every point (random CSG
/// scenes, whose leaves keep most of the program). Below it (colonnade.vm,
/// whose few long leaves sit among a thousand times as many short ones),
/// the compilation would cost more than it saves. Measured in
/// `docs/faithful.md`, session 53.
pub(super) const LONG_PAYS: usize = 500;

/// Keeps, of the leaves' pruned programs `tapes`, those that the points
/// are evaluated with after the build (see [`Octree::tapes`]): every one,
/// unless the long ones (more than `1/INTERPRET_RATIO` of the full
/// program's `full_len` instructions) hold [`LONG_PAYS`] full programs'
/// worth of instructions or more; then the short ones only, and none at
/// all (an empty vector, which [`super::Field`] passes by without looking
/// for a point's leaf) when no leaf has a short one.
///
/// A brick's tree decides on its own leaves. So where the full program
/// overflows inside a branch its pruned one dropped (the one case in which
/// their point values differ, see [`prune`]), a brick's point there may
/// differ from the whole run's.
///
/// [`Octree::tapes`]: super::Octree::tapes
pub(super) fn keep_for_points(tapes: &mut Vec<Option<Arc<Reference>>>, full_len: usize) {
    let long = |t: &Option<Arc<Reference>>| {
        t.as_ref()
            .map(|r| r.0.insts.len())
            .filter(|&len| !short(len, full_len))
    };
    let worth: usize = tapes.iter().filter_map(long).sum();
    if worth >= LONG_PAYS * full_len {
        for t in tapes.iter_mut() {
            if long(t).is_some() {
                *t = None;
            }
        }
        if tapes.iter().all(Option::is_none) {
            tapes.clear();
        }
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

    /// The points keep every pruned program until the long ones are worth
    /// [`LONG_PAYS`] full programs, and then the short ones only, or none
    /// (an empty vector) when there are none.
    #[test]
    fn long_programs_go_once_compiling_pays() {
        let program = |src: &str| Some(Arc::new(Reference(surface(src).program)));
        let full = surface(
            "domain [-1, 1]^3; surface min(min(sqrt(x^2 + y^2 + z^2) - 0.5, \
             sqrt((x - 1)^2 + y^2 + z^2) - 0.5), min(sqrt(x^2 + (y - 1)^2 + z^2) - 0.5, \
             sqrt(x^2 + y^2 + (z - 1)^2) - 0.5));",
        )
        .program
        .insts
        .len();
        let long = program("domain [-1, 1]^3; surface sqrt(x^2 + y^2 + z^2) - 0.5;");
        let short = program("domain [-1, 1]^3; surface x;");
        let len = |t: &Option<Arc<Reference>>| t.as_ref().map_or(0, |r| r.0.insts.len());
        assert!(len(&long) * INTERPRET_RATIO > full && len(&short) * INTERPRET_RATIO <= full);
        // Just below the threshold, and at it.
        let below = (LONG_PAYS * full).div_ceil(len(&long)) - 1;
        for (n, kept) in [(below, true), (below + 1, false)] {
            let mut tapes: Vec<_> = (0..n)
                .flat_map(|_| [long.clone(), short.clone(), None])
                .collect();
            keep_for_points(&mut tapes, full);
            let lens: Vec<usize> = tapes.iter().map(len).collect();
            let expect: Vec<usize> = (0..n)
                .flat_map(|_| [if kept { len(&long) } else { 0 }, len(&short), 0])
                .collect();
            assert_eq!(lens, expect, "{n} long programs");
        }
        // With no short program left, none at all.
        let mut tapes = vec![long.clone(); below + 1];
        tapes.push(None);
        keep_for_points(&mut tapes, full);
        assert!(tapes.is_empty());
    }
}
