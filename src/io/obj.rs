//! Wavefront OBJ: `v`, `vn` and `f v//vn` lines, 1-based indices.

use std::io::Write;

use crate::mesh::Mesh;

/// Writes `mesh` to `out` as OBJ text (without `vn` references in the faces
/// when the mesh has no normal per vertex).
pub fn write(mesh: &Mesh, out: &mut dyn Write) -> std::io::Result<()> {
    writeln!(out, "# isoc")?;
    for p in &mesh.positions {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for n in &mesh.normals {
        writeln!(out, "vn {} {} {}", n.x, n.y, n.z)?;
    }
    let with_normals = mesh.normals.len() == mesh.positions.len();
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| i + 1);
        if with_normals {
            writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}")?;
        } else {
            writeln!(out, "f {a} {b} {c}")?;
        }
    }
    Ok(())
}
