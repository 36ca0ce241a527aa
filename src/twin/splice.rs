//! Local re-initialisation (beyond the paper, whose §5 leaves topology
//! changes open): the part of the mechanical mesh inside a ball is
//! replaced by a robust mesh of the ball, and the two are joined by a
//! strip of triangles.
//!
//! # Contract
//!
//! [`splice`] takes a closed mesh (the mechanical mesh), a *patch* (the
//! robust mesh of the same surface over the cube the ball `B` is inscribed
//! in) and `B`. With depth measured from `B`'s sphere inwards:
//!
//! - the mesh loses every triangle with a corner, an edge midpoint or its
//!   centroid deeper than [`MESH_DEPTH`]`·ê`, leaving holes whose rims
//!   lie about the sphere;
//! - the patch keeps only the triangles whose three vertices are deeper
//!   than [`PATCH_DEPTH`]`·ê` (so the mesher's cells at the cube's faces,
//!   where it cuts the surface off, are gone), leaving rims further in;
//! - each hole rim is paired with the patch rim nearest it (a one-to-one
//!   pairing, else the splice is refused) and the annulus between them is
//!   triangulated by walking both rims together by arc length (a
//!   "zipper").
//!
//! A sphere, not a box, cuts both meshes so that the rims are smooth
//! curves (a box's edges put corners in them, where a zipper folds).
//! The result is returned only if it is a closed, consistently oriented
//! 2-manifold and every joining triangle faces the way its corners'
//! normals do; otherwise [`Refused`] says why, and the caller falls back to
//! a whole re-initialisation. The splice knows nothing of topology: what
//! the patch holds inside `B` (a merged neck, a split, a new component)
//! is what the result holds.
//!
//! # Limits
//!
//! The rims must be simple closed curves in one-to-one correspondence: a
//! surface that runs nearly tangent to the sphere, or whose rims on both
//! sides differ in number (the mesh and the patch disagree about the
//! surface near the sphere), is refused. The joining strip's triangles are
//! as long as the gap between the rims (up to a few ê): the tracker's
//! remeshing evens them out in the frames that follow.

use glam::DVec3;
use rustc_hash::FxHashMap as HashMap;

use crate::geometry::Bounds;
use crate::mesh::Mesh;
use crate::mesh::topology::{self, Topology};

/// Mesh triangles with a corner, an edge midpoint or the centroid deeper
/// than this (in ê) inside the ball are removed.
pub(crate) const MESH_DEPTH: f64 = 1.0;

/// Patch triangles are kept when all three vertices are deeper than this
/// (in ê).
pub(crate) const PATCH_DEPTH: f64 = 1.5;

/// The least cosine between a joining triangle's normal and its corners'
/// mean normal: a little past perpendicular is accepted (the tracker
/// repairs inverted triangles, §2.6), a fold is not.
const MIN_FACING: f64 = -0.25;

/// Rims further apart than this (mean distance, in ê) are not joined.
const MAX_GAP: f64 = 6.0;

/// Most rim vertices of either side (the pairing is quadratic in them).
const MAX_RIM: usize = 20_000;

/// Why a splice was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Refused {
    /// A rim vertex where two rims touch (the cut is not a set of simple
    /// curves).
    PinchedRim,
    /// The mesh and the patch have different numbers of rims, or two rims
    /// of one side are nearest the same rim of the other.
    RimsDisagree,
    /// Paired rims are further apart than `MAX_GAP`·ê.
    RimsApart,
    /// More rim vertices than the pairing handles.
    TooLong,
    /// The joined mesh is not a closed oriented 2-manifold, or a joining
    /// triangle faces against its corners' normals.
    BadJoin,
}

/// A ball, the region a splice replaces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Ball {
    pub centre: DVec3,
    pub radius: f64,
}

impl Ball {
    /// How deep `p` lies inside (negative outside).
    fn depth(&self, p: DVec3) -> f64 {
        self.radius - p.distance(self.centre)
    }

    /// Whether a splice with edge length `edge` cuts out every triangle at
    /// `p`.
    pub fn cut(&self, p: DVec3, edge: f64) -> bool {
        self.depth(p) > MESH_DEPTH * edge
    }

    /// The cube the ball is inscribed in.
    pub fn cube(&self) -> Bounds {
        Bounds {
            lo: (self.centre - DVec3::splat(self.radius)).to_array(),
            hi: (self.centre + DVec3::splat(self.radius)).to_array(),
        }
    }
}

