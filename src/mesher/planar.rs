//! Flat regions retriangulated at once: where the dual grid left a plane
//! covered with cell-sized triangles (the faces of a CSG model), the
//! vertices inside the plane go together and the piece of plane is
//! triangulated anew from its border, with as few interior vertices as a
//! quality bound needs (constrained Delaunay refinement, `spade`).
//!
//! # Contract
//!
//! A vertex is **inner** when the caller lets it go (not a crease point,
//! pinned or otherwise held, see [`retriangulate`]; an ambiguous vertex
//! may go and hands its flag on), its star is a closed disk, every vertex
//! of its star lies on its tangent plane (within [`FLAT`] per length:
//! rounding, not curvature) and every triangle of its star faces along
//! its normal. A **region** is a
//! connected set of inner vertices (joined by edges) with the triangles
//! around them: a planar polygon, holes allowed, whose border is made of
//! the other vertices of those triangles. A region is retriangulated only
//! when all of this holds, and is left as it is otherwise:
//!
//! - every vertex of the region lies on one plane (the first inner
//!   vertex's tangent plane, within `1e-9` of the region's extent);
//! - the constrained Delaunay triangulation of the border vertices, with
//!   the border edges as constraints, keeps every border edge whole (no
//!   vertex on it), and its refinement (minimum angle [`ANGLE_DEG`],
//!   triangles below a minimum area left alone, at most as many new
//!   vertices as inner ones) splits no border edge;
//! - the new triangles use each border edge once, in its direction, and
//!   every other edge twice, opposite ways; no new edge joins two border
//!   vertices already joined outside the region; every border vertex is
//!   used; every new triangle faces along the plane's normal;
//! - every new point lies on `f = 0` (within [`ON_PLANE`] of a cell side,
//!   first order, with the gradient at the region's first vertex): the
//!   plane is the surface there too, not only at the old vertices (a
//!   mesh's plane across a shell thinner than a cell is not).
//!
//! The new triangles then cover the same piece of plane as the old ones,
//! so no point of the mesh moves and the chord error does not change;
//! the mesh keeps its topology, closedness and orientation, since the
//! region's border and everything outside it are untouched. New vertices
//! take the slots of removed inner vertices, so per-vertex data stays
//! indexed (the caller's `kept` flags read as for collapses).
//!
//! # Limits
//!
//! Only planes, found from the mesh's own normals: a region is a plane the
//! mesh already lies on, not one `f` is proved to be. Curved regions are
//! left to the collapses ([`super::coarsen`]). The refinement keeps border
//! edges whole, so a skinny triangle against a short border edge may stay
//! (the collapses and smoothing after it see to those).

use glam::DVec3;
use smallvec::{SmallVec, smallvec};
use spade::handles::FixedVertexHandle;
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, PositionInTriangulation,
    RefinementParameters, Triangulation,
};

use crate::eval::Evaluator;
use crate::mesh::dynmesh::DynMesh;

/// How far from equal two unit normals, and how far off a plane (per
/// length) a point, may be for a star to count as flat: rounding, not
/// curvature.
pub const FLAT: f64 = 1e-12;

/// How far off the region's plane (per length of the region's extent) a
/// vertex of it may be: [`FLAT`] times the edges a region spans.
const DRIFT: f64 = 1e-9;

/// How far off `f = 0` a new point may be, in cell sides (first order):
/// a tenth of what the vertices the mesher projects are held to.
const ON_PLANE: f64 = 1e-7;

/// A region's triangulation in its plane's coordinates.
type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// The refinement's minimum angle (degrees).
const ANGLE_DEG: f64 = 25.0;

/// Regions with fewer inner vertices are left to the collapses.
const MIN_INNER: usize = 3;

