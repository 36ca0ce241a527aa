//! Triangle quality (issue 11, item 2): smoothing — edge flips and
//! tangential relaxation — raises `aspect_good` without giving up a
//! guarantee. On the very mesh before and after the pass: the same vertex
//! count, the same topology (watertight or not, components, Euler
//! characteristic, genus per component, boundary edges), no edge
//! misoriented, no more triangles folded against ∇f than before, every
//! vertex still on f = 0, boundary vertices unmoved; `aspect_good` does not
//! decrease, and the poor surfaces of the issue reach 0.75. Edge flips
//! alone (property test on jittered meshes): positions untouched, topology
//! unchanged, the worst aspect ratio never falls.

use std::sync::OnceLock;

use glam::DVec3;
use isoc::mesh::quality::{aspect_good, aspect_ratio};
use isoc::mesh::{Mesh, topology};
use isoc::mesher::{self, MeshOptions};
use isoc::mesher::{flip, smooth};
use isoc::octree::OctreeOptions;
use isoc::{CompileOptions, Surface};
use proptest::prelude::*;

fn corpus(name: &str) -> Surface {
    let path = format!("corpus/{name}.iso");
    let src = std::fs::read_to_string(&path).unwrap();
    Surface::compile(&src, &path, &CompileOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

/// The mesh before smoothing, at the default options but `max_level`.
fn raw(s: &Surface, level: u8) -> Mesh {
    let opts = MeshOptions {
        octree: OctreeOptions {
            max_level: level,
            ..OctreeOptions::default()
        },
        smooth: 0,
        domain: None,
        creases: true,
    };
    mesher::mesh(s, &opts, &|_| {}).0
}

/// The default number of passes, on a copy of `m`.
fn smoothed(s: &Surface, m: &Mesh) -> Mesh {
    let mut out = m.clone();
    smooth::smooth(&mut out, s, 0.0, MeshOptions::default().smooth);
    out
}

/// Triangles whose normal disagrees with ∇f at one of their corners.
fn folded(m: &Mesh) -> usize {
    m.triangles
        .iter()
        .filter(|&&t| {
            let n = m.face_normal(t);
            t.iter().any(|&v| n.dot(m.normals[v as usize]) <= 0.0)
        })
        .count()
}

/// Vertices on a boundary edge (one triangle).
fn boundary_vertices(m: &Mesh) -> Vec<usize> {
    let mut count = std::collections::HashMap::new();
    for t in &m.triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let mut v: Vec<usize> = count
        .into_iter()
        .filter(|&(_, n)| n == 1)
        .flat_map(|((a, b), _)| [a as usize, b as usize])
        .collect();
    v.sort();
    v.dedup();
    v
}

/// Everything smoothing must keep, `before` against `after`.
fn check_kept(name: &str, s: &Surface, before: &Mesh, after: &Mesh) {
    let (tb, ta) = (topology::analyze(before), topology::analyze(after));
    assert_eq!(after.positions.len(), before.positions.len(), "{name}");
    assert_eq!(after.triangles.len(), before.triangles.len(), "{name}");
    assert_eq!(ta.watertight, tb.watertight, "{name}: {tb:?} → {ta:?}");
    assert_eq!(ta.components, tb.components, "{name}: {tb:?} → {ta:?}");
    assert_eq!(ta.euler, tb.euler, "{name}: {tb:?} → {ta:?}");
    assert_eq!(ta.genus, tb.genus, "{name}: {tb:?} → {ta:?}");
    assert_eq!(ta.edges, tb.edges, "{name}");
    assert_eq!(ta.boundary_edges, tb.boundary_edges, "{name}");
    assert_eq!(ta.nonmanifold_edges, tb.nonmanifold_edges, "{name}");
    assert_eq!(ta.nonmanifold_vertices, tb.nonmanifold_vertices, "{name}");
    assert_eq!(ta.misoriented_edges, 0, "{name}: {ta:?}");
    assert!(
        folded(after) <= folded(before),
        "{name}: {} folded triangles, {} before",
        folded(after),
        folded(before)
    );
    // Every vertex on f = 0, to within a few ulps of the step across it.
    for (i, &p) in after.positions.iter().enumerate() {
        let (v, g) = s.point_grad([p.x, p.y, p.z, 0.0]);
        let g = DVec3::from_array(g).length();
        let h = 1e-12 * (1.0 + p.abs().max_element());
        let bound = (8.0 * g * h + 1e-300).max(1e-9 * g);
        assert!(v.abs() <= bound, "{name}: vertex {i} at {p} has f = {v}");
    }
    for v in boundary_vertices(before) {
        assert_eq!(
            after.positions[v], before.positions[v],
            "{name}: boundary vertex {v} moved"
        );
    }
}

/// Surfaces of the corpus at a level that keeps the test quick; the poor
/// ones of issue 11 (bretzels, lemniscate, genus2) among them, and open
/// or singular ones (teardrop, twoplanes).
const SURFACES: [(&str, u8); 10] = [
    ("bretzel2", 6),
    ("bretzel5", 6),
    ("lemniscate", 7),
    ("genus2", 6),
    ("cyclide", 6),
    ("torus_twist", 7),
    ("nested", 7),
    ("teardrop", 7),
    ("twoplanes", 6),
    ("blobs_pass", 7),
];

#[test]
fn smoothing_keeps_every_guarantee_and_raises_aspect_good() {
    for (name, level) in SURFACES {
        let s = corpus(name);
        let before = raw(&s, level);
        assert!(!before.triangles.is_empty(), "{name}");
        let after = smoothed(&s, &before);
        check_kept(name, &s, &before, &after);
        let (qb, qa) = (aspect_good(&before), aspect_good(&after));
        assert!(qa >= qb, "{name}: aspect_good {qb} → {qa}");
    }
}

/// Issue 11's target on the surfaces it names as poor, at the default
/// options (level 7): at least 0.75 of the triangles have aspect > 0.8.
#[test]
fn the_poor_surfaces_reach_the_target() {
    for name in ["bretzel5", "bretzel2", "lemniscate", "genus2"] {
        let s = corpus(name);
        let (m, r) = mesher::mesh(&s, &MeshOptions::default(), &|_| {});
        assert!(r.topology.watertight, "{name}: {:?}", r.topology);
        assert_eq!(r.aspect_good, aspect_good(&m));
        assert!(
            r.aspect_good >= 0.75,
            "{name}: aspect_good {}",
            r.aspect_good
        );
    }
}

/// Smoothing is deterministic (the colouring and the acceptance order do
/// not depend on the thread count or timing).
#[test]
fn smoothing_is_deterministic() {
    let s = corpus("genus2");
    let before = raw(&s, 5);
    let (a, b) = (smoothed(&s, &before), smoothed(&s, &before));
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.positions, b.positions);
}

/// Raw meshes for the flip property test: closed, high genus, open and
/// singular (twoplanes has non-manifold-free boundary and an ambiguous
/// crossing line).
fn flip_meshes() -> &'static Vec<(String, Mesh)> {
    static M: OnceLock<Vec<(String, Mesh)>> = OnceLock::new();
    M.get_or_init(|| {
        [
            ("torus", 5),
            ("genus2", 5),
            ("teardrop", 5),
            ("twoplanes", 5),
        ]
        .into_iter()
        .map(|(n, l)| (n.to_string(), raw(&corpus(n), l)))
        .collect()
    })
}

