//! The refinement passes of the module doc on triangles that carry their
//! neighbours (half-edge twins), so that marks, midpoints and the
//! subdivided mesh's neighbours are array lookups.
//!
//! Half-edge `3i + k` runs from corner `k` of triangle `i` to corner
//! `k + 1`. An edge not shared by exactly two oppositely oriented triangles
//! (never the case on a closed oriented manifold) is never split. An edge
//! [`SHARED`] with a triangle refined elsewhere (reused from the last
//! frame) is split exactly where that triangle was: at the midpoints it
//! already has, found by name.

use glam::DVec3;
use rayon::prelude::*;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use crate::eval::Evaluator;
use crate::eval::sample::grads_at;
use crate::mesh::Mesh;
use crate::roots::walk::{OnSurface, newton};

/// What a refinement did ([`super::refine`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RefineStats {
    /// Passes that split at least one edge.
    pub passes: usize,
    /// Edges split (midpoints inserted), over all passes.
    pub splits: usize,
    /// Refinement stopped at the triangle budget rather than for lack of
    /// marked edges or passes.
    pub budget_hit: bool,
}

/// The geometric mesh never exceeds this many times the mechanical mesh's
/// triangles.
pub const TRIANGLE_BUDGET: usize = 64;

/// Most triangles of `mech`'s geometric mesh.
pub(super) fn budget(mech: &Mesh) -> usize {
    mech.triangles.len().saturating_mul(TRIANGLE_BUDGET)
}

/// A twin on the mesh's boundary (split like any other edge).
pub(super) const BOUNDARY: u32 = u32::MAX;
/// A twin of an edge not shared by exactly two oppositely oriented
/// triangles: never split.
const FROZEN: u32 = u32::MAX - 1;
/// A twin in a triangle refined elsewhere: split where it is.
const SHARED: u32 = u32::MAX - 2;
/// No midpoint.
const NONE: u32 = u32::MAX;

/// Whether a twin entry is a half-edge (not a marker).
fn is_half_edge(x: u32) -> bool {
    x < SHARED
}

/// A vertex's or a mechanical triangle's name across frames: a hash of
/// how it was made ([`name`]).
pub(super) type Name = u64;

/// Tags of [`name`]: a mechanical vertex (by its slot), a midpoint (by its
/// edge's ends), a mechanical triangle (by its corners).
pub(super) const VERTEX: u64 = 1;
pub(super) const MIDPOINT: u64 = 2;
pub(super) const TRIANGLE: u64 = 3;

