//! Parser and lowering tests: every statement form, precedence and
//! associativity, comments, literals, `--emit ast`, `--set`, `--domain`.

use crate::support::front::*;
use isoc::CompileOptions;
use isoc::syntax::FrontError;
use isoc::syntax::{emit_ast, front_end};

const P: [f64; 4] = [0.3, -0.7, 1.9, 0.25];

#[test]
fn precedence_and_associativity() {
    // -x^2 is -(x^2)
    assert_eq!(val("-x^2", [3.0, 0.0, 0.0, 0.0]), -9.0);
    // 2^3^2 = 2^9
    assert_eq!(val("2^3^2", P), 512.0);
    assert_eq!(val("10-4-3", P), 3.0);
    assert_eq!(val("16/4/2", P), 2.0);
    assert_eq!(val("1+2*3", P), 7.0);
    assert_eq!(val("(1+2)*3", P), 9.0);
    assert_eq!(val("2*3^2", P), 18.0);
    assert_eq!(val("-2^2", P), -4.0);
    assert_eq!(val("(-2)^2", P), 4.0);
    assert_eq!(val("2^-1", P), 0.5);
    assert_eq!(val("2^-x", [1.0, 0.0, 0.0, 0.0]), 0.5);
    assert_eq!(val("x^-2", [2.0, 0.0, 0.0, 0.0]), 0.25);
    assert_eq!(val("2^--1", P), 2.0);
    assert_eq!(val("--3", P), 3.0);
    assert_eq!(val("2*-3", P), -6.0);
    assert_eq!(val("6/-3*2", P), -4.0);
    assert_eq!(val("1 - -1", P), 2.0);
}

#[test]
fn variables_and_builtins() {
    let [x, y, z, t] = P;
    assert!(close(val("x + 2*y - z*t", P), x + 2.0 * y - z * t));
    assert!(close(
        val("sqrt(z) + abs(y) + sin(x) + cos(x) + tan(x)", P),
        z.sqrt() + y.abs() + x.sin() + x.cos() + x.tan()
    ));
    assert!(close(
        val("asin(x) + acos(x) + atan(y) + atan2(y, x)", P),
        x.asin() + x.acos() + y.atan() + y.atan2(x)
    ));
    assert!(close(
        val("exp(x) + log(z) + pow(z, 1.5)", P),
        x.exp() + z.ln() + z.powf(1.5)
    ));
    assert_eq!(val("min(3, x, y, z)", P), y);
    assert_eq!(val("max(x, y)", P), x);
    assert_eq!(val("max(x, y, z, t)", P), z);
    assert!(close(val("pi", P), std::f64::consts::PI));
    assert!(close(val("z^0.5", P), z.sqrt()));
}

#[test]
fn number_literals() {
    assert_eq!(
        val("2 + 0.5 + 1e-3 + .5 + 1. + 2E2 + 1.5e+1", P),
        2.0 + 0.5 + 1e-3 + 0.5 + 1.0 + 200.0 + 15.0
    );
    // A literal that is not an f64 is enclosed, not rounded.
    let p = expr("0.1");
    let c = p.insts.iter().find_map(|op| match op {
        isoc::ir::Op::Const(c) => Some(*c),
        _ => None,
    });
    let c = c.expect("a constant");
    assert!(c.lo <= 0.1 && 0.1 <= c.hi && c.lo < c.hi, "{c:?}");
}

#[test]
fn statements() {
    let src = "
        # a comment
        // another comment
        domain [-2, 2], [-3, 3], [-pi, 2*pi];   # trailing comment
        param r = 1.5;
        param s = -2;
        param q = -r * 2;
        let rho = x^2 + y^2;
        fn g(x, y, c) = x*y + c;     // params shadow coordinates
        fn h(a) = g(a, a, r) + s;
        surface h(rho) + z + t + q = 1;
    ";
    let l = compile(src);
    assert_eq!(l.domain.lo, [-2.0, -3.0, -std::f64::consts::PI]);
    assert_eq!(l.domain.hi, [2.0, 3.0, 2.0 * std::f64::consts::PI]);
    assert_eq!(
        l.params,
        vec![("r".into(), 1.5), ("s".into(), -2.0), ("q".into(), -3.0)]
    );
    let [x, y, z, t] = P;
    let rho = x * x + y * y;
    let want = rho * rho + 1.5 - 2.0 + z + t - 3.0 - 1.0;
    assert!(close(eval(&l.program, P), want));
}

#[test]
fn cube_domain_and_constant_bounds() {
    let l = compile("domain [-3.1, 3.1]^3; surface x;");
    assert_eq!(l.domain.lo, [-3.1; 3]);
    assert_eq!(l.domain.hi, [3.1; 3]);
    let l = compile("param a = 2; domain [-a*pi, a]^3; surface x;");
    assert_eq!(l.domain.lo, [-2.0 * std::f64::consts::PI; 3]);
}

