//! Twinned meshes for moving surfaces (Bouthors & Nesme, *Twinned meshes
//! for dynamic triangulation of implicit surfaces*, GI 2007): a
//! *mechanical* mesh that follows `f(·, t) = 0` from frame to frame, and a
//! *geometric* mesh rebuilt from it every frame, refined where the surface
//! bends.
//!
//! # Contract
//!
//! [`Tracker::new`] meshes the surface at `t₀` with the robust mesher
//! ([`crate::mesher`]) on a uniform octree whose cells match the
//! target edge length ê (§2.1; no separate relaxation: the first frames
//! relax it). Each [`Tracker::advance`]`(t)` then
//!
//! 1. **watches the topology** over `[t_prev, t]` ([`watch`]): a proof by
//!    interval arithmetic that no critical point crosses the surface
//!    (beyond the paper, whose §5 leaves topology changes open). When the
//!    proof fails in a few cells only, the robust mesher meshes a ball
//!    around them at `t`, at the tracker's resolution, and once the step below has brought the mechanical mesh to `t` that
//!    patch is spliced in ([`splice`]): if the spliced mesh's components
//!    or genera differ from the mechanical mesh's, it is **re-initialised
//!    locally** — the mechanical mesh becomes the spliced one (made from a
//!    coarser patch when that one sees the same topology), and the rest of
//!    the mesh keeps tracking. When the proof fails everywhere, or the
//!    cells are spread wide, or the splice is refused, the robust mesher
//!    decides over the whole domain, and a change re-initialises the whole
//!    mechanical mesh from it;
//! 2. takes one **quasi-static step** (§2.2, eq. 1): `(I − dt ∂f/∂x) Δx =
//!    dt f(x)` with co-rotational elements ([`fem`], eq. 2), solved by
//!    conjugate gradients whose residual and iterates are filtered onto
//!    each vertex's tangent plane (Baraff & Witkin 1998), optionally
//!    followed by the sharp-feature constraint (eq. 4) applied to the
//!    solved displacement (a few times, each from the planes of the last):
//!    the paper applies it inside every CG iteration, which — the iterate
//!    moved off the CG recurrence, the recurrence restarted — did not
//!    converge in our tests (the mesh crumpled on the ‖·‖₁ ball; see the
//!    test `sharp_feature_constraint_aligns_triangles_with_the_gradient`);
//! 3. **projects** every vertex onto `f(·, t) = 0` ([`crate::roots::walk`], eq. 3,
//!    safeguarded); a vertex that cannot be projected within reach means
//!    the mesh lost the surface, and the mechanical mesh is re-initialised
//!    from the robust mesher — unless a pending splice cuts the vertex out
//!    (a neck that splits moves faster than its vertices can follow);
//! 4. **detects inversions** (§2.6) and, while some remain, takes up to
//!    `recovery_steps` further steps at the same `t`, in which inverted
//!    elements get the modified displacements of §2.6.2;
//! 5. **remeshes** ([`remesh`], §2.5): splits, collapses, flips — last,
//!    so that the meshes of a frame have their edges in `[e_min, e_max]·ê`
//!    (it is the paper's "before the next quasi-static step");
//! 6. **rebuilds the geometric mesh** ([`geometric`], §3), deciding
//!    afresh only where the mechanical mesh changed shape since the last
//!    frame and reprojecting the rest of the last frame's refinement.
//!
//! # Cancelling
//!
//! A tracker built with a [`Cancel`] token ([`Tracker::new_cancellable`])
//! polls it while it builds its first mesh and, in each frame, before the
//! topology watch, inside every robust mesh the watch asks for (per octree
//! level and batch, per extraction task) and inside the remeshing sweeps
//! that turn a robust mesh into a mechanical one (every few thousand
//! edges), and last before the first change to its state. A cancelled construction returns [`TrackError::Cancelled`];
//! a cancelled [`Tracker::advance`] returns it too and leaves the tracker
//! at its last frame, unchanged: with a fresh token
//! ([`Tracker::set_cancel`]) a later `advance` works as if the cancelled
//! one had not been asked. Once the mechanical step of a frame
//! has begun the frame runs to its end: the step, remeshing and the
//! geometric mesh take time linear in the mesh, a fraction of a robust
//! mesh's; so does a local re-initialisation (its patch is meshed before
//! the checkpoint; the splice, a coarser patch and the remeshing of the
//! result after it) — except when tracking is lost in the step, or a
//! splice is refused, and the tracker falls back to the robust mesh of
//! the whole domain within the frame (rare; it then takes as long as a
//! first frame).
//!
//! Every vertex of both meshes is on the surface to machine precision
//! (where a Newton walk ends on a short step: [`crate::roots::walk`]);
//! both meshes are closed, oriented 2-manifolds (outward = increasing f)
//! whenever the surface is closed and strictly inside the domain.
//!
//! # Evaluation
//!
//! The tracker evaluates through any [`Evaluator`]
//! ([`Tracker::with_evaluator`]; [`Tracker::new`] takes a compiled
//! [`Surface`]). The gradients at all vertices before a step and at the
//! triangle centroids of the sharp-feature constraint are batches
//! ([`crate::eval::sample::grads_at`]); the projections are sequential
//! Newton walks ([`crate::roots::walk`]), one per vertex, run in parallel; remeshing
//! evaluates one point at a time (see [`remesh`]). The step, projection,
//! remeshing and geometric mesh of a frame evaluate points with `f`
//! compiled anew at the frame's `t` when that folds away a transcendental
//! op or a tenth of the program (`Builder::substitute`: the same point
//! values, one JIT compile a frame); intervals always come from `f`.

pub mod error;
pub(crate) mod fem;
pub mod geometric;
pub mod remesh;
mod splice;
pub mod watch;

use std::time::Instant;

use glam::{DMat3, DVec3};
use rayon::prelude::*;
use serde::Serialize;

use crate::cancel::{Cancel, Cancelled, uncancelled};
use crate::eval::Evaluator;
use crate::eval::sample::grads_at;
use crate::geometry::Bounds;
use crate::interval::Interval;
use crate::ir::{Builder, Op, Program, UnOp, Var};
use crate::mesh::dynmesh::{DynMesh, EdgeKey, key};
use crate::mesh::{Mesh, quality, topology};
use crate::mesher::{self, MeshOptions};
use crate::octree::OctreeOptions;
use crate::surface::Surface;
pub use error::TrackError;
use fem::{Frames, Stiffness};
use splice::Ball;

