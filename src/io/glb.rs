//! GLB, the binary container of glTF 2.0 (Khronos glTF 2.0 specification,
//! §4.4 "Binary glTF layout"): a 12-byte header, a JSON chunk and a BIN
//! chunk, each 4-byte aligned. One mesh with one triangle primitive:
//! `POSITION` and `NORMAL` (float32 VEC3), `COLOR_0` (normalised uchar
//! VEC4: the ambiguity colours), `uint32` indices.

use std::io::Write;

use serde_json::json;

use crate::mesh::Mesh;

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

fn pad4(v: &mut Vec<u8>, byte: u8) {
    while !v.len().is_multiple_of(4) {
        v.push(byte);
    }
}

/// Writes `mesh` to `out` as one GLB file: header, JSON chunk and BIN chunk.
pub fn write(mesh: &Mesh, out: &mut dyn Write) -> std::io::Result<()> {
    let nv = mesh.positions.len();
    let mut bin = Vec::with_capacity(nv * 28 + mesh.triangles.len() * 12);
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &mesh.positions {
        for (k, x) in [p.x, p.y, p.z].into_iter().enumerate() {
            let x = x as f32;
            lo[k] = lo[k].min(x);
            hi[k] = hi[k].max(x);
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    let normals_at = bin.len();
    for i in 0..nv {
        let n = mesh.normals.get(i).copied().unwrap_or_default();
        for x in [n.x, n.y, n.z] {
            bin.extend_from_slice(&(x as f32).to_le_bytes());
        }
    }
    let colors_at = bin.len();
    for i in 0..nv {
        let bad = mesh.ambiguous.get(i).copied().unwrap_or(false);
        bin.extend_from_slice(if bad {
            &[220, 40, 40, 255]
        } else {
            &[40, 200, 60, 255]
        });
    }
    let indices_at = bin.len();
    for t in &mesh.triangles {
        for i in t {
            bin.extend_from_slice(&i.to_le_bytes());
        }
    }
    let total = bin.len();
    if nv == 0 {
        lo = [0.0; 3];
        hi = [0.0; 3];
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "isoc"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "COLOR_0": 2},
            "indices": 3,
            "mode": 4
        }]}],
        "buffers": [{"byteLength": total}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": normals_at, "target": ARRAY_BUFFER},
            {"buffer": 0, "byteOffset": normals_at, "byteLength": colors_at - normals_at, "target": ARRAY_BUFFER},
            {"buffer": 0, "byteOffset": colors_at, "byteLength": indices_at - colors_at, "target": ARRAY_BUFFER},
            {"buffer": 0, "byteOffset": indices_at, "byteLength": total - indices_at, "target": ELEMENT_ARRAY_BUFFER}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3", "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5121, "normalized": true, "count": nv, "type": "VEC4"},
            {"bufferView": 3, "componentType": 5125, "count": mesh.triangles.len() * 3, "type": "SCALAR"}
        ]
    });
    let mut json_bytes = serde_json::to_vec(&doc).map_err(std::io::Error::other)?;
    pad4(&mut json_bytes, b' ');
    pad4(&mut bin, 0);
    let length = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let length =
        u32::try_from(length).map_err(|_| std::io::Error::other("mesh too large for GLB"))?;
    out.write_all(b"glTF")?;
    out.write_all(&2u32.to_le_bytes())?;
    out.write_all(&length.to_le_bytes())?;
    out.write_all(&(json_bytes.len() as u32).to_le_bytes())?;
    out.write_all(b"JSON")?;
    out.write_all(&json_bytes)?;
    out.write_all(&(bin.len() as u32).to_le_bytes())?;
    out.write_all(b"BIN\0")?;
    out.write_all(&bin)
}