/// Retriangulates the flat regions of `m` (see the module doc) of the
/// surface `f(·, t) = 0`; `held` flags the vertices that must stay
/// (crease points, pinned vertices, vertices the collapses may not
/// remove), and `side` is the cell side: the refinement leaves alone the
/// triangles smaller than its square. An ambiguous
/// vertex that goes hands its flag in `ambiguous` to the nearest corner
/// of the new triangle it lies in, as a collapse hands it on. Returns the
/// vertices whose star changed: the regions' border vertices and new
/// vertices (in removed vertices' slots).
pub fn retriangulate<E: Evaluator + ?Sized>(
    m: &mut DynMesh,
    held: &[bool],
    ambiguous: &mut [bool],
    f: &E,
    t: f64,
    side: f64,
) -> Vec<u32> {
    let n = m.pos.len();
    let inner: Vec<bool> = (0..n as u32)
        .map(|v| m.vert_alive[v as usize] && !held[v as usize] && flat_star(m, v))
        .collect();
    let mut scratch = Scratch::new(n, m.tris.len());
    let mut changed = Vec::new();
    for seed in 0..n as u32 {
        if !inner[seed as usize] || scratch.component[seed as usize] != NONE {
            continue;
        }
        let region = Region::grow(m, &inner, seed, &mut scratch);
        if region.inner.len() < MIN_INNER {
            continue;
        }
        let new = region.triangulate(m, &scratch, ambiguous, side * side);
        if let Some(new) = new.filter(|new| region.on_surface(new, f, t, side)) {
            region.apply(m, new, ambiguous, &mut changed);
            scratch.tri.resize(m.tris.len(), NONE);
        }
    }
    changed.sort_unstable();
    changed.dedup();
    changed
}

/// No component yet.
const NONE: u32 = u32::MAX;

/// Per vertex and per triangle, the region it belongs to (as its seed).
struct Scratch {
    component: Vec<u32>,
    tri: Vec<u32>,
    /// Per vertex, the region whose border it was last found on.
    border: Vec<u32>,
}

impl Scratch {
    fn new(verts: usize, tris: usize) -> Self {
        Scratch {
            component: vec![NONE; verts],
            tri: vec![NONE; tris],
            border: vec![NONE; verts],
        }
    }
}

/// Whether every vertex of `v`'s star lies on `v`'s tangent plane and
/// every triangle of it faces along `v`'s normal (its star being a closed
/// disk is the caller's `held`).
fn flat_star(m: &DynMesh, v: u32) -> bool {
    let (p, n) = (m.pos[v as usize], m.grad[v as usize]);
    if (n.length() - 1.0).abs() > 1e-6 || m.star[v as usize].is_empty() {
        return false;
    }
    m.star[v as usize].iter().all(|&i| {
        let tri = m.tris[i as usize];
        let q = tri.map(|w| m.pos[w as usize]);
        q.iter().all(|&w| on_tangent_plane(p, n, w))
            && (q[1] - q[0]).cross(q[2] - q[0]).dot(n) > 0.0
    })
}

/// Whether `w` lies on the plane through `p` with unit normal `n`, within
/// [`FLAT`] per length of `w − p`.
pub fn on_tangent_plane(p: DVec3, n: DVec3, w: DVec3) -> bool {
    let d = w - p;
    n.dot(d).abs() <= FLAT * d.length()
}

/// A region: its inner vertices, triangles, border vertices and directed
/// border edges, and its plane.
struct Region {
    id: u32,
    inner: Vec<u32>,
    tris: Vec<u32>,
    border: Vec<u32>,
    edges: Vec<(u32, u32)>,
    origin: DVec3,
    normal: DVec3,
    axes: [DVec3; 2],
}

