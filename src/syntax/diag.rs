//! Rendering located diagnostics as text, and "did you mean" suggestions.
//!
//! # Contract
//!
//! [`render_all`] turns each [`Diagnostic`] into
//!
//! ```text
//! FILE:LINE:COL: error: MESSAGE
//!    |
//!  3 | let a = sqr(x);
//!    |         ^^^
//!    = help: did you mean `sqrt`?
//! ```
//!
//! with 1-based line and column (the column counts characters, not bytes).
//! Line/column lookup uses `codespan-reporting`'s [`SimpleFile`]. No colours,
//! no panics: spans past the end of the source or inside a UTF-8 character
//! are clamped. [`closest`] finds the nearest candidate by edit distance.
//! A [`SourceError`] holds every diagnostic of one file together with its
//! text, and renders itself.

use codespan_reporting::files::{Files, SimpleFile};
use std::fmt::Write;
use std::ops::Range;

/// One located problem in a source file.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// The message, without the `error:` prefix.
    pub message: String,
    /// Byte range in the source that the caret points at.
    pub span: Range<usize>,
    /// Extra lines (`= note: …`, `= help: did you mean …`).
    pub notes: Vec<String>,
}

impl Diagnostic {
    /// A diagnostic with `message` at `span` and no notes.
    pub fn new(message: impl Into<String>, span: Range<usize>) -> Self {
        Diagnostic {
            message: message.into(),
            span,
            notes: Vec::new(),
        }
    }

    /// `self` with one more note line.
    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }
}

/// Every problem found in one source file, with the text they point into.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceError {
    /// The file name the diagnostics are reported against.
    pub file: String,
    /// The source text (lossily decoded when it was not UTF-8).
    pub source: String,
    /// The problems, in source order.
    pub diagnostics: Vec<Diagnostic>,
}

impl SourceError {
    /// Each diagnostic as `FILE:LINE:COL: error: MESSAGE`, the source line,
    /// a caret under the span and the notes (see the module doc).
    pub fn render(&self) -> String {
        render_all(&self.file, &self.source, &self.diagnostics)
    }
}

impl std::fmt::Display for SourceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render())
    }
}

impl std::error::Error for SourceError {}

/// Renders every diagnostic of `diags` (see the module doc), in order.
pub(crate) fn render_all(file: &str, source: &str, diags: &[Diagnostic]) -> String {
    let sf = SimpleFile::new(file, source);
    let mut out = String::new();
    for d in diags {
        render_one(&sf, file, source, d, &mut out);
    }
    out
}

fn render_one(
    sf: &SimpleFile<&str, &str>,
    file: &str,
    source: &str,
    d: &Diagnostic,
    out: &mut String,
) {
    let start = clamp(source, d.span.start);
    let end = clamp(source, d.span.end.max(start));
    let line = sf.line_index((), start).unwrap_or(0);
    let line_range = sf.line_range((), line).unwrap_or(0..source.len());
    let text = source
        .get(line_range.clone())
        .unwrap_or("")
        .trim_end_matches(['\n', '\r']);
    let col_chars = source
        .get(line_range.start..start)
        .map_or(0, |s| s.chars().count());
    let _ = writeln!(
        out,
        "{file}:{}:{}: error: {}",
        line + 1,
        col_chars + 1,
        d.message
    );
    let num = (line + 1).to_string();
    let pad = " ".repeat(num.len());
    // Caret line: keep tabs so that the carets line up under the text.
    let mut caret = String::new();
    for c in source.get(line_range.start..start).unwrap_or("").chars() {
        caret.push(if c == '\t' { '\t' } else { ' ' });
    }
    let line_end = line_range.start + text.len();
    let width = source
        .get(start..end.min(line_end))
        .map_or(0, |s| s.chars().count())
        .max(1);
    caret.push_str(&"^".repeat(width));
    let shown: String = text
        .chars()
        .map(|c| {
            if c.is_control() && c != '\t' {
                '\u{FFFD}'
            } else {
                c
            }
        })
        .collect();
    let _ = writeln!(out, "{pad} |");
    let _ = writeln!(out, "{num} | {shown}");
    let _ = writeln!(out, "{pad} | {caret}");
    for n in &d.notes {
        if n.starts_with("note:") || n.starts_with("help:") {
            let _ = writeln!(out, "{pad} = {n}");
        } else {
            let _ = writeln!(out, "{pad} = note: {n}");
        }
    }
}

/// The largest char boundary of `source` that is `<= pos`.
fn clamp(source: &str, pos: usize) -> usize {
    let mut p = pos.min(source.len());
    while !source.is_char_boundary(p) {
        p -= 1;
    }
    p
}

/// Levenshtein distance between two short strings (by chars).
pub(crate) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, ca) in a.chars().enumerate() {
        cur[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The candidate closest to `name`, if it is close enough to be a likely
/// typo (distance at most 1 for short names, 2 for longer ones).
pub fn closest<'c>(name: &str, candidates: impl IntoIterator<Item = &'c str>) -> Option<&'c str> {
    let limit = if name.chars().count() <= 3 { 1 } else { 2 };
    candidates
        .into_iter()
        .filter(|c| *c != name)
        .map(|c| (edit_distance(name, c), c))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, c)| (d, c.len()))
        .map(|(_, c)| c)
}
