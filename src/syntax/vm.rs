//! The second input language: Fidget's `.vm` text-SSA models (SPEC §1.1).
//!
//! # Format
//!
//! One instruction a line, `NAME OP ARG...`, tokens separated by
//! whitespace. A token starting with `#` starts a comment that runs to the
//! end of the line; blank lines are skipped. NAME is any token; each NAME is
//! defined once, and an ARG names an earlier instruction (or, for `const`,
//! is a number). The last instruction is the function. Ops:
//!
//! | op | IR |
//! |---|---|
//! | `var-x var-y var-z` | `var x y z` |
//! | `const C` | a constant (`C` a finite decimal number, enclosed exactly as in `.iso`) |
//! | `neg abs sqrt square sin cos tan asin acos atan exp` | the same unary op |
//! | `ln` | `log` |
//! | `floor ceil round not` | the same unary op (`round`: ties away from zero) |
//! | `add sub mul div min max compare mod and or` | the same binary op |
//! | `atan2` (Fidget's text reader accepts it too) | `atan2` |
//!
//! Fidget's noise ops `rand` and `mix` are a located error. Every op means
//! what it means in the IR ([`crate::ir`]), which follows Fidget except
//! where Fidget's point evaluator gives an infinity or hides a NaN: `ln 0`
//! and `x / 0` are NaN, and a NaN operand of `and`, `or`, `not`, `compare`
//! gives NaN.
//!
//! The domain is `[-1, 1]³` unless [`CompileOptions::domain`] is given. A
//! model without `var-z` is a 2-D shape: its surface is the prism over the
//! shape, cut by the domain (nothing special is done for it).
//!
//! # Errors and cost
//!
//! Every problem is a located [`Diagnostic`] (`FILE:LINE:COL: error: …`, see
//! [`super::diag`]): an unknown op, a wrong argument count, a name used
//! before it is defined or defined twice, a bad or non-finite number, an
//! empty file (no instruction), invalid UTF-8 (by
//! [`super::source_from_bytes`]), `rand`/`mix`. All problems of a file are
//! reported (at most [`super::MAX_DIAGNOSTICS`]); a line with an error
//! still defines its NAME, so that later uses do not cascade. The reader is
//! one pass over the lines with a hash map of names: linear time and memory,
//! no recursion. The IR is built with [`crate::ir::Builder`], so constant
//! folding, simplification and hash-consing apply.

use std::collections::HashMap;
use std::fmt::Write;
use std::ops::Range;

use super::CompileOptions;
use super::{Diagnostic, FrontError};
use super::{Lowered, diag, source_error};
use crate::geometry::Bounds;
use crate::ir::{BinOp, Builder, Const, UnOp, Value, Var};

/// The domain of a `.vm` model when `--domain` is not given.
pub(crate) const DEFAULT_DOMAIN: Bounds = Bounds {
    lo: [-1.0; 3],
    hi: [1.0; 3],
};

/// What an op name means.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Var(Var),
    Const,
    Unary(UnOp),
    Binary(BinOp),
    /// Fidget's noise ops (`rand`, `mix`), not supported.
    Noise,
}

const OPS: &[(&str, Kind)] = &[
    ("var-x", Kind::Var(Var::X)),
    ("var-y", Kind::Var(Var::Y)),
    ("var-z", Kind::Var(Var::Z)),
    ("const", Kind::Const),
    ("neg", Kind::Unary(UnOp::Neg)),
    ("abs", Kind::Unary(UnOp::Abs)),
    ("sqrt", Kind::Unary(UnOp::Sqrt)),
    ("square", Kind::Unary(UnOp::Square)),
    ("floor", Kind::Unary(UnOp::Floor)),
    ("ceil", Kind::Unary(UnOp::Ceil)),
    ("round", Kind::Unary(UnOp::Round)),
    ("sin", Kind::Unary(UnOp::Sin)),
    ("cos", Kind::Unary(UnOp::Cos)),
    ("tan", Kind::Unary(UnOp::Tan)),
    ("asin", Kind::Unary(UnOp::Asin)),
    ("acos", Kind::Unary(UnOp::Acos)),
    ("atan", Kind::Unary(UnOp::Atan)),
    ("exp", Kind::Unary(UnOp::Exp)),
    ("ln", Kind::Unary(UnOp::Log)),
    ("not", Kind::Unary(UnOp::Not)),
    ("add", Kind::Binary(BinOp::Add)),
    ("sub", Kind::Binary(BinOp::Sub)),
    ("mul", Kind::Binary(BinOp::Mul)),
    ("div", Kind::Binary(BinOp::Div)),
    ("min", Kind::Binary(BinOp::Min)),
    ("max", Kind::Binary(BinOp::Max)),
    ("compare", Kind::Binary(BinOp::Compare)),
    ("mod", Kind::Binary(BinOp::Mod)),
    ("and", Kind::Binary(BinOp::And)),
    ("or", Kind::Binary(BinOp::Or)),
    ("atan2", Kind::Binary(BinOp::Atan2)),
    ("rand", Kind::Noise),
    ("mix", Kind::Noise),
];

