//! Sags read from unit normals, and where a vertex moves to even them out.
//!
//! Two points `p`, `q` of a smooth surface whose unit normals are `n_p`
//! and `n_q` **bend** by `b = (n_q − n_p)·(q − p)`, which is `κ‖q − p‖²`
//! to second order (`κ` the normal curvature along `q − p`). The chord
//! `p–q` then stands `|b| / 8` off the surface at its midpoint, and a
//! triangle's plane stands `|b_ab + b_bc + b_ca| / 18` off it at its
//! centroid (on a quadric, exactly: the height of the centroid under the
//! triangle is a ninth of the second fundamental form summed over the
//! edges, and `b` is twice that form). These are the two points the
//! chord error is measured at (`mesher::chord`), read without an
//! evaluation of `f`.
//!
//! A coarsened mesh's chord error is set by its largest sags and its size
//! by the average one: on sphere.iso at depth 8 the centroids' sags
//! spread from 0.016 to 0.036 cells (1st to 99.9th percentile).
//! [`Sags`] holds the sags of a vertex's star (the triangles around it
//! and the midpoints of its edges) as functions of the vertex's position,
//! and offers a few steps, in its tangent plane, down a soft maximum of
//! them: the passes after the chord splits ([`super::settle`]) take the
//! first that lowers the largest, so that, repeated
//! over the mesh, the largest sags come down towards the average.
//!
//! # Limits
//!
//! Second order only: across a crease or next to a singular point the
//! normals turn by more than any curvature, so a star with a corner whose
//! normal turns past `MAX_TURN` from the vertex's has no [`Sags`]. The
//! normals are held during the search; the caller reads the sags again
//! at the projected point with its own normal.

use glam::DVec3;

use smallvec::SmallVec;

use crate::mesh::{Mesh, Star};

/// The bend `(n_q − n_p)·(q − p)` between two surface points with their
/// unit normals.
fn bend((p, np): (DVec3, DVec3), (q, nq): (DVec3, DVec3)) -> f64 {
    (nq - np).dot(q - p)
}

/// The cosine of the largest turn of the normals, from a vertex to a
/// corner of its star, across which the sags are read (about 37°; a
/// sharper turn is a crease or a singular point, not a bend).
const MAX_TURN: f64 = 0.8;

/// One sag of a star as a function of its centre's position `p` (the
/// normals held): `|at + k·(p − p₀)|`, `p₀` the position it was read at.
/// A triangle's centroid and an edge's midpoint each give one: the bends
/// are linear in `p`.
#[derive(Clone, Copy)]
struct Linear {
    at: f64,
    k: DVec3,
}

impl Linear {
    fn sag(&self, d: DVec3) -> f64 {
        (self.at + self.k.dot(d)).abs()
    }
}

/// The sags of a vertex's star as functions of the vertex's displacement
/// (the normals held): per triangle its centroid's and the midpoint of the
/// edge from the vertex that starts it (each edge of a closed star once).
pub(crate) struct Sags {
    terms: SmallVec<[Linear; 24]>,
    /// The star's shortest edge from the vertex.
    shortest: f64,
}

impl Sags {
    /// The sags of vertex `v`'s star with `v` at `at` (position and unit
    /// normal). `None`: `v` is not a corner of one of its triangles, an
    /// edge from it has no length, or a corner's normal turns past
    /// [`MAX_TURN`] from `at`'s (a crease or a singular point, where the
    /// sags are not second order).
    pub(crate) fn of(mesh: &Mesh, star: &Star, v: usize, at: (DVec3, DVec3)) -> Option<Sags> {
        let n = at.1;
        let corner = |w: u32| (mesh.positions[w as usize], mesh.normals[w as usize]);
        let mut terms = SmallVec::new();
        let mut shortest = f64::INFINITY;
        for &ti in star.of(v) {
            let tri = mesh.triangles[ti as usize];
            let s = tri.iter().position(|&w| w as usize == v)?;
            let (b, c) = (corner(tri[(s + 1) % 3]), corner(tri[(s + 2) % 3]));
            if n.dot(b.1) < MAX_TURN || n.dot(c.1) < MAX_TURN {
                return None;
            }
            shortest = shortest.min(b.0.distance(at.0));
            // d bend(at, q) / d p = −(n_q − n).
            let edge = bend(at, b);
            let sum = edge + bend(b, c) + bend(c, at);
            terms.push(Linear {
                at: sum / 18.0,
                k: -(b.1 - n + c.1 - n) / 18.0,
            });
            terms.push(Linear {
                at: edge / 8.0,
                k: -(b.1 - n) / 8.0,
            });
        }
        (shortest > 0.0 && shortest.is_finite()).then_some(Sags { terms, shortest })
    }

    /// The largest sag with the vertex moved by `d`.
    pub(crate) fn largest(&self, d: DVec3) -> f64 {
        self.terms.iter().fold(0.0f64, |m, s| m.max(s.sag(d)))
    }

