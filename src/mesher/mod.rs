//! The robust adaptive mesher end to end (Paiva et al. §4): octree →
//! dual grid → dual marching cubes (MC33) with vertices bisected onto the
//! surface → coincident vertices welded ([`weld`]) → sharp creases
//! ([`crease`]) → with a chord tolerance and smoothing on, flat regions
//! retriangulated ([`planar`]) and measured edge collapses ([`coarsen`])
//! → smoothing (edge flips and tangential
//! relaxation) → chord splits ([`chord`]), two smoothing passes around
//! them held to the tolerance and a last chord round, and the weld again
//! → report.
//! The report's topology is computed from the mesh itself
//! ([`crate::mesh::topology`]), never assumed.
//!
//! Every stage evaluates the function through one [`Evaluator`] at the
//! octree's time: [`mesh_with`] takes any evaluator and a domain, [`mesh`]
//! is [`mesh_with`] on a compiled [`Surface`] and its own domain.

use std::time::Instant;

use glam::DVec3;

pub mod adapt;
pub mod brick;
pub mod chord;
pub mod coarsen;
pub mod crease;
pub mod flip;
pub mod planar;
pub mod report;
mod sag;
pub mod settle;
pub mod smooth;
pub mod stitch;
pub mod weld;

use crate::cancel::{Cancel, Cancelled, uncancelled};
use crate::eval::Evaluator;
use crate::eval::within::Within;
use crate::geometry::Bounds;
use crate::mesh::order::{permute, retain};
use crate::mesh::origin::Origins;
use crate::mesh::{Mesh, quality, topology};
use crate::octree::{Chord, Octree, OctreeOptions, OctreeStats, Refine};
use crate::polygonize::extract;
use crate::surface::Surface;

/// Options of [`mesh`] (SPEC §2 `isoc mesh`).
///
/// # Example
///
/// A torus (genus 1) meshed with the stronger topology test and no
/// smoothing, on a domain smaller than the file's: the octree refines to
/// level 6 where the topology criterion asks for it.
///
/// ```
/// use isoc::octree::TopologyTest;
/// use isoc::{Bounds, CompileOptions, MeshOptions, OctreeOptions, Surface};
///
/// let torus = Surface::compile(
///     "domain [-3, 3]^3; surface (sqrt(x^2 + y^2) - 1)^2 + z^2 = 0.2;",
///     "torus.iso",
///     &CompileOptions::default(),
/// )?;
/// let opts = MeshOptions {
///     octree: OctreeOptions {
///         max_level: 6,
///         test: TopologyTest::Certify,
///         ..OctreeOptions::default()
///     },
///     smooth: 0,
///     domain: Some(Bounds { lo: [-2.0; 3], hi: [2.0; 3] }),
///     ..MeshOptions::default()
/// };
/// let (mesh, report) = isoc::mesher::mesh(&torus, &opts, &|_stage| {});
/// assert!(report.topology.watertight);
/// assert_eq!(report.topology.genus, vec![Some(1)]);
/// // Every vertex is on the surface (bisected to machine precision).
/// assert!(mesh.positions.iter().all(|p| torus.point([p.x, p.y, p.z, 0.0]).abs() < 1e-12));
/// # Ok::<(), isoc::Error>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct MeshOptions {
    /// Options of the octree: levels, criteria, topology test, time.
    pub octree: OctreeOptions,
    /// Smoothing passes (`--smooth`): edge flips and tangential relaxation
    /// ([`smooth::smooth`]).
    pub smooth: usize,
    /// The domain; `None` means the surface's own.
    pub domain: Option<Bounds>,
    /// Put vertices on sharp creases (CSG edges and corners) and join them
    /// by edges ([`crease`]; `--no-creases` turns it off).
    pub creases: bool,
}

impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions {
            octree: OctreeOptions::default(),
            smooth: 3,
            domain: None,
            creases: true,
        }
    }
}

