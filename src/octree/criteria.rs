//! The interval criteria that decide a cell's fate, from one
//! interval-gradient evaluation over the cell (Paiva et al. §4.1).
//!
//! | criterion | test on `(F(B), ∇F(B))` | consequence |
//! |---|---|---|
//! | connected component | `0 ∉ F(B)`, `F` defined on all of `B` | the cell holds no surface: discard |
//! | topology (paper) | `(0,0,0) ∈ ∇F(B)` | subdivide; ambiguous at the last level |
//! | topology on ∂Ω (a cell on a face or an edge of Ω that `F` may cross, [`boundary_holds`]) | both components of `∇F(B)` along the face, or the one along the edge, hold 0 | subdivide; ambiguous at the last level |
//! | topology (`certify`) | `0 ∈ Σ ∂ᵢF(B) ⊗ ∂ᵢF(B)` with the two factors independent | subdivide; ambiguous at the last level |
//! | topology along `d` (paper's test, last level, across a crease: `super::crease`) | `0 ∈ d·∇F(B)`, `d` the sign pattern of `∇F(B)` | ambiguous |
//! | geometry | `Diam(∇F(B)/‖∇F(B)‖) > k_max` | subdivide (not a guarantee) |
//! | chord (faithful `--level`) | estimated chord error of a mesh through the cell `> τ` ([`chord_error`]) | subdivide (not a guarantee) |
//!
//! A cell that fails the topology or geometry test on its own enclosure,
//! where `F` is differentiable, is judged again on the enclosures over its
//! 8 and then its 64 pieces ([`judge_by_pieces`]), which interval
//! arithmetic's dependency problem widens half and a quarter as much: the
//! same tests on tighter enclosures of the same gradient, so a cell they
//! pass is certified exactly as if its own enclosure had passed.
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
use crate::interval::Interval;
use crate::ir::BinOp;

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
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Verdict {
    /// The interval proves that the cell holds no surface.
    pub empty: bool,
    /// The topology test passed (and `F` is defined on the whole cell).
    pub topology_ok: bool,
    /// The geometry test passed (normal variation within `k_max`).
    pub geometry_ok: bool,
    /// `F` is defined and continuous on the whole cell (SPEC §1 domain
    /// rules): the topology test may be applied.
    pub defined: bool,
    /// `F` is also differentiable on the whole cell (no `min`/`max`
    /// crease, no `abs` fold): enclosures over pieces of the cell may
    /// prove what the cell's own cannot ([`judge_by_pieces`]); across a
    /// crease they seldom do (the hull of two faces' gradients often holds
    /// the zero vector, however small the piece).
    pub smooth: bool,
    /// The enclosure of `∇F` over the whole cell that the verdict was
    /// judged from (the whole line where the value alone decided).
    pub grad: [Interval; 3],
    /// `F` is `±|A|` on the cell, `A` affine: two solids share a face
    /// there, along which `F` touches 0 without changing sign, and no
    /// finer cell decides more (`super::crease`): an ambiguous leaf at
    /// once.
    pub sheet: bool,
}

impl Verdict {
    /// The tests that decide a surface leaf passed: the topology test, and
    /// above the last level the geometry test too.
    pub fn passed(&self, last_level: bool) -> bool {
        self.topology_ok && (self.geometry_ok || last_level)
    }
}

/// The mean-value form of `F` over a cell (Moore 1966; the centred form
/// of interval analysis): `f(B) ⊆ F(c) + Σᵢ ∂ᵢF(B)·(Bᵢ − cᵢ)` for `F`
/// differentiable on `B`, with `F(c)` the interval value at the centre.
/// Its width shrinks quadratically with the cell, so on small cells it
/// proves emptiness where the natural extension `F(B)` cannot.
pub(crate) fn mean_value_form(
    fc: Interval,
    grad: [Interval; 3],
    cell: [Interval; 3],
    c: [f64; 3],
) -> Interval {
    let mut acc = fc;
    for k in 0..3 {
        let point = Interval { lo: c[k], hi: c[k] };
        let (offset, _) = crate::ir::semantics::enclose_binary(BinOp::Sub, cell[k], point);
        let (term, _) = crate::ir::semantics::enclose_binary(BinOp::Mul, grad[k], offset);
        acc = crate::ir::semantics::enclose_binary(BinOp::Add, acc, term).0;
    }
    acc
}

