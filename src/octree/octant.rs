//! Octants: which of a node's 8 children, or of a box's 8 corners.
//!
//! Bit `k` of an [`Octant`] says the high half (or side) along axis `k`
//! (`x = 0, y = 1, z = 2`); the children of a node are stored in octant
//! order (see the octree's "Layout"), and so are a box's corners here.

use glam::DVec3;

/// A child of a node, or a corner of a box: bit `k` set is the high side
/// along axis `k`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Octant(pub u8);

impl Octant {
    /// The 8 octants in storage order.
    pub const ALL: [Octant; 8] = [
        Octant(0),
        Octant(1),
        Octant(2),
        Octant(3),
        Octant(4),
        Octant(5),
        Octant(6),
        Octant(7),
    ];

    /// 1 on the high side along `axis`, else 0.
    pub fn bit(self, axis: usize) -> u32 {
        u32::from((self.0 >> axis) & 1)
    }

    /// The octant whose bits are `high[k]` along each axis.
    pub fn from_sides(high: [bool; 3]) -> Octant {
        Octant((0..3).fold(0, |o, k| o | (u8::from(high[k]) << k)))
    }

    /// The integer position of this child of the node at `ijk`.
    pub fn child_ijk(self, ijk: [u32; 3]) -> [u32; 3] {
        std::array::from_fn(|k| 2 * ijk[k] + self.bit(k))
    }

    /// Per axis, `lo[k]` on the low side and `hi[k]` on the high side: the
    /// corner of the box `[lo, hi]`, or (with `hi` the midpoint) the low
    /// corner of a child box.
    pub fn pick(self, lo: DVec3, hi: DVec3) -> DVec3 {
        DVec3::from_array(std::array::from_fn(|k| {
            if self.bit(k) == 0 { lo[k] } else { hi[k] }
        }))
    }

    /// This child's box of the box `[a, b]` split at `m`.
    pub fn sub_box(self, a: DVec3, m: DVec3, b: DVec3) -> (DVec3, DVec3) {
        (self.pick(a, m), self.pick(m, b))
    }

    /// The child of a box split at `split` that holds `p` (a coordinate on
    /// a splitting plane goes high).
    pub fn containing(p: DVec3, split: DVec3) -> Octant {
        Octant::from_sides(std::array::from_fn(|k| p[k] >= split[k]))
    }

    /// The child holding the deepest-level cell `ijk` below a node
    /// `shift + 1` levels up: bit `shift` of each coordinate.
    pub fn of_cell(ijk: [u64; 3], shift: u8) -> Octant {
        Octant::from_sides(std::array::from_fn(|k| (ijk[k] >> shift) & 1 == 1))
    }
}
