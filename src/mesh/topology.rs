//! The topology of a mesh, computed from the mesh itself: connected
//! components, Euler characteristic, genus per component, and whether the
//! mesh is a closed, consistently oriented 2-manifold.
//!
//! Definitions. An (undirected) edge is *manifold* when exactly two
//! triangles use it, and *consistently oriented* when they traverse it in
//! opposite directions. A *boundary* edge has one triangle. The mesh is
//! **watertight** when every edge is manifold and consistently oriented and
//! no vertex is a non-manifold "bow-tie" (its triangles form one fan).
//! For a closed orientable component, `χ = V − E + F = 2 − 2g`.
//!
//! **Manifold within a domain** (SPEC §2–3, [`analyze_in`]): a mesh cut by
//! the domain Ω is open along ∂Ω, and only there. A boundary edge whose two
//! ends lie on one face of Ω is *on the domain boundary*; any other boundary
//! edge is an *open edge*. The mesh is [`Topology::manifold`] when no edge
//! has three or more triangles, no edge is open and no vertex is a bow-tie.

use rustc_hash::FxHashMap as HashMap;

use glam::DVec3;

use super::{Mesh, Star};
use crate::geometry::Bounds;

/// What [`analyze`] finds.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Topology {
    /// Vertices used by at least one triangle (`V`).
    pub vertices: usize,
    /// Distinct undirected edges (`E`).
    pub edges: usize,
    /// Triangles (`F`).
    pub faces: usize,
    /// Components connected through triangles (isolated vertices ignored).
    pub components: usize,
    /// `V − E + F` of the whole mesh (vertices used by triangles only).
    pub euler: i64,
    /// Genus of each component, largest component first; `None` for a
    /// component that is not closed (its genus is not defined by χ alone).
    pub genus: Vec<Option<i64>>,
    /// Edges with exactly one triangle.
    pub boundary_edges: usize,
    /// Boundary edges that do not lie on a face of the domain (all of them
    /// when no domain is given; see the module doc).
    pub open_edges: usize,
    /// Edges with three or more triangles.
    pub nonmanifold_edges: usize,
    /// Edges whose two triangles traverse them in the same direction.
    pub misoriented_edges: usize,
    /// Vertices whose triangles form more than one fan.
    pub nonmanifold_vertices: usize,
    /// Closed, consistently oriented 2-manifold (see the module doc).
    pub watertight: bool,
}

impl Topology {
    /// The edges that break SPEC §2's manifold rule: used by three or more
    /// triangles, or by one triangle away from the domain boundary (the
    /// `--stats json` figure `nonmanifold_edges`).
    pub fn bad_edges(&self) -> usize {
        self.nonmanifold_edges + self.open_edges
    }

    /// A 2-manifold, closed but along the domain boundary: no bad edge and
    /// no bow-tie vertex (see the module doc).
    pub fn manifold(&self) -> bool {
        self.bad_edges() == 0 && self.nonmanifold_vertices == 0
    }
}

/// Disjoint sets over `0..n` (path halving; the lower root wins).
pub(crate) struct UnionFind(pub(crate) Vec<u32>);

impl UnionFind {
    pub(crate) fn find(&mut self, mut i: u32) -> u32 {
        while self.0[i as usize] != i {
            let p = self.0[self.0[i as usize] as usize];
            self.0[i as usize] = p;
            i = p;
        }
        i
    }
    pub(crate) fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b) as usize] = a.min(b);
        }
    }
}

/// A component's `V`, `E`, `F` and whether it is closed.
pub(crate) type Component = (i64, i64, i64, bool);

/// The genus of each component, largest (most triangles) first: `None`
/// for one that is not closed.
pub(crate) fn genera(mut comps: Vec<Component>) -> Vec<Option<i64>> {
    comps.sort_by_key(|c| std::cmp::Reverse(c.2));
    comps
        .iter()
        .map(|&(v, e, f, closed)| closed.then(|| (2 - (v - e + f)) / 2))
        .collect()
}

/// Analyses `mesh`, with no domain: every boundary edge is open.
pub fn analyze(mesh: &Mesh) -> Topology {
    analyze_in(mesh, None)
}

/// Whether the segment `a b` lies on a face of `domain` (both ends on the
/// same face plane, to a millionth of the domain's size: boundary vertices
/// are bisected on ∂Ω and stay there).
fn on_domain_face(a: DVec3, b: DVec3, domain: &Bounds) -> bool {
    (0..3).any(|k| {
        let tol = 1e-6 * (domain.hi[k] - domain.lo[k]).abs();
        [domain.lo[k], domain.hi[k]]
            .iter()
            .any(|&plane| (a[k] - plane).abs() <= tol && (b[k] - plane).abs() <= tol)
    })
}

/// A mesh's edges and what they connect.
pub(crate) struct Edges {
    /// Per vertex, whether a triangle uses it.
    pub used: Vec<bool>,
    /// Vertices joined by edges: the connected components.
    pub uf: UnionFind,
    /// Every directed edge as `(min, max, backwards)` packed in a `u64`
    /// (`min << 33 | max << 1 | backwards`), sorted: the uses of each
    /// undirected edge are one run.
    pub directed: Vec<u64>,
}

