//! What the geometric refinement keeps from one frame to the next.

use rayon::prelude::*;
use rustc_hash::{FxHashMap as HashMap, FxHashSet as HashSet};

use super::tris::{
    Limits, Name, RefineStats, TRIANGLE, Tris, VERTEX, arc_midpoint, budget, inverted, name,
};
use crate::eval::Evaluator;
use crate::mesh::Mesh;
use crate::roots::walk::newton;

/// How much an edge of a reused triangle may have stretched, relative to
/// its length, since its refinement was decided.
pub const SHAPE_TOLERANCE: f64 = 0.1;
/// How much (in units of α_r) an angle between a reused triangle's corner
/// normals may have changed since its refinement was decided.
pub const TURN_TOLERANCE: f64 = 0.5;

/// Deepest chain of midpoints a record may hold (passes are at most 12).
const MAX_DEPTH: usize = 16;

/// The last frame's geometric mesh, by names that survive from frame to
/// frame: a mechanical vertex is named by its slot in the tracker, a
/// midpoint by its edge's ends, a mechanical triangle by its corners.
///
/// A mechanical triangle is *reused* when it existed at the last frame
/// (the same three corners) and, since its refinement was decided,
/// none of its edges has changed length by more than [`SHAPE_TOLERANCE`]
/// of itself and no angle between two of its corner normals by more than
/// [`TURN_TOLERANCE`] × α_r. It then gets the geometric triangles it had,
/// their midpoints projected anew (in order of depth, each from its edge's
/// arc midpoint, as [`super::refine`] does). The other triangles go
/// through the passes of the module doc, where an edge beside a reused
/// triangle is split exactly where that triangle has midpoints. When a
/// reused midpoint cannot be projected, a reused triangle turns over, or
/// the two parts cannot be joined without one (a shared split that would
/// invert a triangle), nothing is reused in that frame.
#[derive(Clone, Debug, Default)]
pub(crate) struct Reuse {
    /// Per mechanical triangle (by name), how its refinement was decided.
    records: HashMap<Name, Record>,
    /// The geometric triangles, each corner an index into its record's
    /// run of `verts`; a record's are contiguous.
    tris: Vec<[u32; 3]>,
    /// The records' vertices by name, each record's once, contiguous.
    verts: Vec<Name>,
    /// Per midpoint (by name), its edge's ends.
    parents: HashMap<Name, (Name, Name)>,
}

/// A mechanical triangle's shape when its refinement was decided, its
/// geometric triangles (`tris` of [`Reuse::tris`]) and their vertices
/// (`verts` of [`Reuse::verts`]).
#[derive(Clone, Debug)]
struct Record {
    shape: Shape,
    tris: std::ops::Range<u32>,
    verts: std::ops::Range<u32>,
}

/// A triangle's edge lengths and the angles between its corner normals,
/// corners ordered by slot.
type Shape = [f64; 6];

/// A mechanical triangle of this frame: its name, the shape to record, and
/// the geometric triangles to reuse.
struct Decided {
    name: Name,
    shape: Shape,
    reused: Option<Record>,
}

