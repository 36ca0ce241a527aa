//! The adaptive octree over the domain Ω (Paiva et al. §4.1–4.2).
//!
//! # Contract
//!
//! The root is Ω itself; a node at level `l` with integer position
//! `ijk ∈ [0, 2^l)³` is the box `lo + size·ijk/2^l … lo + size·(ijk+1)/2^l`,
//! computed by [`Octree::cell_box`] with one formula everywhere, so that
//! neighbouring cells share their computed faces bit for bit and the leaves
//! tile Ω without gaps. Every node is classified from one interval-gradient
//! evaluation over its box ([`criteria`]), and, where that fails the
//! topology or geometry test, from evaluations over 8 and then 64 pieces
//! of the box (tighter enclosures of the same gradient):
//!
//! - a node is **discarded** (an [`Leaf::Empty`] leaf) only when the interval
//!   proves that `F` has no zero in it — a cell is never dropped on a guess;
//! - otherwise it is subdivided while its level is below `min_level`, or
//!   while it fails the topology or the geometry criterion and its level is
//!   below `max_level`;
//! - a leaf that stops at `max_level` still failing the topology criterion
//!   (for a cell on ∂Ω, also the sheet's trace on the faces and edges of Ω
//!   it may reach: [`criteria::boundary_holds`]),
//!   or on which `F` is not defined and continuous everywhere (SPEC §1), is
//!   [`Leaf::Ambiguous`]; the other surface leaves are [`Leaf::Surface`].
//!
//! # Layout
//!
//! Nodes live in one `Vec<Node>`, root first; a node is a [`Kind::Branch`]
//! or a [`Kind::Leaf`]. The 8 children of a branch are consecutive, child
//! [`Octant`] `o` (bit `k`: the high half along axis `k`) at
//! `first_child + o`. The tree is built breadth-first, one level at a time
//! (`Builder`: judge a level, grow the next, then the proof search); each
//! level's cells are evaluated in parallel (`rayon`).
//!
//! # Evaluation
//!
//! Any [`Evaluator`] will do. Cells are examined in chunks of `BATCH`:
//! one [`Evaluator::interval_batch`] over the cells (a cell whose value
//! enclosure excludes 0, `F` defined, is empty: nothing more is asked),
//! one [`Evaluator::grad_batch`] over the others, and one
//! [`Evaluator::interval_batch`] at the centres of the cells whose gradient
//! flag held (the mean-value form, valid only there). Then `review`: a
//! point-gradient batch at the corners of the cells the chord criterion
//! may stop (above the last level, with a chord tolerance), and
//! [`Evaluator::grad_batch`] over the pieces of the cells that failed the
//! topology or geometry test on a differentiable `F` and would otherwise
//! stop. At the last level a cell across a `min`/`max` crease that failed
//! the topology test gets one more interval-gradient evaluation, along the
//! sign pattern of its gradient enclosure ([`crease`]). The proof search
//! below ambiguous leaves
//! ([`Octree::clear_false_ambiguity`]) is recursive, one cell per call;
//! the ambiguous leaves run in parallel.
//!
//! # Pruning
//!
//! When the evaluator exposes its program ([`Evaluator::program`]) and the
//! program has `min`/`max`/`and`/`or` choices ([`prune::has_choices`]), and
//! [`OctreeOptions::prune`] is on, each node that is subdivided hands its
//! children the program pruned on its own box ([`prune::prune`]): the
//! branches that cannot win anywhere in the node go. A leaf keeps the
//! program it was judged with (its parent's), which the proof search and
//! [`Field`] then use. The pruned program
//! gives the same enclosures as the full one on every cell of the subtree
//! (see [`prune`]'s contract), so every verdict is the one the full program
//! would give with the same evaluator, and no guarantee changes. A node
//! keeps its parent's program unless pruning makes it a tenth shorter, and
//! the live pruned programs of a tree hold at most about `STORE_LIMIT`
//! instructions together (past it, subtrees keep their parents'), so
//! memory stays bounded whatever the model. Once a
//! pruned program is at most `1/INTERPRET_RATIO` of the full one, the
//! subtree is evaluated with the reference interpreters on it
//! ([`Reference`]) instead of the given evaluator: an interpreter is
//! several times slower per instruction than the JIT, and pays off only
//! on much shorter programs. Longer pruned programs are interpreted too
//! while an `INTERPRET_BUDGET` lasts (a compilation's worth of
//! interpretation, spent a level at a time so that the choice never
//! depends on thread timing), so that a model whose programs shrink fast
//! never compiles the JIT's kernels. (The interpreters and the JIT give sound
//! enclosures that may differ in the last bits, so verdicts may differ from
//! an unpruned run's where a bound grazes 0; both are sound.) A node whose
//! prune removed nothing skips the next level's attempt.
//!
//! Before the proof search on an ambiguous leaf, a sign change among the
//! point values at its centre, at one Newton step from the centre and at
//! its corners, with `F` defined and continuous on the leaf, or an exact
//! zero among them, shows that it holds surface (intermediate values), and
//! the search is skipped.

mod crease;
pub(crate) mod criteria;
pub mod field;
pub mod octant;

use glam::DVec3;
use rayon::prelude::*;

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::cancel::{Cancel, Cancelled, uncancelled};
use crate::eval::{Evaluator, Reference, WHOLE, WHOLE_GRAD, prune};
use crate::geometry::Bounds;
use crate::interval::{DecInterval, Interval};
use crate::ir::Program;
pub use criteria::{Chord, TopologyTest};
pub use field::Field;
pub use octant::Octant;

