//! The adaptive octree over the domain Ω (Paiva et al. §4.1–4.2).
//!
//! # Contract
//!
//! The root is Ω itself; a node at level `l` with integer position
//! `ijk ∈ [0, 2^l)³` is the box `lo + size·ijk/2^l … lo + size·(ijk+1)/2^l`,
//! computed by [`Octree::cell_box`] with one formula everywhere, so that
//! neighbouring cells share their computed faces bit for bit and the leaves
//! tile Ω without gaps. Every node is classified from one interval-gradient
//! evaluation over its box ([`criteria`]):
//!
//! - a node is **discarded** (an [`Leaf::Empty`] leaf) only when the interval
//!   proves that `F` has no zero in it — a cell is never dropped on a guess;
//! - otherwise it is subdivided while its level is below `min_level`, or
//!   while it fails the topology or the geometry criterion and its level is
//!   below `max_level`;
//! - a leaf that stops at `max_level` still failing the topology criterion,
//!   or on which `F` is not defined and continuous everywhere (SPEC §1), is
//!   [`Leaf::Ambiguous`]; the other surface leaves are [`Leaf::Surface`].
//!
//! # Layout
//!
//! Nodes live in one `Vec<Node>`, root first; the 8 children of a node are
//! consecutive, child `c` (bits `x = c&1, y = (c>>1)&1, z = (c>>2)&1`) at
//! `first_child + c`. The tree is built breadth-first, one level at a time;
//! each level's cells are evaluated in parallel (`rayon`).
//!
//! # Evaluation
//!
//! Any [`Evaluator`] will do. Cells are examined in chunks of `BATCH`:
//! one [`Evaluator::grad_batch`] over the cells, one
//! [`Evaluator::interval_batch`] at their centres (the mean-value form),
//! and one [`Evaluator::interval_batch`] over the cells whose gradient flag
//! dropped. The proof search below ambiguous leaves
//! ([`Octree::clear_false_ambiguity`]) is recursive, one cell per call;
//! the ambiguous leaves run in parallel.

pub mod criteria;

use glam::DVec3;
use rayon::prelude::*;

use crate::eval::{Evaluator, WHOLE, WHOLE_GRAD};
use crate::interval::Interval;
use crate::surface::Bounds;
pub use criteria::TopologyTest;

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
}

/// One octree node. See the module doc for the layout.
#[derive(Clone, Copy, Debug)]
pub struct Node {
    /// Index of the first of the 8 children, or 0 for a leaf (the root is
    /// never anybody's child).
    pub first_child: u32,
    pub level: u8,
    pub ijk: [u32; 3],
    /// For leaves, how they ended; `None` for internal nodes.
    pub leaf: Option<Leaf>,
}

impl Node {
    pub fn is_leaf(&self) -> bool {
        self.first_child == 0
    }
}

/// Octree parameters (the command line's `--level`, `--min-level`,
/// `--kmax`, `--certify`).
#[derive(Clone, Copy, Debug)]
pub struct OctreeOptions {
    pub max_level: u8,
    pub min_level: u8,
    pub kmax: f64,
    pub test: TopologyTest,
    /// Time at which the surface is taken.
    pub t: f64,
}

impl Default for OctreeOptions {
    fn default() -> Self {
        OctreeOptions {
            max_level: 7,
            min_level: 3,
            kmax: 1.0,
            test: TopologyTest::Paper,
            t: 0.0,
        }
    }
}

/// Counts gathered while building.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OctreeStats {
    pub nodes: usize,
    pub empty_leaves: usize,
    pub surface_leaves: usize,
    pub ambiguous_leaves: usize,
    /// Deepest level of a leaf that may hold surface.
    pub max_level_reached: u8,
}

/// The adaptive octree. See the module doc.
pub struct Octree {
    pub nodes: Vec<Node>,
    pub lo: DVec3,
    pub size: DVec3,
    pub stats: OctreeStats,
}

/// Deepest level allowed: integer positions must fit in `u32` with room.
pub const MAX_LEVEL: u8 = 20;