/// Applies the three criteria to one evaluation. `value_defined` says
/// whether `F` itself is defined and continuous on the whole cell;
/// `g.defined` may be false for a merely non-differentiable `F` (a `min`
/// crease, `sqrt` at 0), whose gradient enclosure then encloses the
/// generalised (Clarke) gradient — the hull of the one-sided gradients —
/// which is what the topology and geometry tests need. `mean_value`, when
/// given, is a second enclosure of `F` over the cell (see
/// [`mean_value_form`]), valid only where `F` is differentiable.
pub(crate) fn judge(
    g: &GradEval,
    value_defined: bool,
    mean_value: Option<Interval>,
    test: TopologyTest,
    kmax: f64,
) -> Verdict {
    // A NaN bound (which a sound kernel never returns) never discards a
    // cell nor certifies one ([`Interval::excludes_zero`]).
    let empty = value_defined
        && (g.value.excludes_zero()
            || (g.defined && mean_value.is_some_and(|m| m.excludes_zero())));
    if empty || !value_defined {
        return Verdict {
            empty,
            topology_ok: false,
            geometry_ok: false,
            defined: value_defined,
            smooth: g.defined,
            grad: g.grad,
            sheet: false,
        };
    }
    let topology_ok = match test {
        TopologyTest::Paper => nonzero(g.grad),
        TopologyTest::Certify => same_side(g.grad),
    };
    let geometry_ok = topology_ok && normal_spread(g.grad) <= kmax;
    Verdict {
        empty: false,
        topology_ok,
        geometry_ok,
        defined: true,
        smooth: g.defined,
        grad: g.grad,
        sheet: false,
    }
}

/// The topology test on ∂Ω for a cell that passed the 3D test and lies
/// on faces of Ω (`faces[k]`: its box reaches the low or the high face
/// across axis `k`). There the sheet is cut by Ω, and the mesh's boundary
/// follows its trace: on a face a curve, certified by the paper's test in
/// two dimensions (one of the gradient's two components along the face
/// excludes 0: no singular point of the trace in the cell); on an edge of
/// Ω (two faces) points, certified in one dimension (the component along
/// the edge excludes 0: at most one crossing). `crosses(k, e)` says
/// whether the sheet may reach the piece of ∂Ω in question (`e` false: the
/// face across axis `k`; true: the edge along axis `k`), from an
/// enclosure of `F` there; a piece it cannot reach asks nothing. Without
/// it a sheet meeting a face at a grazing angle, whose trace is a wedge
/// thinner than a cell, was cut in two by the dual grid and called
/// guaranteed (a random CSG scene in a box domain, seed 61661 at level
/// 7; `z = x² + y² − ε` cut by `z = 0`).
pub(crate) fn boundary_holds(
    grad: [Interval; 3],
    faces: [bool; 3],
    mut crosses: impl FnMut(usize, bool) -> bool,
) -> bool {
    let along = |k: usize| (0..3).any(|j| j != k && grad[j].excludes_zero());
    let faces_hold = (0..3).all(|k| !faces[k] || along(k) || !crosses(k, false));
    let on_edge = |k: usize| (0..3).all(|j| j == k || faces[j]);
    faces_hold && (0..3).all(|k| !on_edge(k) || grad[k].excludes_zero() || !crosses(k, true))
}

/// The paper's test on a gradient enclosure: `(0,0,0) ∉ G`.
fn nonzero(grad: [Interval; 3]) -> bool {
    grad.iter().any(|c| c.excludes_zero())
}

/// Plantinga & Vegter's test on a gradient enclosure: `0 ∉ ⟨G, G⟩`.
fn same_side(grad: [Interval; 3]) -> bool {
    let mut dot = Interval { lo: 0.0, hi: 0.0 };
    for c in grad {
        // Two independent factors: a general product, not a square.
        let (p, _) = crate::ir::semantics::enclose_binary(BinOp::Mul, c, c);
        dot = crate::ir::semantics::enclose_binary(BinOp::Add, dot, p).0;
    }
    dot.excludes_zero()
}