/// Options of the tracker (`isoc animate`). Defaults follow the paper's
/// Table 1 where it gives values.
#[derive(Clone, Copy, Debug)]
pub struct TwinOptions {
    /// Target mechanical edge length ê; `None`: the domain's largest side
    /// over 40.
    pub edge: Option<f64>,
    /// α_r in degrees (§3); −180 disables refinement.
    pub alpha_deg: f64,
    /// N_p, the most refinement passes (§3).
    pub passes: usize,
    /// Young's modulus E.
    pub young: f64,
    /// Poisson's ratio ν.
    pub poisson: f64,
    /// Time step of the quasi-static solve (eq. 1).
    pub dt: f64,
    /// e_min: edges shorter than `e_min·ê` are collapsed (§2.5).
    pub e_min: f64,
    /// e_max: edges longer than `e_max·ê` are split (§2.5); at least
    /// `2·e_min`.
    pub e_max: f64,
    /// ε_e: tolerance on an edge's length change (§2.5).
    pub eps_e: f64,
    /// Edge flips in remeshing (beyond the paper).
    pub flips: bool,
    /// The sharp-feature constraint (eq. 4).
    pub sharp: bool,
    /// Most conjugate-gradient iterations per quasi-static step (eq. 1).
    pub cg_iterations: usize,
    /// CG stops once the (tangent-filtered) residual's norm is below this
    /// times the right-hand side's.
    pub cg_tolerance: f64,
    /// How far a vertex may move per frame, in units of ê.
    pub max_move: f64,
    /// Extra steps at the same `t` while inverted triangles remain.
    pub recovery_steps: usize,
    /// Watch topology changes (step 1 of the module doc).
    pub watch: bool,
    /// The domain; `None`: the surface's own.
    pub domain: Option<Bounds>,
}

impl Default for TwinOptions {
    fn default() -> Self {
        TwinOptions {
            edge: None,
            alpha_deg: 20.0,
            passes: 4,
            young: 1000.0,
            poisson: 0.3,
            dt: 0.04,
            e_min: 1.0,
            e_max: 2.0,
            eps_e: 0.1,
            flips: true,
            sharp: false,
            cg_iterations: 100,
            cg_tolerance: 1e-3,
            max_move: 4.0,
            recovery_steps: 3,
            watch: true,
            domain: None,
        }
    }
}

/// Milliseconds per part of a frame.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct FrameTimings {
    /// Milliseconds in the topology watch (step 1), re-initialisation
    /// included.
    pub watch: f64,
    /// Milliseconds in the mechanical mesh: steps, projections, inversion
    /// recovery and remeshing (steps 2–5).
    pub mechanical: f64,
    /// Milliseconds rebuilding the geometric mesh (step 6, §3).
    pub geometric: f64,
    /// Milliseconds for the whole frame.
    pub total: f64,
}

/// What one [`Tracker::advance`] did (one entry of `stats.json`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameReport {
    /// The time of this frame.
    pub t: f64,
    /// Triangles of the mechanical mesh at the end of the frame.
    pub mechanical_triangles: usize,
    /// Vertices of the mechanical mesh at the end of the frame.
    pub mechanical_vertices: usize,
    /// Triangles of the geometric mesh (§3).
    pub geometric_triangles: usize,
    /// Vertices of the geometric mesh (§3).
    pub geometric_vertices: usize,
    /// Edge splits of this frame's remeshing (§2.5).
    pub splits: usize,
    /// Edge collapses of this frame's remeshing (§2.5).
    pub collapses: usize,
    /// Edge flips of this frame's remeshing (beyond the paper).
    pub flips: usize,
    /// Edges split by the geometric refinement, over all its passes (§3).
    pub geometric_splits: usize,
    /// The geometric refinement stopped at its triangle budget.
    pub geometric_budget_hit: bool,
    /// Triangles found inverted after this frame's first step.
    pub inverted_found: usize,
    /// Of those, the ones the recovery steps turned back.
    pub inverted_repaired: usize,
    /// Inverted triangles left at the end of the frame.
    pub inverted_left: usize,
    /// Conjugate-gradient iterations of all this frame's steps, recovery
    /// steps included.
    pub cg_iterations: usize,
    /// Share of mechanical triangles with aspect ratio > 0.8.
    pub aspect_good: f64,
    /// The topology was proved unchanged since the last frame.
    pub topology_certified: bool,
    /// Why the mechanical mesh was rebuilt by the robust mesher this
    /// frame, if it was.
    pub reinitialized: Option<String>,
    /// Where the mechanical mesh was re-meshed locally this frame (a robust
    /// mesh of a ball spliced in, [`splice`]), if it was.
    pub local_remesh: Option<LocalRemesh>,
    /// Connected components of the mechanical mesh.
    pub components: usize,
    /// Genus of each component, in increasing order; `None` for a
    /// component that is not closed.
    pub genus: Vec<Option<i64>>,
    /// Time spent per part of the frame.
    pub ms: FrameTimings,
}

/// The ball of a local re-mesh ([`FrameReport::local_remesh`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LocalRemesh {
    /// The ball's centre.
    pub centre: [f64; 3],
    /// The ball's radius.
    pub radius: f64,
}

/// The stepper: see the module doc.
///
/// # Example
///
/// A sphere whose radius grows with t, tracked over two frames: the
/// mechanical mesh follows it, every vertex on the surface of its frame.
///
/// ```
/// use isoc::{CompileOptions, Surface, Tracker, TwinOptions};
///
/// let grow = Surface::compile(
///     "domain [-2, 2]^3; surface x^2 + y^2 + z^2 = (1 + 0.2 * t)^2;",
///     "grow.iso",
///     &CompileOptions::default(),
/// )?;
/// let opts = TwinOptions { edge: Some(0.25), ..TwinOptions::default() };
/// let mut tracker = Tracker::new(&grow, 0.0, &opts)?;
/// for t in [0.5, 1.0] {
///     let frame = tracker.advance(t)?;
///     assert_eq!((frame.components, frame.genus.clone()), (1, vec![Some(0)]));
///     let r = 1.0 + 0.2 * t;
///     assert!(tracker.mechanical().positions.iter().all(|p| (p.length() - r).abs() < 1e-9));
/// }
/// # Ok::<(), isoc::Error>(())
/// ```
pub struct Tracker<'s, E: Evaluator + ?Sized = Surface> {
    f: &'s E,
    /// `f` depends on t (otherwise the topology cannot change).
    moves: bool,
    opts: TwinOptions,
    domain: Bounds,
    edge: f64,
    level: u8,
    stiff: Stiffness,
    mesh: DynMesh,
    inverted: Vec<bool>,
    edges: remesh::EdgeState,
    topo: (usize, Vec<Option<i64>>),
    t: f64,
    /// The mechanical mesh as handed out (compacted), rebuilt once a frame.
    mechanical: Mesh,
    geometric: Mesh,
    /// The geometric refinement's memory of the last frame, by the
    /// vertex slots of `mesh` (cleared when they are renumbered).
    reuse: geometric::Reuse,
    cancel: Cancel,
}