/// Mixes two names (in either order) under `tag`.
pub(super) fn name(tag: u64, a: Name, b: Name) -> Name {
    let (lo, hi) = (a.min(b), a.max(b));
    let h = (lo ^ tag)
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .rotate_left(31)
        ^ hi;
    let h = (h ^ (h >> 29)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    let h = (h ^ (h >> 32)).wrapping_mul(0x94d0_49bb_1331_11eb);
    h ^ (h >> 29)
}

/// What bounds a refinement: `cos α_r`, `N_p`, and the most triangles.
#[derive(Clone, Copy, Debug)]
pub(super) struct Limits {
    pub cos_a: f64,
    pub passes: usize,
    pub budget: usize,
}

/// The triangles being refined, with their neighbours.
pub(super) struct Tris {
    pub v: Vec<[u32; 3]>,
    /// Per half-edge, the opposite half-edge or a marker.
    twin: Vec<u32>,
    /// Per triangle, ∇f/‖∇f‖ at its centroid; NaN until computed (a
    /// triangle that a pass leaves whole keeps its normal).
    normal: Vec<DVec3>,
    /// Per half-edge, this pass's midpoint vertex, or [`NONE`].
    mid: Vec<u32>,
    /// Per triangle, the input triangle it refines.
    pub origin: Vec<u32>,
    /// Tracking only (else empty): per vertex of the mesh, its name and
    /// its parents' (a midpoint's edge ends; a mechanical vertex's are 0).
    pub names: Vec<Name>,
    pub parents: Vec<(Name, Name)>,
}

impl Tris {
    /// `v` with its neighbours; an edge without one whose reverse is in
    /// `shared` is [`SHARED`].
    pub fn new(v: Vec<[u32; 3]>, shared: Option<&HashSet<(u32, u32)>>) -> Tris {
        let directed = |h: usize| {
            let t = v[h / 3];
            (t[h % 3], t[(h % 3 + 1) % 3])
        };
        let n = 3 * v.len();
        let mut first: HashMap<(u32, u32), u32> =
            HashMap::with_capacity_and_hasher(n, Default::default());
        for h in 0..n {
            first
                .entry(directed(h))
                .and_modify(|x| *x = FROZEN)
                .or_insert(h as u32);
        }
        let twin = (0..n)
            .map(|h| {
                let (a, b) = directed(h);
                if a == b || first[&(a, b)] == FROZEN {
                    return FROZEN;
                }
                match first.get(&(b, a)) {
                    Some(&o) => o,
                    None if shared.is_some_and(|s| s.contains(&(b, a))) => SHARED,
                    None => BOUNDARY,
                }
            })
            .collect();
        Tris {
            normal: vec![DVec3::NAN; v.len()],
            mid: vec![NONE; n],
            origin: (0..v.len() as u32).collect(),
            v,
            twin,
            names: Vec::new(),
            parents: Vec::new(),
        }
    }

    /// Up to `limits.passes` passes of the module doc on `mesh`, stopping
    /// before the triangles could pass `limits.budget`; midpoints of
    /// [`SHARED`] edges are looked up by name in `known`. Also returns
    /// whether a shared edge's split had to be kept although it inverts a
    /// triangle here, or could not be made (then the result does not match
    /// its neighbour).
    pub fn refine<E: Evaluator + ?Sized>(
        &mut self,
        mesh: &mut Mesh,
        f: &E,
        t: f64,
        limits: Limits,
        known: Option<&HashMap<Name, u32>>,
    ) -> (RefineStats, bool) {
        let Limits {
            cos_a,
            passes,
            budget,
        } = limits;
        let mut stats = RefineStats::default();
        for _ in 0..passes {
            self.centroid_normals(mesh, f, t);
            let marked = self.mark(&mesh.normals, cos_a, known);
            // A pass adds at most 3 triangles per marked edge; stop before
            // the budget could be exceeded (a crease marks edges on every
            // pass).
            if marked.is_empty() || self.v.len() + 3 * marked.len() > budget {
                stats.budget_hit = !marked.is_empty();
                let pending = marked.iter().any(|&h| self.twin[h as usize] == SHARED);
                return (stats, pending);
            }
            let mids: Vec<Option<OnSurface>> = marked
                .par_iter()
                .map(|&h| {
                    if self.twin[h as usize] == SHARED {
                        return None;
                    }
                    let (a, b) = self.ends(h as usize);
                    let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
                    let (na, nb) = (mesh.normals[a as usize], mesh.normals[b as usize]);
                    let len = pa.distance(pb);
                    newton(f, t, arc_midpoint(pa, pb, na, nb), len, 0.5 * len)
                })
                .collect();
            let (new, shared, conflict) = self.place(mesh, &marked, mids, known);
            if conflict {
                return (stats, true);
            }
            if new + shared == 0 {
                break;
            }
            self.subdivide(mesh);
            stats.splits += new;
            stats.passes += 1;
        }
        (stats, false)
    }

    /// The end vertices of half-edge `h`.
    pub fn ends(&self, h: usize) -> (u32, u32) {
        let t = self.v[h / 3];
        (t[h % 3], t[(h % 3 + 1) % 3])
    }

    /// The name of the midpoint of half-edge `h` (tracking only).
    fn mid_name(&self, h: usize) -> Name {
        let (a, b) = self.ends(h);
        name(MIDPOINT, self.names[a as usize], self.names[b as usize])
    }

    /// The midpoints of triangle `i`'s edges (this pass).
    fn mids_of(&self, i: usize) -> [Option<u32>; 3] {
        std::array::from_fn(|k| Some(self.mid[3 * i + k]).filter(|&m| m != NONE))
    }

    /// Sets the midpoint of half-edge `h` and of its twin.
    fn set_mid(&mut self, h: usize, m: u32) {
        self.mid[h] = m;
        let tw = self.twin[h];
        if is_half_edge(tw) {
            self.mid[tw as usize] = m;
        }
    }

    /// Fills in the missing centroid normals (one batch).
    fn centroid_normals<E: Evaluator + ?Sized>(&mut self, mesh: &Mesh, f: &E, t: f64) {
        let todo: Vec<usize> = (0..self.v.len())
            .filter(|&i| self.normal[i].is_nan())
            .collect();
        let centroids: Vec<DVec3> = todo
            .iter()
            .map(|&i| {
                self.v[i]
                    .iter()
                    .map(|&v| mesh.positions[v as usize])
                    .sum::<DVec3>()
                    / 3.0
            })
            .collect();
        for (&i, (_, g)) in todo.iter().zip(grads_at(f, t, &centroids)) {
            let g = g.normalize_or_zero();
            self.normal[i] = if g.is_finite() && g != DVec3::ZERO {
                g
            } else {
                mesh.face_normal(self.v[i]).normalize_or_zero()
            };
        }
    }

    /// The edges to refine in this pass, each as one of its half-edges
    /// (ascending).
    fn mark(&self, n: &[DVec3], cos_a: f64, known: Option<&HashMap<Name, u32>>) -> Vec<u32> {
        let mut m = vec![false; self.twin.len()];
        for h in 0..self.twin.len() {
            let tw = self.twin[h];
            if tw == FROZEN || (is_half_edge(tw) && (tw as usize) < h) {
                continue;
            }
            if tw == SHARED {
                m[h] = known.is_some_and(|k| k.contains_key(&self.mid_name(h)));
                continue;
            }
            let (a, b) = self.ends(h);
            if n[a as usize].dot(n[b as usize]) < cos_a {
                m[h] = true;
            }
            if is_half_edge(tw) && self.normal[h / 3].dot(self.normal[tw as usize / 3]) < cos_a {
                for g in [h, tw as usize] {
                    let base = g - g % 3;
                    for o in (base..base + 3).filter(|&o| o != g && self.twin[o] != SHARED) {
                        m[o] = true;
                    }
                }
            }
        }
        (0..m.len())
            .filter(|&h| match self.twin[h] {
                FROZEN => false,
                BOUNDARY | SHARED => m[h],
                tw => h < tw as usize && (m[h] || m[tw as usize]),
            })
            .map(|h| h as u32)
            .collect()
    }

    /// Adds the projected midpoints of the `marked` edges to `mesh` (a
    /// failed projection leaves its edge whole; a shared edge takes the
    /// midpoint it has in `known`). An edge whose split would leave an
    /// inverted triangle (the midpoint projected past a neighbour on a
    /// tight bend) is left whole, and the triangles beside it are checked
    /// again. Returns the new midpoints and the shared ones kept, and
    /// whether a shared one inverts a triangle.
    fn place(
        &mut self,
        mesh: &mut Mesh,
        marked: &[u32],
        mids: Vec<Option<OnSurface>>,
        known: Option<&HashMap<Name, u32>>,
    ) -> (usize, usize, bool) {
        self.mid.clear();
        self.mid.resize(self.twin.len(), NONE);
        let first = mesh.positions.len();
        let mut shared = 0;
        for (&h, s) in marked.iter().zip(mids) {
            let h = h as usize;
            if self.twin[h] == SHARED {
                if let Some(&m) = known.and_then(|k| k.get(&self.mid_name(h))) {
                    self.set_mid(h, m);
                    shared += 1;
                }
                continue;
            }
            let Some(s) = s else { continue };
            if !self.names.is_empty() {
                let (a, b) = self.ends(h);
                let parents = (self.names[a as usize], self.names[b as usize]);
                self.names.push(self.mid_name(h));
                self.parents.push(parents);
            }
            self.set_mid(h, mesh.positions.len() as u32);
            mesh.positions.push(s.pos);
            mesh.normals.push(s.grad.normalize_or_zero());
            mesh.ambiguous.push(false);
        }
        let mut todo: Vec<usize> = (0..self.v.len())
            .filter(|&i| self.mid[3 * i..3 * i + 3].iter().any(|&m| m != NONE))
            .collect();
        let mut kids = Vec::with_capacity(4);
        let mut conflict = false;
        while let Some(i) = todo.pop() {
            kids.clear();
            split(mesh, self.v[i], self.mids_of(i), &mut kids);
            if kids.len() > 1 && kids.iter().any(|&c| inverted(mesh, c)) {
                for h in 3 * i..3 * i + 3 {
                    let tw = self.twin[h];
                    if self.mid[h] == NONE {
                        continue;
                    }
                    if tw == SHARED {
                        conflict = true;
                        continue;
                    }
                    self.set_mid(h, NONE);
                    if is_half_edge(tw) {
                        todo.push(tw as usize / 3);
                    }
                }
            }
        }
        (self.drop_unused(mesh, first), shared, conflict)
    }

    /// Drops the midpoints from `first` on that no edge kept, renumbering
    /// the rest; returns how many stay.
    fn drop_unused(&mut self, mesh: &mut Mesh, first: usize) -> usize {
        let mut remap = vec![NONE; mesh.positions.len() - first];
        for &m in &self.mid {
            if m != NONE && m as usize >= first {
                remap[m as usize - first] = 0;
            }
        }
        let mut w = first;
        for (r, slot) in remap.iter_mut().enumerate() {
            if *slot == NONE {
                continue;
            }
            let from = first + r;
            mesh.positions[w] = mesh.positions[from];
            mesh.normals[w] = mesh.normals[from];
            mesh.ambiguous[w] = mesh.ambiguous[from];
            if !self.names.is_empty() {
                self.names[w] = self.names[from];
                self.parents[w] = self.parents[from];
            }
            *slot = w as u32;
            w += 1;
        }
        mesh.positions.truncate(w);
        mesh.normals.truncate(w);
        mesh.ambiguous.truncate(w);
        if !self.names.is_empty() {
            self.names.truncate(w);
            self.parents.truncate(w);
        }
        for m in self.mid.iter_mut() {
            if *m != NONE && *m as usize >= first {
                *m = remap[*m as usize - first];
            }
        }
        w - first
    }

    /// Replaces every triangle by its split (Fig. 7a) with this pass's
    /// midpoints, and links the new triangles to their neighbours.
    fn subdivide(&mut self, mesh: &Mesh) {
        let n = self.v.len();
        let mut v = Vec::with_capacity(2 * n);
        let mut normal = Vec::with_capacity(2 * n);
        let mut origin = Vec::with_capacity(2 * n);
        // Per old triangle, its first child; per old half-edge, the child
        // half-edges on its first and second halves (the first alone when
        // it is whole).
        let mut start = Vec::with_capacity(n + 1);
        let mut halves = vec![[NONE; 2]; 3 * n];
        for i in 0..n {
            let base = v.len();
            start.push(base as u32);
            let (t, ms) = (self.v[i], self.mids_of(i));
            if ms == [None; 3] {
                v.push(t);
                normal.push(self.normal[i]);
                origin.push(self.origin[i]);
                for k in 0..3 {
                    halves[3 * i + k][0] = (3 * base + k) as u32;
                }
                continue;
            }
            split(mesh, t, ms, &mut v);
            normal.resize(v.len(), DVec3::NAN);
            origin.resize(v.len(), self.origin[i]);
            // The old triangle's boundary as a cycle of corners and
            // midpoints: a child's edge between neighbours in it lies on an
            // old edge.
            let mut cycle = [(NONE, 0, 0); 6];
            let mut len = 0;
            for k in 0..3 {
                cycle[len] = (t[k], k, 0);
                len += 1;
                if let Some(m) = ms[k] {
                    cycle[len] = (m, k, 1);
                    len += 1;
                }
            }
            let at = |x: u32| cycle[..len].iter().position(|c| c.0 == x);
            for (c, kid) in v.iter().enumerate().skip(base) {
                for j in 0..3 {
                    let (a, b) = (kid[j], kid[(j + 1) % 3]);
                    if let (Some(pa), Some(pb)) = (at(a), at(b))
                        && pb == (pa + 1) % len
                    {
                        let (_, k, side) = cycle[pa];
                        halves[3 * i + k][side] = (3 * c + j) as u32;
                    }
                }
            }
        }
        start.push(v.len() as u32);
        let mut twin = vec![NONE; 3 * v.len()];
        for h in 0..3 * n {
            let split = self.mid[h] != NONE;
            for (side, &ch) in halves[h].iter().enumerate() {
                if ch == NONE {
                    continue;
                }
                let tw = self.twin[h];
                twin[ch as usize] = if !is_half_edge(tw) {
                    tw
                } else if split {
                    halves[tw as usize][1 - side]
                } else {
                    halves[tw as usize][0]
                };
            }
        }
        // Edges inside an old triangle join two of its children.
        for i in 0..n {
            let kids = start[i] as usize..start[i + 1] as usize;
            for c in kids.clone() {
                for j in 0..3 {
                    if twin[3 * c + j] != NONE {
                        continue;
                    }
                    let (a, b) = (v[c][j], v[c][(j + 1) % 3]);
                    twin[3 * c + j] = kids
                        .clone()
                        .flat_map(|d| (0..3).map(move |l| (d, l)))
                        .find(|&(d, l)| v[d][l] == b && v[d][(l + 1) % 3] == a)
                        .map_or(FROZEN, |(d, l)| (3 * d + l) as u32);
                }
            }
        }
        self.v = v;
        self.twin = twin;
        self.normal = normal;
        self.origin = origin;
        self.mid.clear();
        self.mid.resize(self.twin.len(), NONE);
    }
}

/// Where the walk onto the surface starts for the midpoint of the edge
/// `pa`–`pb` with unit normals `na`, `nb`: the chord's midpoint moved along
/// the mean normal by the bulge of the arc the normals describe,
/// `−(pb − pa)·(na − nb)/8` (on a sphere of radius R, the sagitta
/// `‖pb − pa‖²/8R` to fourth order), at most a quarter of the edge.
pub(super) fn arc_midpoint(pa: DVec3, pb: DVec3, na: DVec3, nb: DVec3) -> DVec3 {
    let reach = 0.25 * pa.distance(pb);
    let bulge = (-(pb - pa).dot(na - nb) / 8.0).clamp(-reach, reach);
    let n = (na + nb).normalize_or_zero();
    (pa + pb) * 0.5 + n * if bulge.is_finite() { bulge } else { 0.0 }
}

/// `true` when `t` faces against the normals at all three corners (the
/// inversion test of [`crate::twin::fem::inverted`]).
pub(super) fn inverted(mesh: &Mesh, t: [u32; 3]) -> bool {
    let n = mesh.face_normal(t);
    t.iter().all(|&v| n.dot(mesh.normals[v as usize]) < 0.0)
}

/// Triangle `t` split by the midpoints `ms` of its edges (Fig. 7a).
fn split(mesh: &Mesh, t: [u32; 3], ms: [Option<u32>; 3], out: &mut Vec<[u32; 3]>) {
    match ms {
        [None, None, None] => out.push(t),
        [Some(m1), Some(m2), Some(m3)] => {
            let [a, b, c] = t;
            out.push([a, m1, m3]);
            out.push([m1, b, m2]);
            out.push([m3, m2, c]);
            out.push([m1, m2, m3]);
        }
        _ if ms.iter().flatten().count() == 1 => {
            let k = (0..3).find(|&k| ms[k].is_some()).unwrap_or(0);
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let mid = ms[k].unwrap_or(a);
            out.push([a, mid, c]);
            out.push([mid, b, c]);
        }
        _ => {
            // Two: rotate so that the unmarked edge is b–c, with marked
            // a–b (m1) and c–a (m2).
            let k = (0..3).find(|&k| ms[(k + 1) % 3].is_none()).unwrap_or(0);
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let (Some(m1), Some(m2)) = (ms[k], ms[(k + 2) % 3]) else {
                out.push(t);
                return;
            };
            out.push([a, m1, m2]);
            let nrm = |v: u32| mesh.normals[v as usize];
            if nrm(m1).dot(nrm(c)) >= nrm(b).dot(nrm(m2)) {
                out.push([m1, b, c]);
                out.push([m1, c, m2]);
            } else {
                out.push([m1, b, m2]);
                out.push([b, c, m2]);
            }
        }
    }
}
