//! Helpers shared by the front-end tests: compile a source string and
//! evaluate the lowered program at a point with a tiny local interpreter
//! (independent of `isoc::eval`).
#![allow(dead_code)]

use isoc::ir::{BinOp, Op, Program, UnOp};
use isoc::syntax::{FrontError, Lowered, front_end};
use isoc::{Bounds, CompileOptions};

pub fn compile(src: &str) -> Lowered {
    match front_end(src, "test.iso", &CompileOptions::default()) {
        Ok(l) => l,
        Err(e) => panic!("unexpected error:\n{}", e.render()),
    }
}

/// Compiles `surface EXPR;` in a unit cube.
pub fn expr(e: &str) -> Program {
    compile(&format!("domain [-1, 1]^3;\nsurface {e};\n")).program
}

/// Value of `e` at a point.
pub fn val(e: &str, p: [f64; 4]) -> f64 {
    eval(&expr(e), p)
}

/// The rendered error of a source that must fail.
pub fn error(src: &str) -> String {
    error_with(src, &CompileOptions::default())
}

pub fn error_with(src: &str, opts: &CompileOptions) -> String {
    match front_end(src, "test.iso", opts) {
        Ok(_) => panic!("expected an error for:\n{src}"),
        Err(FrontError::Source(e)) => e.render(),
        Err(e) => panic!("expected a source error, got {e:?}"),
    }
}

/// The first lines (`FILE:LINE:COL: error: …`) of every diagnostic.
pub fn headers(rendered: &str) -> Vec<&str> {
    rendered
        .lines()
        .filter(|l| l.starts_with("test.iso:"))
        .collect()
}

pub fn cube(a: f64, b: f64) -> Bounds {
    Bounds {
        lo: [a; 3],
        hi: [b; 3],
    }
}

/// A straightforward point interpreter over the IR.
pub fn eval(p: &Program, input: [f64; 4]) -> f64 {
    let mut v: Vec<f64> = Vec::with_capacity(p.insts.len());
    for op in &p.insts {
        let r = match *op {
            Op::Var(x) => input[x.index()],
            Op::Const(c) => c.value,
            Op::Unary(u, a) => {
                let a = v[a.index()];
                match u {
                    UnOp::Neg => -a,
                    UnOp::Abs => a.abs(),
                    UnOp::Sqrt => a.sqrt(),
                    UnOp::Square => a * a,
                    UnOp::Exp => a.exp(),
                    UnOp::Log => a.ln(),
                    UnOp::Sin => a.sin(),
                    UnOp::Cos => a.cos(),
                    UnOp::Tan => a.tan(),
                    UnOp::Asin => a.asin(),
                    UnOp::Acos => a.acos(),
                    UnOp::Atan => a.atan(),
                    UnOp::Floor => a.floor(),
                    UnOp::Ceil => a.ceil(),
                    UnOp::Round => a.round(),
                    UnOp::Not => (a == 0.0) as u8 as f64,
                }
            }
            Op::Binary(b, x, y) => {
                let (a, c) = (v[x.index()], v[y.index()]);
                match b {
                    BinOp::Add => a + c,
                    BinOp::Sub => a - c,
                    BinOp::Mul => a * c,
                    BinOp::Div => a / c,
                    BinOp::Min => a.min(c),
                    BinOp::Max => a.max(c),
                    BinOp::Atan2 => a.atan2(c),
                    BinOp::Pow => {
                        if c.fract() == 0.0 || a > 0.0 {
                            a.powf(c)
                        } else {
                            f64::NAN
                        }
                    }
                    BinOp::Compare => a.partial_cmp(&c).map_or(f64::NAN, |o| o as i8 as f64),
                    BinOp::Mod => a.rem_euclid(c),
                    BinOp::And => {
                        if a == 0.0 {
                            a
                        } else {
                            c
                        }
                    }
                    BinOp::Or => {
                        if a != 0.0 {
                            a
                        } else {
                            c
                        }
                    }
                }
            }
            Op::Powi(a, n) => v[a.index()].powf(n as f64),
        };
        v.push(r);
    }
    v[p.output.index()]
}

pub fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()))
}
