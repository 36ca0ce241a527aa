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
//! One idea a file, each depending only on those before it: what a node
//! is (`node`), the parameters (`options`), the built tree and its boxes
//! (`tree`), the evaluations and reviews that judge a level's cells
//! (`examine`, with the tests themselves in [`criteria`] and [`crease`]),
//! the programs pruned per subtree (`tape`), the proof search below
//! ambiguous leaves (`proof`) and the build a level at a time (`build`);
//! [`Field`] evaluates a built tree's surface.
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
//! ([`Octree::clear_false_ambiguity`]) is recursive, each split's 8
//! pieces one [`Evaluator::interval_batch`] (and the gradient tests on
//! the open pieces of its last level one batch); the ambiguous leaves
//! run in parallel.
//!
//! # Pruning
//!
//! When the evaluator exposes its program ([`Evaluator::program`]) and the
//! program has `min`/`max`/`and`/`or` choices ([`prune::has_choices`](crate::eval::prune::has_choices)), and
//! [`OctreeOptions::prune`] is on, each node that is subdivided hands its
//! children the program pruned on its own box ([`prune::prune`](crate::eval::prune::prune)): the
//! branches that cannot win anywhere in the node go. A leaf keeps the
//! program it was judged with (its parent's), which the proof search and
//! [`Field`] then use. The pruned program
//! gives the same enclosures as the full one on every cell of the subtree
//! (see [`prune`](crate::eval::prune)'s contract), so every verdict is
//! the one the full program would give with the same evaluator, and no
//! guarantee changes. A node keeps its parent's program unless pruning makes it a tenth shorter, and
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
//! prune removed nothing skips the next level's attempt. After the build,
//! the points in a leaf ([`Field`]) are evaluated with its program while
//! the budget lasted to the end: a model whose programs shrink fast then
//! never compiles the given evaluator's point kernels either. Once a
//! level's long programs went to the given evaluator, its kernels serve
//! the points too, but in the leaves whose programs are at most
//! `1/POINT_RATIO` of the full one: a point gradient costs the
//! interpreter 6 to 11 times what it costs the JIT's two-point kernel
//! per instruction, and the leaf's descent comes on top
//! (`docs/faithful.md`, session 58). Both evaluate a point to the same
//! bits but where the full program overflows inside a dropped branch (see
//! [`Field`]), so elsewhere the choice changes no mesh.
//!
//! Before the proof search on an ambiguous leaf, a sign change among the
//! point values at its centre, at one Newton step from the centre and at
//! its corners, with `F` defined and continuous on the leaf, or an exact
//! zero among them, shows that it holds surface (intermediate values), and
//! the search is skipped.

mod build;
mod crease;
pub(crate) mod criteria;
mod examine;
pub mod field;
mod node;
pub mod octant;
mod options;
mod proof;
mod tape;
mod tree;

pub use build::{Refine, SharedLevels};
pub use criteria::{Chord, TopologyTest};
pub use field::Field;
pub use node::{Kind, Leaf, MAX_LEVEL, Node, Region};
pub use octant::Octant;
pub use options::{DEFAULT_CHORD, OctreeOptions};
pub use tree::{Octree, OctreeStats};