impl Region {
    /// The region of the inner vertex `seed`, stamped into `scratch`.
    fn grow(m: &DynMesh, inner: &[bool], seed: u32, scratch: &mut Scratch) -> Region {
        let id = seed;
        let mut verts = vec![seed];
        scratch.component[seed as usize] = id;
        let mut tris = Vec::new();
        let mut at = 0;
        while at < verts.len() {
            let v = verts[at];
            at += 1;
            for &i in &m.star[v as usize] {
                if scratch.tri[i as usize] != id {
                    scratch.tri[i as usize] = id;
                    tris.push(i);
                }
                for w in m.tris[i as usize] {
                    if inner[w as usize] && scratch.component[w as usize] == NONE {
                        scratch.component[w as usize] = id;
                        verts.push(w);
                    }
                }
            }
        }
        let mut border = Vec::new();
        for &i in &tris {
            for w in m.tris[i as usize] {
                if scratch.component[w as usize] != id && scratch.border[w as usize] != id {
                    scratch.border[w as usize] = id;
                    border.push(w);
                }
            }
        }
        let edges = border_edges(m, &tris, id, scratch);
        let normal = m.grad[seed as usize].normalize();
        let (a, b) = normal.any_orthonormal_pair();
        let axes = if a.cross(b).dot(normal) > 0.0 {
            [a, b]
        } else {
            [b, a]
        };
        Region {
            id,
            inner: verts,
            tris,
            border,
            edges,
            origin: m.pos[seed as usize],
            normal,
            axes,
        }
    }

    /// A point's coordinates in the plane.
    fn flat(&self, p: DVec3) -> Point2<f64> {
        let d = p - self.origin;
        Point2::new(d.dot(self.axes[0]), d.dot(self.axes[1]))
    }

    /// The new triangles, over the border vertices and new points (as
    /// [`Corner`]s), when every condition of the module doc holds.
    fn triangulate(
        &self,
        m: &DynMesh,
        scratch: &Scratch,
        ambiguous: &[bool],
        min_area: f64,
    ) -> Option<NewTris> {
        if !self.planar(m) {
            return None;
        }
        let mut cdt = self.constrained(m)?;
        let params = RefinementParameters::<f64>::new()
            .keep_constraint_edges()
            .exclude_outer_faces(true)
            .with_angle_limit(AngleLimit::from_deg(ANGLE_DEG))
            .with_min_required_area(min_area)
            .with_max_additional_vertices(self.inner.len());
        let excluded: std::collections::HashSet<_> =
            cdt.refine(params).excluded_faces.into_iter().collect();
        let corner = |h: FixedVertexHandle| {
            let j = h.index();
            if j < self.border.len() {
                Corner::Old(self.border[j])
            } else {
                let p = cdt.vertex(h).position();
                Corner::New(j - self.border.len(), p.x, p.y)
            }
        };
        let tris: Vec<[Corner; 3]> = cdt
            .inner_faces()
            .filter(|f| !excluded.contains(&f.fix()))
            .map(|f| f.vertices().map(|v| corner(v.fix())))
            .collect();
        let marks = self
            .inner
            .iter()
            .filter(|&&v| ambiguous[v as usize])
            .map(|&v| nearest_corner(&cdt, self.flat(m.pos[v as usize])).map(corner))
            .collect::<Option<Vec<Corner>>>()?;
        let new = NewTris::number(tris, marks, self.inner.len())?;
        self.valid(m, scratch, &new).then_some(new)
    }

    /// The constrained Delaunay triangulation of the border vertices
    /// (handle `j` the `j`-th) with the border edges whole as constraints.
    fn constrained(&self, m: &DynMesh) -> Option<Cdt> {
        let mut cdt = Cdt::new();
        let mut local = std::collections::HashMap::with_capacity(self.border.len());
        for (j, &v) in self.border.iter().enumerate() {
            let h = cdt.insert(self.flat(m.pos[v as usize])).ok()?;
            if h.index() != j {
                return None;
            }
            local.insert(v, h);
        }
        for &(a, b) in &self.edges {
            if cdt.try_add_constraint(local[&a], local[&b]).len() != 1 {
                return None;
            }
        }
        Some(cdt)
    }

