//! `--tolerance`'s adaptation on the surface (`mesher::adapt`), judged by
//! oracles independent of the mesher: exact distances to spheres and tori,
//! the topology the surface is known to have, vertex values, the sign of
//! the exact gradient at each triangle, and the domain's faces for cut
//! surfaces.

use glam::DVec3;
use isoc::mesher::{self, MeshOptions};

use crate::support::surface;

/// Meshes `src` to `tol` with the defaults (level cap 10, as the CLI).
fn to_tolerance(
    src: &str,
    tol: f64,
) -> (
    isoc::Surface,
    isoc::Mesh,
    isoc::MeshReport,
    isoc::mesher::ToleranceReport,
) {
    let s = surface(src);
    let mut opts = MeshOptions::default();
    opts.octree.max_level = 10;
    let (mesh, report, t) = mesher::mesh_to_tolerance(&s, s.domain, &opts, tol, &|_| {});
    (s, mesh, report, t)
}

/// The four samples the tolerance is about: centroid and edge midpoints.
fn samples(mesh: &isoc::Mesh) -> impl Iterator<Item = DVec3> + '_ {
    mesh.triangles.iter().flat_map(|tri| {
        let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
        [
            (a + b + c) / 3.0,
            (a + b) * 0.5,
            (b + c) * 0.5,
            (c + a) * 0.5,
        ]
    })
}

/// The exact distance from `p` to the torus of radii `big` (around the
/// z axis) and `tube`.
fn torus_distance(p: DVec3, big: f64, tube: f64) -> f64 {
    ((p.x.hypot(p.y) - big).hypot(p.z) - tube).abs()
}

/// The outward direction of that torus's ∇f at `p` (away from the core
/// circle of radius `big`).
fn torus_outward(p: DVec3, big: f64) -> DVec3 {
    let r = p.x.hypot(p.y);
    DVec3::new(p.x * (r - big) / r, p.y * (r - big) / r, p.z)
}

