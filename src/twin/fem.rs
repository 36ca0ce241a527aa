//! Co-rotational linear triangle elements (Bouthors & Nesme §2.3, after
//! Nesme, Payan & Faure 2005) and the inversion rules of §2.6.
//!
//! # Contract
//!
//! Every element shares one rest shape — the equilateral triangle of edge
//! ê — and so one 6×6 stiffness matrix `K` (constant-strain triangle,
//! plane stress, unit thickness, Young's modulus `E`, Poisson ratio `ν`),
//! computed once ([`Stiffness::new`]). Per step, each element gets a local
//! frame `R = [x̂ ŷ ẑ]`: `x̂` along its first edge `u→v`, `ẑ` its normal,
//! `ŷ = ẑ × x̂`; in that frame the vertices are `u = 0`, `v = (vˣ, 0)`,
//! `w = (wˣ, wʸ)` and the displacement from the rest shape is
//! `d = Rᵀx − x₀ = (0, 0, vˣ − v₀ˣ, 0, wˣ − w₀ˣ, wʸ − w₀ʸ)`. The forces are
//! `f = −R K d` (eq. 2, with `K` positive semi-definite).
//!
//! **Inverted elements** (§2.6.2). A triangle is inverted when its normal
//! disagrees with ∇f at all three vertices. The paper's test, `n·∇F > 0`
//! at every vertex, is written for a field positive inside; ours is
//! positive outside (SPEC §3: outward = increasing f) and our triangles
//! face `+∇f`, so the test here is `n·∇f < 0` at all three vertices
//! ([`inverted`]). An inverted element is re-ordered so that its third
//! vertex has the smallest height (it is the one that crossed), and the
//! vertex is treated as lying at its mirror image `−wʸ` through the base:
//! its `y` displacement becomes `wʸ + w₀ʸ` instead of `wʸ − w₀ʸ`, so the
//! force pulls it back through its base towards the uninverted rest shape.
//! (The paper prints `−wʸ − w₀ʸ` for its convention `f = R K d`; with the
//! element's own frame that sign would push the vertex further away, so we
//! keep the stated intent — fall back to the uninverted state — and test
//! it: `an_inverted_element_is_pushed_back_through_its_base`.)
//!
//! The stiffness of the implicit step (§2.2, eq. 1) is `∂f/∂x ≈ −R K Rᵀ`
//! per element (the rotation's own derivative is neglected, as in
//! co-rotational methods); [`Frames::apply`] computes the product with a
//! vector without assembling a matrix.

use glam::{DMat3, DVec2, DVec3};
use rayon::prelude::*;

use crate::mesh::dynmesh::DynMesh;

/// The shared element: rest shape and stiffness. See the module doc.
#[derive(Clone, Debug)]
pub(crate) struct Stiffness {
    pub k: [[f64; 6]; 6],
    /// Rest coordinates `(u₀, v₀, w₀)` in the element frame.
    pub rest: [DVec2; 3],
}

impl Stiffness {
    /// The CST stiffness of the equilateral triangle of edge `edge`.
    pub fn new(young: f64, poisson: f64, edge: f64) -> Stiffness {
        let h = edge * 3f64.sqrt() / 2.0;
        let rest = [
            DVec2::ZERO,
            DVec2::new(edge, 0.0),
            DVec2::new(edge / 2.0, h),
        ];
        let area = edge * h / 2.0;
        // B = 1/(2A) [[b1 0 b2 0 b3 0], [0 c1 0 c2 0 c3], [c1 b1 c2 b2 c3 b3]]
        // with b_i = y_j − y_k, c_i = x_k − x_j (i, j, k cyclic).
        let mut b = [[0.0; 6]; 3];
        for i in 0..3 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let bi = rest[j].y - rest[k].y;
            let ci = rest[k].x - rest[j].x;
            b[0][2 * i] = bi / (2.0 * area);
            b[1][2 * i + 1] = ci / (2.0 * area);
            b[2][2 * i] = ci / (2.0 * area);
            b[2][2 * i + 1] = bi / (2.0 * area);
        }
        let s = young / (1.0 - poisson * poisson);
        let d = [
            [s, s * poisson, 0.0],
            [s * poisson, s, 0.0],
            [0.0, 0.0, s * (1.0 - poisson) / 2.0],
        ];
        let mut k = [[0.0; 6]; 6];
        for (r, row) in k.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                let mut sum = 0.0;
                for p in 0..3 {
                    for q in 0..3 {
                        sum += b[p][r] * d[p][q] * b[q][c];
                    }
                }
                *v = area * sum;
            }
        }
        Stiffness { k, rest }
    }

    #[inline]
    fn mul(&self, d: &[f64; 6]) -> [f64; 6] {
        let mut out = [0.0; 6];
        for (o, row) in out.iter_mut().zip(&self.k) {
            *o = row.iter().zip(d).map(|(a, b)| a * b).sum();
        }
        out
    }
}

