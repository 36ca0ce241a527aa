//! The shared backend suite run against the reference interpreters, plus
//! tests showing the suite's checks catch broken backends.

mod common;

use common::{check_degenerate, check_grad, check_interval};
use isoc::eval::{Backend, GradEval, Reference};
use isoc::interval::{DecInterval, Interval};
use isoc::ir::{BinOp, Op, Program, UnOp, Value, Var};

backend_suite!(reference, |p: &Program| Reference(p.clone()));

/// A wrong backend: shrinks intervals by one ulp at the top, drops the
/// undefinedness flag and reports a zero gradient.
struct Broken(Reference, u8);

impl Backend for Broken {
    fn point(&self, p: [f64; 4]) -> f64 {
        self.0.point(p)
    }
    fn interval(&self, b: [Interval; 4]) -> DecInterval {
        let r = self.0.interval(b);
        match self.1 {
            0 => DecInterval::new(Interval::new(r.iv.lo, r.iv.hi.next_down()), r.defined),
            _ => DecInterval::new(r.iv, true),
        }
    }
    fn grad(&self, b: [Interval; 4]) -> GradEval {
        let mut g = self.0.grad(b);
        g.grad = [Interval::point(0.0); 3];
        g
    }
}

fn prog(insts: Vec<Op>) -> Program {
    let output = Value(insts.len() as u32 - 1);
    Program { insts, output }
}

fn boxed(x: Interval) -> [Interval; 4] {
    [
        x,
        Interval::point(0.0),
        Interval::point(0.0),
        Interval::point(0.0),
    ]
}

#[test]
fn checks_catch_a_narrow_interval() {
    let p = prog(vec![Op::Var(Var::X)]);
    let b = boxed(Interval::new(0.0, 1.0));
    assert!(check_interval(&Reference(p.clone()), &p, &b, 1).is_ok());
    assert!(check_interval(&Broken(Reference(p.clone()), 0), &p, &b, 1).is_err());
    let d = [1.0, 0.0, 0.0, 0.0];
    assert!(check_degenerate(&Broken(Reference(p.clone()), 0), &p, d).is_err());
}

#[test]
fn checks_catch_a_false_defined_flag() {
    // sqrt(x) on [-1, 1]: undefined at the negative samples.
    let p = prog(vec![Op::Var(Var::X), Op::Unary(UnOp::Sqrt, Value(0))]);
    let b = boxed(Interval::new(-1.0, 1.0));
    assert!(check_interval(&Reference(p.clone()), &p, &b, 7).is_ok());
    assert!(check_interval(&Broken(Reference(p.clone()), 1), &p, &b, 7).is_err());
}

#[test]
fn checks_catch_a_wrong_gradient() {
    // x·x on [1, 2]: gradient 2x is never 0.
    let p = prog(vec![
        Op::Var(Var::X),
        Op::Binary(BinOp::Mul, Value(0), Value(0)),
    ]);
    let b = boxed(Interval::new(1.0, 2.0));
    assert!(check_grad(&Reference(p.clone()), &p, &b, 3).is_ok());
    assert!(check_grad(&Broken(Reference(p.clone()), 0), &p, &b, 3).is_err());
}
