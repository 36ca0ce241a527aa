//! Binary little-endian PLY with, per vertex, `x y z` (float32), `nx ny nz`
//! (the unit gradient direction) and `red green blue` (uchar: green where
//! the mesh is guaranteed, red where it lies in an ambiguous cell), and
//! faces as `uchar`-counted `int` index lists (SPEC §3).

use std::io::Write;

use glam::DVec3;

use crate::mesh::Mesh;

/// Bytes of one vertex record.
pub(crate) const VERTEX_BYTES: usize = 27;
/// Bytes of one face record.
pub(crate) const FACE_BYTES: usize = 13;

/// Writes `mesh` to `out` as a binary little-endian PLY file.
pub fn write(mesh: &Mesh, out: &mut dyn Write) -> std::io::Result<()> {
    header(out, mesh.positions.len(), mesh.triangles.len())?;
    let mut buf =
        Vec::with_capacity(mesh.positions.len() * VERTEX_BYTES + mesh.triangles.len() * FACE_BYTES);
    for i in 0..mesh.positions.len() {
        vertex(&mut buf, mesh, i);
    }
    for t in &mesh.triangles {
        face(&mut buf, *t);
    }
    out.write_all(&buf)
}

/// The header of a file of `vertices` vertices and `faces` faces.
pub(crate) fn header(out: &mut dyn Write, vertices: usize, faces: usize) -> std::io::Result<()> {
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment isoc\n\
         element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face {faces}\nproperty list uchar int vertex_indices\nend_header\n",
    )
}

/// Appends vertex `i` of `mesh` to `buf`.
pub(crate) fn vertex(buf: &mut Vec<u8>, mesh: &Mesh, i: usize) {
    let (p, n) = (mesh.positions[i], mesh.normals.get(i).copied());
    for v in [p, n.unwrap_or(DVec3::ZERO)] {
        for x in [v.x, v.y, v.z] {
            buf.extend_from_slice(&(x as f32).to_le_bytes());
        }
    }
    buf.extend_from_slice(&colour(mesh.ambiguous.get(i).copied().unwrap_or(false)));
}

/// A vertex's colour: red in an ambiguous cell, green elsewhere.
pub(crate) fn colour(ambiguous: bool) -> [u8; 3] {
    if ambiguous {
        [220, 40, 40]
    } else {
        [40, 200, 60]
    }
}

/// Appends triangle `t` to `buf`.
pub(crate) fn face(buf: &mut Vec<u8>, t: [u32; 3]) {
    buf.push(3);
    for i in t {
        buf.extend_from_slice(&(i as i32).to_le_bytes());
    }
}
