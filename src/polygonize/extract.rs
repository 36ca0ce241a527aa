//! Dual marching cubes over the octree (Paiva et al. §4.3): every dual cell
//! whose corner values change sign is polygonised with [`super::mc33`], and
//! the cell meshes are joined into one indexed mesh.
//!
//! # Contract
//!
//! - Corner values are the function's values at the leaf centres, and at
//!   the ghost corners along ∂Ω (see [`crate::dual`]) the values at the
//!   centres' projections onto ∂Ω. A dual cell with repeated corners
//!   (leaves of different sizes) is polygonised with the repeated values
//!   duplicated, as the paper says.
//! - An edge vertex lies on the dual edge between two leaf centres and is
//!   **keyed by the pair of leaves**, never by position, so the cells that
//!   share a dual edge share its vertex: the mesh has no cracks and no
//!   duplicated vertices. Edges whose two corners are the same leaf cannot
//!   carry a vertex (equal values).
//! - Vertices are placed by bisection on the exact function
//!   ([`crate::roots::bisect_batch`], bit for bit
//!   [`crate::roots::bisect`]), not by linear interpolation; the
//!   interior vertices that MC33 adds for tunnels are mapped through the
//!   dual cell's trilinear map and projected onto `f = 0` (where that
//!   leaves Ω, onto a zero between them and a corner of their cell).
//! - A tunnel that MC33 finds through a cell's interior (two corners of
//!   one sign that the cell's faces keep apart, joined inside by the
//!   trilinear interpolant) is kept only where `f` itself has that sign
//!   along the straight segment between two such corners (at
//!   `roots::SEGMENT_SAMPLES` − 1 points, [`crate::roots::keeps_sign`]);
//!   elsewhere the cell's surface is two discs
//!   ([`super::mc33::polygonize_checked`]). Eight values misread a
//!   CSG crease through a dual cell whose corners come from leaves of
//!   different sizes: a convex pyramid had tubes across its 130° edges (a
//!   handle each). Faces are still decided by the asymptotic decider:
//!   deciding them by `f` at their centres left edges with four triangles
//!   where dual cells are degenerate, and, with those mended, joined the
//!   blobs at a pyramid's base corners through two faces each, making
//!   handles (`docs/faithful.md`, sessions 50 and 51).
//! - A leaf centre that every cell around it leaves in a region of its own
//!   (a blob around one sample) is joined to one corner opposite it
//!   across a face where `f` keeps its sign between them
//!   ([`super::isolated`]): the two cells of that face are polygonised
//!   again with the face joining the pair
//!   ([`super::mc33::polygonize_joined`]).
//! - Triangles whose vertices repeat (degenerate dual cells map two cell
//!   edges to one leaf pair) are dropped.
//! - A vertex is *ambiguous* when a leaf of its dual edge (or, for interior
//!   vertices, of its dual cell) is an ambiguous leaf of the octree.
//!
//! # Evaluation
//!
//! Everything is evaluated by an [`Evaluator`] at the octree's time `t`,
//! in batches: the leaf-centre values ([`Evaluator::point_batch`], chunks
//! in parallel), the ghost-corner values (one batch after the dual-grid
//! walk has met them all), the edge vertices (lock-step bisection, one
//! batch per step per chunk of edges) and the vertex normals
//! ([`Evaluator::point_grad_batch`]; where two sides of a kink tie
//! exactly at a vertex and the gradient there is the inner side's, the
//! one-sided gradient just outside, outward read from the edge's sign
//! change or the vertex's triangles:
//! `eval::sample::orient_at_kinks`). The projection of MC33's
//! interior vertices ([`crate::roots::project`]) is sequential per vertex
//! (each evaluation depends on the last); those vertices run in parallel.

use glam::DVec3;
use rayon::prelude::*;

use super::isolated::{self, Join};
use super::mc33::{self, EDGE_CORNERS, Vertex};
use rustc_hash::FxHashMap as HashMap;

use crate::cancel::{Cancel, Cancelled};
use crate::dual::{self, Corner, DualCell};
use crate::eval::Evaluator;
use crate::eval::sample::{normals_at, orient_at_kinks, values_at};
use crate::mesh::Mesh;
use crate::mesh::origin::{self, Origins};
use crate::octree::{Leaf, Octree};
use crate::roots::{self, Segment, bisect, bisect_batch, project};