    /// Whether every new point lies on `f(·, t) = 0` (within [`ON_PLANE`]
    /// of the cell `side`, first order): the plane is the surface there,
    /// not only at the old vertices (a plane across a shell thinner than
    /// a cell is not). ∇f is not compared with the plane's normal: where
    /// two faces coincide, `f` reads the other face's gradient at exact
    /// ties (colonnade.vm's floor).
    fn on_surface<E: Evaluator + ?Sized>(&self, new: &NewTris, f: &E, t: f64, side: f64) -> bool {
        let n = new.points.len();
        let mut xyz = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        for (i, &(x, y)) in new.points.iter().enumerate() {
            let p = self.lift(x, y);
            (0..3).for_each(|k| xyz[k][i] = p[k]);
        }
        let mut values = vec![0.0; n];
        f.point_batch(&xyz[0], &xyz[1], &xyz[2], t, &mut values);
        // `f` is affine on the plane: one gradient gives the scale.
        let o = self.origin;
        let (_, g) = f.point_grad([o.x, o.y, o.z, t]);
        let tolerance = ON_PLANE * side * DVec3::from_array(g).length();
        values.iter().all(|v| v.abs() <= tolerance)
    }

    /// The point at plane coordinates `(x, y)`.
    fn lift(&self, x: f64, y: f64) -> DVec3 {
        self.origin + x * self.axes[0] + y * self.axes[1]
    }

    /// Whether every vertex of the region lies on its plane.
    fn planar(&self, m: &DynMesh) -> bool {
        let all = || {
            self.inner
                .iter()
                .chain(&self.border)
                .map(|&v| m.pos[v as usize])
        };
        let extent = all().map(|p| p.distance(self.origin)).fold(0.0, f64::max);
        all().all(|p| self.normal.dot(p - self.origin).abs() <= DRIFT * extent)
    }

    /// The checks of the module doc on the new triangles.
    fn valid(&self, m: &DynMesh, scratch: &Scratch, new: &NewTris) -> bool {
        let mut edges: Vec<(u32, u32)> = new
            .tris
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .collect();
        edges.sort_unstable();
        if edges.windows(2).any(|w| w[0] == w[1]) {
            return false;
        }
        let has = |e: (u32, u32)| edges.binary_search(&e).is_ok();
        let mut border: Vec<(u32, u32)> = self.edges.clone();
        border.sort_unstable();
        let is_border = |e: (u32, u32)| border.binary_search(&e).is_ok();
        let mut open = 0;
        for &(a, b) in &edges {
            if has((b, a)) {
                // An inside edge: between two border vertices, not an
                // edge outside the region too.
                if a < b
                    && new.is_old(a)
                    && new.is_old(b)
                    && joined_outside(m, scratch, self.id, a, b)
                {
                    return false;
                }
            } else if is_border((a, b)) {
                open += 1;
            } else {
                return false;
            }
        }
        let used = |v: &u32| edges.binary_search_by(|e| e.0.cmp(v)).is_ok();
        open == border.len() && self.border.iter().all(used) && new.faces_along(self, m)
    }

    /// Replaces the region's triangles by `new`: the inner vertices go,
    /// the new points take their slots. Records the vertices whose star
    /// changed in `changed`.
    fn apply(&self, m: &mut DynMesh, new: NewTris, ambiguous: &mut [bool], changed: &mut Vec<u32>) {
        for &i in &self.tris {
            m.kill_tri(i);
        }
        for &v in &self.inner {
            m.vert_alive[v as usize] = false;
            ambiguous[v as usize] = false;
        }
        for (s, &(x, y)) in new.points.iter().enumerate() {
            let v = self.inner[s];
            m.pos[v as usize] = self.lift(x, y);
            m.grad[v as usize] = self.normal;
            m.vert_alive[v as usize] = true;
        }
        for t in &new.tris {
            let t = t.map(|c| new.vertex(self, c));
            m.add_tri(t);
            changed.extend(t);
        }
        for &c in &new.ambiguous {
            ambiguous[new.vertex(self, c) as usize] = true;
        }
    }
}

