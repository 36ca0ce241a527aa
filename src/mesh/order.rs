//! Vertex order for locality: neighbours on the surface near each other in
//! memory.
//!
//! Extraction numbers the vertices by the dual grid's edges and the
//! triangles by its cells, two different orders: the corners of one
//! triangle end up tens of thousands of indices apart, and every stage that
//! walks a vertex's star (edge flips, relaxation, chord splits) misses the
//! cache on almost every read. [`Mesh::reorder`] renumbers the vertices
//! along a Morton (Z-order) curve of their positions and sorts the
//! triangles by their lowest corner, so a star's corners and triangles lie
//! in a few cache lines.
//!
//! # Contract
//!
//! The reordered mesh is the same mesh: the same positions, normals and
//! flags, the same triangles with their corners in the same cyclic order
//! (orientation kept), only numbered differently. The order is a function
//! of the positions and the triangles alone (ties broken by the old index,
//! so it is deterministic), and the caller gets the new index of every old
//! vertex to renumber its own per-vertex data ([`permute`]).
//!
//! # Limits
//!
//! Stages whose choices depend on the order (the greedy colouring of
//! smoothing, the order of edge flips) choose differently after a
//! reorder; their guarantees do not depend on the order.

use glam::DVec3;

use super::Mesh;

/// Bits per axis of the Morton key.
const BITS: u32 = 21;

impl Mesh {
    /// Renumbers the vertices in Morton order of their positions and sorts
    /// the triangles by their lowest corner (see the module doc); returns
    /// the new index of each old vertex.
    pub fn reorder(&mut self) -> Vec<u32> {
        let n = self.positions.len();
        let mut keyed: Vec<(u64, u32)> = morton_keys(&self.positions)
            .into_iter()
            .zip(0..n as u32)
            .collect();
        keyed.sort_unstable();
        let mut new_of_old = vec![0u32; n];
        for (new, &(_, o)) in keyed.iter().enumerate() {
            new_of_old[o as usize] = new as u32;
        }
        permute(&mut self.positions, &new_of_old);
        permute(&mut self.normals, &new_of_old);
        permute(&mut self.ambiguous, &new_of_old);
        for t in &mut self.triangles {
            *t = t.map(|v| new_of_old[v as usize]);
        }
        self.sort_triangles_by_lowest_corner();
        new_of_old
    }

    /// Drops the vertices no triangle uses, keeping the others in order,
    /// and renumbers the triangles; returns which vertices stayed (for the
    /// caller's own per-vertex data, [`retain`]).
    pub fn drop_unused(&mut self) -> Vec<bool> {
        let mut used = vec![false; self.positions.len()];
        for t in &self.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let mut index = vec![u32::MAX; used.len()];
        let mut next = 0u32;
        for (v, &u) in used.iter().enumerate() {
            if u {
                index[v] = next;
                next += 1;
            }
        }
        retain(&mut self.positions, &used);
        retain(&mut self.normals, &used);
        retain(&mut self.ambiguous, &used);
        for t in &mut self.triangles {
            *t = t.map(|v| index[v as usize]);
        }
        used
    }

