//! Property tests of the AST printer: random expressions → parse → print as
//! fully parenthesised infix → parse again gives the same tree and the same
//! IR; the printed form is a fixed point.

use isoc::CompileOptions;
use isoc::syntax::ast::StmtKind;
use isoc::syntax::{front_end, parser};
use proptest::prelude::*;

/// Random source text of an expression, with the loosest parentheses that
/// keep the intended tree (so precedence and associativity get exercised).
fn expr() -> impl Strategy<Value = String> {
    let leaf = prop_oneof![
        Just("x".to_string()),
        Just("y".to_string()),
        Just("z".to_string()),
        Just("t".to_string()),
        Just("pi".to_string()),
        (0u32..100).prop_map(|n| n.to_string()),
        (0u32..1000).prop_map(|n| format!("{}.{}", n / 100, n % 100)),
        (1u32..9, -3i32..3).prop_map(|(m, e)| format!("{m}e{e}")),
        (0u32..10).prop_map(|n| format!(".{n}")),
    ];
    leaf.prop_recursive(6, 64, 4, |inner| {
        prop_oneof![
            (inner.clone(), inner.clone(), 0usize..5, any::<bool>()).prop_map(|(a, b, op, p)| {
                let op = ["+", "-", "*", "/", "^"][op];
                // Sometimes drop the parentheses: the parser's precedence
                // then decides the tree, which must still round-trip.
                if p {
                    format!("({a}) {op} ({b})")
                } else {
                    format!("{a} {op} {b}")
                }
            }),
            inner.clone().prop_map(|a| format!("-{a}")),
            inner.clone().prop_map(|a| format!("-({a})")),
            (inner.clone(), 0usize..10).prop_map(|(a, f)| {
                let f = [
                    "sqrt", "abs", "sin", "cos", "tan", "asin", "acos", "atan", "exp", "log",
                ][f];
                format!("{f}({a})")
            }),
            (inner.clone(), inner.clone(), 0usize..4).prop_map(|(a, b, f)| {
                let f = ["atan2", "pow", "min", "max"][f];
                format!("{f}({a}, {b})")
            }),
            prop::collection::vec(inner, 2..5).prop_map(|v| format!("max({})", v.join(", "))),
        ]
    })
}

/// The surface expression of `src`, printed as infix, and the s-expression
/// of the whole file.
fn reprint(src: &str) -> (String, String) {
    let ast = parser::parse(src);
    assert!(ast.errors.is_empty(), "{src}: {:?}", ast.errors);
    let Some(StmtKind::Surface { lhs, .. }) = ast.stmts.last().map(|s| &s.kind) else {
        panic!("no surface in {src}");
    };
    let mut out = String::new();
    ast.print_infix(*lhs, &mut out);
    (out, ast.print())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(10_000))]

    #[test]
    fn print_parse_roundtrip(e in expr()) {
        let src = format!("domain [-1, 1]^3;\nsurface {e};\n");
        let (printed, sexpr) = reprint(&src);
        let src2 = format!("domain [-1, 1]^3;\nsurface {printed};\n");
        let (printed2, sexpr2) = reprint(&src2);
        prop_assert_eq!(&sexpr, &sexpr2);
        prop_assert_eq!(&printed, &printed2);
        let opts = CompileOptions::default();
        let p1 = front_end(&src, "a.iso", &opts).map_err(|e| TestCaseError::fail(e.render()))?;
        let p2 = front_end(&src2, "b.iso", &opts).map_err(|e| TestCaseError::fail(e.render()))?;
        prop_assert_eq!(p1.program, p2.program);
    }
}
