//! Keeping the mechanical mesh uniform (Bouthors & Nesme §2.5, §2.6.1):
//! edge splits, edge collapses and — beyond the paper — edge flips.
//!
//! # Rules
//!
//! With ê the target edge length and `Δ = ‖e‖ₜ − ‖e‖ₜ₋₁` the change of an
//! edge's length since the last frame:
//!
//! - **split** when `‖e‖ > e_max·ê` and the edge is not shrinking
//!   (`Δ > −ε_e·ê`), unless one of its triangles is inverted (§2.6.1,
//!   case 4). The new vertex is the midpoint projected onto the surface by
//!   [`crate::roots::walk::newton`]; if that fails the edge is left alone.
//! - **collapse** when `‖e‖ < e_min·ê` and the edge is not growing
//!   (`Δ < ε_e·ê`): both ends merge at the projected midpoint, only if the
//!   link condition holds (no non-manifold result, Fig. 3), no surviving
//!   triangle turns over (faces against ∇f or against its old normal,
//!   §2.6.1 case 2), and no new edge is longer than `e_max·ê` (which would
//!   only call for a split next frame).
//! - **flip** (not in the paper; the paper's quality goal of near-
//!   equilateral triangles needs it where vertex valences are uneven, as
//!   marching cubes leaves them): an edge whose two opposite angles sum to
//!   more than π is replaced by the other diagonal of its quad (the
//!   Delaunay criterion), if both new triangles face along ∇f and the new
//!   fold is gentle.
//!
//! The paper reads the split and collapse tests as "still stretching" /
//! "still shrinking" (Fig. 2's caption: *has not been compressed / has not
//! stretched since the last time step*); the tolerance ε_e keeps edges at
//! rest eligible. Every edge an operation creates or changes is *frozen*:
//! it is neither split nor collapsed during the next frame's remeshing
//! (§2.5); flips may still act on it (Delaunay flips cannot oscillate:
//! each one strictly improves the quad), so that the triangles a split
//! leaves behind are repaired at once. No vertex is touched twice in one
//! sweep.
//!
//! Evaluation: each projection is one sequential Newton walk
//! ([`newton`]) and each operation changes the mesh the next one sees, so
//! the function is evaluated one point at a time here.

use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use glam::DVec3;

use crate::cancel::{Cancel, Cancelled};
use crate::eval::Evaluator;
use crate::mesh::dynmesh::{DynMesh, EdgeKey, key};
use crate::roots::walk::newton;

/// Thresholds of [`remesh`].
#[derive(Clone, Copy, Debug)]
pub struct Params {
    /// ê.
    pub edge: f64,
    /// e_min: edges shorter than `e_min·ê` are collapsed.
    pub e_min: f64,
    /// e_max: edges longer than `e_max·ê` are split.
    pub e_max: f64,
    /// ε_e: tolerance on an edge's length change since the last frame, in
    /// units of ê.
    pub eps_e: f64,
    /// Whether edge flips run (beyond the paper).
    pub flips: bool,
    /// Sweeps over the edges per call.
    pub sweeps: usize,
}

/// What [`remesh`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Edges split.
    pub splits: usize,
    /// Edges collapsed.
    pub collapses: usize,
    /// Edges flipped.
    pub flips: usize,
}

/// Why an edge outside `[e_min, e_max]·ê` was left as it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Held {
    /// Modified by the last frame or this one (§2.5).
    Frozen,
    /// Too long but shrinking, or too short but growing (§2.5).
    Trend,
    /// A split next to an inverted triangle (§2.6.1, case 4).
    Inverted,
    /// A collapse that would break the link condition (Fig. 3).
    Topology,
    /// A collapse that would turn a triangle over, leave a sliver, or make
    /// an edge longer than `e_max·ê`.
    Shape,
    /// The new point could not be projected onto the surface.
    Projection,
    /// A neighbour was modified in every sweep.
    Busy,
}