impl From<Ball> for LocalRemesh {
    fn from(b: Ball) -> LocalRemesh {
        LocalRemesh {
            centre: b.centre.to_array(),
            radius: b.radius,
        }
    }
}

/// What the topology watch found before the step ([`Tracker::watch`]).
enum Watch {
    /// The topology is the tracker's (proved, or seen by the robust mesh
    /// of the whole domain).
    Same,
    /// It changed: the mesh to restart from.
    Restart(Restart),
    /// Not proved in a few cells: the robust mesh of a box around them (at
    /// `level`, the tracker's resolution there), to settle after the step
    /// ([`Tracker::settle`]).
    Patch { ball: Ball, level: u8, patch: Mesh },
}

/// A mechanical mesh started afresh ([`Tracker::restart`]), to install.
struct Restart {
    mesh: DynMesh,
    inverted: Vec<bool>,
    topo: (usize, Vec<Option<i64>>),
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1e3
}

impl<'s> Tracker<'s, Surface> {
    /// Meshes `surface` at `t0` over `opts.domain` or the surface's own
    /// (see the module doc).
    pub fn new(
        surface: &'s Surface,
        t0: f64,
        opts: &TwinOptions,
    ) -> Result<Tracker<'s>, TrackError> {
        Tracker::new_cancellable(surface, t0, opts, &Cancel::new())
    }

    /// [`Tracker::new`] with a [`Cancel`] token that the tracker polls
    /// from then on (see "Cancelling" in the module doc).
    pub fn new_cancellable(
        surface: &'s Surface,
        t0: f64,
        opts: &TwinOptions,
        cancel: &Cancel,
    ) -> Result<Tracker<'s>, TrackError> {
        // A surface that does not depend on t cannot change (the program
        // is simplified and dead-code free, so an unused t is absent).
        let moves = surface
            .program
            .insts
            .iter()
            .any(|op| matches!(op, crate::ir::Op::Var(crate::ir::Var::T)));
        Tracker::with_evaluator(surface, surface.domain, moves, t0, opts, cancel)
    }
}