impl Reuse {
    /// This frame's geometric mesh of `mech` (vertex slots `ids`), reusing
    /// what can be; `None` (and nothing recorded) when the reused part
    /// could not be joined to the rest.
    pub(super) fn refine<E: Evaluator + ?Sized>(
        &mut self,
        mech: &Mesh,
        ids: &[u32],
        f: &E,
        t: f64,
        alpha_deg: f64,
        passes: usize,
    ) -> Option<(Mesh, RefineStats)> {
        let decided = self.classify(mech, ids, alpha_deg);
        let mut b = Builder::new(mech, ids, self.parents.len());
        let (mut tris, mut origin, mut local) = (Vec::new(), Vec::new(), Vec::new());
        for (i, d) in decided.iter().enumerate() {
            let Some(r) = &d.reused else {
                continue;
            };
            local.clear();
            for &m in &self.verts[r.verts.start as usize..r.verts.end as usize] {
                local.push(b.resolve(m, &self.parents, 0)?);
            }
            for g in &self.tris[r.tris.start as usize..r.tris.end as usize] {
                tris.push(g.map(|k| local[k as usize]));
                origin.push(i as u32);
            }
        }
        let (reproduced, depth) = b.project(f, t)?;
        if tris.iter().any(|&g| inverted(&b.mesh, g)) {
            return None;
        }
        // The rest afresh, split beside reused triangles where they are.
        let shared: HashSet<(u32, u32)> = decided
            .iter()
            .zip(&mech.triangles)
            .filter(|(d, _)| d.reused.is_some())
            .flat_map(|(_, t)| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .collect();
        let fresh: Vec<u32> = (0..decided.len() as u32)
            .filter(|&i| decided[i as usize].reused.is_none())
            .collect();
        let mut part = Tris::new(
            fresh.iter().map(|&i| mech.triangles[i as usize]).collect(),
            Some(&shared),
        );
        part.origin = fresh;
        part.names = std::mem::take(&mut b.names);
        part.parents = std::mem::take(&mut b.parents);
        let limits = Limits {
            cos_a: alpha_deg.to_radians().cos(),
            passes,
            budget: budget(mech).saturating_sub(tris.len()),
        };
        let (mut stats, conflict) = part.refine(&mut b.mesh, f, t, limits, Some(&b.index));
        if conflict {
            return None;
        }
        tris.extend_from_slice(&part.v);
        origin.extend_from_slice(&part.origin);
        stats.splits += reproduced;
        stats.passes = stats.passes.max(depth);
        self.record(&decided, &tris, &origin, &part, mech.positions.len());
        let mut mesh = b.mesh;
        mesh.triangles = tris;
        Some((mesh, stats))
    }

    /// Each triangle of `mech`, reused or not.
    fn classify(&self, mech: &Mesh, ids: &[u32], alpha_deg: f64) -> Vec<Decided> {
        let turn = TURN_TOLERANCE * alpha_deg.to_radians().abs();
        mech.triangles
            .par_iter()
            .map(|&t| {
                let (name, now) = shape(mech, ids, t);
                match self.records.get(&name) {
                    Some(r)
                        if (0..3).all(|k| {
                            (now[k] - r.shape[k]).abs() <= SHAPE_TOLERANCE * r.shape[k]
                                && (now[k + 3] - r.shape[k + 3]).abs() <= turn
                        }) =>
                    {
                        Decided {
                            name,
                            shape: r.shape,
                            reused: Some(r.clone()),
                        }
                    }
                    _ => Decided {
                        name,
                        shape: now,
                        reused: None,
                    },
                }
            })
            .collect()
    }

    /// Keeps this frame's mesh for the next: `tris` refine `decided[origin]`;
    /// `part` holds every vertex's name and parents, midpoints from
    /// `mechanical` on.
    fn record(
        &mut self,
        decided: &[Decided],
        tris: &[[u32; 3]],
        origin: &[u32],
        part: &Tris,
        mechanical: usize,
    ) {
        // The triangles grouped by origin (a counting sort).
        let mut start = vec![0usize; decided.len() + 1];
        for &o in origin {
            start[o as usize + 1] += 1;
        }
        for i in 0..decided.len() {
            start[i + 1] += start[i];
        }
        let mut order = vec![0usize; tris.len()];
        let mut fill = start.clone();
        for (g, &o) in origin.iter().enumerate() {
            order[fill[o as usize]] = g;
            fill[o as usize] += 1;
        }
        // Each record's vertices once, in order of first use.
        let mut stamp = vec![usize::MAX; part.names.len()];
        let mut local = vec![0u32; part.names.len()];
        self.tris.clear();
        self.verts.clear();
        let mut records = HashMap::with_capacity_and_hasher(decided.len(), Default::default());
        for (i, d) in decided.iter().enumerate() {
            let (first, vfirst) = (self.tris.len() as u32, self.verts.len());
            for &g in &order[start[i]..start[i + 1]] {
                let tri = tris[g].map(|v| {
                    let v = v as usize;
                    if stamp[v] != i {
                        stamp[v] = i;
                        local[v] = (self.verts.len() - vfirst) as u32;
                        self.verts.push(part.names[v]);
                    }
                    local[v]
                });
                self.tris.push(tri);
            }
            let r = Record {
                shape: d.shape,
                tris: first..self.tris.len() as u32,
                verts: vfirst as u32..self.verts.len() as u32,
            };
            records.insert(d.name, r);
        }
        self.records = records;
        self.parents = (mechanical..part.names.len())
            .map(|v| (part.names[v], part.parents[v]))
            .collect();
    }
}

/// Triangle `t`'s name (from its corners' slots `ids`, in any order) and
/// shape.
fn shape(mech: &Mesh, ids: &[u32], t: [u32; 3]) -> (Name, Shape) {
    let mut c = t;
    c.sort_unstable_by_key(|&v| ids[v as usize]);
    let [a, b, d] = c.map(|v| u64::from(ids[v as usize]));
    let p = c.map(|v| mech.positions[v as usize]);
    let n = c.map(|v| mech.normals[v as usize]);
    let angle = |i: usize, j: usize| n[i].dot(n[j]).clamp(-1.0, 1.0).acos();
    let shape = [
        p[0].distance(p[1]),
        p[1].distance(p[2]),
        p[2].distance(p[0]),
        angle(0, 1),
        angle(1, 2),
        angle(2, 0),
    ];
    (name(TRIANGLE, name(TRIANGLE, a, b), d), shape)
}

/// The geometric mesh under construction: the mechanical vertices, then
/// the reused midpoints (created by name, projected by [`Builder::project`]).
struct Builder {
    mesh: Mesh,
    names: Vec<Name>,
    parents: Vec<(Name, Name)>,
    depth: Vec<u8>,
    index: HashMap<Name, u32>,
    /// Reused midpoints to project: vertex, edge ends.
    pending: Vec<(u32, u32, u32)>,
}

impl Builder {
    /// The mechanical vertices of `mech` (slots `ids`), with room for
    /// `midpoints` more.
    fn new(mech: &Mesh, ids: &[u32], midpoints: usize) -> Builder {
        let names: Vec<Name> = ids.iter().map(|&i| name(VERTEX, i.into(), 0)).collect();
        let n = names.len();
        let mut index = HashMap::with_capacity_and_hasher(n + midpoints, Default::default());
        index.extend(names.iter().enumerate().map(|(i, &m)| (m, i as u32)));
        Builder {
            mesh: Mesh {
                positions: mech.positions.clone(),
                normals: mech.normals.clone(),
                ambiguous: vec![false; n],
                triangles: Vec::new(),
            },
            index,
            names,
            parents: vec![(0, 0); n],
            depth: vec![0; n],
            pending: Vec::new(),
        }
    }

