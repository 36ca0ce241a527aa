//! Welding the vertices that extraction put at one position on one sheet.
//!
//! Where `f` is exactly 0 at a dual-grid sample (a leaf centre on a face of
//! an axis-aligned box whose faces lie on octree planes, a plane through
//! the centres), every dual edge leaving that sample has its root there;
//! bisection returns the other end of the final bracket, an ulp or a few
//! away ([`crate::roots`]), so edges that differ only in coordinates the
//! step does not move give the same point or points a few ulps apart. The triangles joining such
//! vertices have zero area (SPEC §3 promises none, and no duplicated
//! vertices on one sheet).
//!
//! The last round of chord splits ([`super::chord`], after smoothing) can
//! do the same: a midpoint projected across a sliver triangle onto its
//! opposite corner, a crease vertex where the projection converges to the
//! very point the crease pass found. The mesher welds again after it.
//!
//! # Contract
//!
//! [`weld_coincident`] collapses every edge whose two ends coincide to
//! rounding (every coordinate within 8 ulps), keeping the end with the
//! lower position (coordinates compared in order, then the index), when
//! the collapse
//! keeps the mesh a 2-manifold: the edge has exactly two triangles, and
//! the ends' other neighbours are only the two vertices opposite the edge
//! (the link condition). The edge's two triangles (of zero area) go; the
//! other triangles of the dropped end are renamed to the kept one, so
//! their shapes change by rounding only (the two ends were one point). Orientation,
//! components and genus are kept. Vertices left without a triangle are
//! removed and the rest renumbered in order; `cell_of` (a value per
//! triangle) follows the triangles. The edges are tried in the order of
//! their ends' positions, so the result depends on the mesh's geometry and
//! connectivity, not on its numbering: a brick of a bricked run welds its
//! coincident vertices as the whole run does ([`weld_coincident_in`]
//! leaves alone the vertices on a brick's seam).
//!
//! # Limits
//!
//! Only coincident ends are welded: a zero-area triangle of three distinct
//! collinear points, or two coincident vertices not joined by an edge
//! (two sheets touching at a point, which SPEC §3 wants kept apart), are
//! left as they are, and so is an edge whose collapse would break the
//! link condition. A mesh without coincident edge ends (the usual case)
//! is left untouched at the cost of one scan of its triangles.

use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use glam::DVec3;

use crate::mesh::Mesh;
use crate::mesh::order::retain;
use crate::mesh::origin::Origins;

/// Collapses the edges of `mesh` whose ends coincide (see the module doc);
/// `cell_of` holds one value per triangle and follows them. Returns how
/// many edges were collapsed.
pub fn weld_coincident(mesh: &mut Mesh, cell_of: &mut Vec<u32>) -> usize {
    weld_coincident_in(mesh, cell_of, &[], None, None)
}

/// [`weld_coincident`] that leaves alone the edges with an end flagged in
/// `frozen` (missing flags are false), and keeps `origins` and `feature`
/// (one per vertex, when given; `feature` may stop short, missing flags
/// being false) in step with the vertices.
pub fn weld_coincident_in(
    mesh: &mut Mesh,
    cell_of: &mut Vec<u32>,
    frozen: &[bool],
    origins: Option<&mut Origins>,
    feature: Option<&mut Vec<bool>>,
) -> usize {
    let p = &mesh.positions;
    let free = |v: u32| !frozen.get(v as usize).copied().unwrap_or(false);
    let same =
        |a: u32, b: u32| a != b && free(a) && free(b) && coincident(p[a as usize], p[b as usize]);
    let first = |a: u32, b: u32| lower(p, a, b) == std::cmp::Ordering::Less;
    let mut pending: Vec<(u32, u32)> = mesh
        .triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .filter(|&(a, b)| same(a, b))
        .map(|(a, b)| if first(a, b) { (a, b) } else { (b, a) })
        .collect();
    if pending.is_empty() {
        return 0;
    }
    pending.sort_unstable_by(|x, y| lower(p, x.0, y.0).then(lower(p, x.1, y.1)));
    pending.dedup();
    let mut star = Stars::around(mesh, &pending);
    let mut alive = vec![true; mesh.triangles.len()];
    let mut welded = 0;
    // Collapses change the neighbourhoods: sweep until none is possible.
    loop {
        let before = welded;
        pending.retain(|&(a, b)| {
            let (keep, drop) = (star.root(a), star.root(b));
            if keep == drop {
                return false;
            }
            let (keep, drop) = if lower(&mesh.positions, keep, drop).is_lt() {
                (keep, drop)
            } else {
                (drop, keep)
            };
            if star.collapse(mesh, &mut alive, keep, drop) {
                welded += 1;
                return false;
            }
            true
        });
        if welded == before || pending.is_empty() {
            break;
        }
    }
    if welded > 0 {
        let used = compact(mesh, cell_of, &alive);
        if let Some(o) = origins {
            o.retain(&used);
        }
        if let Some(f) = feature {
            retain(f, &used);
        }
    }
    welded
}