    /// Displacements, in the tangent plane of the unit normal `n`, along
    /// the descent of a soft maximum of the sags ([`SOFT`]): [`STEPS`]
    /// shares of the shortest edge. None where the descent vanishes.
    pub(crate) fn steps(&self, n: DVec3) -> impl Iterator<Item = DVec3> + '_ {
        let now = self.largest(DVec3::ZERO);
        let mut down = DVec3::ZERO;
        if now > 0.0 {
            for s in &self.terms {
                down -= s.k * s.at.signum() * (s.at.abs() / now).powi(SOFT - 1);
            }
        }
        let down = (down - n * down.dot(n)).normalize_or_zero();
        STEPS
            .iter()
            .filter(move |_| down != DVec3::ZERO)
            .map(move |s| down * (s * self.shortest))
    }
}

/// The exponent of the soft maximum whose descent [`Sags::steps`]
/// follows.
const SOFT: i32 = 8;

/// The steps [`Sags::steps`] offers along the descent, as shares of the
/// star's shortest edge.
const STEPS: [f64; 4] = [0.4, 0.2, 0.1, 0.05];

#[cfg(test)]
mod tests {
    use super::*;

    /// A vertex of the unit sphere at `centre` and a ring of `k` corners
    /// `angle` radians from the pole around it, fanned counter-clockwise
    /// seen from outside; normals are the positions (exact).
    fn fan_on_unit_sphere(centre: DVec3, k: usize, angle: f64) -> Mesh {
        let ring = (0..k).map(|i| {
            let phi = std::f64::consts::TAU * i as f64 / k as f64;
            DVec3::new(
                angle.sin() * phi.cos(),
                angle.sin() * phi.sin(),
                angle.cos(),
            )
        });
        let positions: Vec<DVec3> = std::iter::once(centre.normalize()).chain(ring).collect();
        let k = k as u32;
        Mesh {
            normals: positions.clone(),
            ambiguous: vec![false; positions.len()],
            triangles: (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect(),
            positions,
        }
    }

    /// The exact sags of vertex 0's star on the unit sphere: its
    /// triangles' centroids and its edges' midpoints, each `1 − |x|`.
    fn exact_largest(m: &Mesh) -> f64 {
        let p = &m.positions;
        m.triangles
            .iter()
            .flat_map(|t| {
                let [a, b, c] = t.map(|i| p[i as usize]);
                [(a + b + c) / 3.0, (a + b) / 2.0]
            })
            .map(|x| 1.0 - x.length())
            .fold(0.0, f64::max)
    }

    /// On a sphere the bends are exact (`b = ‖q − p‖² / R`), so the sags
    /// read from the normals match the centroids' and midpoints' true
    /// distances to second order: within 1 % on a star of edges a tenth
    /// of the radius, at the pole and off it.
    #[test]
    fn sags_from_normals_match_a_sphere_to_second_order() {
        for centre in [DVec3::Z, DVec3::new(0.03, -0.02, 1.0)] {
            let m = fan_on_unit_sphere(centre, 6, 0.1);
            let n = m.normals[0];
            let sags = Sags::of(&m, &Star::new(&m), 0, (m.positions[0], n)).expect("smooth star");
            let (read, exact) = (sags.largest(DVec3::ZERO), exact_largest(&m));
            assert!(exact > 1e-4, "{exact}");
            assert!(
                (read - exact).abs() < 0.01 * exact,
                "{read} against {exact}"
            );
        }
    }

    /// Off the centre of its ring a vertex's largest sag is the far
    /// side's; the steps offered lie in its tangent plane, the first
    /// points back towards the ring's centre, and one of them lowers the
    /// largest sag by the exact measure too, once the vertex is moved
    /// there and put back on the sphere.
    #[test]
    fn a_step_down_the_sags_lowers_the_largest_on_the_sphere() {
        let m = fan_on_unit_sphere(DVec3::new(0.04, 0.0, 1.0), 6, 0.1);
        let n = m.normals[0];
        let sags = Sags::of(&m, &Star::new(&m), 0, (m.positions[0], n)).expect("smooth star");
        let steps: Vec<DVec3> = sags.steps(n).collect();
        assert_eq!(steps.len(), STEPS.len());
        assert!(steps.iter().all(|d| d.dot(n).abs() < 1e-12 * d.length()));
        assert!(steps[0].x < 0.0, "{:?}", steps[0]);
        let before = exact_largest(&m);
        let best = steps
            .iter()
            .map(|&d| {
                let mut moved = m.clone();
                let p = (m.positions[0] + d).normalize();
                moved.positions[0] = p;
                moved.normals[0] = p;
                exact_largest(&moved)
            })
            .fold(f64::INFINITY, f64::min);
        assert!(best < 0.9 * before, "{best} against {before}");
    }

    /// A corner whose normal turns past [`MAX_TURN`] from the vertex's
    /// (a crease) leaves the star without sags.
    #[test]
    fn a_crease_in_the_star_has_no_sags() {
        let mut m = fan_on_unit_sphere(DVec3::Z, 6, 0.1);
        m.normals[3] = DVec3::X;
        let n = m.normals[0];
        assert!(Sags::of(&m, &Star::new(&m), 0, (m.positions[0], n)).is_none());
    }
}
