//! The geometric mesh (Bouthors & Nesme §3): a copy of the mechanical
//! mesh, refined where the surface bends by more than α_r.
//!
//! # Contract
//!
//! Each pass (at most `N_p`) marks an edge when the unit gradients at its
//! two end vertices make an angle above α_r, and, when the normals of two
//! neighbouring triangles (∇f at their centroids) do, the *other* edges of
//! both triangles (Fig. 7b). The test is `n₁·n₂ < cos α_r`, so α_r = −π
//! marks nothing: with α_r = −π or `N_p = 0` the result is an exact copy
//! of the mechanical mesh. Each marked edge gets its midpoint projected
//! onto the surface by [`crate::roots::walk::newton`], starting from the
//! bulge of the arc its end normals describe (an edge whose midpoint
//! cannot be projected within the edge's length stays unmarked). A
//! triangle with one, two or three marked edges becomes two, three or
//! four triangles (Fig. 7a); with two, the quad left beside the corner
//! triangle is cut along the diagonal whose ends have the closer normals,
//! i.e. along the direction of least curvature. Marks are per edge, so
//! both triangles of an edge share its midpoint: no T-vertices, and a
//! closed oriented mesh stays closed and oriented. A pass that could take
//! the mesh beyond [`TRIANGLE_BUDGET`] times the mechanical mesh's size is
//! not started (sharp creases mark edges on every pass).
//!
//! # From frame to frame
//!
//! A tracker refines each frame with [`refine_tracked`], which decides
//! afresh only where the mechanical mesh changed (see [`Reuse`]): a
//! mechanical triangle whose corners, edge lengths and corner-normal
//! angles are still those its refinement was decided at (within
//! tolerances) gets the same refinement again, its midpoints projected
//! anew from the same starting points. A surface at rest thus gets
//! [`refine`]'s mesh exactly; a moving one a mesh that is closed and
//! oriented like [`refine`]'s, whose reused parts are split where
//! [`refine`] would have split them when they were decided, so an edge
//! there turns by at most about (1 + [`TURN_TOLERANCE`]) α_r.
//!
//! # Limits
//!
//! Evaluation: the centroid gradients of a pass are one batch
//! ([`crate::eval::sample::grads_at`]); the midpoint projections are
//! sequential Newton walks, run in parallel. Bookkeeping is linear in the
//! mesh (one hash of the edges of the triangles decided afresh, one of
//! the reused midpoints' names), but sequential.

mod reuse;
mod tris;

pub(crate) use reuse::Reuse;
pub use reuse::{SHAPE_TOLERANCE, TURN_TOLERANCE};
pub use tris::{RefineStats, TRIANGLE_BUDGET};

use crate::eval::Evaluator;
use crate::mesh::Mesh;
use tris::{Limits, Tris, budget};

/// Refines `mech` (whose normals are the unit gradients at its vertices)
/// on the surface `f(·, t) = 0`; see the module doc.
pub fn refine<E: Evaluator + ?Sized>(
    mech: &Mesh,
    f: &E,
    t: f64,
    alpha_deg: f64,
    passes: usize,
) -> (Mesh, RefineStats) {
    let mut mesh = mech.clone();
    if alpha_deg <= -180.0 || passes == 0 {
        return (mesh, RefineStats::default());
    }
    let mut tris = Tris::new(std::mem::take(&mut mesh.triangles), None);
    // Nothing is shared, so nothing can conflict.
    let limits = Limits {
        cos_a: alpha_deg.to_radians().cos(),
        passes,
        budget: budget(mech),
    };
    let (stats, _) = tris.refine(&mut mesh, f, t, limits, None);
    mesh.triangles = tris.v;
    (mesh, stats)
}

