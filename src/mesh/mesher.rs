//! The robust adaptive mesher end to end (Paiva et al. §4): octree →
//! dual grid → dual marching cubes (MC33) with vertices bisected onto the
//! surface → tangential smoothing → report. The report's topology is
//! computed from the mesh itself ([`super::topology`]), never assumed.
//!
//! Every stage evaluates the function through one [`Evaluator`] at the
//! octree's time: [`mesh_with`] takes any evaluator and a domain, [`mesh`]
//! is [`mesh_with`] on a compiled [`Surface`] and its own domain.

use std::time::Instant;

use super::Mesh;
use super::{quality, smooth, topology};
use crate::eval::Evaluator;
use crate::octree::{Octree, OctreeOptions, OctreeStats};
use crate::polygonize::extract;
use crate::surface::{Bounds, Surface};

/// Options of [`mesh`] (SPEC §2 `isoc mesh`).
#[derive(Clone, Copy, Debug)]
pub struct MeshOptions {
    pub octree: OctreeOptions,
    /// Smoothing passes (`--smooth`).
    pub smooth: usize,
    /// The domain; `None` means the surface's own.
    pub domain: Option<Bounds>,
}

impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions {
            octree: OctreeOptions::default(),
            smooth: 2,
            domain: None,
        }
    }
}

/// Milliseconds spent per stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timings {
    pub octree: f64,
    pub dual: f64,
    pub polygonize: f64,
    pub smooth: f64,
    pub total: f64,
}

/// What a mesh run found (the fields of SPEC §2 `--stats json`).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshReport {
    pub triangles: usize,
    pub vertices: usize,
    pub aspect_good: f64,
    pub topology: topology::Topology,
    /// Leaves left ambiguous (topology criterion still failing at the
    /// maximal level, or `F` not defined everywhere on the cell).
    pub ambiguous_cells: usize,
    /// True only when no leaf is ambiguous.
    pub guaranteed: bool,
    pub octree: OctreeStats,
    pub dual_cells: usize,
    pub active_cells: usize,
    pub smoothing_moves: usize,
    pub timings: Timings,
}

/// Stage names reported to the progress callback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Octree { level: u8, cells: usize },
    Dual,
    Polygonize,
    Smooth,
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

/// Meshes `surface` (through its JIT kernels) over `opts.domain` or, when
/// that is `None`, the surface's own domain: [`mesh_with`] on the surface.
pub fn mesh(
    surface: &Surface,
    opts: &MeshOptions,
    progress: &(dyn Fn(Stage) + Sync),
) -> (Mesh, MeshReport) {
    mesh_with(surface, surface.domain, opts, progress)
}

/// Meshes `f(·, opts.octree.t) = 0` for any evaluator `f` over
/// `opts.domain` or, when that is `None`, over `domain`. `progress` is told
/// when each stage starts (and after each octree level). The mesh depends
/// only on the values `f` returns: two evaluators that agree bit for bit
/// give the same mesh.
pub fn mesh_with<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    progress: &(dyn Fn(Stage) + Sync),
) -> (Mesh, MeshReport) {
    let start = Instant::now();
    let domain = opts.domain.unwrap_or(domain);
    let t = opts.octree.t;
    let t0 = Instant::now();
    let tree = Octree::build(f, domain, &opts.octree, &|level, cells| {
        progress(Stage::Octree { level, cells })
    });
    let octree_ms = ms(t0);

    progress(Stage::Dual);
    let t0 = Instant::now();
    let mut values = extract::CornerValues::at_leaves(&tree, f, t);
    let (active, dual_cells) = extract::active_cells(&tree, f, t, &mut values);
    let dual_ms = ms(t0);

    progress(Stage::Polygonize);
    let t0 = Instant::now();
    let (mut mesh, ex) = extract::extract(&tree, f, t, &values, &active);
    let polygonize_ms = ms(t0);

    progress(Stage::Smooth);
    let t0 = Instant::now();
    let moves = smooth::smooth(&mut mesh, f, t, opts.smooth);
    let smooth_ms = ms(t0);

    let topo = topology::analyze(&mesh);
    let report = MeshReport {
        triangles: mesh.triangles.len(),
        vertices: mesh.positions.len(),
        aspect_good: quality::aspect_good(&mesh),
        topology: topo,
        ambiguous_cells: tree.stats.ambiguous_leaves,
        guaranteed: tree.stats.ambiguous_leaves == 0,
        octree: tree.stats,
        dual_cells,
        active_cells: ex.active_cells,
        smoothing_moves: moves,
        timings: Timings {
            octree: octree_ms,
            dual: dual_ms,
            polygonize: polygonize_ms,
            smooth: smooth_ms,
            total: ms(start),
        },
    };
    (mesh, report)
}
