//! The crate's typed error: every rejected input names the offending matrix or parameter,
//! its shape or value, and the rule it broke.

/// Everything the solver and the boom estimator can reject.
///
/// # Example
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{SolveOptions, Weights, solve};
///
/// let h = dmatrix![1.0, 0.0; 0.0, 1.0];
/// let z = dvector![1.0, 2.0, 3.0]; // one value too many
/// let err = solve(&h, &z, &Weights::Identity, &SolveOptions::default()).unwrap_err();
/// assert!(matches!(err, wls::Error::Shape { name: "z", .. }));
/// println!("{err}");
/// ```
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// A matrix or vector has the wrong shape for its role.
    #[error("{name} has shape {rows}×{cols}, expected {expected}")]
    Shape {
        /// Which matrix or vector (e.g. `"z"`, `"H"`, `"V"`).
        name: &'static str,
        /// Rows found.
        rows: usize,
        /// Columns found.
        cols: usize,
        /// The shape the role requires, in words (e.g. `"m×1 with m = rows(H) = 6"`).
        expected: String,
    },
    /// An entry is NaN or infinite.
    #[error("{name}[{row}, {col}] = {value} is not finite")]
    NonFinite {
        /// Which matrix, vector or parameter.
        name: &'static str,
        /// Row of the entry (0 for scalars).
        row: usize,
        /// Column of the entry (0 for vectors and scalars).
        col: usize,
        /// The offending value.
        value: f64,
    },
    /// A diagonal weight is negative (weights must be ≥ 0; a zero weight drops the row).
    #[error("weight {name}[{index}] = {value} is negative; weights must be ≥ 0")]
    NegativeWeight {
        /// Which weight vector.
        name: &'static str,
        /// Index of the weight.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A full weight matrix is not symmetric.
    #[error(
        "{name} ({n}×{n}) is not symmetric: |V[{row},{col}] − V[{col},{row}]| = {difference:e}"
    )]
    NotSymmetric {
        /// Which matrix.
        name: &'static str,
        /// Its dimension.
        n: usize,
        /// Row of the worst asymmetric pair.
        row: usize,
        /// Column of the worst asymmetric pair.
        col: usize,
        /// The absolute asymmetry found.
        difference: f64,
    },
    /// A full weight matrix is not positive definite (its Cholesky factorisation failed).
    #[error("{name} ({n}×{n}) is not symmetric positive definite (Cholesky failed)")]
    NotPositiveDefinite {
        /// Which matrix.
        name: &'static str,
        /// Its dimension.
        n: usize,
    },
    /// The weighted design V^{1/2}H (or the regularised system) has numerical rank below n.
    #[error(
        "{name} has numerical rank {rank} < n = {cols} (singular values ≤ {tolerance:e} count as 0); \
         add Tikhonov regularisation or prior rows"
    )]
    RankDeficient {
        /// Which system (`"V^(1/2) H"` or `"regularised system"`).
        name: &'static str,
        /// Numerical rank found.
        rank: usize,
        /// Number of unknowns n.
        cols: usize,
        /// The singular-value tolerance used.
        tolerance: f64,
    },
    /// A scalar parameter is outside its allowed range.
    #[error("parameter {name} = {value} is invalid: {rule}")]
    InvalidParameter {
        /// Which parameter.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// The rule it broke.
        rule: &'static str,
    },
    /// Residual-variance scaling was requested but there are no degrees of freedom.
    #[error(
        "residual-variance scaling needs more rows than unknowns, got {rows} rows for {cols} unknowns"
    )]
    NoDegreesOfFreedom {
        /// Rows of the solved system.
        rows: usize,
        /// Unknowns.
        cols: usize,
    },
    /// A factorisation met an exactly singular pivot although the rank test passed.
    #[error("{name} is numerically singular: {detail}")]
    Singular {
        /// Which matrix.
        name: &'static str,
        /// What failed.
        detail: &'static str,
    },
}

/// Shorthand for this crate's results.
pub type Result<T> = core::result::Result<T, Error>;
