//! Edge flips that improve triangle shape (issue 11, item 2).
//!
//! # Contract
//!
//! [`flip`] replaces the diagonal of the quadrilateral formed by two
//! triangles sharing an edge, `[p, q, c]` and `[q, p, d]`, with the other
//! diagonal, giving `[c, p, d]` and `[d, q, c]`, whenever that raises the
//! smaller of the two triangles' aspect ratios ([`crate::mesh::quality`]) by more
//! than a small margin. A flip is done only when
//!
//! - the edge has exactly two triangles, traversed in opposite directions
//!   (boundary, non-manifold and misoriented edges are never flipped);
//! - the new edge `c–d` does not exist yet (so the mesh stays manifold: a
//!   flip re-triangulates a disk, the quadrilateral, into a disk), as told
//!   by walking around `c`; when `c`'s triangles do not form one fan (a
//!   bow-tie vertex) the flip is refused;
//! - neither new triangle folds: each one's normal agrees with the surface
//!   normal ([`Mesh::normals`], the direction of ∇f) at its three corners
//!   (positive dot product), and it does not agree worse than the two old
//!   triangles did unless it agrees within 30°;
//! - the angle between the two new triangles' normals is no larger than
//!   between the old pair's, unless it is below 30° (no new ridge).
//!
//! Hence a flip never changes the vertex set, the vertex positions, the
//! orientation (the new triangles traverse the quadrilateral's boundary as
//! the old ones did), the components, the Euler characteristic or the
//! genus: only which of the two diagonals of a quadrilateral is an edge.
//! Every accepted flip raises the sorted list of triangle aspect ratios
//! lexicographically, so the sweeps terminate; they are also capped.
//!
//! # Limits
//!
//! Flips only choose among the triangulations of the given vertices: where
//! the vertex density itself is anisotropic (dual cells much longer in one
//! direction than another), no flip makes the triangles equilateral;
//! relaxation ([`super::smooth`]) moves the vertices. The fold test uses the
//! normals at the corners only; it does not test the new triangles against
//! distant parts of the mesh (nor does any other stage). The first sweep of
//! a run picks its candidate edges in parallel (a read-only quality test);
//! the flips themselves are sequential, each one tested against the
//! current mesh, so the result does not depend on the thread count.
//! The adjacency ([`Flips`]) is built once and kept up to date by the
//! flips, so that smoothing's passes can share it.

use rayon::prelude::*;

use crate::mesh::quality::aspect_ratio;
use crate::mesh::{Mesh, Star};
/// A flip must raise the pair's smaller aspect ratio by more than this.
const MARGIN: f64 = 1e-6;
/// New triangles whose normals are within 30° of the surface normals at
/// their corners are always acceptable for the fold test.
const COS_OK: f64 = 0.866;
/// Most sweeps over the worklist's generations.
const MAX_SWEEPS: usize = 20;
/// No twin: a boundary or non-manifold edge, or a misoriented pair.
const NONE: u32 = u32::MAX;

/// The least dot product of the unit normal of `t` with the surface
/// normals at its corners (−1 for a degenerate triangle).
fn agreement(mesh: &Mesh, t: [u32; 3]) -> f64 {
    let n = mesh.face_normal(t);
    let len = n.length();
    if len.is_nan() || len <= 0.0 {
        return -1.0;
    }
    let n = n / len;
    t.iter()
        .map(|&v| n.dot(mesh.normals[v as usize]))
        .fold(f64::INFINITY, f64::min)
}

/// Half-edge `3t + i` of triangle `t` runs from `t[i]` to `t[(i + 1) % 3]`;
/// `twin[h]` is the half-edge running the other way in the neighbouring
/// triangle, or [`NONE`] unless the undirected edge has exactly two
/// half-edges and they run in opposite directions.
pub(crate) struct Flips {
    twin: Vec<u32>,
    /// Triangles per vertex.
    degree: Vec<u32>,
    /// Aspect ratio per triangle.
    aspect: Vec<f64>,
    /// Vertices whose joining edges are never flipped (crease points).
    keep: Vec<bool>,
    /// Vertices never joined by a new edge (a brick's seam: the next brick
    /// may join them already).
    apart: Vec<bool>,
}