/// Cells to subdivide whatever the criteria say
/// ([`Octree::build_refining`]), by level and integer position.
pub type Refine = std::collections::HashSet<(u8, [u32; 3])>;

/// How a leaf ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leaf {
    /// Proved by the interval to contain no surface.
    Empty,
    /// May contain surface; the topology criterion held.
    Surface,
    /// May contain surface; the topology criterion still failed at the
    /// maximal level, or `F` is not defined everywhere on the cell.
    Ambiguous,
    /// Not explored: the cell does not touch the [`Region`] the tree was
    /// built for ([`Octree::build_region`]; bricked meshing only). Nothing
    /// is known of it.
    Outside,
}

/// A closed box of the domain in units of a [`MAX_LEVEL`] cell (each
/// coordinate in `[0, 2^MAX_LEVEL]`): the part of Ω a brick needs
/// ([`Octree::build_region`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// Lowest corner.
    pub lo: [u64; 3],
    /// Highest corner (closed).
    pub hi: [u64; 3],
}

impl Region {
    /// Whether the closed box of node `n` meets the region.
    pub fn meets(&self, n: &Node) -> bool {
        let [lo, hi] = n.grid_box();
        (0..3).all(|k| lo[k] <= self.hi[k] && hi[k] >= self.lo[k])
    }
}

/// What a node is: subdivided, or a leaf and how it ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Subdivided: its 8 children are consecutive from `first_child`, in
    /// [`Octant`] order.
    Branch {
        /// Index of the first child.
        first_child: u32,
    },
    /// A leaf. (While the tree is built, a node not judged yet is an
    /// ambiguous leaf: never discarded, never guaranteed.)
    Leaf(Leaf),
}

/// One octree node. See the module doc for the layout.
#[derive(Clone, Copy, Debug)]
pub struct Node {
    /// Subdivided or a leaf.
    pub kind: Kind,
    /// Depth in the tree: 0 for the root (Ω), `l` for a cell of side
    /// `size / 2^l`.
    pub level: u8,
    /// Integer position of the cell in the level's grid, each in `[0, 2^level)`.
    pub ijk: [u32; 3],
}

impl Node {
    /// A node not judged yet (see [`Kind::Leaf`]).
    fn open(level: u8, ijk: [u32; 3]) -> Node {
        Node {
            kind: Kind::Leaf(Leaf::Ambiguous),
            level,
            ijk,
        }
    }

    /// Whether the node has no children.
    pub fn is_leaf(&self) -> bool {
        matches!(self.kind, Kind::Leaf(_))
    }

    /// How a leaf ended; `None` for a subdivided node.
    pub fn leaf(&self) -> Option<Leaf> {
        match self.kind {
            Kind::Leaf(l) => Some(l),
            Kind::Branch { .. } => None,
        }
    }

    /// The node's closed box in units of a [`MAX_LEVEL`] cell: its low and
    /// high corners.
    pub fn grid_box(&self) -> [[u64; 3]; 2] {
        let shift = MAX_LEVEL - self.level.min(MAX_LEVEL);
        let lo = self.ijk.map(|k| u64::from(k) << shift);
        [lo, lo.map(|k| k + (1u64 << shift))]
    }

    /// Index of child `o`, if the node is subdivided.
    pub fn child(&self, o: Octant) -> Option<u32> {
        match self.kind {
            Kind::Branch { first_child } => Some(first_child + u32::from(o.0)),
            Kind::Leaf(_) => None,
        }
    }
}

/// Octree parameters (the command line's `--level`, `--min-level`,
/// `--kmax`, `--certify`).
#[derive(Clone, Copy, Debug)]
pub struct OctreeOptions {
    /// Deepest level a cell may be subdivided to (`--level`).
    pub max_level: u8,
    /// Level down to which every non-empty cell is subdivided whatever the
    /// criteria (`--min-level`).
    pub min_level: u8,
    /// Geometry criterion (Paiva et al. §4.1): subdivide while the spread of
    /// the unit normals over the cell exceeds it; 0 refines uniformly.
    pub kmax: f64,
    /// Topology criterion applied to each cell (`--certify` picks
    /// [`TopologyTest::Certify`]).
    pub test: TopologyTest,
    /// Time at which the surface is taken.
    pub t: f64,
    /// Prune the program per subtree (see the module doc's "Pruning").
    pub prune: bool,
    /// Faithful `--level` (SPEC §2): the chord tolerance on a flat piece,
    /// in sides of a maximal-level cell (the cube root of Ω's volume over
    /// `2^max_level`); where the surface is curved the tolerance adds a
    /// share of a uniform mesher's chord error there ([`Chord`],
    /// [`OctreeOptions::chord_tolerance`] in domain units). Below the
    /// maximal level, a cell that passes the other criteria is subdivided
    /// while its estimated chord error ([`criteria::chord_error`]) exceeds
    /// `OCTREE_SLACK` times the tolerance at the turn of the normals across
    /// it; the mesher then splits the edges still farther than the
    /// tolerance at theirs (`mesher::chord`). `None`: the geometry
    /// criterion `k_max` alone (the adaptive minimum, `--coarse`).
    pub chord: Option<f64>,
}

impl Default for OctreeOptions {
    fn default() -> Self {
        OctreeOptions {
            max_level: 7,
            min_level: 3,
            kmax: 1.0,
            test: TopologyTest::Paper,
            t: 0.0,
            prune: true,
            chord: Some(DEFAULT_CHORD),
        }
    }
}

