//! Geometry shared by every stage: the axis-aligned box ([`Bounds`]) that is
//! a surface's domain, an octree cell or an evaluation box.
//!
//! Points and vectors elsewhere are `glam` types; a `Bounds` is kept as two
//! `[f64; 3]` corners so it converts to intervals side by side.

use crate::interval::Interval;

/// An axis-aligned box `[lo, hi]` in space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// The low corner.
    pub lo: [f64; 3],
    /// The high corner.
    pub hi: [f64; 3],
}

impl Bounds {
    /// The box's sides as intervals `[x, y, z]`.
    pub fn sides(&self) -> [Interval; 3] {
        std::array::from_fn(|k| Interval {
            lo: self.lo[k],
            hi: self.hi[k],
        })
    }

    /// Whether the point `p` lies in the closed box (a NaN coordinate does
    /// not).
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|k| self.lo[k] <= p[k] && p[k] <= self.hi[k])
    }

    /// The faces of the box the point `p` lies on, exactly (no tolerance:
    /// the mesher puts a point on a face by giving it the face's
    /// coordinate): two bits per axis `k`, bit `2k` for the low face and
    /// bit `2k + 1` for the high one (as [`crate::mesh::origin::Sides`]).
    pub fn faces(&self, p: [f64; 3]) -> u8 {
        (0..3)
            .map(|k| {
                u8::from(p[k] == self.lo[k]) << (2 * k)
                    | u8::from(p[k] == self.hi[k]) << (2 * k + 1)
            })
            .sum()
    }
}
