//! What a node of the octree is: a branch or a leaf and how it ended, its
//! level and integer position, and the region a brick builds.

use super::Octant;

/// How a leaf ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Leaf {
    /// Proved by the interval to contain no surface.
    Empty,
    /// May contain surface; the topology criterion held.
    Surface,
    /// May contain surface; the topology criterion still failed at the
    /// maximal level, or `F` is not defined everywhere on the cell.
    Ambiguous,
    /// Not explored: the cell does not touch the [`Region`] the tree was
    /// built for ([`Octree::build_region`](super::Octree::build_region); bricked meshing only). Nothing
    /// is known of it.
    Outside,
}

/// A closed box of the domain in units of a [`MAX_LEVEL`] cell (each
/// coordinate in `[0, 2^MAX_LEVEL]`): the part of Ω a brick needs
/// ([`Octree::build_region`](super::Octree::build_region)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// Lowest corner.
    pub lo: [u64; 3],
    /// Highest corner (closed).
    pub hi: [u64; 3],
}

impl Region {
    /// Whether the closed box of node `n` meets the region.
    pub fn meets(&self, n: &Node) -> bool {
        let [lo, hi] = n.grid_box();
        (0..3).all(|k| lo[k] <= self.hi[k] && hi[k] >= self.lo[k])
    }
}

/// What a node is: subdivided, or a leaf and how it ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Subdivided: its 8 children are consecutive from `first_child`, in
    /// [`Octant`] order.
    Branch {
        /// Index of the first child.
        first_child: u32,
    },
    /// A leaf. (While the tree is built, a node not judged yet is an
    /// ambiguous leaf: never discarded, never guaranteed.)
    Leaf(Leaf),
}

/// One octree node. See the module doc for the layout.
#[derive(Clone, Copy, Debug)]
pub struct Node {
    /// Subdivided or a leaf.
    pub kind: Kind,
    /// Depth in the tree: 0 for the root (Ω), `l` for a cell of side
    /// `size / 2^l`.
    pub level: u8,
    /// Integer position of the cell in the level's grid, each in `[0, 2^level)`.
    pub ijk: [u32; 3],
}

impl Node {
    /// A node not judged yet (see [`Kind::Leaf`]).
    pub(super) fn open(level: u8, ijk: [u32; 3]) -> Node {
        Node {
            kind: Kind::Leaf(Leaf::Ambiguous),
            level,
            ijk,
        }
    }

    /// Whether the node has no children.
    pub fn is_leaf(&self) -> bool {
        matches!(self.kind, Kind::Leaf(_))
    }

    /// How a leaf ended; `None` for a subdivided node.
    pub fn leaf(&self) -> Option<Leaf> {
        match self.kind {
            Kind::Leaf(l) => Some(l),
            Kind::Branch { .. } => None,
        }
    }

    /// The node's closed box in units of a [`MAX_LEVEL`] cell: its low and
    /// high corners.
    pub fn grid_box(&self) -> [[u64; 3]; 2] {
        let shift = MAX_LEVEL - self.level.min(MAX_LEVEL);
        let lo = self.ijk.map(|k| u64::from(k) << shift);
        [lo, lo.map(|k| k + (1u64 << shift))]
    }

    /// Index of child `o`, if the node is subdivided.
    pub fn child(&self, o: Octant) -> Option<u32> {
        match self.kind {
            Kind::Branch { first_child } => Some(first_child + u32::from(o.0)),
            Kind::Leaf(_) => None,
        }
    }
}

/// Deepest level allowed: integer positions must fit in `u32` with room.
pub const MAX_LEVEL: u8 = 20;