/// `true` when triangle `t` faces against ∇f at all three vertices (see
/// the module doc for the sign convention).
pub fn inverted(mesh: &DynMesh, t: [u32; 3]) -> bool {
    let [a, b, c] = t.map(|v| mesh.pos[v as usize]);
    let n = (b - a).cross(c - a);
    t.iter().all(|&v| n.dot(mesh.grad[v as usize]) < 0.0)
}

/// One element's frame for this step.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frame {
    /// The element's vertices in frame order (`u, v, w`).
    pub verts: [u32; 3],
    pub x: DVec3,
    pub y: DVec3,
}

/// The frames of all live elements for one step.
pub(crate) struct Frames {
    /// Each element's vertices and axes: what the stiffness product reads.
    pub frames: Vec<Frame>,
    /// Each element's local displacement `d` (already modified for
    /// inverted elements), kept apart since only the forces read it.
    pub d: Vec<[f64; 6]>,
}

impl Frames {
    /// Frames and displacements at the mesh's current positions;
    /// `inverted[i]` says whether triangle `i` is inverted.
    pub fn new(mesh: &DynMesh, stiff: &Stiffness, inverted: &[bool]) -> Frames {
        let live: Vec<(u32, [u32; 3])> = mesh.live_tris().collect();
        let (frames, d) = live
            .par_iter()
            .filter_map(|&(i, t)| frame(mesh, stiff, t, inverted[i as usize]))
            .unzip();
        Frames { frames, d }
    }

    /// Elastic forces `f = Σ −R K d` per vertex.
    pub fn forces(&self, stiff: &Stiffness, n: usize) -> Vec<DVec3> {
        let mut f = vec![DVec3::ZERO; n];
        for (fr, d) in self.frames.iter().zip(&self.d) {
            let kd = stiff.mul(d);
            for (k, &v) in fr.verts.iter().enumerate() {
                f[v as usize] -= fr.x * kd[2 * k] + fr.y * kd[2 * k + 1];
            }
        }
        f
    }

    /// `out = Σ R K Rᵀ p` per vertex (the stiffness product).
    pub fn apply(&self, stiff: &Stiffness, p: &[DVec3], out: &mut [DVec3]) {
        out.iter_mut().for_each(|o| *o = DVec3::ZERO);
        for fr in &self.frames {
            let mut local = [0.0; 6];
            for (k, &v) in fr.verts.iter().enumerate() {
                local[2 * k] = fr.x.dot(p[v as usize]);
                local[2 * k + 1] = fr.y.dot(p[v as usize]);
            }
            let kp = stiff.mul(&local);
            for (k, &v) in fr.verts.iter().enumerate() {
                out[v as usize] += fr.x * kp[2 * k] + fr.y * kp[2 * k + 1];
            }
        }
    }
}

impl Frames {
    /// The 3×3 diagonal blocks `Σ R K_vv Rᵀ` of the stiffness, per vertex
    /// (the block-Jacobi preconditioner of the step's solver).
    pub fn diagonal(&self, stiff: &Stiffness, n: usize) -> Vec<DMat3> {
        let mut out = vec![DMat3::ZERO; n];
        for fr in &self.frames {
            for (k, &v) in fr.verts.iter().enumerate() {
                let (i, j) = (2 * k, 2 * k + 1);
                let kx = fr.x * stiff.k[i][i] + fr.y * stiff.k[j][i];
                let ky = fr.x * stiff.k[i][j] + fr.y * stiff.k[j][j];
                // X K_vv Xᵀ with X = [x̂ ŷ]: columns kx x̂ᵀ + ky ŷᵀ.
                out[v as usize] += outer(kx, fr.x) + outer(ky, fr.y);
            }
        }
        out
    }
}

/// The outer product `a bᵀ`.
fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

