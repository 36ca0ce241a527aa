//! Samples that every cell leaves alone, and the one join that mends each.
//!
//! # Contract
//!
//! A leaf centre is **isolated** when no dual cell joins it to another
//! corner: every dual cell around it is active, and in each
//! [`super::mc33`] puts it in a region of its own. The cells then close a
//! small surface around it (an octahedron around one sample): a component
//! of its own. Where `f` keeps the sample's sign along the segment to a
//! corner opposite it across a face of one of its dual cells, that
//! component is not real. At a sharp convex edge or corner of a CSG
//! solid, the inside reaches the sample only along such a diagonal, where
//! the asymptotic decider separates the two: a rotated box and a pyramid
//! had blobs beside their edges (`docs/faithful.md`, session 51).
//!
//! [`joins`] picks, for each isolated sample whose sign `f` carries to such
//! a corner ([`crate::roots::keeps_sign`]), **one** partner: the confirmed
//! corner of least [`dual::global`] name. The face is then decided for the
//! pair in both cells that share it ([`super::mc33::polygonize_joined`]),
//! which joins the blob to the region around it through that face — a
//! connected sum, which merges the two components and adds no handle.
//! (Deciding every face by `f` instead joined such blobs through two
//! faces each, making handles: session 51.)
//!
//! # Limits
//!
//! - Only samples of leaves at the tree's deepest allowed level are mended,
//!   so that a brick, whose tree reaches one such leaf past its box
//!   ([`crate::mesher::brick`]), sees every dual cell around each sample
//!   it mends and mends it as the whole run does. Blobs at coarser leaves
//!   stay.
//! - The pair's other corner may be isolated too: the two blobs are then
//!   one, still a component of its own.
//! - A blob around two or more samples (joined to each other and to
//!   nothing else) is not found, nor one whose sample is a ghost on ∂Ω.
//! - Partners opposite across a cell are not joined: in a wall thinner
//!   than a cell, the tubes that made had waists whose vertices projected
//!   onto one point (zero-area triangles, random scene 111 at level 5).

use rustc_hash::FxHashMap as HashMap;

use crate::dual::{self, Corner, DualCell};
use crate::eval::Evaluator;
use crate::octree::Octree;
use crate::roots;

/// Two corners to join (cell corner numbers) in a dual cell (its number).
pub(super) type Join = (u32, [u8; 2]);

/// Marks a sample that some cell joins to another corner.
const JOINED: u8 = u8::MAX;

/// The dual cells around a leaf of the deepest level: one at each corner
/// of its box (no leaf is smaller, so no other vertex lies on its
/// boundary).
const CELLS_AROUND: u8 = 8;

/// The joins that mend the isolated samples among the corners of the cells
/// `cells(i)` (each with its [`super::mc33::CellMesh::regions`]
/// `regions[i]`; `value(c)` is corner `c`'s value of `f`), at leaves of
/// level `level`, the tree's deepest: per cell index, the pair of corners
/// to join, in cell order. A leaf is isolated
/// when it is alone in its region in [`CELLS_AROUND`] of the cells, which
/// are then all of its dual cells: every cell around such a leaf must be
/// among them.
pub(super) fn joins<'a, E: Evaluator + ?Sized>(
    tree: &Octree,
    (f, t): (&E, f64),
    value: impl Fn(Corner) -> f64,
    cells: impl Fn(usize) -> &'a DualCell,
    regions: &[[u8; 8]],
    level: u8,
) -> Vec<Join> {
    // Per node, how many cells so far leave it alone, or JOINED.
    let mut alone_in = vec![0u8; tree.nodes.len()];
    let mut alone: Vec<(u32, u8)> = Vec::new();
    for (ci, r) in regions.iter().enumerate() {
        let cell = cells(ci);
        for i in 0..8 {
            let c = cell[i];
            let count = &mut alone_in[c.node as usize];
            if c.is_ghost() || *count == JOINED || tree.nodes[c.node as usize].level != level {
                continue;
            }
            let single = (0..8).all(|j| cell[j] == c || r[j] != r[i]);
            if single && value(c).is_finite() {
                *count = (*count + 1).min(JOINED - 1);
                alone.push((ci as u32, i as u8));
            } else {
                *count = JOINED;
            }
        }
    }
    alone.retain(|&(ci, i)| alone_in[cells(ci as usize)[i as usize].node as usize] == CELLS_AROUND);
    if alone.is_empty() {
        return Vec::new();
    }
    let partner = partners(tree, (f, t), &value, &cells, &alone);
    let mut out: Vec<Join> = alone
        .iter()
        .filter_map(|&(ci, i)| {
            let cell = cells(ci as usize);
            let d = *partner.get(&cell[i as usize])?;
            let j = (0..8u8).find(|&j| cell[j as usize] == d && opposite(i, j))?;
            Some((ci, [i, j]))
        })
        .collect();
    out.sort_unstable();
    out
}

/// Per isolated sample (its occurrences `alone` in `cells`), the opposite
/// corner of one sign with it that `f` confirms, least by global name.
fn partners<'a, E: Evaluator + ?Sized>(
    tree: &Octree,
    (f, t): (&E, f64),
    value: &impl Fn(Corner) -> f64,
    cells: &impl Fn(usize) -> &'a DualCell,
    alone: &[(u32, u8)],
) -> HashMap<Corner, Corner> {
    let mut options: HashMap<Corner, Vec<(u128, Corner)>> = HashMap::default();
    for &(ci, i) in alone {
        let cell = cells(ci as usize);
        let s = cell[i as usize];
        let negative = value(s) < 0.0;
        let list = options.entry(s).or_default();
        for j in (0..8u8).filter(|&j| opposite(i, j)) {
            let d = cell[j as usize];
            let v = value(d);
            if d != s && v.is_finite() && (v < 0.0) == negative {
                list.push((dual::global(tree, d), d));
            }
        }
    }
    let mut partner = HashMap::default();
    for (s, mut list) in options {
        list.sort_unstable();
        list.dedup();
        let negative = value(s) < 0.0;
        let confirmed = list.into_iter().find(|&(_, d)| {
            let (a, b) = dual::in_name_order(tree, (s, d));
            roots::keeps_sign(f, t, [a.position(tree), b.position(tree)], negative)
        });
        if let Some((_, d)) = confirmed {
            partner.insert(s, d);
        }
    }
    partner
}

/// Whether cell corners `i` and `j` are opposite across a face.
fn opposite(i: u8, j: u8) -> bool {
    (i ^ j).count_ones() == 2
}
