//! Building the tree breadth-first, a level at a time: judge a level, grow
//! the next (the module doc's "Layout" and "Evaluation").

use glam::DVec3;
use rayon::prelude::*;

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use super::examine::{boundary_look, cell_input, examine, review, sides};
use super::node::{Kind, Leaf, MAX_LEVEL, Node, Region};
use super::octant::Octant;
use super::options::{OCTREE_SLACK, OctreeOptions};
use super::tape::{self, Budget, Tape};
use super::tree::{Octree, OctreeStats};
use super::{crease, criteria};
use crate::cancel::{Cancel, Cancelled, uncancelled};
use crate::eval::{Evaluator, Reference, prune};
use crate::geometry::Bounds;
use crate::interval::Interval;
use crate::octree::Chord;

/// Cells to subdivide whatever the criteria say
/// ([`Octree::build_refining`]), by level and integer position.
pub type Refine = std::collections::HashSet<(u8, [u32; 3])>;

impl Octree {
    /// Builds the octree of `f(·, opts.t)` over `domain`. `progress` is
    /// called after each level with (level, cells evaluated so far).
    pub fn build<E: Evaluator + ?Sized>(
        f: &E,
        domain: Bounds,
        opts: &OctreeOptions,
        progress: &(dyn Fn(u8, usize) + Sync),
    ) -> Octree {
        Octree::build_refining(f, domain, opts, &Refine::default(), progress)
    }

    /// [`Octree::build`], also subdividing every cell of `refine` (by its
    /// level and integer position) above the maximal level, whatever the
    /// criteria say, empty cells included (they shape the dual cells of
    /// their neighbours): the cells a caller found too coarse (e.g. for a
    /// distance tolerance). The children are judged as usual, and every
    /// guarantee stays (a subdivision never removes surface).
    pub fn build_refining<E: Evaluator + ?Sized>(
        f: &E,
        domain: Bounds,
        opts: &OctreeOptions,
        refine: &Refine,
        progress: &(dyn Fn(u8, usize) + Sync),
    ) -> Octree {
        uncancelled(|never| Octree::build_cancellable(f, domain, opts, refine, progress, never))
    }

    /// [`Octree::build_refining`] that stops with [`Cancelled`] soon after
    /// `cancel` is cancelled: the token is polled before each level, before
    /// each batch of cells and before the proof search.
    pub fn build_cancellable<E: Evaluator + ?Sized>(
        f: &E,
        domain: Bounds,
        opts: &OctreeOptions,
        refine: &Refine,
        progress: &(dyn Fn(u8, usize) + Sync),
        cancel: &Cancel,
    ) -> Result<Octree, Cancelled> {
        let mut run = Run::new(f, domain, opts, Some(refine));
        run.advance(false, progress, cancel)?;
        Ok(run.b.finish())
    }

    /// [`Octree::build_cancellable`] for one brick of a bricked run: the
    /// nodes whose closed box meets `region` are built and judged exactly
    /// as the whole tree's are; the others become [`Leaf::Outside`]
    /// leaves, unexplored. Every choice stays the whole run's: the levels
    /// whose choice of evaluator depends on all their cells (the
    /// interpretation budget of the module doc's "Pruning") are built
    /// whole, and the region is applied from the first level after which
    /// none does. So every leaf that meets the region is the whole tree's
    /// leaf, with the same fate and program, unless the pruned programs
    /// outgrow `STORE_LIMIT` (then a whole run's verdicts depend on thread
    /// timing as well).
    pub fn build_region<E: Evaluator + ?Sized>(
        f: &E,
        domain: Bounds,
        opts: &OctreeOptions,
        region: Region,
        progress: &(dyn Fn(u8, usize) + Sync),
        cancel: &Cancel,
    ) -> Result<Octree, Cancelled> {
        let shared = Octree::build_shared(f, domain, opts, progress, cancel)?;
        Octree::build_region_from(&shared, region, progress, cancel)
    }