/// The directed border edges of the region `id` (triangles `tris`): edges
/// between two of its border vertices whose other triangle is not the
/// region's.
fn border_edges(m: &DynMesh, tris: &[u32], id: u32, scratch: &Scratch) -> Vec<(u32, u32)> {
    let mut edges = Vec::new();
    for &i in tris {
        let tri = m.tris[i as usize];
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            if scratch.component[a as usize] == id || scratch.component[b as usize] == id {
                continue;
            }
            if !shares_triangle(m, a, b, |j| j != i && scratch.tri[j as usize] == id) {
                edges.push((a, b));
            }
        }
    }
    edges
}

/// Whether border vertices `a` and `b` share a triangle outside region `id`.
fn joined_outside(m: &DynMesh, scratch: &Scratch, id: u32, a: u32, b: u32) -> bool {
    shares_triangle(m, a, b, |j| scratch.tri[j as usize] != id)
}

/// Whether `a` and `b` share a live triangle `j` for which `which(j)`.
fn shares_triangle(m: &DynMesh, a: u32, b: u32, which: impl Fn(u32) -> bool) -> bool {
    m.star[a as usize]
        .iter()
        .any(|&j| which(j) && m.tris[j as usize].contains(&b))
}

/// The vertex of `cdt` nearest `p` among the corners of what `p` lies in
/// (a vertex, an edge or a face); `None` outside the triangulation.
fn nearest_corner(cdt: &Cdt, p: Point2<f64>) -> Option<FixedVertexHandle> {
    let near: SmallVec<[FixedVertexHandle; 3]> = match cdt.locate(p) {
        PositionInTriangulation::OnVertex(h) => smallvec![h],
        PositionInTriangulation::OnEdge(e) => {
            let e = cdt.directed_edge(e);
            smallvec![e.from().fix(), e.to().fix()]
        }
        PositionInTriangulation::OnFace(f) => {
            cdt.face(f).vertices().iter().map(|v| v.fix()).collect()
        }
        _ => return None,
    };
    let d2 = |h: &FixedVertexHandle| {
        let q = cdt.vertex(*h).position();
        (q.x - p.x).powi(2) + (q.y - p.y).powi(2)
    };
    near.into_iter().min_by(|a, b| d2(a).total_cmp(&d2(b)))
}

/// A corner of a new triangle: a border vertex, or the `j`-th new point
/// at plane coordinates `(x, y)`.
#[derive(Clone, Copy)]
enum Corner {
    Old(u32),
    New(usize, f64, f64),
}

/// The new triangles of a region, numbered: border vertices by their
/// index, new points as `u32::MAX - j` until they get a slot; and the
/// corners that take an ambiguous flag.
struct NewTris {
    tris: Vec<[u32; 3]>,
    points: Vec<(f64, f64)>,
    ambiguous: Vec<u32>,
}

impl NewTris {
    /// Numbers the corners of `tris` and `marks`; `None` when more new
    /// points are used than there are `slots`, or a mark is a new point
    /// no triangle uses.
    fn number(tris: Vec<[Corner; 3]>, marks: Vec<Corner>, slots: usize) -> Option<NewTris> {
        let mut index: std::collections::HashMap<usize, u32> = Default::default();
        let mut points = Vec::new();
        let mut out = Vec::with_capacity(tris.len());
        for t in tris {
            let mut tri = [0u32; 3];
            for (k, c) in t.into_iter().enumerate() {
                tri[k] = match c {
                    Corner::Old(v) => v,
                    Corner::New(j, x, y) => {
                        let s = *index.entry(j).or_insert_with(|| {
                            points.push((x, y));
                            (points.len() - 1) as u32
                        });
                        u32::MAX - s
                    }
                };
            }
            out.push(tri);
        }
        let ambiguous = marks
            .into_iter()
            .map(|c| match c {
                Corner::Old(v) => Some(v),
                Corner::New(j, ..) => index.get(&j).map(|s| u32::MAX - s),
            })
            .collect::<Option<Vec<u32>>>()?;
        (points.len() <= slots).then_some(NewTris {
            tris: out,
            points,
            ambiguous,
        })
    }