/// What remeshing remembers about edges between frames.
#[derive(Clone, Debug, Default)]
pub struct EdgeState {
    /// Vertex positions at the end of the last frame, for Δ (empty before
    /// the first frame: Δ = 0). An edge's length then is the distance of
    /// its ends there: every edge an operation has made since is frozen,
    /// so Δ is only asked of edges that existed then, and no per-edge
    /// store is needed.
    pub prev_pos: Vec<DVec3>,
    /// Edges the last frame modified: not split or collapsed now.
    pub frozen: HashSet<EdgeKey>,
    /// Edges modified now (frozen for the next frame).
    pub new_frozen: HashSet<EdgeKey>,
    /// For edges still outside the band that an operation was refused,
    /// why (the last refusal).
    pub held: HashMap<EdgeKey, Held>,
}

/// Edges between two polls of the cancel token.
const POLL_EDGES: usize = 4096;

/// Edges with their lengths.
type Candidates = Vec<(EdgeKey, f64)>;

/// Whether an edge of length `len` is outside the band, and on which
/// side: `Some(true)` too long, `Some(false)` too short.
fn outside(len: f64, p: &Params) -> Option<bool> {
    if len > p.e_max * p.edge {
        Some(true)
    } else if len < p.e_min * p.edge {
        Some(false)
    } else {
        None
    }
}

/// The edges outside the band `[e_min, e_max]·ê`, each once with its
/// length: the ones to split and the ones to collapse (unsorted, see
/// [`order`]). One pass over the triangles.
fn candidates(mesh: &DynMesh, p: &Params) -> (Candidates, Candidates) {
    let (mut long, mut short) = (Vec::new(), Vec::new());
    for (_, t) in mesh.live_tris() {
        for k in 0..3 {
            let (u, v) = (t[k], t[(k + 1) % 3]);
            let e = key(u, v);
            let len = mesh.length(e);
            let Some(too_long) = outside(len, p) else {
                continue;
            };
            // An edge is listed from the triangle that reads it from its
            // smaller end, or from any of its triangles when none does (a
            // boundary edge); duplicates (inconsistent orientation) go in
            // `order`.
            if u > v {
                let twin = mesh.star[v as usize].iter().any(|&i| {
                    let s = mesh.tris[i as usize];
                    (0..3).any(|j| s[j] == v && s[(j + 1) % 3] == u)
                });
                if twin {
                    continue;
                }
            }
            if too_long { &mut long } else { &mut short }.push((e, len));
        }
    }
    (long, short)
}

/// The order of the candidates to split: as a stable sort of the
/// key-sorted edge list by decreasing length would put them.
fn longest_first(a: &(EdgeKey, f64), b: &(EdgeKey, f64)) -> std::cmp::Ordering {
    b.1.total_cmp(&a.1).then(a.0.cmp(&b.0))
}

/// The order of the candidates to collapse: the reverse of a stable sort
/// of the key-sorted edge list by decreasing length.
fn shortest_first(a: &(EdgeKey, f64), b: &(EdgeKey, f64)) -> std::cmp::Ordering {
    a.1.total_cmp(&b.1).then(b.0.cmp(&a.0))
}

/// Sorts the candidates (the long ones [`longest_first`], the short ones
/// [`shortest_first`]); drops repeats.
fn order(long: &mut Vec<(EdgeKey, f64)>, short: &mut Vec<(EdgeKey, f64)>) {
    long.sort_unstable_by(longest_first);
    short.sort_unstable_by(shortest_first);
    long.dedup_by_key(|x| x.0);
    short.dedup_by_key(|x| x.0);
}

/// Merges the sorted `fresh` into the sorted `list` (no key in both).
fn merge(
    list: &mut Vec<(EdgeKey, f64)>,
    fresh: &[(EdgeKey, f64)],
    cmp: fn(&(EdgeKey, f64), &(EdgeKey, f64)) -> std::cmp::Ordering,
    scratch: &mut Vec<(EdgeKey, f64)>,
) {
    if fresh.is_empty() {
        return;
    }
    scratch.clear();
    scratch.reserve(list.len() + fresh.len());
    let (mut i, mut j) = (0, 0);
    while i < list.len() && j < fresh.len() {
        if cmp(&fresh[j], &list[i]).is_lt() {
            scratch.push(fresh[j]);
            j += 1;
        } else {
            scratch.push(list[i]);
            i += 1;
        }
    }
    scratch.extend_from_slice(&list[i..]);
    scratch.extend_from_slice(&fresh[j..]);
    std::mem::swap(list, scratch);
}