impl<'s, E: Evaluator + ?Sized> Tracker<'s, E> {
    /// Meshes `f(·, t0) = 0` over `opts.domain` or, when that is `None`,
    /// over `domain` (see the module doc). `moves`: whether `f` depends on
    /// t at all; when it does not, the topology watch is skipped. The
    /// tracker polls `cancel` (see "Cancelling" in the module doc).
    pub fn with_evaluator(
        f: &'s E,
        domain: Bounds,
        moves: bool,
        t0: f64,
        opts: &TwinOptions,
        cancel: &Cancel,
    ) -> Result<Tracker<'s, E>, TrackError> {
        let domain = opts.domain.unwrap_or(domain);
        let side = (0..3)
            .map(|k| domain.hi[k] - domain.lo[k])
            .fold(0.0, f64::max);
        let edge = opts.edge.unwrap_or(side / 40.0);
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if !positive(edge) {
            return Err(TrackError::EdgeNotPositive(edge));
        }
        if edge < side / 1000.0 {
            return Err(TrackError::EdgeTooSmall {
                edge,
                min: side / 1000.0,
            });
        }
        if opts.passes > MAX_PASSES {
            return Err(TrackError::TooManyPasses {
                passes: opts.passes,
                max: MAX_PASSES,
            });
        }
        if !t0.is_finite() {
            return Err(TrackError::Time(t0));
        }
        if !(positive(opts.e_min)
            && opts.e_max > 2.0 * opts.e_min - 1e-12
            && opts.e_max.is_finite())
        {
            return Err(TrackError::EdgeBand {
                e_min: opts.e_min,
                e_max: opts.e_max,
            });
        }
        if !(positive(opts.young) && opts.poisson > -1.0 && opts.poisson < 0.5) {
            return Err(TrackError::Material {
                young: opts.young,
                poisson: opts.poisson,
            });
        }
        if !(positive(opts.dt) && opts.eps_e >= 0.0 && positive(opts.max_move)) {
            return Err(TrackError::Step {
                dt: opts.dt,
                eps_e: opts.eps_e,
                max_move: opts.max_move,
            });
        }
        if !opts.alpha_deg.is_finite() {
            return Err(TrackError::Alpha(opts.alpha_deg));
        }
        // Octree cells of about 1.5 ê: marching-cubes edges then span
        // roughly [0, 2] ê, the band the remeshing keeps.
        let level = (side / (1.5 * edge)).log2().ceil().clamp(2.0, 10.0) as u8;
        let mut tracker = Tracker {
            f,
            moves,
            opts: *opts,
            domain,
            edge,
            level,
            stiff: Stiffness::new(opts.young, opts.poisson, edge),
            mesh: DynMesh::default(),
            inverted: Vec::new(),
            edges: remesh::EdgeState::default(),
            topo: (0, Vec::new()),
            t: t0,
            mechanical: Mesh::default(),
            geometric: Mesh::default(),
            reuse: geometric::Reuse::default(),
            cancel: cancel.clone(),
        };
        let (mesh, topo) = tracker.robust(t0, 0, &tracker.cancel)?;
        let first = tracker.restart(&mesh, topo, t0, RESTART_ROUNDS, &tracker.cancel)?;
        tracker.install(first);
        tracker.mechanical = tracker.mesh.to_mesh();
        tracker.geometric = tracker.mechanical.clone();
        Ok(tracker)
    }

    /// Replaces the token the tracker polls (e.g. a fresh one after a
    /// cancelled frame, to go on tracking).
    pub fn set_cancel(&mut self, cancel: &Cancel) {
        self.cancel = cancel.clone();
    }

    /// The time of the last frame.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// The target edge length ê.
    pub fn edge(&self) -> f64 {
        self.edge
    }

    /// The mechanical mesh of the last frame (normals: unit gradients).
    pub fn mechanical(&self) -> &Mesh {
        &self.mechanical
    }

    /// The geometric mesh of the last frame.
    pub fn geometric(&self) -> &Mesh {
        &self.geometric
    }

    /// Triangles of the mechanical mesh that are inverted now.
    pub fn inverted_count(&self) -> usize {
        self.mesh
            .live_tris()
            .filter(|&(_, t)| fem::inverted(&self.mesh, t))
            .count()
    }

    /// The edges the last remeshing left outside `[e_min, e_max]·ê`, as
    /// end positions, with the rule that kept each (see [`remesh::Held`]).
    pub fn held_edges(&self) -> Vec<(DVec3, DVec3, remesh::Held)> {
        let alive = |v: u32| self.mesh.vert_alive[v as usize];
        let frozen = &self.edges.frozen;
        let held = self.edges.held.iter().map(|(&e, &h)| (e, h));
        frozen
            .iter()
            .map(|&e| (e, remesh::Held::Frozen))
            .chain(held.filter(|(e, _)| !frozen.contains(e)))
            .filter(|((a, b), _)| alive(*a) && alive(*b))
            .map(|((a, b), h)| (self.mesh.pos[a as usize], self.mesh.pos[b as usize], h))
            .collect()
    }

    /// The robust mesh at `t`, `extra` levels finer than the tracker's,
    /// unless `cancel` is cancelled first.
    fn robust(
        &self,
        t: f64,
        extra: u8,
        cancel: &Cancel,
    ) -> Result<(Mesh, topology::Topology), Cancelled> {
        let level = (self.level + extra).min(crate::octree::MAX_LEVEL);
        self.robust_in(self.domain, level, t, cancel)
    }

    /// The robust mesh at `t` over `domain` on the uniform octree of
    /// `level`, unless `cancel` is cancelled first.
    fn robust_in(
        &self,
        domain: Bounds,
        level: u8,
        t: f64,
        cancel: &Cancel,
    ) -> Result<(Mesh, topology::Topology), Cancelled> {
        let opts = robust_options(domain, level, t);
        let (mesh, report) = mesher::mesh_with_cancellable(self.f, domain, &opts, &|_| {}, cancel)?;
        Ok((mesh, report.topology))
    }

    /// A mechanical mesh started afresh from the robust mesh `mesh` at
    /// time `t`, not yet installed. Marching cubes leaves many edges far
    /// shorter than ê; elements that small are strongly compressed, the
    /// state §2.6.1 warns leads to inversions, so the short edges are
    /// collapsed (and long ones split) by remeshing sweeps before the first
    /// mechanical step.
    fn restart(
        &self,
        mesh: &Mesh,
        topo: topology::Topology,
        t: f64,
        rounds: usize,
        cancel: &Cancel,
    ) -> Result<Restart, Cancelled> {
        let mut dm = DynMesh::from_mesh(mesh);
        let mut inverted = vec![false; dm.tris.len()];
        let params = self.remesh_params(8);
        for _ in 0..rounds {
            let mut scratch = remesh::EdgeState::default();
            let c = remesh::remesh(
                &mut dm,
                self.f,
                t,
                &params,
                &mut scratch,
                &mut inverted,
                cancel,
            )?;
            if c == remesh::Counts::default() {
                break;
            }
        }
        Ok(Restart {
            mesh: dm,
            inverted,
            topo: topo_key(&topo),
        })
    }

    /// Makes `r` the mechanical mesh.
    fn install(&mut self, r: Restart) {
        self.mesh = r.mesh;
        self.inverted = r.inverted;
        self.edges = remesh::EdgeState::default();
        self.topo = r.topo;
        self.compact();
    }

    /// Restarts from the robust mesh at `t` in a frame past its last
    /// checkpoint (it runs to its end).
    fn restart_to_end(&mut self, t: f64) {
        let restarted = uncancelled(|never| {
            let (mesh, topo) = self.robust(t, 0, never)?;
            self.restart(&mesh, topo, t, RESTART_ROUNDS, never)
        });
        self.install(restarted);
    }

    fn remesh_params(&self, sweeps: usize) -> remesh::Params {
        remesh::Params {
            edge: self.edge,
            e_min: self.opts.e_min,
            e_max: self.opts.e_max,
            eps_e: self.opts.eps_e,
            flips: self.opts.flips,
            sweeps,
        }
    }

    /// Advances to time `t`: one frame (see the module doc), on a pool
    /// thread ([`crate::parallel::on_pool`]).
    pub fn advance(&mut self, t: f64) -> Result<FrameReport, TrackError> {
        crate::parallel::on_pool(|| self.advance_here(t))
    }

    /// [`Tracker::advance`] on the calling thread.
    fn advance_here(&mut self, t: f64) -> Result<FrameReport, TrackError> {
        if !t.is_finite() {
            return Err(TrackError::Time(t));
        }
        self.cancel.check()?;
        let start = Instant::now();
        let mut rep = FrameReport {
            t,
            topology_certified: true,
            ..FrameReport::default()
        };

        // 1. Topology watch (it reads the tracker only; a restart it
        // calls for is applied after the last checkpoint).
        let t0 = Instant::now();
        let watched = self.watch(t, &mut rep)?;
        rep.ms.watch = ms(t0);
        // The last checkpoint: from here on the frame changes the tracker.
        self.cancel.check()?;
        let patch = match watched {
            Watch::Same => None,
            Watch::Restart(r) => {
                self.install(r);
                None
            }
            Watch::Patch { ball, level, patch } => Some((ball, level, patch)),
        };

        // 2–5. Mechanical mesh. Vertices that a pending splice cuts out
        // need not reach the surface.
        let t0 = Instant::now();
        let fx = AtT::new(self.f, t, self.domain);
        let spare = patch.as_ref().map(|(ball, _, _)| *ball);
        let mut step = self.step(&fx, t, spare.as_ref());
        if step.failures > 0 {
            rep.reinitialized = Some(format!(
                "tracking lost: {} vertices could not be projected onto the surface",
                step.failures
            ));
            self.restart_to_end(t);
            step = self.step(&fx, t, None);
            if step.failures > 0 {
                // Keep the restarted mesh itself: it is on the surface.
                self.restart_to_end(t);
                step = StepResult::default();
            }
        }
        rep.cg_iterations = step.cg_iterations;
        let mut spared = step.spared;
        let found = self.flag_inversions();
        rep.inverted_found = found;
        // Inverted triangles a pending splice cuts out need no recovery.
        let mut left = self.inverted_kept(spare.as_ref());
        for _ in 0..self.opts.recovery_steps {
            if left == 0 {
                break;
            }
            let s = self.step(&fx, t, spare.as_ref());
            rep.cg_iterations += s.cg_iterations;
            if s.failures > 0 {
                break;
            }
            spared = s.spared;
            self.flag_inversions();
            left = self.inverted_kept(spare.as_ref());
        }
        rep.inverted_left = left;
        rep.inverted_repaired = found.saturating_sub(left);
        if let Some((ball, level, patch)) = patch.filter(|_| rep.reinitialized.is_none()) {
            self.settle(t, ball, level, &patch, spared > 0, &mut rep);
        }
        // Remeshing closes the frame, so that the meshes handed out have
        // their edges in [e_min, e_max]·ê; for the next frame's step it is
        // the paper's "before the quasi-static integration step" (§2.5).
        let params = self.remesh_params(4);
        self.edges.new_frozen.clear();
        let counts = uncancelled(|never| {
            remesh::remesh(
                &mut self.mesh,
                &fx,
                t,
                &params,
                &mut self.edges,
                &mut self.inverted,
                never,
            )
        });
        rep.splits = counts.splits;
        rep.collapses = counts.collapses;
        rep.flips = counts.flips;
        rep.inverted_left = self.flag_inversions();
        self.edges.frozen = std::mem::take(&mut self.edges.new_frozen);
        self.edges.prev_pos.clone_from(&self.mesh.pos);
        if self.mesh.pos.len() > 2 * self.mesh.live_vert_count() + 64 {
            self.compact();
        }
        self.t = t;
        self.mechanical = self.mesh.to_mesh();
        let mech = &self.mechanical;
        rep.ms.mechanical = ms(t0);

        // 6. Geometric mesh.
        let t0 = Instant::now();
        let ids: Vec<u32> = (0..self.mesh.pos.len() as u32)
            .filter(|&i| self.mesh.vert_alive[i as usize])
            .collect();
        let (alpha, passes) = (self.opts.alpha_deg, self.opts.passes);
        let (geo, gs) =
            geometric::refine_tracked(mech, &ids, &mut self.reuse, &fx, t, alpha, passes);
        rep.geometric_splits = gs.splits;
        rep.geometric_budget_hit = gs.budget_hit;
        self.geometric = geo;
        rep.ms.geometric = ms(t0);

        rep.mechanical_triangles = mech.triangles.len();
        rep.mechanical_vertices = mech.positions.len();
        rep.geometric_triangles = self.geometric.triangles.len();
        rep.geometric_vertices = self.geometric.positions.len();
        rep.aspect_good = quality::aspect_good(mech);
        rep.components = self.topo.0;
        rep.genus = self.topo.1.clone();
        rep.ms.total = ms(start);
        Ok(rep)
    }

    /// Step 1 of a frame: when no proof shows that the topology stays the
    /// same over `[self.t, t]`, the robust mesher settles it. When the
    /// proof failed in a few cells only, that is left to
    /// [`Tracker::settle`] once the step has brought the mesh to `t`, with
    /// the robust mesh of a box around them (the returned
    /// [`Watch::Patch`]); otherwise the robust mesh of the whole domain
    /// decides now ([`Tracker::global`]).
    fn watch(&self, t: f64, rep: &mut FrameReport) -> Result<Watch, Cancelled> {
        if !(self.opts.watch && self.moves && t != self.t) {
            return Ok(Watch::Same);
        }
        let interval = Interval {
            lo: self.t.min(t),
            hi: self.t.max(t),
        };
        let cert = watch::certify(self.f, self.domain, interval, self.level + 1, 50_000);
        let cells = match cert.verdict {
            watch::Verdict::Proved => return Ok(Watch::Same),
            watch::Verdict::Local(cells) => cells,
            watch::Verdict::Unproved => Vec::new(),
        };
        rep.topology_certified = false;
        if let Some((ball, level)) = self.local_region(&cells) {
            let (patch, _) = self.robust_in(ball.cube(), level, t, &self.cancel)?;
            return Ok(Watch::Patch { ball, level, patch });
        }
        Ok(match self.global(t, rep, &self.cancel)? {
            Some(r) => Watch::Restart(r),
            None => Watch::Same,
        })
    }

    /// A ball around `cells` with a margin of [`LOCAL_MARGIN`]·ê whose
    /// cube lies inside the domain, and the octree level whose cells in
    /// that cube are no larger than the tracker's; `None` when there are
    /// no cells, when the cube would pass a quarter of the domain's
    /// largest side, or when it cannot be placed inside the domain with the
    /// cells well within the ball.
    fn local_region(&self, cells: &[Bounds]) -> Option<(Ball, u8)> {
        let first = cells.first()?;
        let (mut lo, mut hi) = (DVec3::from_array(first.lo), DVec3::from_array(first.hi));
        for c in cells {
            lo = lo.min(DVec3::from_array(c.lo));
            hi = hi.max(DVec3::from_array(c.hi));
        }
        let d = &self.domain;
        let (dlo, dhi) = (DVec3::from_array(d.lo), DVec3::from_array(d.hi));
        let inner = (hi - lo).length() / 2.0;
        let radius = inner + LOCAL_MARGIN * self.edge;
        if 2.0 * 2.0 * radius > (dhi - dlo).max_element()
            || 2.0 * radius > (dhi - dlo).min_element()
        {
            return None;
        }
        // Centred on the cells, shifted into the domain.
        let centre = ((lo + hi) / 2.0)
            .min(dhi - DVec3::splat(radius))
            .max(dlo + DVec3::splat(radius));
        let reach = (centre - lo).abs().max((hi - centre).abs()).length();
        if reach > inner + (LOCAL_MARGIN - 1.0) * self.edge {
            return None;
        }
        let cell = ((dhi - dlo) / (1u64 << self.level) as f64).max_element();
        let max = f64::from(crate::octree::MAX_LEVEL - 1);
        let level = (2.0 * radius / cell).log2().ceil().clamp(2.0, max) as u8;
        Some((Ball { centre, radius }, level))
    }

    /// The topology at `t`, from the patch `patch` of [`Tracker::watch`]
    /// spliced into the mechanical mesh ([`splice`]) that the step has
    /// brought to `t`: when it differs from the tracker's, the spliced mesh
    /// is installed (with the patch at a coarser level when that one sees
    /// the new topology too), and when it is the same it is installed only
    /// if the step `spared` vertices (left them off the surface, in the
    /// ball). A refused splice falls back to the whole domain
    /// ([`Tracker::global`]), or to a restart when vertices were spared.
    /// Past the frame's last checkpoint: runs to its end.
    fn settle(
        &mut self,
        t: f64,
        ball: Ball,
        level: u8,
        patch: &Mesh,
        spared: bool,
        rep: &mut FrameReport,
    ) {
        let mesh = self.mesh.to_mesh();
        let spliced = |patch: &Mesh| splice::splice(&mesh, patch, &ball, self.edge).ok();
        let found = match spliced(patch) {
            None if spared => {
                rep.reinitialized = Some(
                    "tracking lost: vertices could not be projected onto the surface \
                     and the local re-mesh was refused"
                        .into(),
                );
                self.restart_to_end(t);
                return;
            }
            None => uncancelled(|never| self.global(t, rep, never)),
            Some((fine, topo)) if topo_key(&topo) == self.topo => {
                if !spared {
                    return;
                }
                rep.local_remesh = Some(ball.into());
                Some(uncancelled(|never| {
                    self.restart(&fine, topo, t, SPLICE_ROUNDS, never)
                }))
            }
            Some((fine, topo)) => {
                let now = topo_key(&topo);
                rep.reinitialized = Some(format!(
                    "topology changed: {} component(s), genus {:?} → {} component(s), genus {:?}",
                    self.topo.0, self.topo.1, now.0, now.1
                ));
                rep.local_remesh = Some(ball.into());
                Some(uncancelled(|never| {
                    let coarser = self.robust_in(ball.cube(), level - 1, t, never)?.0;
                    let (mesh, topo) = spliced(&coarser)
                        .filter(|(_, c)| topo_key(c) == now)
                        .unwrap_or((fine, topo));
                    self.restart(&mesh, topo, t, SPLICE_ROUNDS, never)
                }))
            }
        };
        if let Some(r) = found {
            self.install(r);
        }
    }

    /// The topology from the robust mesh over the whole domain, one level
    /// finer than the tracker's; if it differs from the tracker's, the
    /// mechanical mesh to restart from.
    fn global(
        &self,
        t: f64,
        rep: &mut FrameReport,
        cancel: &Cancel,
    ) -> Result<Option<Restart>, Cancelled> {
        let (mesh, topo) = self.robust(t, 1, cancel)?;
        let now = topo_key(&topo);
        if now == self.topo {
            return Ok(None);
        }
        rep.reinitialized = Some(format!(
            "topology changed: {} component(s), genus {:?} → {} component(s), genus {:?}",
            self.topo.0, self.topo.1, now.0, now.1
        ));
        // Restart at the tracker's own resolution when that mesh sees the
        // new topology too (fewer, larger triangles to start from).
        let (coarse, ctopo) = self.robust(t, 0, cancel)?;
        let (mesh, topo) = if topo_key(&ctopo) == now {
            (coarse, ctopo)
        } else {
            (mesh, topo)
        };
        Ok(Some(self.restart(
            &mesh,
            topo,
            t,
            RESTART_ROUNDS,
            cancel,
        )?))
    }

    /// Flags inverted triangles at the current gradients; returns how many.
    fn flag_inversions(&mut self) -> usize {
        self.inverted.resize(self.mesh.tris.len(), false);
        let mut n = 0;
        for (i, t) in self.mesh.tris.iter().enumerate() {
            let inv = self.mesh.tri_alive[i] && fem::inverted(&self.mesh, *t);
            self.inverted[i] = inv;
            n += inv as usize;
        }
        n
    }

    /// Flagged inverted triangles with no corner that a splice over
    /// `spare` cuts out (all of them without one).
    fn inverted_kept(&self, spare: Option<&Ball>) -> usize {
        let kept = |t: &[u32; 3]| {
            spare.is_none_or(|b| {
                t.iter()
                    .all(|&v| !b.cut(self.mesh.pos[v as usize], self.edge))
            })
        };
        self.mesh
            .tris
            .iter()
            .zip(&self.inverted)
            .filter(|(t, inv)| **inv && kept(t))
            .count()
    }

    fn compact(&mut self) {
        let alive_tris: Vec<bool> = self
            .mesh
            .tris
            .iter()
            .enumerate()
            .filter(|(i, _)| self.mesh.tri_alive[*i])
            .map(|(i, _)| self.inverted.get(i).copied().unwrap_or(false))
            .collect();
        let remap = self.mesh.compact();
        self.reuse = geometric::Reuse::default();
        self.inverted = alive_tris;
        let map = |e: EdgeKey| {
            let (a, b) = (remap[e.0 as usize], remap[e.1 as usize]);
            (a != u32::MAX && b != u32::MAX).then(|| key(a, b))
        };
        let e = &mut self.edges;
        if !e.prev_pos.is_empty() {
            let mut prev = vec![DVec3::NAN; self.mesh.pos.len()];
            for (old, &new) in remap.iter().enumerate() {
                if new != u32::MAX
                    && let Some(&p) = e.prev_pos.get(old)
                {
                    prev[new as usize] = p;
                }
            }
            e.prev_pos = prev;
        }
        e.frozen = e.frozen.iter().filter_map(|&k| map(k)).collect();
        e.held = e
            .held
            .iter()
            .filter_map(|(&k, &h)| map(k).map(|k| (k, h)))
            .collect();
    }

    /// One quasi-static step at time `t`, then projection. A vertex that
    /// cannot be projected is a failure, unless it lies deep enough in
    /// `spare` for a splice to cut it out (it then stays where the step
    /// put it; [`StepResult::spared`] counts it).
    fn step<G: Evaluator + ?Sized>(&mut self, f: &G, t: f64, spare: Option<&Ball>) -> StepResult {
        let n = self.mesh.pos.len();
        // Gradients at the current positions (one batch over the live
        // vertices).
        let alive: Vec<usize> = (0..n).filter(|&i| self.mesh.vert_alive[i]).collect();
        let at: Vec<DVec3> = alive.iter().map(|&i| self.mesh.pos[i]).collect();
        let mut grads = vec![DVec3::ZERO; n];
        for (&i, (_, g)) in alive.iter().zip(grads_at(f, t, &at)) {
            grads[i] = g;
        }
        self.mesh.grad = grads;
        self.flag_inversions();
        let frames = Frames::new(&self.mesh, &self.stiff, &self.inverted);
        let normals: Vec<DVec3> = self
            .mesh
            .grad
            .iter()
            .map(|g| g.normalize_or_zero())
            .collect();
        let forces = frames.forces(&self.stiff, n);
        let b: Vec<DVec3> = forces.iter().map(|x| *x * self.opts.dt).collect();
        let (mut dx, iters) = self.solve(&frames, &normals, &b);
        if self.opts.sharp {
            for _ in 0..SHARP_ITERATIONS {
                self.sharp_constraint(f, t, &mut dx);
            }
        }

        // Projection (eq. 3), in parallel.
        let reach = self.opts.max_move * self.edge;
        let moved: Vec<Option<crate::roots::walk::OnSurface>> = (0..n)
            .into_par_iter()
            .map(|i| {
                if !self.mesh.vert_alive[i] {
                    return None;
                }
                let p = self.mesh.pos[i] + dx[i];
                crate::roots::walk::newton(f, t, p, reach, self.edge)
            })
            .collect();
        let (mut failures, mut spared) = (0, 0);
        let cut = |p: DVec3| spare.is_some_and(|b| b.cut(p, self.edge));
        for (i, m) in moved.into_iter().enumerate() {
            if !self.mesh.vert_alive[i] {
                continue;
            }
            match m {
                Some(s) => {
                    self.mesh.pos[i] = s.pos;
                    self.mesh.grad[i] = s.grad;
                }
                None if cut(self.mesh.pos[i] + dx[i]) => {
                    self.mesh.pos[i] += dx[i];
                    spared += 1;
                }
                None => failures += 1,
            }
        }
        StepResult {
            cg_iterations: iters,
            failures,
            spared,
        }
    }

    /// Filtered conjugate gradients for `(I + dt Σ R K Rᵀ) Δx = b` with
    /// `Δx` kept in the vertices' tangent planes (Baraff & Witkin 1998),
    /// preconditioned by the system's 3×3 diagonal blocks restricted to
    /// each tangent plane (block Jacobi, [`Preconditioner`]). Stops when
    /// the residual is below `cg_tolerance` times the filtered right-hand
    /// side.
    fn solve(&self, frames: &Frames, normals: &[DVec3], b: &[DVec3]) -> (Vec<DVec3>, usize) {
        let n = b.len();
        let dt = self.opts.dt;
        // Every vector below lives for the whole solve (no allocation per
        // iteration); the loops over vertices are fused, each sum still
        // taken in vertex order.
        let precondition = Preconditioner::new(&frames.diagonal(&self.stiff, n), normals, dt);
        let mut x = vec![DVec3::ZERO; n];
        let mut r = b.to_vec();
        let mut b_norm = 0.0;
        for (v, nrm) in r.iter_mut().zip(normals) {
            *v -= *nrm * v.dot(*nrm);
            b_norm += v.dot(*v);
        }
        let b_norm = f64::sqrt(b_norm);
        if b_norm == 0.0 {
            return (x, 0);
        }
        let mut z = vec![DVec3::ZERO; n];
        let mut rz = precondition.apply(&r, &mut z);
        let mut p = z.clone();
        let mut ap = vec![DVec3::ZERO; n];
        let mut iters = 0;
        for _ in 0..self.opts.cg_iterations {
            iters += 1;
            // ap = filter(p + dt K p), and p·ap.
            frames.apply(&self.stiff, &p, &mut ap);
            let mut pap = 0.0;
            for ((o, x), nrm) in ap.iter_mut().zip(&p).zip(normals) {
                let v = *x + *o * dt;
                *o = v - *nrm * v.dot(*nrm);
                pap += x.dot(*o);
            }
            if pap <= 0.0 || !pap.is_finite() {
                break;
            }
            let alpha = rz / pap;
            let mut rr = 0.0;
            for i in 0..n {
                x[i] += p[i] * alpha;
                r[i] -= ap[i] * alpha;
                rr += r[i].dot(r[i]);
            }
            if rr.sqrt() < self.opts.cg_tolerance * b_norm {
                break;
            }
            let rz_new = precondition.apply(&r, &mut z);
            if rz_new <= 0.0 || !rz_new.is_finite() {
                break;
            }
            let beta = rz_new / rz;
            for (p, z) in p.iter_mut().zip(&z) {
                *p = *z + *p * beta;
            }
            rz = rz_new;
        }
        (x, iters)
    }

    /// The sharp-feature constraint (eq. 4, after Ohtake, Belyaev & Pasko
    /// 2003): each vertex moves to the area-weighted least-squares point of
    /// the planes through its triangles' centroids `c_τ` normal to the
    /// field there, `p' = p + Σ A_τ ((c_τ − p)·m_τ) m_τ / Σ A_τ` with
    /// `m_τ = ∇f(c_τ)/‖∇f(c_τ)‖`, so that triangle normals align with ∇f
    /// and vertices settle on creases. (The extracted text of eq. 4 shows
    /// the gradient at `p` in place of `m_τ`, which would only move `p`
    /// along its own normal and be undone by the projection; Ohtake et
    /// al.'s formula, which the paper cites for it, uses the centroids'.)
    fn sharp_constraint<G: Evaluator + ?Sized>(&self, f: &G, t: f64, dx: &mut [DVec3]) {
        let m = &self.mesh;
        let p: Vec<DVec3> = m.pos.iter().zip(dx.iter()).map(|(a, b)| *a + *b).collect();
        // ∇f at the live triangles' centroids, one batch.
        let live: Vec<usize> = (0..m.tris.len()).filter(|&i| m.tri_alive[i]).collect();
        let centroid = |i: usize| {
            let q = m.tris[i].map(|v| p[v as usize]);
            (q[0] + q[1] + q[2]) / 3.0
        };
        let at: Vec<DVec3> = live.iter().map(|&i| centroid(i)).collect();
        let mut planes = vec![(DVec3::ZERO, DVec3::ZERO, 0.0); m.tris.len()];
        for ((&i, c), (_, g)) in live.iter().zip(at.iter()).zip(grads_at(f, t, &at)) {
            let q = m.tris[i].map(|v| p[v as usize]);
            let n = g.normalize_or_zero();
            let area = 0.5 * (q[1] - q[0]).cross(q[2] - q[0]).length();
            planes[i] = (*c, n, if n.is_finite() { area } else { 0.0 });
        }
        for (i, d) in dx.iter_mut().enumerate() {
            if !m.vert_alive[i] {
                continue;
            }
            let (mut sum, mut den) = (DVec3::ZERO, 0.0);
            for &ti in &m.star[i] {
                let (c, n, a) = planes[ti as usize];
                sum += n * (a * (c - p[i]).dot(n));
                den += a;
            }
            if den > 0.0 {
                *d += sum / den;
            }
        }
    }
}

