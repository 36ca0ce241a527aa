//! Triangle quality: the aspect ratio of Paiva et al. Table 1.

use glam::DVec3;

use super::Mesh;

/// `4√3·area / (|ab|² + |ac|² + |bc|²)`: 1 for an equilateral triangle,
/// 0 for a degenerate one.
pub fn aspect_ratio(mesh: &Mesh, t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
    aspect(a, b, c)
}

/// [`aspect_ratio`] of the triangle `a, b, c`.
pub fn aspect(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let area = 0.5 * (b - a).cross(c - a).length();
    let s = (b - a).length_squared() + (c - a).length_squared() + (c - b).length_squared();
    if s > 0.0 {
        4.0 * 3f64.sqrt() * area / s
    } else {
        0.0
    }
}

/// The share of triangles whose aspect ratio exceeds 0.8 (SPEC §2
/// `aspect_good`); 0 for an empty mesh.
pub fn aspect_good(mesh: &Mesh) -> f64 {
    if mesh.triangles.is_empty() {
        return 0.0;
    }
    good_triangles(mesh) as f64 / mesh.triangles.len() as f64
}

/// How many triangles have aspect ratio > 0.8 (the numerator of
/// [`aspect_good`]).
pub fn good_triangles(mesh: &Mesh) -> usize {
    mesh.triangles
        .iter()
        .filter(|&&t| aspect_ratio(mesh, t) > 0.8)
        .count()
}