/// Vertices in the order of their positions (coordinates in order), then
/// of their indices.
fn lower(p: &[DVec3], a: u32, b: u32) -> std::cmp::Ordering {
    let (pa, pb) = (p[a as usize], p[b as usize]);
    (0..3)
        .map(|k| pa[k].total_cmp(&pb[k]))
        .find(|o| o.is_ne())
        .unwrap_or(std::cmp::Ordering::Equal)
        .then(a.cmp(&b))
}

/// Ulps of the coordinates within which two points count as one.
const ULPS: f64 = 8.0;

/// Two points equal to rounding: every coordinate within [`ULPS`] ulps of
/// the larger magnitude (bisection's results around one exact zero differ
/// in their last bits).
fn coincident(a: DVec3, b: DVec3) -> bool {
    let scale = a.abs().max(b.abs()).max_element().max(f64::MIN_POSITIVE);
    (a - b).abs().max_element() <= ULPS * f64::EPSILON * scale
}

/// Triangles around the vertices that take part in collapses, kept up to
/// date as they happen, and which vertex each dropped one became.
struct Stars {
    around: HashMap<u32, Vec<u32>>,
    merged: HashMap<u32, u32>,
}

impl Stars {
    /// The stars of the ends of `edges` (one scan of the triangles).
    fn around(mesh: &Mesh, edges: &[(u32, u32)]) -> Stars {
        let ends: HashSet<u32> = edges.iter().flat_map(|&(a, b)| [a, b]).collect();
        let mut around: HashMap<u32, Vec<u32>> = HashMap::default();
        for (i, t) in mesh.triangles.iter().enumerate() {
            for &v in t {
                if ends.contains(&v) {
                    around.entry(v).or_default().push(i as u32);
                }
            }
        }
        Stars {
            around,
            merged: HashMap::default(),
        }
    }

    /// The vertex `v` is now.
    fn root(&self, mut v: u32) -> u32 {
        while let Some(&w) = self.merged.get(&v) {
            v = w;
        }
        v
    }

    /// Collapses `drop` into `keep` when the link condition holds; returns
    /// whether it did.
    fn collapse(&mut self, mesh: &mut Mesh, alive: &mut [bool], keep: u32, drop: u32) -> bool {
        let live = |ts: &[u32], alive: &[bool]| -> Vec<u32> {
            ts.iter().copied().filter(|&t| alive[t as usize]).collect()
        };
        let sk = live(self.around.get(&keep).map_or(&[][..], |v| v), alive);
        let sd = live(self.around.get(&drop).map_or(&[][..], |v| v), alive);
        let shared: Vec<u32> = sk.iter().copied().filter(|t| sd.contains(t)).collect();
        if shared.len() != 2 {
            return false;
        }
        let tri = |t: u32| mesh.triangles[t as usize];
        let opposite: HashSet<u32> = shared
            .iter()
            .flat_map(|&t| tri(t))
            .filter(|&v| v != keep && v != drop)
            .collect();
        let neighbours = |ts: &[u32], me: u32| -> HashSet<u32> {
            ts.iter()
                .flat_map(|&t| tri(t))
                .filter(|&v| v != me)
                .collect()
        };
        let (nk, nd) = (neighbours(&sk, keep), neighbours(&sd, drop));
        let common: HashSet<u32> = nk.intersection(&nd).copied().collect();
        if opposite.len() != 2 || common != opposite {
            return false;
        }
        // Nor may a renamed triangle repeat one of `keep`'s (a tetrahedron
        // collapsing onto a doubled triangle meets the link condition).
        let sorted = |mut t: [u32; 3]| {
            t.sort_unstable();
            t
        };
        let kept: HashSet<[u32; 3]> = sk
            .iter()
            .filter(|t| !shared.contains(t))
            .map(|&t| sorted(tri(t)))
            .collect();
        let renamed = |t: u32| sorted(tri(t).map(|v| if v == drop { keep } else { v }));
        if sd
            .iter()
            .filter(|t| !shared.contains(t))
            .any(|&t| kept.contains(&renamed(t)))
        {
            return false;
        }
        for &t in &shared {
            alive[t as usize] = false;
        }
        let mut moved = Vec::new();
        for &t in &sd {
            if alive[t as usize] {
                for v in mesh.triangles[t as usize].iter_mut() {
                    if *v == drop {
                        *v = keep;
                    }
                }
                moved.push(t);
            }
        }
        self.around.entry(keep).or_default().extend(moved);
        self.around.remove(&drop);
        self.merged.insert(drop, keep);
        true
    }
}