fn arity(k: Kind, name: &str) -> usize {
    match k {
        Kind::Var(_) => 0,
        Kind::Const | Kind::Unary(_) => 1,
        Kind::Binary(_) => 2,
        Kind::Noise => usize::from(name == "mix") + 1,
    }
}

/// True when `file` names a `.vm` model (by its extension, any case).
pub(crate) fn is_vm_file(file: &str) -> bool {
    std::path::Path::new(file)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("vm"))
}

/// One parsed line.
struct Line<'s> {
    name: (&'s str, Range<usize>),
    op: (&'s str, Range<usize>),
    args: Vec<(&'s str, Range<usize>)>,
}

/// The tokens of every instruction line, with byte spans into `source`.
fn lines(source: &str) -> impl Iterator<Item = Vec<(&str, Range<usize>)>> {
    let mut start = 0;
    source.split_inclusive('\n').filter_map(move |raw| {
        let base = start;
        start += raw.len();
        let mut toks = Vec::new();
        let mut i = 0;
        let bytes = raw.as_bytes();
        while i < bytes.len() {
            if bytes[i].is_ascii_whitespace() {
                i += 1;
                continue;
            }
            if bytes[i] == b'#' {
                break;
            }
            let s = i;
            while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
                i += 1;
            }
            toks.push((&raw[s..i], base + s..base + i));
        }
        (!toks.is_empty()).then_some(toks)
    })
}

/// A `const` argument: a finite decimal number, as a constant enclosing the
/// real number it denotes.
fn number(text: &str) -> Result<Const, String> {
    let bad = || format!("`{text}` is not a finite number");
    let (neg, body) = match text.as_bytes().first() {
        Some(b'-') => (true, &text[1..]),
        Some(b'+') => (false, &text[1..]),
        _ => (false, text),
    };
    let v: f64 = text.parse().map_err(|_| bad())?;
    if !v.is_finite() {
        return Err(bad());
    }
    let c = match Const::literal(body) {
        Some(c) if c.value.is_finite() => c,
        // A form the `.iso` lexer does not have (`1.`, …): a one-ulp-wide
        // enclosure on both sides of the parsed value is always sound.
        _ => {
            let a = v.abs();
            Const {
                value: a,
                lo: a.next_down(),
                hi: a.next_up(),
                defined: true,
            }
        }
    };
    Ok(if neg {
        Const {
            value: -c.value,
            lo: -c.hi,
            hi: -c.lo,
            defined: c.defined,
        }
    } else {
        c
    })
}

fn parse_line<'s>(toks: &[(&'s str, Range<usize>)]) -> Line<'s> {
    Line {
        name: toks[0].clone(),
        op: toks
            .get(1)
            .cloned()
            .unwrap_or(("", toks[0].1.end..toks[0].1.end)),
        args: toks.get(2..).unwrap_or(&[]).to_vec(),
    }
}

/// Checks one line's op and argument count; returns its kind.
fn check_op(line: &Line) -> Result<Kind, Diagnostic> {
    let (op, span) = &line.op;
    if op.is_empty() {
        return Err(Diagnostic::new(
            format!("expected an op after `{}`", line.name.0),
            span.clone(),
        )
        .with_note("help: a line is `NAME OP ARG...`, e.g. `_1 add _0 _0`"));
    }
    let Some(&(_, kind)) = OPS.iter().find(|(n, _)| n == op) else {
        let d = Diagnostic::new(format!("unknown op `{op}`"), span.clone());
        return Err(
            match diag::closest(
                op,
                OPS.iter()
                    .map(|(n, _)| *n)
                    .filter(|n| *n != "rand" && *n != "mix"),
            ) {
                Some(c) => d.with_note(format!("help: did you mean `{c}`?")),
                None => d,
            },
        );
    };
    if kind == Kind::Noise {
        return Err(Diagnostic::new(
            format!("`{op}` (one of Fidget's noise ops) is not supported"),
            span.clone(),
        ));
    }
    let n = arity(kind, op);
    if line.args.len() != n {
        let what = if kind == Kind::Const {
            "1 argument (a number)".to_string()
        } else if n == 1 {
            "1 argument".to_string()
        } else {
            format!("{n} arguments")
        };
        let end = line.args.last().map_or(span.end, |a| a.1.end);
        return Err(Diagnostic::new(
            format!("`{op}` takes {what}, found {}", line.args.len()),
            span.start..end,
        ));
    }
    Ok(kind)
}

