//! The dual grid of an octree (Schaefer & Warren, *Dual marching cubes*,
//! 2004; Paiva et al. §4.2).
//!
//! # Contract
//!
//! Every vertex of the octree's cell complex gives one dual cell: the 8
//! leaves around it, listed in the marching-cubes corner order (corner `i`
//! is on the low/high side of the vertex along x, y, z by bits `i&1`,
//! `(i>>1)&1`, `(i>>2)&1`). Where leaves of different levels meet, one leaf
//! fills several corners: the dual cell is a degenerate cube with repeated
//! corners.
//!
//! **Boundary.** The leaf centres alone span less than Ω: a strip half a
//! leaf wide along ∂Ω would be lost, and with it any surface there. So the
//! octree is surrounded by *ghost* leaves: the mirror image of each leaf
//! that touches ∂Ω, flattened onto ∂Ω — its "centre" is the leaf's centre
//! projected onto the face (edge, corner) of Ω. A [`Corner`] is a leaf plus
//! the set of boundary sides it is mirrored across. With the ghosts, the
//! dual cells tile Ω exactly once: a closed surface anywhere inside Ω is
//! meshed closed, and a surface that leaves Ω is cut exactly on ∂Ω.
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

use glam::DVec3;

use crate::octree::{Leaf, MAX_LEVEL, Node, Octant, Octree};

/// A dual-cell corner: a leaf, or a ghost of a leaf mirrored across the
/// domain's boundary. `mirror` holds two bits per axis `k` (bits `2k`,
/// `2k+1`): 0 = not mirrored, 1 = mirrored across the low face, 2 = across
/// the high face.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Corner {
    /// Index of the leaf in [`Octree::nodes`].
    pub node: u32,
    /// Mirroring across ∂Ω, two bits per axis (see above); 0 for a real leaf.
    pub mirror: u8,
}

impl Corner {
    /// A real leaf.
    pub fn leaf(node: u32) -> Corner {
        Corner { node, mirror: 0 }
    }

    /// True for a ghost.
    pub fn is_ghost(self) -> bool {
        self.mirror != 0
    }

    /// Which axes are mirrored, as a bit mask over `x y z`.
    fn axes(self) -> usize {
        (0..3)
            .filter(|k| (self.mirror >> (2 * k)) & 3 != 0)
            .fold(0, |m, k| m | (1 << k))
    }

    /// The dual vertex: the leaf's centre, projected onto ∂Ω along the
    /// mirrored axes.
    pub fn position(self, tree: &Octree) -> DVec3 {
        let mut p = tree.center(&tree.nodes[self.node as usize]);
        for k in 0..3 {
            match (self.mirror >> (2 * k)) & 3 {
                1 => p[k] = tree.lo[k],
                2 => p[k] = tree.hi[k],
                _ => {}
            }
        }
        p
    }

    /// A single dense number for the corner (for keys and sorting).
    pub fn id(self) -> u64 {
        (self.node as u64) | ((self.mirror as u64) << 32)
    }
}

/// The octree vertex a dual cell is built around, in units of a
/// maximal-level cell (each coordinate in `[0, 2^MAX_LEVEL]`): along each
/// axis, the highest low face among its corners' boxes (a ghost's box
/// mirrored across ∂Ω). The corners on the vertex's high side start there
/// and the others end there, so this is the vertex itself.
pub fn vertex(tree: &Octree, cell: &DualCell) -> [u64; 3] {
    let n = 1i64 << MAX_LEVEL;
    std::array::from_fn(|k| {
        let low_face = |c: &Corner| {
            let [lo, hi] = tree.nodes[c.node as usize].grid_box();
            let (lo, hi) = (lo[k] as i64, hi[k] as i64);
            match (c.mirror >> (2 * k)) & 3 {
                1 => -hi,
                2 => 2 * n - hi,
                _ => lo,
            }
        };
        let v = cell.iter().map(low_face).max().unwrap_or(0);
        v.clamp(0, n) as u64
    })
}

/// A dual-grid corner's name in any tree of the same domain: its leaf's
/// level and integer position, and its mirroring (a total order, and the
/// parts of [`crate::mesh::origin`]'s ids).
pub fn global(tree: &Octree, c: Corner) -> u128 {
    let n = &tree.nodes[c.node as usize];
    let [i, j, k] = n.ijk.map(u128::from);
    (u128::from(n.level) << 72) | (i << 48) | (j << 24) | (k << 8) | u128::from(c.mirror)
}

/// Two corners in the order of their names in any tree ([`global`]), so
/// that work along the segment between them (bisection, sign samples) runs
/// the same way in a brick's tree as in the whole one.
pub fn in_name_order(tree: &Octree, (a, b): (Corner, Corner)) -> (Corner, Corner) {
    if global(tree, a) <= global(tree, b) {
        (a, b)
    } else {
        (b, a)
    }
}

/// A dual cell: 8 corners in corner order (see the module doc).
pub(crate) type DualCell = [Corner; 8];

