//! Cells across a CSG crease at the last level: the paper's topology test
//! once more, along one direction.
//!
//! Where two faces of a `min`/`max` meet inside a cell, the interval
//! gradient over the cell is the box hull of both faces' gradients, which
//! holds the zero vector as soon as the faces' normals differ in sign or
//! vanish along every axis (a face along `x` and one along `y`: the hull
//! `[0,1]×[0,1]×0`), however small the cell. The pieces of the cell
//! ([`super::criteria::judge_by_pieces`]) do not help: each piece across
//! the crease has the same hull. So every crease cell ended ambiguous.
//!
//! # Contract
//!
//! A cell of the last level on which `F` is defined and continuous but not
//! differentiable, and which failed the paper's topology test, gets one
//! more interval-gradient evaluation ([`crease_look`]), in a frame whose
//! first column `d` is the sign pattern of its gradient enclosure (`+1`
//! along an axis where every partial is `≥ 0` and some `> 0`, `-1` for the
//! mirror case, `0` where the partial straddles 0), normalised
//! ([`Evaluator::grad_in`]). Across a crease the derivative along `d` is
//! enclosed by the hull of the faces' own derivatives along `d`, not by
//! the projection of the hull of their gradients: for the two faces above,
//! `d = (1,1,0)/√2` and the derivative along it is `1/√2` on both. A
//! derivative along `d` whose enclosure excludes 0 proves that no
//! generalised gradient of `F` on the cell vanishes (each has `d·g ≠ 0`),
//! which is the paper's conclusion, so the cell passes its topology test —
//! soundly, the enclosure being the proof and the sign pattern only the
//! choice of direction. With `--certify` the look is not taken: a
//! direction does not bound the angle between two gradients, which
//! Plantinga and Vegter's test needs.
//!
//! # Limits
//!
//! Only the last level is looked at: above it a crease cell also fails
//! the geometry and chord criteria, which read the crease as curvature,
//! so it is subdivided whatever its topology; stopping crease cells
//! earlier was measured to triple colonnade.vm's chord error (the mesher
//! does not rebuild a crease through a coarse cell well enough,
//! `docs/faithful.md`). One direction is tried. Coincident faces, as
//! `max(a, -a)` where a model joins two solids along a shared face, have
//! opposite gradients on the cell, which no direction separates: those
//! cells stay ambiguous.

use glam::DVec3;

use super::OctreeOptions;
use super::criteria::{TopologyTest, Verdict};
use crate::eval::Evaluator;
use crate::eval::grad::Frame;
use crate::interval::Interval;

/// The look along one direction at the crease cells among `cells`, all
/// of the last level when `last_level` (see the module doc): the cells on
/// which `F` is defined but not differentiable and whose topology test
/// failed. `f` is the cells' evaluator.
pub(super) fn crease_look(
    f: &dyn Evaluator,
    cells: &[[Interval; 4]],
    verdicts: &mut [Verdict],
    opts: &OctreeOptions,
    last_level: bool,
) {
    if opts.test != TopologyTest::Paper || !last_level {
        return;
    }
    for (cell, v) in cells.iter().zip(verdicts.iter_mut()) {
        if !v.empty && v.defined && !v.smooth && !v.topology_ok {
            v.topology_ok = along_signs(f, cell, v.grad);
        }
    }
}

/// Whether the derivative of `F` along the sign pattern of the gradient
/// enclosure `hull` is proved nonzero on `cell` by `f`.
fn along_signs(f: &dyn Evaluator, cell: &[Interval; 4], hull: [Interval; 3]) -> bool {
    let sign = |c: Interval| {
        if c.lo >= 0.0 && c.hi > 0.0 {
            1.0
        } else if c.hi <= 0.0 && c.lo < 0.0 {
            -1.0
        } else {
            0.0
        }
    };
    let Some(d) = DVec3::from_array(hull.map(sign)).try_normalize() else {
        return false;
    };
    let (e1, e2) = d.any_orthonormal_pair();
    let frame: Frame = std::array::from_fn(|i| [d[i], e1[i], e2[i]]);
    f.grad_in(*cell, &frame).grad[0].excludes_zero()
}
