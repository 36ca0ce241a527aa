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

/// What a value of a program is, as a function of `x, y, z` on a cell
/// (`t` is fixed while a mesh is made): [`two_planes`]'s classes.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Shape {
    /// The same everywhere.
    Constant,
    /// Affine: its zero set is one plane.
    Affine,
    /// The `min` or `max` of two affine functions (or such a value plus an
    /// affine one, scaled): two half-planes joined along a line.
    Kinked,
    /// Anything else.
    Other,
}

/// Whether `program` is, as a function of `x, y, z`, the `min` or `max`
/// of two affine functions (up to affine terms added and a constant
/// factor): its zero set in any cell is then two planar pieces joined
/// along one straight crease, or one of them.
fn two_planes(program: &crate::ir::Program) -> bool {
    use crate::ir::{BinOp, Op, UnOp, Var};
    use Shape::*;
    let mut shape: Vec<Shape> = Vec::with_capacity(program.insts.len());
    for op in &program.insts {
        let at = |v: crate::ir::Value| shape[v.index()];
        let s = match *op {
            Op::Const(_) | Op::Var(Var::T) => Constant,
            Op::Var(_) => Affine,
            Op::Unary(UnOp::Neg, a) => at(a),
            Op::Unary(_, a) | Op::Powi(a, _) => {
                if at(a) == Constant {
                    Constant
                } else {
                    Other
                }
            }
            Op::Binary(b, x, y) => {
                let (x, y) = (at(x), at(y));
                match b {
                    BinOp::Add | BinOp::Sub => match (x.max(y), x.min(y)) {
                        (Kinked, Kinked) | (Other, _) => Other,
                        (hi, _) => hi,
                    },
                    BinOp::Mul => match (x, y) {
                        (Constant, s) | (s, Constant) => s,
                        _ => Other,
                    },
                    BinOp::Div if y == Constant => x,
                    BinOp::Min | BinOp::Max => match (x, y) {
                        (Constant | Affine, Constant | Affine) => {
                            if x == Constant && y == Constant {
                                Constant
                            } else {
                                Kinked
                            }
                        }
                        _ => Other,
                    },
                    _ if x == Constant && y == Constant => Constant,
                    _ => Other,
                }
            }
        };
        shape.push(s);
    }
    shape.get(program.output.index()) == Some(&Kinked)
}

/// The look at cells above the last level whose program, pruned on the
/// cell's own box (`program` is pruned on an ancestor's), is planar
/// pieces; only cells whose verdict failed and on which `F` is defined but
/// not differentiable are looked at, and none on the boundary of Ω (a
/// crease that ends on ∂Ω would be cut off there, where the mesher splits
/// no edge).
///
/// - A [`sheet`] (two solids sharing a face) is flagged
///   ([`Verdict::sheet`]): no finer level would decide more.
/// - With the paper's test, on the level just above the last
///   (`next_is_last`), a cell whose pruned program is [`two_planes`]
///   passes the topology test when the derivative along its gradient's
///   sign pattern is proved nonzero (as [`crease_look`]), and then the
///   geometry and chord tests too: its surface is two planar pieces,
///   which the mesher's crease pass rebuilds through the cell. Higher up
///   the cells are too coarse for that: on colonnade.vm, stopping two-plane
///   cells at every level rose the chord error from 0.23 to 0.27 cells
///   for no time saved (`docs/faithful.md`).
///
/// Each cell's pruned program goes to `owns` (the same index), for its
/// children should the cell be subdivided ([`super::tape::Tape::child`]):
/// pruning again on the same box would give the same program.
pub(super) fn planar_look(
    program: &crate::ir::Program,
    cells: &[[Interval; 4]],
    verdicts: &mut [Verdict],
    opts: &OctreeOptions,
    sides: &[[(bool, bool); 3]],
    next_is_last: bool,
    owns: &mut [Option<crate::ir::Program>],
) {
    let looks = cells.iter().zip(verdicts.iter_mut()).zip(sides);
    for (((cell, v), sides), slot) in looks.zip(owns) {
        let on_boundary = sides.iter().any(|&(lo, hi)| lo || hi);
        if v.empty || !v.defined || v.smooth || v.passed(false) || on_boundary {
            continue;
        }
        let own = crate::eval::Reference(crate::eval::prune::prune(program, *cell));
        look_planar(&own, cell, v, opts, next_is_last);
        *slot = Some(own.0);
    }
}

