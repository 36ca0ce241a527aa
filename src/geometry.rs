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
}
