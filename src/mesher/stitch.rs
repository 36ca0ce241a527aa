//! Welding brick parts as they come (SPEC §2 `--bricks`, `isoc merge`),
//! with the welded mesh's topology tallied on the way.
//!
//! # Contract
//!
//! Parts are added one at a time, in any order ([`Stitcher::add`]). A
//! part's *rim* vertices — the ends of its edges with one triangle in the
//! part — are looked up by id ([`Origins`]) among the rims still open; the
//! part's other vertices are new. Each new vertex and every triangle goes
//! straight to a [`Sink`] (a file writer, or a [`Mesh`]). What is kept
//! between parts is only what a later part can still meet: the rim
//! vertices and rim edges not yet matched by the other side, and a
//! handful of counts per connected piece of each part. A rim vertex is
//! forgotten once every rim edge around it is matched, so memory follows
//! the open seams, not the mesh.
//!
//! [`Stitcher::finish`] gives the welded mesh's [`Topology`]: the same
//! figures [`topology::analyze_in`] computes on the whole welded mesh
//! (components, Euler characteristic, genera, boundary, open, non-manifold
//! and misoriented edges), but for these limits:
//!
//! - a bow-tie at a rim vertex is not counted (its fan is split between
//!   parts, so no part sees it whole); bow-ties elsewhere are;
//! - a boundary edge lies on ∂Ω when its ends share a face of Ω by their
//!   recorded sides ([`Origins::on_boundary`]), not by their positions;
//! - an edge that is a rim edge in three parts counts as an open edge (it
//!   is non-manifold either way).
//!
//! A vertex whose fan is complete in two parts (two sheets touching at a
//! point that lies on a seam) stays two vertices: the weld follows open
//! rims only.

use rustc_hash::FxHashMap as HashMap;

use crate::mesh::origin::{Origins, VertexId};
use crate::mesh::sink::Sink;
use crate::mesh::topology::{self, Component, Topology, UnionFind};
use crate::mesh::{Mesh, quality};

/// A rim vertex still waiting for its other side.
struct Rim {
    /// Its number in the welded mesh.
    index: u32,
    /// The piece (connected part of a part) it was first seen in.
    piece: u32,
    /// Its rim edges not matched yet.
    open: u32,
}

/// A rim edge not matched yet.
struct OpenEdge {
    /// Whether its triangle traverses it from the lower id to the higher.
    forward: bool,
    /// The piece of its triangle.
    piece: u32,
    /// Whether it lies in a face of Ω (a boundary edge, not a seam).
    on_boundary: bool,
}

/// What [`Stitcher::finish`] gives.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stitched {
    /// The welded mesh's topology (see the module doc's limits).
    pub topology: Topology,
    /// Vertices written.
    pub vertices: usize,
    /// Triangles written.
    pub triangles: usize,
    /// Triangles with aspect ratio above 0.8 ([`quality::good_triangles`]).
    pub good_triangles: usize,
}

impl Stitched {
    /// The share of good triangles ([`quality::aspect_good`]).
    pub fn aspect_good(&self) -> f64 {
        if self.triangles == 0 {
            0.0
        } else {
            self.good_triangles as f64 / self.triangles as f64
        }
    }
}

/// Welds parts into a [`Sink`] (see the module doc): an owned one, or
/// `&mut` one.
pub struct Stitcher<S: Sink> {
    sink: S,
    out: Stitched,
    rims: HashMap<VertexId, Rim>,
    open: HashMap<(VertexId, VertexId), OpenEdge>,
    /// Pieces joined through shared rim vertices.
    pieces: UnionFind,
    /// Per piece: `V`, `E`, `F`, closed.
    counts: Vec<Component>,
}

/// One part's view of itself: its pieces and its rim.
struct Local {
    used: Vec<bool>,
    rim: Vec<bool>,
    /// Per vertex, its piece's global number.
    piece: Vec<u32>,
    /// Rim edges, as traversed by their triangle.
    rim_edges: Vec<(u32, u32)>,
}

impl<S: Sink> Stitcher<S> {
    /// A stitcher writing to `sink`.
    pub fn new(sink: S) -> Self {
        Stitcher {
            sink,
            out: Stitched::default(),
            rims: HashMap::default(),
            open: HashMap::default(),
            pieces: UnionFind(Vec::new()),
            counts: Vec::new(),
        }
    }

    /// Welds a part (its mesh and its vertices' origins) to those before,
    /// and writes its new vertices and its triangles to the sink.
    pub fn add(&mut self, mesh: &Mesh, origins: &Origins) -> std::io::Result<()> {
        let local = self.survey(mesh);
        let mut keep = local.used.clone();
        for (k, r) in keep.iter_mut().zip(&local.rim) {
            *k &= !r;
        }
        self.out.topology.nonmanifold_vertices += topology::count_bowties(mesh, &keep);
        let (global, new) = self.number(&local, origins);
        self.match_rims(&local, origins);
        let triangles: Vec<[u32; 3]> = mesh
            .triangles
            .iter()
            .map(|t| {
                self.counts[local.piece[t[0] as usize] as usize].2 += 1;
                t.map(|v| global[v as usize])
            })
            .collect();
        self.out.triangles += triangles.len();
        self.out.good_triangles += quality::good_triangles(mesh);
        self.sink.append(mesh, &new, &triangles)
    }

