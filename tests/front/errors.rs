//! One test per error kind: the message, `FILE:LINE:COL` and the caret.

use crate::support::front::*;
use isoc::CompileOptions;
use isoc::syntax::source_from_bytes;

const D: &str = "domain [-1, 1]^3;\n";

/// Asserts that `src` fails with exactly these diagnostic header lines.
fn expect(src: &str, want: &[&str]) -> String {
    let r = error(src);
    assert_eq!(headers(&r), want, "full output:\n{r}");
    r
}

#[test]
fn render_format_has_source_line_and_caret() {
    let r = expect(
        "domain [-1, 1]^3;\nlet a = sqr(x);\nsurface a;",
        &["test.iso:2:9: error: unknown function `sqr`"],
    );
    let lines: Vec<&str> = r.lines().collect();
    assert_eq!(lines[1], "  |");
    assert_eq!(lines[2], "2 | let a = sqr(x);");
    assert_eq!(lines[3], "  |         ^^^");
    assert_eq!(lines[4], "  = help: did you mean `sqrt`?");
}

#[test]
fn lexical_error() {
    expect(
        &format!("{D}surface x $ 2;"),
        &["test.iso:2:11: error: unexpected character `$`"],
    );
}

#[test]
fn nul_bytes_are_lexical_errors() {
    expect(
        &format!("{D}surface x\0;"),
        &["test.iso:2:10: error: unexpected character `U+0000`"],
    );
}

#[test]
fn invalid_utf8() {
    let e = source_from_bytes(b"domain [-1,1]^3;\nsurface x\xff;", "test.iso").unwrap_err();
    assert_eq!(
        headers(&e.render()),
        ["test.iso:2:10: error: invalid UTF-8 (bytes 0xff)"]
    );
    assert_eq!(source_from_bytes(b"surface x;", "f").unwrap(), "surface x;");
}

#[test]
fn syntax_error() {
    let r = expect(
        &format!("{D}surface (x + ;"),
        &["test.iso:2:14: error: unexpected `;`"],
    );
    assert!(
        r.contains("expected one of a name, a number, `-`, `(`"),
        "{r}"
    );
}

#[test]
fn unexpected_end_of_file() {
    expect(
        &format!("{D}surface x"),
        &["test.iso:2:10: error: unexpected end of file"],
    );
}

#[test]
fn every_syntax_error_is_reported() {
    expect(
        "domain [-1, 1]^3;\nlet a = 1 +;\nlet b = (x;\nlet c = 2 # 3\n  * ) ;\nsurface a @ b;\nlet d = x x;",
        &[
            "test.iso:2:12: error: unexpected `;`",
            "test.iso:3:11: error: unexpected `;`",
            "test.iso:5:5: error: unexpected `)`",
            "test.iso:6:11: error: unexpected character `@`",
            "test.iso:7:11: error: unexpected name `x`",
        ],
    );
}

#[test]
fn syntax_and_semantic_errors_together() {
    expect(
        "domain [-1, 1]^3;\nlet a = foo;\nlet b = 1 +;\nsurface a + bar;",
        &[
            "test.iso:2:9: error: unknown name `foo`",
            "test.iso:3:12: error: unexpected `;`",
            "test.iso:4:13: error: unknown name `bar`",
        ],
    );
}

#[test]
fn unknown_name_with_suggestion() {
    let r = expect(
        &format!("{D}let radius = 2;\nsurface x^2 - radus;"),
        &["test.iso:3:15: error: unknown name `radus`"],
    );
    assert!(r.contains("help: did you mean `radius`?"), "{r}");
    let r = expect(
        &format!("{D}surface qqq;"),
        &["test.iso:2:9: error: unknown name `qqq`"],
    );
    assert!(!r.contains("did you mean"), "{r}");
}

#[test]
fn unknown_function_with_suggestion() {
    let r = expect(
        &format!("{D}surface sqtr(x) + 1;"),
        &["test.iso:2:9: error: unknown function `sqtr`"],
    );
    assert!(r.contains("help: did you mean `sqrt`?"), "{r}");
    let r = expect(
        &format!("{D}fn bump(u) = u^2;\nsurface bmp(x);"),
        &["test.iso:3:9: error: unknown function `bmp`"],
    );
    assert!(r.contains("help: did you mean `bump`?"), "{r}");
}