    /// The levels that every brick of a bricked run builds whole (see
    /// [`Octree::build_region`]), built once: each brick then goes on
    /// from them ([`Octree::build_region_from`]).
    pub fn build_shared<'a, E: Evaluator + ?Sized>(
        f: &'a E,
        domain: Bounds,
        opts: &'a OctreeOptions,
        progress: &(dyn Fn(u8, usize) + Sync),
        cancel: &Cancel,
    ) -> Result<SharedLevels<'a, E>, Cancelled> {
        let mut run = Run::new(f, domain, opts, None);
        run.advance(true, progress, cancel)?;
        Ok(SharedLevels(run))
    }

    /// [`Octree::build_region`] from levels built once for every brick.
    pub fn build_region_from<E: Evaluator + ?Sized>(
        shared: &SharedLevels<'_, E>,
        region: Region,
        progress: &(dyn Fn(u8, usize) + Sync),
        cancel: &Cancel,
    ) -> Result<Octree, Cancelled> {
        let mut run = shared.0.fork(region);
        run.advance(false, progress, cancel)?;
        Ok(run.b.finish())
    }
}

/// Cells per batch call.
const BATCH: usize = 128;

/// One [`Octree::build_refining`] in progress: the tree so far, and what
/// the evaluation carries from one level to the next (the interpretation
/// budget, the pruned programs' store, the ambiguous leaves for the proof
/// search).
pub(super) struct Builder<'a, E: ?Sized> {
    f: &'a E,
    opts: &'a OctreeOptions,
    /// Cells subdivided whatever the criteria (none for a bricked run).
    refine: Option<&'a Refine>,
    tree: Octree,
    min_level: u8,
    /// The full program's length when pruning is on, else 0.
    full_len: usize,
    budget: Budget,
    /// Instructions of the live pruned programs (see `STORE_LIMIT`).
    store: AtomicU64,
    /// Of which the leaves' (kept to the end).
    leaf_live: u64,
    /// The chord tolerance ([`OctreeOptions::chord_tolerance`]) times
    /// `OCTREE_SLACK`.
    tau: Option<Chord>,
    /// Ambiguous leaves at the maximal level, with their tapes, for the
    /// proof search.
    ambiguous: Vec<(u32, Tape)>,
    /// Build only the nodes that meet this region
    /// ([`Octree::build_region`]), once `settled`.
    region: Option<Region>,
    /// No later choice of evaluator depends on cells outside the region:
    /// the interpretation budget is closed, or no cell of the last level
    /// judged had a long program (their descendants have none either).
    settled: bool,
}

impl<'a, E: Evaluator + ?Sized> Builder<'a, E> {
    /// The builder of a tree that is only its root, and the root's tape.
    fn new(
        f: &'a E,
        domain: Bounds,
        opts: &'a OctreeOptions,
        refine: Option<&'a Refine>,
    ) -> (Self, Tape) {
        let max_level = opts.max_level.min(MAX_LEVEL);
        let tree = Octree {
            nodes: vec![Node::open(0, [0; 3])],
            lo: DVec3::from_array(domain.lo),
            hi: DVec3::from_array(domain.hi),
            stats: OctreeStats::default(),
            tapes: Vec::new(),
            max_level,
        };
        let full = f.program().filter(|p| opts.prune && prune::has_choices(p));
        let full_len = full.map_or(0, |p| p.insts.len());
        let root = Tape::root(full);
        let tau = opts.chord_tolerance(domain).map(|c| c.times(OCTREE_SLACK));
        let b = Builder {
            f,
            opts,
            refine,
            tree,
            min_level: opts.min_level.min(max_level),
            full_len,
            budget: Budget::new(full_len),
            store: AtomicU64::new(0),
            leaf_live: 0,
            tau,
            ambiguous: Vec::new(),
            region: None,
            settled: false,
        };
        (b, root)
    }

    /// A copy of this build to go on with in `region` (a brick of shared
    /// levels, [`SharedLevels`]).
    fn fork(&self, region: Region) -> Self {
        Builder {
            f: self.f,
            opts: self.opts,
            refine: self.refine,
            tree: self.tree.clone(),
            min_level: self.min_level,
            full_len: self.full_len,
            budget: self.budget,
            store: AtomicU64::new(self.store.load(Ordering::Relaxed)),
            leaf_live: self.leaf_live,
            tau: self.tau,
            ambiguous: self.ambiguous.clone(),
            region: Some(region),
            settled: self.settled,
        }
    }

