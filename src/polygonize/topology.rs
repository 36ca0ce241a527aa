//! Topology of a triangle soup with shared vertex indices: connected
//! components and Euler characteristic `χ = V − E + F`.
//!
//! Vertices are counted only when a triangle uses them; edges are the
//! distinct unordered index pairs of the triangles' sides.

/// Components (of the vertices used by triangles, joined by triangle sides)
/// and Euler characteristic of the triangle set `tris` over vertex ids.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Topology {
    /// Number of connected components.
    pub components: usize,
    /// `V − E + F`.
    pub euler: i64,
}

/// Compute [`Topology`] of triangles given as index triples.
pub fn topology<I: Copy + Into<u64>>(tris: &[[I; 3]]) -> Topology {
    let mut ids: Vec<u64> = tris.iter().flatten().map(|&i| i.into()).collect();
    ids.sort_unstable();
    ids.dedup();
    let idx = |x: I| ids.binary_search(&x.into()).unwrap_or(0);
    let mut parent: Vec<usize> = (0..ids.len()).collect();
    fn find(p: &mut [usize], mut a: usize) -> usize {
        while p[a] != a {
            p[a] = p[p[a]];
            a = p[a];
        }
        a
    }
    let mut edges: Vec<(usize, usize)> = Vec::with_capacity(tris.len() * 3);
    for t in tris {
        let v = [idx(t[0]), idx(t[1]), idx(t[2])];
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b)));
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            if ra != rb {
                parent[ra] = rb;
            }
        }
    }
    edges.sort_unstable();
    edges.dedup();
    let components = (0..ids.len())
        .filter(|&i| find(&mut parent, i) == i)
        .count();
    Topology {
        components,
        euler: ids.len() as i64 - edges.len() as i64 + tris.len() as i64,
    }
}