/// The edges of `mesh` ([`Edges`]).
pub(crate) fn edges(mesh: &Mesh) -> Edges {
    let n = mesh.positions.len();
    let mut used = vec![false; n];
    let mut uf = UnionFind((0..n as u32).collect());
    let mut directed: Vec<u64> = Vec::with_capacity(3 * mesh.triangles.len());
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            used[a as usize] = true;
            let (lo, hi) = (u64::from(a.min(b)), u64::from(a.max(b)));
            directed.push((lo << 33) | (hi << 1) | u64::from(a > b));
            uf.union(a, b);
        }
    }
    directed.sort_unstable();
    Edges { used, uf, directed }
}

/// Analyses `mesh`; boundary edges on a face of `domain` are not open (see
/// the module doc).
pub fn analyze_in(mesh: &Mesh, domain: Option<&Bounds>) -> Topology {
    let n = mesh.positions.len();
    let Edges {
        used,
        mut uf,
        directed,
    } = edges(mesh);
    // Per component: V, E, F and closedness.
    let mut comp: HashMap<u32, Component> = HashMap::default();
    for i in 0..n as u32 {
        if used[i as usize] {
            let r = uf.find(i);
            comp.entry(r).or_insert((0, 0, 0, true)).0 += 1;
        }
    }
    for t in &mesh.triangles {
        let r = uf.find(t[0]);
        comp.get_mut(&r).expect("component").2 += 1;
    }
    // Each run of `directed` is one undirected edge: its uses forwards and
    // backwards decide its kind (no per-edge table is kept).
    let (mut edges, mut open) = (0usize, 0usize);
    let (mut boundary, mut nonmanifold, mut misoriented) = (0, 0, 0);
    for run in directed.chunk_by(|x, y| x >> 1 == y >> 1) {
        let back = run.iter().filter(|&&d| d & 1 == 1).count();
        let fwd = run.len() - back;
        let (a, b) = (
            (run[0] >> 33) as u32,
            ((run[0] >> 1) & 0xffff_ffff) as usize,
        );
        edges += 1;
        match fwd + back {
            1 => {
                boundary += 1;
                let on_boundary = domain.is_some_and(|d| {
                    on_domain_face(mesh.positions[a as usize], mesh.positions[b], d)
                });
                if !on_boundary {
                    open += 1;
                }
            }
            2 if fwd != 1 => misoriented += 1,
            2 => {}
            _ => nonmanifold += 1,
        }
        let c = comp.get_mut(&uf.find(a)).expect("edge of a used vertex");
        c.1 += 1;
        if fwd + back != 2 || fwd != 1 {
            c.3 = false;
        }
    }
    drop(directed);
    let nonmanifold_vertices = count_bowties(mesh, &used);
    let v = used.iter().filter(|u| **u).count();
    let comps: Vec<Component> = comp.into_values().collect();
    let components = comps.len();
    let genus = genera(comps);
    let watertight =
        boundary == 0 && nonmanifold == 0 && misoriented == 0 && nonmanifold_vertices == 0;
    Topology {
        vertices: v,
        edges,
        faces: mesh.triangles.len(),
        components,
        euler: v as i64 - edges as i64 + mesh.triangles.len() as i64,
        genus,
        boundary_edges: boundary,
        open_edges: open,
        nonmanifold_edges: nonmanifold,
        misoriented_edges: misoriented,
        nonmanifold_vertices,
        watertight,
    }
}

/// The connected component of every triangle (triangles that share a
/// vertex are connected), numbered from 0 in order of first appearance.
pub fn triangle_components(mesh: &Mesh) -> Vec<u32> {
    let mut uf = UnionFind((0..mesh.positions.len() as u32).collect());
    for t in &mesh.triangles {
        uf.union(t[0], t[1]);
        uf.union(t[1], t[2]);
    }
    let mut label = vec![u32::MAX; mesh.positions.len()];
    let mut next = 0;
    mesh.triangles
        .iter()
        .map(|t| {
            let r = uf.find(t[0]) as usize;
            if label[r] == u32::MAX {
                label[r] = next;
                next += 1;
            }
            label[r]
        })
        .collect()
}

/// Vertices whose incident triangles do not form a single fan (connected
/// through shared edges around the vertex).
pub(crate) fn count_bowties(mesh: &Mesh, used: &[bool]) -> usize {
    let star = Star::new(mesh);
    let mut bad = 0;
    let (mut fan, mut by_nb, mut uf) = (Vec::new(), Vec::new(), UnionFind(Vec::new()));
    for (v, _) in used.iter().enumerate().filter(|(_, u)| **u) {
        // The edge opposite `v` in each incident triangle.
        fan.clear();
        fan.extend(star.of(v).iter().map(|&ti| {
            let t = mesh.triangles[ti as usize];
            let k = t.iter().position(|&w| w as usize == v).unwrap_or(0);
            (t[(k + 1) % 3], t[(k + 2) % 3])
        }));
        // Union the triangles of the fan that share a neighbour vertex:
        // sorted (neighbour, triangle) pairs put them side by side.
        uf.0.clear();
        uf.0.extend(0..fan.len() as u32);
        by_nb.clear();
        for (i, &(a, b)) in fan.iter().enumerate() {
            by_nb.extend([(a, i as u32), (b, i as u32)]);
        }
        by_nb.sort_unstable();
        for w in by_nb.windows(2) {
            if w[0].0 == w[1].0 {
                uf.union(w[0].1, w[1].1);
            }
        }
        let roots = (0..fan.len() as u32).filter(|&i| uf.find(i) == i).count();
        if roots > 1 {
            bad += 1;
        }
    }
    bad
}
