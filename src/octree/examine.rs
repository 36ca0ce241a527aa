//! Judging one level's cells: the batch evaluations behind the criteria's
//! verdicts (value, interval gradient, mean-value form), then the cell-local
//! reviews (chord error, the topology on ∂Ω, pieces of a cell).

use glam::DVec3;
use rustc_hash::FxHashMap as HashMap;

use super::{Chord, Node, Octant, OctreeOptions, criteria};
use crate::eval::{Evaluator, WHOLE, WHOLE_GRAD};
use crate::interval::{DecInterval, Interval};

/// The verdicts on `cells` (all at one level, evaluated by `f`) after the
/// cell-local criteria beyond [`examine`]'s one enclosure: above the last
/// level, with a chord tolerance `tau` (already scaled by the slack), a
/// cell passes only if its estimated chord error is within it
/// ([`chord_within`]); a cell that
/// failed the topology or geometry test (at the last level: the topology
/// test) gets a second look from pieces of it ([`pieces_test`]) — above
/// the last level only if its chord error would let it be a leaf.
pub(super) fn review<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    verdicts: &mut [criteria::Verdict],
    opts: &OctreeOptions,
    tau: Option<Chord>,
    last_level: bool,
) {
    // Smooth: pieces seldom prove anything across a crease.
    let second = |v: &criteria::Verdict| !v.empty && v.defined && v.smooth && !v.passed(last_level);
    let open: Vec<usize> = match tau.filter(|_| !last_level) {
        None => (0..cells.len()).filter(|&i| second(&verdicts[i])).collect(),
        Some(tau) => {
            let judged: Vec<usize> = (0..cells.len())
                .filter(|&i| verdicts[i].passed(false) || second(&verdicts[i]))
                .collect();
            let within = chord_within(f, cells, &judged, &tau, opts.t);
            // A cell within the tolerance keeps its verdict: it gets the
            // second look if it needs one.
            judged
                .into_iter()
                .zip(within)
                .filter(|&(i, ok)| {
                    verdicts[i].geometry_ok &= ok;
                    ok && second(&verdicts[i])
                })
                .map(|(i, _)| i)
                .collect()
        }
    };
    pieces_test(f, cells, verdicts, &open, opts, last_level);
}

/// Whether each of `cells[i]` for `i` in `which` has an estimated chord
/// error ([`criteria::chord_error`]) within `tau` at the turn of the
/// normals across it ([`Chord::at`]): one point-gradient batch at the
/// corners of those cells, each distinct corner once (siblings share
/// most of theirs: eight children of a cell have 27 corners, not 64).
pub(super) fn chord_within<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    which: &[usize],
    tau: &Chord,
    t: f64,
) -> Vec<bool> {
    let corners: Vec<[f64; 3]> = which.iter().flat_map(|&i| corners(&cells[i])).collect();
    let (distinct, slot) = distinct_points(&corners);
    let mut at = vec![(0.0, [0.0; 3]); distinct.len()];
    f.point_grad_batch(&distinct, t, &mut at);
    which
        .iter()
        .zip(slot.chunks_exact(8))
        .map(|(&i, slot)| {
            let grads: [[f64; 3]; 8] = std::array::from_fn(|c| at[slot[c] as usize].1);
            // On a box, the side of a cube of its volume, as the
            // tolerance's cell ([`OctreeOptions::chord_tolerance`]).
            let (lo, hi) = bounds(&cells[i]);
            let side = (hi - lo).element_product().cbrt();
            criteria::chord_within(side, &grads, tau)
        })
        .collect()
}

/// The spatial bounds of a cell's box.
fn bounds(cell: &[Interval; 4]) -> (DVec3, DVec3) {
    let lo = DVec3::new(cell[0].lo, cell[1].lo, cell[2].lo);
    let hi = DVec3::new(cell[0].hi, cell[1].hi, cell[2].hi);
    (lo, hi)
}

/// The corners of a cell's box, in [`Octant::ALL`]'s order.
fn corners(cell: &[Interval; 4]) -> [[f64; 3]; 8] {
    let (lo, hi) = bounds(cell);
    Octant::ALL.map(|o| o.pick(lo, hi).to_array())
}

/// The distinct points of `pts` (by their bits, in order of first
/// appearance) and, per point of `pts`, its index among them.
fn distinct_points(pts: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<u32>) {
    let mut index: HashMap<[u64; 3], u32> = HashMap::default();
    let mut distinct = Vec::new();
    let slot = pts
        .iter()
        .map(|p| {
            *index.entry(p.map(f64::to_bits)).or_insert_with(|| {
                distinct.push(*p);
                (distinct.len() - 1) as u32
            })
        })
        .collect();
    (distinct, slot)
}