impl Flips {
    /// The adjacency of `mesh`; valid while only [`Flips::run`] changes its
    /// triangles (moving vertices is fine).
    pub fn new(mesh: &Mesh) -> Self {
        let star = Star::new(mesh);
        let tris = &mesh.triangles;
        let twin: Vec<u32> = (0..3 * tris.len())
            .into_par_iter()
            .map(|h| {
                let (t, i) = (h / 3, h % 3);
                let degenerate = |t: [u32; 3]| t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
                if degenerate(tris[t]) {
                    return NONE;
                }
                let (a, b) = (tris[t][i], tris[t][(i + 1) % 3]);
                // The other triangles holding both ends; exactly one, and
                // running b → a, for a twin (none next to a triangle with a
                // repeated corner).
                let mut other = NONE;
                for &u in star.of(a as usize) {
                    if u as usize == t {
                        continue;
                    }
                    let tr = tris[u as usize];
                    if degenerate(tr) && tr.contains(&b) {
                        return NONE;
                    }
                    if let Some(j) = tr.iter().position(|&w| w == b) {
                        if other != NONE {
                            return NONE;
                        }
                        if tr[(j + 1) % 3] != a {
                            return NONE;
                        }
                        other = 3 * u + j as u32;
                    }
                }
                other
            })
            .collect();
        let degree = (0..mesh.positions.len())
            .map(|v| star.of(v).len() as u32)
            .collect();
        let aspect = tris.par_iter().map(|&t| aspect_ratio(mesh, t)).collect();
        Flips {
            twin,
            degree,
            aspect,
            keep: Vec::new(),
            apart: Vec::new(),
        }
    }

    /// Whether `c` and `d` are joined by an edge, or `None` when that cannot
    /// be told from `c`'s fan (its triangles do not form one fan). `start`
    /// is a triangle holding `c`.
    fn joined(&self, mesh: &Mesh, c: u32, start: u32, d: u32) -> Option<bool> {
        let degree = self.degree[c as usize];
        let (mut seen, mut found) = (0u32, false);
        let mut look = |tr: [u32; 3], s: usize| {
            seen += 1;
            found |= tr[(s + 1) % 3] == d || tr[(s + 2) % 3] == d;
            seen
        };
        // Forward: cross the edge entering `c`.
        let mut t = start;
        loop {
            let tr = mesh.triangles[t as usize];
            let s = tr.iter().position(|&w| w == c)?;
            if look(tr, s) > degree {
                return None;
            }
            let g = self.twin[3 * t as usize + (s + 2) % 3];
            if g == NONE {
                break;
            }
            t = g / 3;
            if t == start {
                return (seen == degree).then_some(found);
            }
        }
        // A boundary stopped the walk: backward from `start`, crossing the
        // edge leaving `c`.
        let mut t = start;
        loop {
            let tr = mesh.triangles[t as usize];
            let s = tr.iter().position(|&w| w == c)?;
            let g = self.twin[3 * t as usize + s];
            if g == NONE {
                break;
            }
            t = g / 3;
            if t == start {
                return None;
            }
            let tr = mesh.triangles[t as usize];
            let s = tr.iter().position(|&w| w == c)?;
            if look(tr, s) > degree {
                return None;
            }
        }
        (seen == degree).then_some(found)
    }

