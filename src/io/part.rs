//! Part files (SPEC §2 `--brick I`, `isoc merge`): one brick's mesh with
//! what welding needs, as a binary little-endian PLY that viewers open.
//!
//! # Layout
//!
//! The header's first comment is `comment isoc-part ` and one line of
//! JSON saying which brick of which run the file is (its content is the
//! caller's: [`crate::mesher::brick::PartInfo`]). Per vertex: `x y z`
//! (double, so a merge is exact), `nx ny nz` (float), `red green blue`
//! (uchar, as [`super::ply`]), the vertex's id as four `uint` words
//! `id0..id3`, low word first ([`crate::mesh::origin::VertexId`]), and
//! `sides` (uchar, [`crate::mesh::origin::Sides`]). Faces as `uchar`-counted
//! `int` lists.
//!
//! # Limits
//!
//! [`read`] reads what [`write`] writes, and refuses any other PLY with a
//! message (no panic, nothing allocated beyond the file's size).

use std::io::{BufRead, Read, Write};

use glam::DVec3;

use crate::mesh::Mesh;
use crate::mesh::origin::Origins;

/// The first comment line's start.
const TAG: &str = "comment isoc-part ";

/// The header after the tag line, up to the vertex count, and from the
/// vertex properties to the face count.
const VERTEX_PROPERTIES: &str = "property double x\nproperty double y\nproperty double z\n\
     property double nx\nproperty double ny\nproperty double nz\n\
     property uchar red\nproperty uchar green\nproperty uchar blue\n\
     property uint id0\nproperty uint id1\nproperty uint id2\nproperty uint id3\n\
     property uchar sides\n";

/// Bytes of a vertex record.
const VERTEX_BYTES: usize = 24 + 24 + 3 + 16 + 1;
/// Bytes of a face record.
const FACE_BYTES: usize = 13;

/// Why a file is not a part [`read`] takes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PartError(pub String);

impl std::fmt::Display for PartError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "not an isoc part file: {}", self.0)
    }
}

impl std::error::Error for PartError {}

fn bad<T>(why: impl Into<String>) -> Result<T, PartError> {
    Err(PartError(why.into()))
}

/// Writes a part: `mesh`, its vertices' `origins`, and `info` (one line
/// of JSON, no newline).
pub fn write(
    mesh: &Mesh,
    origins: &Origins,
    info: &str,
    out: &mut dyn Write,
) -> std::io::Result<()> {
    let info = info.replace('\n', " ");
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\n{TAG}{info}\nelement vertex {}\n\
         {VERTEX_PROPERTIES}element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangles.len()
    )?;
    let mut buf = Vec::with_capacity(1 << 16);
    for (i, p) in mesh.positions.iter().enumerate() {
        let n = mesh.normals.get(i).copied().unwrap_or(DVec3::ZERO);
        for x in p.to_array().into_iter().chain(n.to_array()) {
            buf.extend_from_slice(&x.to_le_bytes());
        }
        let ambiguous = mesh.ambiguous.get(i).copied().unwrap_or(false);
        buf.extend_from_slice(&super::ply::colour(ambiguous));
        let id = origins.ids[i];
        for k in 0..4 {
            buf.extend_from_slice(&((id >> (32 * k)) as u32).to_le_bytes());
        }
        buf.push(origins.sides[i]);
        if buf.len() > 1 << 16 {
            out.write_all(&buf)?;
            buf.clear();
        }
    }
    for t in &mesh.triangles {
        super::ply::face(&mut buf, *t);
        if buf.len() > 1 << 16 {
            out.write_all(&buf)?;
            buf.clear();
        }
    }
    out.write_all(&buf)
}

/// A part's header: its info line and its counts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Header {
    /// The JSON line given to [`write`].
    pub info: String,
    /// Vertices.
    pub vertices: usize,
    /// Faces.
    pub faces: usize,
    /// Bytes of the header (the records follow).
    pub len: usize,
}