/// Surfaces of known genus and an exact distance function: the adapted
/// mesh is closed, has the surface's components and genera, keeps every
/// vertex on the surface, faces along ∇f everywhere (the exact gradient at
/// each centroid), and is within the tolerance at every sample by the
/// exact distance, which the reported deviation bounds from above.
#[test]
fn adapted_meshes_keep_topology_orientation_and_the_tolerance() {
    type Dist = fn(DVec3) -> f64;
    type Grad = fn(DVec3) -> DVec3;
    type Case = (&'static str, f64, Vec<Option<i64>>, Dist, Grad, f64);
    // (source, tolerance, genera, exact distance, exact gradient direction,
    // least share of triangles with aspect ratio above 0.8)
    let cases: [Case; 3] = [
        (
            // A torus of tube radius 0.25.
            "domain [-1.5, 1.5], [-1.5, 1.5], [-0.5, 0.5];
             surface (sqrt(x^2 + y^2) - 1)^2 + z^2 - 0.0625;",
            4e-4,
            vec![Some(1)],
            |p| torus_distance(p, 1.0, 0.25),
            |p| torus_outward(p, 1.0),
            0.7,
        ),
        (
            // Two spheres of very different radii: one tolerance, two sizes.
            "domain [-1.2, 2.0], [-1.2, 1.2], [-1.2, 1.2];
             surface min(sqrt(x^2 + y^2 + z^2) - 1, sqrt((x - 1.6)^2 + y^2 + z^2) - 0.15);",
            3e-4,
            vec![Some(0), Some(0)],
            |p| {
                (p.length() - 1.0)
                    .abs()
                    .min(((p - DVec3::new(1.6, 0.0, 0.0)).length() - 0.15).abs())
            },
            |p| {
                let q = p - DVec3::new(1.6, 0.0, 0.0);
                if p.length() - 1.0 < q.length() - 0.15 {
                    p
                } else {
                    q
                }
            },
            0.85,
        ),
        (
            // A thin torus: tube radius 0.08 around a circle of radius 0.7.
            "domain [-1, 1], [-1, 1], [-0.2, 0.2];
             surface (sqrt(x^2 + y^2) - 0.7)^2 + z^2 - 0.0064;",
            2e-4,
            vec![Some(1)],
            |p| torus_distance(p, 0.7, 0.08),
            |p| torus_outward(p, 0.7),
            // The equators of a thin tube keep stretched triangles.
            0.55,
        ),
    ];
    for (src, tol, genera, dist, grad, shape) in cases {
        let (s, mesh, report, t) = to_tolerance(src, tol);
        assert!(t.met, "{src}: {t:?}");
        assert_eq!(t.passes, 1, "{src}: the adaptation alone meets it");
        assert!(report.topology.watertight, "{src}: {:?}", report.topology);
        let mut got = report.topology.genus.clone();
        got.sort();
        assert_eq!(got, genera, "{src}");
        for (i, p) in mesh.positions.iter().enumerate() {
            let (v, g) = isoc::eval::Evaluator::point_grad(&s, [p.x, p.y, p.z, 0.0]);
            let g = DVec3::from_array(g).length();
            assert!(
                v.abs() <= 1e-12 * g.max(1.0),
                "{src}: vertex {i} off the surface: f = {v:e}"
            );
        }
        for tri in &mesh.triangles {
            let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(
                n.dot(grad((a + b + c) / 3.0)) > 0.0,
                "{src}: triangle {tri:?} faces against ∇f"
            );
        }
        let worst = samples(&mesh).map(dist).fold(0.0, f64::max);
        assert!(worst <= tol, "{src}: exact deviation {worst:e} > {tol:e}");
        assert!(
            worst <= t.max_deviation * (1.0 + 1e-9) + 1e-15,
            "{worst:e} > reported {t:?}"
        );
        assert!(
            report.aspect_good > shape,
            "{src}: aspect_good {}",
            report.aspect_good
        );
    }
}

/// Adaptation sizes triangles by the local curvature: on the ellipsoid
/// `x²/4 + y² + z² = 1` the tips (both curvatures 2) get smaller
/// triangles than the equator (curvatures 1 and 1/4), about half the area
/// as the chord error grows with curvature times area.
#[test]
fn triangles_grow_where_the_surface_is_flatter() {
    let (_, mesh, _, t) = to_tolerance(
        "domain [-2.2, 2.2], [-1.2, 1.2], [-1.2, 1.2]; surface x^2/4 + y^2 + z^2 - 1;",
        3e-4,
    );
    assert!(t.met, "{t:?}");
    let (mut tips, mut equator) = (Vec::new(), Vec::new());
    for tri in &mesh.triangles {
        let q = tri.map(|i| mesh.positions[i as usize]);
        let c = (q[0] + q[1] + q[2]) / 3.0;
        let area = 0.5 * (q[1] - q[0]).cross(q[2] - q[0]).length();
        if c.x.abs() > 1.9 {
            tips.push(area);
        } else if c.x.abs() < 0.3 {
            equator.push(area);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(!tips.is_empty() && !equator.is_empty());
    assert!(
        mean(&equator) > 1.4 * mean(&tips),
        "equator {:e} tips {:e}",
        mean(&equator),
        mean(&tips)
    );
}

/// A surface cut by the domain (a tilted plane, open): the adaptation
/// keeps its boundary on the domain's faces, the mesh stays one open disc
/// (Euler characteristic 1) within the tolerance, the plane being flat the
/// triangles are few.
#[test]
fn a_cut_surface_keeps_its_boundary_on_the_domain() {
    let (_, mesh, report, t) = to_tolerance(
        "domain [-1, 1]^3; surface x + 0.3*y + 0.2*z + 0.1*(x^2 + y^2);",
        1e-3,
    );
    assert!(t.met, "{t:?}");
    assert!(!report.topology.watertight);
    assert_eq!(report.topology.components, 1);
    assert_eq!(report.topology.euler, 1, "{:?}", report.topology);
    // Boundary vertices: those on an edge with one triangle.
    let mut count = std::collections::HashMap::new();
    for tri in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let mut on_boundary = 0;
    for (&(a, b), &n) in &count {
        if n == 1 {
            for v in [a, b] {
                let p = mesh.positions[v as usize];
                let face = p.to_array().iter().any(|c| (c.abs() - 1.0).abs() < 1e-9);
                assert!(face, "boundary vertex {p:?} left the domain's faces");
                on_boundary += 1;
            }
        }
    }
    assert!(on_boundary > 0);
    assert!(
        mesh.triangles.len() < 20_000,
        "{} triangles for a near-plane",
        mesh.triangles.len()
    );
}

/// Where ∇f vanishes on the whole surface (a sphere written as a cube,
/// `(r² − 1)³`: Newton's step is a third of the distance) the measure
/// still bounds every sample from above, and a met tolerance holds by the
/// exact distance.
#[test]
fn a_flat_zero_is_measured_soundly() {
    let (_, mesh, _, t) = to_tolerance(
        "domain [-1.3, 1.3]^3; surface (x^2 + y^2 + z^2 - 1)^3;",
        1e-3,
    );
    let worst = samples(&mesh)
        .map(|p| (p.length() - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= t.max_deviation * (1.0 + 1e-9) + 1e-15,
        "{worst:e} > {t:?}"
    );
    if t.met {
        assert!(worst <= 1e-3, "{worst:e}");
    }
}