    /// Flips the edge of half-edge `h` if allowed and worthwhile; returns
    /// the half-edges of the quadrilateral's sides when it did.
    fn try_flip(
        &mut self,
        mesh: &mut Mesh,
        h: u32,
        allow: &dyn Fn(&Mesh, u32, u32) -> bool,
    ) -> Option<[u32; 4]> {
        let g = self.twin[h as usize];
        if g == NONE {
            return None;
        }
        let (t1, t2) = (h / 3, g / 3);
        let (i, j) = (h % 3, g % 3);
        let (a, b) = (mesh.triangles[t1 as usize], mesh.triangles[t2 as usize]);
        let (p, q, c) = (
            a[i as usize],
            a[(i as usize + 1) % 3],
            a[(i as usize + 2) % 3],
        );
        let d = b[(j as usize + 2) % 3];
        debug_assert!(b[j as usize] == q && b[(j as usize + 1) % 3] == p);
        if c == d || p == c || q == c || p == d || q == d {
            return None;
        }
        let kept = |v: u32| self.keep.get(v as usize).copied().unwrap_or(false);
        if kept(p) && kept(q) {
            return None;
        }
        let apart = |v: u32| self.apart.get(v as usize).copied().unwrap_or(false);
        if apart(c) && apart(d) {
            return None;
        }
        let old = [[p, q, c], [q, p, d]];
        let new = [[c, p, d], [d, q, c]];
        let (n1, n2) = (aspect_ratio(mesh, new[0]), aspect_ratio(mesh, new[1]));
        if n1.min(n2) <= self.aspect[t1 as usize].min(self.aspect[t2 as usize]) + MARGIN {
            return None;
        }
        if self.joined(mesh, c, t1, d) != Some(false) {
            return None;
        }
        let agree = |ts: &[[u32; 3]; 2]| agreement(mesh, ts[0]).min(agreement(mesh, ts[1]));
        let (agree_new, agree_old) = (agree(&new), agree(&old));
        if agree_new.is_nan() || agree_new <= 0.0 || (agree_new < agree_old && agree_new < COS_OK) {
            return None;
        }
        // Refuse a sharp crease between the two new triangles where the
        // old pair was flatter (a flip across a ridge of the mesh).
        let n = |t: [u32; 3]| mesh.face_normal(t).normalize_or_zero();
        let crease = |ts: &[[u32; 3]; 2]| n(ts[0]).dot(n(ts[1]));
        if crease(&new) < crease(&old).min(COS_OK) || !allow(mesh, c, d) {
            return None;
        }
        // Old half-edges: t1 = p→q (h), q→c, c→p; t2 = q→p (g), p→d, d→q.
        let tw = |k: u32| self.twin[k as usize];
        let (qc, cp) = (tw(3 * t1 + (i + 1) % 3), tw(3 * t1 + (i + 2) % 3));
        let (pd, dq) = (tw(3 * t2 + (j + 1) % 3), tw(3 * t2 + (j + 2) % 3));
        // New t1 = [c, p, d]: c→p, p→d, d→c; new t2 = [d, q, c]: d→q, q→c,
        // c→d.
        mesh.triangles[t1 as usize] = new[0];
        mesh.triangles[t2 as usize] = new[1];
        self.aspect[t1 as usize] = n1;
        self.aspect[t2 as usize] = n2;
        let link = |tw: &mut Vec<u32>, x: u32, y: u32| {
            tw[x as usize] = y;
            if y != NONE {
                tw[y as usize] = x;
            }
        };
        link(&mut self.twin, 3 * t1, cp);
        link(&mut self.twin, 3 * t1 + 1, pd);
        link(&mut self.twin, 3 * t1 + 2, 3 * t2 + 2);
        link(&mut self.twin, 3 * t2, dq);
        link(&mut self.twin, 3 * t2 + 1, qc);
        for v in [p, q] {
            self.degree[v as usize] -= 1;
        }
        for v in [c, d] {
            self.degree[v as usize] += 1;
        }
        Some([3 * t1, 3 * t1 + 1, 3 * t2, 3 * t2 + 1])
    }
}

impl Flips {
    /// Never flip an edge whose two ends are flagged in `keep` (a crease
    /// of [`super::crease`]).
    pub fn keep_edges_between(&mut self, keep: &[bool]) {
        self.keep = keep.to_vec();
    }

    /// Never join two vertices flagged in `apart` by a flip (a brick's
    /// seam vertices: another brick may join them).
    pub fn keep_apart(&mut self, apart: &[bool]) {
        self.apart = apart.to_vec();
    }

    /// The aspect ratio of every triangle as the last [`Flips::run`] left
    /// the mesh.
    pub fn aspects(&self) -> &[f64] {
        &self.aspect
    }