/// Milliseconds spent per stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Timings {
    /// Milliseconds in the octree stage.
    pub octree: f64,
    /// Milliseconds in the dual grid stage (corner values, active cells).
    pub dual: f64,
    /// Milliseconds in dual marching cubes, vertex bisection included.
    pub polygonize: f64,
    /// Milliseconds in smoothing.
    pub smooth: f64,
    /// Milliseconds adapting the mesh to a tolerance ([`adapt`]; the last
    /// pass of [`mesh_to_tolerance`], 0 otherwise).
    pub adapt: f64,
    /// Milliseconds for the whole run.
    pub total: f64,
}

/// What a mesh run found (the fields of SPEC §2 `--stats json`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeshReport {
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Vertices of the mesh.
    pub vertices: usize,
    /// Share of triangles with aspect ratio > 0.8.
    pub aspect_good: f64,
    /// Components, genera and manifold checks, computed from the mesh.
    pub topology: topology::Topology,
    /// Leaves left ambiguous (topology criterion still failing at the
    /// maximal level, or `F` not defined everywhere on the cell).
    pub ambiguous_cells: usize,
    /// True only when no leaf is ambiguous.
    pub guaranteed: bool,
    /// Counts of the octree's nodes and leaves.
    pub octree: OctreeStats,
    /// Dual cells visited.
    pub dual_cells: usize,
    /// Dual cells whose corner values change sign (the ones polygonised).
    pub active_cells: usize,
    /// Vertex moves accepted by smoothing, over all passes.
    pub smoothing_moves: usize,
    /// Vertices placed on sharp creases ([`crease`]).
    pub crease_vertices: usize,
    /// Time spent per stage.
    pub timings: Timings,
}

/// Stage names reported to the progress callback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// An octree level is done.
    Octree {
        /// The level just finished.
        level: u8,
        /// Cells evaluated so far.
        cells: usize,
    },
    /// The dual grid stage starts.
    Dual,
    /// Dual marching cubes starts.
    Polygonize,
    /// Smoothing starts.
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

/// [`mesh`] that stops with [`Cancelled`] soon after `cancel` is
/// cancelled: [`mesh_with_cancellable`] on the surface.
pub fn mesh_cancellable(
    surface: &Surface,
    opts: &MeshOptions,
    progress: &(dyn Fn(Stage) + Sync),
    cancel: &Cancel,
) -> Result<(Mesh, MeshReport), Cancelled> {
    mesh_with_cancellable(surface, surface.domain, opts, progress, cancel)
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
    uncancelled(|never| mesh_with_cancellable(f, domain, opts, progress, never))
}

/// [`mesh_with`] that stops with [`Cancelled`] soon after `cancel` is
/// cancelled. Every stage polls the token: the octree per level and per
/// batch of cells ([`Octree::build_cancellable`]), extraction per task of
/// cells, chord refinement per round, smoothing per pass and colour
/// class, and the mesher between stages; a cancelled run returns nothing.
pub fn mesh_with_cancellable<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    progress: &(dyn Fn(Stage) + Sync),
    cancel: &Cancel,
) -> Result<(Mesh, MeshReport), Cancelled> {
    let refine = Refine::default();
    // On a pool thread ([`crate::parallel::on_pool`]).
    let (mesh, report, _, _) = crate::parallel::on_pool(|| {
        mesh_refining(f, domain, opts, &refine, true, progress, cancel)
    })?;
    Ok((mesh, report))
}

