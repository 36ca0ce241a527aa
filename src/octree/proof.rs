//! The proof search below ambiguous leaves: a leaf ambiguous only because
//! interval enclosures are loose on it is split further, for the proof only,
//! and becomes empty when every piece is proved empty.

use glam::DVec3;
use rayon::prelude::*;

use super::examine::{cell_input, examine};
use super::tape::Tape;
use super::{Kind, Leaf, Octant, Octree, OctreeOptions};
use crate::eval::{Evaluator, WHOLE};
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
    // A batch of one: the JIT compiles its single-box interval kernel
    // apart, and the octree needs the batch kernel anyway.
    seen && (zero || {
        let mut r = [WHOLE];
        f.interval_batch(&[cell_input(a, b, t)], &mut r);
        r[0].defined
    })
}

/// Whether the box `[a, b]`, not proved empty itself, is proved free of
/// surface by its pieces, splitting it up to `depth` more times: every one
/// of its 8 children must be. One interval batch over the children settles
/// those whose natural enclosure excludes 0 with `F` defined on them; the
/// others (or where `F` may be undefined) are split again, down to the last
/// level of the search, where a piece on which `F` may be undefined fails
/// it, and the gradient kernel's tests ([`examine`]'s: the mean-value form,
/// the gradient kernel's own value enclosure), sharpest on the smallest
/// boxes, get the last word, in one batch too.
///
/// Most searches succeed (on random CSG scenes, most of the leaves
/// searched: `docs/faithful.md`, session 54), and a success evaluates
/// every piece whatever the order: so the pieces are batched rather than
/// ordered to fail fast.
pub(super) fn proves_empty<E: Evaluator + ?Sized>(
    f: &E,
    a: DVec3,
    b: DVec3,
    opts: &OctreeOptions,
    depth: u8,
) -> bool {
    if depth == 0 {
        return false;
    }
    let m = (a + b) * 0.5;
    let children = Octant::ALL.map(|o| o.sub_box(a, m, b));
    let boxes = children.map(|(lo, hi)| cell_input(lo, hi, opts.t));
    let mut values = [WHOLE; 8];
    f.interval_batch(&boxes, &mut values);
    let mut open = (0..8).filter(|&c| !values[c].excludes_zero());
    if depth > 1 {
        return open.all(|c| proves_empty(f, children[c].0, children[c].1, opts, depth - 1));
    }
    // At the last level a piece on which `F` may be undefined fails.
    if values.iter().any(|r| !r.defined) {
        return false;
    }
    let open: Vec<[Interval; 4]> = open.map(|c| boxes[c]).collect();
    examine(f, &open, opts, false).iter().all(|v| v.empty)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::Reference;
    use crate::testing::{Rng, surface};

    /// `x² − 1.9x + 1` stays above 0.0975, but its natural enclosures
    /// hold 0 on every piece down to the last level of a three-level
    /// search of `[0, 2] × [0, 1]²`: the mean-value form on the smallest
    /// pieces proves the box empty, and a two-level search cannot. With a
    /// root in the box (`x² − 1`), no search proves it empty. The JIT and
    /// the interpreters alike.
    #[test]
    fn search_proves_a_loose_box_empty_at_its_last_level() {
        let opts = OctreeOptions::default();
        let (a, b) = (DVec3::ZERO, DVec3::new(2.0, 1.0, 1.0));
        let loose = surface("domain [0, 2]^3; surface x*x - 1.9*x + 1;");
        let crossed = surface("domain [0, 2]^3; surface x*x - 1;");
        for (name, f) in [
            ("jit", &loose as &dyn Evaluator),
            ("interpreters", &Reference(loose.program.clone())),
        ] {
            assert!(!proves_empty(f, a, b, &opts, 2), "{name}: two levels");
            assert!(proves_empty(f, a, b, &opts, 3), "{name}: three levels");
        }
        assert!(!proves_empty(&crossed, a, b, &opts, PROOF_DEPTH));
        assert!(straddles(&crossed, a, b, 0.0));
    }

    /// On random small boxes near a CSG solid's surface (an R-function
    /// union, less a cylinder), a box proved empty holds no zero: 7³
    /// samples of it all have one sign. And the proof is found on some of
    /// the boxes that one enclosure leaves open, not on all.
    #[test]
    fn boxes_proved_empty_hold_no_sign_change() {
        let f = surface(
            "domain [-1, 1]^3; \
             let a = sqrt(x^2 + y^2 + z^2) - 0.5; \
             let b = max(abs(x - 0.3) - 0.4, abs(y) - 0.2, abs(z + 0.1) - 0.3); \
             let j = a + b - sqrt(a^2 + b^2); \
             surface max(j, 0.15 - sqrt((x + 0.2)^2 + z^2));",
        );
        let opts = OctreeOptions::default();
        let mut rng = Rng::new(7);
        let (mut proved, mut open) = (0, 0);
        for _ in 0..2000 {
            let a = DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 1.6 - 0.8;
            let b = a + DVec3::splat(0.01 + 0.05 * rng.unit());
            if f.interval(cell_input(a, b, 0.0)).excludes_zero() {
                continue;
            }
            open += 1;
            if !proves_empty(&f, a, b, &opts, PROOF_DEPTH) {
                continue;
            }
            proved += 1;
            let n = 6.0;
            let signs: Vec<bool> = (0..343)
                .map(|i| {
                    let k = DVec3::new((i % 7) as f64, (i / 7 % 7) as f64, (i / 49) as f64);
                    let p = a + (b - a) * k / n;
                    f.point([p.x, p.y, p.z, 0.0]) > 0.0
                })
                .collect();
            assert!(
                signs.iter().all(|&s| s == signs[0]),
                "{a} {b}: a sign change"
            );
        }
        assert!(proved > 0 && proved < open, "{proved} of {open} proved");
    }
}