fn worst_aspect(m: &Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|&t| aspect_ratio(m, t))
        .fold(f64::INFINITY, f64::min)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Edge flips on a mesh whose vertices were jittered (random triangle
    /// shapes, some folded): positions untouched, topology and boundary
    /// unchanged, no edge misoriented, no more folded triangles, and the
    /// worst aspect ratio does not fall.
    #[test]
    fn flips_keep_topology_and_never_worsen_the_worst_triangle(
        which in 0usize..4,
        seed in any::<u64>(),
        amplitude in 0.0f64..0.6,
    ) {
        let (name, base) = &flip_meshes()[which];
        let mut m = base.clone();
        // Jitter each vertex by up to `amplitude` of its shortest edge.
        let mut shortest = vec![f64::INFINITY; m.positions.len()];
        for t in &m.triangles {
            for i in 0..3 {
                let (a, b) = (t[i] as usize, t[(i + 1) % 3] as usize);
                let l = (m.positions[a] - m.positions[b]).length();
                shortest[a] = shortest[a].min(l);
                shortest[b] = shortest[b].min(l);
            }
        }
        let mut rng = seed | 1;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for (p, &l) in m.positions.iter_mut().zip(&shortest) {
            if l.is_finite() {
                *p += DVec3::new(next(), next(), next()) * (amplitude * l / 3f64.sqrt());
            }
        }
        let before = m.clone();
        let n = flip::flip(&mut m);
        prop_assert_eq!(&m.positions, &before.positions);
        let (tb, ta) = (topology::analyze(&before), topology::analyze(&m));
        prop_assert_eq!(ta.euler, tb.euler, "{}", name);
        prop_assert_eq!(&ta.genus, &tb.genus, "{}", name);
        prop_assert_eq!(ta.components, tb.components, "{}", name);
        prop_assert_eq!(ta.edges, tb.edges, "{}", name);
        prop_assert_eq!(ta.watertight, tb.watertight, "{}", name);
        prop_assert_eq!(ta.nonmanifold_edges, tb.nonmanifold_edges, "{}", name);
        prop_assert_eq!(ta.nonmanifold_vertices, tb.nonmanifold_vertices, "{}", name);
        prop_assert_eq!(ta.misoriented_edges, 0, "{}", name);
        prop_assert_eq!(boundary_vertices(&m), boundary_vertices(&before), "{}", name);
        prop_assert!(folded(&m) <= folded(&before), "{}", name);
        prop_assert!(worst_aspect(&m) >= worst_aspect(&before), "{}", name);
        if n == 0 {
            prop_assert_eq!(&m.triangles, &before.triangles);
        }
    }
}

