//! Bricked meshing (SPEC §2 `--bricks`): the domain cut at octree level
//! `B` into `8^B` bricks, each meshed on its own, the parts welded by their
//! vertices' ids.
//!
//! # Contract
//!
//! Every vertex of the octree's cell complex — and so every dual cell —
//! belongs to exactly one brick: the brick whose half-open box holds it
//! (closed on Ω's high faces). A brick ([`mesh_brick`]) builds the octree
//! only where it meets its closed box ([`Octree::build_region`]: those
//! nodes are the whole tree's, with the same fates and programs), and
//! polygonises its own dual cells with the whole run's rules; its
//! vertices carry [`Origins`], ids that depend on the structure that made
//! them, by which [`super::stitch`] welds the parts. Then:
//!
//! - **with `smooth = 0` and no creases, the union of the parts is the
//!   whole run's mesh**: the same triangles over the same positions, bit
//!   for bit ([`merge`] welds equal ids). Extraction, the weld of
//!   coincident vertices and the chord splits decide each vertex, edge and
//!   triangle from its own structure (see [`super::weld`], [`super::chord`]).
//! - **With smoothing or creases**, the vertices on a seam (an edge with
//!   one triangle in the part, off ∂Ω) are pinned: both sides keep them
//!   where extraction and the chord splits put them, so the seams stay
//!   closed and 2-manifold; inside a brick the stages run as in a whole
//!   run, on the brick's triangles only (the collapses of
//!   [`super::coarsen`] too: a seam vertex is never removed).
//!
//! # Limits
//!
//! - Exact equality needs the whole run to make the same choices: it does
//!   unless the octree's pruned programs outgrow their store (see
//!   [`Octree::build_region`]), or a cluster of coincident vertices (`f`
//!   exactly 0 at a leaf centre) lies on a seam (the part leaves it
//!   unwelded).
//! - Each brick repeats the levels of the octree above `B` (and, with
//!   pruning, those whose choice of evaluator is not settled yet): cheap
//!   for `B ≤ 3`, the point of bricks being levels far below.
//! - `--tolerance` is a whole-mesh adaptation: it is not bricked.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;

use super::stitch::{Stitched, Stitcher};
use super::{MeshOptions, MeshReport, Stage, Timings, coarsen, crease, ms, smooth, weld};
use crate::cancel::{Cancel, Cancelled};
use crate::dual;
use crate::eval::Evaluator;
use crate::eval::within::Within;
use crate::geometry::Bounds;
use crate::mesh::order::{permute, retain};
use crate::mesh::origin::{self, Origins};
use crate::mesh::sink::Sink;
use crate::mesh::{Mesh, topology};
use crate::octree::{MAX_LEVEL, Node, Octree, OctreeStats, Region, SharedLevels, TopologyTest};
use crate::polygonize::extract;
use crate::surface::Surface;

/// Deepest brick level: `8^6` bricks.
pub const MAX_BRICK_LEVEL: u8 = 6;

/// One brick of `8^level`, by its integer position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Brick {
    /// Brick level `B`: `2^B` bricks along each axis.
    pub level: u8,
    /// Integer position, each in `[0, 2^B)`.
    pub ijk: [u32; 3],
}

impl Brick {
    /// Brick `index` of `8^level` (x fastest, then y, then z); `None` when
    /// `level` exceeds [`MAX_BRICK_LEVEL`] or `index` is out of range.
    pub fn new(level: u8, index: u32) -> Option<Brick> {
        let n = 1u32 << level.min(MAX_BRICK_LEVEL);
        (level <= MAX_BRICK_LEVEL && u64::from(index) < u64::from(n).pow(3)).then(|| Brick {
            level,
            ijk: [index % n, (index / n) % n, index / (n * n)],
        })
    }

    /// How many bricks level `level` has.
    pub fn count(level: u8) -> u32 {
        1u32 << (3 * u32::from(level.min(MAX_BRICK_LEVEL)))
    }

