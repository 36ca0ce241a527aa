//! A mutable triangle mesh: indexed triangles whose connectivity changes
//! by local operations — edge split, edge collapse (Bouthors & Nesme §2.5)
//! and edge flip. The twinned tracker's mechanical mesh changes by them
//! every frame; the mesher adapts a mesh to a tolerance with them.
//!
//! # Layout
//!
//! Vertices and triangles are never moved in their arrays while tracking:
//! a collapse marks one vertex and two triangles dead, a split appends.
//! Each live vertex keeps its *star* (the live triangles that use it), so
//! every local operation is O(valence). [`DynMesh::compact`] renumbers
//! when dead entries pile up; callers remap their per-vertex data with the
//! map it returns.
//!
//! Triangles are counter-clockwise seen from `f > 0` (SPEC §3), like
//! [`crate::mesh::Mesh`]; every operation here preserves that orientation.

use glam::DVec3;
use smallvec::SmallVec;

use super::Mesh;

/// The triangles of one edge, as [`DynMesh::edge_tris`] lists them, on the
/// stack for the usual one or two.
type EdgeTris = SmallVec<[(u32, [u32; 3]); 2]>;

/// A vertex's neighbours, on the stack up to a generous valence.
type Ring = SmallVec<[u32; 32]>;

/// An undirected edge, smaller index first.
pub(crate) type EdgeKey = (u32, u32);

/// The key of edge `a–b`.
pub fn key(a: u32, b: u32) -> EdgeKey {
    if a < b { (a, b) } else { (b, a) }
}

/// A mesh under modification. See the module doc.
#[derive(Clone, Debug, Default)]
pub struct DynMesh {
    pub pos: Vec<DVec3>,
    /// ∇f at `pos` (at the time of the last evaluation).
    pub grad: Vec<DVec3>,
    pub vert_alive: Vec<bool>,
    pub tris: Vec<[u32; 3]>,
    pub tri_alive: Vec<bool>,
    /// Live triangles around each vertex.
    pub star: Vec<Vec<u32>>,
}

impl DynMesh {
    /// From an indexed mesh (its normals become the initial gradients;
    /// vertices no triangle uses are dropped).
    pub fn from_mesh(mesh: &Mesh) -> DynMesh {
        let mut remap = vec![u32::MAX; mesh.positions.len()];
        let mut m = DynMesh::default();
        for t in &mesh.triangles {
            let mut nt = [0u32; 3];
            for (k, &v) in t.iter().enumerate() {
                let v = v as usize;
                if remap[v] == u32::MAX {
                    remap[v] = m.pos.len() as u32;
                    m.pos.push(mesh.positions[v]);
                    m.grad
                        .push(mesh.normals.get(v).copied().unwrap_or(DVec3::ZERO));
                    m.vert_alive.push(true);
                    m.star.push(Vec::new());
                }
                nt[k] = remap[v];
            }
            m.add_tri(nt);
        }
        m
    }

    /// From an indexed mesh vertex for vertex (vertex `i` stays `i`, used
    /// or not, so per-vertex data of the caller stays indexed alike); its
    /// normals become the initial gradients.
    pub fn indexed(mesh: &Mesh) -> DynMesh {
        let mut m = DynMesh::default();
        for (i, &p) in mesh.positions.iter().enumerate() {
            let g = mesh.normals.get(i).copied().unwrap_or(DVec3::ZERO);
            m.add_vertex(p, g);
        }
        for &tri in &mesh.triangles {
            m.add_tri(tri);
        }
        m
    }

