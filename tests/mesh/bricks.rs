//! Bricked meshing (`isoc::mesher::brick`): the parts of `8^B` bricks,
//! welded by their vertices' ids, against the whole run's mesh — the same
//! triangles over the same positions, bit for bit, with smoothing and
//! creases off; closed and 2-manifold across the seams with them on.

use isoc::io::part;
use isoc::io::stream::StreamWriter;
use isoc::io::threemf::Unit;
use isoc::mesh::Mesh;
use isoc::mesh::topology::analyze_in;
use isoc::mesher::brick::{self, Brick, Part};
use isoc::mesher::stitch::Stitcher;
use isoc::mesher::{self, MeshOptions};
use isoc::{Bounds, Cancel, Surface};

use crate::support::csg::{self, Config, Scene};

/// The parts of every brick of level `b`.
fn parts(s: &Surface, opts: &MeshOptions, b: u8) -> Vec<Part> {
    (0..Brick::count(b))
        .map(|i| {
            let brick = Brick::new(b, i).expect("a brick in range");
            brick::mesh_brick(s, s.domain, opts, brick, &|_| {}, &Cancel::new())
                .expect("never cancelled")
        })
        .collect()
}

/// A triangle as the bits of its corners' positions, rotated to start at
/// the least (orientation kept).
fn canonical(mesh: &Mesh) -> Vec<[[u64; 3]; 3]> {
    let mut tris: Vec<[[u64; 3]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|v| mesh.positions[v as usize].to_array().map(f64::to_bits));
            let r = (0..3).min_by_key(|&k| p[k]).unwrap_or(0);
            [p[r], p[(r + 1) % 3], p[(r + 2) % 3]]
        })
        .collect();
    tris.sort_unstable();
    tris
}

/// Asserts that the parts of every brick level in `levels` weld into
/// exactly the whole run's mesh (as triangle sets), with no vertex
/// repeated at one id.
fn assert_bricked_is_whole(name: &str, s: &Surface, opts: &MeshOptions, levels: &[u8]) {
    let (whole, report) = mesher::mesh(s, opts, &|_| {});
    let expected = canonical(&whole);
    for &b in levels {
        let parts = parts(s, opts, b);
        let (merged, stitched) = brick::merge(&parts);
        let got = canonical(&merged);
        let missing = expected
            .iter()
            .filter(|t| got.binary_search(t).is_err())
            .count();
        let extra = got
            .iter()
            .filter(|t| expected.binary_search(t).is_err())
            .count();
        assert!(
            missing == 0 && extra == 0 && merged.positions.len() == whole.positions.len(),
            "{name}, B = {b}: {missing} of {} triangles missing, {extra} extra; {} vertices against {}",
            expected.len(),
            merged.positions.len(),
            whole.positions.len()
        );
        let reports: Vec<_> = parts.iter().map(|p| p.report.clone()).collect();
        let r = brick::merge_reports(&reports, &stitched, 0.0);
        assert_eq!(r.octree, report.octree, "{name}, B = {b}: octree counts");
        assert_eq!(r.active_cells, report.active_cells, "{name}, B = {b}");
        assert_eq!(
            r.topology, report.topology,
            "{name}, B = {b}: tallied topology"
        );
        assert_eq!(r.aspect_good, report.aspect_good, "{name}, B = {b}");
    }
}

fn plain(level: u8) -> MeshOptions {
    csg::options(level, true)
}

#[test]
fn bricked_corpus_surfaces_equal_the_whole_mesh() {
    for name in [
        "heart",
        "torus",
        "twotorus",
        "chair_off",
        "cyclide",
        "tanglecube",
        "twoplanes",
        "nested",
    ] {
        let path = format!("corpus/{name}.iso");
        let Ok(src) = std::fs::read_to_string(&path) else {
            continue;
        };
        let s = csg::compile(&src, &path);
        assert_bricked_is_whole(&path, &s, &plain(6), &[1, 2]);
    }
}

#[test]
fn bricked_random_csg_scenes_equal_the_whole_mesh() {
    let cfg = Config::default();
    for seed in 0..24 {
        let scene = Scene::random(seed, &cfg);
        let s = csg::compile(&scene.source, "scene.iso");
        let levels: &[u8] = if seed < 6 { &[1, 2] } else { &[1] };
        assert_bricked_is_whole(&scene.source, &s, &plain(6), levels);
    }
}

/// The samples extraction joins to a solid along a diagonal (at a convex
/// solid's sharp edges, `isoc::polygonize`'s isolated samples) are joined
/// in a brick as in the whole run, also where the sample and its cells
/// straddle a seam.
#[test]
fn bricked_blob_joins_equal_the_whole_mesh() {
    for (name, src) in [("pyramid", csg::PYRAMID), ("box", csg::ROTATED_BOX)] {
        let s = csg::compile(src, name);
        assert_bricked_is_whole(name, &s, &plain(8), &[1, 2]);
    }
}