/// The vertices a sweep has touched: flags, and the list of the flagged
/// ones (so that clearing costs what was touched).
#[derive(Default)]
struct Dirty {
    flag: Vec<bool>,
    list: Vec<u32>,
}

impl Dirty {
    fn get(&self, v: u32) -> bool {
        self.flag[v as usize]
    }

    fn set(&mut self, v: u32) {
        if !self.flag[v as usize] {
            self.flag[v as usize] = true;
            self.list.push(v);
        }
    }

    fn grow(&mut self, n: usize) {
        if self.flag.len() < n {
            self.flag.resize(n, false);
        }
    }

    /// Unflags everything; returns the list of what was flagged, in the
    /// order flagged (`into` is reused for it).
    fn take(&mut self, into: &mut Vec<u32>) {
        for &v in &self.list {
            self.flag[v as usize] = false;
        }
        into.clear();
        std::mem::swap(into, &mut self.list);
    }

    /// Whether a vertex of `v`'s star is flagged (`v` included).
    fn near(&self, mesh: &DynMesh, v: u32) -> bool {
        self.get(v)
            || mesh.star[v as usize]
                .iter()
                .any(|&i| mesh.tris[i as usize].iter().any(|&w| self.get(w)))
    }
}

/// One remeshing pass; see the module doc. `inverted[i]` flags triangle
/// `i` (triangles created here are not). Stops with [`Cancelled`] when
/// `cancel` is cancelled (polled every few thousand edges); the mesh is
/// then valid (every operation done is whole) but partly remeshed.
///
/// Cost: the first sweep makes one pass over the triangles and tests every
/// edge for a flip; a later sweep only revisits what the sweep before it
/// touched — every test here depends on the stars of an edge's ends (the
/// positions, gradients and valences found there) and on the surface
/// alone, and every operation flags the vertices of the triangles it
/// changes, so an edge whose neighbourhood no flag reached gets the
/// answer it got before, and is not asked again. Only the edges outside
/// the band are sorted.
pub fn remesh<E: Evaluator + ?Sized>(
    mesh: &mut DynMesh,
    f: &E,
    t: f64,
    p: &Params,
    edges: &mut EdgeState,
    inverted: &mut Vec<bool>,
    cancel: &Cancel,
) -> Result<Counts, Cancelled> {
    let mut counts = Counts::default();
    edges.held.clear();
    let mut ring: Vec<u32> = Vec::new();
    let mut dirty = Dirty::default();
    // The vertices the last sweep flagged.
    let mut last: Vec<u32> = Vec::new();
    // The vertices next to one of `last` (whose edges the flips revisit).
    let mut active: Vec<bool> = Vec::new();
    let mut quads: Vec<(u32, u32)> = Vec::new();
    // Refusals that depend on the edge's neighbourhood only, kept while
    // no flag reaches it.
    let mut known: HashMap<EdgeKey, Held> = HashMap::default();
    let (mut long, mut short) = candidates(mesh, p);
    order(&mut long, &mut short);
    let (mut fresh_long, mut fresh_short, mut scratch) = (Vec::new(), Vec::new(), Vec::new());
    for sweep in 0..p.sweeps {
        let before = counts;
        if sweep > 0 {
            // The candidates: edges whose ends no flag reached keep their
            // length and their place (and the others are the flagged
            // vertices' edges, sorted apart and merged in).
            let keep = |&(e, _): &(EdgeKey, f64)| !(dirty.get(e.0) || dirty.get(e.1));
            long.retain(keep);
            short.retain(keep);
            fresh_long.clear();
            fresh_short.clear();
            for &v in &dirty.list {
                // Each edge of `v` once, from the triangle that reads it
                // out of `v` or, when none does (a boundary edge), into
                // `v`; an edge of two flagged vertices from its smaller
                // end. (Repeats, from inconsistent orientations, are
                // dropped by `order`.)
                let star = &mesh.star[v as usize];
                let next = |i: u32| {
                    let t = mesh.tris[i as usize];
                    let k = (0..3).find(|&k| t[k] == v).unwrap_or(0);
                    (t[(k + 1) % 3], t[(k + 2) % 3])
                };
                for &i in star {
                    let (n, prev) = next(i);
                    let into = !star.iter().any(|&j| next(j).0 == prev);
                    for w in [Some(n), into.then_some(prev)].into_iter().flatten() {
                        if dirty.get(w) && w < v {
                            continue;
                        }
                        let e = key(v, w);
                        let len = mesh.length(e);
                        match outside(len, p) {
                            Some(true) => fresh_long.push((e, len)),
                            Some(false) => fresh_short.push((e, len)),
                            None => {}
                        }
                    }
                }
            }
            order(&mut fresh_long, &mut fresh_short);
            merge(&mut long, &fresh_long, longest_first, &mut scratch);
            merge(&mut short, &fresh_short, shortest_first, &mut scratch);
            dirty.take(&mut last);
        }
        dirty.grow(mesh.pos.len());
        let EdgeState {
            frozen,
            new_frozen,
            held,
            prev_pos,
        } = edges;
        let is_frozen = |e: &EdgeKey, nf: &HashSet<EdgeKey>| frozen.contains(e) || nf.contains(e);

        // Splits, longest first.
        for (i, &(e, len)) in long.iter().enumerate() {
            if i % POLL_EDGES == 0 {
                cancel.check()?;
            }
            let (a, b) = e;
            if dirty.get(a) || dirty.get(b) {
                held.insert(e, Held::Busy);
                continue;
            }
            if is_frozen(&e, new_frozen) {
                held.insert(e, Held::Frozen);
                continue;
            }
            if edges_delta(prev_pos, e, len) <= -p.eps_e * p.edge {
                held.insert(e, Held::Trend);
                continue;
            }
            if let Some(&h) = known.get(&e) {
                held.insert(e, h);
                continue;
            }
            let inverted_pair = match mesh.edge_pair(a, b) {
                Some(tris) => tris.iter().any(|(i, _)| inverted[*i as usize]),
                None => true,
            };
            if inverted_pair {
                held.insert(e, Held::Inverted);
                known.insert(e, Held::Inverted);
                continue;
            }
            let mid = (mesh.pos[a as usize] + mesh.pos[b as usize]) * 0.5;
            let Some(s) = newton(f, t, mid, 0.5 * len, 0.25 * len) else {
                held.insert(e, Held::Projection);
                known.insert(e, Held::Projection);
                continue;
            };
            held.remove(&e);
            let m = mesh.split(a, b, s.pos, s.grad);
            inverted.resize(mesh.tris.len(), false);
            dirty.grow(mesh.pos.len());
            ring.clear();
            mesh.neighbours_into(m, &mut ring);
            for &w in &ring {
                dirty.set(w);
                new_frozen.insert(key(m, w));
            }
            dirty.set(m);
            counts.splits += 1;
        }

        // Collapses, shortest first.
        for (i, &(e, len)) in short.iter().enumerate() {
            if i % POLL_EDGES == 0 {
                cancel.check()?;
            }
            let (a, b) = e;
            if dirty.get(a)
                || dirty.get(b)
                || !mesh.vert_alive[a as usize]
                || !mesh.vert_alive[b as usize]
            {
                held.insert(e, Held::Busy);
                continue;
            }
            if is_frozen(&e, new_frozen) {
                held.insert(e, Held::Frozen);
                continue;
            }
            if edges_delta(prev_pos, e, len) >= p.eps_e * p.edge {
                held.insert(e, Held::Trend);
                continue;
            }
            if let Some(&h) = known.get(&e) {
                held.insert(e, h);
                continue;
            }
            if !mesh.can_collapse_topologically(a, b) {
                held.insert(e, Held::Topology);
                known.insert(e, Held::Topology);
                continue;
            }
            let mid = (mesh.pos[a as usize] + mesh.pos[b as usize]) * 0.5;
            let Some(s) = newton(f, t, mid, p.edge, 0.25 * p.edge) else {
                held.insert(e, Held::Projection);
                known.insert(e, Held::Projection);
                continue;
            };
            if !collapse_keeps_shape(mesh, a, b, s.pos, s.grad, p.e_max * p.edge) {
                held.insert(e, Held::Shape);
                known.insert(e, Held::Shape);
                continue;
            }
            held.remove(&e);
            ring.clear();
            mesh.neighbours_into(a, &mut ring);
            mesh.neighbours_into(b, &mut ring);
            mesh.collapse(a, b, s.pos, s.grad);
            for &w in &ring {
                dirty.set(w);
                if w != a && w != b {
                    new_frozen.insert(key(a, w));
                }
            }
            dirty.set(a);
            dirty.set(b);
            counts.collapses += 1;
        }

        // Flips, over the edges in increasing key order. They are listed
        // vertex by vertex as the loop goes rather than collected first:
        // a flip removes only the edge at hand and adds one between two
        // vertices it flags, which the loop then skips, so the edges
        // tested are the same as from a list made before the loop. After
        // the first sweep, only the edges of the vertices next to one the
        // last sweep flagged: any other edge's quad is as the last sweep
        // left it, refused.
        if p.flips {
            if sweep > 0 {
                active.clear();
                active.resize(mesh.pos.len(), false);
                for &x in &last {
                    active[x as usize] = true;
                    for &i in &mesh.star[x as usize] {
                        for w in mesh.tris[i as usize] {
                            active[w as usize] = true;
                        }
                    }
                }
            }
            let mut visited = 0usize;
            for a in 0..mesh.pos.len() as u32 {
                if !mesh.vert_alive[a as usize] || (sweep > 0 && !active[a as usize]) {
                    continue;
                }
                // The edges `a–b`, `b > a`, with the vertex opposite them
                // in each triangle: `(b, opposite)` pairs, sorted, so that
                // an interior edge is a run of two. (Once `a` flips an edge
                // it is flagged and its other edges are skipped, so the
                // table need not follow the flip.)
                quads.clear();
                for &i in &mesh.star[a as usize] {
                    let t = mesh.tris[i as usize];
                    let k = (0..3).find(|&k| t[k] == a).unwrap_or(0);
                    let (x, y) = (t[(k + 1) % 3], t[(k + 2) % 3]);
                    if x > a {
                        quads.push((x, y));
                    }
                    if y > a {
                        quads.push((y, x));
                    }
                }
                quads.sort_unstable();
                let mut r = 0;
                while r < quads.len() {
                    let b = quads[r].0;
                    let run = quads[r..].iter().take_while(|q| q.0 == b).count();
                    let (c, d) = (quads[r].1, quads[r + run - 1].1);
                    r += run;
                    if visited.is_multiple_of(POLL_EDGES) {
                        cancel.check()?;
                    }
                    visited += 1;
                    // Cheap tests first: an edge of two triangles, no flag
                    // on its quad, and not the Delaunay test's sure "no"
                    // (both opposite angles acute), which most edges get.
                    if run != 2
                        || dirty.get(a)
                        || dirty.get(b)
                        || dirty.get(c)
                        || dirty.get(d)
                        || !may_violate_delaunay(mesh, a, b, c, d)
                    {
                        continue;
                    }
                    let Some((c, d, t1, t2)) = mesh.flip_quad(a, b) else {
                        continue;
                    };
                    if inverted[t1 as usize]
                        || inverted[t2 as usize]
                        || !flip_improves(mesh, a, b, c, d)
                    {
                        continue;
                    }
                    if let Some(ne) = mesh.flip(a, b) {
                        for v in [a, b, c, d] {
                            dirty.set(v);
                        }
                        new_frozen.insert(ne);
                        counts.flips += 1;
                    }
                }
            }
        }
        if counts == before {
            break;
        }
        // Forget the refusals a flag reached.
        known.retain(|&(a, b), _| !(dirty.near(mesh, a) || dirty.near(mesh, b)));
    }
    Ok(counts)
}