/// A second look at a cell whose own gradient enclosure failed the
/// topology or geometry test, from the enclosures over pieces of it
/// (`pieces`, boxes that together cover the cell). Interval arithmetic
/// overestimates a range by about the box's width times the derivatives'
/// spread (the dependency problem: a degree-8 product, `a³` beside its own
/// zero), so the enclosures over halves are about twice as tight, and
/// often prove what the whole cell's cannot — the same tests, on
/// enclosures of the same gradients:
///
/// - the paper's test holds on the cell when it holds on every piece
///   (`∇F ≠ 0` on each, so on their union);
/// - Plantinga & Vegter's and the geometry test are applied to the hull
///   of the pieces' enclosures, itself an enclosure of `∇F` over the cell.
///
/// Emptiness is not revisited (the pieces' value enclosures go unused), and
/// a cell where `F` is not defined and continuous stays unproved.
pub(crate) fn judge_by_pieces(
    v: Verdict,
    pieces: &[GradEval],
    test: TopologyTest,
    kmax: f64,
) -> Verdict {
    let nan = |g: &GradEval| g.grad.iter().any(|c| c.lo.is_nan() || c.hi.is_nan());
    if v.empty || !v.defined || v.passed(false) || pieces.iter().any(nan) {
        return v;
    }
    // (No NaN bound: `hull` would drop it.)
    let hull = pieces.iter().skip(1).fold(pieces[0].grad, |h, g| {
        std::array::from_fn(|k| h[k].hull(g.grad[k]))
    });
    let topology_ok = v.topology_ok
        || match test {
            TopologyTest::Paper => pieces.iter().all(|g| nonzero(g.grad)),
            TopologyTest::Certify => same_side(hull),
        };
    Verdict {
        topology_ok,
        geometry_ok: topology_ok && normal_spread(hull) <= kmax,
        ..v
    }
}

/// `Diam(∇F(B)/‖∇F(B)‖)` with the paper's `Diam(Ix, Iy, Iz) = max |Iᵢ|`:
/// the largest width, over the three components, of the range of the unit
/// normal `g/‖g‖` as `g` runs over the gradient box `∇F(B)` (Paiva et al.
/// §4.1, geometry criterion). The range is computed exactly per component
/// rather than by interval division, which would count the dependency
/// between `gᵢ` and `‖g‖` twice and refine flat regions for nothing.
/// Infinite when the box contains the zero vector. (Not a guarantee, so
/// round-to-nearest is fine here.)
pub(crate) fn normal_spread(grad: [Interval; 3]) -> f64 {
    if grad.iter().all(|c| c.contains(0.0)) {
        return f64::INFINITY;
    }
    // Smallest and largest squares of each component over its interval.
    let sq_min = |c: Interval| {
        if c.contains(0.0) {
            0.0
        } else {
            (c.lo * c.lo).min(c.hi * c.hi)
        }
    };
    let sq_max = |c: Interval| (c.lo * c.lo).max(c.hi * c.hi);
    let mut widest = 0.0f64;
    for i in 0..3 {
        let (mut rmin, mut rmax) = (0.0, 0.0);
        for j in (0..3).filter(|&j| j != i) {
            rmin += sq_min(grad[j]);
            rmax += sq_max(grad[j]);
        }
        // u(a, r²) = a / sqrt(a² + r²) grows with a; for a > 0 it falls as
        // r² grows, for a < 0 it rises. Max at a = hi, min at a = lo, each
        // with the r² that pushes it outward.
        let u = |a: f64, r2: f64| {
            let n = (a * a + r2).sqrt();
            if n > 0.0 { a / n } else { 0.0 }
        };
        let c = grad[i];
        if !(c.lo.is_finite() && c.hi.is_finite() && rmax.is_finite()) {
            return f64::INFINITY;
        }
        let hi = u(c.hi, if c.hi > 0.0 { rmin } else { rmax });
        let lo = u(c.lo, if c.lo < 0.0 { rmin } else { rmax });
        // A zero vector in the box (all r² minima 0 and a straddling 0) was
        // excluded above; with a = 0 reachable and r² = 0 impossible the
        // formula is exact.
        widest = widest.max(hi - lo);
    }
    widest
}

