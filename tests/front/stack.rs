//! Hostile inputs: each must give a result or an error quickly, without
//! panicking or overflowing the (default, 2 MiB) test thread stack.

use crate::support::front::*;
use isoc::CompileOptions;
use isoc::syntax::{emit_ast, front_end, source_from_bytes};
use std::time::{Duration, Instant};

/// Runs the whole front end (and the AST printer) on `src`; returns whether
/// it compiled. Fails if it takes too long.
fn run(src: &str) -> bool {
    let start = Instant::now();
    let r = front_end(src, "h.iso", &CompileOptions::default());
    if let Err(e) = &r {
        let _ = e.render();
    }
    let _ = emit_ast(src, "h.iso");
    let took = start.elapsed();
    assert!(took < Duration::from_secs(2), "took {took:?}");
    r.is_ok()
}

const D: &str = "domain [-1, 1]^3;\n";

#[test]
fn deep_parentheses() {
    let n = 20_000;
    let src = format!("{D}surface {}x{};", "(".repeat(n), ")".repeat(n));
    assert!(run(&src));
    // unbalanced: an error, not a crash
    let src = format!("{D}surface {}x;", "(".repeat(n));
    assert!(!run(&src));
}

#[test]
fn many_unary_minuses() {
    let n = 20_000;
    let src = format!("{D}surface {}x;", "-".repeat(n));
    assert!(run(&src));
    let l = compile(&src);
    assert_eq!(eval(&l.program, [2.0, 0.0, 0.0, 0.0]), 2.0); // even count
    let src = format!("{D}surface {}x;", "-".repeat(n + 1));
    assert_eq!(eval(&compile(&src).program, [2.0, 0.0, 0.0, 0.0]), -2.0);
}

#[test]
fn long_sum() {
    let n = 100_000;
    let src = format!("{D}surface x{};", " + 1".repeat(n));
    assert!(run(&src));
    let l = compile(&src);
    assert_eq!(eval(&l.program, [0.5, 0.0, 0.0, 0.0]), 0.5 + n as f64);
}

#[test]
fn long_right_deep_power_chain() {
    let n = 20_000;
    let src = format!("{D}surface {}1;", "1^".repeat(n));
    assert!(run(&src));
}

#[test]
fn huge_exponent() {
    let src = format!("{D}surface x^10000000000 - 1;");
    assert!(run(&src));
    assert!(run(&format!("{D}surface x^-10000000000000000000000 - 1;")));
    assert!(run(&format!("{D}surface x^1e300 - 1;")));
}

#[test]
fn deep_function_nesting() {
    // Each fn calls the previous one twice: exponential if not memoised.
    let mut src = String::from(D);
    src.push_str("fn f0(u) = u*u + 1;\n");
    for i in 1..60 {
        src.push_str(&format!("fn f{i}(u) = f{}(u) + f{}(u);\n", i - 1, i - 1));
    }
    src.push_str("surface f59(x);\n");
    assert!(run(&src));
}

#[test]
fn exponential_inlining_is_an_error_not_a_hang() {
    // Distinct arguments defeat memoisation: the inlined size is 2^40.
    let mut src = String::from(D);
    src.push_str("fn f0(u) = u*u;\n");
    for i in 1..40 {
        src.push_str(&format!(
            "fn f{i}(u) = f{}(u + 1) * f{}(u + 2);\n",
            i - 1,
            i - 1
        ));
    }
    src.push_str("surface f39(x);\n");
    assert!(!run(&src));
    let r = error(&src);
    assert!(r.contains("too large"), "{r}");
}

#[test]
fn deep_let_chain() {
    let mut src = String::from(D);
    src.push_str("let a0 = x;\n");
    for i in 1..5000 {
        src.push_str(&format!("let a{i} = a{} * 2 - a{};\n", i - 1, i - 1));
    }
    src.push_str("surface a4999;\n");
    assert!(run(&src));
}

