//! How far a mesh's triangles stray from the surface `f = 0`.
//!
//! [`max_deviation`] samples every triangle at its centroid and at the
//! midpoints of its edges — where a flat triangle is farthest from a
//! curved surface through its corners — and moves each sample onto the
//! surface along the gradient line ([`super::roots::project`]: Newton, then
//! bisection inside a sign-change bracket). The distance to the projected
//! point is an *upper bound* on the sample's distance to the surface, since
//! the projected point lies on it (to bisection precision). A sample that
//! cannot be projected within `reach` counts as infinitely far, so a mesh
//! is never reported within a tolerance that a measured point breaks.
//!
//! # Limits
//!
//! Only those four points per triangle are measured: the deviation of the
//! rest of a triangle is not bounded (between samples a triangle could
//! pass farther from a surface with detail below the triangle's size).

use glam::DVec3;
use rayon::prelude::*;

use super::Mesh;
use crate::eval::Evaluator;
use crate::roots::project;

/// The largest distance from the samples of `mesh` (centroids and edge
/// midpoints) to the surface `f(·, t) = 0`, each found by projection no
/// farther than `reach`; `+∞` if some sample cannot be projected. 0 for a
/// mesh without triangles.
pub fn max_deviation<E: Evaluator + ?Sized>(mesh: &Mesh, f: &E, t: f64, reach: f64) -> f64 {
    triangle_deviations(mesh, f, t, reach)
        .into_iter()
        .fold(0.0, f64::max)
}

/// Per triangle of `mesh`, the largest distance from its samples to the
/// surface, as [`max_deviation`] measures it.
pub(crate) fn triangle_deviations<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    f: &E,
    t: f64,
    reach: f64,
) -> Vec<f64> {
    let p = &mesh.positions;
    mesh.triangles
        .par_iter()
        .with_min_len(256)
        .map(|tri| {
            let [a, b, c] = tri.map(|i| p[i as usize]);
            let samples = [
                (a + b + c) / 3.0,
                (a + b) * 0.5,
                (b + c) * 0.5,
                (c + a) * 0.5,
            ];
            samples
                .into_iter()
                .map(|s| distance(f, t, s, reach))
                .fold(0.0, f64::max)
        })
        .collect()
}

/// Distance from `s` to its projection on the surface (`+∞` if none within
/// `reach`).
fn distance<E: Evaluator + ?Sized>(f: &E, t: f64, s: DVec3, reach: f64) -> f64 {
    match project(f, t, s, reach) {
        Some(q) => (q - s).length(),
        None => f64::INFINITY,
    }
}