/// A mesh vertex before numbering: an edge between two leaves (smaller
/// leaf first), or an interior vertex of one dual cell, packed into one
/// number whose order is (edges first) the order of the corner pairs, then
/// the interior vertices by cell and position in the cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
struct Key(u128);

/// Bit marking an interior key.
const INTERIOR: u128 = 1 << 127;

impl Key {
    fn corner_bits(c: Corner) -> u128 {
        ((c.node as u128) << 8) | c.mirror as u128
    }

    fn corner(bits: u128) -> Corner {
        Corner {
            node: (bits >> 8) as u32,
            mirror: bits as u8,
        }
    }

    /// The edge between `a` and `b` (either order).
    fn edge(a: Corner, b: Corner) -> Key {
        let (a, b) = (a.min(b), a.max(b));
        Key((Self::corner_bits(a) << 40) | Self::corner_bits(b))
    }

    /// Vertex `k` of dual cell `cell`.
    fn interior(cell: u32, k: u8) -> Key {
        Key(INTERIOR | ((cell as u128) << 8) | k as u128)
    }

    fn is_edge(self) -> bool {
        self.0 & INTERIOR == 0
    }

    /// The two corners of an edge key, smaller first.
    fn ends(self) -> (Corner, Corner) {
        debug_assert!(self.is_edge());
        let mask = (1u128 << 40) - 1;
        (Self::corner(self.0 >> 40), Self::corner(self.0 & mask))
    }

    /// The dual cell of an interior key.
    fn cell(self) -> u32 {
        debug_assert!(!self.is_edge());
        (self.0 >> 8) as u32
    }
}

/// The triangles (over keys) of a run of cells, their interior vertices
/// with positions (in key order), and how many degenerate triangles they
/// dropped.
#[derive(Default)]
struct CellsOutput {
    triangles: Vec<[Key; 3]>,
    /// The active cell of each triangle.
    cells: Vec<u32>,
    interiors: Vec<(Key, DVec3)>,
    dropped: usize,
    /// Per cell, its corners' regions ([`mc33::CellMesh::regions`]).
    regions: Vec<[u8; 8]>,
}

/// Active cells per polygonisation task.
const CELLS_PER_TASK: usize = 1024;

/// Counts of the extraction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExtractStats {
    /// Dual cells whose corner values change sign (the ones polygonised).
    pub active_cells: usize,
    /// Triangles dropped because two of their vertices were the same.
    pub dropped_degenerate: usize,
}

/// The function's values at the dual grid's corners: at every leaf centre
/// (internal nodes get NaN, never read), and at the ghost corners met so
/// far; and the active cells beside a brick's, for [`super::isolated`].
pub struct CornerValues {
    leaves: Vec<f64>,
    ghosts: HashMap<Corner, f64>,
    /// The active dual cells the walk's `keep` refused whose corners are
    /// all known (a brick's neighbours' cells beside it).
    near: Vec<DualCell>,
}

/// Edges per lock-step bisection.
const BATCH: usize = 256;

impl CornerValues {
    /// Values of `f(·, t)` at every leaf centre (batch calls, in parallel).
    pub fn at_leaves<E: Evaluator + ?Sized>(tree: &Octree, f: &E, t: f64) -> CornerValues {
        // An unexplored leaf (a brick's tree) is no dual corner of
        // interest: it keeps NaN.
        let leaves: Vec<usize> = (0..tree.nodes.len())
            .filter(|&i| tree.nodes[i].is_leaf() && tree.nodes[i].leaf() != Some(Leaf::Outside))
            .collect();
        let centres: Vec<DVec3> = leaves
            .iter()
            .map(|&i| tree.center(&tree.nodes[i]))
            .collect();
        let mut values = vec![f64::NAN; tree.nodes.len()];
        for (&i, v) in leaves.iter().zip(values_at(f, t, &centres)) {
            values[i] = v;
        }
        CornerValues {
            leaves: values,
            ghosts: HashMap::default(),
            near: Vec::new(),
        }
    }

    /// The value at `c` (a ghost must have been met by [`active_cells`]).
    pub fn get(&self, c: Corner) -> f64 {
        if c.is_ghost() {
            self.ghosts[&c]
        } else {
            self.leaves[c.node as usize]
        }
    }
}