#[test]
fn binary_garbage() {
    // A deterministic pseudo-random byte soup, lossily decoded.
    let mut s: u64 = 0x1234_5678_9abc_def0;
    let bytes: Vec<u8> = (0..200_000)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 24) as u8
        })
        .collect();
    let start = Instant::now();
    let r = source_from_bytes(&bytes, "g.iso");
    let src = match r {
        Ok(s) => s,
        Err(e) => {
            assert!(!e.render().is_empty());
            String::from_utf8_lossy(&bytes).into_owned()
        }
    };
    assert!(start.elapsed() < Duration::from_secs(2));
    assert!(!run(&src));
    let text: String = bytes.iter().map(|&b| (b % 96 + 32) as char).collect();
    assert!(!run(&text));
}

#[test]
fn nul_bytes_and_empty_input() {
    assert!(!run("\0\0\0"));
    assert!(!run(&format!("{D}surface x\0;")));
    assert!(!run(""));
    assert!(!run("   \n# only a comment"));
    assert!(!run(";;;;"));
}

#[test]
fn invalid_utf8_everywhere() {
    let bytes: Vec<u8> = (0..100_000)
        .map(|i| if i % 2 == 0 { 0xff } else { b'x' })
        .collect();
    let start = Instant::now();
    let e = source_from_bytes(&bytes, "u.iso").unwrap_err();
    let _ = e.render();
    assert!(start.elapsed() < Duration::from_secs(2));
}

#[test]
fn many_errors_are_capped() {
    let src = "let = ;\n".repeat(10_000);
    let r = error(&src);
    assert!(headers(&r).len() <= isoc::syntax::MAX_DIAGNOSTICS + 1);
    assert!(r.contains("too many errors"), "{r}");
}

#[test]
fn many_semantic_errors_stay_linear() {
    let mut src = String::from(D);
    for i in 0..10_000 {
        src.push_str(&format!(
            "let name{i} = nam{i} + g{i}(x) + later{i};\nfn f{i}(u) = h{i}(u);\n"
        ));
    }
    src.push_str("surface x;\n");
    assert!(!run(&src));
}

#[test]
fn deep_calls_and_wide_calls() {
    let n = 20_000;
    let src = format!("{D}surface {}x{};", "sin(".repeat(n), ")".repeat(n));
    assert!(run(&src));
    let src = format!(
        "{D}fn f(u) = u + 1;\nsurface {}x{};",
        "f(".repeat(n),
        ")".repeat(n)
    );
    assert!(run(&src));
    let l = compile(&src);
    assert_eq!(eval(&l.program, [0.5, 0.0, 0.0, 0.0]), 0.5 + n as f64);
    let args = vec!["x"; 100_000].join(", ");
    assert!(run(&format!("{D}surface max({args}, y);")));
}

#[test]
fn vm_one_megabyte_chain() {
    // 50,000 `add` lines, each using the previous: one long dependency
    // chain (~1 MB). Must compile and evaluate without recursion, quickly.
    use std::fmt::Write;
    let n = 50_000;
    let mut src = String::from("# a long chain\n_0 var-x\n");
    for i in 1..=n {
        let _ = writeln!(src, "_{i} add _{} _0", i - 1);
    }
    assert!(src.len() > 1_000_000, "{}", src.len());
    let start = Instant::now();
    let s = isoc::Surface::compile(&src, "chain.vm", &CompileOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()));
    assert_eq!(s.program.len(), n + 1);
    assert_eq!(s.point([1.0, 0.0, 0.0, 0.0]), (n + 1) as f64);
    let took = start.elapsed();
    assert!(took < Duration::from_secs(10), "took {took:?}");
    // An error at the very end of the long file is still located.
    src.push_str("_bad add _1 _nope\n");
    let e = isoc::Surface::compile(&src, "chain.vm", &CompileOptions::default()).unwrap_err();
    assert!(
        e.render().starts_with(&format!(
            "chain.vm:{}:13: error: `_nope` is not defined",
            n + 3
        )),
        "{}",
        e.render()
    );
}