    /// Live triangles.
    pub fn live_tris(&self) -> impl Iterator<Item = (u32, [u32; 3])> + '_ {
        self.tris
            .iter()
            .enumerate()
            .filter(|(i, _)| self.tri_alive[*i])
            .map(|(i, t)| (i as u32, *t))
    }

    pub fn live_tri_count(&self) -> usize {
        self.tri_alive.iter().filter(|a| **a).count()
    }

    pub fn live_vert_count(&self) -> usize {
        self.vert_alive.iter().filter(|a| **a).count()
    }

    /// Appends a vertex.
    pub fn add_vertex(&mut self, p: DVec3, g: DVec3) -> u32 {
        self.pos.push(p);
        self.grad.push(g);
        self.vert_alive.push(true);
        self.star.push(Vec::new());
        (self.pos.len() - 1) as u32
    }

    /// Appends a triangle and registers it in its vertices' stars.
    pub fn add_tri(&mut self, t: [u32; 3]) -> u32 {
        let i = self.tris.len() as u32;
        self.tris.push(t);
        self.tri_alive.push(true);
        for v in t {
            self.star[v as usize].push(i);
        }
        i
    }

    /// Removes triangle `i` from the mesh and its vertices' stars.
    pub fn kill_tri(&mut self, i: u32) {
        self.tri_alive[i as usize] = false;
        for v in self.tris[i as usize] {
            self.star[v as usize].retain(|&x| x != i);
        }
    }

    /// Replaces triangle `i` by `t`, updating stars.
    fn set_tri(&mut self, i: u32, t: [u32; 3]) {
        for v in self.tris[i as usize] {
            self.star[v as usize].retain(|&x| x != i);
        }
        self.tris[i as usize] = t;
        for v in t {
            self.star[v as usize].push(i);
        }
    }

    /// The right-hand normal of triangle `i` (length = twice the area).
    pub fn normal(&self, i: u32) -> DVec3 {
        let [a, b, c] = self.tris[i as usize].map(|v| self.pos[v as usize]);
        (b - a).cross(c - a)
    }

    /// The live triangles that use edge `a–b`, each rotated so that it
    /// reads `[a, b, c]` or `[b, a, c]` (the edge first).
    pub fn edge_tris(&self, a: u32, b: u32) -> Vec<(u32, [u32; 3])> {
        self.star[a as usize]
            .iter()
            .filter_map(|&i| {
                let t = self.tris[i as usize];
                if !t.contains(&b) {
                    return None;
                }
                Some((i, rotate_to_edge(t, a, b)))
            })
            .collect()
    }

    /// [`DynMesh::edge_tris`] without a heap allocation for up to two
    /// triangles.
    fn edge_tris_small(&self, a: u32, b: u32) -> EdgeTris {
        self.star[a as usize]
            .iter()
            .filter(|&&i| self.tris[i as usize].contains(&b))
            .map(|&i| (i, rotate_to_edge(self.tris[i as usize], a, b)))
            .collect()
    }

    /// The two live triangles of an interior edge `a–b` (as
    /// [`DynMesh::edge_tris`] rotates them), or `None` when the edge has
    /// another number of triangles. No allocation.
    pub fn edge_pair(&self, a: u32, b: u32) -> Option<[(u32, [u32; 3]); 2]> {
        let mut out = [(u32::MAX, [0; 3]); 2];
        let mut n = 0;
        for &i in &self.star[a as usize] {
            let t = self.tris[i as usize];
            if t.contains(&b) {
                if n == 2 {
                    return None;
                }
                out[n] = (i, rotate_to_edge(t, a, b));
                n += 1;
            }
        }
        (n == 2).then_some(out)
    }

    /// Every live edge once, in no particular order, without sorting: an
    /// interior edge from the triangle that reads it from its smaller end,
    /// a boundary edge from its one triangle.
    pub fn edges_unordered(&self) -> Vec<EdgeKey> {
        self.edges_from(false)
    }

    /// [`DynMesh::edges_unordered`] for a mesh the caller knows to be
    /// closed (every edge in two triangles, read both ways): no boundary
    /// search.
    pub fn closed_edges(&self) -> Vec<EdgeKey> {
        self.edges_from(true)
    }

    fn edges_from(&self, closed: bool) -> Vec<EdgeKey> {
        let mut out = Vec::with_capacity(self.tris.len() * 3 / 2 + 16);
        for (_, t) in self.live_tris() {
            for k in 0..3 {
                let (u, v) = (t[k], t[(k + 1) % 3]);
                // The twin `v → u` read by another triangle, if any.
                let twin = || {
                    self.star[v as usize].iter().any(|&i| {
                        let s = self.tris[i as usize];
                        (0..3).any(|j| s[j] == v && s[(j + 1) % 3] == u)
                    })
                };
                if u < v || (!closed && !twin()) {
                    out.push(key(u, v));
                }
            }
        }
        out
    }

    /// The vertices adjacent to `v`, in increasing order.
    pub fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out = Vec::new();
        self.neighbours_into(v, &mut out);
        out
    }

    /// [`DynMesh::neighbours`] appended to `out` (which the caller may
    /// reuse across calls: no allocation once it is large enough).
    pub fn neighbours_into(&self, v: u32, out: &mut Vec<u32>) {
        let start = out.len();
        let star = &self.star[v as usize];
        out.reserve(2 * star.len());
        for &i in star {
            for w in self.tris[i as usize] {
                if w != v {
                    out.push(w);
                }
            }
        }
        out[start..].sort_unstable();
        let mut w = start;
        for r in start..out.len() {
            if w == start || out[r] != out[w - 1] {
                out[w] = out[r];
                w += 1;
            }
        }
        out.truncate(w);
    }

    /// [`DynMesh::neighbours`] on the stack for usual valences.
    fn ring(&self, v: u32) -> Ring {
        let star = &self.star[v as usize];
        let mut out = Ring::new();
        if 2 * star.len() > out.inline_size() {
            // A rare high valence: the general path.
            let mut all = Vec::new();
            self.neighbours_into(v, &mut all);
            out.extend(all);
            return out;
        }
        for &i in star {
            for w in self.tris[i as usize] {
                if w != v {
                    // Insertion into the sorted prefix, skipping repeats.
                    match out.binary_search(&w) {
                        Ok(_) => {}
                        Err(k) => out.insert(k, w),
                    }
                }
            }
        }
        out
    }

    /// Whether `u–v` is an edge (no allocation).
    pub fn adjacent(&self, u: u32, v: u32) -> bool {
        self.star[u as usize]
            .iter()
            .any(|&i| self.tris[i as usize].contains(&v))
    }

    /// Every live edge once.
    pub fn edges(&self) -> Vec<EdgeKey> {
        let mut out: Vec<EdgeKey> = self
            .live_tris()
            .flat_map(|(_, [a, b, c])| [key(a, b), key(b, c), key(c, a)])
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    pub fn length(&self, e: EdgeKey) -> f64 {
        self.pos[e.0 as usize].distance(self.pos[e.1 as usize])
    }

    /// Splits edge `a–b` at a new vertex `(p, g)`; each triangle
    /// `[a, b, c]` becomes `[a, m, c]`, `[m, b, c]`. Returns the new vertex.
    pub fn split(&mut self, a: u32, b: u32, p: DVec3, g: DVec3) -> u32 {
        let m = self.add_vertex(p, g);
        for (i, [x, y, c]) in self.edge_tris_small(a, b) {
            self.set_tri(i, [x, m, c]);
            self.add_tri([m, y, c]);
        }
        m
    }

    /// Collapses edge `a–b` into `a`, moved to `(p, g)`: the triangles of
    /// the edge die, `b`'s other triangles take `a` instead. The caller
    /// has checked [`DynMesh::can_collapse_topologically`].
    pub fn collapse(&mut self, a: u32, b: u32, p: DVec3, g: DVec3) {
        for (i, _) in self.edge_tris_small(a, b) {
            self.kill_tri(i);
        }
        // `b`'s star is emptied anyway: take it rather than copy it.
        let star_b = std::mem::take(&mut self.star[b as usize]);
        for &i in &star_b {
            let t = self.tris[i as usize].map(|v| if v == b { a } else { v });
            self.set_tri(i, t);
        }
        self.vert_alive[b as usize] = false;
        // Keep the emptied list's allocation.
        self.star[b as usize] = star_b;
        self.star[b as usize].clear();
        self.pos[a as usize] = p;
        self.grad[a as usize] = g;
    }

    /// The link condition (Dey et al. 1999): collapsing `a–b` keeps a
    /// closed 2-manifold iff the common neighbours of `a` and `b` are
    /// exactly the two vertices opposite the edge, and neither of those
    /// drops below valence 3.
    pub fn can_collapse_topologically(&self, a: u32, b: u32) -> bool {
        let Some(tris) = self.edge_pair(a, b) else {
            return false;
        };
        let opp = [tris[0].1[2], tris[1].1[2]];
        if opp[0] == opp[1] {
            return false;
        }
        // Valence of the opposite vertices after the collapse (the
        // cheapest test, first).
        if !opp.iter().all(|&v| self.star[v as usize].len() > 3) {
            return false;
        }
        let na = self.ring(a);
        let nb = self.ring(b);
        // Common neighbours of the two sorted rings, by a merge.
        let (mut i, mut j, mut common) = (0, 0, 0);
        while i < na.len() && j < nb.len() {
            match na[i].cmp(&nb[j]) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    common += 1;
                    i += 1;
                    j += 1;
                }
            }
        }
        if common != 2 || !opp.iter().all(|v| na.binary_search(v).is_ok()) {
            return false;
        }
        // The merged vertex keeps at least 3 neighbours.
        na.len() + nb.len() - 4 >= 3
    }

    /// Flips edge `a–b`: `[a, b, c]`, `[b, a, d]` become `[a, d, c]`,
    /// `[b, c, d]`. Returns the new edge `c–d`, or `None` when the flip is
    /// not topologically allowed (boundary, `c–d` already an edge, or a
    /// vertex would drop below valence 3).
    pub fn flip(&mut self, a: u32, b: u32) -> Option<EdgeKey> {
        let (c, d, t1, t2) = self.flip_quad(a, b)?;
        self.set_tri(t1, [a, d, c]);
        self.set_tri(t2, [b, c, d]);
        Some(key(c, d))
    }

    /// The quad of a flippable edge: `(c, d, t1, t2)` with
    /// `t1 = [a, b, c]`, `t2 = [b, a, d]`.
    pub fn flip_quad(&self, a: u32, b: u32) -> Option<(u32, u32, u32, u32)> {
        let [mut t1, mut t2] = self.edge_pair(a, b)?;
        if t1.1[0] != a {
            std::mem::swap(&mut t1, &mut t2);
        }
        if t1.1[0] != a || t2.1[0] != b {
            return None;
        }
        let (c, d) = (t1.1[2], t2.1[2]);
        if c == d
            || self.star[a as usize].len() <= 3
            || self.star[b as usize].len() <= 3
            || self.adjacent(c, d)
        {
            return None;
        }
        Some((c, d, t1.0, t2.0))
    }

    /// Renumbers live vertices and triangles densely; returns the vertex
    /// map (old → new, `u32::MAX` for dead vertices).
    pub fn compact(&mut self) -> Vec<u32> {
        let mut remap = vec![u32::MAX; self.pos.len()];
        let mut n = 0u32;
        for (i, alive) in self.vert_alive.iter().enumerate() {
            if *alive {
                remap[i] = n;
                n += 1;
            }
        }
        let keep = |v: &Vec<bool>, i: usize| v[i];
        let pos = (0..self.pos.len())
            .filter(|&i| keep(&self.vert_alive, i))
            .map(|i| self.pos[i])
            .collect();
        let grad = (0..self.grad.len())
            .filter(|&i| keep(&self.vert_alive, i))
            .map(|i| self.grad[i])
            .collect();
        let tris: Vec<[u32; 3]> = self
            .live_tris()
            .map(|(_, t)| t.map(|v| remap[v as usize]))
            .collect();
        let mut m = DynMesh {
            pos,
            grad,
            vert_alive: vec![true; n as usize],
            tris: Vec::with_capacity(tris.len()),
            tri_alive: Vec::with_capacity(tris.len()),
            star: vec![Vec::new(); n as usize],
        };
        for t in tris {
            m.add_tri(t);
        }
        *self = m;
        remap
    }

    /// A plain [`Mesh`] of the live part, normals the unit gradients.
    /// Live vertices and triangles are numbered as [`DynMesh::compact`]
    /// would, without copying the stars.
    pub fn to_mesh(&self) -> Mesh {
        let mut remap = vec![u32::MAX; self.pos.len()];
        let live = self.live_vert_count();
        let (mut positions, mut normals) = (Vec::with_capacity(live), Vec::with_capacity(live));
        for (i, alive) in self.vert_alive.iter().enumerate() {
            if *alive {
                remap[i] = positions.len() as u32;
                positions.push(self.pos[i]);
                normals.push(self.grad[i].normalize_or_zero());
            }
        }
        let triangles = self
            .live_tris()
            .map(|(_, t)| t.map(|v| remap[v as usize]))
            .collect();
        Mesh {
            ambiguous: vec![false; positions.len()],
            positions,
            normals,
            triangles,
        }
    }
}

