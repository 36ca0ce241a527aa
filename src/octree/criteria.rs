//! The interval criteria that decide a cell's fate, from one
//! interval-gradient evaluation over the cell (Paiva et al. §4.1).
//!
//! | criterion | test on `(F(B), ∇F(B))` | consequence |
//! |---|---|---|
//! | connected component | `0 ∉ F(B)`, `F` defined on all of `B` | the cell holds no surface: discard |
//! | topology (paper) | `(0,0,0) ∈ ∇F(B)` | subdivide; ambiguous at the last level |
//! | topology (`certify`) | `0 ∈ Σ ∂ᵢF(B) ⊗ ∂ᵢF(B)` with the two factors independent | subdivide; ambiguous at the last level |
//! | geometry | `Diam(∇F(B)/‖∇F(B)‖) > k_max` | subdivide (not a guarantee) |
//!
//! *What each topology test guarantees.* The paper's test only certifies
//! that `∇F` does not vanish on the cell, so the surface there is a smooth
//! 2-manifold without singular points; it does not bound how much the
//! normal turns. The stricter "small normal variation" test of Plantinga &
//! Vegter (SGP 2004) certifies `⟨∇F(p), ∇F(q)⟩ > 0` for every pair of
//! points `p, q` of the cell — all normals lie in one open half-space — so
//! the surface is a graph over a plane inside the cell: it meets the cell
//! in disks without folds, which is what their isotopy argument builds on.
//! Neither test is applied where `F` is not defined and continuous on the
//! whole cell (SPEC §1 domain rules): such a cell is never discarded and
//! never guaranteed.

use crate::eval::grad::GradEval;
use crate::interval::{self, Interval};
use crate::ir::{BinOp, UnOp};

/// Which topology test the octree applies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TopologyTest {
    /// Paiva et al. §4.1: `(0,0,0) ∉ ∇F(B)`.
    #[default]
    Paper,
    /// Plantinga & Vegter's small normal variation: `0 ∉ ⟨∇F(B), ∇F(B)⟩`.
    Certify,
}

/// The verdict on one cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Verdict {
    /// The interval proves that the cell holds no surface.
    pub empty: bool,
    /// The topology test passed (and `F` is defined on the whole cell).
    pub topology_ok: bool,
    /// The geometry test passed (normal variation within `k_max`).
    pub geometry_ok: bool,
}

fn contains_zero(i: Interval) -> bool {
    i.lo <= 0.0 && 0.0 <= i.hi
}

/// Applies the three criteria to one evaluation.
pub fn judge(g: &GradEval, test: TopologyTest, kmax: f64) -> Verdict {
    // Written so that a NaN bound (which a sound kernel never returns) can
    // never discard a cell.
    let empty = g.defined && (g.value.lo > 0.0 || g.value.hi < 0.0);
    if empty || !g.defined {
        return Verdict {
            empty,
            topology_ok: false,
            geometry_ok: false,
        };
    }
    let topology_ok = match test {
        TopologyTest::Paper => !g.grad.iter().all(|c| contains_zero(*c)),
        TopologyTest::Certify => {
            let mut dot = Interval { lo: 0.0, hi: 0.0 };
            for c in g.grad {
                // Two independent factors: a general product, not a square.
                let (p, _) = interval::binary(BinOp::Mul, c, c);
                dot = interval::binary(BinOp::Add, dot, p).0;
            }
            !contains_zero(dot)
        }
    };
    let geometry_ok = topology_ok && normal_spread(g.grad) <= kmax;
    Verdict {
        empty: false,
        topology_ok,
        geometry_ok,
    }
}

/// `Diam(∇F(B)/‖∇F(B)‖)` with the paper's `Diam(Ix, Iy, Iz) = max |Iᵢ|`,
/// the largest width of the box that encloses the unit normals over the
/// cell (Paiva et al. §4.1, geometry criterion). Infinite when the
/// gradient's norm interval reaches 0.
pub fn normal_spread(grad: [Interval; 3]) -> f64 {
    let mut norm2 = Interval { lo: 0.0, hi: 0.0 };
    for c in grad {
        let (s, _) = interval::unary(UnOp::Square, c);
        norm2 = interval::binary(BinOp::Add, norm2, s).0;
    }
    let (norm, _) = interval::unary(UnOp::Sqrt, norm2);
    if !(norm.lo > 0.0) {
        return f64::INFINITY;
    }
    let mut widest = 0.0f64;
    for c in grad {
        let (n, _) = interval::binary(BinOp::Div, c, norm);
        let w = n.hi - n.lo;
        if !w.is_finite() {
            return f64::INFINITY;
        }
        widest = widest.max(w);
    }
    widest
}