impl OctreeOptions {
    /// The chord tolerance [`OctreeOptions::chord`] in domain units: its
    /// share of the side of a maximal-level cell of `domain` on a flat
    /// piece, more where the surface is curved ([`Chord`]). Where `domain`
    /// is not a cube, the side is that of a cube of a maximal-level cell's
    /// volume (the geometric mean of its sides): a uniform mesher with
    /// `2^L` cells per axis has as many cells.
    pub fn chord_tolerance(&self, domain: Bounds) -> Option<Chord> {
        let volume: f64 = (0..3).map(|k| domain.hi[k] - domain.lo[k]).product();
        let level = self.max_level.min(MAX_LEVEL);
        let cell = volume.cbrt() / (1u64 << level) as f64;
        self.chord.map(|c| Chord {
            base: c * cell,
            cell,
        })
    }
}

/// The octree's chord criterion subdivides cells whose estimated chord
/// error exceeds this many times the tolerance: the mesher's edge splits
/// ([`crate::mesher::chord`]) correct the last factor below a level.
const OCTREE_SLACK: f64 = 4.0;

/// The default chord tolerance of [`OctreeOptions::chord`] on a flat
/// piece, in sides of a maximal-level cell (calibrated against Fidget at
/// depth 8: `docs/faithful.md`).
pub const DEFAULT_CHORD: f64 = 0.035;

/// The verdicts on `cells` (all at one level, evaluated by `f`) after the
/// cell-local criteria beyond [`examine`]'s one enclosure: above the last
/// level, with a chord tolerance `tau` (already scaled by the slack), a
/// cell passes only if its estimated chord error is within it
/// ([`chord_within`]); a cell that
/// failed the topology or geometry test (at the last level: the topology
/// test) gets a second look from pieces of it ([`pieces_test`]) — above
/// the last level only if its chord error would let it be a leaf.
fn review<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    verdicts: &mut [criteria::Verdict],
    opts: &OctreeOptions,
    tau: Option<Chord>,
    last_level: bool,
) {
    // Smooth: pieces seldom prove anything across a crease.
    let second = |v: &criteria::Verdict| !v.empty && v.defined && v.smooth && !v.passed(last_level);
    let open: Vec<usize> = match tau.filter(|_| !last_level) {
        None => (0..cells.len()).filter(|&i| second(&verdicts[i])).collect(),
        Some(tau) => {
            let judged: Vec<usize> = (0..cells.len())
                .filter(|&i| verdicts[i].passed(false) || second(&verdicts[i]))
                .collect();
            let within = chord_within(f, cells, &judged, &tau, opts.t);
            // A cell within the tolerance keeps its verdict: it gets the
            // second look if it needs one.
            judged
                .into_iter()
                .zip(within)
                .filter(|&(i, ok)| {
                    verdicts[i].geometry_ok &= ok;
                    ok && second(&verdicts[i])
                })
                .map(|(i, _)| i)
                .collect()
        }
    };
    pieces_test(f, cells, verdicts, &open, opts, last_level);
}

/// Whether each of `cells[i]` for `i` in `which` has an estimated chord
/// error ([`criteria::chord_error`]) within `tau` at the turn of the
/// normals across it ([`Chord::at`]): one point-gradient batch at the
/// corners of those cells.
fn chord_within<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    which: &[usize],
    tau: &Chord,
    t: f64,
) -> Vec<bool> {
    let lo = |i: usize| DVec3::new(cells[i][0].lo, cells[i][1].lo, cells[i][2].lo);
    let hi = |i: usize| DVec3::new(cells[i][0].hi, cells[i][1].hi, cells[i][2].hi);
    let corners: Vec<[f64; 3]> = which
        .iter()
        .flat_map(|&i| Octant::ALL.map(|o| o.pick(lo(i), hi(i)).to_array()))
        .collect();
    let mut at = vec![(0.0, [0.0; 3]); corners.len()];
    f.point_grad_batch(&corners, t, &mut at);
    which
        .iter()
        .zip(at.chunks_exact(8))
        .map(|(&i, at)| {
            let grads: [[f64; 3]; 8] = std::array::from_fn(|c| at[c].1);
            // On a box, the side of a cube of its volume, as the
            // tolerance's cell ([`OctreeOptions::chord_tolerance`]).
            let side = (hi(i) - lo(i)).element_product().cbrt();
            criteria::chord_within(side, &grads, tau)
        })
        .collect()
}

/// The sides of Ω a node's cell lies on, per axis: on the low face, on
/// the high face (from its integer position, so exactly the cells whose
/// computed box reaches ∂Ω).
fn sides(node: &Node) -> [(bool, bool); 3] {
    let last = (1u32 << node.level) - 1;
    node.ijk.map(|i| (i == 0, i == last))
}

/// The topology test on ∂Ω ([`criteria::boundary_holds`]) on the cells
/// whose verdict passed the 3D test and that lie on faces of Ω (`sides`,
/// per cell): failed there, the cell's topology (and geometry) test
/// fails. Whether the sheet may reach a face or an edge of the cell on
/// ∂Ω is read, where the gradient alone does not certify it, from `f`'s
/// enclosure over that piece.
fn boundary_look<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    sides: &[[(bool, bool); 3]],
    verdicts: &mut [criteria::Verdict],
) {
    for ((cell, sides), v) in cells.iter().zip(sides).zip(verdicts.iter_mut()) {
        let faces = sides.map(|(lo, hi)| lo || hi);
        if !v.topology_ok || !faces.contains(&true) {
            continue;
        }
        let crosses = |k: usize, edge: bool| reaches(f, cell, sides, k, edge);
        if !criteria::boundary_holds(v.grad, faces, crosses) {
            v.topology_ok = false;
            v.geometry_ok = false;
        }
    }
}

