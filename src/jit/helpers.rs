//! `extern "C"` Rust helpers that the kernels call for the operations they
//! do not inline (transcendentals, division and a few others), registered
//! with `JITBuilder::symbol` under the names in [`SYMBOLS`].
//!
//! Operation codes are indices into [`UnOp::ALL`] / [`BinOp::ALL`]; a code
//! out of range gives NaN (point) or the whole real line, undefined
//! (interval), never a panic. Pointers are to arrays of f64 laid out as in
//! the kernels' ABI (see [`super`]): an interval is `[lo, hi]`, a gradient
//! record is `[F.lo, F.hi, Fx.lo, Fx.hi, Fy.lo, Fy.hi, Fz.lo, Fz.hi]`.
//!
//! The point helpers are the reference evaluator's own per-op functions
//! ([`crate::eval::point`]) and the interval helpers the interval module's
//! per-op enclosures ([`crate::interval`]), so the JIT and the interpreter
//! cannot disagree on them. The gradient helpers apply the chain rule with
//! those same enclosures.

use crate::interval::{self, Interval};
use crate::ir::{BinOp, UnOp};

/// `(name, address)` of every helper, for `JITBuilder::symbols`.
pub fn symbols() -> [(&'static str, *const u8); 7] {
    [
        (PT_UNARY, pt_unary as *const u8),
        (PT_BINARY, pt_binary as *const u8),
        (IV_UNARY, iv_unary as *const u8),
        (IV_BINARY, iv_binary as *const u8),
        (IV_POWI, iv_powi as *const u8),
        (GD_UNARY, gd_unary as *const u8),
        (GD_BINARY, gd_binary as *const u8),
    ]
}

pub const PT_UNARY: &str = "isoc_pt_unary";
pub const PT_BINARY: &str = "isoc_pt_binary";
pub const IV_UNARY: &str = "isoc_iv_unary";
pub const IV_BINARY: &str = "isoc_iv_binary";
pub const IV_POWI: &str = "isoc_iv_powi";
pub const GD_UNARY: &str = "isoc_gd_unary";
pub const GD_BINARY: &str = "isoc_gd_binary";
/// `gd_binary` op code standing for `powi` (with `n` passed as the second
/// operand's `F.lo`).
pub const GD_POWI_CODE: u32 = 1000;

/// The code of a unary op (its index in [`UnOp::ALL`]).
pub fn unop_code(op: UnOp) -> u32 {
    UnOp::ALL.iter().position(|&o| o == op).unwrap_or(0) as u32
}

/// The code of a binary op (its index in [`BinOp::ALL`]).
pub fn binop_code(op: BinOp) -> u32 {
    BinOp::ALL.iter().position(|&o| o == op).unwrap_or(0) as u32
}

const ENTIRE: Interval = Interval {
    lo: f64::NEG_INFINITY,
    hi: f64::INFINITY,
};

extern "C" fn pt_unary(op: u32, a: f64) -> f64 {
    match UnOp::ALL.get(op as usize) {
        Some(&op) => crate::eval::point::unary(op, a),
        None => f64::NAN,
    }
}

extern "C" fn pt_binary(op: u32, a: f64, b: f64) -> f64 {
    match BinOp::ALL.get(op as usize) {
        Some(&op) => crate::eval::point::binary(op, a, b),
        None => f64::NAN,
    }
}

/// # Safety
/// `out` points to 2 writable f64.
unsafe extern "C" fn iv_unary(op: u32, lo: f64, hi: f64, out: *mut f64) -> u8 {
    let (r, d) = match UnOp::ALL.get(op as usize) {
        Some(&op) => interval::unary(op, Interval { lo, hi }),
        None => (ENTIRE, false),
    };
    // SAFETY: the kernel passes a 16-byte aligned stack slot of 2 f64.
    unsafe { write_iv(out, r) };
    d as u8
}

/// # Safety
/// `out` points to 2 writable f64.
unsafe extern "C" fn iv_binary(
    op: u32,
    alo: f64,
    ahi: f64,
    blo: f64,
    bhi: f64,
    out: *mut f64,
) -> u8 {
    let a = Interval { lo: alo, hi: ahi };
    let b = Interval { lo: blo, hi: bhi };
    let (r, d) = match BinOp::ALL.get(op as usize) {
        Some(&op) => interval::binary(op, a, b),
        None => (ENTIRE, false),
    };
    // SAFETY: as in `iv_unary`.
    unsafe { write_iv(out, r) };
    d as u8
}

/// # Safety
/// `out` points to 2 writable f64.
unsafe extern "C" fn iv_powi(lo: f64, hi: f64, n: i64, out: *mut f64) -> u8 {
    let (r, d) = interval::powi(Interval { lo, hi }, n);
    // SAFETY: as in `iv_unary`.
    unsafe { write_iv(out, r) };
    d as u8
}

/// # Safety
/// `out` points to 2 writable f64.
unsafe fn write_iv(out: *mut f64, r: Interval) {
    // SAFETY: guaranteed by the caller.
    unsafe {
        *out = r.lo;
        *out.add(1) = r.hi;
    }
}

/// An interval with its three partial derivatives.
#[derive(Clone, Copy)]
struct Dual {
    v: Interval,
    d: [Interval; 3],
}

/// # Safety
/// `p` points to 8 readable f64.
unsafe fn read_dual(p: *const f64) -> Dual {
    // SAFETY: guaranteed by the caller.
    let r = unsafe { std::slice::from_raw_parts(p, 8) };
    let iv = |i: usize| Interval {
        lo: r[2 * i],
        hi: r[2 * i + 1],
    };
    Dual {
        v: iv(0),
        d: [iv(1), iv(2), iv(3)],
    }
}

/// # Safety
/// `p` points to 8 writable f64.
unsafe fn write_dual(p: *mut f64, g: Dual) {
    // SAFETY: guaranteed by the caller.
    let w = unsafe { std::slice::from_raw_parts_mut(p, 8) };
    for (i, iv) in std::iter::once(g.v).chain(g.d).enumerate() {
        w[2 * i] = iv.lo;
        w[2 * i + 1] = iv.hi;
    }
}

/// Interval arithmetic that ANDs every decoration into `ok`.
struct Ops {
    ok: bool,
}

impl Ops {
    fn b(&mut self, op: BinOp, a: Interval, b: Interval) -> Interval {
        let (r, d) = interval::binary(op, a, b);
        self.ok &= d;
        r
    }
    fn u(&mut self, op: UnOp, a: Interval) -> Interval {
        let (r, d) = interval::unary(op, a);
        self.ok &= d;
        r
    }
    fn powi(&mut self, a: Interval, n: i64) -> Interval {
        let (r, d) = interval::powi(a, n);
        self.ok &= d;
        r
    }
    /// `(f(A), f'(A)·dA)`.
    fn chain(&mut self, v: Interval, fprime: Interval, a: &Dual) -> Dual {
        let d = a.d.map(|di| self.b(BinOp::Mul, fprime, di));
        Dual { v, d }
    }
}

fn point(c: f64) -> Interval {
    Interval { lo: c, hi: c }
}

fn hull(a: Interval, b: Interval) -> Interval {
    Interval {
        lo: a.lo.min(b.lo),
        hi: a.hi.max(b.hi),
    }
}

fn unary_dual(op: UnOp, a: &Dual, o: &mut Ops) -> Dual {
    use BinOp::{Add, Div, Mul, Sub};
    use UnOp::*;
    let one = point(1.0);
    match op {
        Neg => Dual {
            v: o.u(Neg, a.v),
            d: a.d.map(|d| o.u(Neg, d)),
        },
        Abs => {
            let v = o.u(Abs, a.v);
            let s = if a.v.lo > 0.0 {
                one
            } else if a.v.hi < 0.0 {
                point(-1.0)
            } else {
                // |x| is not differentiable at 0.
                o.ok = false;
                Interval { lo: -1.0, hi: 1.0 }
            };
            o.chain(v, s, a)
        }
        Sqrt => {
            let v = o.u(Sqrt, a.v);
            let two_v = o.b(Mul, point(2.0), v);
            let f = o.b(Div, one, two_v);
            o.chain(v, f, a)
        }
        Square => {
            let v = o.u(Square, a.v);
            let f = o.b(Mul, point(2.0), a.v);
            o.chain(v, f, a)
        }
        Exp => {
            let v = o.u(Exp, a.v);
            o.chain(v, v, a)
        }
        Log => {
            let v = o.u(Log, a.v);
            let f = o.b(Div, one, a.v);
            o.chain(v, f, a)
        }
        Sin => {
            let v = o.u(Sin, a.v);
            let f = o.u(Cos, a.v);
            o.chain(v, f, a)
        }
        Cos => {
            let v = o.u(Cos, a.v);
            let s = o.u(Sin, a.v);
            let f = o.u(Neg, s);
            o.chain(v, f, a)
        }
        Tan => {
            let v = o.u(Tan, a.v);
            let t2 = o.u(Square, v);
            let f = o.b(Add, one, t2);
            o.chain(v, f, a)
        }
        Asin | Acos => {
            let v = o.u(op, a.v);
            let x2 = o.u(Square, a.v);
            let r = o.b(Sub, one, x2);
            let s = o.u(Sqrt, r);
            let mut f = o.b(Div, one, s);
            if op == Acos {
                f = o.u(Neg, f);
            }
            o.chain(v, f, a)
        }
        Atan => {
            let v = o.u(Atan, a.v);
            let x2 = o.u(Square, a.v);
            let r = o.b(Add, one, x2);
            let f = o.b(Div, one, r);
            o.chain(v, f, a)
        }
    }
}

fn binary_dual(op: BinOp, a: &Dual, b: &Dual, o: &mut Ops) -> Dual {
    use BinOp::*;
    let v = o.b(op, a.v, b.v);
    let d = match op {
        Add | Sub => [0, 1, 2].map(|i| o.b(op, a.d[i], b.d[i])),
        Mul => [0, 1, 2].map(|i| {
            let p = o.b(Mul, a.v, b.d[i]);
            let q = o.b(Mul, a.d[i], b.v);
            o.b(Add, p, q)
        }),
        Div => [0, 1, 2].map(|i| {
            // (dA − F·dB) / B
            let p = o.b(Mul, v, b.d[i]);
            let q = o.b(Sub, a.d[i], p);
            o.b(Div, q, b.v)
        }),
        Min | Max => {
            let a_wins = if op == Min {
                a.v.hi < b.v.lo
            } else {
                a.v.lo > b.v.hi
            };
            let b_wins = if op == Min {
                b.v.hi < a.v.lo
            } else {
                b.v.lo > a.v.hi
            };
            if a_wins {
                a.d
            } else if b_wins {
                b.d
            } else {
                // Not differentiable where a = b: enclose both branches.
                o.ok = false;
                [0, 1, 2].map(|i| hull(a.d[i], b.d[i]))
            }
        }
        Atan2 => {
            // atan2(y, x)' = (x·dy − y·dx) / (x² + y²), y = a, x = b.
            let x2 = o.u(UnOp::Square, b.v);
            let y2 = o.u(UnOp::Square, a.v);
            let r2 = o.b(Add, x2, y2);
            [0, 1, 2].map(|i| {
                let p = o.b(Mul, b.v, a.d[i]);
                let q = o.b(Mul, a.v, b.d[i]);
                let n = o.b(Sub, p, q);
                o.b(Div, n, r2)
            })
        }
        Pow => {
            // d(a^b) = a^b · (db·ln a + b·da/a)
            let ln = o.u(UnOp::Log, a.v);
            let b_over_a = o.b(Div, b.v, a.v);
            [0, 1, 2].map(|i| {
                let p = o.b(Mul, b.d[i], ln);
                let q = o.b(Mul, b_over_a, a.d[i]);
                let s = o.b(Add, p, q);
                o.b(Mul, v, s)
            })
        }
    };
    Dual { v, d }
}

fn powi_dual(a: &Dual, n: i64, o: &mut Ops) -> Dual {
    let v = o.powi(a.v, n);
    if n == 0 {
        return Dual {
            v,
            d: [point(0.0); 3],
        };
    }
    let pm1 = o.powi(a.v, n - 1);
    // n is exact in f64 up to 2^53; beyond, enclose it.
    let nf = n as f64;
    let n_iv = if nf.abs() <= 9007199254740992.0 {
        point(nf)
    } else {
        Interval {
            lo: nf.next_down(),
            hi: nf.next_up(),
        }
    };
    let f = o.b(BinOp::Mul, n_iv, pm1);
    o.chain(v, f, a)
}

/// # Safety
/// `a` points to 8 readable f64, `out` to 8 writable f64.
unsafe extern "C" fn gd_unary(op: u32, a: *const f64, out: *mut f64) -> u8 {
    // SAFETY: the kernel passes stack slots of 8 f64.
    let a = unsafe { read_dual(a) };
    let mut o = Ops { ok: true };
    let r = match UnOp::ALL.get(op as usize) {
        Some(&op) => unary_dual(op, &a, &mut o),
        None => {
            o.ok = false;
            Dual {
                v: ENTIRE,
                d: [ENTIRE; 3],
            }
        }
    };
    // SAFETY: as above.
    unsafe { write_dual(out, r) };
    o.ok as u8
}

/// # Safety
/// `a`, `b` point to 8 readable f64, `out` to 8 writable f64. For
/// [`GD_POWI_CODE`], `n` is the exponent and `b` is not read.
unsafe extern "C" fn gd_binary(op: u32, a: *const f64, b: *const f64, n: i64, out: *mut f64) -> u8 {
    // SAFETY: the kernel passes stack slots of 8 f64.
    let a = unsafe { read_dual(a) };
    let mut o = Ops { ok: true };
    let r = if op == GD_POWI_CODE {
        powi_dual(&a, n, &mut o)
    } else {
        match BinOp::ALL.get(op as usize) {
            Some(&bop) => {
                // SAFETY: as above; `b` is valid for every binary code.
                let b = unsafe { read_dual(b) };
                binary_dual(bop, &a, &b, &mut o)
            }
            None => {
                o.ok = false;
                Dual {
                    v: ENTIRE,
                    d: [ENTIRE; 3],
                }
            }
        }
    };
    // SAFETY: as above.
    unsafe { write_dual(out, r) };
    o.ok as u8
}