    /// The brick's index (the inverse of [`Brick::new`]).
    pub fn index(&self) -> u32 {
        let n = 1u32 << self.level;
        self.ijk[0] + n * (self.ijk[1] + n * self.ijk[2])
    }

    /// Low corner and side, in units of a maximal-level cell.
    fn span(&self) -> ([u64; 3], u64) {
        let side = 1u64 << (MAX_LEVEL - self.level);
        (self.ijk.map(|k| u64::from(k) * side), side)
    }

    /// The octree the brick needs, for leaves of level at most
    /// `max_level`: its closed box and one such leaf around it (where
    /// extraction finds the samples it mends, [`crate::polygonize`]'s
    /// isolated samples), within Ω.
    pub fn region(&self, max_level: u8) -> Region {
        let (lo, side) = self.span();
        let leaf = 1u64 << (MAX_LEVEL - max_level.min(MAX_LEVEL));
        let top = 1u64 << MAX_LEVEL;
        Region {
            lo: lo.map(|k| k.saturating_sub(leaf)),
            hi: lo.map(|k| (k + side + leaf).min(top)),
        }
    }

    /// Whether the brick owns the grid point `v` (units of a maximal-level
    /// cell): its half-open box, closed on Ω's high faces.
    pub fn owns(&self, v: [u64; 3]) -> bool {
        let (lo, side) = self.span();
        let top = 1u64 << MAX_LEVEL;
        (0..3)
            .all(|k| lo[k] <= v[k] && (v[k] < lo[k] + side || (v[k] == top && lo[k] + side == top)))
    }

    /// Whether the brick owns node `n` (its low corner).
    fn owns_node(&self, n: &Node) -> bool {
        self.owns(n.grid_box()[0])
    }
}

/// A brick's mesh and its vertices' origins.
#[derive(Clone, Debug)]
pub struct Part {
    /// The brick's triangles (open along its seams).
    pub mesh: Mesh,
    /// Per vertex, its id and the faces of Ω it lies on.
    pub origins: Origins,
    /// The brick's share of the whole run's figures (see [`merge_reports`]).
    pub report: MeshReport,
}

/// Meshes brick `brick` of `f(·, opts.octree.t) = 0` over `opts.domain`
/// or `domain` (see the module doc). `progress` is told as
/// [`super::mesh_with`] tells it.
pub fn mesh_brick<E: Evaluator + ?Sized>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    brick: Brick,
    progress: &(dyn Fn(Stage) + Sync),
    cancel: &Cancel,
) -> Result<Part, Cancelled> {
    let domain = opts.domain.unwrap_or(domain);
    let levels = |level, cells| progress(Stage::Octree { level, cells });
    let shared = Octree::build_shared(f, domain, &opts.octree, &levels, cancel)?;
    mesh_brick_from(&shared, domain, opts, brick, progress, cancel)
}

/// [`mesh_brick`] from the levels every brick shares, built once
/// ([`Octree::build_shared`] of the same `f`, `domain` and options).
pub fn mesh_brick_from<E: Evaluator + ?Sized>(
    shared: &SharedLevels<'_, E>,
    domain: Bounds,
    opts: &MeshOptions,
    brick: Brick,
    progress: &(dyn Fn(Stage) + Sync),
    cancel: &Cancel,
) -> Result<Part, Cancelled> {
    crate::parallel::on_pool(|| mesh_brick_from_here(shared, domain, opts, brick, progress, cancel))
}