struct Walker<'a, F: FnMut(DualCell)> {
    nodes: &'a [Node],
    emit: F,
}

impl<F: FnMut(DualCell)> Walker<'_, F> {
    fn leaf(&self, n: Corner) -> bool {
        self.nodes[n.node as usize].is_leaf()
    }

    /// Whether `n` is unexplored (a brick's tree): every dual cell with
    /// it as a corner lies outside the brick, and is skipped.
    fn outside(&self, n: Corner) -> bool {
        self.nodes[n.node as usize].leaf() == Some(Leaf::Outside)
    }

    /// Child `c` of `n`, or `n` itself when it is a leaf. A ghost's
    /// children mirror the real node's: flipped along the mirrored axes.
    fn child(&self, n: Corner, c: usize) -> Corner {
        match self.nodes[n.node as usize].child(Octant((c ^ n.axes()) as u8)) {
            Some(node) => Corner {
                node,
                mirror: n.mirror,
            },
            None => n,
        }
    }

    fn cell(&mut self, n: Corner) {
        if self.leaf(n) {
            return;
        }
        let c: [Corner; 8] = std::array::from_fn(|i| self.child(n, i));
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
    fn face(&mut self, a: Corner, b: Corner, axis: usize) {
        if (self.leaf(a) && self.leaf(b)) || self.outside(a) || self.outside(b) {
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
        let v: [Corner; 8] = std::array::from_fn(|i| {
            // Flip along `axis` only: the vertex is mid-face for a and b.
            let n = if i & bit != 0 { b } else { a };
            self.child(n, i ^ bit)
        });
        self.vert(v);
    }

    /// The edge along `axis` between four nodes; `n[k]` lies on the low or
    /// high side of the edge along the other two axes `(p, q)` by bits
    /// `k&1`, `k>>1`.
    fn edge(&mut self, n: [Corner; 4], axis: usize) {
        if n.iter().all(|&k| self.leaf(k)) || n.iter().any(|&k| self.outside(k)) {
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
        let v: [Corner; 8] = std::array::from_fn(|i| {
            // Flip across the edge (p, q), not along it: the vertex is the
            // edge's midpoint for all four nodes.
            let k = ((i >> p) & 1) | (((i >> q) & 1) << 1);
            self.child(n[k], i ^ ((1 << p) | (1 << q)))
        });
        self.vert(v);
    }

    /// The vertex shared by eight nodes, `n[i]` in octant `i` around it.
    fn vert(&mut self, n: [Corner; 8]) {
        if n.iter().any(|&k| self.outside(k)) {
            return;
        }
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

/// Calls `emit` once for every dual cell of `tree`, ghost cells along ∂Ω
/// included, but those with an unexplored corner ([`Leaf::Outside`], a
/// brick's tree: such a cell lies outside the brick, and the walk skips
/// the faces, edges and vertices that touch one).
pub fn for_each_cell(tree: &Octree, emit: impl FnMut(DualCell)) {
    let mut w = Walker {
        nodes: &tree.nodes,
        emit,
    };
    let root = Corner::leaf(0);
    // The root's ghost across the given sides: `sides[k]` is 0 (none),
    // 1 (low) or 2 (high).
    let ghost = |sides: [u8; 3]| Corner {
        node: 0,
        mirror: sides[0] | (sides[1] << 2) | (sides[2] << 4),
    };
    w.cell(root);
    for axis in 0..3 {
        let mut lo = [0u8; 3];
        lo[axis] = 1;
        let mut hi = [0u8; 3];
        hi[axis] = 2;
        w.face(ghost(lo), root, axis);
        w.face(root, ghost(hi), axis);
    }
    // The 12 edges of Ω: along `axis`, on sides (sp, sq) of the others.
    for axis in 0..3 {
        let (p, q) = others(axis);
        for sp in [1u8, 2] {
            for sq in [1u8, 2] {
                let n4 = std::array::from_fn(|k| {
                    // n[k] is on the low/high side of the edge along p, q
                    // by the bits of k; the side towards the outside is the
                    // ghost, the side towards Ω is the root.
                    let mut sides = [0u8; 3];
                    let (bp, bq) = ((k & 1) as u8, (k >> 1) as u8);
                    if (sp == 1) == (bp == 0) {
                        sides[p] = sp;
                    }
                    if (sq == 1) == (bq == 0) {
                        sides[q] = sq;
                    }
                    ghost(sides)
                });
                w.edge(n4, axis);
            }
        }
    }
    // The 8 corners of Ω.
    for corner in 0..8usize {
        let n8 = std::array::from_fn(|i| {
            let mut sides = [0u8; 3];
            for (k, side) in sides.iter_mut().enumerate() {
                let c = (corner >> k) & 1; // 0: Ω's low corner along k
                let b = (i >> k) & 1; // octant side around the vertex
                if b == c {
                    // On the outside of Ω along k.
                    *side = if c == 0 { 1 } else { 2 };
                }
            }
            ghost(sides)
        });
        w.vert(n8);
    }
}
