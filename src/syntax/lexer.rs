//! The lexer: source text → tokens with byte spans.
//!
//! # Contract
//!
//! [`lex`] never fails and never panics: every byte of the input ends up in a
//! token, in skipped whitespace or in a comment. A character that starts no
//! token (`@`, a NUL byte, …) becomes a [`Tok::Error`] token, so that the
//! parser can recover from it and report every problem of the file; the lexer
//! also returns one [`Diagnostic`] per such run of bad characters.
//!
//! # Layout
//!
//! [`Tok`] is the `logos` token type and is also the terminal type of the
//! lalrpop grammar (`grammar/isoc.lalrpop`, `extern` block). [`lex`] turns the
//! `logos` stream into the `(start, token, end)` triples that lalrpop expects.

use super::diag::Diagnostic;
use logos::Logos;
use std::fmt;

/// A token. Names and numbers borrow their text from the source.
#[derive(Logos, Clone, Copy, Debug, PartialEq)]
#[logos(skip r"[ \t\r\n\f]+")]
// Comments run to the end of the line: the greedy `[^\n]*` is intended.
#[logos(skip(r"(#|//)[^\n]*", allow_greedy = true))]
pub(crate) enum Tok<'s> {
    #[token("domain")]
    Domain,
    #[token("let")]
    Let,
    #[token("param")]
    Param,
    #[token("fn")]
    Fn,
    #[token("surface")]
    Surface,
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*", |lex| lex.slice())]
    Ident(&'s str),
    /// `2`, `0.5`, `1e-3`, `.5`, `1.`
    #[regex(r"[0-9]+(\.[0-9]*)?([eE][+-]?[0-9]+)?", |lex| lex.slice())]
    #[regex(r"\.[0-9]+([eE][+-]?[0-9]+)?", |lex| lex.slice())]
    Num(&'s str),
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    #[token("^")]
    Caret,
    #[token("=")]
    Eq,
    #[token(",")]
    Comma,
    #[token(";")]
    Semi,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token("[")]
    LBracket,
    #[token("]")]
    RBracket,
    /// Characters that start no token (already reported by [`lex`]).
    Error,
}

impl fmt::Display for Tok<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Tok::Domain => "`domain`",
            Tok::Let => "`let`",
            Tok::Param => "`param`",
            Tok::Fn => "`fn`",
            Tok::Surface => "`surface`",
            Tok::Ident(name) => return write!(f, "name `{name}`"),
            Tok::Num(text) => return write!(f, "number `{text}`"),
            Tok::Plus => "`+`",
            Tok::Minus => "`-`",
            Tok::Star => "`*`",
            Tok::Slash => "`/`",
            Tok::Caret => "`^`",
            Tok::Eq => "`=`",
            Tok::Comma => "`,`",
            Tok::Semi => "`;`",
            Tok::LParen => "`(`",
            Tok::RParen => "`)`",
            Tok::LBracket => "`[`",
            Tok::RBracket => "`]`",
            Tok::Error => "invalid character",
        };
        f.write_str(s)
    }
}

/// A token with its byte span, as lalrpop wants it.
pub(crate) type Spanned<'s> = (usize, Tok<'s>, usize);

/// Splits `source` into tokens. Runs of characters that start no token
/// become one [`Tok::Error`] each and one diagnostic each.
pub(crate) fn lex(source: &str) -> (Vec<Spanned<'_>>, Vec<Diagnostic>) {
    let mut toks: Vec<Spanned<'_>> = Vec::new();
    let mut diags = Vec::new();
    for (res, span) in Tok::lexer(source).spanned() {
        match res {
            Ok(t) => toks.push((span.start, t, span.end)),
            Err(()) => {
                // Merge adjacent bad characters into one token.
                if let Some(last) = toks.last_mut()
                    && last.1 == Tok::Error
                    && last.2 == span.start
                {
                    last.2 = span.end;
                    continue;
                }
                toks.push((span.start, Tok::Error, span.end));
            }
        }
    }
    for &(lo, t, hi) in &toks {
        if t == Tok::Error {
            diags.push(bad_chars(source, lo..hi));
        }
    }
    (toks, diags)
}

fn bad_chars(source: &str, span: std::ops::Range<usize>) -> Diagnostic {
    let text = source.get(span.clone()).unwrap_or("");
    let shown: String = text
        .chars()
        .take(8)
        .map(|c| {
            if c.is_control() || c.is_whitespace() {
                format!("U+{:04X}", c as u32)
            } else {
                c.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join(" ");
    let what = if text.chars().nth(1).is_some() {
        "characters"
    } else {
        "character"
    };
    Diagnostic::new(format!("unexpected {what} `{shown}`"), span)
}
