//! How far a mesh's triangles stray from the surface `f = 0`.
//!
//! [`max_deviation`] samples every triangle at its centroid and at the
//! midpoints of its edges — where a flat triangle is farthest from a
//! curved surface through its corners — and bounds each sample's distance
//! to the surface from above (`sample_bounds`):
//!
//! - **Newton's bracket.** With `v = f(s)` and `g = ∇f(s)`, Newton's step
//!   along the gradient line is `d = −v/|g|`. If `f` changes sign between
//!   `s` and `s + 1.01·d·ĝ`, a zero lies on that segment (`f` is
//!   continuous where it is defined), so the distance is at most
//!   `1.01·|d|`: two evaluations, within 1 % of Newton's estimate.
//! - **Otherwise** (Newton's step fell short by more than 1 %, or a value
//!   is not finite) the sample is moved onto the surface along the
//!   gradient line ([`crate::roots::project`]: Newton, then bisection
//!   inside a sign-change bracket) and the distance to the projected point
//!   is the bound.
//!
//! A sample that cannot be projected within `reach` counts as infinitely
//! far, so a mesh is never reported within a tolerance that a measured
//! point breaks.
//!
//! # Limits
//!
//! Only those four points per triangle are measured: the deviation of the
//! rest of a triangle is not bounded (between samples a triangle could
//! pass farther from a surface with detail below the triangle's size).
//! The bounds rely on `f` being continuous where it is defined, as every
//! bracket search here does.

use glam::DVec3;
use rayon::prelude::*;

use super::Mesh;
use crate::eval::Evaluator;
use crate::roots::{at, project};

/// The largest distance from the samples of `mesh` (centroids and edge
/// midpoints) to the surface `f(·, t) = 0`, each bounded as the module doc
/// says (Newton's bracket or projection), searched no farther than
/// `reach`; `+∞` if some sample cannot be projected. 0 for a mesh without
/// triangles.
pub fn max_deviation<E: Evaluator + ?Sized>(mesh: &Mesh, f: &E, t: f64, reach: f64) -> f64 {
    triangle_deviations(mesh, f, t, reach, false)
        .into_iter()
        .fold(0.0, f64::max)
}

/// Per triangle of `mesh`, the largest distance from its samples to the
/// surface, as [`max_deviation`] measures it; with `on_surface` (the
/// mesh's vertices are known to lie on the surface, as the mesher's do) each
/// sample's bound is also at most its distance to the triangle's nearest
/// corner ([`triangle_bounds`]).
pub(crate) fn triangle_deviations<E: Evaluator + ?Sized>(
    mesh: &Mesh,
    f: &E,
    t: f64,
    reach: f64,
    on_surface: bool,
) -> Vec<f64> {
    let p = &mesh.positions;
    mesh.triangles
        .par_chunks(1024)
        .flat_map_iter(|tris| {
            let q: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|i| p[i as usize])).collect();
            triangle_bounds(f, t, &q, reach, on_surface)
                .into_iter()
                .map(|b| b.into_iter().fold(0.0, f64::max))
        })
        .collect()
}

/// The bounds of the four [`samples`] of each triangle of `tris` (one batch,
/// [`sample_bounds`]); with `on_surface`, each also at most the sample's
/// distance to the triangle's nearest corner ([`corner_bound`]).
pub(crate) fn triangle_bounds<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    tris: &[[DVec3; 3]],
    reach: f64,
    on_surface: bool,
) -> Vec<[f64; 4]> {
    let pts: Vec<DVec3> = tris.iter().flat_map(|&q| samples(q)).collect();
    let b = sample_bounds(f, t, &pts, reach);
    tris.iter()
        .zip(b.chunks(4).zip(pts.chunks(4)))
        .map(|(&q, (c, s))| {
            [0, 1, 2, 3].map(|k| {
                if on_surface {
                    c[k].min(corner_bound(q, s[k]))
                } else {
                    c[k]
                }
            })
        })
        .collect()
}

