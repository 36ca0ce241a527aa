//! Triangle meshes: the mesher's output, and its analyses (topology,
//! triangle quality, distance to the surface). Making and improving meshes
//! is [`crate::mesher`]'s.
//!
//! # Layout
//!
//! Indexed triangles over a vertex list. Per vertex: position, unit normal
//! (the direction of ∇f), and whether it lies in an ambiguous region
//! (Paiva et al. §4: the map of regions whose topology is not guaranteed).
//! Triangles are counter-clockwise seen from the side `f > 0`, so their
//! right-hand normal points along `+∇f` (outward = increasing f).

pub mod deviation;
pub(crate) mod dynmesh;
pub mod order;
pub mod origin;
pub mod quality;
pub mod sink;
pub mod topology;

use glam::DVec3;

/// An indexed triangle mesh. See the module doc.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions (domain coordinates).
    pub positions: Vec<DVec3>,
    /// Per vertex, the unit normal (direction of ∇f).
    pub normals: Vec<DVec3>,
    /// Per vertex, whether it lies in an ambiguous region (topology not
    /// guaranteed).
    pub ambiguous: Vec<bool>,
    /// Triangles as indices into `positions`, counter-clockwise seen from
    /// `f > 0`.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The right-hand normal of triangle `t`, not normalised (its length is
    /// twice the area).
    pub fn face_normal(&self, t: [u32; 3]) -> DVec3 {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        (b - a).cross(c - a)
    }
}

/// Vertex → incident triangles, as compressed rows (one `Vec` of triangle
/// indices, sliced per vertex).
pub(crate) struct Star {
    start: Vec<u32>,
    tris: Vec<u32>,
}

impl Star {
    pub fn new(mesh: &Mesh) -> Star {
        let n = mesh.positions.len();
        let mut start = vec![0u32; n + 1];
        for t in &mesh.triangles {
            for &v in t {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut tris = vec![0u32; start[n] as usize];
        for (ti, t) in mesh.triangles.iter().enumerate() {
            for &v in t {
                tris[fill[v as usize] as usize] = ti as u32;
                fill[v as usize] += 1;
            }
        }
        Star { start, tris }
    }

    /// The triangles around vertex `v`.
    pub fn of(&self, v: usize) -> &[u32] {
        &self.tris[self.start[v] as usize..self.start[v + 1] as usize]
    }
}
