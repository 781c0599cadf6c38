//! The crate's typed error: every invalid input names the offending matrix and the rule broken.

/// Errors of model construction, filter construction and filter steps.
///
/// Every variant names the matrix or vector it is about (`"F"`, `"Q"`, `"z"`, …) so a
/// message points at the culprit. Steps return errors for inputs of the wrong length or
/// non-finite values and for a diverged estimate ([`Error::Diverged`]); a numerically
/// singular innovation covariance is *not* an error (it takes the rank-revealing path, see
/// [`crate::StepInfo::rank`]).
///
/// # Example
/// ```
/// use kalman::{DynDims, Error, Model};
///
/// // A 2×2 F for a model declared with n = 3.
/// let err = Model::new(DynDims::new(3, 1, 0)?, &[[1.0, 0.0], [0.0, 1.0]], &[[1.0, 0.0, 0.0]],
///     &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], &[[1.0]]).unwrap_err();
/// assert!(matches!(err, Error::Shape { name: "F", .. }));
/// println!("{err}");
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A matrix or vector has the wrong shape.
    #[error("{name} is {rows}x{cols}, expected {expected_rows}x{expected_cols}")]
    Shape {
        /// Name of the matrix (`"F"`, `"H"`, `"Q"`, `"R"`, `"S"`, `"B"`, `"P0"`, `"x0"`, `"z"`, `"u"`).
        name: &'static str,
        /// Rows found.
        rows: usize,
        /// Columns found.
        cols: usize,
        /// Rows required.
        expected_rows: usize,
        /// Columns required.
        expected_cols: usize,
    },
    /// A matrix or vector holds a NaN or infinite entry where only finite values are allowed.
    #[error("{name} ({rows}x{cols}) has a non-finite entry at ({row}, {col})")]
    NonFinite {
        /// Name of the matrix.
        name: &'static str,
        /// Rows of the matrix.
        rows: usize,
        /// Columns of the matrix.
        cols: usize,
        /// Row of the first offending entry.
        row: usize,
        /// Column of the first offending entry.
        col: usize,
    },
    /// A covariance is not symmetric within the tolerance [`crate::SYMMETRY_TOL`].
    #[error(
        "{name} ({n}x{n}) is not symmetric: |a[{row},{col}] - a[{col},{row}]| = {diff:e} exceeds tolerance {tol:e}"
    )]
    NotSymmetric {
        /// Name of the matrix.
        name: &'static str,
        /// Dimension.
        n: usize,
        /// Row of the worst pair.
        row: usize,
        /// Column of the worst pair.
        col: usize,
        /// The asymmetry found.
        diff: f64,
        /// The tolerance it broke.
        tol: f64,
    },
    /// A covariance (or the joint noise covariance `[[R, Sᵀ], [S, Q]]`) is indefinite.
    #[error(
        "{name} ({n}x{n}) is not positive semidefinite: minimum eigenvalue {min_eigenvalue:e} < -{tol:e}"
    )]
    NotPositiveSemidefinite {
        /// Name of the matrix (`"[[R, S^T], [S, Q]]"` for the joint noise covariance).
        name: &'static str,
        /// Dimension.
        n: usize,
        /// The most negative eigenvalue found.
        min_eigenvalue: f64,
        /// The tolerance (see [`crate::PSD_TOL`]).
        tol: f64,
    },
    /// A dimension is out of the supported range (zero states, or a fixed-size model above
    /// its compile-time limit).
    #[error("dimension {name} = {value} is out of range: {rule}")]
    Dimension {
        /// Name of the dimension (`"n"`, `"m"`, `"p"`).
        name: &'static str,
        /// The value given.
        value: usize,
        /// The rule broken.
        rule: &'static str,
    },
    /// A [`crate::ModelSource`] has no model for step `step`.
    #[error("the model source has no model for step {step}")]
    NoModel {
        /// The step index.
        step: usize,
    },
    /// A numerical factorisation failed at construction (e.g. an eigen-solver did not converge).
    #[error("factorisation of {name} failed: {reason}")]
    Factorisation {
        /// Name of the matrix.
        name: &'static str,
        /// What went wrong.
        reason: &'static str,
    },
    /// The filter diverged: after step `step` (0 for the first measurement) an entry of a
    /// state estimate or a diagonal entry of a covariance is NaN or infinite — typically an
    /// unstable mode the measurements do not see, whose variance overflowed. Checked at
    /// every step, so all earlier steps' estimates were finite; what was computed at this
    /// step is not meaningful, and [`crate::Filter::reset`] restarts the filter.
    #[error("the filter diverged at step {step}: {what} is not finite ({value})")]
    Diverged {
        /// The step index.
        step: usize,
        /// The quantity that diverged, e.g. `"P_{k+1|k}"`, `"x_{k|k}"`, `"x_{k|N}"`.
        what: &'static str,
        /// The offending value (NaN or ±∞).
        value: f64,
    },
    // ---- steady state, continuous time, smoothing, gain schedule ----
    /// A matrix that must be positive definite (not merely semidefinite) is not.
    #[error("{name} ({n}x{n}) is not positive definite: {rule}")]
    NotPositiveDefinite {
        /// Name of the matrix.
        name: &'static str,
        /// Dimension.
        n: usize,
        /// Why it must be positive definite.
        rule: &'static str,
    },
    // ---- steady-state / Riccati variants ----
    /// A pair fails the PBH detectability test: an eigenvalue on or outside the stability
    /// boundary has an eigenvector the output matrix does not see.
    #[error(
        "{pair} is not detectable: the mode λ = {re:.6e} {im:+.6e}i on or outside the stability boundary is unobservable (PBH rank test)"
    )]
    NotDetectable {
        /// The pair, e.g. "(F, H)".
        pair: &'static str,
        /// Real part of the offending eigenvalue.
        re: f64,
        /// Imaginary part of the offending eigenvalue.
        im: f64,
    },
    /// A pair fails the PBH stabilisability test.
    #[error(
        "{pair} is not stabilisable: the mode λ = {re:.6e} {im:+.6e}i on or outside the stability boundary is uncontrollable (PBH rank test)"
    )]
    NotStabilisable {
        /// The pair, e.g. "(F, Q^{1/2})".
        pair: &'static str,
        /// Real part of the offending eigenvalue.
        re: f64,
        /// Imaginary part of the offending eigenvalue.
        im: f64,
    },
    /// The doubling / ODE iteration for a Riccati equation did not converge.
    #[error("{equation}: no convergence after {iterations} iterations ({reason})")]
    RiccatiNoConvergence {
        /// Which equation ("filter DARE", "CARE", …).
        equation: &'static str,
        /// Iterations done.
        iterations: usize,
        /// What went wrong.
        reason: &'static str,
    },
    /// The computed Riccati solution fails its residual or stability check.
    #[error(
        "{equation}: relative residual {residual:.3e} exceeds {tolerance:.1e} or closed loop not stable (spectral measure {closed_loop:.6})"
    )]
    RiccatiCheck {
        /// Which equation.
        equation: &'static str,
        /// ‖residual‖_F / ‖P‖_F.
        residual: f64,
        /// Allowed relative residual.
        tolerance: f64,
        /// Spectral radius (discrete) or spectral abscissa (continuous) of the closed loop.
        closed_loop: f64,
    },
    // ---- nonlinear filters ----
    /// A nonlinear model's function (`"f"`, `"h"`, a Jacobian, `"Q"`, `"R"`) returned a NaN
    /// or infinite value.
    #[error("step {step}: the model's {function} returned a non-finite value at entry {index}")]
    ModelNonFinite {
        /// The function (`"f"`, `"h"`, `"f_jacobian"`, `"h_jacobian"`, `"Q"`, `"R"`).
        function: &'static str,
        /// The step index k.
        step: usize,
        /// Column-major index of the first offending entry.
        index: usize,
    },
    /// The covariance the sigma points are drawn from is not positive semidefinite (e.g. a
    /// negative centre weight of the unscented transform made the predicted covariance
    /// indefinite).
    #[error(
        "step {step}: {name} ({n}x{n}) for the sigma points is not positive semidefinite: Cholesky pivot {pivot:e} < -{tol:e}"
    )]
    SigmaCovariance {
        /// The covariance (`"P_{k|k-1}"` before an update, `"P_{k|k}"` before a prediction).
        name: &'static str,
        /// The step index k.
        step: usize,
        /// Dimension.
        n: usize,
        /// The offending pivot.
        pivot: f64,
        /// The tolerance it broke (relative to the largest diagonal entry).
        tol: f64,
    },
    /// The innovation covariance of a nonlinear update is singular (the nonlinear filters
    /// have no pseudo-inverse path: the linearised gain would be arbitrary).
    #[error(
        "step {step}: the innovation covariance ({m}x{m}) of the {filter} update is singular: Cholesky pivot {pivot:e} <= {tol:e} of its diagonal entry"
    )]
    SingularInnovation {
        /// The filter (`"EKF"`, `"iterated EKF"`, `"UKF"`).
        filter: &'static str,
        /// The step index k.
        step: usize,
        /// Observed measurement rows.
        m: usize,
        /// The offending pivot.
        pivot: f64,
        /// The tolerance (relative to the pivot's own diagonal entry of the covariance).
        tol: f64,
    },
    /// An error in one series of a [`crate::batch::BatchFilter`] run.
    #[error("series {series}: {error}")]
    InSeries {
        /// The series (0-based).
        series: usize,
        /// What went wrong in it.
        error: Box<Error>,
    },
    /// A record's time stamp is invalid: not finite, or earlier than the stamp before it.
    #[error("{name}[{index}] = {value} is invalid: {rule}")]
    TimeStamp {
        /// The time vector (`"t"`).
        name: &'static str,
        /// The index of the offending stamp.
        index: usize,
        /// The offending stamp.
        value: f64,
        /// The rule broken.
        rule: &'static str,
    },
    /// An option of a filter is out of its valid range.
    #[error("{name} = {value} is invalid: {rule}")]
    InvalidOption {
        /// The option (`"alpha"`, `"kappa"`, `"max_iterations"`, …).
        name: &'static str,
        /// The value given.
        value: f64,
        /// The rule broken.
        rule: &'static str,
    },
    // ---- particle filters ----
    /// An argument of a particle filter, its resampling or its smoother is invalid (a
    /// length, a weight, a uniform outside [0, 1)).
    #[error("{name}: {rule}")]
    ParticleInput {
        /// The argument (`"weights"`, `"uniforms"`, `"particles"`, …).
        name: &'static str,
        /// The rule broken, with the offending value.
        rule: String,
    },
    /// Every particle has zero weight: the measurement at step `step` is impossible under
    /// every particle (all log-weights −∞), or no particle of the smoother's step can reach
    /// the state drawn at the next one.
    #[error("step {step}: {what} is zero for every particle")]
    ParticleCollapse {
        /// The step index k.
        step: usize,
        /// What vanished (`"the likelihood"`, `"the look-ahead likelihood"`, `"the transition density"`).
        what: &'static str,
    },
    /// The algorithm asked for needs a function the particle model does not provide.
    #[error("{algorithm} needs the model's {function}, which it does not provide")]
    MissingFunction {
        /// The algorithm (`"the auxiliary particle filter"`, `"FFBSi"`).
        algorithm: &'static str,
        /// The trait method (`"lookahead"`, `"log_transition_density"`).
        function: &'static str,
    },
}