/// [`mesh_brick_from`] on the calling thread.
fn mesh_brick_from_here<E: Evaluator + ?Sized>(
    shared: &SharedLevels<'_, E>,
    domain: Bounds,
    opts: &MeshOptions,
    brick: Brick,
    progress: &(dyn Fn(Stage) + Sync),
    cancel: &Cancel,
) -> Result<Part, Cancelled> {
    let start = Instant::now();
    let f = shared.evaluator();
    let t = opts.octree.t;
    let t0 = Instant::now();
    let tree = Octree::build_region_from(
        shared,
        brick.region(shared.max_level()),
        &|level, cells| progress(Stage::Octree { level, cells }),
        cancel,
    )?;
    let octree_ms = ms(t0);

    cancel.check()?;
    progress(Stage::Dual);
    let t0 = Instant::now();
    let field = tree.field(f);
    let mut values = extract::CornerValues::at_leaves(&tree, &field, t);
    let owns = |cell: &dual::DualCell| brick.owns(dual::vertex(&tree, cell));
    let (active, dual_cells) = extract::active_cells_where(&tree, &field, t, &mut values, owns);
    let dual_ms = ms(t0);

    cancel.check()?;
    progress(Stage::Polygonize);
    let t0 = Instant::now();
    let (mut mesh, ex, mut cell_of, mut origins) =
        extract::extract_with_origins(&tree, &field, t, &values, &active, cancel)?;
    let on_seam = seam(&mesh, &origins);
    weld::weld_coincident_in(&mut mesh, &mut cell_of, &on_seam, Some(&mut origins), None);
    let (mut feature, crease_cells) = if opts.creases {
        let bounds = |c: u32| extract::cell_bounds(&tree, &active[c as usize]);
        let name =
            |m: &Mesh, n0| name_crease_points(&mut origins, brick, &m.positions[n0..], domain, n0);
        let (c, used) = crease::sharpen(&mut mesh, &cell_of, &bounds, &domain, &field, t, name);
        origins.retain(&used);
        (c.feature, c.cells)
    } else {
        (vec![false; mesh.positions.len()], 0)
    };
    drop((values, active, cell_of));
    let new_of_old = mesh.reorder();
    permute(&mut feature, &new_of_old);
    permute(&mut origins.ids, &new_of_old);
    permute(&mut origins.sides, &new_of_old);
    let tau = opts.octree.chord_tolerance(domain);
    let polygonize_ms = ms(t0);

    cancel.check()?;
    progress(Stage::Smooth);
    let t0 = Instant::now();
    // As the whole run: vertices move and split within Ω only.
    let field = Within::new(&field, domain);
    if let Some(tau) = tau
        && opts.smooth > 0
    {
        let on_seam = seam(&mesh, &origins);
        let marks = coarsen::Marks {
            pinned: &on_seam,
            crease: &feature,
            domain: Some(domain),
        };
        let kept = coarsen::coarsen(&mut mesh, marks, &field, t, tau, cancel)?;
        retain(&mut feature, &kept);
        origins.retain(&kept);
    }
    let on_seam = seam(&mesh, &origins);
    let moves = smooth::smooth_part(
        &mut mesh,
        &field,
        t,
        opts.smooth,
        &feature,
        &on_seam,
        cancel,
    )?;
    if let Some(tau) = tau {
        let origins = Some(&mut origins);
        super::split_after_smoothing(
            &mut mesh,
            &mut feature,
            origins,
            &field,
            t,
            tau,
            opts,
            cancel,
        )?;
    }
    let smooth_ms = ms(t0);

    let octree = owned_stats(&tree, brick);
    let report = MeshReport {
        triangles: mesh.triangles.len(),
        vertices: mesh.positions.len(),
        aspect_good: 0.0,
        topology: topology::Topology::default(),
        ambiguous_cells: octree.ambiguous_leaves,
        guaranteed: octree.ambiguous_leaves == 0,
        octree,
        dual_cells,
        active_cells: ex.active_cells,
        smoothing_moves: moves,
        crease_vertices: crease_cells,
        timings: Timings {
            octree: octree_ms,
            dual: dual_ms,
            polygonize: polygonize_ms,
            smooth: smooth_ms,
            adapt: 0.0,
            total: ms(start),
        },
    };
    Ok(Part {
        mesh,
        origins,
        report,
    })
}

/// What a part file says of itself ([`crate::io::part`]'s info line): which
/// brick of which run, and the brick's report.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PartInfo {
    /// The brick level `B` of the run.
    pub bricks: u8,
    /// The brick's index ([`Brick::index`]).
    pub brick: u32,
    /// The run ([`run_id`]): parts of different runs do not weld.
    pub run: String,
    /// Whether the run's topology test was the stricter one (`--certify`).
    #[serde(default)]
    pub certify: bool,
    /// The brick's report ([`Part::report`]).
    pub report: MeshReport,
}

