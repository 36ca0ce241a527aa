//! The front end's error: problems in the source text, or compile options
//! that do not fit the file. Messages name the options' fields
//! ([`super::CompileOptions`]); a command line maps them to its flags.

use super::diag::SourceError;
use crate::geometry::Bounds;

/// Why the front end could not produce a program.
#[derive(Clone, Debug, PartialEq)]
pub enum FrontError {
    /// Problems in the source text: every one that was found, in order.
    Source(SourceError),
    /// A param override whose value is not finite.
    ParamNotFinite {
        /// The param's name.
        name: String,
        /// The value given.
        value: f64,
    },
    /// A param override that names no param of the file.
    UnknownParam {
        /// The name given.
        name: String,
        /// The file it was looked up in.
        file: String,
        /// The file's param closest to `name`, if one is close.
        closest: Option<String>,
        /// Every param of the file, in source order.
        known: Vec<String>,
    },
    /// A replacement domain with an infinite or empty range.
    BadDomain(Bounds),
}

impl FrontError {
    /// A source error as its rendered diagnostics (`FILE:LINE:COL: error:`
    /// with a caret, see [`super::diag`]), anything else as
    /// `error: MESSAGE`.
    pub fn render(&self) -> String {
        match self {
            FrontError::Source(e) => e.render(),
            _ => format!("error: {self}\n"),
        }
    }
}

impl std::fmt::Display for FrontError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FrontError::Source(e) => f.write_str(&e.render()),
            FrontError::ParamNotFinite { name, value } => {
                write!(
                    f,
                    "param `{name}`: the value must be a finite number, got {value}"
                )
            }
            FrontError::UnknownParam {
                name,
                file,
                closest,
                known,
            } => {
                write!(f, "`{name}` is not a param of {file}")?;
                match closest {
                    Some(c) => write!(f, " (did you mean `{c}`?)"),
                    None if known.is_empty() => write!(f, " (the file has no params)"),
                    None => write!(f, " (the file's params: {})", known.join(", ")),
                }
            }
            FrontError::BadDomain(d) => write!(
                f,
                "domain: every range must be finite and non-empty, got [{}, {}] x [{}, {}] x [{}, {}]",
                d.lo[0], d.hi[0], d.lo[1], d.hi[1], d.lo[2], d.hi[2]
            ),
        }
    }
}

impl std::error::Error for FrontError {}

impl From<SourceError> for FrontError {
    fn from(e: SourceError) -> FrontError {
        FrontError::Source(e)
    }
}
