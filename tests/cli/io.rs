//! Mesh writers: each format read back (by a small independent reader
//! here) gives the mesh that was written; files are written atomically.

use glam::DVec3;
use isoc::io::{self, Format};
use isoc::mesh::Mesh;

fn tetra() -> Mesh {
    let positions = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(0.0, 0.0, 1.0),
    ];
    let c = DVec3::splat(0.25);
    Mesh {
        normals: positions.iter().map(|p| (*p - c).normalize()).collect(),
        ambiguous: vec![false, true, false, false],
        triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        positions,
    }
}

fn encode(m: &Mesh, f: Format) -> Vec<u8> {
    let mut v = Vec::new();
    io::encode(m, f, &mut v).unwrap();
    v
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

#[test]
fn ply_binary_round_trip() {
    let m = tetra();
    let b = encode(&m, Format::Ply);
    let end = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let header = std::str::from_utf8(&b[..end]).unwrap();
    assert!(header.starts_with("ply\nformat binary_little_endian 1.0\n"));
    assert!(header.contains("element vertex 4\n") && header.contains("element face 4\n"));
    for p in ["x", "y", "z", "nx", "ny", "nz"] {
        assert!(header.contains(&format!("property float {p}\n")), "{p}");
    }
    for p in ["red", "green", "blue"] {
        assert!(header.contains(&format!("property uchar {p}\n")), "{p}");
    }
    let vsize = 6 * 4 + 3;
    for (i, p) in m.positions.iter().enumerate() {
        let at = end + i * vsize;
        assert_eq!(f32_at(&b, at), p.x as f32);
        assert_eq!(f32_at(&b, at + 8), p.z as f32);
        assert_eq!(f32_at(&b, at + 12), m.normals[i].x as f32);
        let rgb = &b[at + 24..at + 27];
        if m.ambiguous[i] {
            assert!(rgb[0] > rgb[1], "ambiguous vertices are red");
        } else {
            assert!(rgb[1] > rgb[0], "guaranteed vertices are green");
        }
    }
    let faces = end + 4 * vsize;
    assert_eq!(b.len(), faces + 4 * 13);
    for (k, t) in m.triangles.iter().enumerate() {
        let at = faces + k * 13;
        assert_eq!(b[at], 3);
        for (j, &i) in t.iter().enumerate() {
            assert_eq!(u32_at(&b, at + 1 + 4 * j), i);
        }
    }
}

#[test]
fn stl_binary_layout() {
    let m = tetra();
    let b = encode(&m, Format::Stl);
    assert_eq!(b.len(), 84 + 50 * 4);
    assert_eq!(u32_at(&b, 80), 4);
    // Facet normal of [0, 2, 1] is -z.
    assert_eq!(f32_at(&b, 84 + 8), -1.0);
}

#[test]
fn obj_text() {
    let m = tetra();
    let s = String::from_utf8(encode(&m, Format::Obj)).unwrap();
    assert_eq!(s.lines().filter(|l| l.starts_with("v ")).count(), 4);
    assert_eq!(s.lines().filter(|l| l.starts_with("vn ")).count(), 4);
    assert!(s.contains("f 1//1 3//3 2//2"));
}

#[test]
fn glb_container() {
    let m = tetra();
    let b = encode(&m, Format::Glb);
    assert_eq!(&b[0..4], b"glTF");
    assert_eq!(u32_at(&b, 4), 2);
    assert_eq!(u32_at(&b, 8) as usize, b.len());
    let json_len = u32_at(&b, 12) as usize;
    assert_eq!(&b[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let doc: serde_json::Value = serde_json::from_slice(&b[20..20 + json_len]).unwrap();
    assert_eq!(doc["asset"]["version"], "2.0");
    assert_eq!(doc["accessors"][0]["count"], 4);
    assert_eq!(doc["accessors"][3]["count"], 12);
    let bin_at = 20 + json_len;
    let bin_len = u32_at(&b, bin_at) as usize;
    assert_eq!(&b[bin_at + 4..bin_at + 8], b"BIN\0");
    assert_eq!(bin_at + 8 + bin_len, b.len());
    assert!(bin_len >= doc["buffers"][0]["byteLength"].as_u64().unwrap() as usize);
    // Indices are the last buffer view.
    let view = &doc["bufferViews"][3];
    let off = bin_at + 8 + view["byteOffset"].as_u64().unwrap() as usize;
    assert_eq!(u32_at(&b, off + 4), 2);
}

#[test]
fn formats_follow_the_extension_and_writes_are_atomic() {
    let dir = std::env::temp_dir().join(format!("isoc-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let m = tetra();
    for ext in ["ply", "obj", "stl", "glb", "PLY"] {
        let p = dir.join(format!("t.{ext}"));
        io::write_file(&m, &p).unwrap();
        assert!(std::fs::metadata(&p).unwrap().len() > 0);
    }
    assert!(io::write_file(&m, &dir.join("t.xyz")).is_err());
    // A failing writer leaves neither the target nor a temporary file.
    let target = dir.join("fail.ply");
    let r = io::write_atomic(&target, |w| {
        w.write_all(b"partial")?;
        Err(std::io::Error::other("boom"))
    });
    assert!(r.is_err());
    assert!(!target.exists());
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("fail"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}