/// A fingerprint of a bricked run: of the surface's program text, the
/// domain and the options (their `Debug` forms), so that parts of one run
/// are told from parts of another.
pub fn run_id(program: &str, domain: &Bounds, opts: &MeshOptions) -> String {
    let text = format!("{program}|{domain:?}|{opts:?}");
    let id = text.as_bytes().chunks(16).fold(0u128, |h, c| {
        let mut w = [0u8; 16];
        w[..c.len()].copy_from_slice(c);
        origin::mix(origin::RUN, h, u128::from_le_bytes(w))
    });
    format!("{id:032x}")
}

impl PartInfo {
    /// The info line of a part file (one line of JSON).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("a part's info is plain data")
    }

    /// Reads an info line back.
    pub fn from_json(text: &str) -> Result<PartInfo, String> {
        serde_json::from_str(text).map_err(|e| e.to_string())
    }
}

/// Brick `brick` of `surface`'s bricked run, with its [`PartInfo`] (what
/// a part file carries; [`crate::io::part`]).
pub fn mesh_part(
    surface: &Surface,
    opts: &MeshOptions,
    brick: Brick,
    cancel: &Cancel,
) -> Result<(Part, PartInfo), Cancelled> {
    let part = mesh_brick(surface, surface.domain, opts, brick, &|_| {}, cancel)?;
    let info = PartInfo {
        bricks: brick.level,
        brick: brick.index(),
        run: run_id(&surface.program.to_string(), &surface.domain, opts),
        certify: opts.octree.test == TopologyTest::Certify,
        report: part.report.clone(),
    };
    Ok((part, info))
}

/// Per vertex, whether it is on a seam: an end of an edge with one
/// triangle in the part that does not lie on ∂Ω.
pub fn seam(mesh: &Mesh, origins: &Origins) -> Vec<bool> {
    let mut uses: HashMap<(u32, u32), u32> = HashMap::default();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut on = vec![false; mesh.positions.len()];
    for (&(a, b), &n) in &uses {
        if n == 1 && !origins.on_boundary(a, b) {
            on[a as usize] = true;
            on[b as usize] = true;
        }
    }
    on
}

/// Ids for the feature points `added`, numbered from `n0`, that
/// [`crease::sharpen`] added: they lie inside the brick's cells, so the
/// brick and their number name them. One where a crease leaves Ω lies on
/// that face of Ω.
fn name_crease_points(
    origins: &mut Origins,
    brick: Brick,
    added: &[DVec3],
    domain: Bounds,
    n0: usize,
) {
    for (k, p) in added.iter().enumerate() {
        let id = origin::mix(origin::CREASE, u128::from(brick.index()), (n0 + k) as u128);
        origins.ids.push(id);
        origins.sides.push(domain.faces(p.to_array()));
    }
}

/// The octree's counts over the nodes the brick owns (by their low
/// corners): summed over all bricks, the whole tree's.
fn owned_stats(tree: &Octree, brick: Brick) -> OctreeStats {
    OctreeStats::over(tree.nodes.iter().filter(|n| brick.owns_node(n)))
}

/// Why [`mesh_bricks`] stopped.
#[derive(Debug)]
pub enum BrickError {
    /// The run was cancelled.
    Cancelled,
    /// The sink refused a part.
    Io(std::io::Error),
}

impl From<Cancelled> for BrickError {
    fn from(_: Cancelled) -> Self {
        BrickError::Cancelled
    }
}

impl From<std::io::Error> for BrickError {
    fn from(e: std::io::Error) -> Self {
        BrickError::Io(e)
    }
}

impl std::fmt::Display for BrickError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BrickError::Cancelled => write!(f, "cancelled"),
            BrickError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for BrickError {}