#[test]
fn seams_stay_closed_with_smoothing_and_creases() {
    let cfg = Config::default();
    for seed in 100..112 {
        let scene = Scene::random(seed, &cfg);
        let s = csg::compile(&scene.source, "scene.iso");
        let opts = csg::options(6, false);
        let (whole, _) = mesher::mesh(&s, &opts, &|_| {});
        let (merged, stitched) = brick::merge(&parts(&s, &opts, 1));
        let domain: Bounds = s.domain;
        let (a, b) = (
            analyze_in(&whole, Some(&domain)),
            analyze_in(&merged, Some(&domain)),
        );
        assert_eq!(stitched.topology, b, "tallied topology: {}", scene.source);
        assert_eq!(b.bad_edges(), a.bad_edges(), "{}", scene.source);
        assert_eq!(
            (b.components, &b.genus),
            (a.components, &a.genus),
            "{}",
            scene.source
        );
    }
}

/// The parts of a small bricked run of `corpus/twotorus.iso`.
fn twotorus_parts() -> Vec<Part> {
    let path = "corpus/twotorus.iso";
    let src = std::fs::read_to_string(path).expect("the corpus is in the repository");
    let s = csg::compile(&src, path);
    parts(&s, &csg::options(5, false), 1)
}

/// A zip package's entries, by name (a 3MF's bytes also hold times).
fn unzipped(bytes: &[u8]) -> Vec<(String, Vec<u8>)> {
    let mut zip = zip::ZipArchive::new(std::io::Cursor::new(bytes)).expect("a zip package");
    (0..zip.len())
        .map(|i| {
            let mut f = zip.by_index(i).expect("an entry");
            let mut data = Vec::new();
            std::io::Read::read_to_end(&mut f, &mut data).expect("inflate");
            (f.name().expect("a name").to_string(), data)
        })
        .collect()
}

#[test]
fn streamed_files_are_the_welded_mesh_written_at_once() {
    let parts = twotorus_parts();
    let (merged, _) = brick::merge(&parts);
    let dir = std::env::temp_dir().join(format!("isoc-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    for ext in ["ply", "obj", "stl", "3mf", "glb"] {
        let (streamed, whole) = (dir.join(format!("s.{ext}")), dir.join(format!("w.{ext}")));
        let mut w = StreamWriter::create(&streamed, Unit::Millimeter).expect("create");
        let mut st = Stitcher::new(&mut w);
        for p in &parts {
            st.add(&p.mesh, &p.origins).expect("append");
        }
        st.finish();
        w.finish().expect("finish");
        isoc::io::write_file(&merged, &whole).expect("write");
        let (a, b) = (
            std::fs::read(&streamed).unwrap(),
            std::fs::read(&whole).unwrap(),
        );
        let (a, b) = if ext == "3mf" {
            (unzipped(&a), unzipped(&b))
        } else {
            (vec![(String::new(), a)], vec![(String::new(), b)])
        };
        assert!(a == b, ".{ext}: the streamed file differs");
    }
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().flatten().collect();
    assert_eq!(left.len(), 10, "no temporary file is left: {left:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_dropped_stream_leaves_no_file() {
    let parts = twotorus_parts();
    let dir = std::env::temp_dir().join(format!("isoc-drop-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    {
        let mut w = StreamWriter::create(&dir.join("x.ply"), Unit::Millimeter).expect("create");
        Stitcher::new(&mut w)
            .add(&parts[0].mesh, &parts[0].origins)
            .expect("append");
    }
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn part_files_round_trip_and_refuse_damage() {
    let parts = twotorus_parts();
    let p = &parts[3];
    let mut bytes = Vec::new();
    part::write(&p.mesh, &p.origins, r#"{"any": "line"}"#, &mut bytes).expect("write");
    let (mesh, origins, info) = part::read(&bytes).expect("read back");
    assert_eq!(info, r#"{"any": "line"}"#);
    assert_eq!(origins, p.origins);
    assert_eq!(mesh.positions, p.mesh.positions);
    assert_eq!(mesh.normals, p.mesh.normals);
    assert_eq!(mesh.ambiguous, p.mesh.ambiguous);
    assert_eq!(mesh.triangles, p.mesh.triangles);
    // Every truncation, and a byte changed at many places: an error or a
    // part, never a panic; a changed face index past the vertices is an
    // error.
    for cut in (0..bytes.len()).step_by(97) {
        assert!(part::read(&bytes[..cut]).is_err(), "cut at {cut}");
    }
    for at in (0..bytes.len()).step_by(89) {
        let mut b = bytes.clone();
        b[at] ^= 0xa5;
        let _ = part::read(&b);
    }
    let mut b = bytes.clone();
    let last = b.len() - 4;
    b[last..].copy_from_slice(&(mesh.positions.len() as i32).to_le_bytes());
    assert!(part::read(&b).is_err(), "a face index past the vertices");
}