    /// The vertex named `m`, created (unprojected) with its ancestors
    /// when new; `None` when its chain is not in `parents`.
    fn resolve(
        &mut self,
        m: Name,
        parents: &HashMap<Name, (Name, Name)>,
        depth: usize,
    ) -> Option<u32> {
        if let Some(&i) = self.index.get(&m) {
            return Some(i);
        }
        if depth > MAX_DEPTH {
            return None;
        }
        let &(a, b) = parents.get(&m)?;
        let ia = self.resolve(a, parents, depth + 1)?;
        let ib = self.resolve(b, parents, depth + 1)?;
        let i = self.mesh.positions.len() as u32;
        self.mesh.positions.push(glam::DVec3::NAN);
        self.mesh.normals.push(glam::DVec3::NAN);
        self.mesh.ambiguous.push(false);
        self.names.push(m);
        self.parents.push((a, b));
        let d = 1 + self.depth[ia as usize].max(self.depth[ib as usize]);
        self.depth.push(d);
        self.pending.push((i, ia, ib));
        self.index.insert(m, i);
        Some(i)
    }

    /// Projects the reused midpoints, shallowest first (in parallel within
    /// a depth); returns how many and the deepest, or `None` when one
    /// cannot be projected.
    fn project<E: Evaluator + ?Sized>(&mut self, f: &E, t: f64) -> Option<(usize, usize)> {
        let mut pending = std::mem::take(&mut self.pending);
        pending.sort_by_key(|p| self.depth[p.0 as usize]);
        let deepest = pending.last().map_or(0, |p| self.depth[p.0 as usize]);
        for level in pending.chunk_by(|p, q| self.depth[p.0 as usize] == self.depth[q.0 as usize]) {
            let mesh = &self.mesh;
            let out: Vec<_> = level
                .par_iter()
                .map(|&(_, a, b)| {
                    let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
                    let (na, nb) = (mesh.normals[a as usize], mesh.normals[b as usize]);
                    let len = pa.distance(pb);
                    newton(f, t, arc_midpoint(pa, pb, na, nb), len, 0.5 * len)
                })
                .collect();
            for (&(i, _, _), s) in level.iter().zip(out) {
                let s = s?;
                self.mesh.positions[i as usize] = s.pos;
                self.mesh.normals[i as usize] = s.grad.normalize_or_zero();
            }
        }
        Some((pending.len(), usize::from(deepest)))
    }
}