/// Meshes all `8^level` bricks of `f(·, opts.octree.t) = 0` over
/// `opts.domain` or `domain` and welds them into `sink` as they finish
/// ([`Stitcher`]): `2 ×` rayon's threads at a time, added in brick order,
/// so the output does not depend on the thread count and memory holds one
/// batch of parts. `done(k, n)` is told after each batch (`k` of `n`
/// bricks done). The report is [`merge_reports`]'s.
pub fn mesh_bricks<E: Evaluator + ?Sized, S: Sink>(
    f: &E,
    domain: Bounds,
    opts: &MeshOptions,
    level: u8,
    sink: S,
    done: &(dyn Fn(u32, u32) + Sync),
    cancel: &Cancel,
) -> Result<MeshReport, BrickError> {
    let start = Instant::now();
    let domain = opts.domain.unwrap_or(domain);
    let shared = Octree::build_shared(f, domain, &opts.octree, &|_, _| {}, cancel)?;
    let shared_ms = ms(start);
    let count = Brick::count(level);
    let batch = 2 * rayon::current_num_threads() as u32;
    let mut stitcher = Stitcher::new(sink);
    let mut reports = Vec::with_capacity(count as usize);
    for first in (0..count).step_by(batch as usize) {
        let parts = (first..(first + batch).min(count))
            .into_par_iter()
            .map(|i| {
                let brick = Brick::new(level, i).expect("a brick index below the count");
                mesh_brick_from(&shared, domain, opts, brick, &|_| {}, cancel)
            })
            .collect::<Result<Vec<Part>, Cancelled>>()?;
        for p in parts {
            stitcher.add(&p.mesh, &p.origins)?;
            reports.push(p.report);
        }
        done((first + batch).min(count), count);
    }
    let (welded, _) = stitcher.finish();
    let mut report = merge_reports(&reports, &welded, ms(start));
    report.timings.octree += shared_ms;
    Ok(report)
}

/// Welds `parts` into one mesh in memory ([`Stitcher`] into a [`Mesh`]).
pub fn merge<'a>(parts: impl IntoIterator<Item = &'a Part>) -> (Mesh, Stitched) {
    let mut mesh = Mesh::default();
    let mut st = Stitcher::new(&mut mesh);
    for p in parts {
        st.add(&p.mesh, &p.origins)
            .expect("a mesh in memory takes every part");
    }
    let (stitched, _) = st.finish();
    (mesh, stitched)
}

/// The whole run's report from the parts' reports and the welded mesh's
/// figures ([`Stitcher::finish`]): counts summed, the deepest level the
/// deepest, the topology and quality the welded mesh's, `total` the wall
/// time given.
pub fn merge_reports(parts: &[MeshReport], welded: &Stitched, total_ms: f64) -> MeshReport {
    let mut octree = OctreeStats::default();
    let mut r = MeshReport {
        triangles: welded.triangles,
        vertices: welded.vertices,
        aspect_good: welded.aspect_good(),
        topology: welded.topology.clone(),
        ambiguous_cells: 0,
        guaranteed: true,
        octree,
        dual_cells: 0,
        active_cells: 0,
        smoothing_moves: 0,
        crease_vertices: 0,
        timings: Timings::default(),
    };
    for p in parts {
        octree.nodes += p.octree.nodes;
        octree.empty_leaves += p.octree.empty_leaves;
        octree.surface_leaves += p.octree.surface_leaves;
        octree.ambiguous_leaves += p.octree.ambiguous_leaves;
        octree.max_level_reached = octree.max_level_reached.max(p.octree.max_level_reached);
        r.dual_cells += p.dual_cells;
        r.active_cells += p.active_cells;
        r.smoothing_moves += p.smoothing_moves;
        r.crease_vertices += p.crease_vertices;
        let (a, b) = (&mut r.timings, &p.timings);
        a.octree += b.octree;
        a.dual += b.dual;
        a.polygonize += b.polygonize;
        a.smooth += b.smooth;
    }
    r.octree = octree;
    r.ambiguous_cells = octree.ambiguous_leaves;
    r.guaranteed = octree.ambiguous_leaves == 0;
    r.timings.total = total_ms;
    r
}
