//! The built tree: its nodes, the boxes they stand for, and the counts
//! gathered while building.

use glam::DVec3;
use std::sync::Arc;

use super::node::{Kind, Leaf, Node};
use super::octant::Octant;
use crate::eval::Reference;

/// Counts gathered while building.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct OctreeStats {
    /// Number of octree nodes built, leaves included.
    pub nodes: usize,
    /// Leaves proved to hold no surface ([`Leaf::Empty`]).
    pub empty_leaves: usize,
    /// Leaves that may hold surface and passed the topology criterion
    /// ([`Leaf::Surface`]).
    pub surface_leaves: usize,
    /// Leaves whose topology is not guaranteed ([`Leaf::Ambiguous`]).
    pub ambiguous_leaves: usize,
    /// Deepest level of a leaf that may hold surface.
    pub max_level_reached: u8,
}

/// The adaptive octree. See the module doc.
#[derive(Clone)]
pub struct Octree {
    /// All nodes, root first, siblings consecutive (see the module doc's
    /// "Layout").
    pub nodes: Vec<Node>,
    /// Lowest corner of the domain Ω (the root's box).
    pub lo: DVec3,
    /// Highest corner of Ω, exactly as given: the boxes on Ω's high faces
    /// end there ([`Octree::cell_box`]).
    pub hi: DVec3,
    /// Counts gathered while building.
    pub stats: OctreeStats,
    /// Per node, the pruned program that is valid on a leaf's box, when
    /// the leaf's subtree was evaluated with one and the points there are
    /// to be evaluated with it too (see the module doc's "Pruning");
    /// `None`, or past the end of the vector, elsewhere. Empty without
    /// pruning. [`Octree::field`] evaluates with them.
    pub tapes: Vec<Option<Arc<Reference>>>,
    /// The deepest level a leaf may have (the options' `max_level`, at most
    /// [`MAX_LEVEL`](super::MAX_LEVEL)).
    pub max_level: u8,
}

impl Octree {
    /// The leaf whose closed box holds `p` (descent by the splitting
    /// planes of [`Octree::cell_box`]), if `p` is in the domain.
    pub fn leaf_containing(&self, p: DVec3) -> Option<usize> {
        let (a, b) = self.cell_box(self.nodes.first()?);
        if !(p.cmpge(a).all() && p.cmple(b).all()) {
            return None;
        }
        let mut i = 0usize;
        while let Kind::Branch { first_child } = self.nodes[i].kind {
            let (_, split) = self.cell_box(&self.nodes[first_child as usize]);
            i = first_child as usize + usize::from(Octant::containing(p, split).0);
        }
        Some(i)
    }

    /// Extent of Ω along each axis.
    pub fn size(&self) -> DVec3 {
        self.hi - self.lo
    }

    /// The box of a node, by the one formula shared by all nodes: a grid
    /// plane at the fraction `f` of Ω lies at `lo + size · f`, and Ω's high
    /// faces at `hi` itself (where `lo + size` rounds past or short of it,
    /// as `−1.2 + 1.5` does, a box would otherwise leave Ω or miss a sliver
    /// of it, and points put on the face would not lie on it).
    pub fn cell_box(&self, n: &Node) -> (DVec3, DVec3) {
        let scale = (1u64 << n.level) as f64;
        let size = self.size();
        let at = |k: [u32; 3]| {
            DVec3::from_array(std::array::from_fn(|a| {
                let f = k[a] as f64 / scale;
                if f == 1.0 {
                    self.hi[a]
                } else {
                    self.lo[a] + size[a] * f
                }
            }))
        };
        (at(n.ijk), at(n.ijk.map(|k| k + 1)))
    }

    /// The centre of a node's box.
    pub fn center(&self, n: &Node) -> DVec3 {
        let (a, b) = self.cell_box(n);
        (a + b) * 0.5
    }
}

impl OctreeStats {
    /// The counts over `nodes` (a tree's, or the part of one a brick
    /// owns).
    pub(crate) fn over<'a>(nodes: impl IntoIterator<Item = &'a Node>) -> OctreeStats {
        let mut s = OctreeStats::default();
        for n in nodes {
            s.nodes += 1;
            match n.leaf() {
                Some(Leaf::Empty) => s.empty_leaves += 1,
                Some(Leaf::Surface) => s.surface_leaves += 1,
                Some(Leaf::Ambiguous) => s.ambiguous_leaves += 1,
                Some(Leaf::Outside) | None => continue,
            }
            if n.leaf() != Some(Leaf::Empty) {
                s.max_level_reached = s.max_level_reached.max(n.level);
            }
        }
        s
    }
}
