//! The dual grid (Schaefer & Warren 2004) on octrees built by hand: a
//! uniform tree gives exactly the (2^L − 1)³ cubes between leaf centres;
//! an adaptive tree gives dual cells whose corners are leaves that touch
//! the cell's vertex, and every pair of face-adjacent leaves is joined by
//! a dual edge.

use std::collections::HashSet;

use glam::DVec3;
use isoc::dual::{self, Corner};
use isoc::octree::{Kind, Leaf, Node, Octant, Octree, OctreeStats};

/// An octree over [0,1]³ split wherever `split(level, ijk)` says, to at
/// most `max` levels.
fn tree(max: u8, split: &dyn Fn(u8, [u32; 3]) -> bool) -> Octree {
    let open = |level: u8, ijk: [u32; 3]| Node {
        kind: Kind::Leaf(Leaf::Surface),
        level,
        ijk,
    };
    let mut nodes = vec![open(0, [0; 3])];
    let mut i = 0;
    while i < nodes.len() {
        let n = nodes[i];
        if n.level < max && split(n.level, n.ijk) {
            nodes[i].kind = Kind::Branch {
                first_child: nodes.len() as u32,
            };
            for o in Octant::ALL {
                nodes.push(open(n.level + 1, o.child_ijk(n.ijk)));
            }
        }
        i += 1;
    }
    Octree {
        nodes,
        lo: DVec3::ZERO,
        hi: DVec3::ONE,
        stats: OctreeStats::default(),
        tapes: Vec::new(),
        max_level: max,
    }
}

/// The dual cells made only of real leaves (no ghost corner), as leaf ids.
fn cells(t: &Octree) -> Vec<[u32; 8]> {
    let mut v = Vec::new();
    dual::for_each_cell(t, |c| {
        if c.iter().all(|k| !k.is_ghost()) {
            v.push(c.map(|k| k.node));
        }
    });
    v
}

/// Volume of the trilinear hexahedron with corners `p` (corner order), by
/// 2-point Gauss–Legendre quadrature of det J (exact: det J has degree at
/// most 2 in each variable).
fn hex_volume(p: &[DVec3; 8]) -> f64 {
    let g = [0.5 - 0.5 / 3f64.sqrt(), 0.5 + 0.5 / 3f64.sqrt()];
    let mut vol = 0.0;
    for &u in &g {
        for &v in &g {
            for &w in &g {
                let lerp2 = |a: DVec3, b: DVec3, c: DVec3, d: DVec3, s: f64, t: f64| {
                    a.lerp(b, s).lerp(c.lerp(d, s), t)
                };
                let du = lerp2(p[1] - p[0], p[3] - p[2], p[5] - p[4], p[7] - p[6], v, w);
                let dv = lerp2(p[2] - p[0], p[3] - p[1], p[6] - p[4], p[7] - p[5], u, w);
                let dw = lerp2(p[4] - p[0], p[5] - p[1], p[6] - p[2], p[7] - p[3], u, v);
                vol += du.cross(dv).dot(dw) / 8.0;
            }
        }
    }
    vol
}

/// All dual cells, ghosts included, with their corner positions.
fn all_cells(t: &Octree) -> Vec<([Corner; 8], [DVec3; 8])> {
    let mut v = Vec::new();
    dual::for_each_cell(t, |c| v.push((c, c.map(|k| k.position(t)))));
    v
}

#[test]
fn with_ghosts_the_dual_cells_tile_the_domain() {
    let trees = [
        tree(3, &|_, _| true),
        tree(5, &|level, ijk| {
            let s = (1u32 << level) as f64;
            let c = ijk.map(|k| (k as f64 + 0.5) / s);
            level < 1 || (c[0] + c[1] < 0.7 && level < 5) || (c[2] > 0.8 && level < 4)
        }),
        tree(6, &|level, ijk| {
            level < 2 || (ijk == [0, 0, 0] && level < 6)
        }),
    ];
    for (n, t) in trees.iter().enumerate() {
        let cs = all_cells(t);
        let mut total = 0.0;
        for (c, p) in &cs {
            let v = hex_volume(p);
            assert!(v >= -1e-12, "tree {n}: inverted dual cell {c:?}: {v}");
            total += v;
        }
        assert!(
            (total - 1.0).abs() < 1e-9,
            "tree {n}: dual cells cover {total}, not 1"
        );
    }
    // The uniform tree: (2^L + 1)^3 cells in all.
    let t = tree(3, &|_, _| true);
    assert_eq!(all_cells(&t).len(), 9 * 9 * 9);
}

