//! The dual grid of an octree (Schaefer & Warren, *Dual marching cubes*,
//! 2004; Paiva et al. §4.2).
//!
//! # Contract
//!
//! Every vertex of the octree's cell complex that is interior to the domain
//! and shared by leaves gives one dual cell: the 8 leaves around it, listed
//! in the marching-cubes corner order (corner `i` is on the low/high side of
//! the vertex along x, y, z by bits `i&1`, `(i>>1)&1`, `(i>>2)&1`). Where
//! leaves of different levels meet, one leaf fills several corners: the
//! dual cell is a degenerate cube with repeated corners. The dual cells
//! cover the box spanned by the leaf centres exactly once, so polygonising
//! them all gives a crack-free surface there. The strip between the
//! outermost leaf centres and ∂Ω (half a leaf wide) is not covered: a
//! surface that leaves Ω is cut there, with a clean open boundary.
//!
//! # Method
//!
//! The recursive `cellProc / faceProc / edgeProc / vertProc` traversal:
//! `cellProc` visits a node's children, the 12 faces, 6 edges and 1 vertex
//! between them; `faceProc` the 4 sub-faces, 4 edges and 1 vertex of a face
//! between two nodes; `edgeProc` the 2 sub-edges and 1 vertex of an edge
//! between four nodes; `vertProc` emits the dual cell once all eight nodes
//! around a vertex are leaves, descending into the children that touch the
//! vertex otherwise. No neighbour pointers are needed. Recursion depth is
//! bounded by the octree's depth ([`crate::octree::MAX_LEVEL`]).

use crate::octree::{Node, Octree};

/// A dual cell: 8 leaf indices in corner order (see the module doc).
pub type DualCell = [u32; 8];

struct Walker<'a, F: FnMut(DualCell)> {
    nodes: &'a [Node],
    emit: F,
}

impl<F: FnMut(DualCell)> Walker<'_, F> {
    fn leaf(&self, n: u32) -> bool {
        self.nodes[n as usize].is_leaf()
    }

    /// Child `c` of `n`, or `n` itself when it is a leaf.
    fn child(&self, n: u32, c: usize) -> u32 {
        let node = &self.nodes[n as usize];
        if node.is_leaf() {
            n
        } else {
            node.first_child + c as u32
        }
    }

    fn cell(&mut self, n: u32) {
        if self.leaf(n) {
            return;
        }
        let c: [u32; 8] = std::array::from_fn(|i| self.child(n, i));
        for &k in &c {
            self.cell(k);
        }
        for axis in 0..3 {
            let bit = 1 << axis;
            for i in (0..8).filter(|i| i & bit == 0) {
                self.face(c[i], c[i | bit], axis);
            }
        }
        for axis in 0..3 {
            let (p, q) = others(axis);
            for s in 0..2 {
                let base = s << axis;
                let n4 = std::array::from_fn(|k| c[base | ((k & 1) << p) | ((k >> 1) << q)]);
                self.edge(n4, axis);
            }
        }
        self.vert(c);
    }

    /// The face between `a` (low side along `axis`) and `b` (high side).
    fn face(&mut self, a: u32, b: u32, axis: usize) {
        if self.leaf(a) && self.leaf(b) {
            return;
        }
        let (p, q) = others(axis);
        let bit = 1 << axis;
        // Children touching the face: a's high side, b's low side.
        for k in 0..4 {
            let at = ((k & 1) << p) | ((k >> 1) << q);
            let (ca, cb) = (self.child(a, bit | at), self.child(b, at));
            self.face(ca, cb, axis);
        }
        // The 4 edges inside the face: two halves of the line along p (in
        // the middle along q), two halves of the line along q.
        for (e, c) in [(p, q), (q, p)] {
            let (ep, eq) = others(e);
            for s in 0..2 {
                let n4 = std::array::from_fn(|k| {
                    let mut pos = [0usize; 3];
                    pos[ep] = k & 1;
                    pos[eq] = k >> 1;
                    // Along `axis`: low side is a's child touching the face.
                    let (n, face_bit) = if pos[axis] == 1 { (b, 0) } else { (a, bit) };
                    self.child(n, face_bit | (pos[c] << c) | (s << e))
                });
                self.edge(n4, e);
            }
        }
        let v: [u32; 8] = std::array::from_fn(|i| {
            // Flip along `axis` only: the vertex is mid-face for a and b.
            let n = if i & bit != 0 { b } else { a };
            self.child(n, i ^ bit)
        });
        self.vert(v);
    }

    /// The edge along `axis` between four nodes; `n[k]` lies on the low or
    /// high side of the edge along the other two axes `(p, q)` by bits
    /// `k&1`, `k>>1`.
    fn edge(&mut self, n: [u32; 4], axis: usize) {
        if n.iter().all(|&k| self.leaf(k)) {
            return;
        }
        let (p, q) = others(axis);
        for s in 0..2 {
            let sub = std::array::from_fn(|k| {
                // The child of n[k] next to the edge: opposite side along p
                // and q, side `s` along the edge.
                let idx = ((1 - (k & 1)) << p) | ((1 - (k >> 1)) << q) | (s << axis);
                self.child(n[k], idx)
            });
            self.edge(sub, axis);
        }
        let v: [u32; 8] = std::array::from_fn(|i| {
            // Flip across the edge (p, q), not along it: the vertex is the
            // edge's midpoint for all four nodes.
            let k = ((i >> p) & 1) | (((i >> q) & 1) << 1);
            self.child(n[k], i ^ ((1 << p) | (1 << q)))
        });
        self.vert(v);
    }

    /// The vertex shared by eight nodes, `n[i]` in octant `i` around it.
    fn vert(&mut self, n: [u32; 8]) {
        if n.iter().all(|&k| self.leaf(k)) {
            (self.emit)(n);
            return;
        }
        let sub = std::array::from_fn(|i| self.child(n[i], i ^ 7));
        self.vert(sub);
    }
}

/// The two axes other than `axis`, in increasing order.
fn others(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Calls `emit` once for every dual cell of `tree`.
pub fn for_each_cell(tree: &Octree, emit: impl FnMut(DualCell)) {
    let mut w = Walker {
        nodes: &tree.nodes,
        emit,
    };
    w.cell(0);
}