    /// Sorts the triangles by their lowest corner, stably (a counting
    /// sort: linear in the mesh).
    fn sort_triangles_by_lowest_corner(&mut self) {
        let lowest = |t: &[u32; 3]| t[0].min(t[1]).min(t[2]) as usize;
        let mut start = vec![0u32; self.positions.len() + 1];
        for t in &self.triangles {
            start[lowest(t) + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut sorted = vec![[0u32; 3]; self.triangles.len()];
        for t in &self.triangles {
            let slot = &mut start[lowest(t)];
            sorted[*slot as usize] = *t;
            *slot += 1;
        }
        self.triangles = sorted;
    }
}

/// Moves `data[old]` to `data[new_of_old[old]]`. Empty data (an absent
/// per-vertex array) stays empty; shorter data is first padded with
/// `T::default()` (a flag array that flags nothing past its end).
pub fn permute<T: Copy + Default>(data: &mut Vec<T>, new_of_old: &[u32]) {
    if data.is_empty() {
        return;
    }
    data.resize(new_of_old.len(), T::default());
    let mut out = data.clone();
    for (o, &n) in new_of_old.iter().enumerate() {
        out[n as usize] = data[o];
    }
    *data = out;
}

/// Keeps `data[i]` where `keep[i]`, in order (a vertex filter such as
/// [`crate::mesher::coarsen::coarsen`] returns). Empty data stays empty;
/// entries past the end of `keep` are dropped.
pub fn retain<T>(data: &mut Vec<T>, keep: &[bool]) {
    let mut k = keep.iter();
    data.retain(|_| k.next().copied().unwrap_or(false));
}

/// The Morton key of each point, on a grid of `2^BITS` cells per side over
/// the points' bounding box (0 for non-finite points).
fn morton_keys(points: &[DVec3]) -> Vec<u64> {
    let finite = points.iter().filter(|p| p.is_finite());
    let lo = finite.clone().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = finite.fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    let cells = f64::from((1u32 << BITS) - 1);
    let scale = (hi - lo).max_element();
    let scale = if scale > 0.0 { cells / scale } else { 0.0 };
    points
        .iter()
        .map(|p| {
            if !p.is_finite() {
                return 0;
            }
            let q = ((*p - lo) * scale).clamp(DVec3::ZERO, DVec3::splat(cells));
            spread(q.x as u64) | spread(q.y as u64) << 1 | spread(q.z as u64) << 2
        })
        .collect()
}

/// The low `BITS` bits of `x`, two zero bits between each.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip of `n` quads along x, its vertices numbered in a scrambled
    /// order.
    fn scrambled_strip(n: u32) -> Mesh {
        let count = 2 * (n + 1);
        let scramble = |v: u32| (v * 7919) % count;
        let mut positions = vec![DVec3::ZERO; count as usize];
        for i in 0..=n {
            for j in 0..2 {
                let p = DVec3::new(f64::from(i), f64::from(j), 0.0);
                positions[scramble(2 * i + j) as usize] = p;
            }
        }
        let triangles = (0..n)
            .flat_map(|i| {
                let [a, b, c, d] = [2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3].map(scramble);
                [[a, c, d], [a, d, b]]
            })
            .collect();
        Mesh {
            normals: vec![DVec3::Z; count as usize],
            ambiguous: (0..count).map(|v| v % 3 == 0).collect(),
            positions,
            triangles,
        }
    }

    /// The triangles as position triples, each rotated to start at its
    /// least corner (same cyclic order), sorted.
    fn geometry(m: &Mesh) -> Vec<[[i64; 3]; 3]> {
        let key = |v: u32| m.positions[v as usize].to_array().map(|c| c as i64);
        let mut out: Vec<[[i64; 3]; 3]> = m
            .triangles
            .iter()
            .map(|t| {
                let c = t.map(key);
                let s = (0..3).min_by_key(|&s| c[s]).unwrap();
                [c[s], c[(s + 1) % 3], c[(s + 2) % 3]]
            })
            .collect();
        out.sort();
        out
    }

    #[test]
    fn reorder_keeps_the_mesh_and_brings_corners_together() {
        let before = scrambled_strip(200);
        let span = |m: &Mesh| {
            m.triangles
                .iter()
                .map(|t| t.iter().max().unwrap() - t.iter().min().unwrap())
                .max()
                .unwrap()
        };
        let mut after = before.clone();
        let new_of_old = after.reorder();
        assert_eq!(geometry(&before), geometry(&after));
        for (o, &n) in new_of_old.iter().enumerate() {
            assert_eq!(before.positions[o], after.positions[n as usize]);
            assert_eq!(before.ambiguous[o], after.ambiguous[n as usize]);
        }
        assert!(span(&before) > 100, "the strip starts scrambled");
        assert!(span(&after) <= 8, "span after: {}", span(&after));
        let firsts: Vec<u32> = after
            .triangles
            .iter()
            .map(|t| *t.iter().min().unwrap())
            .collect();
        assert!(firsts.windows(2).all(|w| w[0] <= w[1]));
    }

    #[test]
    fn morton_keys_follow_the_octants() {
        let pts = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
        let k = morton_keys(&pts);
        assert_eq!(k[0], 0);
        assert_eq!(k[1], spread((1 << BITS) - 1));
        assert_eq!(k[2], k[1] << 1);
        assert_eq!(k[3], k[1] << 2);
        assert_eq!(k[4], k[1] | k[2] | k[3]);
    }
}