/// The margin (in ê) around the cells the topology proof failed in, for
/// the ball re-meshed locally: the splice keeps the patch only deeper than
/// [`splice::PATCH_DEPTH`]·ê inside the ball, and the failed cells must lie
/// well within what it keeps.
const LOCAL_MARGIN: f64 = splice::PATCH_DEPTH + 4.5;

/// Remeshing calls (of 8 sweeps each, until one changes nothing) that
/// turn a robust mesh into a first mechanical mesh.
const RESTART_ROUNDS: usize = 8;

/// Remeshing calls after a splice: only the patch and the strip need
/// them, and the frames that follow go on remeshing.
const SPLICE_ROUNDS: usize = 1;

/// Most refinement passes accepted.
pub(crate) const MAX_PASSES: usize = 12;

/// Applications of eq. 4 per step (each from the planes of the last).
const SHARP_ITERATIONS: usize = 5;

/// Block-Jacobi preconditioner of the step's solver: per vertex, the
/// inverse of the system's diagonal block `M = I + dt K_vv` restricted to
/// the tangent plane, `T S⁻¹ Tᵀ` with `T` an orthonormal basis of the
/// plane and `S = Tᵀ M T` (symmetric positive definite on the plane, so
/// the preconditioned iteration is still conjugate gradients); a vertex
/// without a normal gets `M⁻¹`, and a singular block the identity.
struct Preconditioner {
    blocks: Vec<DMat3>,
}