/// The distance from `s` to the nearest of the corners `q`: a bound on its
/// distance to the surface when the corners lie on it (a triangle no
/// larger than a tolerance is within it wherever it is measured).
pub(crate) fn corner_bound(q: [DVec3; 3], s: DVec3) -> f64 {
    q.iter()
        .map(|c| c.distance_squared(s))
        .fold(f64::INFINITY, f64::min)
        .sqrt()
}

/// The four samples of triangle `[a, b, c]`: centroid, then the midpoints
/// of `ab`, `bc`, `ca`.
pub(crate) fn samples([a, b, c]: [DVec3; 3]) -> [DVec3; 4] {
    [
        (a + b + c) / 3.0,
        (a + b) * 0.5,
        (b + c) * 0.5,
        (c + a) * 0.5,
    ]
}

/// Newton's bracket is `1 + SLACK` times Newton's step (see the module doc).
const SLACK: f64 = 0.01;

/// Upper bounds on the distances from `samples` to the surface
/// `f(·, t) = 0` (see the module doc), each searched no farther than
/// `reach`; `+∞` where no zero was found. One batch of gradients and one of
/// values for all samples; projection one at a time for the few that need
/// it.
pub(crate) fn sample_bounds<E: Evaluator + ?Sized>(
    f: &E,
    t: f64,
    samples: &[DVec3],
    reach: f64,
) -> Vec<f64> {
    let pts: Vec<[f64; 3]> = samples.iter().map(|s| s.to_array()).collect();
    let mut vg = vec![(0.0, [0.0; 3]); pts.len()];
    f.point_grad_batch(&pts, t, &mut vg);
    // Newton's bracket ends.
    let mut steps = vec![f64::NAN; pts.len()];
    let (mut xs, mut ys, mut zs) = (Vec::new(), Vec::new(), Vec::new());
    for (i, (s, &(v, g))) in samples.iter().zip(&vg).enumerate() {
        if let Some((step, e)) = newton_end(*s, v, DVec3::from_array(g), reach) {
            steps[i] = step;
            xs.push(e.x);
            ys.push(e.y);
            zs.push(e.z);
        }
    }
    let mut ends = vec![0.0; xs.len()];
    if !xs.is_empty() {
        f.point_batch(&xs, &ys, &zs, t, &mut ends);
    }
    let mut ends = ends.into_iter();
    samples
        .iter()
        .zip(&vg)
        .zip(&steps)
        .map(|((s, &(v, _)), &step)| {
            let end = if step.is_nan() {
                f64::NAN
            } else {
                ends.next().expect("one end per bracketed sample")
            };
            verdict(v, step, end).unwrap_or_else(|| distance(f, t, *s, reach))
        })
        .collect()
}

/// [`sample_bounds`] of one sample, one point at a time.
pub(crate) fn sample_bound<E: Evaluator + ?Sized>(f: &E, t: f64, s: DVec3, reach: f64) -> f64 {
    let (v, g) = f.point_grad(at(s, t));
    let (step, end) = match newton_end(s, v, DVec3::from_array(g), reach) {
        Some((step, e)) => (step, f.point(at(e, t))),
        None => (f64::NAN, f64::NAN),
    };
    verdict(v, step, end).unwrap_or_else(|| distance(f, t, s, reach))
}

/// Newton's bracket from `s` with value `v` and gradient `g`: its length
/// and its far end, when the step is finite, non-zero and within `reach`.
fn newton_end(s: DVec3, v: f64, g: DVec3, reach: f64) -> Option<(f64, DVec3)> {
    let len = g.length();
    if !(v.is_finite() && v != 0.0 && len.is_finite() && len > 0.0) {
        return None;
    }
    let d = -v / len;
    let step = d.abs() * (1.0 + SLACK);
    (step <= reach).then(|| (step, s + g * (d * (1.0 + SLACK) / len)))
}

