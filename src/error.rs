//! Typed errors of the library. Nothing here prints: the binary renders
//! errors with [`Error::render`] and chooses the exit status.

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
    pub fn new(message: impl Into<String>, span: Range<usize>) -> Self {
        Diagnostic {
            message: message.into(),
            span,
            notes: Vec::new(),
        }
    }

    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }
}

/// Every failure of the library.
#[derive(Debug)]
pub enum Error {
    /// Problems in a source file: all that were found in one run, in source
    /// order.
    Source {
        file: String,
        source: String,
        diagnostics: Vec<Diagnostic>,
    },
    /// A bad option value given by the caller (e.g. `--set r=abc`, an unknown
    /// param, an empty `--domain`).
    Usage(String),
    /// Reading or writing a file failed.
    Io { path: String, error: std::io::Error },
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render())
    }
}

impl std::error::Error for Error {}

impl Error {
    /// The error as the command line shows it, without colours: for a
    /// source error, each diagnostic as `FILE:LINE:COL: error: MESSAGE`, the
    /// source line, a caret under the span and the notes (see
    /// [`crate::syntax::diag`]).
    pub fn render(&self) -> String {
        match self {
            Error::Source {
                file,
                source,
                diagnostics,
            } => crate::syntax::diag::render_all(file, source, diagnostics),
            Error::Usage(m) => format!("error: {m}\n"),
            Error::Io { path, error } => format!("error: {path}: {error}\n"),
        }
    }
}