#[test]
fn wrong_argument_count() {
    expect(
        &format!("{D}surface sin(x, y);"),
        &["test.iso:2:9: error: `sin` takes 1 argument but 2 were given"],
    );
    expect(
        &format!("{D}surface atan2(x);"),
        &["test.iso:2:9: error: `atan2` takes 2 arguments but 1 was given"],
    );
    expect(
        &format!("{D}surface max(x);"),
        &["test.iso:2:9: error: `max` takes at least 2 arguments but 1 was given"],
    );
    expect(
        &format!("{D}fn f(a, b) = a*b;\nsurface f(x);"),
        &["test.iso:3:9: error: `f` takes 2 arguments but 1 was given"],
    );
}

#[test]
fn direct_recursion() {
    expect(
        &format!("{D}fn f(a) = f(a) + 1;\nsurface f(x);"),
        &["test.iso:2:11: error: recursion: function `f` calls itself"],
    );
}

#[test]
fn mutual_recursion() {
    expect(
        &format!("{D}fn f(a) = g(a);\nfn g(a) = h(a);\nfn h(a) = f(a);\nsurface f(x);"),
        &["test.iso:2:11: error: recursion: `f` calls `g` calls `h` calls `f`"],
    );
}

#[test]
fn call_before_definition() {
    expect(
        &format!("{D}fn f(a) = g(a);\nfn g(a) = a;\nsurface f(x);"),
        &["test.iso:2:11: error: function `g` is called before its definition"],
    );
    expect(
        &format!("{D}let a = b;\nlet b = 1;\nsurface a;"),
        &["test.iso:2:9: error: `b` is used before its definition"],
    );
}

#[test]
fn redefinition() {
    let r = expect(
        &format!("{D}let a = 1;\nparam a = 2;\nsurface a;"),
        &["test.iso:3:7: error: redefinition of `a`"],
    );
    assert!(r.contains("first defined (by `let`) on line 2"), "{r}");
    expect(
        &format!("{D}fn f(u) = u;\nfn f(u) = u;\nsurface f(x);"),
        &["test.iso:3:4: error: redefinition of `f`"],
    );
    expect(
        &format!("{D}fn f(u, u) = u;\nsurface f(x, y);"),
        &["test.iso:2:9: error: duplicate parameter `u` in `fn f`"],
    );
}

#[test]
fn coordinate_names_cannot_be_defined() {
    expect(
        &format!("{D}let x = 1;\nsurface y;"),
        &["test.iso:2:5: error: cannot define `x` with `let`: `x` is a coordinate"],
    );
    expect(
        &format!("{D}param t = 1;\nsurface y;"),
        &["test.iso:2:7: error: cannot define `t` with `param`: `t` is a coordinate"],
    );
    expect(
        &format!("{D}let sin = 1;\nlet pi = 3;\nsurface y;"),
        &[
            "test.iso:2:5: error: cannot define `sin` with `let`: it is a built-in function",
            "test.iso:3:5: error: cannot define `pi` with `let`: it is a built-in constant",
        ],
    );
    // fn parameters may shadow coordinates
    compile(&format!("{D}fn f(x, t) = x*t;\nsurface f(y, z);"));
}

#[test]
fn missing_surface() {
    expect(D, &["test.iso:2:1: error: missing `surface` statement"]);
}

#[test]
fn duplicate_surface() {
    let r = expect(
        &format!("{D}surface x;\nsurface y;"),
        &["test.iso:3:1: error: duplicate `surface` statement"],
    );
    assert!(r.contains("first `surface` is on line 2"), "{r}");
}

#[test]
fn missing_domain() {
    expect(
        "surface x;",
        &["test.iso:1:1: error: missing `domain` statement"],
    );
    // ... unless --domain is given
    let opts = CompileOptions {
        params: vec![],
        domain: Some(cube(-1.0, 1.0)),
    };
    assert!(isoc::syntax::front_end("surface x;", "f", &opts).is_ok());
}

#[test]
fn duplicate_domain() {
    expect(
        &format!("{D}domain [0, 1]^3;\nsurface x;"),
        &["test.iso:2:1: error: duplicate `domain` statement"],
    );
}

#[test]
fn empty_domain() {
    expect(
        "domain [0, 1], [2, 2], [0, 1];\nsurface x;",
        &["test.iso:1:17: error: empty domain: the range [2, 2] has zero width"],
    );
}

