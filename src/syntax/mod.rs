//! The front end: source text → checked, lowered IR.
//!
//! # Contract
//!
//! [`front_end`] lexes, parses, resolves, checks and lowers one `.iso` file
//! (SPEC §1). It never panics, never recurses on the input's nesting depth
//! and reports *every* problem it finds in one [`FrontError::Source`] (sorted by
//! position, at most [`MAX_DIAGNOSTICS`]). [`emit_ast`] stops after parsing
//! and prints the AST. [`source_from_bytes`] turns raw file bytes into the
//! source string, reporting invalid UTF-8 with its location.
//! [`front_end_for`] and [`emit_ast_for`] choose the language by the file
//! name: `.vm` files are Fidget's text-SSA models, read by [`vm`].
//!
//! # Layout
//!
//! - [`lexer`]: `logos` tokens, bad characters → error tokens;
//! - [`parser`]: the lalrpop grammar `grammar/isoc.lalrpop`, with recovery;
//! - [`ast`]: the arena AST and its printer;
//! - [`resolve`]: names, semantic checks, constants (params, domain);
//! - [`names`]: what resolution decides (built-ins, [`names::Res`], [`names::Resolved`]);
//! - [`lower`]: inlining and lowering to [`crate::ir`];
//! - [`diag`]: rendering diagnostics, "did you mean";
//! - [`vm`]: the `.vm` reader (SPEC §1.1).

pub mod ast;
pub(crate) mod diag;
pub mod error;
pub(crate) mod lexer;
pub mod lower;
pub mod names;
pub mod parser;
pub mod resolve;
pub mod vm;

use crate::geometry::Bounds;
use crate::ir::Program;
pub use diag::{Diagnostic, SourceError};
pub use error::FrontError;

/// Options of the front end (and of [`crate::Surface::compile`]).
#[derive(Clone, Debug, Default)]
pub struct CompileOptions {
    /// Overrides of the file's `param`s (name, value), applied in order.
    pub params: Vec<(String, f64)>,
    /// Replaces the file's `domain` (and makes the statement optional).
    pub domain: Option<Bounds>,
}

/// At most this many diagnostics are reported for one file (binary garbage
/// would otherwise produce one per byte).
pub const MAX_DIAGNOSTICS: usize = 100;

/// The front end's result.
#[derive(Clone, Debug)]
pub struct Lowered {
    /// The surface's function, lowered to IR.
    pub program: Program,
    /// The file's domain, or `CompileOptions::domain` when given.
    pub domain: Bounds,
    /// Every `param` with its final value (after `--set`), in source order.
    pub params: Vec<(String, f64)>,
}

/// Compiles `source` (named `file` in messages) to IR. See the module doc.
pub fn front_end(source: &str, file: &str, opts: &CompileOptions) -> Result<Lowered, FrontError> {
    let ast = parser::parse(source);
    let mut diags = ast.errors.clone();
    let complete = diags.is_empty();
    let r = resolve::resolve(&ast, source, opts, complete, &mut diags);
    if !diags.is_empty() {
        return Err(source_error(file, source, diags));
    }
    check_params(file, &r.params, opts)?;
    check_domain(opts)?;
    let domain = match (opts.domain, r.domain) {
        (Some(d), _) | (None, Some(d)) => d,
        (None, None) => {
            // Unreachable after a clean resolution; stay a value, not a panic.
            return Err(source_error(
                file,
                source,
                vec![Diagnostic::new("missing `domain` statement", 0..0)],
            ));
        }
    };
    let program = lower::lower_surface(&ast, &r).map_err(|lower::TooLarge| {
        let span = r.surface.as_ref().map_or(0..0, |s| s.2.clone());
        source_error(
            file,
            source,
            vec![
                Diagnostic::new(
                    "the surface is too large (function calls are inlined at every use)",
                    span,
                )
                .with_note(format!(
                    "note: inlining visits more than {} nodes of function bodies",
                    lower::WORK_LIMIT
                )),
            ],
        )
    })?;
    Ok(Lowered {
        program,
        domain,
        params: r.params,
    })
}

