//! The proof search below ambiguous leaves: a leaf ambiguous only because
//! interval enclosures are loose on it is split further, for the proof only,
//! and becomes empty when every piece is proved empty.

use glam::DVec3;
use rayon::prelude::*;

use super::examine::{cell_input, examine};
use super::tape::Tape;
use super::{Kind, Leaf, Octant, Octree, OctreeOptions};
use crate::eval::Evaluator;
use crate::interval::Interval;

/// Extra levels below an ambiguous leaf searched for a proof that it is
/// empty (see [`Octree::clear_false_ambiguity`]).
const PROOF_DEPTH: u8 = 3;

/// Points per axis of the grid [`straddles`] samples.
pub(super) const STRADDLE_GRID: u32 = 2;

/// Whether point values over `[a, b]` show that the box holds surface, so
/// that no proof of emptiness can succeed: values of both strict signs,
/// with `F` defined and continuous on the box (so it vanishes in between),
/// or a value that is exactly 0 (a zero up to rounding, whatever the
/// continuity). The points: the centre and one Newton step from it along
/// the gradient, which lands on a surface the box's corners do not see (a
/// sheet that touches 0 without crossing, as `−|u|` does where two solids
/// meet face to face), then a `STRADDLE_GRID³` grid (2: the corners; a
/// finer grid found barely more on colonnade).
pub(super) fn straddles<E: Evaluator + ?Sized>(f: &E, a: DVec3, b: DVec3, t: f64) -> bool {
    let (mut neg, mut pos, mut zero) = (false, false, false);
    let mut sees = |v: f64| {
        neg |= v < 0.0;
        pos |= v > 0.0;
        zero |= v == 0.0;
        zero || (neg && pos)
    };
    // The Newton step first: it alone sees the touching sheets, which are
    // most of the doomed searches (the answer does not depend on the
    // order, only the work).
    let c = (a + b) * 0.5;
    let (v, g) = f.point_grad([c.x, c.y, c.z, t]);
    let g = DVec3::from_array(g);
    let q = c - g * (v / g.length_squared());
    let mut seen = sees(v)
        || (q.is_finite()
            && q.cmpge(a).all()
            && q.cmple(b).all()
            && sees(f.point([q.x, q.y, q.z, t])));
    let n = STRADDLE_GRID - 1;
    let at = |k: u32, lo: f64, hi: f64| lo + (hi - lo) * (f64::from(k) / f64::from(n));
    'grid: for i in 0..=n {
        for j in 0..=n {
            for k in 0..=n {
                if seen {
                    break 'grid;
                }
                seen = sees(f.point([at(i, a.x, b.x), at(j, a.y, b.y), at(k, a.z, b.z), t]));
            }
        }
    }
    seen && (zero || f.interval(cell_input(a, b, t)).defined)
}

/// Whether interval arithmetic proves the cell free of surface: `F`
/// defined on it and `0 ∉ F(B)` by the natural extension (one interval
/// evaluation), or, failing that, by the mean-value form or the gradient
/// kernel's own value enclosure ([`examine`]'s test). The cheap interval
/// kernel first, the gradient kernel only where it is needed.
pub(super) fn empty<E: Evaluator + ?Sized>(
    f: &E,
    cell: [Interval; 4],
    opts: &OctreeOptions,
    with_gradient: bool,
) -> bool {
    let r = f.interval(cell);
    if !r.defined {
        return false;
    }
    if r.iv.excludes_zero() {
        return true;
    }
    with_gradient && examine(f, &[cell], opts, false)[0].empty
}

/// Whether the box `[a, b]` is proved free of surface, splitting it up to
/// `depth` more times.
pub(super) fn proves_empty<E: Evaluator + ?Sized>(
    f: &E,
    a: DVec3,
    b: DVec3,
    opts: &OctreeOptions,
    depth: u8,
) -> bool {
    // The leaf itself (`depth == PROOF_DEPTH`) was examined when the tree
    // was built. Above the last level of the search only the natural
    // interval is tried (cheap); the gradient kernel's tests (mean-value
    // form) on the smallest boxes, where they are sharpest.
    if depth < PROOF_DEPTH && empty(f, cell_input(a, b, opts.t), opts, depth == 0) {
        return true;
    }
    if depth == 0 {
        return false;
    }
    let m = (a + b) * 0.5;
    let child = |o: Octant| o.sub_box(a, m, b);
    // Every child must be proved empty; the one whose centre value is
    // nearest 0 is the likeliest to fail, so it goes first (the answer
    // does not depend on the order, only the work).
    let mut order: Vec<(f64, Octant)> = Octant::ALL
        .into_iter()
        .map(|c| {
            let (lo, hi) = child(c);
            let p = (lo + hi) * 0.5;
            let v = f.point([p.x, p.y, p.z, opts.t]).abs();
            (if v.is_nan() { 0.0 } else { v }, c)
        })
        .collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0));
    order.iter().all(|&(_, c)| {
        let (lo, hi) = child(c);
        proves_empty(f, lo, hi, opts, depth - 1)
    })
}

impl Octree {
    /// An ambiguous leaf at the maximal level may be ambiguous only because
    /// interval enclosures are loose on it: it may hold no surface at all.
    /// Each one is split further (up to [`PROOF_DEPTH`] levels, for the
    /// proof only: the octree keeps its leaf) and becomes [`Leaf::Empty`]
    /// when every piece is proved empty. Nothing else is relaxed.
    pub(super) fn clear_false_ambiguity<E: Evaluator + ?Sized>(
        &mut self,
        f: &E,
        opts: &OctreeOptions,
        ambiguous: &[(u32, Tape)],
        long: bool,
    ) {
        let proved: Vec<bool> = ambiguous
            .par_iter()
            .map(|(i, tape)| {
                let (a, b) = self.cell_box(&self.nodes[*i as usize]);
                tape.with(f, long, |e, _| {
                    !straddles(e, a, b, opts.t) && proves_empty(e, a, b, opts, PROOF_DEPTH)
                })
            })
            .collect();
        for ((i, _), empty) in ambiguous.iter().zip(proved) {
            if empty {
                self.nodes[*i as usize].kind = Kind::Leaf(Leaf::Empty);
            }
        }
    }
}
