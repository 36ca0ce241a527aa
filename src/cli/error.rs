//! The command line's errors: its own usage and I/O problems, and the
//! library's errors mapped to the flags that caused them.

use isoc::syntax::FrontError;
use isoc::twin::TrackError;

/// Every failure of a command.
#[derive(Debug)]
pub enum Error {
    /// A bad flag value or combination.
    Usage(String),
    /// Reading or writing a file failed.
    Io {
        /// The file.
        path: String,
        /// What the system said.
        error: std::io::Error,
    },
    /// The library failed.
    Lib(isoc::Error),
    /// Ctrl-C stopped the run (exit status 130; nothing written).
    Interrupted,
}

impl<E: Into<isoc::Error>> From<E> for Error {
    fn from(e: E) -> Error {
        Error::Lib(e.into())
    }
}

impl Error {
    /// The text printed on stderr: a source error as its diagnostics, the
    /// rest as `error: MESSAGE`, naming the flag that caused it.
    pub fn render(&self) -> String {
        let message = match self {
            Error::Usage(m) => m.clone(),
            Error::Interrupted => "interrupted: nothing was written".to_string(),
            Error::Io { path, error } => format!("{path}: {error}"),
            Error::Lib(e) => {
                if let Some(s) = e.source_error() {
                    return s.render();
                }
                match e {
                    isoc::Error::Front(f) => match f {
                        FrontError::ParamNotFinite { name, value } => {
                            format!("--set {name}={value}: the value must be a finite number")
                        }
                        FrontError::UnknownParam { name, .. } => format!("--set {name}=…: {f}"),
                        FrontError::BadDomain(_) => format!("--{f}"),
                        FrontError::Source(_) => f.to_string(),
                    },
                    isoc::Error::Track(
                        t @ (TrackError::EdgeNotPositive(_)
                        | TrackError::EdgeTooSmall { .. }
                        | TrackError::TooManyPasses { .. }
                        | TrackError::Alpha(_)),
                    ) => format!("--{t}"),
                    other => other.to_string(),
                }
            }
        };
        format!("error: {message}\n")
    }
}
