//! Random expression trees → printed as `.iso` source with the fewest
//! parentheses the grammar allows → parsed and lowered by the front end →
//! the same IR as building the tree directly with [`Builder`]. This checks
//! precedence, associativity, literals, calls and lowering together.
//!
//! Programs are compared up to renumbering: each value gets a canonical id
//! from its op and its operands' canonical ids (operands of commutative ops
//! sorted), shared between the two programs.

use std::collections::HashMap;

use isoc::CompileOptions;
use isoc::ir::{BinOp, Builder, Const, Op, Program, UnOp, Value, Var};
use isoc::syntax::front_end;
use proptest::prelude::*;

#[derive(Clone, Debug)]
enum Expr {
    Var(Var),
    Num(String),
    Pi,
    Neg(Box<Expr>),
    Bin(char, Box<Expr>, Box<Expr>),
    /// `a ^ b` with `b` a printed exponent (possibly negative literal).
    Pow(Box<Expr>, Box<Expr>),
    Call(&'static str, Vec<Expr>),
}

const UNARY_FNS: [(&str, UnOp); 10] = [
    ("sqrt", UnOp::Sqrt),
    ("abs", UnOp::Abs),
    ("sin", UnOp::Sin),
    ("cos", UnOp::Cos),
    ("tan", UnOp::Tan),
    ("asin", UnOp::Asin),
    ("acos", UnOp::Acos),
    ("atan", UnOp::Atan),
    ("exp", UnOp::Exp),
    ("log", UnOp::Log),
];
const BINARY_FNS: [(&str, BinOp); 4] = [
    ("atan2", BinOp::Atan2),
    ("pow", BinOp::Pow),
    ("min", BinOp::Min),
    ("max", BinOp::Max),
];

fn arb_literal() -> impl Strategy<Value = String> {
    prop_oneof![
        (0u32..20).prop_map(|n| n.to_string()),
        (0u32..1000, 1u32..4).prop_map(|(n, d)| format!(
            "{}.{:0w$}",
            n / 10,
            n % 10,
            w = d as usize
        )),
        (1u32..10, -5i32..5).prop_map(|(m, e)| format!("{m}e{e}")),
        (1u32..100).prop_map(|n| format!(".{n}")),
    ]
}

fn arb_expr() -> impl Strategy<Value = Expr> {
    let leaf = prop_oneof![
        prop::sample::select(Var::ALL.to_vec()).prop_map(Expr::Var),
        arb_literal().prop_map(Expr::Num),
        Just(Expr::Pi),
    ];
    leaf.prop_recursive(6, 48, 3, |inner| {
        prop_oneof![
            inner.clone().prop_map(|a| Expr::Neg(Box::new(a))),
            (
                prop::sample::select(vec!['+', '-', '*', '/']),
                inner.clone(),
                inner.clone()
            )
                .prop_map(|(o, a, b)| Expr::Bin(o, Box::new(a), Box::new(b))),
            (
                inner.clone(),
                prop_oneof![
                    (-4i32..6).prop_map(|n| Expr::Num(n.to_string())),
                    inner.clone(),
                ]
            )
                .prop_map(|(a, b)| Expr::Pow(Box::new(a), Box::new(b))),
            (
                prop::sample::select(UNARY_FNS.map(|f| f.0).to_vec()),
                inner.clone()
            )
                .prop_map(|(f, a)| Expr::Call(f, vec![a])),
            (
                prop::sample::select(BINARY_FNS.map(|f| f.0).to_vec()),
                inner.clone(),
                inner
            )
                .prop_map(|(f, a, b)| Expr::Call(f, vec![a, b])),
        ]
    })
}

/// Binding strength of an expression's top operator: 1 `+ -`, 2 `* /`,
/// 3 unary minus, 4 `^`, 5 atoms.
fn level(e: &Expr) -> u8 {
    match e {
        Expr::Bin('+' | '-', ..) => 1,
        Expr::Bin(..) => 2,
        Expr::Neg(_) => 3,
        Expr::Pow(..) => 4,
        Expr::Num(n) if n.starts_with('-') => 3,
        _ => 5,
    }
}

/// Prints `e`, parenthesised when it binds less tightly than `min`.
fn print(e: &Expr, min: u8, out: &mut String) {
    let paren = level(e) < min;
    if paren {
        out.push('(');
    }
    match e {
        Expr::Var(v) => out.push_str(v.name()),
        Expr::Num(n) => out.push_str(n),
        Expr::Pi => out.push_str("pi"),
        Expr::Neg(a) => {
            out.push('-');
            print(a, 3, out);
        }
        Expr::Bin(o, a, b) => {
            let l = if matches!(o, '+' | '-') { 1 } else { 2 };
            print(a, l, out);
            out.push_str(&format!(" {o} "));
            print(b, l + 1, out);
        }
        Expr::Pow(a, b) => {
            print(a, 5, out);
            out.push('^');
            // Right-associative: the exponent may itself be a power; a
            // signed exponent is allowed (`x^-2`).
            match &**b {
                Expr::Num(n) if n.starts_with('-') => out.push_str(n),
                b => print(b, 4, out),
            }
        }
        Expr::Call(f, args) => {
            out.push_str(f);
            out.push('(');
            for (i, a) in args.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                print(a, 1, out);
            }
            out.push(')');
        }
    }
    if paren {
        out.push(')');
    }
}

