//! Where each vertex of a mesh part comes from, as a number that any run
//! of the same surface gives it: what bricked meshing welds parts by
//! (`crate::mesher::brick`).
//!
//! # Contract
//!
//! A vertex's [`VertexId`] is a function of the structure that made it,
//! never of an index or a position:
//!
//! - an edge vertex, of the two dual-grid corners of its edge (each named
//!   by its leaf's level and integer position and its mirroring across
//!   ∂Ω), in either order;
//! - an interior vertex of a dual cell, of the octree vertex the cell is
//!   built around and the vertex's number in the cell's MC33 case;
//! - a vertex that splits an edge, of the ids of the edge's ends, in either
//!   order.
//!
//! Two runs that build the same structure (the same leaves around an
//! edge) give the same id; the vertices at one id are at one position,
//! bit for bit. Ids are 128-bit mixes of those parts ([`mix`]): two
//! different structures share an id with probability about `n² / 2¹²⁹`
//! for `n` vertices.
//!
//! A vertex also records the faces of Ω it lies on ([`Sides`]): an edge
//! vertex whose two corners are both mirrored across one face lies on
//! that face; an edge whose two ends share a face lies in it (a boundary
//! edge of the mesh, not a seam between parts).

/// A vertex's id (see the module doc).
pub type VertexId = u128;

/// Faces of Ω a vertex lies on: two bits per axis `k` (bit `2k`: the low
/// face, bit `2k + 1`: the high face), as [`crate::dual::Corner`]'s
/// mirroring.
pub type Sides = u8;

/// Per vertex of a mesh, its id and the faces of Ω it lies on.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Origins {
    /// [`VertexId`] per vertex.
    pub ids: Vec<VertexId>,
    /// [`Sides`] per vertex.
    pub sides: Vec<Sides>,
}

impl Origins {
    /// Records a vertex that splits the edge between vertices `a` and `b`
    /// in split round `round`, on the faces of Ω both lie on. An
    /// edge split in one round is gone from the next, unless a flip
    /// joined its ends again (smoothing, between two rounds): the round
    /// keeps the ids apart.
    pub fn push_split(&mut self, a: u32, b: u32, round: u32) {
        let (ia, ib) = (self.ids[a as usize], self.ids[b as usize]);
        let tag = SPLIT | (u64::from(round) << 8);
        self.ids.push(mix(tag, ia.min(ib), ia.max(ib)));
        self.sides
            .push(self.sides[a as usize] & self.sides[b as usize]);
    }

    /// Whether the edge between vertices `a` and `b` lies in a face of Ω.
    pub fn on_boundary(&self, a: u32, b: u32) -> bool {
        self.sides[a as usize] & self.sides[b as usize] != 0
    }

    /// Keeps the vertices flagged in `keep`, in order.
    pub fn retain(&mut self, keep: &[bool]) {
        super::order::retain(&mut self.ids, keep);
        super::order::retain(&mut self.sides, keep);
    }
}

/// Tag of an edge vertex's id.
pub const EDGE: u64 = 1;
/// Tag of an interior vertex's id.
pub const INTERIOR: u64 = 2;
/// Tag of a split vertex's id.
pub const SPLIT: u64 = 3;
/// Tag of a crease feature point's id (inside one brick: named by the
/// brick and its number there).
pub const CREASE: u64 = 4;
/// Tag of a run's fingerprint (not a vertex: `crate::mesher::brick::run_id`).
pub const RUN: u64 = 5;

/// A 128-bit mix of a tag and two 128-bit parts: two 64-bit lanes, each a
/// chain of the `splitmix64` finaliser over the parts' words with its own
/// seed.
pub fn mix(tag: u64, a: u128, b: u128) -> VertexId {
    let words = [a as u64, (a >> 64) as u64, b as u64, (b >> 64) as u64];
    let lane = |seed: u64| {
        words
            .iter()
            .fold(finalise(seed ^ tag), |h, &w| finalise(h ^ finalise(w)))
    };
    (u128::from(lane(0x9e37_79b9_7f4a_7c15)) << 64) | u128::from(lane(0xd1b5_4a32_d192_ed03))
}

fn finalise(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mixes_separate_tags_parts_and_order() {
        let ids = [
            mix(EDGE, 1, 2),
            mix(EDGE, 2, 1),
            mix(SPLIT, 1, 2),
            mix(EDGE, 1, 3),
            mix(EDGE, 1 << 64, 2),
        ];
        for (i, a) in ids.iter().enumerate() {
            for b in &ids[i + 1..] {
                assert_ne!(a, b);
            }
        }
        assert_eq!(mix(EDGE, 1, 2), mix(EDGE, 1, 2));
    }
}