    /// How a cell of `level` with verdict `v` ends (`None`: subdivided);
    /// `forced` cells are subdivided below the maximal level whatever the
    /// criteria.
    fn fate(&self, v: &criteria::Verdict, forced: bool, level: u8) -> Option<Leaf> {
        if forced && level < self.tree.max_level {
            None
        } else if v.empty {
            Some(Leaf::Empty)
        } else if level < self.min_level {
            None
        } else if level == self.tree.max_level {
            Some(if v.topology_ok {
                Leaf::Surface
            } else {
                Leaf::Ambiguous
            })
        } else if v.topology_ok && v.geometry_ok {
            Some(Leaf::Surface)
        } else if v.sheet {
            Some(Leaf::Ambiguous)
        } else {
            None
        }
    }

    /// The fate of every cell of `frontier` (all at `level`), and the tape
    /// each one keeps (a leaf) or hands its children (a subdivided cell):
    /// chunks of `BATCH` cells in parallel, each run of cells with the same
    /// tape evaluated together.
    /// Once `cancel` is cancelled, the remaining chunks are skipped (the
    /// caller abandons the level).
    fn judge_level(
        &mut self,
        frontier: &[(u32, Tape)],
        level: u8,
        cancel: &Cancel,
    ) -> Vec<(Option<Leaf>, Tape)>
    where
        E: Sync,
    {
        let cost = frontier.iter().map(|(_, t)| t.long_cost()).sum();
        let long = self.budget.spend(cost);
        self.settled |= cost == 0 || !self.budget.open;
        let this = &*self;
        frontier
            .par_chunks(BATCH)
            .flat_map_iter(|chunk| {
                if cancel.is_cancelled() {
                    return Vec::new();
                }
                this.judge_chunk(chunk, level, long)
            })
            .collect()
    }

    /// [`Builder::judge_level`] on one chunk.
    fn judge_chunk(
        &self,
        chunk: &[(u32, Tape)],
        level: u8,
        long: bool,
    ) -> Vec<(Option<Leaf>, Tape)> {
        let (opts, tree) = (self.opts, &self.tree);
        let cells: Vec<[Interval; 4]> = chunk
            .iter()
            .map(|(i, _)| {
                let (a, b) = tree.cell_box(&tree.nodes[*i as usize]);
                cell_input(a, b, opts.t)
            })
            .collect();
        let sides_of: Vec<[(bool, bool); 3]> = chunk
            .iter()
            .map(|(i, _)| sides(&tree.nodes[*i as usize]))
            .collect();
        let mut out = Vec::with_capacity(chunk.len());
        let mut start = 0;
        while start < chunk.len() {
            let tape = &chunk[start].1;
            let mut end = start + 1;
            while end < chunk.len() && chunk[end].1.same(tape) {
                end += 1;
            }
            // The programs `planar_look` pruned on the cells' own boxes.
            let mut owns = vec![None; end - start];
            let verdicts = tape.with(self.f, long, |e, interpreted| {
                let mut v = examine(e, &cells[start..end], opts, interpreted);
                if level >= self.min_level {
                    let last = level == self.tree.max_level;
                    review(e, &cells[start..end], &mut v, opts, self.tau, last);
                    // Across creases at the last level, along one
                    // direction: with the pruned program when there is
                    // one, which the interpreter runs (the JIT has no
                    // kernel for it).
                    let along: &dyn Evaluator = match &tape.program {
                        Some(r) => r.as_ref(),
                        None => e,
                    };
                    crease::crease_look(along, &cells[start..end], &mut v, opts, last);
                    let on = &sides_of[start..end];
                    boundary_look(e, &cells[start..end], on, &mut v);
                    // Above the last level, cells whose own program is
                    // planar pieces (faithful `--level` only).
                    // With or without pruning alike: the full program
                    // when the tape has no pruned one.
                    let program = tape.program.as_ref().map(|r| &r.0).or_else(|| e.program());
                    if let (Some(program), Some(_), false) = (program, self.tau, last) {
                        let next_is_last = level + 1 == self.tree.max_level;
                        crease::planar_look(
                            program,
                            &cells[start..end],
                            &mut v,
                            opts,
                            on,
                            next_is_last,
                            &mut owns,
                        );
                    }
                }
                v
            });
            for ((k, v), own) in verdicts.iter().enumerate().zip(owns) {
                let node = &tree.nodes[chunk[start + k].0 as usize];
                let forced = self
                    .refine
                    .is_some_and(|r| r.contains(&(node.level, node.ijk)));
                let leaf = self.fate(v, forced, level);
                // A subdivided node hands its children the program pruned
                // on its box. A leaf keeps its own: pruning an ambiguous
                // one for the proof search and the mesher's point
                // evaluations costs more than the shorter program saves
                // (measured on colonnade: 84k prunes at the last level, 29%
                // of them shorter).
                let child = match leaf {
                    None => tape.child(cells[start + k], own, self.full_len, &self.store),
                    Some(_) => tape.clone(),
                };
                out.push((leaf, child));
            }
            start = end;
        }
        out
    }