impl Preconditioner {
    fn new(diagonal: &[DMat3], normals: &[DVec3], dt: f64) -> Preconditioner {
        let blocks = diagonal
            .iter()
            .zip(normals)
            .map(|(k, &nrm)| Preconditioner::block(DMat3::IDENTITY + *k * dt, nrm))
            .collect();
        Preconditioner { blocks }
    }

    fn block(m: DMat3, nrm: DVec3) -> DMat3 {
        let outer = |u: DVec3, v: DVec3| DMat3::from_cols(u * v.x, u * v.y, u * v.z);
        if nrm == DVec3::ZERO {
            let det = m.determinant();
            return if det > 0.0 && det.is_finite() {
                m.inverse()
            } else {
                DMat3::IDENTITY
            };
        }
        let (t1, t2) = nrm.any_orthonormal_pair();
        let a = t1.dot(m * t1);
        let b = 0.5 * (t1.dot(m * t2) + t2.dot(m * t1));
        let d = t2.dot(m * t2);
        let det = a * d - b * b;
        let (ia, ib, id) = if det > 0.0 && det.is_finite() {
            (d / det, -b / det, a / det)
        } else {
            (1.0, 0.0, 1.0)
        };
        outer(t1, t1) * ia + (outer(t1, t2) + outer(t2, t1)) * ib + outer(t2, t2) * id
    }