/// See the module doc. `mesh` and `patch` carry unit normals; the patch
/// must cover the ball; the result holds the kept vertices of `mesh`, then
/// those of `patch`, and comes with its topology.
pub(crate) fn splice(
    mesh: &Mesh,
    patch: &Mesh,
    region: &Ball,
    edge: f64,
) -> Result<(Mesh, Topology), Refused> {
    let deep = |p: DVec3, d: f64| region.depth(p) > d * edge;
    let mut out = Mesh::default();
    append(&mut out, mesh, |t| {
        let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
        // Corners, edge midpoints and centroid: a long triangle (a
        // stretched neck) can cross the ball with its corners outside.
        let samples = [
            a,
            b,
            c,
            (a + b) / 2.0,
            (b + c) / 2.0,
            (c + a) / 2.0,
            (a + b + c) / 3.0,
        ];
        samples.iter().all(|&p| !region.cut(p, edge))
    });
    let first_patch = out.positions.len() as u32;
    append(&mut out, patch, |t| {
        t.iter()
            .all(|&v| deep(patch.positions[v as usize], PATCH_DEPTH))
    });
    trim_ears(&mut out.triangles);
    let joined = out.triangles.len();
    let rims = rims(&out.triangles)?;
    let (outer, inner): (Vec<Vec<u32>>, Vec<Vec<u32>>) =
        rims.into_iter().partition(|r| r[0] < first_patch);
    if outer.iter().chain(&inner).map(Vec::len).sum::<usize>() > MAX_RIM {
        return Err(Refused::TooLong);
    }
    let pairs = pair(&out.positions, &outer, &inner, edge)?;
    for (hole, rim) in outer.iter().zip(pairs) {
        if !zip(
            &out.positions,
            &out.normals,
            hole,
            &inner[rim],
            &mut out.triangles,
        ) {
            return Err(Refused::TooLong);
        }
    }
    unfold(&out.positions, &out.normals, &mut out.triangles, joined);
    let topo = check(&out, joined)?;
    Ok((out, topo))
}

/// Appends the triangles of `m` that `keep` accepts, with the vertices
/// they use.
fn append(out: &mut Mesh, m: &Mesh, keep: impl Fn(&[u32; 3]) -> bool) {
    let mut remap = vec![u32::MAX; m.positions.len()];
    for t in m.triangles.iter().filter(|t| keep(t)) {
        let nt = t.map(|v| {
            let v = v as usize;
            if remap[v] == u32::MAX {
                remap[v] = out.positions.len() as u32;
                out.positions.push(m.positions[v]);
                out.normals.push(m.normals[v]);
                out.ambiguous.push(false);
            }
            remap[v]
        });
        out.triangles.push(nt);
    }
}

/// Removes, a few rounds over, the triangles with two or three edges on a
/// rim: a cut through a mesh leaves such spikes, around which a rim turns
/// back on itself and no strip can join it without a fold. (The vertices
/// they alone used stay in the vertex list, unused.)
fn trim_ears(tris: &mut Vec<[u32; 3]>) {
    for _ in 0..REPAIR_ROUNDS {
        let directed: rustc_hash::FxHashSet<(u32, u32)> = tris
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .collect();
        let on_rim = |t: &[u32; 3]| {
            (0..3)
                .filter(|&k| !directed.contains(&(t[(k + 1) % 3], t[k])))
                .count()
        };
        let before = tris.len();
        tris.retain(|t| on_rim(t) < 2);
        if tris.len() == before {
            break;
        }
    }
}

/// Most rounds of [`trim_ears`] and of [`unfold`].
const REPAIR_ROUNDS: usize = 3;