/// Reads a part's header from the start of `input` (at most 1 MiB).
pub fn read_header<R: BufRead>(input: &mut R) -> Result<Header, PartError> {
    let mut lines = Vec::new();
    let mut len = 0;
    loop {
        let mut line = Vec::new();
        let n = input
            .by_ref()
            .take((1 << 20) - len as u64)
            .read_until(b'\n', &mut line)
            .map_err(|e| PartError(e.to_string()))?;
        if n == 0 || line.last() != Some(&b'\n') {
            return bad("the header has no end_header line");
        }
        len += n;
        let text =
            String::from_utf8(line).map_err(|_| PartError("the header is not text".into()))?;
        let done = text == "end_header\n";
        lines.push(text);
        if done {
            break;
        }
    }
    parse_header(&lines.concat(), len)
}

/// Checks the header's lines against [`write`]'s.
fn parse_header(text: &str, len: usize) -> Result<Header, PartError> {
    let Some(rest) = text.strip_prefix("ply\nformat binary_little_endian 1.0\n") else {
        return bad("not a binary little-endian PLY file");
    };
    let Some(rest) = rest.strip_prefix(TAG) else {
        return bad("no `comment isoc-part` line (write parts with `isoc mesh --brick I`)");
    };
    let (info, rest) = rest.split_once('\n').unwrap_or((rest, ""));
    let count = |rest: &str, element: &str| -> Result<(usize, String), PartError> {
        let Some(r) = rest.strip_prefix(element) else {
            return bad(format!("expected `{}`", element.trim()));
        };
        let (n, r) = r.split_once('\n').unwrap_or((r, ""));
        let n = n
            .parse()
            .map_err(|_| PartError(format!("`{element}{n}`: not a count")))?;
        Ok((n, r.to_string()))
    };
    let (vertices, rest) = count(rest, "element vertex ")?;
    let Some(rest) = rest.strip_prefix(VERTEX_PROPERTIES) else {
        return bad("the vertex properties are not a part's");
    };
    let (faces, rest) = count(rest, "element face ")?;
    if rest != "property list uchar int vertex_indices\nend_header\n" {
        return bad("the face properties are not a part's");
    }
    Ok(Header {
        info: info.to_string(),
        vertices,
        faces,
        len,
    })
}

/// Reads a whole part: its mesh, its origins and its info line.
pub fn read(bytes: &[u8]) -> Result<(Mesh, Origins, String), PartError> {
    let h = read_header(&mut &bytes[..])?;
    let body = &bytes[h.len..];
    let need = h
        .vertices
        .checked_mul(VERTEX_BYTES)
        .zip(h.faces.checked_mul(FACE_BYTES))
        .and_then(|(v, f)| v.checked_add(f));
    if need != Some(body.len()) {
        return bad(format!(
            "{} vertices and {} faces need {} bytes after the header; the file has {}",
            h.vertices,
            h.faces,
            need.map_or("too many".to_string(), |n| n.to_string()),
            body.len()
        ));
    }
    let (vs, fs) = body.split_at(h.vertices * VERTEX_BYTES);
    let mut mesh = Mesh::default();
    let mut origins = Origins::default();
    for r in vs.chunks_exact(VERTEX_BYTES) {
        let f64_at = |k: usize| f64::from_le_bytes(r[8 * k..8 * k + 8].try_into().expect("8"));
        mesh.positions
            .push(DVec3::new(f64_at(0), f64_at(1), f64_at(2)));
        mesh.normals
            .push(DVec3::new(f64_at(3), f64_at(4), f64_at(5)));
        mesh.ambiguous.push(r[48] > r[49]);
        let word = |k: usize| {
            u128::from(u32::from_le_bytes(
                r[51 + 4 * k..55 + 4 * k].try_into().expect("4"),
            ))
        };
        origins.ids.push((0..4).map(|k| word(k) << (32 * k)).sum());
        origins.sides.push(r[67]);
    }
    for r in fs.chunks_exact(FACE_BYTES) {
        let idx = |k: usize| i32::from_le_bytes(r[1 + 4 * k..5 + 4 * k].try_into().expect("4"));
        let t = [idx(0), idx(1), idx(2)];
        if r[0] != 3 || t.iter().any(|&i| i < 0 || i as usize >= h.vertices) {
            return bad(format!(
                "face {} is not a triangle of the file's vertices",
                mesh.triangles.len()
            ));
        }
        mesh.triangles.push(t.map(|i| i as u32));
    }
    Ok((mesh, origins, h.info))
}