/// The dual cells whose corner values change sign, in the dual grid's
/// order, and the number of dual cells visited. Evaluates the ghost
/// corners' values of `f(·, t)` (one batch, after the walk).
pub fn active_cells<E: Evaluator + ?Sized>(
    tree: &Octree,
    f: &E,
    t: f64,
    values: &mut CornerValues,
) -> (Vec<DualCell>, usize) {
    active_cells_where(tree, f, t, values, |_| true)
}

/// [`active_cells`] among the dual cells for which `keep` holds (a brick's
/// own: `keep` is asked first, before any value is read). The cells `keep`
/// refuses whose corners are all explored leaves are read too, for
/// [`super::isolated`]: the active ones are kept in `values`.
pub fn active_cells_where<E: Evaluator + ?Sized>(
    tree: &Octree,
    f: &E,
    t: f64,
    values: &mut CornerValues,
    keep: impl Fn(&DualCell) -> bool,
) -> (Vec<DualCell>, usize) {
    let negative = |v: f64| v < 0.0;
    let changes_sign = |values: &CornerValues, cell: &DualCell| {
        let first = negative(values.get(cell[0]));
        cell.iter().any(|&c| negative(values.get(c)) != first)
    };
    let explored = |c: &Corner| tree.nodes[c.node as usize].leaf() != Some(Leaf::Outside);
    let mut count = 0;
    // Cells with a ghost corner are kept as candidates (in order) and
    // decided once every ghost met has its value.
    let mut cells: Vec<(DualCell, bool, bool)> = Vec::new();
    let mut new_ghosts: Vec<Corner> = Vec::new();
    dual::for_each_cell(tree, |cell| {
        let own = keep(&cell);
        if own {
            count += 1;
        } else if !cell.iter().all(explored) {
            return;
        }
        let mut pending = false;
        for &c in &cell {
            if c.is_ghost() && !values.ghosts.contains_key(&c) {
                values.ghosts.insert(c, f64::NAN);
                new_ghosts.push(c);
            }
            pending |= c.is_ghost();
        }
        if pending || changes_sign(values, &cell) {
            cells.push((cell, own, pending));
        }
    });
    let at: Vec<DVec3> = new_ghosts.iter().map(|c| c.position(tree)).collect();
    for (c, v) in new_ghosts.iter().zip(values_at(f, t, &at)) {
        values.ghosts.insert(*c, v);
    }
    let (mut active, mut near) = (Vec::with_capacity(cells.len()), Vec::new());
    for (cell, own, pending) in cells {
        if pending && !changes_sign(values, &cell) {
            continue;
        }
        if own { &mut active } else { &mut near }.push(cell);
    }
    values.near = near;
    (active, count)
}

/// Polygonises the active dual cells of the octree of `f(·, t)`. See the
/// module doc. Also returns, per triangle, the index in `active` of its
/// dual cell (the triangles of one cell are consecutive). Stops with
/// [`Cancelled`] when `cancel` is cancelled (polled per task of cells and
/// before the vertices are placed).
pub fn extract<E: Evaluator + ?Sized>(
    tree: &Octree,
    f: &E,
    t: f64,
    values: &CornerValues,
    active: &[DualCell],
    cancel: &Cancel,
) -> Result<(Mesh, ExtractStats, Vec<u32>), Cancelled> {
    let (mesh, stats, cell_of, _) = extract_in(tree, f, t, values, active, false, cancel)?;
    Ok((mesh, stats, cell_of))
}

/// [`extract`], also giving every vertex its [`Origins`] (its id and the
/// faces of Ω it lies on; [`crate::mesh::origin`]).
pub fn extract_with_origins<E: Evaluator + ?Sized>(
    tree: &Octree,
    f: &E,
    t: f64,
    values: &CornerValues,
    active: &[DualCell],
    cancel: &Cancel,
) -> Result<(Mesh, ExtractStats, Vec<u32>, Origins), Cancelled> {
    extract_in(tree, f, t, values, active, true, cancel)
}

