//! The error type of the `scenarios` program: every variant names the file, key or value at
//! fault, and all of them map to exit code 2 (bad input the user can fix) except
//! [`Error::Write`] on output and [`Error::Compute`].

use std::path::PathBuf;

/// What went wrong, with enough context for a one-line message on stderr.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A file could not be written (the destination is left untouched).
    #[error("{path}: cannot write: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A configuration or model file is malformed or holds an invalid value.
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong: the key, matrix or line and column, and the rule broken.
        message: String,
    },
    /// A command-line value is invalid.
    #[error("{0}")]
    Usage(String),
    /// A computation failed on valid input (a library error surfaced as is).
    #[error("{0}")]
    Compute(String),
}

impl Error {
    /// The process exit code for this error: 2 for input the user can fix, 1 otherwise.
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::Write { .. } | Error::Compute(_) => 1,
            _ => 2,
        }
    }

    /// An [`Error::Invalid`] for `path`.
    pub fn invalid(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// Shorthand used across the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