/// Reads a `.vm` model (see the module doc).
pub fn front_end(source: &str, file: &str, opts: &CompileOptions) -> Result<Lowered, FrontError> {
    let mut b = Builder::new();
    // NAME → its value (None: the line had an error) and where it was defined.
    let mut names: HashMap<&str, (Option<Value>, Range<usize>)> = HashMap::new();
    let mut diags: Vec<Diagnostic> = Vec::new();
    let mut last: Option<Option<Value>> = None;
    for toks in lines(source) {
        let line = parse_line(&toks);
        let value = build_line(&mut b, &line, &names, &mut diags);
        let (name, span) = line.name.clone();
        if let Some((_, first)) = names.get(name) {
            let (l, c) = line_col(source, first.start);
            diags.push(
                Diagnostic::new(format!("`{name}` is defined twice"), span)
                    .with_note(format!("note: first defined at {file}:{l}:{c}")),
            );
        } else {
            names.insert(name, (value, span));
        }
        last = Some(value);
    }
    let Some(last) = last else {
        diags.push(
            Diagnostic::new("the file has no instruction", 0..0)
                .with_note("note: a .vm model is one instruction a line, `NAME OP ARG...`; the last one is the function"),
        );
        return Err(source_error(file, source, diags));
    };
    if !diags.is_empty() {
        return Err(source_error(file, source, diags));
    }
    super::check_params(file, &[], opts)?;
    let domain = super::check_domain(opts)?.unwrap_or(DEFAULT_DOMAIN);
    let output = last.expect("every line is free of errors");
    Ok(Lowered {
        program: b.finish(output),
        domain,
        params: Vec::new(),
    })
}

/// The IR value of one line, or `None` after pushing its diagnostic.
fn build_line(
    b: &mut Builder,
    line: &Line,
    names: &HashMap<&str, (Option<Value>, Range<usize>)>,
    diags: &mut Vec<Diagnostic>,
) -> Option<Value> {
    let kind = match check_op(line) {
        Ok(k) => k,
        Err(d) => {
            diags.push(d);
            return None;
        }
    };
    if kind == Kind::Const {
        let (text, span) = &line.args[0];
        return match number(text) {
            Ok(c) => Some(b.constant(c)),
            Err(m) => {
                diags.push(Diagnostic::new(m, span.clone()));
                None
            }
        };
    }
    let mut args = Vec::with_capacity(2);
    let mut ok = true;
    for (text, span) in &line.args {
        match names.get(text) {
            Some((Some(v), _)) => args.push(*v),
            // Defined by a line with an error: reported there.
            Some((None, _)) => ok = false,
            None => {
                ok = false;
                let mut d = Diagnostic::new(
                    format!("`{text}` is not defined before this line"),
                    span.clone(),
                );
                if diags.len() <= super::MAX_DIAGNOSTICS
                    && names.len() <= 100_000
                    && let Some(c) = diag::closest(text, names.keys().copied())
                {
                    d = d.with_note(format!("help: did you mean `{c}`?"));
                }
                diags.push(d);
            }
        }
    }
    if !ok {
        return None;
    }
    Some(match kind {
        Kind::Var(v) => b.var(v),
        Kind::Unary(u) => b.unary(u, args[0]),
        Kind::Binary(o) => b.binary(o, args[0], args[1]),
        Kind::Const | Kind::Noise => unreachable!("handled above"),
    })
}

/// 1-based line and column (in characters) of byte `pos`.
fn line_col(source: &str, pos: usize) -> (usize, usize) {
    let before = &source[..pos.min(source.len())];
    let line = before.bytes().filter(|&c| c == b'\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[start..].chars().count() + 1)
}

/// `isoc compile --emit ast` for a `.vm` file: the instructions as
/// s-expressions `(NAME OP ARG...)`, one a line, after checking every line
/// (a `.vm` model has no tree; this is its parse).
pub fn emit_ast(source: &str, file: &str) -> Result<String, FrontError> {
    let lowered = front_end(source, file, &CompileOptions::default())?;
    drop(lowered);
    let mut out = String::new();
    for toks in lines(source) {
        let words: Vec<&str> = toks.iter().map(|t| t.0).collect();
        let _ = writeln!(out, "({})", words.join(" "));
    }
    Ok(out)
}
