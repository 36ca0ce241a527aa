//! The parser: tokens → [`Ast`], with every syntax error collected.
//!
//! # Contract
//!
//! [`parse`] never fails and never panics. It returns the AST of every
//! statement that parsed, plus one [`Diagnostic`] per lexical error and per
//! syntax error (recovery skips to the next `;`; a missing `;` before a
//! keyword is detected and inserted, so it costs one error, not two
//! statements), sorted by position. The
//! parser is lalrpop's table-driven LR(1) automaton (no recursion), so input
//! nesting depth only costs heap.
//!
//! # Layout
//!
//! The generated module `isoc` (from `grammar/isoc.lalrpop`), [`parse`], and
//! the conversion of lalrpop errors into diagnostics ([`recovered`] is called
//! by the grammar's `!` rule).

use super::ast::Ast;
use super::diag::Diagnostic;
use super::lexer::{Spanned, Tok, lex};
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
    let (toks, inserted) = insert_semicolons(toks);
    let mut ast = Ast::new();
    for w in toks.windows(2) {
        if let [
            (_, Tok::Let | Tok::Param | Tok::Fn, _),
            (_, Tok::Ident(name), _),
        ] = w
        {
            ast.declared.insert((*name).to_string());
        }
    }
    let result = isoc::FileParser::new().parse(&mut ast, toks.into_iter().map(Ok::<_, Infallible>));
    if let Err(e) = result
        && let Some(d) = describe(e)
    {
        ast.errors.push(d);
    }
    // A statement that was complete before an inserted `;` lacked only the
    // `;`; one that was not got an "ends early" error from the parser.
    for (at, keyword) in inserted {
        if !ast.errors.iter().any(|d| d.span == (at..at)) {
            ast.errors.push(
                Diagnostic::new("missing `;` at the end of the statement", at..at)
                    .with_note(format!("note: the next statement starts with {keyword}")),
            );
        }
    }
    diags.append(&mut ast.errors);
    diags.sort_by_key(|d| (d.span.start, d.span.end));
    ast.errors = diags;
    ast
}

/// Keywords only ever start a statement, so a keyword that does not follow
/// a `;` (or the start of the file) means the previous statement lacks its
/// `;`. A zero-width `;` is inserted there, so that the parser recovers at
/// the keyword instead of skipping the next statement. Returns the tokens
/// and, for each insertion, its position and the keyword.
fn insert_semicolons(toks: Vec<Spanned<'_>>) -> (Vec<Spanned<'_>>, Vec<(usize, String)>) {
    let mut out = Vec::with_capacity(toks.len());
    let mut inserted = Vec::new();
    for t in toks {
        let keyword = matches!(
            t.1,
            Tok::Domain | Tok::Let | Tok::Param | Tok::Fn | Tok::Surface
        );
        if keyword
            && let Some(&(_, prev, end)) = out.last()
            && prev != Tok::Semi
        {
            out.push((end, Tok::Semi, end));
            inserted.push((end, t.1.to_string()));
        }
        out.push(t);
    }
    (out, inserted)
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
        // A `;` inserted before a keyword (see `insert_semicolons`).
        ParseError::UnrecognizedToken {
            token: (l, Tok::Semi, r),
            expected,
        } if l == r => Some(with_expected(
            Diagnostic::new("unexpected end of statement", l..r),
            &expected,
        )),
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