/// [`EdgeState::delta`] on the positions alone (borrowed apart from the
/// sets the loops update).
fn edges_delta(prev_pos: &[DVec3], e: EdgeKey, len: f64) -> f64 {
    match (prev_pos.get(e.0 as usize), prev_pos.get(e.1 as usize)) {
        // NaN: a vertex made since (see `Tracker::compact`).
        (Some(a), Some(b)) if !(a.is_nan() || b.is_nan()) => len - a.distance(*b),
        _ => 0.0,
    }
}

/// `false` when both angles opposite `a–b` in the quad `[a, b, c]`,
/// `[b, a, d]` are strictly acute: their sum is then at most π and
/// [`flip_improves`] refuses the flip. A sure answer without `acos`.
fn may_violate_delaunay(mesh: &DynMesh, a: u32, b: u32, c: u32, d: u32) -> bool {
    let [pa, pb, pc, pd] = [a, b, c, d].map(|v| mesh.pos[v as usize]);
    !((pa - pc).dot(pb - pc) > 0.0 && (pa - pd).dot(pb - pd) > 0.0)
}

/// The geometric conditions of a collapse of `a–b` to `p` (see the module
/// doc).
fn collapse_keeps_shape(mesh: &DynMesh, a: u32, b: u32, p: DVec3, g: DVec3, max_len: f64) -> bool {
    // The edge lengths first: the cheapest test, and the one that refuses
    // most. (The neighbours come from the stars; repeats do no harm.)
    for v in [a, b] {
        for &ti in &mesh.star[v as usize] {
            for w in mesh.tris[ti as usize] {
                if w != a && w != b && mesh.pos[w as usize].distance(p) > max_len {
                    return false;
                }
            }
        }
    }
    for v in [a, b] {
        for &ti in &mesh.star[v as usize] {
            let t = mesh.tris[ti as usize];
            if t.contains(&a) && t.contains(&b) {
                continue;
            }
            let old = mesh.normal(ti);
            let q = t.map(|w| {
                if w == a || w == b {
                    p
                } else {
                    mesh.pos[w as usize]
                }
            });
            let new = (q[1] - q[0]).cross(q[2] - q[0]);
            let gs: DVec3 = t
                .iter()
                .map(|&w| {
                    if w == a || w == b {
                        g
                    } else {
                        mesh.grad[w as usize]
                    }
                })
                .map(|x| x.normalize_or_zero())
                .sum();
            if new.dot(old) <= 0.0 || new.dot(gs) <= 0.0 {
                return false;
            }
            // Quality floor: no sliver.
            if aspect(q) < 0.2 {
                return false;
            }
        }
    }
    true
}