#[test]
fn inverted_domain() {
    expect(
        "domain [1, -1]^3;\nsurface x;",
        &["test.iso:1:9: error: inverted domain: lower bound 1 is greater than upper bound -1"],
    );
}

#[test]
fn non_finite_domain() {
    expect(
        "domain [0, log(0)]^3;\nsurface x;",
        &["test.iso:1:12: error: a domain bound is not a finite number (it evaluates to -inf)"],
    );
    expect(
        "domain [0, 1e999]^3;\nsurface x;",
        &["test.iso:1:12: error: number `1e999` is too large: it overflows to infinity"],
    );
}

#[test]
fn domain_shape() {
    expect(
        "domain [0, 1]^2;\nsurface x;",
        &["test.iso:1:15: error: a domain is three-dimensional: write `^3`, not `^2`"],
    );
    expect(
        "domain [0, 1], [0, 1];\nsurface x;",
        &["test.iso:1:1: error: a domain needs three ranges, found 2"],
    );
    expect(
        "domain [0, x]^3;\nsurface x;",
        &["test.iso:1:12: error: a domain bound must be constant, but `x` is a coordinate"],
    );
}

#[test]
fn literal_overflow() {
    expect(
        &format!("{D}surface x - 1e999;"),
        &["test.iso:2:13: error: number `1e999` is too large: it overflows to infinity"],
    );
}

#[test]
fn param_must_be_constant() {
    expect(
        &format!("{D}param r = y;\nsurface x - r;"),
        &["test.iso:2:11: error: a `param` value must be constant, but `y` is a coordinate"],
    );
}

#[test]
fn misuse_of_names() {
    expect(
        &format!("{D}fn f(u) = u;\nsurface f + 1;"),
        &["test.iso:3:9: error: `f` is a function: call it with arguments, `f(…)`"],
    );
    expect(
        &format!("{D}let a = 1;\nsurface a(x);"),
        &["test.iso:3:9: error: `a` is not a function (it is a `let`)"],
    );
}

#[test]
fn columns_count_characters_not_bytes() {
    expect(
        &format!("{D}# é è\nsurface \"é\";"),
        &["test.iso:3:9: error: unexpected characters `\" é \"`"],
    );
}

#[test]
fn missing_semicolon_before_keyword() {
    // The statement after the missing `;` still parses (no cascade).
    expect(
        "domain [-1, 1]^3\nlet a = x;\nsurface a + 1\n",
        &[
            "test.iso:1:17: error: missing `;` at the end of the statement",
            "test.iso:3:14: error: unexpected end of file",
        ],
    );
    expect(
        &format!("{D}let a = x +\nlet b = 2;\nsurface a + b + c;"),
        &[
            "test.iso:2:12: error: unexpected end of statement",
            "test.iso:4:17: error: unknown name `c`",
        ],
    );
}

// ------------------------------------------------------------ `.vm` models

/// The rendered error of a `.vm` model that must fail (through the
/// extension dispatch of `Surface::compile_bytes`).
fn vm_error(src: &[u8]) -> String {
    match isoc::Surface::compile_bytes(src, "m.vm", &CompileOptions::default()) {
        Ok(_) => panic!("expected an error for:\n{}", String::from_utf8_lossy(src)),
        Err(isoc::surface::CompileError::Front(isoc::syntax::FrontError::Source(e))) => e.render(),
        Err(e) => panic!("expected a source error, got {e:?}"),
    }
}

/// Asserts that the `.vm` source fails with exactly these headers.
fn vm_expect(src: &[u8], want: &[&str]) -> String {
    let r = vm_error(src);
    let got: Vec<&str> = r.lines().filter(|l| l.starts_with("m.vm:")).collect();
    assert_eq!(got, want, "full output:\n{r}");
    r
}

#[test]
fn vm_unknown_op() {
    let r = vm_expect(
        b"_0 var-x\n_1 sqr _0\n",
        &["m.vm:2:4: error: unknown op `sqr`"],
    );
    let lines: Vec<&str> = r.lines().collect();
    assert_eq!(lines[2], "2 | _1 sqr _0");
    assert_eq!(lines[3], "  |    ^^^");
    assert_eq!(lines[4], "  = help: did you mean `sqrt`?");
    vm_expect(b"a var-w\n", &["m.vm:1:3: error: unknown op `var-w`"]);
}