/// The chord tolerance of faithful `--level` at a place on the surface:
/// `base` plus a share of the chord error that a uniform mesher with cells
/// of side `cell` has there. A chord of length `cell` on a surface whose
/// normal turns by `turn` over a length `length` (curvature
/// `κ = turn / length`) stands `κ·cell²/8` off it; the tolerance allows
/// [`CURVATURE_SHARE`] of that on top of `base`. Where the surface is flat
/// it is `base`; where it is curved it stays below the uniform mesher's own
/// chord error there plus `base` (SPEC §2: no worse than a uniform mesher
/// at the same depth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chord {
    /// The tolerance on a flat piece (domain units).
    pub base: f64,
    /// The side of the uniform mesher's cells (domain units); 0 for a
    /// tolerance that does not depend on the curvature.
    pub cell: f64,
}

/// The largest curvature [`Chord::at`] reads, in radians per uniform
/// cell: a radius of five cells. A level-L mesher does not resolve a
/// tighter bend; where the normals turn faster than this they read a
/// singular point (the heart's cusps, where ∇f vanishes) or a crease, not
/// a curvature a larger tolerance could follow. With 0.3 the heart's
/// chord error at depth 8 rose to 1.04× Fidget's; with 0.2 it is 0.9×
/// (`docs/faithful.md`).
pub const MAX_BEND: f64 = 0.2;

/// The share of a uniform mesher's chord error `κ·cell²/8` that
/// [`Chord::at`] adds to the base tolerance: two thirds, so the local
/// tolerance is `base + κ·cell²/12`. Measured against Fidget at depth 8
/// (`docs/faithful.md`): with 1/12 every surface tried keeps its chord
/// error within 0.9× Fidget's; with 0.15 the chairs' rose to 1.3×.
pub const CURVATURE_SHARE: f64 = 2.0 / 3.0;

impl Chord {
    /// A tolerance of `base` everywhere.
    pub fn uniform(base: f64) -> Self {
        Chord { base, cell: 0.0 }
    }

    /// The tolerance where the unit normal turns by the angle `turn` over
    /// the distance `length` (`base` where either is not a positive finite
    /// number), the curvature read no higher than [`MAX_BEND`] per cell.
    pub fn at(&self, turn: f64, length: f64) -> f64 {
        let kappa = turn / length;
        if kappa.is_finite() && kappa > 0.0 {
            let kappa = kappa.min(MAX_BEND / self.cell);
            self.base + CURVATURE_SHARE * kappa * self.cell * self.cell / 8.0
        } else {
            self.base
        }
    }

    /// The tolerance scaled by `k` (its base and its curvature share).
    pub fn times(&self, k: f64) -> Self {
        Chord {
            base: k * self.base,
            cell: k.sqrt() * self.cell,
        }
    }
}

/// The angle between the unit vectors `a` and `b`.
pub fn turn(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3)
        .map(|c| a[c] * b[c])
        .sum::<f64>()
        .clamp(-1.0, 1.0)
        .acos()
}

/// An estimate of the chord error (distance from the surface to the
/// triangles' centroids and edge midpoints) of a mesh through a cell of
/// side `side`, from the gradients of `F` at the cell's corners: where the
/// unit normals turn by an angle `θ` across the cell, the surface is
/// curved with radius about `span / θ`, and a chord of length `s` stands
/// `s² / 8R = s·θ / 8` off it; the dual cells' triangles span about a side
/// (`s = side`). Unit normals do not change when `F` is replaced by `φ(F)`
/// with `φ` monotone (`F³` for `F`, a distance for its square), so neither
/// does the estimate. Infinite where a gradient vanishes or is not a
/// number (the cell is then subdivided). A sample, not a bound: the
/// criterion shapes the mesh, it guarantees nothing.
pub(crate) fn chord_error(side: f64, grads: &[[f64; 3]]) -> f64 {
    let mut unit = [[0.0; 3]; 8];
    for (u, g) in unit.iter_mut().zip(grads) {
        let n = g.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(n > 0.0 && n.is_finite()) {
            return f64::INFINITY;
        }
        *u = g.map(|x| x / n);
    }
    let k = grads.len().min(8);
    let mut least = 1.0f64;
    for i in 0..k {
        for j in 0..i {
            least = least.min((0..3).map(|c| unit[i][c] * unit[j][c]).sum());
        }
    }
    side * least.clamp(-1.0, 1.0).acos() / 8.0
}

