//! Bricked meshing (`isoc::mesher::brick`): the parts of `8^B` bricks,
//! welded by their vertices' ids, against the whole run's mesh — the same
//! triangles over the same positions, bit for bit, with smoothing and
//! creases off; closed and 2-manifold across the seams with them on.

use isoc::mesh::Mesh;
use isoc::mesh::topology::analyze_in;
use isoc::mesher::brick::{self, Brick, Part};
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
        let (merged, _) = brick::merge(&parts);
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
        let r = brick::merge_reports(&reports, &merged, &s.domain, 0.0);
        assert_eq!(r.octree, report.octree, "{name}, B = {b}: octree counts");
        assert_eq!(r.active_cells, report.active_cells, "{name}, B = {b}");
        assert_eq!(r.topology, report.topology, "{name}, B = {b}");
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
        assert_bricked_is_whole(&scene.source, &s, &plain(6), &[1]);
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
        let (merged, _) = brick::merge(&parts(&s, &opts, 1));
        let domain: Bounds = s.domain;
        let (a, b) = (
            analyze_in(&whole, Some(&domain)),
            analyze_in(&merged, Some(&domain)),
        );
        assert_eq!(b.bad_edges(), a.bad_edges(), "{}", scene.source);
        assert_eq!(
            (b.components, &b.genus),
            (a.components, &a.genus),
            "{}",
            scene.source
        );
    }
}