    /// Applies the fates of `frontier`'s cells (at `level`): leaves keep
    /// their fate and tape, the others get 8 children, which are the next
    /// frontier. Counts the live pruned programs into the store.
    fn grow(
        &mut self,
        frontier: &[(u32, Tape)],
        judged: Vec<(Option<Leaf>, Tape)>,
        level: u8,
    ) -> Vec<(u32, Tape)> {
        let mut next = Vec::new();
        // The programs alive after this level: the leaves' (kept to the
        // end) and the next frontier's; the store counts them.
        let mut last: *const Reference = std::ptr::null();
        let mut counted = |tape: &Tape| match &tape.program {
            Some(r) if !std::ptr::eq(Arc::as_ptr(r), last) => {
                last = Arc::as_ptr(r);
                r.0.insts.len() as u64
            }
            _ => 0,
        };
        let mut frontier_live = 0;
        let tree = &mut self.tree;
        for ((i, _), (leaf, tape)) in frontier.iter().zip(judged) {
            let i = *i as usize;
            match leaf {
                Some(l) => {
                    tree.nodes[i].kind = Kind::Leaf(l);
                    self.leaf_live += counted(&tape);
                    if tape.program.is_some() {
                        if tree.tapes.len() <= i {
                            tree.tapes.resize(i + 1, None);
                        }
                        tree.tapes[i] = tape.program.clone();
                    }
                    if l == Leaf::Ambiguous {
                        self.ambiguous.push((i as u32, tape));
                    }
                }
                None => {
                    frontier_live += counted(&tape);
                    let first = tree.nodes.len() as u32;
                    let parent = tree.nodes[i];
                    tree.nodes[i].kind = Kind::Branch { first_child: first };
                    for o in Octant::ALL {
                        let mut child = Node::open(level + 1, o.child_ijk(parent.ijk));
                        let outside = self
                            .region
                            .filter(|_| self.settled)
                            .is_some_and(|r| !r.meets(&child));
                        if outside {
                            child.kind = Kind::Leaf(Leaf::Outside);
                        } else {
                            next.push((first + u32::from(o.0), tape.clone()));
                        }
                        tree.nodes.push(child);
                    }
                }
            }
        }
        self.store
            .store(self.leaf_live + frontier_live, Ordering::Relaxed);
        next
    }

    /// The proof search below the ambiguous leaves, then the counts.
    pub(super) fn finish(mut self) -> Octree {
        // The proof search: about ten evaluations a leaf.
        let long = self.budget.spend(
            10 * self
                .ambiguous
                .iter()
                .map(|(_, t)| t.long_cost())
                .sum::<u64>(),
        );
        // Outside the region the verdicts do not matter (the budget above
        // counted them all, as a whole run does).
        if let Some(r) = self.region {
            let nodes = &self.tree.nodes;
            self.ambiguous.retain(|(i, _)| r.meets(&nodes[*i as usize]));
        }
        self.tree
            .clear_false_ambiguity(self.f, self.opts, &self.ambiguous, long);
        tape::keep_for_points(&mut self.tree.tapes, self.full_len, !self.budget.open);
        self.tree.stats = OctreeStats::over(&self.tree.nodes);
        self.tree
    }
}