/// Whether a cell of side `side` with the corner gradients `grads` is
/// within the chord tolerance `tol` ([`chord_error`] against
/// [`Chord::at`] for the turn across the cell).
pub(crate) fn chord_within(side: f64, grads: &[[f64; 3]], tol: &Chord) -> bool {
    let e = chord_error(side, grads);
    // The largest turn between two corners, back from the estimate.
    e <= tol.at(8.0 * e / side, side)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Off ∂Ω nothing is asked; on a face, one of the gradient's two
    /// components along it must exclude 0 (the one across it does not
    /// count); on an edge of Ω, the component along the edge; a face or an
    /// edge the sheet cannot reach asks nothing.
    #[test]
    fn the_boundary_asks_for_a_gradient_along_it() {
        let iv = |lo: f64, hi: f64| Interval { lo, hi };
        let reach = |_: usize, _: bool| true;
        // ∂F/∂z away from 0, the others holding it.
        let across_z = [iv(-1.0, 1.0), iv(-0.5, 0.5), iv(0.9, 1.1)];
        assert!(boundary_holds(across_z, [false; 3], reach));
        assert!(boundary_holds(across_z, [true, false, false], reach));
        assert!(boundary_holds(across_z, [false, true, false], reach));
        assert!(!boundary_holds(across_z, [false, false, true], reach));
        // The face z = const out of the sheet's reach.
        let not_z = |k: usize, edge: bool| edge || k != 2;
        assert!(boundary_holds(across_z, [false, false, true], not_z));
        // Along the face z = const, ∂F/∂x away from 0: certified.
        let along_x = [iv(0.1, 0.2), iv(-0.5, 0.5), iv(0.9, 1.1)];
        assert!(boundary_holds(along_x, [false, false, true], reach));
        // On the edge along y (faces across x and z), ∂F/∂y holds 0 —
        // unless the sheet cannot reach that edge; along z, ∂F/∂z is away
        // from 0.
        assert!(!boundary_holds(along_x, [true, false, true], reach));
        assert!(boundary_holds(along_x, [true, false, true], |_, e| !e));
        assert!(boundary_holds(along_x, [true, true, false], reach));
        // A NaN bound certifies nothing.
        let nan = [iv(f64::NAN, 1.0), iv(-0.5, 0.5), iv(0.9, 1.1)];
        assert!(!boundary_holds(nan, [false, false, true], reach));
    }

    /// On a flat piece the tolerance is the base; on a sphere of radius
    /// `r` (the normal turns by `s / r` over a length `s`, whatever `s`)
    /// it adds two thirds of the sagitta `cell² / 8r` of a chord one cell
    /// long, `r` no less than `cell / MAX_BEND`; scaled, both parts scale;
    /// a degenerate turn or length gives the base.
    #[test]
    fn the_chord_tolerance_adds_a_share_of_the_uniform_sagitta() {
        let tol = Chord {
            base: 0.01,
            cell: 0.1,
        };
        assert_eq!(tol.at(0.0, 0.3), 0.01);
        // Radii under five cells bend faster than `MAX_BEND`: read as five
        // cells (of the tolerance's own cell, scaled or not).
        let want = |c: Chord, r: f64| {
            c.base + 2.0 / 3.0 * c.cell * c.cell / (8.0 * r.max(c.cell / MAX_BEND))
        };
        for r in [0.005f64, 0.02, 0.5, 5.0] {
            for s in [0.01, 0.1, 1.0] {
                assert!(
                    (tol.at(s / r, s) - want(tol, r)).abs() < 1e-15,
                    "r {r}, s {s}"
                );
                let scaled = tol.times(4.0);
                assert!((scaled.at(s / r, s) - want(scaled, r)).abs() < 1e-15);
            }
            if r >= 1.0 {
                // Below the cap, scaling scales both parts.
                let ratio = tol.times(4.0).at(0.1 / r, 0.1) / tol.at(0.1 / r, 0.1);
                assert!((ratio - 4.0).abs() < 1e-12);
            }
        }
        for (turn, length) in [(f64::NAN, 1.0), (1.0, 0.0), (0.5, f64::NAN)] {
            assert_eq!(tol.at(turn, length), 0.01, "{turn} over {length}");
        }
        assert_eq!(Chord::uniform(0.02).at(3.0, 0.1), 0.02);
        let right = turn([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert!((right - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }
}