#[test]
fn vm_wrong_arity() {
    vm_expect(
        b"_0 var-x\n_1 add _0\n",
        &["m.vm:2:4: error: `add` takes 2 arguments, found 1"],
    );
    vm_expect(
        b"_0 var-x\n_1 neg _0 _0\n",
        &["m.vm:2:4: error: `neg` takes 1 argument, found 2"],
    );
    vm_expect(
        b"_0 var-x 1\n",
        &["m.vm:1:4: error: `var-x` takes 0 arguments, found 1"],
    );
    vm_expect(
        b"_0 const\n",
        &["m.vm:1:4: error: `const` takes 1 argument (a number), found 0"],
    );
    vm_expect(b"_0\n", &["m.vm:1:3: error: expected an op after `_0`"]);
}

#[test]
fn vm_undefined_name() {
    vm_expect(
        b"_0 var-x\n_1 add _0 _9\n",
        &["m.vm:2:11: error: `_9` is not defined before this line"],
    );
    // Used before its definition (SSA order).
    vm_expect(
        b"_1 neg _2\n_2 var-x\n",
        &["m.vm:1:8: error: `_2` is not defined before this line"],
    );
}

#[test]
fn vm_duplicate_name() {
    let r = vm_expect(
        b"_0 var-x\n  _0 var-y\n_1 add _0 _0\n",
        &["m.vm:2:3: error: `_0` is defined twice"],
    );
    assert!(r.contains("= note: first defined at m.vm:1:1"), "{r}");
}

#[test]
fn vm_bad_numbers() {
    for bad in ["1.2.3", "inf", "-inf", "NaN", "1e999", "0x10", "abc"] {
        vm_expect(
            format!("# c\n_0 const {bad}\n").as_bytes(),
            &[&format!("m.vm:2:10: error: `{bad}` is not a finite number")],
        );
    }
}

#[test]
fn vm_empty_file_and_only_comments() {
    for src in [&b""[..], b"\n\n", b"# only a comment\n\n   # and another\n"] {
        vm_expect(src, &["m.vm:1:1: error: the file has no instruction"]);
    }
}

#[test]
fn vm_invalid_utf8() {
    vm_expect(
        b"_0 var-x\n_1 neg \xff\n",
        &["m.vm:2:8: error: invalid UTF-8 (bytes 0xff)"],
    );
}

#[test]
fn vm_noise_ops_are_errors() {
    vm_expect(
        b"_0 var-x\n_1 rand _0\n",
        &["m.vm:2:4: error: `rand` (one of Fidget's noise ops) is not supported"],
    );
    vm_expect(
        b"_0 var-x\n_1 mix _0 _0\n",
        &["m.vm:2:4: error: `mix` (one of Fidget's noise ops) is not supported"],
    );
}

#[test]
fn vm_every_error_is_reported_without_cascades() {
    // Line 2's error poisons `_1`, so line 3 reports nothing; line 4 does.
    vm_expect(
        b"_0 var-x\n_1 foo _0\n_2 neg _1\n_3 add _2 _q\n",
        &[
            "m.vm:2:4: error: unknown op `foo`",
            "m.vm:4:11: error: `_q` is not defined before this line",
        ],
    );
}

#[test]
fn vm_set_has_nothing_to_set() {
    let opts = CompileOptions {
        params: vec![("r".into(), 1.0)],
        domain: None,
    };
    let e = isoc::Surface::compile_bytes(b"_0 var-x\n", "m.vm", &opts).unwrap_err();
    match &e {
        isoc::surface::CompileError::Front(isoc::syntax::FrontError::UnknownParam {
            name,
            known,
            ..
        }) => assert!(name == "r" && known.is_empty(), "{e:?}"),
        other => panic!("{other:?}"),
    }
    // The library names the option's field, not a flag (the CLI adds `--set`).
    assert_eq!(
        e.render(),
        "error: `r` is not a param of m.vm (the file has no params)\n"
    );
}

#[test]
fn vm_garbage_is_an_error_not_a_panic() {
    let mut bytes: Vec<u8> = (0..20_000u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    bytes.extend_from_slice(b"\n\0\0 \x01\n");
    let _ = isoc::Surface::compile_bytes(&bytes, "m.vm", &CompileOptions::default());
    let s: String = "x y z\n".repeat(5_000);
    let r = vm_error(s.as_bytes());
    assert!(r.contains("too many errors"), "{}", &r[..300.min(r.len())]);
}