fn extract_in<E: Evaluator + ?Sized>(
    tree: &Octree,
    f: &E,
    t: f64,
    values: &CornerValues,
    active: &[DualCell],
    origins: bool,
    cancel: &Cancel,
) -> Result<(Mesh, ExtractStats, Vec<u32>, Origins), Cancelled> {
    let nodes = &tree.nodes;
    let mut stats = ExtractStats {
        active_cells: active.len(),
        ..ExtractStats::default()
    };
    // Polygonise every active cell into triangles over keys, then again
    // the tasks whose cells mend an isolated sample.
    let mut outputs: Vec<CellsOutput> = active
        .par_chunks(CELLS_PER_TASK)
        .enumerate()
        .map(|(chunk, cells)| polygonize_task(tree, (f, t), values, chunk, cells, &[], cancel))
        .collect();
    cancel.check()?;
    let mends = mends(tree, (f, t), values, active, &outputs);
    let task = |j: &Join| j.0 as usize / CELLS_PER_TASK;
    let redone: Vec<(usize, CellsOutput)> = mends
        .chunk_by(|a, b| task(a) == task(b))
        .collect::<Vec<_>>()
        .par_iter()
        .map(|joins| {
            let chunk = task(&joins[0]);
            let cells = active.chunks(CELLS_PER_TASK).nth(chunk).unwrap_or(&[]);
            let out = polygonize_task(tree, (f, t), values, chunk, cells, joins, cancel);
            (chunk, out)
        })
        .collect();
    for (chunk, out) in redone {
        outputs[chunk] = out;
    }
    cancel.check()?;
    stats.dropped_degenerate = outputs.iter().map(|o| o.dropped).sum();
    let cell_of: Vec<u32> = outputs
        .iter()
        .flat_map(|o| o.cells.iter().copied())
        .collect();

    // Number the vertices in key order: the distinct corner keys, sorted;
    // a triangle's corners are then found by binary search (no per-corner
    // slot records, which cost twice the keys).
    let mut keys: Vec<Key> = outputs
        .iter()
        .flat_map(|o| o.triangles.iter().flatten().copied())
        .collect();
    keys.par_sort_unstable();
    keys.dedup();
    keys.shrink_to_fit();
    let index = |k: &Key| {
        keys.binary_search(k)
            .expect("every corner key was collected") as u32
    };
    let triangles: Vec<[u32; 3]> = outputs
        .par_iter()
        .flat_map_iter(|o| o.triangles.iter().map(|t| t.each_ref().map(index)))
        .collect();
    for o in &mut outputs {
        o.triangles = Vec::new();
    }
    // Interior positions in key order (cells in order, each in order).
    let interiors: Vec<(Key, DVec3)> = outputs
        .iter()
        .flat_map(|o| o.interiors.iter().copied())
        .collect();

    let ambiguous_leaf = |c: Corner| nodes[c.node as usize].leaf() == Some(Leaf::Ambiguous);
    // Edge keys sort before interior keys.
    let edges = keys.partition_point(|k| k.is_edge());
    // Per edge vertex, also the direction in which `f` grows along its
    // edge.
    let (mut placed, mut outward): (Vec<(DVec3, bool)>, Vec<DVec3>) = keys[..edges]
        .par_chunks(BATCH)
        .flat_map_iter(|chunk| {
            let segments: Vec<Segment> = chunk
                .iter()
                .map(|k| {
                    let (a, b) = dual::in_name_order(tree, k.ends());
                    Segment {
                        a: a.position(tree),
                        b: b.position(tree),
                        fa: values.get(a),
                        fb: values.get(b),
                    }
                })
                .collect();
            let ps = bisect_batch(f, t, &segments);
            chunk.iter().zip(ps).zip(segments).map(move |((k, p), s)| {
                let (a, b) = k.ends();
                let up = (s.b - s.a) * (s.fb - s.fa).signum();
                ((p, ambiguous_leaf(a) || ambiguous_leaf(b)), up)
            })
        })
        .unzip();
    let in_domain = |p: &DVec3| p.cmpge(tree.lo).all() && p.cmple(tree.hi).all();
    placed.par_extend(keys[edges..].par_iter().map(|k| {
        let at = interiors
            .binary_search_by_key(k, |&(key, _)| key)
            .expect("every interior key was collected");
        let p0 = interiors[at].1;
        let cell = active[k.cell() as usize];
        let reach = cell_reach(tree, &cell);
        let p = project(f, t, p0, reach)
            .filter(in_domain)
            .or_else(|| zero_in_cell(tree, f, t, values, &cell, p0))
            .unwrap_or(p0);
        (p, cell.iter().any(|&l| ambiguous_leaf(l)))
    }));

    let mut mesh = Mesh {
        positions: placed.iter().map(|p| p.0).collect(),
        ambiguous: placed.iter().map(|p| p.1).collect(),
        normals: Vec::new(),
        triangles,
    };
    mesh.normals = normals_at(f, t, &mesh.positions);
    // Outward: along the edge's sign change for an edge vertex, along its
    // triangles' normals (oriented outward by construction) for the rest.
    outward.resize(mesh.positions.len(), DVec3::ZERO);
    for &tri in &mesh.triangles {
        let n = mesh.face_normal(tri);
        for &v in tri.iter().filter(|&&v| v as usize >= edges) {
            outward[v as usize] += n;
        }
    }
    orient_at_kinks(f, t, &mesh.positions, &mut mesh.normals, &outward);
    let origins = if origins {
        origins_of(tree, active, &keys)
    } else {
        Origins::default()
    };
    Ok((mesh, stats, cell_of, origins))
}