/// `t` rotated so that it starts with edge `a–b` in either direction.
fn rotate_to_edge(t: [u32; 3], a: u32, b: u32) -> [u32; 3] {
    for r in 0..3 {
        let u = [t[r], t[(r + 1) % 3], t[(r + 2) % 3]];
        if (u[0] == a && u[1] == b) || (u[0] == b && u[1] == a) {
            return u;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::analyze;

    /// An octahedron, outward oriented.
    fn octahedron() -> DynMesh {
        let p = [
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::NEG_Z,
        ];
        let tris = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        let mesh = Mesh {
            positions: p.to_vec(),
            normals: p.to_vec(),
            ambiguous: vec![false; 6],
            triangles: tris,
        };
        DynMesh::from_mesh(&mesh)
    }

    fn check_closed(m: &DynMesh, faces: usize) {
        check_topology(m, faces);
        for (i, t) in m.live_tris() {
            let n = m.normal(i);
            let c = t.map(|v| m.pos[v as usize]).iter().sum::<DVec3>();
            assert!(n.dot(c) > 0.0, "triangle {t:?} faces inwards");
        }
    }

    fn check_topology(m: &DynMesh, faces: usize) {
        let mesh = m.to_mesh();
        let topo = analyze(&mesh);
        assert!(topo.watertight, "{topo:?}");
        assert_eq!(topo.euler, 2);
        assert_eq!(topo.faces, faces);
    }

    #[test]
    fn split_collapse_flip_keep_a_closed_oriented_sphere() {
        let mut m = octahedron();
        check_closed(&m, 8);
        let id = |p: DVec3| m.pos.iter().position(|&q| q == p).unwrap() as u32;
        let (x, y) = (id(DVec3::X), id(DVec3::Y));
        let mut expect = [x, y, id(DVec3::Z), id(DVec3::NEG_Z)];
        expect.sort();
        let mid = (DVec3::X + DVec3::Y).normalize();
        let v = m.split(x, y, mid, mid);
        check_closed(&m, 10);
        assert_eq!(m.neighbours(v), expect.to_vec());
        // The new vertex has valence 4 and its edge to x can collapse back.
        assert!(m.can_collapse_topologically(v, x));
        m.collapse(x, v, DVec3::X, DVec3::X);
        check_closed(&m, 8);
        // Octahedron edges have valence-4 ends: a flip leaves valence 3,
        // which is allowed, and the new diagonal (±z) is not an edge yet.
        // (The flipped octahedron is flat through its centre, so only its
        // topology is checked.)
        let e = m.flip(x, y);
        assert!(e.is_some());
        check_topology(&m, 8);
        m.compact();
        check_topology(&m, 8);
    }

    /// `edge_pair` finds the two triangles of every interior edge, rotated
    /// to start with it; `edges_unordered` (and `closed_edges` on a closed
    /// mesh) lists the same edges as the sorted `edges`, each once, closed
    /// or with a boundary.
    #[test]
    fn edge_queries() {
        let mut m = octahedron();
        for (a, b) in m.edges() {
            let [(i, s), (j, t)] = m.edge_pair(a, b).expect("interior edge");
            assert_ne!(i, j);
            for u in [s, t] {
                assert!((u[0] == a && u[1] == b) || (u[0] == b && u[1] == a));
            }
        }
        let mut e = m.edges_unordered();
        e.sort_unstable();
        assert_eq!(e, m.edges());
        let mut e = m.closed_edges();
        e.sort_unstable();
        assert_eq!(e, m.edges());
        // With a boundary: drop one triangle; its three edges become
        // boundary edges and are still listed once.
        m.kill_tri(1);
        let mut e = m.edges_unordered();
        e.sort_unstable();
        assert_eq!(e, m.edges());
        let boundary = e
            .iter()
            .filter(|&&(a, b)| m.edge_pair(a, b).is_none())
            .count();
        assert_eq!(boundary, 3);
    }

    #[test]
    fn the_link_condition_refuses_a_tetrahedron_collapse() {
        // A tetrahedron: every collapse would pinch it.
        let p = vec![
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(1.0, -1.0, -1.0),
            DVec3::new(-1.0, 1.0, -1.0),
            DVec3::new(-1.0, -1.0, 1.0),
        ];
        let mesh = Mesh {
            normals: p.clone(),
            ambiguous: vec![false; 4],
            positions: p,
            triangles: vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]],
        };
        let m = DynMesh::from_mesh(&mesh);
        check_closed(&m, 4);
        for a in 0..4 {
            for b in 0..4 {
                if a != b {
                    assert!(!m.can_collapse_topologically(a, b));
                }
            }
        }
    }
}
