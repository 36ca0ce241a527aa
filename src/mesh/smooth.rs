//! Tangential smoothing with re-projection (Paiva et al. §4.3, end).
//!
//! One pass moves every vertex towards the barycentre of its star (the
//! average of its neighbours), keeping only the component of the move in
//! the tangent plane of the surface at the vertex, then projects it back
//! onto `f = 0` ([`super::roots::project`]). A move is **skipped** when it
//! would flip or collapse an incident triangle (its normal would turn by
//! more than 90° or its area fall below a fraction of the old), or when the
//! projection finds no zero near the candidate: smoothing never changes the
//! mesh's connectivity or orientation, so never its topology.
//!
//! Candidates are computed in parallel from the positions at the start of
//! the pass (the costly part: projection); they are then accepted one by
//! one against the *current* positions, so two neighbours moving at once
//! cannot together flip a triangle that each alone would not.
//!
//! Evaluation: the projections are sequential per vertex (each evaluation
//! depends on the last; the vertices run in parallel); the normals after a
//! pass are one batch of point gradients ([`super::sample::grads_at`]).

use glam::DVec3;
use rayon::prelude::*;

use super::roots::project;
use super::sample::grads_at;
use super::{Mesh, Star};
use crate::eval::Evaluator;

/// Whether moving vertex `v` to `p` keeps every incident triangle's
/// orientation and a reasonable share of its area.
fn move_is_safe(mesh: &Mesh, star: &Star, v: usize, p: DVec3) -> bool {
    star.of(v).iter().all(|&ti| {
        let t = mesh.triangles[ti as usize];
        let before = mesh.face_normal(t);
        let [a, b, c] = t.map(|i| {
            if i as usize == v {
                p
            } else {
                mesh.positions[i as usize]
            }
        });
        let after = (b - a).cross(c - a);
        after.dot(before) > 0.0 && after.length() > 0.05 * before.length()
    })
}

/// Runs `passes` smoothing passes on the surface `f(·, t) = 0`; returns how
/// many moves were accepted.
pub fn smooth<E: Evaluator + ?Sized>(mesh: &mut Mesh, f: &E, t: f64, passes: usize) -> usize {
    if passes == 0 || mesh.triangles.is_empty() {
        return 0;
    }
    let star = Star::new(mesh);
    let mut accepted = 0;
    for _ in 0..passes {
        let candidates: Vec<Option<DVec3>> = (0..mesh.positions.len())
            .into_par_iter()
            .map(|v| {
                let tris = star.of(v);
                if tris.is_empty() {
                    return None;
                }
                let p = mesh.positions[v];
                let (mut sum, mut count, mut reach) = (DVec3::ZERO, 0.0, 0.0f64);
                for &ti in tris {
                    for &w in &mesh.triangles[ti as usize] {
                        if w as usize != v {
                            let q = mesh.positions[w as usize];
                            sum += q;
                            count += 1.0;
                            reach = reach.max((q - p).length());
                        }
                    }
                }
                let n = mesh.normals[v];
                let d = sum / count - p;
                let tangential = d - n * d.dot(n);
                project(f, t, p + tangential, 0.5 * reach)
            })
            .collect();
        for (v, c) in candidates.into_iter().enumerate() {
            if let Some(p) = c
                && move_is_safe(mesh, &star, v, p)
            {
                mesh.positions[v] = p;
                accepted += 1;
            }
        }
        // Normals follow the surface at the new positions.
        let normals: Vec<DVec3> = grads_at(f, t, &mesh.positions)
            .into_par_iter()
            .zip(mesh.normals.par_iter())
            .map(|((_, g), &old)| {
                if g.is_finite() && g.length_squared() > 0.0 {
                    g.normalize()
                } else {
                    old
                }
            })
            .collect();
        mesh.normals = normals;
    }
    accepted
}