/// [`mesh_with`] on an octree that also subdivides the cells of `refine`
/// ([`Octree::build_refining`]); returns the octree and the crease
/// vertices' flags too. Without `analyze` the report's topology and
/// `aspect_good` are left at their defaults (for a mesh changed next).
fn mesh_refining<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    refine: &Refine,
    analyze: bool,
    progress: &(dyn Fn(Stage) + Sync),
    cancel: &Cancel,
) -> Result<(Mesh, MeshReport, Octree, Vec<bool>), Cancelled> {
    let start = Instant::now();
    let domain = opts.domain.unwrap_or(domain);
    let t = opts.octree.t;
    let t0 = Instant::now();
    let tree = Octree::build_cancellable(
        f,
        domain,
        &opts.octree,
        refine,
        &|level, cells| progress(Stage::Octree { level, cells }),
        cancel,
    )?;
    let octree_ms = ms(t0);

    cancel.check()?;
    progress(Stage::Dual);
    let t0 = Instant::now();
    // Point evaluations from here on use the leaves' pruned programs.
    let field = tree.field(f);
    let mut values = extract::CornerValues::at_leaves(&tree, &field, t);
    let (active, dual_cells) = extract::active_cells(&tree, &field, t, &mut values);
    let dual_ms = ms(t0);

    cancel.check()?;
    progress(Stage::Polygonize);
    let t0 = Instant::now();
    let tau = opts.octree.chord_tolerance(domain);
    let (mut mesh, ex, mut cell_of) = extract::extract(&tree, &field, t, &values, &active, cancel)?;
    weld::weld_coincident(&mut mesh, &mut cell_of);
    cancel.check()?;
    let mut creases = if opts.creases {
        let bounds = |c: u32| extract::cell_bounds(&tree, &active[c as usize]);
        crease::sharpen(&mut mesh, &cell_of, &bounds, &domain, &field, t, |_, _| ()).0
    } else {
        crease::Creases::default()
    };
    // The dual grid's data is not needed past the creases: free it before
    // the stages that add to the mesh.
    drop((values, active, cell_of));
    permute(&mut creases.feature, &mesh.reorder());
    let polygonize_ms = ms(t0);

    cancel.check()?;
    progress(Stage::Smooth);
    let t0 = Instant::now();
    // Vertices move and split onto `f = 0` within Ω only.
    let field = Within::new(&field, domain);
    if let Some(tau) = tau
        && opts.smooth > 0
    {
        let marks = coarsen::Marks {
            pinned: &[],
            crease: &creases.feature,
            domain: Some(domain),
        };
        let kept = coarsen::coarsen(&mut mesh, marks, &field, t, tau, cancel)?;
        retain(&mut creases.feature, &kept);
    }
    let moves =
        smooth::smooth_keeping(&mut mesh, &field, t, opts.smooth, &creases.feature, cancel)?;
    if let Some(tau) = tau {
        split_after_smoothing(
            &mut mesh,
            &mut creases.feature,
            None,
            &field,
            t,
            tau,
            opts,
            cancel,
        )?;
    }
    let smooth_ms = ms(t0);
    cancel.check()?;

    let (topo, aspect_good) = if analyze {
        (
            topology::analyze_in(&mesh, Some(&domain)),
            quality::aspect_good(&mesh),
        )
    } else {
        (topology::Topology::default(), 0.0)
    };
    let report = MeshReport {
        triangles: mesh.triangles.len(),
        vertices: mesh.positions.len(),
        aspect_good,
        topology: topo,
        ambiguous_cells: tree.stats.ambiguous_leaves,
        guaranteed: tree.stats.ambiguous_leaves == 0,
        octree: tree.stats,
        dual_cells,
        active_cells: ex.active_cells,
        smoothing_moves: moves,
        crease_vertices: creases.cells,
        timings: Timings {
            octree: octree_ms,
            dual: dual_ms,
            polygonize: polygonize_ms,
            smooth: smooth_ms,
            adapt: 0.0,
            total: ms(start),
        },
    };
    Ok((mesh, report, tree, creases.feature))
}