/// Two triangles over a flat quadrilateral, normals +z.
fn quad(p: [DVec3; 4], tris: Vec<[u32; 3]>) -> Mesh {
    Mesh {
        positions: p.to_vec(),
        normals: vec![DVec3::Z; 4],
        ambiguous: vec![false; 4],
        triangles: tris,
    }
}

/// Edge flips on hand-built quadrilaterals: a thin rhombus cut along its
/// long diagonal is flipped to the short one, keeping the orientation; not
/// when the surface normals say the new triangles would face the other way,
/// and a triangle with a repeated corner is left alone.
#[test]
fn flips_on_hand_built_quadrilaterals() {
    let rhombus = [
        DVec3::new(-1.0, 0.0, 0.0),
        DVec3::new(0.0, -0.3, 0.0),
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 0.3, 0.0),
    ];
    // Long diagonal 0–2: [0, 1, 2] and [2, 3, 0], counter-clockwise seen
    // from +z.
    let long = vec![[0, 1, 2], [2, 3, 0]];
    let mut m = quad(rhombus, long.clone());
    assert_eq!(flip::flip(&mut m), 1);
    let has =
        |m: &Mesh, a: u32, b: u32| m.triangles.iter().any(|t| t.contains(&a) && t.contains(&b));
    assert!(has(&m, 1, 3) && !has(&m, 0, 2), "{:?}", m.triangles);
    for &t in &m.triangles {
        assert!(
            m.face_normal(t).z > 0.0,
            "orientation lost: {:?}",
            m.triangles
        );
    }
    assert_eq!(flip::flip(&mut m), 0, "a second run undoes nothing");

    // Normals pointing down: the new triangles would disagree with ∇f.
    let mut m = quad(rhombus, long.clone());
    m.normals = vec![-DVec3::Z; 4];
    assert_eq!(flip::flip(&mut m), 0);
    assert_eq!(m.triangles, long);

    // A repeated corner: nothing to flip, no panic.
    let mut m = quad(rhombus, vec![[0, 1, 2], [2, 3, 0], [0, 0, 3]]);
    flip::flip(&mut m);
    assert!(m.triangles.contains(&[0, 0, 3]), "{:?}", m.triangles);
}