/// Extra levels below an ambiguous leaf searched for a proof that it is
/// empty (see [`Octree::clear_false_ambiguity`]).
pub const PROOF_DEPTH: u8 = 3;

fn cell_input(a: DVec3, b: DVec3, t: f64) -> [Interval; 4] {
    [
        Interval { lo: a.x, hi: b.x },
        Interval { lo: a.y, hi: b.y },
        Interval { lo: a.z, hi: b.z },
        Interval { lo: t, hi: t },
    ]
}

/// Interval-gradient evaluations over cells (one batch call), judged by
/// the criteria; the value kernel is asked too where the gradient kernel's
/// flag dropped (for a merely non-differentiable F: a third batch call),
/// and at the centres for the mean-value form (a second batch call).
fn examine<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    opts: &OctreeOptions,
) -> Vec<criteria::Verdict> {
    let mut grads = vec![WHOLE_GRAD; cells.len()];
    f.grad_batch(cells, &mut grads);
    let centres: Vec<[Interval; 4]> = cells
        .iter()
        .map(|cell| {
            let mut c = *cell;
            for side in c.iter_mut().take(3) {
                let m = 0.5 * (side.lo + side.hi);
                *side = Interval { lo: m, hi: m };
            }
            c
        })
        .collect();
    let mut at_centres = vec![WHOLE; cells.len()];
    f.interval_batch(&centres, &mut at_centres);
    let undiff: Vec<[Interval; 4]> = cells
        .iter()
        .zip(&grads)
        .filter(|(_, g)| !g.defined)
        .map(|(c, _)| *c)
        .collect();
    let mut on_undiff = vec![WHOLE; undiff.len()];
    f.interval_batch(&undiff, &mut on_undiff);
    let mut on_undiff = on_undiff.into_iter();
    cells
        .iter()
        .zip(grads)
        .zip(centres.iter().zip(at_centres))
        .map(|((cell, g), (centre, fc))| {
            let value_defined = g.defined
                || on_undiff
                    .next()
                    .expect("one value per cell whose gradient flag dropped")
                    .defined;
            let mean_value = (g.defined && value_defined).then(|| {
                let c = [0, 1, 2].map(|k| centre[k].lo);
                criteria::mean_value_form(fc.iv, g.grad, [cell[0], cell[1], cell[2]], c)
            });
            criteria::judge(&g, value_defined, mean_value, opts.test, opts.kmax)
        })
        .collect()
}

/// Cells per batch call.
const BATCH: usize = 128;

/// Whether interval arithmetic proves the cell free of surface: `F`
/// defined on it and `0 ∉ F(B)` by the natural extension (one interval
/// evaluation), or, failing that, by the mean-value form or the gradient
/// kernel's own value enclosure ([`examine`]'s test). The cheap interval
/// kernel first, the gradient kernel only where it is needed.
fn empty<E: Evaluator + ?Sized>(f: &E, cell: [Interval; 4], opts: &OctreeOptions) -> bool {
    let r = f.interval(cell);
    if !r.defined {
        return false;
    }
    if r.iv.lo > 0.0 || r.iv.hi < 0.0 {
        return true;
    }
    examine(f, &[cell], opts)[0].empty
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
    if empty(f, cell_input(a, b, opts.t), opts) {
        return true;
    }
    if depth == 0 {
        return false;
    }
    let m = (a + b) * 0.5;
    (0..8).all(|c: u32| {
        let pick = |k: usize, lo: f64, mid: f64, hi: f64| {
            if (c >> k) & 1 == 0 {
                (lo, mid)
            } else {
                (mid, hi)
            }
        };
        let (x0, x1) = pick(0, a.x, m.x, b.x);
        let (y0, y1) = pick(1, a.y, m.y, b.y);
        let (z0, z1) = pick(2, a.z, m.z, b.z);
        proves_empty(
            f,
            DVec3::new(x0, y0, z0),
            DVec3::new(x1, y1, z1),
            opts,
            depth - 1,
        )
    })
}

