//! The library's error: one enum over each stage's own error type, so a
//! caller can match on what went wrong or just render it. Nothing here
//! prints or names command-line flags; the binary maps these to its flags,
//! messages and exit status.

use crate::io::WriteError;
use crate::jit::JitError;
use crate::surface::CompileError;
use crate::syntax::{FrontError, SourceError};
use crate::twin::TrackError;

/// Every failure of the library.
#[derive(Debug)]
pub enum Error {
    /// The front end: problems in the source, or options that do not fit it.
    Front(FrontError),
    /// The JIT could not compile the kernels.
    Jit(JitError),
    /// Tracker options out of range (see [`crate::twin::TwinOptions`]).
    Track(TrackError),
    /// Writing a mesh failed.
    Write(WriteError),
}

impl Error {
    /// The source diagnostics, when that is what the error is.
    pub fn source_error(&self) -> Option<&SourceError> {
        match self {
            Error::Front(FrontError::Source(e)) => Some(e),
            _ => None,
        }
    }

    /// The error as text, without colours: a source error as its rendered
    /// diagnostics (`FILE:LINE:COL: error: …` with a caret, see
    /// [`crate::syntax::diag`]), anything else as `error: MESSAGE`.
    pub fn render(&self) -> String {
        match self {
            Error::Front(e) => e.render(),
            _ => format!("error: {self}\n"),
        }
    }
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Front(e) => e.fmt(f),
            Error::Jit(e) => e.fmt(f),
            Error::Track(e) => e.fmt(f),
            Error::Write(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for Error {}

impl From<FrontError> for Error {
    fn from(e: FrontError) -> Error {
        Error::Front(e)
    }
}

impl From<CompileError> for Error {
    fn from(e: CompileError) -> Error {
        match e {
            CompileError::Front(e) => Error::Front(e),
            CompileError::Jit(e) => Error::Jit(e),
        }
    }
}

impl From<JitError> for Error {
    fn from(e: JitError) -> Error {
        Error::Jit(e)
    }
}

impl From<TrackError> for Error {
    fn from(e: TrackError) -> Error {
        Error::Track(e)
    }
}

impl From<WriteError> for Error {
    fn from(e: WriteError) -> Error {
        Error::Write(e)
    }
}
