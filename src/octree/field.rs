//! The function as the octree's leaves see it: point evaluations with the
//! program pruned for the leaf that holds the point.
//!
//! # Contract
//!
//! [`Field`] is an [`Evaluator`] for the same function as the evaluator
//! `f` the octree was built with. A point evaluation (value, or value and
//! gradient) finds the leaf whose box holds the point, by descent from the
//! root with the splitting planes of [`Octree::cell_box`]; when that leaf
//! has a pruned program ([`Octree::tapes`]) the reference interpreter runs
//! it, otherwise `f` evaluates the point. The pruned program is valid on
//! the leaf's closed box ([`crate::eval::prune`]), so the value is the full
//! program's reference value — and `f`'s, for an `f` whose point kernels
//! agree with the reference interpreters bit for bit, as the JIT's do
//! (tested) — except where an overflow inside a dropped branch made the
//! full program NaN (see [`crate::eval::prune`]). Points outside Ω, and
//! every box evaluation, go to `f`.
//!
//! Batches keep `f`'s batch kernels for the points without a pruned
//! program, so a tree built without pruning costs one length check per
//! batch.
//!
//! # Limits
//!
//! The interpreter evaluates one point at a time; it pays where pruning
//! made the programs much shorter than the full one (a sixteenth, against
//! the JIT's point kernels), or where the given evaluator's point kernels
//! are never compiled: those are the programs the octree keeps (see the
//! octree's "Pruning").

use glam::DVec3;

use super::{Octant, Octree};
use crate::eval::{self, Evaluator, GradEval, Reference};
use crate::interval::{DecInterval, Interval};
use crate::ir::Program;

/// See the module doc.
pub struct Field<'a, E: ?Sized> {
    tree: &'a Octree,
    f: &'a E,
    /// The first child of every node (0 for a leaf: the root is nobody's
    /// child), packed (the descent's only read).
    children: Vec<u32>,
    /// Deepest level of a node, and `2^depth`.
    depth: u8,
    scale: f64,
}

impl Octree {
    /// The octree's function as an evaluator (see [`Field`]).
    pub fn field<'a, E: Evaluator + ?Sized>(&'a self, f: &'a E) -> Field<'a, E> {
        let (children, depth) = if self.tapes.is_empty() {
            (Vec::new(), 0)
        } else {
            (
                self.nodes
                    .iter()
                    .map(|n| n.child(Octant(0)).unwrap_or(0))
                    .collect(),
                self.nodes.iter().map(|n| n.level).max().unwrap_or(0),
            )
        };
        Field {
            tree: self,
            f,
            children,
            depth,
            scale: (1u64 << depth) as f64,
        }
    }
}

impl<E: Evaluator + ?Sized> Field<'_, E> {
    /// The pruned program of the leaf holding `p`, if it has one.
    fn tape_at(&self, p: [f64; 3]) -> Option<&Reference> {
        if self.tree.tapes.is_empty() || self.tree.nodes.is_empty() {
            return None;
        }
        let leaf = self.leaf_at(DVec3::from_array(p))?;
        self.tree.tapes.get(leaf)?.as_deref()
    }

    /// The leaf whose (closed) box holds `p`, if `p` is in Ω.
    fn leaf_at(&self, p: DVec3) -> Option<usize> {
        let tree = self.tree;
        // Written so that NaN coordinates fail the test.
        let inside = |a: DVec3, b: DVec3| (0..3).all(|k| a[k] <= p[k] && p[k] <= b[k]);
        // The point's cell at the deepest level, by integer coordinates.
        let u = (p - tree.lo) / tree.size() * self.scale;
        if !(0..3).all(|k| u[k] >= 0.0 && u[k] <= self.scale) {
            return None;
        }
        let top = (1u64 << self.depth) - 1;
        let ijk = [0, 1, 2].map(|k| (u[k] as u64).min(top));
        let mut i = 0usize;
        let mut level = 0u8;
        while self.children[i] != 0 {
            let c = Octant::of_cell(ijk, self.depth - level - 1);
            i = self.children[i] as usize + usize::from(c.0);
            level += 1;
        }
        // Far from the leaf's faces (in units of the deepest cells) the
        // integer descent cannot be wrong; near them, check the box.
        let cells = f64::from(1u32 << (self.depth - level));
        let safe = (0..3).all(|k| (1e-6..=1.0 - 1e-6).contains(&(u[k] / cells).fract()));
        let in_box = |i: usize| {
            let (a, b) = tree.cell_box(&tree.nodes[i]);
            inside(a, b)
        };
        if safe || in_box(i) {
            return Some(i);
        }
        // Rounding put the point on the wrong side of a face: descend
        // again by the splitting planes themselves.
        tree.leaf_containing(p).filter(|&i| in_box(i))
    }
}