    /// The part's pieces, rim and edges; its inner edges are counted.
    fn survey(&mut self, mesh: &Mesh) -> Local {
        let n = mesh.positions.len();
        let topology::Edges {
            used,
            mut uf,
            directed,
        } = topology::edges(mesh);
        let mut piece = vec![u32::MAX; n];
        for v in (0..n as u32).filter(|&v| used[v as usize]) {
            let r = uf.find(v) as usize;
            if piece[r] == u32::MAX {
                piece[r] = self.counts.len() as u32;
                self.pieces.0.push(piece[r]);
                self.counts.push((0, 0, 0, true));
            }
            piece[v as usize] = piece[r];
        }
        let mut rim = vec![false; n];
        let mut rim_edges = Vec::new();
        let topo = &mut self.out.topology;
        for run in directed.chunk_by(|x, y| x >> 1 == y >> 1) {
            let (lo, hi) = ((run[0] >> 33) as u32, ((run[0] >> 1) & 0xffff_ffff) as u32);
            let back = run.iter().filter(|&&d| d & 1 == 1).count();
            let c = &mut self.counts[piece[lo as usize] as usize];
            match (run.len(), back) {
                (1, b) => {
                    rim[lo as usize] = true;
                    rim[hi as usize] = true;
                    rim_edges.push(if b == 1 { (hi, lo) } else { (lo, hi) });
                    continue;
                }
                (2, 1) => {}
                (2, _) => {
                    topo.misoriented_edges += 1;
                    c.3 = false;
                }
                _ => {
                    topo.nonmanifold_edges += 1;
                    c.3 = false;
                }
            }
            c.1 += 1;
        }
        Local {
            used,
            rim,
            piece,
            rim_edges,
        }
    }

    /// Numbers the part's vertices in the welded mesh: rim vertices
    /// already open keep their number; the others are new (returned in
    /// order). Pieces that share a rim vertex are joined.
    fn number(&mut self, local: &Local, origins: &Origins) -> (Vec<u32>, Vec<u32>) {
        let n = local.used.len();
        let mut global = vec![u32::MAX; n];
        let mut new = Vec::new();
        for v in (0..n).filter(|&v| local.used[v]) {
            let piece = local.piece[v];
            let next = self.out.vertices as u32;
            if local.rim[v] {
                let rim = self.rims.entry(origins.ids[v]).or_insert(Rim {
                    index: next,
                    piece,
                    open: 0,
                });
                global[v] = rim.index;
                if rim.index != next {
                    self.pieces.union(rim.piece, piece);
                    continue;
                }
            }
            global[v] = next;
            new.push(v as u32);
            self.out.vertices += 1;
            self.counts[piece as usize].0 += 1;
        }
        (global, new)
    }

    /// Matches the part's rim edges with those still open: a match is an
    /// inner edge of the welded mesh (misoriented when both sides traverse
    /// it the same way); the others wait for their other side.
    fn match_rims(&mut self, local: &Local, origins: &Origins) {
        for &(a, b) in &local.rim_edges {
            let (ia, ib) = (origins.ids[a as usize], origins.ids[b as usize]);
            let key = (ia.min(ib), ia.max(ib));
            let forward = ia < ib;
            match self.open.remove(&key) {
                Some(e) => {
                    if e.forward == forward {
                        self.out.topology.misoriented_edges += 1;
                        self.counts[e.piece as usize].3 = false;
                    }
                    self.release(ia);
                    self.release(ib);
                }
                None => {
                    let piece = local.piece[a as usize];
                    self.counts[piece as usize].1 += 1;
                    let on_boundary = origins.on_boundary(a, b);
                    self.open.insert(
                        key,
                        OpenEdge {
                            forward,
                            piece,
                            on_boundary,
                        },
                    );
                    for id in [ia, ib] {
                        if let Some(r) = self.rims.get_mut(&id) {
                            r.open += 1;
                        }
                    }
                }
            }
        }
    }

    /// One rim edge at `id` is matched; the vertex is forgotten with its
    /// last.
    fn release(&mut self, id: VertexId) {
        if let Some(r) = self.rims.get_mut(&id) {
            r.open = r.open.saturating_sub(1);
            if r.open == 0 {
                self.rims.remove(&id);
            }
        }
    }

    /// The welded mesh's figures, and the sink back; rim edges never
    /// matched are boundary edges (open ones unless on ∂Ω).
    pub fn finish(mut self) -> (Stitched, S) {
        let topo = &mut self.out.topology;
        for e in self.open.values() {
            topo.boundary_edges += 1;
            if !e.on_boundary {
                topo.open_edges += 1;
            }
            self.counts[e.piece as usize].3 = false;
        }
        let mut joined: HashMap<u32, Component> = HashMap::default();
        for (i, c) in self.counts.iter().enumerate() {
            let j = joined
                .entry(self.pieces.find(i as u32))
                .or_insert((0, 0, 0, true));
            *j = (j.0 + c.0, j.1 + c.1, j.2 + c.2, j.3 && c.3);
        }
        let comps: Vec<Component> = joined.into_values().collect();
        topo.vertices = self.out.vertices;
        topo.edges = comps.iter().map(|c| c.1 as usize).sum();
        topo.faces = self.out.triangles;
        topo.components = comps.len();
        topo.euler = topo.vertices as i64 - topo.edges as i64 + topo.faces as i64;
        topo.genus = topology::genera(comps);
        topo.watertight = topo.boundary_edges == 0
            && topo.nonmanifold_edges == 0
            && topo.misoriented_edges == 0
            && topo.nonmanifold_vertices == 0;
        (self.out, self.sink)
    }
}