    /// Whether `v` numbers a border vertex.
    fn is_old(&self, v: u32) -> bool {
        (v as usize) < (u32::MAX as usize - self.points.len())
    }

    /// The mesh vertex of corner number `v` in `region`.
    fn vertex(&self, region: &Region, v: u32) -> u32 {
        if self.is_old(v) {
            v
        } else {
            region.inner[(u32::MAX - v) as usize]
        }
    }

    /// Whether every new triangle faces along the region's normal.
    fn faces_along(&self, region: &Region, m: &DynMesh) -> bool {
        let at = |v: u32| {
            if self.is_old(v) {
                m.pos[v as usize]
            } else {
                let (x, y) = self.points[(u32::MAX - v) as usize];
                region.lift(x, y)
            }
        };
        self.tris.iter().all(|t| {
            let q = t.map(at);
            (q[1] - q[0]).cross(q[2] - q[0]).dot(region.normal) > 0.0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::mesh::quality::aspect;
    use crate::mesh::topology::analyze;

    /// The unit cube's surface, each face an `n × n` grid of squares cut
    /// into two triangles (outward), the normals each face's own (the
    /// edges' vertices one of their faces'); and which vertices lie on the
    /// cube's edges.
    fn cube(n: usize) -> (Mesh, Vec<bool>) {
        let mut mesh = Mesh::default();
        let mut index = std::collections::HashMap::new();
        let mut on_edge = Vec::new();
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                let normal = DVec3::from_array(std::array::from_fn(|k| {
                    if k == axis { 2.0 * side - 1.0 } else { 0.0 }
                }));
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let mut id = |i: usize, j: usize| {
                    let mut p = [0.0; 3];
                    p[axis] = side;
                    p[u] = i as f64 / n as f64;
                    p[v] = j as f64 / n as f64;
                    let key = p.map(|c| (c * n as f64).round() as i64);
                    *index.entry(key).or_insert_with(|| {
                        mesh.positions.push(DVec3::from_array(p));
                        mesh.normals.push(normal);
                        let edge = [i, j].iter().any(|&c| c == 0 || c == n);
                        on_edge.push(edge);
                        mesh.positions.len() as u32 - 1
                    })
                };
                let mut quads = Vec::new();
                for i in 0..n {
                    for j in 0..n {
                        quads.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
                    }
                }
                for q in quads {
                    // `u × v` is `+axis`: reverse on the low side.
                    let (a, b) = ([q[0], q[1], q[2]], [q[0], q[2], q[3]]);
                    let flip = |t: [u32; 3]| if side > 0.0 { t } else { [t[0], t[2], t[1]] };
                    mesh.triangles.extend([flip(a), flip(b)]);
                }
            }
        }
        mesh.ambiguous = vec![false; mesh.positions.len()];
        (mesh, on_edge)
    }

    /// The unit cube `[0, 1]³` (less a ball of `radius` at the centre of
    /// its `z = 1` face), as a surface.
    fn solid(radius: f64) -> crate::surface::Surface {
        let src = format!(
            "domain [-1, 2]^3; surface max(max(abs(x - 0.5), abs(y - 0.5), abs(z - 0.5)) - 0.5, \
             {radius} - sqrt((x - 0.5)^2 + (y - 0.5)^2 + (z - 1)^2));"
        );
        crate::surface::Surface::compile(&src, "cube.iso", &Default::default()).unwrap()
    }

    /// The enclosed volume of a closed, outward mesh.
    fn volume(m: &DynMesh) -> f64 {
        m.live_tris()
            .map(|(_, t)| {
                let [a, b, c] = t.map(|v| m.pos[v as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    fn area(m: &DynMesh) -> f64 {
        (0..m.tris.len() as u32)
            .filter(|&i| m.tri_alive[i as usize])
            .map(|i| 0.5 * m.normal(i).length())
            .sum()
    }

    #[test]
    fn a_grid_cube_keeps_its_surface_with_fewer_triangles() {
        let (mesh, held) = cube(16);
        let mut m = DynMesh::indexed(&mesh);
        let mut ambiguous = vec![false; mesh.positions.len()];
        let before = m.live_tri_count();
        let changed = retriangulate(&mut m, &held, &mut ambiguous, &solid(0.0), 0.0, 1.0 / 16.0);
        assert!(!changed.is_empty());
        assert!(
            m.live_tri_count() * 3 < before,
            "{} of {before} triangles left",
            m.live_tri_count()
        );
        assert_same_cube(&m, &mesh, &held);
        for (_, t) in m.live_tris() {
            let q = t.map(|v| m.pos[v as usize]);
            assert!(aspect(q[0], q[1], q[2]) > 0.05, "sliver {q:?}");
        }
    }

    /// Whether `p` lies in the triangle `q` (in its plane, up to rounding).
    fn inside(p: DVec3, q: [DVec3; 3]) -> bool {
        let n = (q[1] - q[0]).cross(q[2] - q[0]);
        let off = n.dot(p - q[0]).abs() <= 1e-12 * n.length();
        off && (0..3).all(|k| {
            let (a, b) = (q[k], q[(k + 1) % 3]);
            (b - a).cross(p - a).dot(n) >= -1e-12 * n.length_squared()
        })
    }

    /// The checks every retriangulated cube `m` (of `mesh`) passes: the
    /// same closed surface (volume, area, topology), the `held` vertices
    /// where they were, every triangle on one face.
    fn assert_same_cube(m: &DynMesh, mesh: &Mesh, held: &[bool]) {
        assert!((volume(m) - 1.0).abs() < 1e-12, "volume {}", volume(m));
        assert!((area(m) - 6.0).abs() < 1e-12, "area {}", area(m));
        let topo = analyze(&m.to_mesh());
        assert!(topo.watertight && topo.manifold(), "{topo:?}");
        assert_eq!((topo.components, topo.euler), (1, 2));
        for (v, &h) in held.iter().enumerate() {
            assert!(!h || (m.vert_alive[v] && m.pos[v] == mesh.positions[v]));
        }
        for (_, t) in m.live_tris() {
            let q = t.map(|v| m.pos[v as usize]);
            let shared = (0..3).any(|k| {
                q.iter().all(|p| p[k].abs() < 1e-12) || q.iter().all(|p| (p[k] - 1.0).abs() < 1e-12)
            });
            assert!(shared, "{q:?} is not on one face");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

        /// Whatever is held and whatever is ambiguous, a grid cube keeps
        /// its surface; an ambiguous vertex that stays keeps its flag, one
        /// that goes leaves it on a corner of the triangle it lies in, and
        /// no flag is made from nothing.
        #[test]
        fn any_held_set_keeps_the_cube(
            n in 2usize..10,
            flags in proptest::collection::vec(0u8..8, 600),
        ) {
            let (mesh, edges) = cube(n);
            let held: Vec<bool> = (0..mesh.positions.len())
                .map(|v| edges[v] || flags[v % flags.len()] == 0)
                .collect();
            let mut ambiguous: Vec<bool> = (0..mesh.positions.len())
                .map(|v| flags[(v * 7 + 3) % flags.len()] == 1)
                .collect();
            let before = ambiguous.clone();
            let mut m = DynMesh::indexed(&mesh);
            retriangulate(&mut m, &held, &mut ambiguous, &solid(0.0), 0.0, 1.0 / n as f64);
            assert_same_cube(&m, &mesh, &held);
            for v in (0..before.len()).filter(|&v| before[v]) {
                let p = mesh.positions[v];
                let kept = m.vert_alive[v] && m.pos[v] == p;
                let handed = m.live_tris().any(|(_, t)| {
                    t.iter().any(|&w| ambiguous[w as usize]) && inside(p, t.map(|w| m.pos[w as usize]))
                });
                proptest::prop_assert!(if kept { ambiguous[v] } else { handed }, "{p:?}");
            }
            let left = (0..m.pos.len()).any(|v| m.vert_alive[v] && ambiguous[v]);
            proptest::prop_assert_eq!(left, before.iter().any(|&a| a));
        }
    }

    #[test]
    fn a_curved_patch_is_left_alone() {
        let (mut mesh, held) = cube(8);
        // Bulge the z = 1 face: its inner vertices leave its plane.
        for (p, &h) in mesh.positions.iter_mut().zip(&held) {
            if !h && p.z == 1.0 {
                p.z += 0.1 * (p.x * (1.0 - p.x) * p.y * (1.0 - p.y));
            }
        }
        let mut m = DynMesh::indexed(&mesh);
        let mut ambiguous = vec![false; mesh.positions.len()];
        retriangulate(&mut m, &held, &mut ambiguous, &solid(0.0), 0.0, 1.0 / 8.0);
        let bulged = |p: DVec3| p.z > 1.0;
        let left = mesh.positions.iter().filter(|&&p| bulged(p)).count();
        let kept = (0..m.pos.len())
            .filter(|&v| m.vert_alive[v] && bulged(m.pos[v]) && m.pos[v] == mesh.positions[v])
            .count();
        assert_eq!(kept, left, "the bulged face's vertices stay");
        let topo = analyze(&m.to_mesh());
        assert!(topo.watertight && topo.manifold(), "{topo:?}");
    }

    #[test]
    fn a_plane_the_surface_leaves_is_left_alone() {
        // The mesh's z = 1 face is flat, the surface has a dimple there
        // (a ball of radius 0.3 taken out) which the grid does not see.
        let (mesh, held) = cube(16);
        let top = |m: &DynMesh| {
            (0..m.pos.len())
                .filter(|&v| m.vert_alive[v] && m.pos[v].z == 1.0)
                .count()
        };
        for (radius, stays) in [(0.3, true), (0.0, false)] {
            let mut m = DynMesh::indexed(&mesh);
            let mut ambiguous = vec![false; mesh.positions.len()];
            let before = top(&m);
            retriangulate(
                &mut m,
                &held,
                &mut ambiguous,
                &solid(radius),
                0.0,
                1.0 / 16.0,
            );
            assert_eq!(top(&m) == before, stays, "radius {radius}");
            // The other faces go either way.
            assert!(m.live_tri_count() < mesh.triangles.len() / 2);
        }
    }

    #[test]
    fn an_ambiguous_vertex_hands_its_flag_on() {
        let (mesh, held) = cube(8);
        let mut m = DynMesh::indexed(&mesh);
        let mut ambiguous = vec![false; mesh.positions.len()];
        // An inner vertex of the z = 1 face.
        let v = (0..mesh.positions.len())
            .find(|&v| !held[v] && mesh.positions[v].z == 1.0)
            .unwrap();
        ambiguous[v] = true;
        retriangulate(&mut m, &held, &mut ambiguous, &solid(0.0), 0.0, 1.0 / 8.0);
        let flagged: Vec<usize> = (0..m.pos.len())
            .filter(|&w| m.vert_alive[w] && ambiguous[w])
            .collect();
        assert_eq!(flagged.len(), 1, "{flagged:?}");
        assert!(m.pos[flagged[0]].z == 1.0 && !m.star[flagged[0]].is_empty());
    }
}
