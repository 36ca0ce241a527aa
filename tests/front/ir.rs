//! The IR's own contract: builder simplification, hash-consing, sound
//! constant folding, dead-code elimination and the text form's round trip.

use isoc::ir::{BinOp, Builder, Const, Op, Program, UnOp, Var, text};

fn lit(b: &mut Builder, t: &str) -> isoc::ir::Value {
    b.constant(Const::literal(t).unwrap())
}

#[test]
fn hash_consing_shares_identical_instructions() {
    let mut b = Builder::new();
    let x = b.var(Var::X);
    let y = b.var(Var::Y);
    let s1 = b.binary(BinOp::Add, x, y);
    let s2 = b.binary(BinOp::Add, y, x); // commutative: same value
    assert_eq!(s1, s2);
    let d1 = b.binary(BinOp::Sub, x, y);
    let d2 = b.binary(BinOp::Sub, y, x); // not commutative
    assert_ne!(d1, d2);
    let m = b.binary(BinOp::Mul, s1, d1);
    let p = b.finish(m);
    // x, y, add, sub, mul
    assert_eq!(p.len(), 5, "{p}");
}

#[test]
fn algebraic_rules() {
    let mut b = Builder::new();
    let x = b.var(Var::X);
    let one = b.num(1.0);
    let zero = b.num(0.0);
    assert_eq!(b.binary(BinOp::Mul, x, one), x);
    assert_eq!(b.binary(BinOp::Add, zero, x), x);
    assert_eq!(b.binary(BinOp::Div, x, one), x);
    let sq = b.binary(BinOp::Mul, x, x);
    assert_eq!(b.op(sq), Op::Unary(UnOp::Square, x));
    let two = b.num(2.0);
    assert_eq!(b.power(x, two), sq);
    let n = b.unary(UnOp::Neg, x);
    assert_eq!(b.unary(UnOp::Neg, n), x);
    let three = b.num(3.0);
    let m3 = b.unary(UnOp::Neg, three);
    let p = b.power(x, m3);
    assert_eq!(b.op(p), Op::Powi(x, -3));
    let half = lit(&mut b, "0.5");
    let q = b.power(x, half);
    assert_eq!(b.op(q), Op::Binary(BinOp::Pow, x, half));
    // a - (-b) → a + b
    let y = b.var(Var::Y);
    let ny = b.unary(UnOp::Neg, y);
    let s = b.binary(BinOp::Sub, x, ny);
    assert_eq!(b.op(s), Op::Binary(BinOp::Add, x, y));
}

#[test]
fn folding_keeps_the_real_value_enclosed() {
    // The soundness trap: 0.1 + 0.2 folded in round-to-nearest is
    // 0.30000000000000004, above the real 0.3.
    let mut b = Builder::new();
    let a = lit(&mut b, "0.1");
    let c = lit(&mut b, "0.2");
    let s = b.binary(BinOp::Add, a, c);
    let k = b.as_const(s).expect("folded");
    assert_eq!(
        k.value,
        0.1 + 0.2,
        "point value as the point evaluator computes it"
    );
    // The real 0.3 lies strictly between the f64 0.3 and the next one up.
    assert!(k.lo <= 0.3 && k.hi >= 0.3f64.next_up(), "{k:?}");
    // pi's enclosure contains the real π.
    let pi = Const::pi();
    assert!(pi.lo == std::f64::consts::PI && pi.hi > std::f64::consts::PI);
    // Folding through a transcendental stays an enclosure of the real value:
    // sin(pi) is a tiny positive number (π's f64 is below π), never exactly 0.
    let p = b.constant(pi);
    let sp = b.unary(UnOp::Sin, p);
    let k = b.as_const(sp).unwrap();
    assert!(
        k.lo <= 0.0 && k.hi > 0.0,
        "sin over an enclosure of π: {k:?}"
    );
}

#[test]
fn dead_code_is_removed() {
    let mut b = Builder::new();
    let x = b.var(Var::X);
    let y = b.var(Var::Y);
    let _unused = b.unary(UnOp::Sin, y);
    let out = b.unary(UnOp::Cos, x);
    let p = b.finish(out);
    assert_eq!(p.len(), 2, "{p}");
    assert!(!p.uses_var(Var::Y));
    p.validate().unwrap();
}

fn sample_program() -> Program {
    let mut b = Builder::new();
    let x = b.var(Var::X);
    let y = b.var(Var::Y);
    let z = b.var(Var::Z);
    let t = b.var(Var::T);
    let c = lit(&mut b, "0.1");
    let xs = b.powi(x, 5);
    let a = b.binary(BinOp::Atan2, y, z);
    let l = b.unary(UnOp::Log, t);
    let q = b.binary(BinOp::Pow, xs, c);
    let s = b.binary(BinOp::Min, a, l);
    let m = b.binary(BinOp::Max, s, q);
    let e = b.unary(UnOp::Exp, m);
    b.finish(e)
}

#[test]
fn text_form_round_trips() {
    let p = sample_program();
    let text = p.to_string();
    let back = text::parse(&text).unwrap();
    assert_eq!(back, p, "{text}");
    assert!(
        text.contains("const 0.1 [0.09999999999999999, 0.1]"),
        "{text}"
    );
}

#[test]
fn text_form_errors_name_the_line() {
    let e = text::parse("v0 = var x\nv1 = add v0 v1\noutput v1\n").unwrap_err();
    assert_eq!(e.line, 2);
    let e = text::parse("v0 = var w\noutput v0\n").unwrap_err();
    assert_eq!(e.line, 1);
    let e = text::parse("v0 = var x\n").unwrap_err();
    assert!(e.message.contains("output"));
    let e = text::parse("v0 = frob v0\noutput v0").unwrap_err();
    assert!(e.message.contains("frob"));
}