/// The bound from a sample's value `v`, its Newton bracket's length `step`
/// (NaN: none) and the value `end` at the bracket's far end; `None` when
/// the bracket shows no sign change (project instead).
fn verdict(v: f64, step: f64, end: f64) -> Option<f64> {
    if v == 0.0 {
        return Some(0.0);
    }
    let changes = end == 0.0 || (end.is_finite() && (end < 0.0) != (v < 0.0));
    (!step.is_nan() && changes).then_some(step)
}

/// Distance from `s` to its projection on the surface (`+∞` if none within
/// `reach`).
fn distance<E: Evaluator + ?Sized>(f: &E, t: f64, s: DVec3, reach: f64) -> f64 {
    match project(f, t, s, reach) {
        Some(q) => (q - s).length(),
        None => f64::INFINITY,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CompileOptions, Surface};

    fn points(n: usize) -> Vec<DVec3> {
        let mut rng = crate::testing::Rng::new(0x9E37_79B9_7F4A_7C15);
        let mut unit = || rng.unit();
        (0..n)
            .map(|_| {
                let d = DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5).normalize();
                // Within 0.05 of the unit sphere, on either side.
                d * (0.95 + 0.1 * unit())
            })
            .collect()
    }

    /// Against the exact distance to the unit sphere: every bound is an
    /// upper bound, for `r² − 1` (Newton's bracket, within 1 % of the
    /// exact distance up to Newton's own error) and for `(r² − 1)³`, whose
    /// Newton step is a third of the distance (the bracket fails and the
    /// projection decides); the scalar and batch forms agree.
    #[test]
    fn bounds_are_upper_bounds_of_the_exact_distance() {
        for (src, tight) in [
            ("domain [-2, 2]^3; surface x^2 + y^2 + z^2 - 1;", true),
            ("domain [-2, 2]^3; surface (x^2 + y^2 + z^2 - 1)^3;", false),
        ] {
            let s = Surface::compile(src, "t.iso", &CompileOptions::default()).unwrap();
            let pts = points(500);
            let batch = sample_bounds(&s, 0.0, &pts, 0.5);
            for (p, b) in pts.iter().zip(&batch) {
                let exact = (p.length() - 1.0).abs();
                assert!(
                    *b >= exact * (1.0 - 1e-12),
                    "{src}: bound {b:e} < exact {exact:e} at {p:?}"
                );
                if tight {
                    assert!(
                        *b <= exact * 1.06 + 1e-15,
                        "{src}: bound {b:e} loose for {exact:e}"
                    );
                }
                let one = sample_bound(&s, 0.0, *p, 0.5);
                assert_eq!(
                    one.to_bits(),
                    b.to_bits(),
                    "{src}: scalar {one:e} != batch {b:e}"
                );
            }
        }
    }

    /// Corners on the surface bound every sample by its nearest corner.
    #[test]
    fn the_corner_bound_caps_unprojectable_samples() {
        // `sqrt` of a negative is NaN: no sample inside the unit ball
        // projects, yet a small triangle with corners on the sphere is
        // within its size.
        let s = Surface::compile(
            "domain [-2, 2]^3; surface sqrt(1 - x^2 - y^2 - z^2) - 0.0;",
            "t.iso",
            &CompileOptions::default(),
        )
        .unwrap();
        let q = [
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0).lerp(DVec3::X, 0.99).normalize(),
            DVec3::new(0.0, 0.0, 1.0).lerp(DVec3::X, 0.99).normalize(),
        ];
        let free = triangle_bounds(&s, 0.0, &[q], 0.1, false)[0];
        let capped = triangle_bounds(&s, 0.0, &[q], 0.1, true)[0];
        for k in 0..4 {
            assert!(capped[k] <= free[k]);
            assert!(capped[k] <= corner_bound(q, samples(q)[k]));
        }
        assert!(capped.iter().all(|d| d.is_finite()));
    }
}