/// Drops the dead triangles (and their `cell_of` entries) and the vertices
/// no triangle uses, renumbering the rest in order; returns which vertices
/// stayed.
fn compact(mesh: &mut Mesh, cell_of: &mut Vec<u32>, alive: &[bool]) -> Vec<bool> {
    retain(cell_of, alive);
    retain(&mut mesh.triangles, alive);
    mesh.drop_unused()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::analyze;

    /// A mesh of `positions` and `triangles` (normals unused by the weld).
    fn mesh_of(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        let n = positions.len();
        Mesh {
            normals: vec![DVec3::Z; n],
            ambiguous: vec![false; n],
            positions,
            triangles,
        }
    }

    /// An octahedron whose +z apex is doubled: vertex 6 sits where 4 does,
    /// joined to it by an edge, with two zero-area triangles between them.
    fn octahedron_with_a_doubled_apex() -> (Mesh, Vec<u32>) {
        let positions = vec![
            DVec3::X,
            DVec3::Y,
            -DVec3::X,
            -DVec3::Y,
            DVec3::Z,
            -DVec3::Z,
            DVec3::Z,
        ];
        // Around the +z apex: 4 takes the fan 0-1-2, 6 takes 2-3-0, and
        // the zero-area triangles [4, 2, 6] and [6, 0, 4] close it.
        let triangles = vec![
            [0, 1, 4],
            [1, 2, 4],
            [4, 2, 6],
            [2, 3, 6],
            [3, 0, 6],
            [6, 0, 4],
            [1, 0, 5],
            [2, 1, 5],
            [3, 2, 5],
            [0, 3, 5],
        ];
        let mesh = mesh_of(positions, triangles);
        let cells = (0..mesh.triangles.len() as u32).collect();
        (mesh, cells)
    }

    #[test]
    fn coincident_ends_are_welded_into_a_closed_manifold() {
        let (mut mesh, mut cells) = octahedron_with_a_doubled_apex();
        let before = analyze(&mesh);
        assert!(before.watertight);
        assert_eq!(weld_coincident(&mut mesh, &mut cells), 1);
        assert_eq!((mesh.positions.len(), mesh.triangles.len()), (6, 8));
        let after = analyze(&mesh);
        assert!(after.watertight);
        assert_eq!((after.components, after.euler), (1, 2));
        assert!(
            mesh.triangles
                .iter()
                .all(|&t| mesh.face_normal(t).length() > 0.0)
        );
        // The two zero-area triangles (2 and 5) went with their cells.
        assert_eq!(cells, [0, 1, 3, 4, 6, 7, 8, 9]);
        // Outward orientation kept: every face points away from the centre.
        for &t in &mesh.triangles {
            let c = t.iter().map(|&v| mesh.positions[v as usize]).sum::<DVec3>();
            assert!(mesh.face_normal(t).dot(c) > 0.0);
        }
    }

    #[test]
    fn a_collapse_onto_a_doubled_triangle_is_refused() {
        // A tetrahedron whose edge 0-1 has coincident ends: the link
        // condition holds (the common neighbours 2 and 3 are the opposite
        // vertices), but the collapse would leave two triangles on the
        // same three vertices.
        let positions = vec![DVec3::ZERO, DVec3::ZERO, DVec3::Y, DVec3::Z];
        let mut mesh = mesh_of(positions, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
        let mut cells = vec![0, 1, 2, 3];
        let welded = weld_coincident(&mut mesh, &mut cells);
        let after = analyze(&mesh);
        assert!(after.watertight, "{after:?}");
        assert_eq!(welded, 0);
        assert_eq!(mesh.triangles.len(), 4);
    }

    #[test]
    fn a_collapse_with_a_third_common_neighbour_is_refused() {
        // u = 0 and v = 1 coincide; besides the opposite vertices 2 and 3
        // both are joined to 4: the link condition fails.
        let positions = vec![DVec3::ZERO, DVec3::ZERO, DVec3::X, -DVec3::X, DVec3::Y];
        let mut mesh = mesh_of(positions, vec![[0, 1, 2], [1, 0, 3], [0, 4, 2], [1, 4, 3]]);
        let mut cells = vec![0, 1, 2, 3];
        assert_eq!(weld_coincident(&mut mesh, &mut cells), 0);
        assert_eq!(mesh.triangles.len(), 4);
    }

    #[test]
    fn a_mesh_without_coincident_ends_is_untouched() {
        let (mut mesh, mut cells) = octahedron_with_a_doubled_apex();
        mesh.positions[6] = DVec3::new(0.0, 0.0, 0.9);
        let copy = mesh.clone();
        assert_eq!(weld_coincident(&mut mesh, &mut cells), 0);
        assert_eq!(mesh.triangles, copy.triangles);
        assert_eq!(mesh.positions, copy.positions);
    }
}