/// A build in progress: the builder, the frontier of `level`, and the
/// frontier's verdicts once judged (applied by the next step).
pub(super) struct Run<'a, E: ?Sized> {
    pub(super) b: Builder<'a, E>,
    frontier: Vec<(u32, Tape)>,
    level: u8,
    judged: Option<Vec<(Option<Leaf>, Tape)>>,
    evaluated: usize,
}

impl<'a, E: Evaluator + ?Sized> Run<'a, E> {
    pub(super) fn new(
        f: &'a E,
        domain: Bounds,
        opts: &'a OctreeOptions,
        refine: Option<&'a Refine>,
    ) -> Self {
        let (b, root) = Builder::new(f, domain, opts, refine);
        Run {
            b,
            frontier: vec![(0, root)],
            level: 0,
            judged: None,
            evaluated: 0,
        }
    }

    /// Judges and grows level after level to the end; with `pause`, stops
    /// right after judging the level that settles the choices of
    /// evaluator (its verdicts kept, not applied: the region applies from
    /// them on). Runs on a pool thread ([`crate::parallel::on_pool`]).
    pub(super) fn advance(
        &mut self,
        pause: bool,
        progress: &(dyn Fn(u8, usize) + Sync),
        cancel: &Cancel,
    ) -> Result<(), Cancelled> {
        crate::parallel::on_pool(|| self.advance_here(pause, progress, cancel))
    }

    /// [`Run::advance`] on the calling thread.
    fn advance_here(
        &mut self,
        pause: bool,
        progress: &(dyn Fn(u8, usize) + Sync),
        cancel: &Cancel,
    ) -> Result<(), Cancelled> {
        loop {
            if let Some(judged) = self.judged.take() {
                self.frontier = self.b.grow(&self.frontier, judged, self.level);
                progress(self.level, self.evaluated);
                self.level += 1;
            }
            if self.frontier.is_empty() || self.level > self.b.tree.max_level {
                return cancel.check();
            }
            cancel.check()?;
            let judged = self.b.judge_level(&self.frontier, self.level, cancel);
            cancel.check()?;
            self.evaluated += self.frontier.len();
            self.judged = Some(judged);
            if pause && self.b.settled {
                return Ok(());
            }
        }
    }

    /// A copy to go on with in `region`: the nodes built so far that do
    /// not meet it become [`Leaf::Outside`] (no dual cell of the region
    /// has them as corners; their subtrees are cut off), and so does the
    /// part of the frontier outside it.
    pub(super) fn fork(&self, region: Region) -> Self {
        let mut b = self.b.fork(region);
        for n in &mut b.tree.nodes {
            if !region.meets(n) {
                n.kind = Kind::Leaf(Leaf::Outside);
            }
        }
        let mut frontier = Vec::with_capacity(self.frontier.len());
        let mut judged = self.judged.as_ref().map(|_| Vec::new());
        for (k, (i, tape)) in self.frontier.iter().enumerate() {
            if region.meets(&b.tree.nodes[*i as usize]) {
                frontier.push((*i, tape.clone()));
                if let (Some(out), Some(all)) = (&mut judged, &self.judged) {
                    out.push(all[k].clone());
                }
            }
        }
        Run {
            b,
            frontier,
            level: self.level,
            judged,
            evaluated: self.evaluated,
        }
    }
}

/// The levels every brick of one bricked run builds alike
/// ([`Octree::build_shared`]): the whole tree down to the level that
/// settles the choices of evaluator, that level judged.
pub struct SharedLevels<'a, E: ?Sized>(pub(super) Run<'a, E>);

impl<'a, E: ?Sized> SharedLevels<'a, E> {
    /// The function the levels were built for.
    pub fn evaluator(&self) -> &'a E {
        self.0.b.f
    }

    /// The deepest level a leaf may have ([`Octree::max_level`]).
    pub fn max_level(&self) -> u8 {
        self.0.b.tree.max_level
    }
}
