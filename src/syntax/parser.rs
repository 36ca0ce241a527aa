//! The parser: tokens → [`Ast`], with every syntax error collected.
//!
//! # Contract
//!
//! [`parse`] never fails and never panics. It returns the AST of every
//! statement that parsed, plus one [`Diagnostic`] per lexical error and per
//! syntax error (recovery skips to the next `;`), sorted by position. The
//! parser is lalrpop's table-driven LR(1) automaton (no recursion), so input
//! nesting depth only costs heap.
//!
//! # Layout
//!
//! The generated module `isoc` (from `grammar/isoc.lalrpop`), [`parse`], and
//! the conversion of lalrpop errors into diagnostics ([`recovered`] is called
//! by the grammar's `!` rule).

use super::ast::Ast;
use super::lexer::{Tok, lex};
use crate::error::Diagnostic;
use lalrpop_util::{ErrorRecovery, ParseError};
use std::convert::Infallible;

lalrpop_util::lalrpop_mod!(
    #[allow(clippy::all, clippy::pedantic, unused, missing_docs)]
    #[rustfmt::skip]
    isoc,
    "/isoc.rs"
);

/// Parses a whole file. See the module doc.
pub fn parse(source: &str) -> Ast {
    let (toks, mut diags) = lex(source);
    let mut ast = Ast::new();
    let result = isoc::FileParser::new().parse(&mut ast, toks.into_iter().map(Ok::<_, Infallible>));
    if let Err(e) = result
        && let Some(d) = describe(e)
    {
        ast.errors.push(d);
    }
    diags.append(&mut ast.errors);
    diags.sort_by_key(|d| (d.span.start, d.span.end));
    ast.errors = diags;
    ast
}

/// The grammar's error-recovery action: records the error in `ast`.
pub(crate) fn recovered(ast: &mut Ast, e: ErrorRecovery<usize, Tok<'_>, Infallible>) {
    if let Some(d) = describe(e.error) {
        ast.errors.push(d);
    }
}

/// A diagnostic for a lalrpop error; `None` for an error on a
/// [`Tok::Error`] token, which the lexer has reported already.
fn describe(e: ParseError<usize, Tok<'_>, Infallible>) -> Option<Diagnostic> {
    match e {
        ParseError::InvalidToken { location } => {
            Some(Diagnostic::new("invalid token", location..location + 1))
        }
        ParseError::UnrecognizedEof { location, expected } => Some(with_expected(
            Diagnostic::new("unexpected end of file", location..location),
            &expected,
        )),
        ParseError::UnrecognizedToken {
            token: (_, Tok::Error, _),
            ..
        } => None,
        ParseError::UnrecognizedToken {
            token: (l, t, r),
            expected,
        } => Some(with_expected(
            Diagnostic::new(format!("unexpected {t}"), l..r),
            &expected,
        )),
        ParseError::ExtraToken { token: (l, t, r) } => {
            Some(Diagnostic::new(format!("unexpected {t}"), l..r))
        }
        ParseError::User { error } => match error {},
    }
}

fn with_expected(d: Diagnostic, expected: &[String]) -> Diagnostic {
    if expected.is_empty() {
        return d;
    }
    let names: Vec<String> = expected
        .iter()
        .map(|e| {
            let t = e.trim_matches('"');
            match t {
                "name" | "number" => format!("a {t}"),
                _ => format!("`{t}`"),
            }
        })
        .collect();
    let note = if names.len() == 1 {
        format!("expected {}", names[0])
    } else {
        format!("expected one of {}", names.join(", "))
    };
    d.with_note(note)
}
