//! The crate's typed error: every variant names the offending matrix or parameter and the rule.

/// Everything that can go wrong when building, composing, discretising or analysing a model.
///
/// Each variant names the matrix or parameter at fault (for example `"A"`, `"Q"`, `"dt"`,
/// `"time_constant"`), its shape or value, and the rule it broke.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
/// use model::{ContinuousSs, Error};
///
/// let a = dmatrix![1.0, 2.0]; // 1×2
/// let err = ContinuousSs::new(a, dmatrix![1.0], dmatrix![1.0], dmatrix![0.0]).unwrap_err();
/// assert!(matches!(err, Error::NotSquare { name: "A", .. }));
/// println!("{err}"); // matrix A must be square, but it is 1×2
/// ```
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// A matrix that must be square is not.
    #[error("matrix {name} must be square, but it is {rows}×{cols}")]
    NotSquare {
        /// The matrix.
        name: &'static str,
        /// Its number of rows.
        rows: usize,
        /// Its number of columns.
        cols: usize,
    },
    /// A matrix does not have the shape its partners imply.
    #[error("matrix {name} is {rows}×{cols} but must be {expected_rows}×{expected_cols} ({rule})")]
    DimensionMismatch {
        /// The matrix.
        name: &'static str,
        /// Its number of rows.
        rows: usize,
        /// Its number of columns.
        cols: usize,
        /// The rows it must have.
        expected_rows: usize,
        /// The columns it must have.
        expected_cols: usize,
        /// Why: which other matrix fixes the dimension.
        rule: &'static str,
    },
    /// A matrix entry is NaN or infinite.
    #[error("matrix {name} has a non-finite entry {value} at ({row}, {col})")]
    NonFiniteMatrix {
        /// The matrix.
        name: &'static str,
        /// Row of the first bad entry.
        row: usize,
        /// Column of the first bad entry.
        col: usize,
        /// The entry.
        value: f64,
    },
    /// A scalar parameter is NaN, infinite or outside its allowed range.
    #[error("parameter {name} = {value} is invalid: it must be {rule}")]
    InvalidParameter {
        /// The parameter (for example `"dt"`, `"time_constant"`, `"variance"`).
        name: &'static str,
        /// Its value.
        value: f64,
        /// The rule it broke (for example `"finite and > 0"`).
        rule: &'static str,
    },
    /// A covariance or intensity matrix is not symmetric.
    #[error("matrix {name} must be symmetric, but |{name} − {name}ᵀ| reaches {asymmetry:e}")]
    NotSymmetric {
        /// The matrix.
        name: &'static str,
        /// Largest |M_ij − M_ji|.
        asymmetry: f64,
    },
    /// A covariance or intensity matrix has a negative eigenvalue.
    #[error(
        "matrix {name} must be positive semi-definite, but its smallest eigenvalue is {min_eigenvalue:e}"
    )]
    NotPositiveSemiDefinite {
        /// The matrix.
        name: &'static str,
        /// Its smallest eigenvalue.
        min_eigenvalue: f64,
    },
    /// A stationary quantity was asked of a system that has none.
    #[error("matrix {name} is not stable: {measure} = {value} (needs {rule})")]
    Unstable {
        /// The matrix (`"F"` or `"A"`).
        name: &'static str,
        /// What was measured (`"spectral radius"` or `"largest real part of an eigenvalue"`).
        measure: &'static str,
        /// The measured value.
        value: f64,
        /// The rule (`"< 1"` or `"< 0"`).
        rule: &'static str,
    },
    /// A matrix that must be inverted (by a solve) is singular.
    #[error("matrix {name} is singular: {context}")]
    Singular {
        /// The matrix, written as an expression (for example `"I − A·dt/2"`).
        name: &'static str,
        /// Where it was needed.
        context: &'static str,
    },
    /// A polynomial is empty, all zero or has a zero coefficient where one is required.
    #[error("polynomial {name} is invalid: {rule}")]
    InvalidPolynomial {
        /// `"numerator"` or `"denominator"`.
        name: &'static str,
        /// The rule broken.
        rule: &'static str,
    },
    /// A transfer function has a numerator of higher degree than its denominator.
    #[error(
        "transfer function is improper: numerator degree {num_degree} > denominator degree {den_degree}"
    )]
    Improper {
        /// Degree of the numerator.
        num_degree: usize,
        /// Degree of the denominator.
        den_degree: usize,
    },
    /// Two systems that must share a sampling interval do not.
    #[error("sampling intervals differ: {first} s vs {second} s")]
    SampleTimeMismatch {
        /// The first system's Δt.
        first: f64,
        /// The second system's Δt.
        second: f64,
    },
    /// An index (output selection) is out of range.
    #[error("{name} index {index} is out of range (there are {len})")]
    IndexOutOfRange {
        /// What was indexed (for example `"output"`).
        name: &'static str,
        /// The index.
        index: usize,
        /// How many there are.
        len: usize,
    },
    /// A matrix exponential over one step overflowed: the step is too large for the dynamics
    /// (`e^{A·dt}` grows like `e^{λ_max·dt}`, past `f64`'s range near `λ·dt ≈ 709`).
    #[error(
        "dt = {dt} is too large for this A: {what} overflows (‖A‖·dt = {growth:e}); use a smaller dt"
    )]
    StepTooLarge {
        /// The step size Δt.
        dt: f64,
        /// The exponential that overflowed (for example `"e^{A·dt}"`).
        what: &'static str,
        /// `‖A‖₁·dt` (the 1-norm of the scaled state matrix), for scale.
        growth: f64,
    },
    /// An iterative algorithm did not converge.
    #[error("{algorithm} did not converge within {iterations} iterations")]
    NoConvergence {
        /// The algorithm.
        algorithm: &'static str,
        /// Iterations spent.
        iterations: usize,
    },
    /// The Kalman engine rejected the model built by `DiscreteSs::to_kalman` (feature
    /// `kalman`).
    #[cfg(feature = "kalman")]
    #[error("kalman: {0}")]
    Kalman(#[from] kalman::Error),
}

/// Short form of `Result<T, model::Error>`.
pub type Result<T> = std::result::Result<T, Error>;