impl<E: Evaluator + ?Sized> Evaluator for Field<'_, E> {
    fn point(&self, p: [f64; 4]) -> f64 {
        match self.tape_at([p[0], p[1], p[2]]) {
            Some(r) => r.point(p),
            None => self.f.point(p),
        }
    }
    fn point_grad(&self, p: [f64; 4]) -> (f64, [f64; 3]) {
        match self.tape_at([p[0], p[1], p[2]]) {
            Some(r) => r.point_grad(p),
            None => self.f.point_grad(p),
        }
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        self.f.interval(b)
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        self.f.grad(b)
    }
    fn program(&self) -> Option<&Program> {
        self.f.program()
    }

    fn point_batch(&self, xs: &[f64], ys: &[f64], zs: &[f64], t: f64, out: &mut [f64]) {
        eval::check_len(out.len(), &[xs.len(), ys.len(), zs.len()]);
        if self.tree.tapes.is_empty() {
            return self.f.point_batch(xs, ys, zs, t, out);
        }
        let mut rest = Vec::new();
        for i in 0..out.len() {
            match self.tape_at([xs[i], ys[i], zs[i]]) {
                Some(r) => out[i] = r.point([xs[i], ys[i], zs[i], t]),
                None => rest.push(i),
            }
        }
        if rest.is_empty() {
            return;
        }
        let pick = |s: &[f64]| rest.iter().map(|&i| s[i]).collect::<Vec<f64>>();
        let mut vals = vec![0.0; rest.len()];
        self.f
            .point_batch(&pick(xs), &pick(ys), &pick(zs), t, &mut vals);
        for (&i, v) in rest.iter().zip(vals) {
            out[i] = v;
        }
    }
    fn point_grad_batch(&self, pts: &[[f64; 3]], t: f64, out: &mut [(f64, [f64; 3])]) {
        eval::check_len(out.len(), &[pts.len()]);
        if self.tree.tapes.is_empty() {
            return self.f.point_grad_batch(pts, t, out);
        }
        let mut rest = Vec::new();
        for (i, p) in pts.iter().enumerate() {
            match self.tape_at(*p) {
                Some(r) => out[i] = r.point_grad([p[0], p[1], p[2], t]),
                None => rest.push(i),
            }
        }
        if rest.is_empty() {
            return;
        }
        let sub: Vec<[f64; 3]> = rest.iter().map(|&i| pts[i]).collect();
        let mut vals = vec![(0.0, [0.0; 3]); rest.len()];
        self.f.point_grad_batch(&sub, t, &mut vals);
        for (&i, v) in rest.iter().zip(vals) {
            out[i] = v;
        }
    }
    fn interval_batch(&self, boxes: &[[Interval; 4]], out: &mut [DecInterval]) {
        self.f.interval_batch(boxes, out)
    }
    fn grad_batch(&self, boxes: &[[Interval; 4]], out: &mut [GradEval]) {
        self.f.grad_batch(boxes, out)
    }
}