/// The rims of a mesh whose triangles are consistently oriented: each a
/// cycle of vertices along directed edges `a → b` used by one triangle
/// whose reverse no triangle uses.
fn rims(tris: &[[u32; 3]]) -> Result<Vec<Vec<u32>>, Refused> {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::default();
    for t in tris {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    let mut next: HashMap<u32, u32> = HashMap::default();
    for (&(a, b), &n) in &directed {
        if n == 1 && !directed.contains_key(&(b, a)) && next.insert(a, b).is_some() {
            return Err(Refused::PinchedRim);
        }
    }
    let mut starts: Vec<u32> = next.keys().copied().collect();
    starts.sort_unstable();
    let mut seen: HashMap<u32, ()> = HashMap::default();
    let mut out = Vec::new();
    for s in starts {
        if seen.contains_key(&s) {
            continue;
        }
        let mut rim = vec![s];
        seen.insert(s, ());
        let mut v = next[&s];
        while v != s {
            if seen.insert(v, ()).is_some() {
                return Err(Refused::PinchedRim);
            }
            rim.push(v);
            v = *next.get(&v).ok_or(Refused::PinchedRim)?;
        }
        out.push(rim);
    }
    Ok(out)
}

/// Mean distance from the vertices of `a` to the nearest vertex of `b`.
fn gap(p: &[DVec3], a: &[u32], b: &[u32]) -> f64 {
    let near = |v: u32| {
        b.iter()
            .map(|&w| p[v as usize].distance_squared(p[w as usize]))
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    };
    a.iter().map(|&v| near(v)).sum::<f64>() / a.len() as f64
}

/// Pairs each hole rim with the nearest patch rim, one to one: for each
/// hole in turn, the index of its rim.
fn pair(
    p: &[DVec3],
    holes: &[Vec<u32>],
    rims: &[Vec<u32>],
    edge: f64,
) -> Result<Vec<usize>, Refused> {
    if holes.len() != rims.len() {
        return Err(Refused::RimsDisagree);
    }
    let mut taken = vec![false; rims.len()];
    let mut out = Vec::with_capacity(holes.len());
    for hole in holes {
        let (best, d) = rims
            .iter()
            .enumerate()
            .map(|(i, r)| (i, gap(p, hole, r)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .ok_or(Refused::RimsDisagree)?;
        if taken[best] {
            return Err(Refused::RimsDisagree);
        }
        if d > MAX_GAP * edge {
            return Err(Refused::RimsApart);
        }
        taken[best] = true;
        out.push(best);
    }
    Ok(out)
}

/// Triangulates the annulus between a hole rim and a patch rim. The hole's
/// rim runs against the patch's (they bound the surface from opposite
/// sides), so the hole is walked backwards; both start at the patch vertex
/// nearest the hole's first. Each triangle of the strip advances one rim
/// by one vertex; of all such strips the one of least cost is chosen by
/// dynamic programming over the pairs of rim positions (Fuchs, Kedem &
/// Uselton 1977), where a triangle costs its cross edge's length plus a
/// heavy penalty when it faces against its corners' normals. The pairs
/// searched are those whose arc-length fractions differ by at most
/// [`BAND`] (so rims of very different vertex counts stay in step). The
/// table holds every pair of rim positions, so time and memory are the
/// product of the rims' lengths: returns `false` (and adds nothing) when
/// it passes [`MAX_PAIRS`].
/// The triangles use every rim edge reversed, as the closed result needs.
fn zip(
    p: &[DVec3],
    normals: &[DVec3],
    hole: &[u32],
    rim: &[u32],
    tris: &mut Vec<[u32; 3]>,
) -> bool {
    let a: Vec<u32> = hole.iter().rev().copied().collect();
    let at = |v: u32| p[v as usize];
    let j0 = (0..rim.len())
        .min_by(|&i, &j| {
            let d = |k: usize| at(a[0]).distance_squared(at(rim[k]));
            d(i).total_cmp(&d(j))
        })
        .unwrap_or(0);
    let b: Vec<u32> = rim[j0..].iter().chain(&rim[..j0]).copied().collect();
    let (sa, sb) = (arc_fractions(p, &a), arc_fractions(p, &b));
    let (m, n) = (a.len(), b.len());
    if (m + 1) * (n + 1) > MAX_PAIRS {
        return false;
    }
    let scale = sa.len().max(1) as f64;
    let cost = |t: [u32; 3], cross: (u32, u32)| {
        let len = at(cross.0).distance(at(cross.1));
        let facing = facing(p, normals, t);
        len + if facing > 0.0 {
            0.0
        } else {
            1e3 * scale * (1.0 - facing) * len.max(1e-300)
        }
    };
    // best[(i, j)]: least cost of a strip from (0, 0) to (i, j); step: how
    // it was reached (true: along the hole).
    let width = n + 1;
    let mut best = vec![f64::INFINITY; (m + 1) * width];
    let mut along_hole = vec![false; (m + 1) * width];
    best[0] = 0.0;
    let in_band = |i: usize, j: usize| (sa[i] - sb[j]).abs() <= BAND || (i == m && j == n);
    for i in 0..=m {
        for j in 0..=n {
            let here = best[i * width + j];
            if !here.is_finite() {
                continue;
            }
            if i < m && in_band(i + 1, j) {
                let t = [a[i], a[(i + 1) % m], b[j % n]];
                let c = here + cost(t, (a[(i + 1) % m], b[j % n]));
                let k = (i + 1) * width + j;
                if c < best[k] {
                    best[k] = c;
                    along_hole[k] = true;
                }
            }
            if j < n && in_band(i, j + 1) {
                let t = [b[(j + 1) % n], b[j], a[i % m]];
                let c = here + cost(t, (b[(j + 1) % n], a[i % m]));
                let k = i * width + j + 1;
                if c < best[k] {
                    best[k] = c;
                    along_hole[k] = false;
                }
            }
        }
    }
    if !best[m * width + n].is_finite() {
        return false;
    }
    let mut strip = Vec::with_capacity(m + n);
    let (mut i, mut j) = (m, n);
    while i > 0 || j > 0 {
        if along_hole[i * width + j] {
            i -= 1;
            strip.push([a[i], a[(i + 1) % m], b[j % n]]);
        } else {
            j -= 1;
            strip.push([b[(j + 1) % n], b[j], a[i % m]]);
        }
    }
    tris.extend(strip.into_iter().rev());
    true
}

/// How a triangle faces: the cosine between its normal and its corners'
/// mean normal (0 for a degenerate one).
fn facing(p: &[DVec3], normals: &[DVec3], t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|v| p[v as usize]);
    let n = (b - a).cross(c - a).normalize_or_zero();
    let corners: DVec3 = t.iter().map(|&v| normals[v as usize]).sum();
    n.dot(corners.normalize_or_zero())
}

/// Flips, a few rounds over, the edges between two joining triangles (from
/// index `joined` on) when one of them faces against its corners' normals
/// (below [`MIN_FACING`]) and both flipped triangles face along them and
/// the new edge is not one the mesh has: what the strip's one-rim-at-a-
/// time steps cannot avoid where a rim doubles back on itself.
fn unfold(p: &[DVec3], normals: &[DVec3], tris: &mut [[u32; 3]], joined: usize) {
    let good = |t: [u32; 3]| facing(p, normals, t) > MIN_FACING;
    for _ in 0..REPAIR_ROUNDS {
        let mut edges: HashMap<(u32, u32), usize> = HashMap::default();
        for (i, t) in tris.iter().enumerate() {
            for k in 0..3 {
                edges.insert((t[k], t[(k + 1) % 3]), i);
            }
        }
        let mut flipped = false;
        for i in joined..tris.len() {
            if good(tris[i]) {
                continue;
            }
            for k in 0..3 {
                let t = tris[i];
                let (u, v, w) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let Some(&j) = edges.get(&(v, u)) else {
                    continue;
                };
                if j < joined {
                    continue;
                }
                let o = tris[j];
                let x = o[(0..3).find(|&m| o[m] != u && o[m] != v).unwrap_or(0)];
                let (n1, n2) = ([w, u, x], [x, v, w]);
                if x == w || edges.contains_key(&(w, x)) || edges.contains_key(&(x, w)) {
                    continue;
                }
                if good(n1) && good(n2) {
                    tris[i] = n1;
                    tris[j] = n2;
                    for (a, b) in [(u, v), (v, u)] {
                        edges.remove(&(a, b));
                    }
                    for (tri, idx) in [(n1, i), (n2, j)] {
                        for m in 0..3 {
                            edges.insert((tri[m], tri[(m + 1) % 3]), idx);
                        }
                    }
                    flipped = true;
                    break;
                }
            }
        }
        if !flipped {
            break;
        }
    }
}

/// Pairs of rim positions whose arc-length fractions may differ in a
/// zipper strip ([`zip`]).
const BAND: f64 = 0.25;

/// Most pairs of rim positions a zipper searches.
const MAX_PAIRS: usize = 4_000_000;

/// Cumulative length along the closed polyline `loop_` at each vertex and
/// back at the first, as fractions of the whole (`len + 1` values).
fn arc_fractions(p: &[DVec3], loop_: &[u32]) -> Vec<f64> {
    let n = loop_.len();
    let mut s = Vec::with_capacity(n + 1);
    let mut total = 0.0;
    s.push(0.0);
    for k in 0..n {
        total += p[loop_[k] as usize].distance(p[loop_[(k + 1) % n] as usize]);
        s.push(total);
    }
    let total = if total > 0.0 { total } else { 1.0 };
    s.iter().map(|x| x / total).collect()
}

/// The joined mesh is a closed oriented 2-manifold, and no joining
/// triangle (from index `joined` on) is degenerate or faces against its
/// corners' normals (beyond [`MIN_FACING`]).
fn check(m: &Mesh, joined: usize) -> Result<Topology, Refused> {
    let topo = topology::analyze(m);
    if !topo.watertight || topo.nonmanifold_vertices > 0 {
        return Err(Refused::BadJoin);
    }
    let faces_out = m.triangles[joined..]
        .iter()
        .all(|&t| facing(&m.positions, &m.normals, t) > MIN_FACING);
    if faces_out {
        Ok(topo)
    } else {
        Err(Refused::BadJoin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesher;
    use crate::testing::surface;

    fn robust(src: &str, domain: Bounds, level: u8) -> Mesh {
        let opts = super::super::robust_options(domain, level, 0.0);
        mesher::mesh_with(&surface(src), domain, &opts, &|_| {}).0
    }

    fn cube(lo: f64, hi: f64) -> Bounds {
        Bounds {
            lo: [lo; 3],
            hi: [hi; 3],
        }
    }

    fn ball(x: f64, y: f64, z: f64, radius: f64) -> Ball {
        Ball {
            centre: DVec3::new(x, y, z),
            radius,
        }
    }

    #[test]
    fn a_patch_of_the_same_sphere_splices_into_a_closed_sphere() {
        let src = "domain [-2, 2]^3; surface x^2 + y^2 + z^2 - 1;";
        let mesh = robust(src, cube(-2.0, 2.0), 4);
        for region in [ball(1.0, 0.0, 0.0, 0.8), ball(0.4, 0.4, 0.4, 1.0)] {
            let patch = robust(src, region.cube(), 4);
            let (out, topo) = splice(&mesh, &patch, &region, 0.2).expect("splices");
            assert_eq!(topo, topology::analyze(&out));
            assert!(topo.watertight, "{topo:?}");
            assert_eq!((topo.components, topo.genus), (1, vec![Some(0)]));
            // Every vertex is one of the inputs' (on the sphere).
            assert!(
                out.positions
                    .iter()
                    .all(|p| (p.length() - 1.0).abs() < 1e-6)
            );
        }
    }

    #[test]
    fn a_neck_in_the_patch_joins_two_components() {
        // Two spheres, then the same two joined by a neck at the origin:
        // the patch over the neck brings the new topology.
        let apart = "domain [-3, 3]^3; surface min(sqrt((x-1.1)^2 + y^2 + z^2), \
                     sqrt((x+1.1)^2 + y^2 + z^2)) - 1;";
        let joined = "domain [-3, 3]^3; surface min(min(sqrt((x-1.1)^2 + y^2 + z^2), \
                      sqrt((x+1.1)^2 + y^2 + z^2)) - 1, sqrt(y^2 + z^2) - 0.4 + 0*x);";
        let mesh = robust(apart, cube(-3.0, 3.0), 5);
        assert_eq!(topology::analyze(&mesh).components, 2);
        let region = ball(0.0, 0.0, 0.0, 1.0);
        let patch = robust(joined, region.cube(), 4);
        // A cube of side 2 over 16 cells: edges about 0.15.
        let (_, topo) = splice(&mesh, &patch, &region, 0.15).expect("splices");
        assert!(topo.watertight, "{topo:?}");
        assert_eq!((topo.components, topo.genus), (1, vec![Some(0)]));
    }

    #[test]
    fn rims_that_do_not_correspond_are_refused() {
        // A patch of another surface (a smaller sphere) has no rim near
        // the hole's.
        let mesh = robust(
            "domain [-2, 2]^3; surface x^2 + y^2 + z^2 - 1;",
            cube(-2.0, 2.0),
            4,
        );
        let region = ball(1.0, 0.0, 0.0, 0.8);
        let patch = robust(
            "domain [-2, 2]^3; surface x^2 + y^2 + z^2 - 0.25;",
            region.cube(),
            4,
        );
        assert!(splice(&mesh, &patch, &region, 0.2).is_err());
    }
}