/// [`refine`] for a tracker's frame, reusing the last frame's refinement
/// where the mechanical mesh kept its shape (module doc, [`Reuse`]); `ids`
/// names `mech`'s vertices across frames (the tracker's vertex slots).
pub(crate) fn refine_tracked<E: Evaluator + ?Sized>(
    mech: &Mesh,
    ids: &[u32],
    reuse: &mut Reuse,
    f: &E,
    t: f64,
    alpha_deg: f64,
    passes: usize,
) -> (Mesh, RefineStats) {
    if alpha_deg <= -180.0 || passes == 0 {
        *reuse = Reuse::default();
        return (mech.clone(), RefineStats::default());
    }
    if let Some(done) = reuse.refine(mech, ids, f, t, alpha_deg, passes) {
        return done;
    }
    // The reused part could not be joined to the rest: all afresh (with
    // nothing to reuse, nothing is shared and this cannot fail).
    *reuse = Reuse::default();
    reuse
        .refine(mech, ids, f, t, alpha_deg, passes)
        .unwrap_or_else(|| refine(mech, f, t, alpha_deg, passes))
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;
    use crate::Surface;
    use crate::eval::GradEval;
    use crate::interval::{DecInterval, Interval};
    use crate::mesh::topology::analyze;
    use crate::mesher::{self, MeshOptions};
    use crate::octree::OctreeOptions;
    use crate::testing::surface;

    /// `f`, counting the batches of gradients asked (the centroid normals
    /// of a pass).
    struct Counting<'a>(&'a Surface, AtomicUsize);

    impl Evaluator for Counting<'_> {
        fn point(&self, p: [f64; 4]) -> f64 {
            self.0.point(p)
        }
        fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
            self.0.point_grad(p)
        }
        fn interval(&self, b: [Interval; 4]) -> DecInterval {
            self.0.interval(b)
        }
        fn grad(&self, b: [Interval; 4]) -> GradEval {
            self.0.grad(b)
        }
        fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64, out: &mut [(f64, [f64; 3])]) {
            self.1.fetch_add(pts.len(), Ordering::Relaxed);
            Evaluator::point_grad_batch(self.0, pts, t, out);
        }
    }

    /// A robust mesh of `s` at level 4, as a mechanical mesh.
    fn mechanical(s: &Surface) -> Mesh {
        let opts = MeshOptions {
            octree: OctreeOptions {
                max_level: 4,
                ..OctreeOptions::default()
            },
            ..MeshOptions::default()
        };
        mesher::mesh(s, &opts, &|_| {}).0
    }

    /// The triangles by their corners' positions (bits), each starting at
    /// its least corner, sorted: the mesh whatever its numbering.
    fn by_position(m: &Mesh) -> Vec<[[u64; 3]; 3]> {
        let mut out: Vec<[[u64; 3]; 3]> = m
            .triangles
            .iter()
            .map(|t| {
                let c = t.map(|v| m.positions[v as usize].to_array().map(f64::to_bits));
                let k = (0..3).min_by_key(|&k| c[k]).unwrap_or(0);
                [c[k], c[(k + 1) % 3], c[(k + 2) % 3]]
            })
            .collect();
        out.sort_unstable();
        out
    }

    #[test]
    fn a_surface_at_rest_gets_the_same_mesh_without_new_decisions() {
        let s = surface("domain [-2, 2]^3; surface (x / 1.5)^2 + y^2 + (z / 0.7)^2 - 1;");
        let mech = mechanical(&s);
        let ids: Vec<u32> = (0..mech.positions.len() as u32).collect();
        let (fresh, stats) = refine(&mech, &s, 0.0, 8.0, 3);
        assert!(stats.splits > mech.triangles.len(), "{stats:?}");
        let mut reuse = Reuse::default();
        let f = Counting(&s, AtomicUsize::new(0));
        let (first, _) = refine_tracked(&mech, &ids, &mut reuse, &f, 0.0, 8.0, 3);
        assert!(f.1.load(Ordering::Relaxed) > 0);
        f.1.store(0, Ordering::Relaxed);
        let (again, again_stats) = refine_tracked(&mech, &ids, &mut reuse, &f, 0.0, 8.0, 3);
        assert_eq!(by_position(&first), by_position(&fresh));
        assert_eq!(by_position(&again), by_position(&fresh));
        assert_eq!(again.positions.len(), fresh.positions.len());
        assert_eq!(again_stats.splits, stats.splits);
        // Nothing was decided again: no centroid normals.
        assert_eq!(f.1.load(Ordering::Relaxed), 0);
        let topo = analyze(&again);
        assert!(topo.watertight && topo.components == 1, "{topo:?}");
    }

    #[test]
    fn changed_triangles_are_decided_again_and_joined_to_the_rest() {
        let s = surface("domain [-2, 2]^3; surface (x / 1.5)^2 + y^2 + (z / 0.7)^2 - 1;");
        let mech = mechanical(&s);
        let ids: Vec<u32> = (0..mech.positions.len() as u32).collect();
        let mut reuse = Reuse::default();
        refine_tracked(&mech, &ids, &mut reuse, &s, 0.0, 8.0, 3);
        // Turn the normals of the vertices with x > 0.5 a little: the
        // triangles there are decided again, the others reused.
        let mut bent = mech.clone();
        for (p, n) in bent.positions.iter().zip(&mut bent.normals) {
            if p.x > 0.5 {
                *n = (*n + glam::DVec3::new(0.0, 0.3 * p.x, 0.0)).normalize();
            }
        }
        let f = Counting(&s, AtomicUsize::new(0));
        let (geo, _) = refine_tracked(&bent, &ids, &mut reuse, &f, 0.0, 8.0, 3);
        let asked = f.1.load(Ordering::Relaxed);
        let (fresh, _) = refine(&bent, &s, 0.0, 8.0, 3);
        assert!(asked > 0, "the bent part is decided again");
        assert!(
            asked < fresh.triangles.len() / 2,
            "{asked} centroid normals for {} triangles: the rest is reused",
            fresh.triangles.len()
        );
        let topo = analyze(&geo);
        assert!(topo.watertight && topo.components == 1, "{topo:?}");
        for &t in &geo.triangles {
            assert!(!tris::inverted(&geo, t));
        }
        for p in &geo.positions[mech.positions.len()..] {
            assert!(s.point([p.x, p.y, p.z, 0.0]).abs() < 1e-12, "{p}");
        }
    }
}