/// 4√3·area / Σ‖edge‖² (1 for an equilateral triangle).
pub fn aspect(q: [DVec3; 3]) -> f64 {
    let area2 = (q[1] - q[0]).cross(q[2] - q[0]).length();
    let s = q[0].distance_squared(q[1]) + q[1].distance_squared(q[2]) + q[2].distance_squared(q[0]);
    if s == 0.0 {
        0.0
    } else {
        2.0 * 3f64.sqrt() * area2 / s
    }
}

fn angle(at: DVec3, p: DVec3, q: DVec3) -> f64 {
    (p - at).angle_between(q - at)
}

/// The Delaunay test on the quad `[a, b, c]`, `[b, a, d]`, plus the
/// geometric checks of the module doc.
fn flip_improves(mesh: &DynMesh, a: u32, b: u32, c: u32, d: u32) -> bool {
    let [pa, pb, pc, pd] = [a, b, c, d].map(|v| mesh.pos[v as usize]);
    if angle(pc, pa, pb) + angle(pd, pa, pb) <= std::f64::consts::PI + 1e-9 {
        return false;
    }
    let n3 = (pd - pa).cross(pc - pa);
    let n4 = (pc - pb).cross(pd - pb);
    let gsum = |ts: [u32; 3]| -> DVec3 {
        ts.iter()
            .map(|&v| mesh.grad[v as usize].normalize_or_zero())
            .sum()
    };
    if n3.dot(gsum([a, d, c])) <= 0.0 || n4.dot(gsum([b, c, d])) <= 0.0 {
        return false;
    }
    let (u3, u4) = (n3.normalize_or_zero(), n4.normalize_or_zero());
    let n1 = (pb - pa).cross(pc - pa).normalize_or_zero();
    let n2 = (pa - pb).cross(pd - pb).normalize_or_zero();
    // The new fold is no sharper than the old one or than 30°.
    u3.dot(u4) >= n1.dot(n2).min(30f64.to_radians().cos())
}