/// The sides of Ω a node's cell lies on, per axis: on the low face, on
/// the high face (from its integer position, so exactly the cells whose
/// computed box reaches ∂Ω).
pub(super) fn sides(node: &Node) -> [(bool, bool); 3] {
    let last = (1u32 << node.level) - 1;
    node.ijk.map(|i| (i == 0, i == last))
}

/// The topology test on ∂Ω ([`criteria::boundary_holds`]) on the cells
/// whose verdict passed the 3D test and that lie on faces of Ω (`sides`,
/// per cell): failed there, the cell's topology (and geometry) test
/// fails. Whether the sheet may reach a face or an edge of the cell on
/// ∂Ω is read, where the gradient alone does not certify it, from `f`'s
/// enclosure over that piece.
pub(super) fn boundary_look<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    sides: &[[(bool, bool); 3]],
    verdicts: &mut [criteria::Verdict],
) {
    for ((cell, sides), v) in cells.iter().zip(sides).zip(verdicts.iter_mut()) {
        let faces = sides.map(|(lo, hi)| lo || hi);
        if !v.topology_ok || !faces.contains(&true) {
            continue;
        }
        let crosses = |k: usize, edge: bool| reaches(f, cell, sides, k, edge);
        if !criteria::boundary_holds(v.grad, faces, crosses) {
            v.topology_ok = false;
            v.geometry_ok = false;
        }
    }
}

/// Whether `f`'s enclosure may vanish on the piece of ∂Ω `cell` lies on
/// (`sides`): the face across axis `k`, or with `edge` the edge along
/// axis `k` (both other axes on faces) — on each of its sides where the
/// cell lies on two (a level-0 cell).
pub(super) fn reaches<E: Evaluator + ?Sized>(
    f: &E,
    cell: &[Interval; 4],
    sides: &[(bool, bool); 3],
    k: usize,
    edge: bool,
) -> bool {
    let pinned: Vec<usize> = (0..3)
        .filter(|&j| if edge { j != k } else { j == k })
        .collect();
    let mut boxes = vec![*cell];
    for &j in &pinned {
        let ends: Vec<f64> = [(sides[j].0, cell[j].lo), (sides[j].1, cell[j].hi)]
            .into_iter()
            .filter_map(|(on, x)| on.then_some(x))
            .collect();
        boxes = boxes
            .iter()
            .flat_map(|b| {
                ends.iter().map(move |&x| {
                    let mut b = *b;
                    b[j] = Interval { lo: x, hi: x };
                    b
                })
            })
            .collect();
    }
    let mut out = vec![DecInterval::new(Interval::ENTIRE, false); boxes.len()];
    f.interval_batch(&boxes, &mut out);
    out.iter().any(|d| !d.excludes_zero())
}

/// Gives the cells `cells[i]` for `i` in `open` (evaluated by `f`) a second
/// look from their `n³` pieces for `n` in [`PIECES`]
/// ([`criteria::judge_by_pieces`]): one interval-gradient batch over the
/// pieces of the cells still failing, per `n`. A cell that passes is a
/// leaf where it would otherwise be subdivided (and at the last level,
/// guaranteed where it would be ambiguous).
pub(super) fn pieces_test<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    verdicts: &mut [criteria::Verdict],
    open: &[usize],
    opts: &OctreeOptions,
    last_level: bool,
) {
    let mut open = open.to_vec();
    for n in PIECES {
        open.retain(|&i| !verdicts[i].passed(last_level));
        if open.is_empty() {
            return;
        }
        let mut pieces = Vec::with_capacity(open.len() * n * n * n);
        for &i in &open {
            push_pieces(&cells[i], n, &mut pieces);
        }
        let mut grads = vec![WHOLE_GRAD; pieces.len()];
        f.grad_batch(&pieces, &mut grads);
        for (&i, of_cell) in open.iter().zip(grads.chunks_exact(n * n * n)) {
            verdicts[i] = criteria::judge_by_pieces(verdicts[i], of_cell, opts.test, opts.kmax);
        }
    }
}

/// The pieces per axis of [`pieces_test`]'s successive looks.
pub(super) const PIECES: [usize; 2] = [2, 4];

/// Appends to `out` the `n³` boxes of a cell cut in `n` along each axis,
/// which cover it.
pub(super) fn push_pieces(cell: &[Interval; 4], n: usize, out: &mut Vec<[Interval; 4]>) {
    // The cuts along each axis: the cell's own bounds at both ends.
    let cuts = |k: usize| {
        let (a, b) = (cell[k].lo, cell[k].hi);
        move |j: usize| match j {
            0 => a,
            j if j == n => b,
            j => a + (b - a) * (j as f64 / n as f64),
        }
    };
    let (x, y, z) = (cuts(0), cuts(1), cuts(2));
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let lo = DVec3::new(x(i), y(j), z(k));
                let hi = DVec3::new(x(i + 1), y(j + 1), z(k + 1));
                out.push(cell_input(lo, hi, cell[3].lo));
            }
        }
    }
}

