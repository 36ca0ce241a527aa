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
//!   ([`crate::mesh::roots::bisect_batch`], bit for bit
//!   [`crate::mesh::roots::bisect`]), not by linear interpolation; the
//!   interior vertices that MC33 adds for tunnels are mapped through the
//!   dual cell's trilinear map and projected onto `f = 0`.
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
//! ([`Evaluator::point_grad_batch`]). The projection of MC33's interior
//! vertices ([`crate::mesh::roots::project`]) is sequential per vertex
//! (each evaluation depends on the last); those vertices run in parallel.

use glam::DVec3;
use rayon::prelude::*;

use super::mc33::{self, EDGE_CORNERS, Vertex};
use std::collections::HashMap;

use crate::dual::{self, Corner, DualCell};
use crate::eval::Evaluator;
use crate::mesh::Mesh;
use crate::mesh::roots::{Segment, bisect_batch, project};
use crate::mesh::sample::{normals_at, values_at};
use crate::octree::{Leaf, Octree};

/// A mesh vertex before numbering: an edge between two leaves (smaller
/// leaf first), or an interior vertex of one dual cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
enum Key {
    Edge(Corner, Corner),
    Interior(u32, u8),
}

/// One cell's triangles over keys, its interior vertices with their
/// positions, and how many degenerate triangles it dropped.
type CellOutput = (Vec<[Key; 3]>, Vec<(Key, DVec3)>, usize);

/// Counts of the extraction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ExtractStats {
    pub active_cells: usize,
    pub dropped_degenerate: usize,
}

/// The function's values at the dual grid's corners: at every leaf centre
/// (internal nodes get NaN, never read), and at the ghost corners met so
/// far.
pub struct CornerValues {
    leaves: Vec<f64>,
    ghosts: HashMap<Corner, f64>,
}

/// Edges per lock-step bisection.
const BATCH: usize = 256;