fn frame(mesh: &DynMesh, stiff: &Stiffness, t: [u32; 3], inv: bool) -> Option<(Frame, [f64; 6])> {
    let p = t.map(|v| mesh.pos[v as usize]);
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    // Order: for an inverted element, the vertex of smallest height (the
    // one opposite the longest edge) goes third.
    let r = if inv {
        let len = |i: usize| p[(i + 1) % 3].distance_squared(p[(i + 2) % 3]);
        (0..3)
            .max_by(|&i, &j| len(i).total_cmp(&len(j)))
            .unwrap_or(0)
    } else {
        2
    };
    let order = [(r + 1) % 3, (r + 2) % 3, r];
    let verts = order.map(|i| t[i]);
    let [u, v, w] = order.map(|i| p[i]);
    let e = v - u;
    let len = e.length();
    if len == 0.0 || !len.is_finite() {
        return None;
    }
    let x = e / len;
    // The element normal; a degenerate element borrows the gradient.
    let z = if n.length_squared() > 1e-24 * len.powi(4) {
        n.normalize()
    } else {
        let g: DVec3 = t.iter().map(|&v| mesh.grad[v as usize]).sum();
        let g = g - x * g.dot(x);
        if g.length_squared() == 0.0 {
            return None;
        }
        g.normalize()
    };
    let y = z.cross(x);
    let wl = DVec2::new((w - u).dot(x), (w - u).dot(y));
    let [_, v0, w0] = stiff.rest;
    let wy = if inv { wl.y + w0.y } else { wl.y - w0.y };
    let d = [0.0, 0.0, len - v0.x, 0.0, wl.x - w0.x, wy];
    Some((Frame { verts, x, y }, d))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stiffness_is_symmetric_and_kills_rigid_motions() {
        let s = Stiffness::new(1000.0, 0.3, 0.7);
        for r in 0..6 {
            for c in 0..6 {
                assert!((s.k[r][c] - s.k[c][r]).abs() < 1e-9 * s.k[0][0].abs());
            }
        }
        // Translations and the infinitesimal rotation give no force.
        let tx = [1.0, 0.0, 1.0, 0.0, 1.0, 0.0];
        let ty = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
        let rot: Vec<f64> = s.rest.iter().flat_map(|p| [-p.y, p.x]).collect();
        for m in [tx, ty, rot.try_into().unwrap()] {
            assert!(s.mul(&m).iter().all(|f| f.abs() < 1e-9 * s.k[0][0]));
        }
        // A stretch does give force.
        let stretch: Vec<f64> = s.rest.iter().flat_map(|p| [p.x, 0.0]).collect();
        assert!(
            s.mul(&stretch.try_into().unwrap())
                .iter()
                .any(|f| f.abs() > 1e-3)
        );
    }

    fn one_triangle(w: DVec3, grad: DVec3) -> DynMesh {
        let mut m = DynMesh::default();
        for p in [DVec3::ZERO, DVec3::X, w] {
            m.add_vertex(p, grad);
        }
        m.add_tri([0, 1, 2]);
        m
    }

    #[test]
    fn rest_shape_has_no_force_and_a_stretched_one_pulls_in() {
        let s = Stiffness::new(1000.0, 0.3, 1.0);
        let rest = DVec3::new(0.5, 3f64.sqrt() / 2.0, 0.0);
        let m = one_triangle(rest, DVec3::Z);
        let fr = Frames::new(&m, &s, &[false]);
        assert!(fr.forces(&s, 3).iter().all(|f| f.length() < 1e-9));
        // Third vertex pulled away: its force points back.
        let m = one_triangle(rest * 1.5, DVec3::Z);
        let fr = Frames::new(&m, &s, &[false]);
        let f = fr.forces(&s, 3);
        assert!(f[2].dot(rest) < 0.0);
        // Total force and torque vanish.
        assert!(f.iter().sum::<DVec3>().length() < 1e-9);
    }

    #[test]
    fn an_inverted_element_is_pushed_back_through_its_base() {
        let s = Stiffness::new(1000.0, 0.3, 1.0);
        // Vertex 2 crossed below the base: the triangle faces −z, the
        // surface normal is +z.
        let m = one_triangle(DVec3::new(0.5, -0.3, 0.0), DVec3::Z);
        let t = m.tris[0];
        assert!(inverted(&m, t));
        let fr = Frames::new(&m, &s, &[true]);
        let f = fr.forces(&s, 3);
        assert!(
            f[2].y > 0.0,
            "force {:?} must push the vertex back up",
            f[2]
        );
        // Unmodified, the element would be at rest in its flipped frame.
        let fr = Frames::new(&m, &s, &[false]);
        let f0 = fr.forces(&s, 3);
        assert!(f0[2].y <= 0.0 || f0[2].y < f[2].y);
    }
}