    /// `z = P r`; returns `r·z` (summed in vertex order).
    fn apply(&self, r: &[DVec3], z: &mut [DVec3]) -> f64 {
        let mut rz = 0.0;
        for ((m, v), z) in self.blocks.iter().zip(r).zip(z.iter_mut()) {
            *z = *m * *v;
            rz += v.dot(*z);
        }
        rz
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct StepResult {
    cg_iterations: usize,
    failures: usize,
    /// Vertices left off the surface for a splice to cut out.
    spared: usize,
}

/// The robust mesher's options for the tracker's meshes over `domain` at
/// time `t`: plain marching cubes on the uniform octree of `level`.
pub(crate) fn robust_options(domain: Bounds, level: u8, t: f64) -> MeshOptions {
    MeshOptions {
        octree: OctreeOptions {
            max_level: level,
            min_level: level,
            t,
            // The tracker sizes its meshes itself.
            chord: None,
            ..OctreeOptions::default()
        },
        smooth: 0,
        domain: Some(domain),
        // The tracker keeps features its own way (the sharp-feature
        // constraint); its starting meshes are plain marching cubes.
        creases: false,
    }
}

/// Components and the sorted genera: what "the same topology" compares.
fn topo_key(t: &topology::Topology) -> (usize, Vec<Option<i64>>) {
    let mut g = t.genus.clone();
    g.sort();
    (t.components, g)
}

/// The evaluator of one frame: `f`, whose point methods go to `f`
/// compiled anew with `t` fixed at the frame's time ([`Builder::substitute`]:
/// the same point values) when that saves a transcendental op or a tenth
/// of the program at every point — worth one JIT compile a frame. Interval
/// methods always go to `f` itself (they may be asked over a range of t).
struct AtT<'s, E: ?Sized> {
    f: &'s E,
    frozen: Option<Surface>,
}

impl<'s, E: Evaluator + ?Sized> AtT<'s, E> {
    fn new(f: &'s E, t: f64, domain: Bounds) -> AtT<'s, E> {
        let frozen = f.program().filter(|p| p.uses_var(Var::T)).and_then(|p| {
            let q = Builder::substitute(p, Var::T, t);
            let heavy = |p: &Program| {
                p.insts
                    .iter()
                    .filter(|op| {
                        matches!(op, Op::Unary(u, _) if !matches!(u, UnOp::Neg | UnOp::Abs | UnOp::Square))
                    })
                    .count()
            };
            let saves = heavy(&q) < heavy(p) || 10 * q.len() <= 9 * p.len();
            saves
                .then(|| Surface::from_program("", q, domain, Vec::new()).ok())
                .flatten()
        });
        AtT { f, frozen }
    }
}

impl<E: Evaluator + ?Sized> Evaluator for AtT<'_, E> {
    fn point(&self, p: [f64; 4]) -> f64 {
        match &self.frozen {
            Some(g) => g.point(p),
            None => self.f.point(p),
        }
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        match &self.frozen {
            Some(g) => g.point_grad(p),
            None => self.f.point_grad(p),
        }
    }
    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        match &self.frozen {
            Some(g) => Evaluator::point_batch(g, xs, ys, zs, t, out),
            None => self.f.point_batch(xs, ys, zs, t, out),
        }
    }
    fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64, out: &mut [(f64, [f64; 3])]) {
        match &self.frozen {
            Some(g) => Evaluator::point_grad_batch(g, pts, t, out),
            None => self.f.point_grad_batch(pts, t, out),
        }
    }
    fn interval(&self, b: [Interval; 4]) -> crate::interval::DecInterval {
        self.f.interval(b)
    }
    fn grad(&self, b: [Interval; 4]) -> crate::eval::GradEval {
        self.f.grad(b)
    }
    fn program(&self) -> Option<&Program> {
        self.f.program()
    }
    fn interval_batch(&self, boxes: &[[Interval; 4]], out: &mut [crate::interval::DecInterval]) {
        self.f.interval_batch(boxes, out)
    }
    fn grad_batch(&self, boxes: &[[Interval; 4]], out: &mut [crate::eval::GradEval]) {
        self.f.grad_batch(boxes, out)
    }
}