#[test]
fn uniform_tree_gives_the_grid_of_centres() {
    for level in 1..=4u8 {
        let t = tree(level, &|_, _| true);
        let cs = cells(&t);
        let side = (1u32 << level) - 1;
        assert_eq!(cs.len() as u32, side * side * side, "level {level}");
        for c in &cs {
            let base = t.nodes[c[0] as usize].ijk;
            for (i, &l) in c.iter().enumerate() {
                let ijk = t.nodes[l as usize].ijk;
                let want = [0, 1, 2].map(|k| base[k] + ((i as u32 >> k) & 1));
                assert_eq!(ijk, want, "corner {i} of {c:?}");
            }
        }
        let unique: HashSet<_> = cs.iter().collect();
        assert_eq!(unique.len(), cs.len());
    }
}

/// Corners of an adaptive tree's dual cell touch the cell's shared vertex:
/// corner i's box has the vertex on its side given by the bits of i.
#[test]
fn adaptive_tree_cells_surround_a_vertex() {
    // Refine towards a corner and along a diagonal plane.
    let split = |level: u8, ijk: [u32; 3]| {
        let s = (1u32 << level) as f64;
        let c = ijk.map(|k| (k as f64 + 0.5) / s);
        level < 2 || (c[0] + c[1] < 0.7 && level < 5) || (c[2] > 0.8 && level < 4)
    };
    let t = tree(5, &split);
    let cs = cells(&t);
    assert!(!cs.is_empty());
    for c in &cs {
        // The shared vertex, read off corner pairs whose leaves differ.
        let boxes: Vec<(DVec3, DVec3)> = c
            .iter()
            .map(|&l| t.cell_box(&t.nodes[l as usize]))
            .collect();
        let mut v = DVec3::splat(f64::NAN);
        for i in 0..8usize {
            for k in 0..3 {
                let j = i | (1 << k);
                if j != i && c[i] != c[j] {
                    assert!(
                        v[k].is_nan() || v[k] == boxes[i].1[k],
                        "{c:?}: inconsistent vertex"
                    );
                    v[k] = boxes[i].1[k];
                    assert_eq!(
                        boxes[j].0[k], v[k],
                        "{c:?}: corners {i} and {j} are not adjacent"
                    );
                }
            }
        }
        assert!(
            !v.is_nan(),
            "{c:?}: a dual cell must change leaf along every axis"
        );
        // A leaf repeated across an axis spans the vertex along it.
        for i in 0..8usize {
            for k in 0..3 {
                let (lo, hi) = boxes[i];
                assert!(
                    lo[k] <= v[k] && v[k] <= hi[k],
                    "{c:?}: corner {i} does not touch {v}"
                );
                let j = i ^ (1 << k);
                if c[i] == c[j] {
                    assert!(
                        lo[k] < v[k] && v[k] < hi[k],
                        "{c:?}: repeated corner {i} not across {v}"
                    );
                } else if (i >> k) & 1 == 0 {
                    assert_eq!(hi[k], v[k]);
                } else {
                    assert_eq!(lo[k], v[k]);
                }
            }
        }
    }
    // Every pair of face-adjacent leaves is a dual edge of some cell.
    let mut edges = HashSet::new();
    for c in &cs {
        for i in 0..8usize {
            for k in 0..3 {
                let j = i | (1 << k);
                if j != i {
                    let (a, b) = (c[i].min(c[j]), c[i].max(c[j]));
                    edges.insert((a, b));
                }
            }
        }
    }
    let leaves: Vec<u32> = (0..t.nodes.len() as u32)
        .filter(|&i| t.nodes[i as usize].is_leaf())
        .collect();
    for &a in &leaves {
        for &b in &leaves {
            if a >= b {
                continue;
            }
            let (la, ha) = t.cell_box(&t.nodes[a as usize]);
            let (lb, hb) = t.cell_box(&t.nodes[b as usize]);
            // Face-adjacent: touch along one axis, overlap with positive
            // area in the other two.
            let mut touch = 0;
            let mut overlap = 0;
            for k in 0..3 {
                if ha[k] == lb[k] || hb[k] == la[k] {
                    touch += 1;
                } else if la[k].max(lb[k]) < ha[k].min(hb[k]) {
                    overlap += 1;
                }
            }
            if touch == 1 && overlap == 2 {
                assert!(
                    edges.contains(&(a, b)),
                    "leaves {a} and {b} share a face but no dual edge"
                );
            }
        }
    }
}