/// Whether `f`'s enclosure may vanish on the piece of ∂Ω `cell` lies on
/// (`sides`): the face across axis `k`, or with `edge` the edge along
/// axis `k` (both other axes on faces) — on each of its sides where the
/// cell lies on two (a level-0 cell).
fn reaches<E: Evaluator + ?Sized>(
    f: &E,
    cell: &[Interval; 4],
    sides: &[(bool, bool); 3],
    k: usize,
    edge: bool,
) -> bool {
    let pinned: Vec<usize> = (0..3)
        .filter(|&j| if edge { j != k } else { j == k })
        .collect();
    let mut boxes = vec![*cell];
    for &j in &pinned {
        let ends: Vec<f64> = [(sides[j].0, cell[j].lo), (sides[j].1, cell[j].hi)]
            .into_iter()
            .filter_map(|(on, x)| on.then_some(x))
            .collect();
        boxes = boxes
            .iter()
            .flat_map(|b| {
                ends.iter().map(move |&x| {
                    let mut b = *b;
                    b[j] = Interval { lo: x, hi: x };
                    b
                })
            })
            .collect();
    }
    let mut out = vec![DecInterval::new(Interval::ENTIRE, false); boxes.len()];
    f.interval_batch(&boxes, &mut out);
    out.iter().any(|d| !(d.defined && d.iv.excludes_zero()))
}

/// Gives the cells `cells[i]` for `i` in `open` (evaluated by `f`) a second
/// look from their `n³` pieces for `n` in [`PIECES`]
/// ([`criteria::judge_by_pieces`]): one interval-gradient batch over the
/// pieces of the cells still failing, per `n`. A cell that passes is a
/// leaf where it would otherwise be subdivided (and at the last level,
/// guaranteed where it would be ambiguous).
fn pieces_test<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    verdicts: &mut [criteria::Verdict],
    open: &[usize],
    opts: &OctreeOptions,
    last_level: bool,
) {
    let mut open = open.to_vec();
    for n in PIECES {
        open.retain(|&i| !verdicts[i].passed(last_level));
        if open.is_empty() {
            return;
        }
        let mut pieces = Vec::with_capacity(open.len() * n * n * n);
        for &i in &open {
            push_pieces(&cells[i], n, &mut pieces);
        }
        let mut grads = vec![WHOLE_GRAD; pieces.len()];
        f.grad_batch(&pieces, &mut grads);
        for (&i, of_cell) in open.iter().zip(grads.chunks_exact(n * n * n)) {
            verdicts[i] = criteria::judge_by_pieces(verdicts[i], of_cell, opts.test, opts.kmax);
        }
    }
}

/// The pieces per axis of [`pieces_test`]'s successive looks.
const PIECES: [usize; 2] = [2, 4];

/// Appends to `out` the `n³` boxes of a cell cut in `n` along each axis,
/// which cover it.
fn push_pieces(cell: &[Interval; 4], n: usize, out: &mut Vec<[Interval; 4]>) {
    // The cuts along each axis: the cell's own bounds at both ends.
    let cuts = |k: usize| {
        let (a, b) = (cell[k].lo, cell[k].hi);
        move |j: usize| match j {
            0 => a,
            j if j == n => b,
            j => a + (b - a) * (j as f64 / n as f64),
        }
    };
    let (x, y, z) = (cuts(0), cuts(1), cuts(2));
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let lo = DVec3::new(x(i), y(j), z(k));
                let hi = DVec3::new(x(i + 1), y(j + 1), z(k + 1));
                out.push(cell_input(lo, hi, cell[3].lo));
            }
        }
    }
}

/// Counts gathered while building.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct OctreeStats {
    /// Number of octree nodes built, leaves included.
    pub nodes: usize,
    /// Leaves proved to hold no surface ([`Leaf::Empty`]).
    pub empty_leaves: usize,
    /// Leaves that may hold surface and passed the topology criterion
    /// ([`Leaf::Surface`]).
    pub surface_leaves: usize,
    /// Leaves whose topology is not guaranteed ([`Leaf::Ambiguous`]).
    pub ambiguous_leaves: usize,
    /// Deepest level of a leaf that may hold surface.
    pub max_level_reached: u8,
}

/// The adaptive octree. See the module doc.
#[derive(Clone)]
pub struct Octree {
    /// All nodes, root first, siblings consecutive (see the module doc's
    /// "Layout").
    pub nodes: Vec<Node>,
    /// Lowest corner of the domain Ω (the root's box).
    pub lo: DVec3,
    /// Extent of Ω along each axis (`hi - lo`).
    pub size: DVec3,
    /// Counts gathered while building.
    pub stats: OctreeStats,
    /// Per node, the pruned program that is valid on a leaf's box, when
    /// the leaf's subtree was evaluated with one (see the module doc's
    /// "Pruning"); `None`, or past the end of the vector, elsewhere. Empty
    /// without pruning. [`Octree::field`] evaluates with them.
    pub tapes: Vec<Option<Arc<Reference>>>,
}

/// Deepest level allowed: integer positions must fit in `u32` with room.
pub const MAX_LEVEL: u8 = 20;

/// Extra levels below an ambiguous leaf searched for a proof that it is
/// empty (see [`Octree::clear_false_ambiguity`]).
pub(crate) const PROOF_DEPTH: u8 = 3;

fn cell_input(a: DVec3, b: DVec3, t: f64) -> [Interval; 4] {
    [
        Interval { lo: a.x, hi: b.x },
        Interval { lo: a.y, hi: b.y },
        Interval { lo: a.z, hi: b.z },
        Interval { lo: t, hi: t },
    ]
}

