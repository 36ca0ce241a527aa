//! Wavefront OBJ: per vertex a `v` line and, when the mesh has normals, a
//! `vn` line (so both count alike), then `f v//vn` lines, 1-based indices.

use std::io::Write;

use crate::mesh::Mesh;

/// Writes `mesh` to `out` as OBJ text (without `vn` references in the faces
/// when the mesh has no normal per vertex).
pub fn write(mesh: &Mesh, out: &mut dyn Write) -> std::io::Result<()> {
    let mut buf = b"# isoc\n".to_vec();
    for i in 0..mesh.positions.len() {
        vertex(&mut buf, mesh, i);
    }
    for t in &mesh.triangles {
        face(&mut buf, *t, with_normals(mesh));
    }
    out.write_all(&buf)
}

/// Whether `mesh` has a normal per vertex (its faces then name them).
pub(crate) fn with_normals(mesh: &Mesh) -> bool {
    mesh.normals.len() == mesh.positions.len()
}

/// Appends vertex `i` of `mesh`: its `v` line, and its `vn` line if the
/// mesh has normals.
pub(crate) fn vertex(buf: &mut Vec<u8>, mesh: &Mesh, i: usize) {
    let p = mesh.positions[i];
    let _ = writeln!(buf, "v {} {} {}", p.x, p.y, p.z);
    if with_normals(mesh) {
        let n = mesh.normals[i];
        let _ = writeln!(buf, "vn {} {} {}", n.x, n.y, n.z);
    }
}

/// Appends triangle `t` (0-based) as an `f` line.
pub(crate) fn face(buf: &mut Vec<u8>, t: [u32; 3], normals: bool) {
    let [a, b, c] = t.map(|i| u64::from(i) + 1);
    let _ = if normals {
        writeln!(buf, "f {a}//{a} {b}//{b} {c}//{c}")
    } else {
        writeln!(buf, "f {a} {b} {c}")
    };
}