impl Octree {
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
        let max_level = opts.max_level.min(MAX_LEVEL);
        let min_level = opts.min_level.min(max_level);
        let mut tree = Octree {
            nodes: vec![Node {
                first_child: 0,
                level: 0,
                ijk: [0; 3],
                leaf: None,
            }],
            lo: DVec3::from_array(domain.lo),
            size: DVec3::from_array(domain.hi) - DVec3::from_array(domain.lo),
            stats: OctreeStats::default(),
        };
        let mut frontier: Vec<u32> = vec![0];
        let mut evaluated = 0;
        for level in 0..=max_level {
            if frontier.is_empty() {
                break;
            }
            let verdicts: Vec<criteria::Verdict> = frontier
                .par_chunks(BATCH)
                .flat_map_iter(|chunk| {
                    let cells: Vec<[Interval; 4]> = chunk
                        .iter()
                        .map(|&i| {
                            let (a, b) = tree.cell_box(&tree.nodes[i as usize]);
                            cell_input(a, b, opts.t)
                        })
                        .collect();
                    examine(f, &cells, opts)
                })
                .collect();
            evaluated += frontier.len();
            let mut next = Vec::new();
            for (&i, v) in frontier.iter().zip(&verdicts) {
                let leaf = if v.empty {
                    Some(Leaf::Empty)
                } else if level < min_level {
                    None
                } else if level == max_level {
                    Some(if v.topology_ok {
                        Leaf::Surface
                    } else {
                        Leaf::Ambiguous
                    })
                } else if v.topology_ok && v.geometry_ok {
                    Some(Leaf::Surface)
                } else {
                    None
                };
                match leaf {
                    Some(l) => tree.nodes[i as usize].leaf = Some(l),
                    None => {
                        let first = tree.nodes.len() as u32;
                        let parent = tree.nodes[i as usize];
                        tree.nodes[i as usize].first_child = first;
                        for c in 0..8u32 {
                            let bit = |k: u32| (c >> k) & 1;
                            tree.nodes.push(Node {
                                first_child: 0,
                                level: level + 1,
                                ijk: [
                                    parent.ijk[0] * 2 + bit(0),
                                    parent.ijk[1] * 2 + bit(1),
                                    parent.ijk[2] * 2 + bit(2),
                                ],
                                leaf: None,
                            });
                            next.push(first + c);
                        }
                    }
                }
            }
            progress(level, evaluated);
            frontier = next;
        }
        tree.clear_false_ambiguity(f, opts);
        tree.count();
        tree
    }

    /// An ambiguous leaf at the maximal level may be ambiguous only because
    /// interval enclosures are loose on it: it may hold no surface at all.
    /// Each one is split further (up to [`PROOF_DEPTH`] levels, for the
    /// proof only: the octree keeps its leaf) and becomes [`Leaf::Empty`]
    /// when every piece is proved empty. Nothing else is relaxed.
    fn clear_false_ambiguity<E: Evaluator + ?Sized>(&mut self, f: &E, opts: &OctreeOptions) {
        let ambiguous: Vec<usize> = (0..self.nodes.len())
            .filter(|&i| self.nodes[i].leaf == Some(Leaf::Ambiguous))
            .collect();
        let proved: Vec<bool> = ambiguous
            .par_iter()
            .map(|&i| {
                let (a, b) = self.cell_box(&self.nodes[i]);
                proves_empty(f, a, b, opts, PROOF_DEPTH)
            })
            .collect();
        for (&i, empty) in ambiguous.iter().zip(proved) {
            if empty {
                self.nodes[i].leaf = Some(Leaf::Empty);
            }
        }
    }

    fn count(&mut self) {
        let mut s = OctreeStats {
            nodes: self.nodes.len(),
            ..OctreeStats::default()
        };
        for n in &self.nodes {
            match n.leaf {
                Some(Leaf::Empty) => s.empty_leaves += 1,
                Some(Leaf::Surface) => s.surface_leaves += 1,
                Some(Leaf::Ambiguous) => s.ambiguous_leaves += 1,
                None => continue,
            }
            if n.leaf != Some(Leaf::Empty) {
                s.max_level_reached = s.max_level_reached.max(n.level);
            }
        }
        self.stats = s;
    }
}
