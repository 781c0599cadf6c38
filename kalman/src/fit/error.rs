//! The fitting error: every failure names what is wrong with the model, the data or the
//! parameterisation.

/// Errors of likelihood evaluation and fitting.
///
/// The crate's second error type, for a reason: a fit fails in ways no filter step can
/// (nothing free, a direction the data do not identify, an optimiser that stops, an
/// interruption), with messages naming parameters built at run time, while the filter steps'
/// [`crate::Error`] names its matrices by static names. A filter's own error reaches a fit
/// unchanged as [`FitError::Model`], so a caller of the fitting API matches one type.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    /// The model or prior is invalid (shape, finiteness, symmetry, PSD).
    #[error(transparent)]
    Model(#[from] crate::Error),
    /// The data do not fit the model or are malformed.
    #[error("data: {0}")]
    Data(String),
    /// The series holds no observed measurement.
    #[error("the data hold no measurement (every entry is missing)")]
    NoMeasurements,
    /// Nothing is free: there is nothing to fit.
    #[error("nothing is free: free at least one of Q, R, x0, P0 or a matrix entry")]
    NothingFree,
    /// A free quantity cannot be identified from the data.
    #[error("{what} cannot be identified from the data: {why}")]
    NotIdentifiable {
        /// The free quantity, e.g. `"R"`.
        what: String,
        /// Why.
        why: String,
    },
    /// An innovation covariance (or a smoother's prediction covariance) is not positive
    /// definite, so the likelihood or its gradient is undefined there.
    #[error("{name} is not positive definite at step {step}")]
    NotPositiveDefinite {
        /// `"innovation covariance"` or `"predicted covariance"`.
        name: &'static str,
        /// The step.
        step: usize,
    },
    /// A quantity of the filter stopped being finite: the computation diverged at that step.
    #[error("the filter diverged at step {step}: {what} is not finite")]
    Diverged {
        /// What stopped being finite, e.g. `"the predicted state"`.
        what: &'static str,
        /// The step.
        step: usize,
    },
    /// A parameter vector has the wrong length or a non-finite entry.
    #[error("parameter vector: {0}")]
    Parameters(String),
    /// The estimator is not available for this request.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// The optimiser failed.
    #[error("optimiser failed: {0}")]
    Optimiser(String),
    /// The options' `interrupt` check asked the fit to stop.
    #[error("the fit was interrupted")]
    Interrupted,
}

/// A check a long fit calls between its iterations (see `EmOptions::interrupt` and
/// `MleOptions::interrupt`): `true` stops it with [`FitError::Interrupted`]. A plain
/// function, so the options stay `Copy`; it reaches its state through statics or, as the
/// Python module does, through the interpreter's own signal flag.
///
/// ```
/// use kalman::fit::Interrupt;
/// fn never() -> bool { false }
/// assert!(!Interrupt(never).fired());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Interrupt(pub fn() -> bool);

impl Interrupt {
    /// Runs the check.
    pub fn fired(&self) -> bool {
        (self.0)()
    }
}

impl PartialEq for Interrupt {
    /// The same function (by address, as `std::ptr::fn_addr_eq` compares them).
    fn eq(&self, other: &Self) -> bool {
        std::ptr::fn_addr_eq(self.0, other.0)
    }
}