/// The criteria's verdicts on cells, from three batch calls: the value
/// kernel over the cells (a cell it proves empty needs nothing more), the
/// interval-gradient kernel over the others, and the value kernel at the
/// centres of those whose gradient flag held (the mean-value form). With
/// `value_first` false, [`examine_gradient_first`]: the cheaper order when
/// the gradient kernel is not much dearer than the value kernel (the JIT's,
/// against the interpreters' five times).
fn examine<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    opts: &OctreeOptions,
    value_first: bool,
) -> Vec<criteria::Verdict> {
    if !value_first {
        return examine_gradient_first(f, cells, opts);
    }
    let mut values = vec![WHOLE; cells.len()];
    f.interval_batch(cells, &mut values);
    let excluded = |v: &crate::interval::DecInterval| v.defined && v.iv.excludes_zero();
    let open: Vec<[Interval; 4]> = cells
        .iter()
        .zip(&values)
        .filter(|(_, v)| !excluded(v))
        .map(|(c, _)| *c)
        .collect();
    let mut grads = vec![WHOLE_GRAD; open.len()];
    f.grad_batch(&open, &mut grads);
    let centres: Vec<[Interval; 4]> = open
        .iter()
        .zip(&grads)
        .filter(|(_, g)| g.defined)
        .map(|(c, _)| centre(c))
        .collect();
    let mut at_centres = vec![WHOLE; centres.len()];
    f.interval_batch(&centres, &mut at_centres);
    let mut grads = grads.into_iter();
    let mut at_centres = centres.iter().zip(at_centres);
    cells
        .iter()
        .zip(&values)
        .map(|(cell, v)| {
            if excluded(v) {
                return criteria::Verdict {
                    empty: true,
                    topology_ok: false,
                    geometry_ok: false,
                    defined: true,
                    smooth: true,
                    grad: [Interval::ENTIRE; 3],
                    sheet: false,
                };
            }
            let g = grads.next().expect("one gradient per open cell");
            let mean_value = mean_value_next(&g, cell, &mut at_centres);
            let value_defined = g.defined || v.defined;
            criteria::judge(&g, value_defined, mean_value, opts.test, opts.kmax)
        })
        .collect()
}

/// [`examine`] from the interval-gradient kernel over all cells (its value
/// enclosure decides emptiness), the value kernel at the centres of the
/// cells whose gradient flag held, and the value kernel over those whose
/// flag dropped (is `F` itself defined there?).
fn examine_gradient_first<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    opts: &OctreeOptions,
) -> Vec<criteria::Verdict> {
    let mut grads = vec![WHOLE_GRAD; cells.len()];
    f.grad_batch(cells, &mut grads);
    let (mut centres, mut undiff) = (Vec::new(), Vec::new());
    for (cell, g) in cells.iter().zip(&grads) {
        if g.defined {
            centres.push(centre(cell));
        } else {
            undiff.push(*cell);
        }
    }
    let mut at_centres = vec![WHOLE; centres.len()];
    f.interval_batch(&centres, &mut at_centres);
    let mut on_undiff = vec![WHOLE; undiff.len()];
    f.interval_batch(&undiff, &mut on_undiff);
    let mut at_centres = centres.iter().zip(at_centres);
    let mut on_undiff = on_undiff.into_iter();
    cells
        .iter()
        .zip(grads)
        .map(|(cell, g)| {
            let value_defined = g.defined
                || on_undiff
                    .next()
                    .expect("one value per cell whose gradient flag dropped")
                    .defined;
            let mean_value = mean_value_next(&g, cell, &mut at_centres);
            criteria::judge(&g, value_defined, mean_value, opts.test, opts.kmax)
        })
        .collect()
}

/// The centre of a cell, as a degenerate box.
fn centre(cell: &[Interval; 4]) -> [Interval; 4] {
    let mut c = *cell;
    for side in c.iter_mut().take(3) {
        let m = 0.5 * (side.lo + side.hi);
        *side = Interval { lo: m, hi: m };
    }
    c
}

/// The mean-value form over `cell` when its gradient flag held (the next
/// centre value of `centres` is then its own), else `None`.
fn mean_value_next<'a>(
    g: &crate::eval::GradEval,
    cell: &[Interval; 4],
    centres: &mut impl Iterator<Item = (&'a [Interval; 4], crate::interval::DecInterval)>,
) -> Option<Interval> {
    if !g.defined {
        return None;
    }
    let (centre, fc) = centres
        .next()
        .expect("one centre per cell with a defined gradient");
    let c = [0, 1, 2].map(|k| centre[k].lo);
    Some(criteria::mean_value_form(
        fc.iv,
        g.grad,
        [cell[0], cell[1], cell[2]],
        c,
    ))
}

/// Cells per batch call.
const BATCH: usize = 128;

/// A pruned program is run by the reference interpreters once it has at
/// most `1/INTERPRET_RATIO` of the full program's instructions (the JIT is
/// roughly this many times faster per instruction; see `docs/jit.md`).
const INTERPRET_RATIO: usize = 8;

/// With pruning, cells whose program is still long are interpreted too,
/// until the interpreters have run the equivalent of this many full
/// programs: compiling the JIT's value and gradient kernels (on first use,
/// ≈ 40 µs an instruction) costs about as much as interpreting both
/// (≈ 55 ns an instruction) this many times, so a model whose programs
/// shrink fast never compiles them.
const INTERPRET_BUDGET: u64 = 512;

/// Most instructions the live pruned programs of one octree may hold
/// together (about 40 bytes each; counted anew after each level: the
/// leaves' and the frontier's): past it, subtrees keep their parent's
/// program.
const STORE_LIMIT: u64 = 1 << 23;

