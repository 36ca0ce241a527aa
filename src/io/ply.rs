//! Binary little-endian PLY with, per vertex, `x y z` (float32), `nx ny nz`
//! (the unit gradient direction) and `red green blue` (uchar: green where
//! the mesh is guaranteed, red where it lies in an ambiguous cell), and
//! faces as `uchar`-counted `int` index lists (SPEC §3).

use std::io::Write;

use crate::mesh::Mesh;

/// Writes `mesh` to `out` as a binary little-endian PLY file.
pub fn write(mesh: &Mesh, out: &mut dyn Write) -> std::io::Result<()> {
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment isoc\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangles.len()
    )?;
    let mut buf = Vec::with_capacity(mesh.positions.len() * 27 + mesh.triangles.len() * 13);
    for (i, p) in mesh.positions.iter().enumerate() {
        let n = mesh.normals.get(i).copied().unwrap_or_default();
        for v in [p.x, p.y, p.z, n.x, n.y, n.z] {
            buf.extend_from_slice(&(v as f32).to_le_bytes());
        }
        let ambiguous = mesh.ambiguous.get(i).copied().unwrap_or(false);
        buf.extend_from_slice(if ambiguous {
            &[220, 40, 40]
        } else {
            &[40, 200, 60]
        });
    }
    for t in &mesh.triangles {
        buf.push(3);
        for i in t {
            buf.extend_from_slice(&(*i as i32).to_le_bytes());
        }
    }
    out.write_all(&buf)
}