pub(super) fn cell_input(a: DVec3, b: DVec3, t: f64) -> [Interval; 4] {
    [
        Interval { lo: a.x, hi: b.x },
        Interval { lo: a.y, hi: b.y },
        Interval { lo: a.z, hi: b.z },
        Interval { lo: t, hi: t },
    ]
}

/// The criteria's verdicts on cells, from three batch calls: the value
/// kernel over the cells (a cell it proves empty needs nothing more), the
/// interval-gradient kernel over the others, and the value kernel at the
/// centres of those whose gradient flag held (the mean-value form). With
/// `value_first` false, [`examine_gradient_first`]: the cheaper order when
/// the gradient kernel is not much dearer than the value kernel (the JIT's,
/// against the interpreters' five times).
pub(super) fn examine<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    opts: &OctreeOptions,
    value_first: bool,
) -> Vec<criteria::Verdict> {
    if !value_first {
        return examine_gradient_first(f, cells, opts);
    }
    let mut values = vec![WHOLE; cells.len()];
    f.interval_batch(cells, &mut values);
    let open: Vec<[Interval; 4]> = cells
        .iter()
        .zip(&values)
        .filter(|(_, v)| !v.excludes_zero())
        .map(|(c, _)| *c)
        .collect();
    let mut grads = vec![WHOLE_GRAD; open.len()];
    f.grad_batch(&open, &mut grads);
    let centres: Vec<[Interval; 4]> = open
        .iter()
        .zip(&grads)
        .filter(|(_, g)| g.defined)
        .map(|(c, _)| centre(c))
        .collect();
    let mut at_centres = vec![WHOLE; centres.len()];
    f.interval_batch(&centres, &mut at_centres);
    let mut grads = grads.into_iter();
    let mut at_centres = centres.iter().zip(at_centres);
    cells
        .iter()
        .zip(&values)
        .map(|(cell, v)| {
            if v.excludes_zero() {
                return criteria::Verdict {
                    empty: true,
                    topology_ok: false,
                    geometry_ok: false,
                    defined: true,
                    smooth: true,
                    grad: [Interval::ENTIRE; 3],
                    sheet: false,
                };
            }
            let g = grads.next().expect("one gradient per open cell");
            let mean_value = mean_value_next(&g, cell, &mut at_centres);
            let value_defined = g.defined || v.defined;
            criteria::judge(&g, value_defined, mean_value, opts.test, opts.kmax)
        })
        .collect()
}

/// [`examine`] from the interval-gradient kernel over all cells (its value
/// enclosure decides emptiness), the value kernel at the centres of the
/// cells whose gradient flag held, and the value kernel over those whose
/// flag dropped (is `F` itself defined there?).
pub(super) fn examine_gradient_first<E: Evaluator + ?Sized>(
    f: &E,
    cells: &[[Interval; 4]],
    opts: &OctreeOptions,
) -> Vec<criteria::Verdict> {
    let mut grads = vec![WHOLE_GRAD; cells.len()];
    f.grad_batch(cells, &mut grads);
    let (mut centres, mut undiff) = (Vec::new(), Vec::new());
    for (cell, g) in cells.iter().zip(&grads) {
        if g.defined {
            centres.push(centre(cell));
        } else {
            undiff.push(*cell);
        }
    }
    let mut at_centres = vec![WHOLE; centres.len()];
    f.interval_batch(&centres, &mut at_centres);
    let mut on_undiff = vec![WHOLE; undiff.len()];
    f.interval_batch(&undiff, &mut on_undiff);
    let mut at_centres = centres.iter().zip(at_centres);
    let mut on_undiff = on_undiff.into_iter();
    cells
        .iter()
        .zip(grads)
        .map(|(cell, g)| {
            let value_defined = g.defined
                || on_undiff
                    .next()
                    .expect("one value per cell whose gradient flag dropped")
                    .defined;
            let mean_value = mean_value_next(&g, cell, &mut at_centres);
            criteria::judge(&g, value_defined, mean_value, opts.test, opts.kmax)
        })
        .collect()
}

/// The centre of a cell, as a degenerate box.
pub(super) fn centre(cell: &[Interval; 4]) -> [Interval; 4] {
    let mut c = *cell;
    for side in c.iter_mut().take(3) {
        let m = 0.5 * (side.lo + side.hi);
        *side = Interval { lo: m, hi: m };
    }
    c
}