/// Checks the param overrides against the file's params: every value
/// finite, every name a param of the file.
pub(crate) fn check_params(
    file: &str,
    params: &[(String, f64)],
    opts: &CompileOptions,
) -> Result<(), FrontError> {
    for (name, v) in &opts.params {
        if !v.is_finite() {
            return Err(FrontError::ParamNotFinite {
                name: name.clone(),
                value: *v,
            });
        }
        if !params.iter().any(|(p, _)| p == name) {
            let known: Vec<&str> = params.iter().map(|(p, _)| p.as_str()).collect();
            return Err(FrontError::UnknownParam {
                name: name.clone(),
                file: file.to_string(),
                closest: diag::closest(name, known.iter().copied()).map(str::to_string),
                known: known.iter().map(|k| k.to_string()).collect(),
            });
        }
    }
    Ok(())
}

/// Checks the replacement domain (every range finite and non-empty) and returns it.
pub(crate) fn check_domain(opts: &CompileOptions) -> Result<Option<Bounds>, FrontError> {
    if let Some(d) = opts.domain
        && !(0..3).all(|i| d.lo[i].is_finite() && d.hi[i].is_finite() && d.lo[i] < d.hi[i])
    {
        return Err(FrontError::BadDomain(d));
    }
    Ok(opts.domain)
}

/// The front end for `file`, chosen by its extension: `.vm` → [`vm`]
/// (Fidget's text-SSA models), anything else → `.iso` ([`front_end`]).
pub(crate) fn front_end_for(
    source: &str,
    file: &str,
    opts: &CompileOptions,
) -> Result<Lowered, FrontError> {
    if vm::is_vm_file(file) {
        vm::front_end(source, file, opts)
    } else {
        front_end(source, file, opts)
    }
}

/// `--emit ast` for `file`, chosen by its extension as [`front_end_for`].
pub fn emit_ast_for(source: &str, file: &str) -> Result<String, FrontError> {
    if vm::is_vm_file(file) {
        vm::emit_ast(source, file)
    } else {
        emit_ast(source, file)
    }
}

/// Parses `source` and prints its AST (`isoc compile --emit ast`): one
/// fully parenthesised s-expression per statement. Syntax errors only.
pub fn emit_ast(source: &str, file: &str) -> Result<String, FrontError> {
    let ast = parser::parse(source);
    if !ast.errors.is_empty() {
        return Err(source_error(file, source, ast.errors));
    }
    Ok(ast.print())
}

/// The source text of a file's bytes. Invalid UTF-8 is a
/// [`FrontError::Source`] with one diagnostic per invalid sequence, located in
/// the lossily decoded text (each bad sequence shown as U+FFFD). NUL bytes
/// are valid UTF-8 and are left to the lexer.
pub fn source_from_bytes(bytes: &[u8], file: &str) -> Result<String, FrontError> {
    let Err(_) = std::str::from_utf8(bytes) else {
        return Ok(String::from_utf8_lossy(bytes).into_owned());
    };
    let mut text = String::new();
    let mut diags = Vec::new();
    for chunk in bytes.utf8_chunks() {
        text.push_str(chunk.valid());
        let bad = chunk.invalid();
        if !bad.is_empty() {
            let at = text.len();
            text.push('\u{FFFD}');
            let hex: Vec<String> = bad.iter().map(|b| format!("{b:#04x}")).collect();
            diags.push(Diagnostic::new(
                format!("invalid UTF-8 (bytes {})", hex.join(" ")),
                at..at + '\u{FFFD}'.len_utf8(),
            ));
        }
    }
    Err(source_error(file, &text, diags))
}

pub(crate) fn source_error(file: &str, source: &str, mut diags: Vec<Diagnostic>) -> FrontError {
    diags.sort_by_key(|d| (d.span.start, d.span.end));
    if diags.len() > MAX_DIAGNOSTICS {
        let n = diags.len();
        diags.truncate(MAX_DIAGNOSTICS);
        let at = diags.last().map_or(0..0, |d| d.span.clone());
        diags.push(Diagnostic::new(
            format!("too many errors ({n}); only the first {MAX_DIAGNOSTICS} are shown"),
            at,
        ));
    }
    FrontError::Source(SourceError {
        file: file.to_string(),
        source: source.to_string(),
        diagnostics: diags,
    })
}