/// The chord splits of a coarsened and smoothed mesh (of the mesh as
/// extracted with `opts.smooth` 0), as the whole run and each brick
/// ([`brick`], with its vertices' `origins`) make them: the rounds of
/// [`chord::split_edges_in`]; with smoothing on, two passes that even out the
/// shapes (a single split makes two 30-60-90 triangles of an equilateral
/// one) and the sags, whose flips and moves make no edge the splits would
/// split ([`settle::settle`]); one more round
/// (for a brick, numbered after the others); and the coincident vertices
/// welded. With `opts.creases` (the crease pass ran), an edge across a
/// crease is split onto it ([`chord`]).
///
/// Splitting after the collapses rather than before them splits only what
/// the coarsened mesh needs: on decocube at level 8, 117k triangles were
/// extracted, 103k more split before coarsening and 83k of them collapsed
/// again (`docs/faithful.md`).
#[allow(clippy::too_many_arguments)]
fn split_after_smoothing<E: Evaluator + ?Sized>(
    mesh: &mut Mesh,
    feature: &mut Vec<bool>,
    mut origins: Option<&mut Origins>,
    f: &E,
    t: f64,
    tau: Chord,
    opts: &MeshOptions,
    cancel: &Cancel,
) -> Result<(), Cancelled> {
    // A centroid's split reads the edge's triangles: with smoothing off, a
    // brick's seam must split as the whole run does, edge by edge.
    let rules = chord::Rules {
        creases: opts.creases,
        centroids: opts.smooth > 0,
    };
    let seam = |mesh: &Mesh, origins: Option<&Origins>| match origins {
        Some(o) => brick::seam(mesh, o),
        None => Vec::new(),
    };
    chord::split_edges_in(
        mesh,
        feature,
        origins.as_deref_mut(),
        f,
        t,
        tau,
        rules,
        cancel,
    )?;
    if opts.smooth > 0 {
        // A brick's seam stays.
        let mut still = seam(mesh, origins.as_deref());
        still.resize(mesh.positions.len(), false);
        settle::settle(mesh, f, t, feature, &still, tau, cancel)?;
    }
    // The round after smoothing: numbered after the others.
    let round = origins.as_deref_mut().map(|o| (o, chord::ROUNDS as u32));
    chord::split_round_in(mesh, feature, round, f, t, tau, rules);
    let on_seam = seam(mesh, origins.as_deref());
    weld::weld_coincident_in(mesh, &mut Vec::new(), &on_seam, origins, Some(feature));
    Ok(())
}

/// What [`mesh_to_tolerance`] achieved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToleranceReport {
    /// The tolerance asked for (domain units).
    pub tolerance: f64,
    /// The largest measured triangle-to-surface distance of the returned
    /// mesh ([`crate::mesh::deviation::max_deviation`]; `+∞` when a sample could
    /// not be projected).
    pub max_deviation: f64,
    /// `max_deviation <= tolerance`.
    pub met: bool,
    /// The geometry criterion `k_max` of the returned mesh.
    pub kmax: f64,
    /// Meshes built (octree passes).
    pub passes: usize,
    /// What the adaptation on the surface did, over all passes
    /// ([`adapt`]).
    pub adapted: adapt::Adapted,
    /// Wall time of all passes, deviation measurements included (ms).
    pub total_ms: f64,
}

/// Most meshes [`mesh_to_tolerance`] builds.
const MAX_PASSES: usize = 12;

/// Meshes `f = 0` so that every triangle lies within `tolerance` of the
/// surface, as measured at its centroid and edge midpoints
/// ([`crate::mesh::deviation`]), with `opts.octree.max_level` as the cap.
///
/// 1. **The octree decides the topology.** The first mesh is
///    [`mesh_with`]'s at the default level 7 (or the cap, if lower),
///    without smoothing; its octree's criteria and guarantees are
///    [`mesh_with`]'s.
/// 2. **The surface decides the size** ([`adapt`]): the mesh is remeshed on
///    the surface — edge lengths sized from the measured deviations,
///    splits, collapses, flips and relaxation, every vertex projected onto
///    `f = 0`, topology and orientation kept — and the triangles still
///    outside the tolerance are repaired by measured flips and splits.
///    Flat regions get large triangles, curved ones small ones.
/// 3. **The mesh is measured again**, on its own, and is returned if every
///    triangle is within the tolerance.
/// 4. **Otherwise** (where ∇f vanishes on the surface, at a cusp or a
///    pinch, some splits find no surface point), it falls back to refining
///    the octree: a mesh at the cap (with `opts.smooth` passes), then
///    meshes on octrees that also subdivide the leaves under the offending
///    triangles' corners, centroids and edge quarter points
///    ([`Octree::build_refining`]; the set only grows). When no offending
///    leaf can be split, or two passes did not lower the deviation by a
///    quarter, the geometry criterion `k_max` is lowered everywhere (by
///    `√(tolerance / deviation)`, clamped to `[0.1, 0.7]`, down to 10⁻³), at
///    most twice. It stops when the tolerance is met, after 12 meshes, or
///    when it stalls with no lowering left (`met` is then false).
///
/// The returned report's `max_deviation` is measured on the returned mesh;
/// `met` is true only when no measured point is farther than `tolerance`.
///
/// # Limits
///
/// The deviation is measured at four points per triangle only. The
/// adaptation does not test triangles against distant parts of the mesh
/// (two sheets closer than an edge). The fallback rebuilds each octree from
/// the root, so its time is the sum of its passes'.
pub fn mesh_to_tolerance<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    tolerance: f64,
    progress: &(dyn Fn(Stage) + Sync),
) -> (Mesh, MeshReport, ToleranceReport) {
    uncancelled(|never| mesh_to_tolerance_cancellable(f, domain, opts, tolerance, progress, never))
}