/// The program a subtree's cells are evaluated with.
#[derive(Clone)]
struct Tape {
    /// The program pruned on the subtree's root box; `None` without
    /// pruning.
    program: Option<Arc<Reference>>,
    /// Evaluate with `program` (the interpreters) rather than the given
    /// evaluator.
    interpret: bool,
    /// The last prune removed nothing: skip one attempt.
    skip: bool,
}

impl Tape {
    fn same(&self, other: &Tape) -> bool {
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
    fn with<E: Evaluator + ?Sized, R>(
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
    fn long_cost(&self) -> u64 {
        match &self.program {
            Some(r) if !self.interpret => r.0.insts.len() as u64,
            _ => 0,
        }
    }

    /// The tape for the children of a node with box `cell`
    /// that this tape evaluated. `full_len` is the full program's length.
    fn child(&self, cell: [Interval; 4], full_len: usize, store: &AtomicU64) -> Tape {
        let Some(current) = &self.program else {
            return self.clone();
        };
        let interpret = |len: usize| len * INTERPRET_RATIO <= full_len;
        let stored = store.load(Ordering::Relaxed);
        if self.skip || stored >= STORE_LIMIT || !prune::has_choices(&current.0) {
            return Tape {
                skip: false,
                interpret: interpret(current.0.insts.len()),
                program: self.program.clone(),
            };
        }
        let pruned: Program = prune::prune(&current.0, cell);
        // A new program only when it is a tenth shorter: the programs along
        // a path from the root shrink geometrically, and the memory they
        // hold stays within `STORE_LIMIT` instructions.
        if 10 * pruned.insts.len() > 9 * current.0.insts.len() {
            return Tape {
                // Nothing at all came off: the next level is unlikely to
                // do better, skip its attempt.
                skip: pruned.insts.len() >= current.0.insts.len(),
                interpret: interpret(current.0.insts.len()),
                program: self.program.clone(),
            };
        }
        store.fetch_add(pruned.insts.len() as u64, Ordering::Relaxed);
        Tape {
            interpret: interpret(pruned.insts.len()),
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
struct Budget {
    left: u64,
    open: bool,
}

impl Budget {
    /// Whether the long programs of a stage costing `cost` instructions are
    /// interpreted.
    fn spend(&mut self, cost: u64) -> bool {
        if self.open && cost <= self.left {
            self.left -= cost;
        } else if cost > 0 {
            self.open = false;
        }
        self.open
    }
}

/// Points per axis of the grid [`straddles`] samples.
const STRADDLE_GRID: u32 = 2;

/// Whether point values over `[a, b]` show that the box holds surface, so
/// that no proof of emptiness can succeed: values of both strict signs,
/// with `F` defined and continuous on the box (so it vanishes in between),
/// or a value that is exactly 0 (a zero up to rounding, whatever the
/// continuity). The points: the centre and one Newton step from it along
/// the gradient, which lands on a surface the box's corners do not see (a
/// sheet that touches 0 without crossing, as `−|u|` does where two solids
/// meet face to face), then a `STRADDLE_GRID³` grid (2: the corners; a
/// finer grid found barely more on colonnade).
fn straddles<E: Evaluator + ?Sized>(f: &E, a: DVec3, b: DVec3, t: f64) -> bool {
    let (mut neg, mut pos, mut zero) = (false, false, false);
    let mut sees = |v: f64| {
        neg |= v < 0.0;
        pos |= v > 0.0;
        zero |= v == 0.0;
        zero || (neg && pos)
    };
    // The Newton step first: it alone sees the touching sheets, which are
    // most of the doomed searches (the answer does not depend on the
    // order, only the work).
    let c = (a + b) * 0.5;
    let (v, g) = f.point_grad([c.x, c.y, c.z, t]);
    let g = DVec3::from_array(g);
    let q = c - g * (v / g.length_squared());
    let mut seen = sees(v)
        || (q.is_finite()
            && q.cmpge(a).all()
            && q.cmple(b).all()
            && sees(f.point([q.x, q.y, q.z, t])));
    let n = STRADDLE_GRID - 1;
    let at = |k: u32, lo: f64, hi: f64| lo + (hi - lo) * (f64::from(k) / f64::from(n));
    'grid: for i in 0..=n {
        for j in 0..=n {
            for k in 0..=n {
                if seen {
                    break 'grid;
                }
                seen = sees(f.point([at(i, a.x, b.x), at(j, a.y, b.y), at(k, a.z, b.z), t]));
            }
        }
    }
    seen && (zero || f.interval(cell_input(a, b, t)).defined)
}

/// Whether interval arithmetic proves the cell free of surface: `F`
/// defined on it and `0 ∉ F(B)` by the natural extension (one interval
/// evaluation), or, failing that, by the mean-value form or the gradient
/// kernel's own value enclosure ([`examine`]'s test). The cheap interval
/// kernel first, the gradient kernel only where it is needed.
fn empty<E: Evaluator + ?Sized>(
    f: &E,
    cell: [Interval; 4],
    opts: &OctreeOptions,
    with_gradient: bool,
) -> bool {
    let r = f.interval(cell);
    if !r.defined {
        return false;
    }
    if r.iv.excludes_zero() {
        return true;
    }
    with_gradient && examine(f, &[cell], opts, false)[0].empty
}

/// Whether the box `[a, b]` is proved free of surface, splitting it up to
/// `depth` more times.
fn proves_empty<E: Evaluator + ?Sized>(
    f: &E,
    a: DVec3,
    b: DVec3,
    opts: &OctreeOptions,
    depth: u8,
) -> bool {
    // The leaf itself (`depth == PROOF_DEPTH`) was examined when the tree
    // was built. Above the last level of the search only the natural
    // interval is tried (cheap); the gradient kernel's tests (mean-value
    // form) on the smallest boxes, where they are sharpest.
    if depth < PROOF_DEPTH && empty(f, cell_input(a, b, opts.t), opts, depth == 0) {
        return true;
    }
    if depth == 0 {
        return false;
    }
    let m = (a + b) * 0.5;
    let child = |o: Octant| o.sub_box(a, m, b);
    // Every child must be proved empty; the one whose centre value is
    // nearest 0 is the likeliest to fail, so it goes first (the answer
    // does not depend on the order, only the work).
    let mut order: Vec<(f64, Octant)> = Octant::ALL
        .into_iter()
        .map(|c| {
            let (lo, hi) = child(c);
            let p = (lo + hi) * 0.5;
            let v = f.point([p.x, p.y, p.z, opts.t]).abs();
            (if v.is_nan() { 0.0 } else { v }, c)
        })
        .collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0));
    order.iter().all(|&(_, c)| {
        let (lo, hi) = child(c);
        proves_empty(f, lo, hi, opts, depth - 1)
    })
}

/// One [`Octree::build_refining`] in progress: the tree so far, and what
/// the evaluation carries from one level to the next (the interpretation
/// budget, the pruned programs' store, the ambiguous leaves for the proof
/// search).
struct Builder<'a, E: ?Sized> {
    f: &'a E,
    opts: &'a OctreeOptions,
    /// Cells subdivided whatever the criteria (none for a bricked run).
    refine: Option<&'a Refine>,
    tree: Octree,
    max_level: u8,
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
            size: DVec3::from_array(domain.hi) - DVec3::from_array(domain.lo),
            stats: OctreeStats::default(),
            tapes: Vec::new(),
        };
        let full = f.program().filter(|p| opts.prune && prune::has_choices(p));
        let full_len = full.map_or(0, |p| p.insts.len());
        let root = Tape {
            program: full.map(|p| Arc::new(Reference(p.clone()))),
            interpret: false,
            skip: false,
        };
        let tau = opts.chord_tolerance(domain).map(|c| c.times(OCTREE_SLACK));
        let b = Builder {
            f,
            opts,
            refine,
            tree,
            max_level,
            min_level: opts.min_level.min(max_level),
            full_len,
            budget: Budget {
                left: INTERPRET_BUDGET * full_len as u64,
                open: true,
            },
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
            max_level: self.max_level,
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
        if forced && level < self.max_level {
            None
        } else if v.empty {
            Some(Leaf::Empty)
        } else if level < self.min_level {
            None
        } else if level == self.max_level {
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
            let verdicts = tape.with(self.f, long, |e, interpreted| {
                let mut v = examine(e, &cells[start..end], opts, interpreted);
                if level >= self.min_level {
                    let last = level == self.max_level;
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
                        let next_is_last = level + 1 == self.max_level;
                        crease::planar_look(
                            program,
                            &cells[start..end],
                            &mut v,
                            opts,
                            on,
                            next_is_last,
                        );
                    }
                }
                v
            });
            for (k, v) in verdicts.iter().enumerate() {
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
                    None => tape.child(cells[start + k], self.full_len, &self.store),
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
    fn finish(mut self) -> Octree {
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
        self.tree.count();
        self.tree
    }
}

/// A build in progress: the builder, the frontier of `level`, and the
/// frontier's verdicts once judged (applied by the next step).
struct Run<'a, E: ?Sized> {
    b: Builder<'a, E>,
    frontier: Vec<(u32, Tape)>,
    level: u8,
    judged: Option<Vec<(Option<Leaf>, Tape)>>,
    evaluated: usize,
}

impl<'a, E: Evaluator + ?Sized> Run<'a, E> {
    fn new(f: &'a E, domain: Bounds, opts: &'a OctreeOptions, refine: Option<&'a Refine>) -> Self {
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
    /// them on).
    fn advance(
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
            if self.frontier.is_empty() || self.level > self.b.max_level {
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
    fn fork(&self, region: Region) -> Self {
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
pub struct SharedLevels<'a, E: ?Sized>(Run<'a, E>);

impl<'a, E: ?Sized> SharedLevels<'a, E> {
    /// The function the levels were built for.
    pub fn evaluator(&self) -> &'a E {
        self.0.b.f
    }
}

impl Octree {
    /// The leaf whose closed box holds `p` (descent by the splitting
    /// planes of [`Octree::cell_box`]), if `p` is in the domain.
    pub fn leaf_containing(&self, p: DVec3) -> Option<usize> {
        let (a, b) = self.cell_box(self.nodes.first()?);
        if !(p.cmpge(a).all() && p.cmple(b).all()) {
            return None;
        }
        let mut i = 0usize;
        while let Kind::Branch { first_child } = self.nodes[i].kind {
            let (_, split) = self.cell_box(&self.nodes[first_child as usize]);
            i = first_child as usize + usize::from(Octant::containing(p, split).0);
        }
        Some(i)
    }

    /// The box of a node, by the one formula shared by all nodes.
    pub fn cell_box(&self, n: &Node) -> (DVec3, DVec3) {
        let scale = (1u64 << n.level) as f64;
        let at = |k: [u32; 3]| {
            let f = DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64) / scale;
            self.lo + self.size * f
        };
        (at(n.ijk), at(n.ijk.map(|k| k + 1)))
    }

    /// The centre of a node's box.
    pub fn center(&self, n: &Node) -> DVec3 {
        let (a, b) = self.cell_box(n);
        (a + b) * 0.5
    }

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
        Octree::build_in(f, domain, opts, refine, progress, cancel)
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

    fn build_in<E: Evaluator + ?Sized>(
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

    /// An ambiguous leaf at the maximal level may be ambiguous only because
    /// interval enclosures are loose on it: it may hold no surface at all.
    /// Each one is split further (up to [`PROOF_DEPTH`] levels, for the
    /// proof only: the octree keeps its leaf) and becomes [`Leaf::Empty`]
    /// when every piece is proved empty. Nothing else is relaxed.
    fn clear_false_ambiguity<E: Evaluator + ?Sized>(
        &mut self,
        f: &E,
        opts: &OctreeOptions,
        ambiguous: &[(u32, Tape)],
        long: bool,
    ) {
        let proved: Vec<bool> = ambiguous
            .par_iter()
            .map(|(i, tape)| {
                let (a, b) = self.cell_box(&self.nodes[*i as usize]);
                tape.with(f, long, |e, _| {
                    !straddles(e, a, b, opts.t) && proves_empty(e, a, b, opts, PROOF_DEPTH)
                })
            })
            .collect();
        for ((i, _), empty) in ambiguous.iter().zip(proved) {
            if empty {
                self.nodes[*i as usize].kind = Kind::Leaf(Leaf::Empty);
            }
        }
    }

    fn count(&mut self) {
        let mut s = OctreeStats {
            nodes: self.nodes.len(),
            ..OctreeStats::default()
        };
        for n in &self.nodes {
            match n.leaf() {
                Some(Leaf::Empty) => s.empty_leaves += 1,
                Some(Leaf::Surface) => s.surface_leaves += 1,
                Some(Leaf::Ambiguous) => s.ambiguous_leaves += 1,
                Some(Leaf::Outside) | None => continue,
            }
            if n.leaf() != Some(Leaf::Empty) {
                s.max_level_reached = s.max_level_reached.max(n.level);
            }
        }
        self.stats = s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Rng, surface};

    /// The chord tolerance's cell is a maximal-level cell's side on a
    /// cube, and on a box the side of a cube of that cell's volume: a box
    /// eight times as long as it is wide and deep has cells twice as
    /// large as the cube on its width, and half as large as the cube on
    /// its length. Its base is `chord` cells; `None` gives none.
    #[test]
    fn the_chord_tolerance_reads_the_cell_of_a_box_by_its_volume() {
        let opts = OctreeOptions {
            max_level: 3,
            chord: Some(0.5),
            ..OctreeOptions::default()
        };
        let cube = Bounds {
            lo: [0.0; 3],
            hi: [8.0; 3],
        };
        let long = Bounds {
            lo: [0.0; 3],
            hi: [8.0, 1.0, 1.0],
        };
        let tol = |b| opts.chord_tolerance(b).expect("on");
        assert_eq!(
            tol(cube),
            Chord {
                base: 0.5,
                cell: 1.0
            }
        );
        let c = tol(long);
        assert!((c.cell - 0.25).abs() < 1e-15, "{c:?}");
        assert!((c.base - 0.125).abs() < 1e-15, "{c:?}");
        let coarse = OctreeOptions {
            chord: None,
            ..opts
        };
        assert_eq!(coarse.chord_tolerance(long), None);
    }

    /// `f = (u + v)² + (u - v)² + 2w² - r²` with `(u, v, w) = p - c` is
    /// twice the squared distance to `c`, so its gradient vanishes only at
    /// the centre `c`; but its natural interval extension sums two terms
    /// that cancel (`2(u+v) + 2(u-v)` for `∂/∂x`), and overestimates the
    /// gradient by the cell's width (the dependency problem the pieces
    /// defeat). Random cells, some holding the centre: a cell holding it is
    /// never certified by either test, a cell certified by its own
    /// enclosure stays so, and some cells are certified only by pieces.
    #[test]
    fn pieces_certify_only_cells_without_a_critical_point() {
        let centre = [0.13, -0.21, 0.07];
        let s = surface(&format!(
            "domain [-1, 1]^3; let u = x - {}; let v = y - {}; let w = z - {};
             surface (u + v)^2 + (u - v)^2 + 2*w^2 - 0.5;",
            centre[0], centre[1], centre[2]
        ));
        let f = &s;
        let mut rng = Rng::new(21);
        for test in [TopologyTest::Paper, TopologyTest::Certify] {
            let opts = OctreeOptions {
                test,
                ..OctreeOptions::default()
            };
            let cells: Vec<[Interval; 4]> = (0..4000)
                .map(|_| {
                    let side = 0.02 + 0.5 * rng.unit();
                    let near = rng.unit() < 0.3;
                    let lo: [f64; 3] = std::array::from_fn(|k| {
                        if near {
                            centre[k] - side * rng.unit()
                        } else {
                            -1.0 + (2.0 - side) * rng.unit()
                        }
                    });
                    cell_input(DVec3::from(lo), DVec3::from(lo) + side, 0.0)
                })
                .collect();
            let own = examine(f, &cells, &opts, false);
            let mut v = own.clone();
            let open: Vec<usize> = (0..cells.len()).collect();
            pieces_test(f, &cells, &mut v, &open, &opts, true);
            let holds = |c: &[Interval; 4]| (0..3).all(|k| c[k].contains(centre[k]));
            let mut by_pieces = 0;
            for ((c, own), v) in cells.iter().zip(&own).zip(&v) {
                assert!(!(v.topology_ok && holds(c)), "{test:?}: {c:?} certified");
                assert!(!own.topology_ok || v.topology_ok, "{test:?}: {c:?} lost");
                by_pieces += usize::from(v.topology_ok && !own.topology_ok);
            }
            assert!(by_pieces >= 20, "{test:?}: only {by_pieces} cells gained");
        }
    }
}
