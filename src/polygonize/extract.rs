//! Dual marching cubes over the octree (Paiva et al. §4.3): every dual cell
//! whose corner values change sign is polygonised with [`super::mc33`], and
//! the cell meshes are joined into one indexed mesh.
//!
//! # Contract
//!
//! - Corner values are the function's values at the leaf centres (point
//!   kernel), and at the ghost corners along ∂Ω (see [`crate::dual`]) the
//!   values at the centres' projections onto ∂Ω. A dual cell with repeated corners (leaves of different sizes)
//!   is polygonised with the repeated values duplicated, as the paper says.
//! - An edge vertex lies on the dual edge between two leaf centres and is
//!   **keyed by the pair of leaves**, never by position, so the cells that
//!   share a dual edge share its vertex: the mesh has no cracks and no
//!   duplicated vertices. Edges whose two corners are the same leaf cannot
//!   carry a vertex (equal values).
//! - Vertices are placed by bisection on the exact function
//!   ([`crate::mesh::roots::bisect`]), not by linear interpolation; the
//!   interior vertices that MC33 adds for tunnels are mapped through the
//!   dual cell's trilinear map and projected onto `f = 0`.
//! - Triangles whose vertices repeat (degenerate dual cells map two cell
//!   edges to one leaf pair) are dropped.
//! - A vertex is *ambiguous* when a leaf of its dual edge (or, for interior
//!   vertices, of its dual cell) is an ambiguous leaf of the octree.

use glam::DVec3;
use rayon::prelude::*;

use super::mc33::{self, EDGE_CORNERS, Vertex};
use std::collections::HashMap;

use crate::dual::{self, Corner, DualCell};
use crate::mesh::Mesh;
use crate::mesh::roots::{Field, bisect, project};
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

impl CornerValues {
    /// Values at every leaf centre, evaluated in parallel.
    pub fn at_leaves(tree: &Octree, field: &dyn Field) -> CornerValues {
        let leaves = tree
            .nodes
            .par_iter()
            .map(|n| {
                if n.is_leaf() {
                    field.value(tree.center(n))
                } else {
                    f64::NAN
                }
            })
            .collect();
        CornerValues {
            leaves,
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

/// The dual cells whose corner values change sign, and the number of dual
/// cells visited. Evaluates the ghost corners' values on the way.
pub fn active_cells(
    tree: &Octree,
    field: &dyn Field,
    values: &mut CornerValues,
) -> (Vec<DualCell>, usize) {
    let negative = |v: f64| v < 0.0;
    let mut count = 0;
    let mut active: Vec<DualCell> = Vec::new();
    dual::for_each_cell(tree, |cell| {
        count += 1;
        for &c in &cell {
            if c.is_ghost() {
                values
                    .ghosts
                    .entry(c)
                    .or_insert_with(|| field.value(c.position(tree)));
            }
        }
        let first = negative(values.get(cell[0]));
        if cell.iter().any(|&c| negative(values.get(c)) != first) {
            active.push(cell);
        }
    });
    (active, count)
}

/// Polygonises the active dual cells of `field`'s octree. See the module
/// doc.
pub fn extract(
    tree: &Octree,
    field: &dyn Field,
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
    let placed: Vec<(DVec3, bool)> = keys
        .par_iter()
        .map(|k| match *k {
            Key::Edge(a, b) => {
                let (pa, pb) = (a.position(tree), b.position(tree));
                let p = bisect(field, pa, pb, values.get(a), values.get(b));
                (p, ambiguous_leaf(a) || ambiguous_leaf(b))
            }
            Key::Interior(ci, _) => {
                let p0 = interior_at[k];
                let cell = active[ci as usize];
                let reach = cell_reach(tree, &cell);
                let p = project(field, p0, reach).unwrap_or(p0);
                (p, cell.iter().any(|&l| ambiguous_leaf(l)))
            }
        })
        .collect();

    let mut mesh = Mesh {
        positions: placed.iter().map(|p| p.0).collect(),
        ambiguous: placed.iter().map(|p| p.1).collect(),
        normals: Vec::new(),
        triangles: Vec::new(),
    };
    mesh.normals = mesh
        .positions
        .par_iter()
        .map(|&p| field.gradient(p).1.normalize_or_zero())
        .collect();
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
