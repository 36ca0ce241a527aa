//! Binary STL: an 80-byte header, a triangle count, then per triangle the
//! unit facet normal and three vertices (float32) and a zero attribute.

use std::io::Write;

use crate::mesh::Mesh;

/// Writes `mesh` to `out` as binary STL, with facet normals computed from
/// the triangles' winding.
pub fn write(mesh: &Mesh, out: &mut dyn Write) -> std::io::Result<()> {
    header(out, mesh.triangles.len())?;
    let mut buf = Vec::with_capacity(mesh.triangles.len() * 50);
    for &t in &mesh.triangles {
        facet(&mut buf, mesh, t);
    }
    out.write_all(&buf)
}

/// The header and the count of `triangles` (at most `u32::MAX`).
pub(crate) fn header(out: &mut dyn Write, triangles: usize) -> std::io::Result<()> {
    let mut header = [0u8; 80];
    header[..4].copy_from_slice(b"isoc");
    out.write_all(&header)?;
    let count = u32::try_from(triangles)
        .map_err(|_| std::io::Error::other("too many triangles for STL"))?;
    out.write_all(&count.to_le_bytes())
}

/// Appends triangle `t` of `mesh` to `buf`: normal, corners, attribute.
pub(crate) fn facet(buf: &mut Vec<u8>, mesh: &Mesh, t: [u32; 3]) {
    let n = mesh.face_normal(t).normalize_or_zero();
    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
    for v in [n, a, b, c] {
        for x in [v.x, v.y, v.z] {
            buf.extend_from_slice(&(x as f32).to_le_bytes());
        }
    }
    buf.extend_from_slice(&[0, 0]);
}
