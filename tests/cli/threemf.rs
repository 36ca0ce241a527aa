//! 3MF output (SPEC §2): the package is read back with the `zip` crate and
//! a small attribute scanner here — its parts, the unit, and the vertices
//! and triangles, exactly; the command line writes it with `-o x.3mf` and
//! `--unit`, and writes nothing on error.

use std::io::Read;
use std::path::Path;
use std::process::Command;

use glam::DVec3;
use isoc::io::threemf::{self, Unit};
use isoc::mesh::Mesh;

fn tetra() -> Mesh {
    let positions = vec![
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.5, 0.0, 0.0),
        DVec3::new(0.0, 0.1, 0.0),
        DVec3::new(0.0, 0.0, -1e-7),
    ];
    Mesh {
        normals: vec![DVec3::X; 4],
        ambiguous: vec![false; 4],
        triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        positions,
    }
}

/// The package's parts by name.
fn parts(bytes: &[u8]) -> Vec<(String, String)> {
    let mut zip = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
    (0..zip.len())
        .map(|i| {
            let mut f = zip.by_index(i).unwrap();
            let mut s = String::new();
            f.read_to_string(&mut s).unwrap();
            (f.name().unwrap().to_string(), s)
        })
        .collect()
}

/// The value of every `name="…"` attribute of every `<tag …/>` element.
fn attrs(xml: &str, tag: &str, name: &str) -> Vec<String> {
    xml.split(&format!("<{tag} "))
        .skip(1)
        .map(|e| {
            let e = &e[..e.find('>').unwrap()];
            let at = e.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
            e[at..at + e[at..].find('"').unwrap()].to_string()
        })
        .collect()
}

/// Vertices and triangles of the (single) model part.
fn read_model(model: &str) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let f = |k| attrs(model, "vertex", k);
    let (x, y, z) = (f("x"), f("y"), f("z"));
    let v = (0..x.len())
        .map(|i| [&x[i], &y[i], &z[i]].map(|s| s.parse().unwrap()))
        .collect();
    let g = |k| attrs(model, "triangle", k);
    let (a, b, c) = (g("v1"), g("v2"), g("v3"));
    let t = (0..a.len())
        .map(|i| [&a[i], &b[i], &c[i]].map(|s| s.parse().unwrap()))
        .collect();
    (v, t)
}

fn model_of(bytes: &[u8]) -> String {
    let p = parts(bytes);
    let names: Vec<&str> = p.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        ["[Content_Types].xml", "_rels/.rels", "3D/3dmodel.model"]
    );
    assert!(p[0].1.contains("Extension=\"model\""));
    assert!(p[1].1.contains("Target=\"/3D/3dmodel.model\""));
    p[2].1.clone()
}

#[test]
fn package_round_trip_is_exact() {
    let m = tetra();
    let mut bytes = Vec::new();
    isoc::io::encode(&m, isoc::io::Format::ThreeMf, &mut bytes).unwrap();
    let model = model_of(&bytes);
    assert_eq!(attrs(&model, "model", "unit"), ["millimeter"]);
    let (v, t) = read_model(&model);
    let want: Vec<[f64; 3]> = m.positions.iter().map(|p| p.to_array()).collect();
    assert_eq!(v, want);
    assert_eq!(t, m.triangles);
    assert_eq!(attrs(&model, "item", "objectid"), ["1"]);
}

#[test]
fn units_and_objects() {
    let m = tetra();
    for unit in Unit::ALL {
        assert_eq!(unit.name().parse::<Unit>(), Ok(unit));
        let mut bytes = Vec::new();
        threemf::write_objects(&[&m, &m], unit, &mut bytes).unwrap();
        let model = model_of(&bytes);
        assert_eq!(attrs(&model, "model", "unit"), [unit.name()]);
        assert_eq!(attrs(&model, "object", "id"), ["1", "2"]);
        assert_eq!(attrs(&model, "item", "objectid"), ["1", "2"]);
        assert_eq!(attrs(&model, "triangle", "v1").len(), 8);
    }
    assert!("furlong".parse::<Unit>().is_err());
    assert_eq!("mm".parse::<Unit>(), Ok(Unit::Millimeter));
}

#[test]
fn empty_meshes_are_no_objects() {
    // The core specification requires triangles in a mesh object: an empty
    // mesh is left out and the ids stay consecutive.
    let m = tetra();
    let empty = Mesh::default();
    let mut bytes = Vec::new();
    threemf::write_objects(&[&empty, &m, &empty], Unit::Millimeter, &mut bytes).unwrap();
    let model = model_of(&bytes);
    assert_eq!(attrs(&model, "object", "id"), ["1"]);
    assert_eq!(attrs(&model, "item", "objectid"), ["1"]);
    assert_eq!(
        read_model(&model),
        read_model(&model_of(&{
            let mut one = Vec::new();
            threemf::write(&m, &mut one).unwrap();
            one
        }))
    );
    let mut bytes = Vec::new();
    threemf::write(&empty, &mut bytes).unwrap();
    let model = model_of(&bytes);
    assert!(!model.contains("<object") && !model.contains("<item"));
    assert!(model.contains("<resources>") && model.contains("<build>"));
}

fn isoc(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_isoc"))
        .args(args)
        .output()
        .expect("run isoc")
}

#[test]
fn cli_writes_3mf_with_unit_and_nothing_on_error() {
    let dir = std::env::temp_dir().join(format!("isoc-3mf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sphere = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus/sphere.iso");
    let out = dir.join("sphere.3mf");
    let o = isoc(&[
        "mesh",
        sphere.to_str().unwrap(),
        "--level",
        "4",
        "-o",
        out.to_str().unwrap(),
        "--unit",
        "inch",
        "--stats",
        "json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stats: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let model = model_of(&std::fs::read(&out).unwrap());
    assert_eq!(attrs(&model, "model", "unit"), ["inch"]);
    let (v, t) = read_model(&model);
    assert_eq!(v.len() as u64, stats["vertices"].as_u64().unwrap());
    assert_eq!(t.len() as u64, stats["triangles"].as_u64().unwrap());
    // Every edge of the closed mesh is used twice, once each way.
    let mut edges = std::collections::HashMap::new();
    for tri in &t {
        for k in 0..3 {
            *edges.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    assert!(
        edges
            .iter()
            .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
    );

    // A bad unit, or a source that does not compile: exit 1, no file.
    let bad = dir.join("bad.3mf");
    let o = isoc(&[
        "mesh",
        sphere.to_str().unwrap(),
        "-o",
        bad.to_str().unwrap(),
        "--unit",
        "furlong",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown unit `furlong`"));
    let broken = dir.join("broken.iso");
    std::fs::write(&broken, "domain [-1, 1]^3; surface x +;").unwrap();
    let o = isoc(&[
        "mesh",
        broken.to_str().unwrap(),
        "-o",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!bad.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
