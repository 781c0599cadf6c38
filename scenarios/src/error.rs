//! The error type of the `scenarios` program: every variant names the file, key or value at
//! fault. Bad input the user can fix ([`Error::Read`], [`Error::Invalid`], [`Error::Usage`])
//! exits with code 2; output and computation failures with code 1.

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
    /// The `kalman` crate rejected a computation on the model of a user's file.
    #[error("{}: {context}: {source}", path.display())]
    KalmanOnFile {
        /// The model file.
        path: PathBuf,
        /// What was being computed.
        context: &'static str,
        /// The library's error.
        source: kalman::Error,
    },
    /// A model fit failed.
    #[error("{context}: {source}")]
    Fit {
        /// Which fit or which part of it.
        context: &'static str,
        /// The fitting library's error.
        source: kalman::fit::FitError,
    },
    /// A fit stopped before converging and `--allow-unconverged` was not given.
    #[error("fit: not converged ({message}); rerun with --allow-unconverged to write it anyway")]
    FitNotConverged {
        /// The optimiser's reason for stopping.
        message: String,
    },
    /// An optimiser (argmin) failed to set up or to run.
    #[error("{stage}: {source}")]
    Optimiser {
        /// Which search.
        stage: &'static str,
        /// argmin's error.
        source: argmin::core::Error,
    },
    /// A search finished without evaluating a single candidate, so it has no best one.
    #[error("{stage}: the search evaluated no candidate")]
    NothingEvaluated {
        /// Which search.
        stage: &'static str,
    },
    /// The autocorrelation fit was given fewer observed samples than it needs.
    #[error(
        "autocorrelation fit: {observed} observed samples for {lags} lags (needs at least lags + 2, and lags ≥ 1)"
    )]
    TooFewSamples {
        /// Observed (non-missing) samples.
        observed: usize,
        /// Lags asked for.
        lags: usize,
    },
    /// A model could not be written as TOML.
    #[error("{dest}: cannot serialise: {source}")]
    SerialiseToml {
        /// Where it was to be written (a file or stdout).
        dest: String,
        /// The TOML writer's error.
        source: toml::ser::Error,
    },
    /// The `model` crate rejected a computation on valid input.
    #[error("{context}: {source}")]
    Model {
        /// What was being computed.
        context: &'static str,
        /// The library's error.
        source: model::Error,
    },
    /// The `kalman` crate rejected a computation on valid input.
    #[error("{context}: {source}")]
    Kalman {
        /// What was being computed.
        context: &'static str,
        /// The library's error.
        source: kalman::Error,
    },
    /// The `wls` crate rejected a computation on valid input.
    #[error("{context}: {source}")]
    Wls {
        /// What was being computed.
        context: &'static str,
        /// The library's error.
        source: wls::Error,
    },
    /// The `sensors` crate rejected a configuration.
    #[error("{context}: {source}")]
    Sensors {
        /// Which sensor or process.
        context: &'static str,
        /// The library's error.
        source: sensors::Error,
    },
    /// The interrupt handler could not be installed (one is already set).
    #[error("cannot install the interrupt handler: {0}")]
    Interrupt(ctrlc::Error),
    /// A value could not be serialised for writing.
    #[error("{path}: cannot serialise: {source}")]
    Serialise {
        /// The file it was for.
        path: PathBuf,
        /// serde_json's error.
        source: serde_json::Error,
    },
    /// A computed model lacks a property the scenario relies on.
    #[error("{0}")]
    Degenerate(&'static str),
    /// The worker pool could not start.
    #[error("cannot start {threads:?} worker threads: {source}")]
    Threads {
        /// The requested number of threads (`None`: all cores).
        threads: Option<usize>,
        /// Rayon's error.
        source: rayon::ThreadPoolBuildError,
    },
    /// A figure could not be drawn.
    #[error("{path}: cannot draw: {message}")]
    Plot {
        /// The SVG file.
        path: PathBuf,
        /// The plotting library's message.
        message: String,
    },
}

/// Why a command-line value was refused; clap prints it after naming the argument.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ValueError {
    /// Not a string of decimal digits.
    #[error("expected a whole number")]
    NotWhole,
    /// Digits, but more than the target type holds.
    #[error("too large for a whole number here")]
    TooLarge,
    /// A count that must be at least 1.
    #[error("must be at least 1")]
    Zero,
    /// A number of seconds that is zero, negative or not finite.
    #[error("must be finite and > 0 (seconds)")]
    NotPositiveSeconds,
    /// A probability that is not a number strictly between 0 and 1.
    #[error("must be a number strictly between 0 and 1 (a probability such as 0.9999)")]
    NotProbability,
    /// Not a number where seconds were expected.
    #[error("not a number (seconds, finite and > 0)")]
    NotSeconds,
    /// A discretisation method the program does not know (the text given).
    #[error(
        "unknown method `{0}`: expected zoh, tustin, tustin-prewarp:W, euler or backward-euler"
    )]
    UnknownMethod(String),
    /// `tustin-prewarp:W` with a frequency that is not a finite number > 0 (the text given).
    #[error("tustin-prewarp:W needs a pre-warp frequency W > 0 in rad/s, not `{0}`")]
    Prewarp(String),
}

impl Error {
    /// The process exit code for this error: 2 for input the user can fix, 1 otherwise.
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::Write { .. }
            | Error::KalmanOnFile { .. }
            | Error::Fit { .. }
            | Error::FitNotConverged { .. }
            | Error::Optimiser { .. }
            | Error::NothingEvaluated { .. }
            | Error::TooFewSamples { .. }
            | Error::SerialiseToml { .. }
            | Error::Model { .. }
            | Error::Kalman { .. }
            | Error::Wls { .. }
            | Error::Sensors { .. }
            | Error::Degenerate(_)
            | Error::Interrupt(_)
            | Error::Serialise { .. }
            | Error::Threads { .. }
            | Error::Plot { .. } => 1,
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