/// The mean-value form over `cell` when its gradient flag held (the next
/// centre value of `centres` is then its own), else `None`.
pub(super) fn mean_value_next<'a>(
    g: &crate::eval::GradEval,
    cell: &[Interval; 4],
    centres: &mut impl Iterator<Item = (&'a [Interval; 4], crate::interval::DecInterval)>,
) -> Option<Interval> {
    if !g.defined {
        return None;
    }
    let (centre, fc) = centres
        .next()
        .expect("one centre per cell with a defined gradient");
    let c = [0, 1, 2].map(|k| centre[k].lo);
    Some(criteria::mean_value_form(
        fc.iv,
        g.grad,
        [cell[0], cell[1], cell[2]],
        c,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::octree::TopologyTest;
    use crate::testing::{Rng, surface};

    /// `f = (u + v)² + (u - v)² + 2w² - r²` with `(u, v, w) = p - c` is
    /// twice the squared distance to `c`, so its gradient vanishes only at
    /// the centre `c`; but its natural interval extension sums two terms
    /// that cancel (`2(u+v) + 2(u-v)` for `∂/∂x`), and overestimates the
    /// gradient by the cell's width (the dependency problem the pieces
    /// defeat). Random cells, some holding the centre: a cell holding it is
    /// never certified by either test, a cell certified by its own
    /// enclosure stays so, and some cells are certified only by pieces.
    #[test]
    fn pieces_certify_only_cells_without_a_critical_point() {
        let centre = [0.13, -0.21, 0.07];
        let s = surface(&format!(
            "domain [-1, 1]^3; let u = x - {}; let v = y - {}; let w = z - {};
             surface (u + v)^2 + (u - v)^2 + 2*w^2 - 0.5;",
            centre[0], centre[1], centre[2]
        ));
        let f = &s;
        let mut rng = Rng::new(21);
        for test in [TopologyTest::Paper, TopologyTest::Certify] {
            let opts = OctreeOptions {
                test,
                ..OctreeOptions::default()
            };
            let cells: Vec<[Interval; 4]> = (0..4000)
                .map(|_| {
                    let side = 0.02 + 0.5 * rng.unit();
                    let near = rng.unit() < 0.3;
                    let lo: [f64; 3] = std::array::from_fn(|k| {
                        if near {
                            centre[k] - side * rng.unit()
                        } else {
                            -1.0 + (2.0 - side) * rng.unit()
                        }
                    });
                    cell_input(DVec3::from(lo), DVec3::from(lo) + side, 0.0)
                })
                .collect();
            let own = examine(f, &cells, &opts, false);
            let mut v = own.clone();
            let open: Vec<usize> = (0..cells.len()).collect();
            pieces_test(f, &cells, &mut v, &open, &opts, true);
            let holds = |c: &[Interval; 4]| (0..3).all(|k| c[k].contains(centre[k]));
            let mut by_pieces = 0;
            for ((c, own), v) in cells.iter().zip(&own).zip(&v) {
                assert!(!(v.topology_ok && holds(c)), "{test:?}: {c:?} certified");
                assert!(!own.topology_ok || v.topology_ok, "{test:?}: {c:?} lost");
                by_pieces += usize::from(v.topology_ok && !own.topology_ok);
            }
            assert!(by_pieces >= 20, "{test:?}: only {by_pieces} cells gained");
        }
    }

    /// `chord_within` reads each distinct corner once and gives every cell
    /// the verdict its own eight corners give: siblings sharing corners,
    /// against each cell judged alone.
    #[test]
    fn shared_corners_are_read_once_with_the_same_verdicts() {
        let s = surface("domain [-1, 1]^3; surface x*x + 2*y*y + 3*z*z - 0.5;");
        let f = s.kernels();
        let tau = Chord {
            base: 0.01,
            cell: 0.05,
        };
        // The eight children of each of a 4×4×4 grid of cells.
        let mut cells = Vec::new();
        for i in 0..64 {
            let lo =
                DVec3::new(f64::from(i % 4), f64::from(i / 4 % 4), f64::from(i / 16)) * 0.5 - 1.0;
            for o in Octant::ALL {
                let c = o.pick(lo, lo + 0.25);
                cells.push(cell_input(c, c + 0.25, 0.0));
            }
        }
        let all: Vec<usize> = (0..cells.len()).collect();
        let together = chord_within(f, &cells, &all, &tau, 0.0);
        let alone: Vec<bool> = all
            .iter()
            .map(|&i| chord_within(f, &cells, &[i], &tau, 0.0)[0])
            .collect();
        assert_eq!(together, alone);
        assert!(together.contains(&true) && together.contains(&false));
        let corners: Vec<[f64; 3]> = cells.iter().flat_map(corners).collect();
        let (distinct, slot) = distinct_points(&corners);
        assert_eq!(distinct.len(), 9 * 9 * 9);
        assert!(
            corners
                .iter()
                .zip(&slot)
                .all(|(p, &k)| distinct[k as usize] == *p)
        );
    }
}