    /// Per vertex, whether it lies on an edge that is not an interior
    /// manifold edge (boundary, non-manifold or misoriented). Flips never
    /// change that set.
    pub fn pinned(&self, mesh: &Mesh) -> Vec<bool> {
        let mut pinned = vec![false; mesh.positions.len()];
        for (h, &g) in self.twin.iter().enumerate() {
            if g == NONE {
                let t = mesh.triangles[h / 3];
                pinned[t[h % 3] as usize] = true;
                pinned[t[(h % 3 + 1) % 3] as usize] = true;
            }
        }
        pinned
    }

    /// Per vertex, whether it lies on a ridge line: at least two of its
    /// edges are ridges, interior manifold edges whose two triangles' unit
    /// normals have a dot product below `cos` (a single ridge edge is a
    /// kink in a crumpled fan, not a line).
    pub fn on_ridge_lines(&self, mesh: &Mesh, cos: f64) -> Vec<bool> {
        let n = |h: usize| mesh.face_normal(mesh.triangles[h / 3]).normalize_or_zero();
        let mut ridges = vec![0u8; mesh.positions.len()];
        for (h, &g) in self.twin.iter().enumerate() {
            if g != NONE && h < g as usize && n(h).dot(n(g as usize)) < cos {
                let t = mesh.triangles[h / 3];
                for v in [t[h % 3], t[(h % 3 + 1) % 3]] {
                    ridges[v as usize] = ridges[v as usize].saturating_add(1);
                }
            }
        }
        ridges.into_iter().map(|r| r >= 2).collect()
    }

    /// Runs flip sweeps on `mesh` (whose connectivity must be the one
    /// [`Flips::new`] saw, as left by earlier runs) until none is accepted
    /// (or [`MAX_SWEEPS`]); returns how many flips were made. See the
    /// module doc.
    pub fn run(&mut self, mesh: &mut Mesh) -> usize {
        self.run_where(mesh, &|_, _, _| true)
    }

    /// [`Flips::run`], making only the flips whose new edge `c–d` `allow`
    /// accepts (asked last, after every other test holds).
    pub fn run_where(&mut self, mesh: &mut Mesh, allow: &dyn Fn(&Mesh, u32, u32) -> bool) -> usize {
        self.aspect = mesh
            .triangles
            .par_iter()
            .map(|&t| aspect_ratio(mesh, t))
            .collect();
        // One half-edge per interior edge whose flip would raise the
        // pair's worst aspect ratio (a read-only test, in parallel;
        // `try_flip` tests it again, and the rest, against the current
        // mesh).
        let mut work: Vec<u32> = {
            let (m, twin, aspect) = (&*mesh, &self.twin, &self.aspect);
            (0..twin.len() as u32)
                .into_par_iter()
                .filter(|&h| {
                    let g = twin[h as usize];
                    if g == NONE || g < h {
                        return false;
                    }
                    let (a, b) = (m.triangles[h as usize / 3], m.triangles[g as usize / 3]);
                    let i = h as usize % 3;
                    let (p, q, c) = (a[i], a[(i + 1) % 3], a[(i + 2) % 3]);
                    let d = b[(g as usize % 3 + 2) % 3];
                    let worst = aspect_ratio(m, [c, p, d]).min(aspect_ratio(m, [d, q, c]));
                    worst > aspect[h as usize / 3].min(aspect[g as usize / 3]) + MARGIN
                })
                .collect()
        };
        let mut flips = 0;
        for _ in 0..MAX_SWEEPS {
            if work.is_empty() {
                break;
            }
            let mut next = Vec::new();
            for h in std::mem::take(&mut work) {
                if let Some(sides) = self.try_flip(mesh, h, allow) {
                    flips += 1;
                    next.extend(sides);
                }
            }
            next.sort_unstable();
            next.dedup();
            work = next;
        }
        flips
    }
}

/// [`Flips::run`] once on a fresh adjacency.
pub fn flip(mesh: &mut Mesh) -> usize {
    Flips::new(mesh).run(mesh)
}