/// [`planar_look`] on one cell, with its own program `own`.
fn look_planar(
    own: &crate::eval::Reference,
    cell: &[Interval; 4],
    v: &mut Verdict,
    opts: &OctreeOptions,
    next_is_last: bool,
) {
    if sheet(&own.0, cell, opts.t) {
        v.sheet = true;
        return;
    }
    if !next_is_last || opts.test != TopologyTest::Paper || !two_planes(&own.0) {
        return;
    }
    // The direction from the cell's own program: its gradient hull is
    // the two planes' normals alone.
    if along_signs(own, cell, own.grad(*cell).grad) {
        v.topology_ok = true;
        v.geometry_ok = true;
    }
}

/// The affine form `[a, b, c, d]` (`a·x + b·y + c·z + d`) of each value of
/// `program` that is affine in `x, y, z` at time `t`.
fn affine_forms(program: &crate::ir::Program, t: f64) -> Vec<Option<[f64; 4]>> {
    use crate::ir::{BinOp, Op, UnOp, Var};
    let mut forms: Vec<Option<[f64; 4]>> = Vec::with_capacity(program.insts.len());
    let constant = |f: &[f64; 4]| f[..3].iter().all(|&c| c == 0.0);
    for op in &program.insts {
        let at = |v: crate::ir::Value| forms.get(v.index()).copied().flatten();
        let zip = |a: [f64; 4], b: [f64; 4], op: fn(f64, f64) -> f64| {
            Some(std::array::from_fn(|k| op(a[k], b[k])))
        };
        let form = match *op {
            Op::Var(Var::X) => Some([1.0, 0.0, 0.0, 0.0]),
            Op::Var(Var::Y) => Some([0.0, 1.0, 0.0, 0.0]),
            Op::Var(Var::Z) => Some([0.0, 0.0, 1.0, 0.0]),
            Op::Var(Var::T) => Some([0.0, 0.0, 0.0, t]),
            Op::Const(c) => Some([0.0, 0.0, 0.0, c.value]).filter(|_| c.defined),
            Op::Unary(UnOp::Neg, a) => at(a).map(|a| a.map(|c| -c)),
            Op::Binary(b, x, y) => match (b, at(x), at(y)) {
                (BinOp::Add, Some(x), Some(y)) => zip(x, y, |p, q| p + q),
                (BinOp::Sub, Some(x), Some(y)) => zip(x, y, |p, q| p - q),
                (BinOp::Mul, Some(x), Some(y)) if constant(&x) => Some(y.map(|c| c * x[3])),
                (BinOp::Mul, Some(x), Some(y)) if constant(&y) => Some(x.map(|c| c * y[3])),
                (BinOp::Div, Some(x), Some(y)) if constant(&y) => Some(x.map(|c| c / y[3])),
                _ => None,
            },
            _ => None,
        };
        forms.push(form.filter(|f| f.iter().all(|c| c.is_finite())));
    }
    forms
}

/// Whether `program` is `max(A, B)` (`Some(true)`) or `min(A, B)`
/// (`Some(false)`) of two affine values with `B = −A`, `A` not constant:
/// `±|A|`, which touches 0 along a plane without changing sign.
fn touching(program: &crate::ir::Program, t: f64) -> Option<bool> {
    use crate::ir::{BinOp, Op};
    let Some(&Op::Binary(b @ (BinOp::Max | BinOp::Min), x, y)) =
        program.insts.get(program.output.index())
    else {
        return None;
    };
    let forms = affine_forms(program, t);
    let (a, c) = (
        forms.get(x.index())?.as_ref()?,
        forms.get(y.index())?.as_ref()?,
    );
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let opposite = (0..4).all(|k| (a[k] + c[k]).abs() <= 1e-12 * scale);
    (opposite && a[..3].iter().any(|&v| v != 0.0)).then_some(b == BinOp::Max)
}

/// Whether `program`, pruned on `cell`, is a sheet where two solids share
/// a face ([`touching`]) whose sign at the cell's centre is the sheet's
/// own: `|A| ≥ 0` everywhere, or `−|A| < 0` at the centre, so the centre,
/// the one point the dual grid samples of a leaf, reads as its finer
/// cells' centres all would (a zero reads as outside).
fn sheet(program: &crate::ir::Program, cell: &[Interval; 4], t: f64) -> bool {
    match touching(program, t) {
        Some(true) => true,
        Some(false) => {
            let mid = |k: usize| 0.5 * (cell[k].lo + cell[k].hi);
            crate::eval::point::eval(program, [mid(0), mid(1), mid(2), t]) < 0.0
        }
        None => false,
    }
}