fn build(e: &Expr, b: &mut Builder) -> Value {
    match e {
        Expr::Var(v) => b.var(*v),
        Expr::Num(n) => match n.strip_prefix('-') {
            Some(m) => {
                let c = b.constant(Const::literal(m).unwrap());
                b.unary(UnOp::Neg, c)
            }
            None => b.constant(Const::literal(n).unwrap()),
        },
        Expr::Pi => b.constant(Const::pi()),
        Expr::Neg(a) => {
            let a = build(a, b);
            b.unary(UnOp::Neg, a)
        }
        Expr::Bin(o, x, y) => {
            let x = build(x, b);
            let y = build(y, b);
            let op = match o {
                '+' => BinOp::Add,
                '-' => BinOp::Sub,
                '*' => BinOp::Mul,
                _ => BinOp::Div,
            };
            b.binary(op, x, y)
        }
        Expr::Pow(x, y) => {
            let x = build(x, b);
            let y = build(y, b);
            b.power(x, y)
        }
        Expr::Call(f, args) => {
            let vs: Vec<Value> = args.iter().map(|a| build(a, b)).collect();
            if let Some((_, u)) = UNARY_FNS.iter().find(|(n, _)| n == f) {
                b.unary(*u, vs[0])
            } else {
                let (_, o) = BINARY_FNS.iter().find(|(n, _)| n == f).unwrap();
                if *o == BinOp::Pow {
                    // The built-in `pow` means the same as `^`.
                    b.power(vs[0], vs[1])
                } else {
                    b.binary(*o, vs[0], vs[1])
                }
            }
        }
    }
}

/// Canonical ids of every value of `p`, interned in `table`.
fn canonical(p: &Program, table: &mut HashMap<String, usize>) -> usize {
    let mut ids: Vec<usize> = Vec::with_capacity(p.len());
    for op in &p.insts {
        let key = match *op {
            Op::Var(v) => format!("var {}", v.name()),
            Op::Const(c) => format!("const {c}"),
            Op::Unary(u, a) => format!("{} {}", u.name(), ids[a.index()]),
            Op::Powi(a, n) => format!("powi {} {n}", ids[a.index()]),
            Op::Binary(o, a, b) => {
                let (mut x, mut y) = (ids[a.index()], ids[b.index()]);
                if o.is_commutative() && y < x {
                    std::mem::swap(&mut x, &mut y);
                }
                format!("{} {x} {y}", o.name())
            }
        };
        let n = table.len();
        ids.push(*table.entry(key).or_insert(n));
    }
    ids[p.output.index()]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(10_000))]

    #[test]
    fn printed_source_lowers_to_the_same_ir(e in arb_expr()) {
        let mut text = String::new();
        print(&e, 1, &mut text);
        let source = format!("domain [-1, 1]^3;\nsurface {text};\n");
        // The front end alone: this test is about parsing and lowering, and
        // JIT-compiling 10,000 programs would only slow it down.
        let surface = front_end(&source, "gen.iso", &CompileOptions::default())
            .map_err(|err| TestCaseError::fail(format!("{}\n{source}", err.render())))?;
        let mut b = Builder::new();
        let out = build(&e, &mut b);
        let direct = b.finish(out);
        let mut table = HashMap::new();
        let got = canonical(&surface.program, &mut table);
        let want = canonical(&direct, &mut table);
        prop_assert_eq!(got, want, "source: {}\nparsed:\n{}\ndirect:\n{}", source, surface.program, direct);
    }
}