impl CornerValues {
    /// Values of `f(·, t)` at every leaf centre (batch calls, in parallel).
    pub fn at_leaves<E: Evaluator + ?Sized>(tree: &Octree, f: &E, t: f64) -> CornerValues {
        let leaves: Vec<usize> = (0..tree.nodes.len())
            .filter(|&i| tree.nodes[i].is_leaf())
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
            ghosts: HashMap::new(),
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
    let negative = |v: f64| v < 0.0;
    let changes_sign = |values: &CornerValues, cell: &DualCell| {
        let first = negative(values.get(cell[0]));
        cell.iter().any(|&c| negative(values.get(c)) != first)
    };
    let mut count = 0;
    // Cells with a ghost corner are kept as candidates (in order) and
    // decided once every ghost met has its value.
    let mut cells: Vec<(DualCell, bool)> = Vec::new();
    let mut new_ghosts: Vec<Corner> = Vec::new();
    dual::for_each_cell(tree, |cell| {
        count += 1;
        let mut pending = false;
        for &c in &cell {
            if c.is_ghost() && !values.ghosts.contains_key(&c) {
                values.ghosts.insert(c, f64::NAN);
                new_ghosts.push(c);
            }
            pending |= c.is_ghost();
        }
        if pending {
            cells.push((cell, true));
        } else if changes_sign(values, &cell) {
            cells.push((cell, false));
        }
    });
    let at: Vec<DVec3> = new_ghosts.iter().map(|c| c.position(tree)).collect();
    for (c, v) in new_ghosts.iter().zip(values_at(f, t, &at)) {
        values.ghosts.insert(*c, v);
    }
    let active = cells
        .into_iter()
        .filter(|(cell, pending)| !pending || changes_sign(values, cell))
        .map(|(cell, _)| cell)
        .collect();
    (active, count)
}

/// Polygonises the active dual cells of the octree of `f(·, t)`. See the
/// module doc.
pub fn extract<E: Evaluator + ?Sized>(
    tree: &Octree,
    f: &E,
    t: f64,
    values: &CornerValues,
    active: &[DualCell],
) -> (Mesh, ExtractStats) {
    let nodes = &tree.nodes;
    let mut stats = ExtractStats {
        active_cells: active.len(),
        ..ExtractStats::default()
    };
    // Polygonise every active cell into triangles over keys.
    let per_cell: Vec<CellOutput> = active
        .par_iter()
        .enumerate()
        .map(|(ci, cell)| {
            let v: [f64; 8] = cell.map(|c| values.get(c));
            let cm = mc33::polygonize(&v);
            let keys: Vec<Key> = cm
                .vertices()
                .iter()
                .enumerate()
                .map(|(k, vert)| match *vert {
                    Vertex::Edge { edge, .. } => {
                        let [a, b] = EDGE_CORNERS[edge as usize];
                        let (la, lb) = (cell[a as usize], cell[b as usize]);
                        Key::Edge(la.min(lb), la.max(lb))
                    }
                    Vertex::Interior(_) => Key::Interior(ci as u32, k as u8),
                })
                .collect();
            let interiors = cm
                .vertices()
                .iter()
                .enumerate()
                .filter_map(|(k, vert)| match *vert {
                    Vertex::Interior(p) => Some((keys[k], trilinear_map(tree, cell, p))),
                    Vertex::Edge { .. } => None,
                })
                .collect();
            let mut tris = Vec::with_capacity(cm.triangles().len());
            let mut dropped = 0;
            for t in cm.triangles() {
                let k = t.map(|i| keys[i as usize]);
                if k[0] == k[1] || k[1] == k[2] || k[0] == k[2] {
                    dropped += 1;
                } else {
                    tris.push(k);
                }
            }
            (tris, interiors, dropped)
        })
        .collect();

    // Number the vertices: sorted unique keys.
    let mut keys: Vec<Key> = per_cell
        .iter()
        .flat_map(|(t, _, _)| t.iter().flatten().copied())
        .collect();
    keys.par_sort_unstable();
    keys.dedup();
    let index = |k: &Key| keys.binary_search(k).expect("every key was collected") as u32;
    let interior_at: std::collections::HashMap<Key, DVec3> = per_cell
        .iter()
        .flat_map(|(_, i, _)| i.iter().copied())
        .collect();

    let ambiguous_leaf = |c: Corner| nodes[c.node as usize].leaf == Some(Leaf::Ambiguous);
    // Edge keys sort before interior keys.
    let edges = keys.partition_point(|k| matches!(k, Key::Edge(..)));
    let mut placed: Vec<(DVec3, bool)> = keys[..edges]
        .par_chunks(BATCH)
        .flat_map_iter(|chunk| {
            let ends = |k: &Key| match *k {
                Key::Edge(a, b) => (a, b),
                Key::Interior(..) => unreachable!("edge keys only"),
            };
            let segments: Vec<Segment> = chunk
                .iter()
                .map(|k| {
                    let (a, b) = ends(k);
                    Segment {
                        a: a.position(tree),
                        b: b.position(tree),
                        fa: values.get(a),
                        fb: values.get(b),
                    }
                })
                .collect();
            let ps = bisect_batch(f, t, &segments);
            chunk.iter().zip(ps).map(move |(k, p)| {
                let (a, b) = ends(k);
                (p, ambiguous_leaf(a) || ambiguous_leaf(b))
            })
        })
        .collect();
    placed.par_extend(keys[edges..].par_iter().map(|k| {
        let Key::Interior(ci, _) = *k else {
            unreachable!("interior keys only")
        };
        let p0 = interior_at[k];
        let cell = active[ci as usize];
        let reach = cell_reach(tree, &cell);
        let p = project(f, t, p0, reach).unwrap_or(p0);
        (p, cell.iter().any(|&l| ambiguous_leaf(l)))
    }));

    let mut mesh = Mesh {
        positions: placed.iter().map(|p| p.0).collect(),
        ambiguous: placed.iter().map(|p| p.1).collect(),
        normals: Vec::new(),
        triangles: Vec::new(),
    };
    mesh.normals = normals_at(f, t, &mesh.positions);
    for (tris, _, dropped) in &per_cell {
        stats.dropped_degenerate += dropped;
        mesh.triangles
            .extend(tris.iter().map(|t| t.map(|k| index(&k))));
    }
    (mesh, stats)
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

/// The largest distance between two corners of a dual cell.
fn cell_reach(tree: &Octree, cell: &DualCell) -> f64 {
    let (lo, hi) = cell.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &l| {
            let c = l.position(tree);
            (lo.min(c), hi.max(c))
        },
    );
    (hi - lo).length()
}