#[test]
fn set_and_domain_options() {
    let opts = CompileOptions {
        params: vec![("r".into(), 3.0)],
        domain: Some(cube(-5.0, 5.0)),
    };
    let l = front_end("param r = 1; param d = 2*r; surface x - d;", "f.iso", &opts).unwrap();
    assert_eq!(l.params, vec![("r".into(), 3.0), ("d".into(), 6.0)]);
    assert_eq!(l.domain, cube(-5.0, 5.0));
    assert_eq!(eval(&l.program, [6.0, 0.0, 0.0, 0.0]), 0.0);
    // --domain overrides the file's domain.
    let only_domain = CompileOptions {
        params: vec![],
        domain: Some(cube(-5.0, 5.0)),
    };
    let l = front_end("domain [0,1]^3; surface x;", "f.iso", &only_domain).unwrap();
    assert_eq!(l.domain, cube(-5.0, 5.0));
    // An unknown param override: a typed error naming the closest param.
    let bad = CompileOptions {
        params: vec![("rr".into(), 3.0)],
        domain: None,
    };
    match front_end("domain [0,1]^3; param r = 1; surface x - r;", "f.iso", &bad) {
        Err(e @ FrontError::UnknownParam { .. }) => {
            let FrontError::UnknownParam {
                name,
                closest,
                known,
                ..
            } = &e
            else {
                unreachable!()
            };
            assert_eq!((name.as_str(), closest.as_deref()), ("rr", Some("r")));
            assert_eq!(known, &["r".to_string()]);
            let m = e.to_string();
            assert!(m.contains("`rr`") && m.contains("`r`"), "{m}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn lets_are_lowered_once_and_fns_inlined() {
    let l = compile(
        "domain [-1,1]^3; let a = sin(x); let b = a*a + a; fn f(u) = u + b; surface f(a) + f(b);",
    );
    let sins = l
        .program
        .insts
        .iter()
        .filter(|op| matches!(op, isoc::ir::Op::Unary(isoc::ir::UnOp::Sin, _)))
        .count();
    assert_eq!(sins, 1);
    let a = P[0].sin();
    let b = a * a + a;
    assert!(close(eval(&l.program, P), (a + b) + (b + b)));
}

#[test]
fn emit_ast_prints_structure() {
    let s = emit_ast(
        "domain [-1, 1]^3; let a = -x^2 - y - z; fn f(u, v) = u/v/2; surface f(a, 2^3^t) = 1;",
        "t.iso",
    )
    .unwrap();
    let want = "(domain [(neg 1) 1] ^3)\n\
                (let a (- (- (neg (^ x 2)) y) z))\n\
                (fn f (u v) (/ (/ u v) 2))\n\
                (surface (f a (^ 2 (^ 3 t))) 1)\n";
    assert_eq!(s, want);
    let s = emit_ast(
        "domain [0,1],[0,2],[0,3]; param p = -1.5; surface min(x,y,z);",
        "t.iso",
    )
    .unwrap();
    assert_eq!(
        s,
        "(domain [0 1] [0 2] [0 3])\n(param p (neg 1.5))\n(surface (min x y z))\n"
    );
}

#[test]
fn whitespace_and_comments_everywhere() {
    let l = compile("domain#c\n[-1,1]//c\n^3;surface\tx#c\n+\r\n1//c\n;#end");
    assert_eq!(eval(&l.program, [2.0, 0.0, 0.0, 0.0]), 3.0);
}

#[test]
fn sets_last_value_wins() {
    let opts = CompileOptions {
        params: vec![("r".into(), 3.0), ("r".into(), 4.0)],
        domain: None,
    };
    let l = front_end(
        "domain [0,1]^3; param r = 1; surface x - r;",
        "f.iso",
        &opts,
    )
    .unwrap();
    assert_eq!(l.params, vec![("r".into(), 4.0)]);
}

#[test]
fn bad_options_are_typed_errors() {
    let src = "domain [0,1]^3; param r = 1; surface x - r;";
    let inf = CompileOptions {
        params: vec![("r".into(), f64::INFINITY)],
        domain: None,
    };
    assert!(matches!(
        front_end(src, "f", &inf),
        Err(FrontError::ParamNotFinite { ref name, value }) if name == "r" && value == f64::INFINITY
    ));
    let empty = CompileOptions {
        params: vec![],
        domain: Some(isoc::Bounds {
            lo: [0.0, 1.0, 0.0],
            hi: [1.0, 1.0, 1.0],
        }),
    };
    match front_end(src, "f", &empty) {
        Err(e @ FrontError::BadDomain(d)) => {
            assert_eq!(d.hi[1], 1.0);
            assert!(e.to_string().starts_with("domain:"), "{e}");
        }
        other => panic!("{other:?}"),
    }
}