/// The origins of the vertices numbered by `keys`.
fn origins_of(tree: &Octree, active: &[DualCell], keys: &[Key]) -> Origins {
    let (ids, sides) = keys
        .par_iter()
        .map(|k| {
            if k.is_edge() {
                let (a, b) = dual::in_name_order(tree, k.ends());
                let id = origin::mix(origin::EDGE, dual::global(tree, a), dual::global(tree, b));
                (id, a.mirror & b.mirror)
            } else {
                let [x, y, z] = dual::vertex(tree, &active[k.cell() as usize]).map(u128::from);
                let at = (x << 42) | (y << 21) | z;
                (origin::mix(origin::INTERIOR, at, k.0 & 0xff), 0)
            }
        })
        .unzip();
    Origins { ids, sides }
}

/// Polygonises the active dual cells `cells` of task `chunk` (cell
/// numbers from `chunk * CELLS_PER_TASK`), joining in cell `ci` the pairs
/// `(ci, pair)` of `joins` (sorted); nothing when cancelled.
fn polygonize_task<E: Evaluator + ?Sized>(
    tree: &Octree,
    (f, t): (&E, f64),
    values: &CornerValues,
    chunk: usize,
    cells: &[DualCell],
    joins: &[Join],
    cancel: &Cancel,
) -> CellsOutput {
    let mut out = CellsOutput::default();
    if cancel.is_cancelled() {
        return out;
    }
    for (i, cell) in cells.iter().enumerate() {
        let ci = (chunk * CELLS_PER_TASK + i) as u32;
        let from = joins.partition_point(|j| j.0 < ci);
        let to = joins.partition_point(|j| j.0 <= ci);
        let pairs: Vec<[u8; 2]> = joins[from..to].iter().map(|j| j.1).collect();
        let cm = polygonize_cell(tree, (f, t), cell, values, &pairs);
        out.push(tree, ci, cell, &cm);
    }
    out
}

/// The joins that mend the isolated samples ([`super::isolated`]) among
/// the active cells (their regions in `outputs`) and the cells beside them
/// that the walk kept in `values`, per active cell number.
fn mends<E: Evaluator + ?Sized>(
    tree: &Octree,
    (f, t): (&E, f64),
    values: &CornerValues,
    active: &[DualCell],
    outputs: &[CellsOutput],
) -> Vec<Join> {
    let near: Vec<[u8; 8]> = values
        .near
        .par_iter()
        .map(|cell| polygonize_cell(tree, (f, t), cell, values, &[]).regions())
        .collect();
    let regions: Vec<[u8; 8]> = outputs
        .iter()
        .flat_map(|o| o.regions.iter().copied())
        .chain(near)
        .collect();
    let cells = |ci: usize| {
        active
            .get(ci)
            .unwrap_or_else(|| &values.near[ci - active.len()])
    };
    let value = |c: Corner| values.get(c);
    let mut joins = isolated::joins(tree, (f, t), value, cells, &regions, tree.max_level);
    joins.retain(|j| (j.0 as usize) < active.len());
    joins
}

