//! The robust adaptive mesher end to end (Paiva et al. §4): octree →
//! dual grid → dual marching cubes (MC33) with vertices bisected onto the
//! surface → smoothing (edge flips and tangential relaxation) → report.
//! The report's topology is computed from the mesh itself
//! ([`super::topology`]), never assumed.
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
    /// Smoothing passes (`--smooth`): edge flips and tangential relaxation
    /// ([`smooth::smooth`]).
    pub smooth: usize,
    /// The domain; `None` means the surface's own.
    pub domain: Option<Bounds>,
}

impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions {
            octree: OctreeOptions::default(),
            smooth: 3,
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
    // Point evaluations from here on use the leaves' pruned programs.
    let field = tree.field(f);
    let mut values = extract::CornerValues::at_leaves(&tree, &field, t);
    let (active, dual_cells) = extract::active_cells(&tree, &field, t, &mut values);
    let dual_ms = ms(t0);

    progress(Stage::Polygonize);
    let t0 = Instant::now();
    let (mut mesh, ex) = extract::extract(&tree, &field, t, &values, &active);
    let polygonize_ms = ms(t0);

    progress(Stage::Smooth);
    let t0 = Instant::now();
    let moves = smooth::smooth(&mut mesh, &field, t, opts.smooth);
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

/// What [`mesh_to_tolerance`] achieved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToleranceReport {
    /// The tolerance asked for (domain units).
    pub tolerance: f64,
    /// The largest measured triangle-to-surface distance of the returned
    /// mesh ([`super::deviation::max_deviation`]; `+∞` when a sample could
    /// not be projected).
    pub max_deviation: f64,
    /// `max_deviation <= tolerance`.
    pub met: bool,
    /// The geometry criterion `k_max` of the returned mesh.
    pub kmax: f64,
    /// Meshes built.
    pub passes: usize,
    /// Wall time of all passes, deviation measurements included (ms).
    pub total_ms: f64,
}

/// Smallest `k_max` [`mesh_to_tolerance`] tries.
const KMAX_FLOOR: f64 = 1e-3;
/// Most meshes [`mesh_to_tolerance`] builds.
const MAX_PASSES: usize = 10;

/// Meshes like [`mesh_with`], then measures the mesh's deviation from the
/// surface and, while it exceeds `tolerance`, meshes again with a smaller
/// geometry criterion `k_max` (starting from `opts.octree.kmax`), up to
/// `opts.octree.max_level`.
///
/// The octree's geometry criterion subdivides a cell while the spread of
/// its normals exceeds `k_max`; a triangle's chord error grows like the
/// square of its size times the curvature, so lowering `k_max` refines
/// only where the surface bends — flat regions keep large cells. Each pass
/// scales `k_max` by `√(tolerance / deviation)` (clamped to `[0.1, 0.7]`).
/// It stops when the tolerance is met, when `k_max` reaches 10⁻³, after 10
/// passes, or when the maximal level is reached and the deviation no longer
/// shrinks (the cap is too coarse: `met` is then false).
///
/// # Limits
///
/// `k_max` is one number for the whole domain: where the surface is flat
/// but the deviation is set by a distant high-curvature region, cells are
/// finer than the tolerance alone would need. The deviation is measured at
/// centroids and edge midpoints only (see [`super::deviation`]).
pub fn mesh_to_tolerance<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    tolerance: f64,
    progress: &(dyn Fn(Stage) + Sync),
) -> (Mesh, MeshReport, ToleranceReport) {
    let start = Instant::now();
    let t = opts.octree.t;
    let mut o = *opts;
    let mut passes = 0;
    let mut previous = f64::INFINITY;
    loop {
        passes += 1;
        let (mesh, report) = mesh_with(f, domain, &o, progress);
        // A triangle's corners lie on the surface, so the surface is within
        // one edge length of every sample; the projection may search twice
        // that.
        let reach = 2.0 * longest_edge(&mesh) + f64::MIN_POSITIVE;
        let dev = super::deviation::max_deviation(&mesh, f, t, reach);
        let met = dev <= tolerance;
        let at_cap = report.octree.max_level_reached >= o.octree.max_level;
        let stalled = at_cap && dev >= 0.95 * previous;
        if met || stalled || o.octree.kmax <= KMAX_FLOOR || passes >= MAX_PASSES {
            let r = ToleranceReport {
                tolerance,
                max_deviation: dev,
                met,
                kmax: o.octree.kmax,
                passes,
                total_ms: ms(start),
            };
            return (mesh, report, r);
        }
        previous = dev;
        let scale = if dev.is_finite() && dev > 0.0 {
            (tolerance / dev).sqrt().clamp(0.1, 0.7)
        } else {
            0.1
        };
        o.octree.kmax = (o.octree.kmax * scale).max(KMAX_FLOOR);
    }
}

fn longest_edge(mesh: &Mesh) -> f64 {
    let p = &mesh.positions;
    mesh.triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (p[a as usize] - p[b as usize]).length())
        .fold(0.0, f64::max)
}