/// [`mesh_to_tolerance`] that stops with [`Cancelled`] soon after `cancel`
/// is cancelled (checked in every pass as [`mesh_cancellable`] does, and
/// after the adaptation).
pub fn mesh_to_tolerance_cancellable<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    tolerance: f64,
    progress: &(dyn Fn(Stage) + Sync),
    cancel: &Cancel,
) -> Result<(Mesh, MeshReport, ToleranceReport), Cancelled> {
    crate::parallel::on_pool(|| {
        mesh_to_tolerance_cancellable_here(f, domain, opts, tolerance, progress, cancel)
    })
}

/// [`mesh_to_tolerance_cancellable`] on the calling thread.
fn mesh_to_tolerance_cancellable_here<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    tolerance: f64,
    progress: &(dyn Fn(Stage) + Sync),
    cancel: &Cancel,
) -> Result<(Mesh, MeshReport, ToleranceReport), Cancelled> {
    let start = Instant::now();
    let t = opts.octree.t;
    let mut refine = Refine::default();
    let mut o = *opts;
    let cap = opts.octree.max_level;
    // The first octree is `mesh`'s at its default level (or the cap, if
    // lower): the adaptation on the surface, not the octree, meets the
    // tolerance. Later passes may refine the octree up to the cap.
    o.octree.max_level = cap.min(OctreeOptions::default().max_level);
    // The tolerance, not the level, decides the size: the octree's chord
    // criterion would only refine what the adaptation coarsens again.
    o.octree.chord = None;
    // The adaptation relaxes the mesh itself, with its tolerance checked;
    // smoothing the extracted mesh first would be undone.
    o.smooth = 0;
    let mut passes = 0;
    let (mut best, mut stuck, mut lowerings) = (f64::INFINITY, 0, 0);
    let mut adapted = adapt::Adapted::default();
    loop {
        passes += 1;
        // The first mesh is adapted and analysed after that.
        let (mut mesh, mut report, tree, feature) =
            mesh_refining(f, domain, &o, &refine, passes > 1, progress, cancel)?;
        if passes == 1 {
            // Adapt the first mesh on the surface. Should that fail to
            // meet the tolerance (where ∇f vanishes, as at a cusp, some
            // splits find no surface point), the passes after it refine
            // the octree where the adapted triangles are too far, up to
            // the cap, with the mesher's own smoothing instead.
            let t0 = Instant::now();
            // No edge is split below a quarter of the tolerance (a
            // triangle no larger than the tolerance is within it, its
            // corners being on the surface) nor below an eighth of the
            // cap's cells (the finest detail `--level` allows).
            let bounds = o.domain.unwrap_or(domain);
            let cell = (0..3)
                .map(|k| (bounds.hi[k] - bounds.lo[k]) / f64::from(1u32 << cap.min(30)))
                .fold(f64::INFINITY, f64::min);
            let min_edge = (MIN_EDGE * tolerance).max(cell / 8.0);
            adapted = adapt::adapt(&mut mesh, &feature, (f, t), bounds, tolerance, min_edge);
            report.triangles = mesh.triangles.len();
            report.vertices = mesh.positions.len();
            report.aspect_good = quality::aspect_good(&mesh);
            report.topology = topology::analyze_in(&mesh, Some(&bounds));
            report.timings.adapt = ms(t0);
            cancel.check()?;
            // Any later mesh is the fallback's: at the cap, smoothed.
            o.smooth = opts.smooth;
            o.octree.max_level = cap;
        }
        // A triangle's corners lie on the surface, so the surface is within
        // one edge length of every sample; the projection may search twice
        // that.
        let reach = 2.0 * longest_edge(&mesh) + f64::MIN_POSITIVE;
        let devs = crate::mesh::deviation::triangle_deviations(&mesh, f, t, reach, true);
        let dev = devs.iter().copied().fold(0.0, f64::max);
        let met = dev <= tolerance;
        if !met && passes == 1 {
            // The adapted mesh missed the tolerance: mesh again as `mesh`
            // does at the cap, then refine that octree where its triangles
            // are too far (the loop below).
            continue;
        }
        // The leaves under the offending triangles, where they can still
        // be split.
        let before = refine.len();
        if !met {
            for (tri, _) in mesh
                .triangles
                .iter()
                .zip(&devs)
                .filter(|(_, d)| d.is_nan() || **d > tolerance)
            {
                let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
                // Its corners, centroid and points along its edges: the
                // leaves of its dual cell that make it large.
                let along = |p: DVec3, q: DVec3| [0.25, 0.5, 0.75].map(|s| p.lerp(q, s));
                let points = [a, b, c, (a + b + c) / 3.0]
                    .into_iter()
                    .chain(along(a, b))
                    .chain(along(b, c))
                    .chain(along(c, a));
                for p in points {
                    if let Some(leaf) = tree.leaf_containing(p) {
                        let n = &tree.nodes[leaf];
                        if n.level < cap {
                            refine.insert((n.level, n.ijk));
                        }
                    }
                }
            }
        }
        // Nothing left to split where the triangles are bad, or two passes
        // each without lowering the deviation by a quarter (every such leaf
        // at the cap, or a measurement the leaves do not explain, e.g. near
        // a singular point): tighten the geometry criterion everywhere
        // instead, at most `MAX_LOWERINGS` times.
        if dev < GAIN * best {
            best = dev;
            stuck = 0;
        } else {
            stuck += 1;
        }
        let stalled = !met && (refine.len() == before || stuck >= 2);
        let give_up = stalled && (lowerings >= MAX_LOWERINGS || o.octree.kmax <= KMAX_FLOOR);
        if met || passes >= MAX_PASSES || give_up {
            let r = ToleranceReport {
                tolerance,
                max_deviation: dev,
                met,
                kmax: o.octree.kmax,
                passes,
                adapted,
                total_ms: ms(start),
            };
            report.timings.total = ms(start);
            return Ok((mesh, report, r));
        }
        if stalled {
            let scale = if dev.is_finite() && dev > 0.0 {
                (tolerance / dev).sqrt().clamp(0.1, 0.7)
            } else {
                0.1
            };
            o.octree.kmax = (o.octree.kmax * scale).max(KMAX_FLOOR);
            lowerings += 1;
            stuck = 0;
        }
    }
}

/// No edge shorter than this share of the tolerance is split.
const MIN_EDGE: f64 = 0.25;

/// A fallback pass gains when its deviation is below this share of the
/// best so far.
const GAIN: f64 = 0.75;

/// Most times [`mesh_to_tolerance`] lowers `k_max`.
const MAX_LOWERINGS: usize = 2;

/// Smallest `k_max` [`mesh_to_tolerance`] tries.
const KMAX_FLOOR: f64 = 1e-3;

fn longest_edge(mesh: &Mesh) -> f64 {
    let p = &mesh.positions;
    mesh.triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (p[a as usize] - p[b as usize]).length())
        .fold(0.0, f64::max)
}