/// Polygonises one dual cell, joining the pairs of corners `joined`
/// ([`mc33::polygonize_joined`]).
fn polygonize_cell<E: Evaluator + ?Sized>(
    tree: &Octree,
    (f, t): (&E, f64),
    cell: &DualCell,
    values: &CornerValues,
    joined: &[[u8; 2]],
) -> mc33::CellMesh {
    let v: [f64; 8] = cell.map(|c| values.get(c));
    let through = |i: usize, j: usize| {
        let ends = [cell[i].position(tree), cell[j].position(tree)];
        roots::keeps_sign(f, t, ends, v[i] < 0.0)
    };
    mc33::polygonize_joined(&v, &through, joined)
}

impl CellsOutput {
    /// Adds the polygonisation `cm` of active cell number `ci`.
    fn push(&mut self, tree: &Octree, ci: u32, cell: &DualCell, cm: &mc33::CellMesh) {
        let mut keys = [Key(0); mc33::MAX_VERTS];
        for (k, vert) in cm.vertices().iter().enumerate() {
            keys[k] = match *vert {
                Vertex::Edge { edge, .. } => {
                    let [a, b] = EDGE_CORNERS[edge as usize];
                    Key::edge(cell[a as usize], cell[b as usize])
                }
                Vertex::Interior(p) => {
                    let key = Key::interior(ci, k as u8);
                    self.interiors.push((key, trilinear_map(tree, cell, p)));
                    key
                }
            };
        }
        for t in cm.triangles() {
            let k = t.map(|i| keys[i as usize]);
            if k[0] == k[1] || k[1] == k[2] || k[0] == k[2] {
                self.dropped += 1;
            } else {
                self.triangles.push(k);
                self.cells.push(ci);
            }
        }
        self.regions.push(cm.regions());
    }
}

/// The point with cell coordinates `p` in the dual cell's trilinear map of
/// its corner leaves' centres.
fn trilinear_map(tree: &Octree, cell: &DualCell, p: DVec3) -> DVec3 {
    let c: [DVec3; 8] = cell.map(|l| l.position(tree));
    let x00 = c[0].lerp(c[1], p.x);
    let x10 = c[2].lerp(c[3], p.x);
    let x01 = c[4].lerp(c[5], p.x);
    let x11 = c[6].lerp(c[7], p.x);
    x00.lerp(x10, p.y).lerp(x01.lerp(x11, p.y), p.z)
}

/// The bounding box (low and high corners) of a dual cell's corners.
pub fn cell_bounds(tree: &Octree, cell: &DualCell) -> [DVec3; 2] {
    cell.iter().fold(
        [DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)],
        |[lo, hi], &l| {
            let c = l.position(tree);
            [lo.min(c), hi.max(c)]
        },
    )
}

/// When the gradient line from an interior vertex `p0` finds no zero in
/// Ω: a zero on the segment from `p0` to the nearest corner of its dual
/// cell whose value has the other sign (bisection; the corner values are
/// known), so the vertex still lies on the surface and in its cell.
/// `None` where `f(p0)` is not finite or no corner has the other sign.
fn zero_in_cell<E: Evaluator + ?Sized>(
    tree: &Octree,
    f: &E,
    t: f64,
    values: &CornerValues,
    cell: &DualCell,
    p0: DVec3,
) -> Option<DVec3> {
    let f0 = f.point([p0.x, p0.y, p0.z, t]);
    if !f0.is_finite() {
        return None;
    }
    if f0 == 0.0 {
        return Some(p0);
    }
    cell.iter()
        .map(|&c| (c.position(tree), values.get(c)))
        .filter(|&(_, v)| !v.is_nan() && (v < 0.0) != (f0 < 0.0))
        .min_by(|a, b| {
            p0.distance_squared(a.0)
                .total_cmp(&p0.distance_squared(b.0))
        })
        .map(|(q, v)| bisect(f, t, p0, q, f0, v))
}

/// The diagonal of the box of a dual cell's corners (no two corners are
/// farther apart).
fn cell_reach(tree: &Octree, cell: &DualCell) -> f64 {
    let [lo, hi] = cell_bounds(tree, cell);
    (hi - lo).length()
}
