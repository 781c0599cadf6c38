//! The crate's dense kernels and its covariance rule on plain slices, for front ends that hold
//! their matrices as buffers (the Python module): the same Cholesky factorisation and solve
//! the filters run, and the same symmetry and PSD tolerances every constructor applies.
//!
//! Matrices are `n`×`n` column-major slices. A symmetric matrix reads the same in either
//! order, so a row-major caller may pass its buffer as it is to [`check_covariance`];
//! [`cholesky`] of a row-major buffer leaves the *upper* factor `U = Lᵀ` in the buffer's
//! row-major upper triangle.
//!
//! ```
//! use kalman::dense;
//!
//! let mut a = [4.0, 2.0, 2.0, 5.0]; // [[4, 2], [2, 5]]
//! dense::check_covariance("A", &a, 2)?;
//! assert!(dense::cholesky(&mut a, 2, 0.0)); // L = [[2, 0], [1, 2]] in the lower triangle
//! let mut b = [8.0, 9.0];
//! dense::cholesky_solve(&a, 2, &mut b); // A x = b
//! assert!((b[0] - 1.375).abs() < 1e-15 && (b[1] - 1.25).abs() < 1e-15);
//! assert!(dense::check_covariance("A", &[1.0, 0.0, 0.0, -1.0], 2).is_err());
//! # Ok::<(), kalman::Error>(())
//! ```

use crate::error::Error;

/// In-place lower Cholesky factorisation of the `n`×`n` column-major `a`: only the lower
/// triangle is read and written (the strict upper triangle is left as it was). Returns
/// `false` when a pivot is NaN or at or below `tol` (0 for "positive definite").
///
/// ```
/// let mut a = [1.0, 1.0, 1.0, 1.0]; // singular: the second pivot is 0
/// assert!(!kalman::dense::cholesky(&mut a, 2, 0.0));
/// ```
pub fn cholesky(a: &mut [f64], n: usize, tol: f64) -> bool {
    crate::kernels::cholesky(&mut a[..n * n], n, tol)
}

/// Solves `L Lᵀ x = b` in place, with `L` the lower factor [`cholesky`] left in `l`.
///
/// ```
/// let l = [2.0, 0.0, 0.0, 3.0]; // L = diag(2, 3): A = diag(4, 9)
/// let mut b = [8.0, 18.0];
/// kalman::dense::cholesky_solve(&l, 2, &mut b);
/// assert_eq!(b, [2.0, 2.0]);
/// ```
pub fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
    crate::kernels::cholesky_solve(&l[..n * n], n, &mut b[..n]);
}

/// Solves `L Lᵀ X = B` in place for the `n`×`c` row-major `B`, column by column, with `L`
/// the lower factor [`cholesky`] left in `l`.
///
/// ```
/// let l = [2.0, 0.0, 0.0, 3.0]; // A = diag(4, 9)
/// let mut b = [4.0, 8.0, 9.0, 27.0]; // row-major [[4, 8], [9, 27]]
/// kalman::dense::cholesky_solve_columns(&l, 2, &mut b, 2);
/// assert_eq!(b, [1.0, 2.0, 1.0, 3.0]);
/// ```
pub fn cholesky_solve_columns(l: &[f64], n: usize, b: &mut [f64], c: usize) {
    for j in 0..c {
        crate::kernels::cholesky_solve_strided(&l[..n * n], n, &mut b[j..], c);
    }
}

/// The workspace's covariance rule: `a` (`n`×`n`) is symmetric within
/// [`crate::SYMMETRY_TOL`]`·max|a|` and positive semi-definite within
/// [`crate::PSD_TOL`]`·max|λ|` — what [`crate::Model::new`] and every filter constructor
/// check. `a` is not changed.
///
/// # Errors
/// [`Error::NotSymmetric`] naming `name` and the worst pair, [`Error::NotPositiveSemidefinite`]
/// with the most negative eigenvalue, [`Error::Factorisation`] if the eigen-decomposition
/// fails, [`Error::Dimension`] when `a` holds fewer than `n²` entries.
///
/// ```
/// use kalman::{Error, dense::check_covariance};
///
/// // Singular by round-off (rank one): accepted; an eigenvalue of −1e-6: refused.
/// assert!(check_covariance("P", &[1.0, 1.0, 1.0, 1.0 + 1e-17], 2).is_ok());
/// let refused = check_covariance("P", &[1.0, 0.0, 0.0, -1e-6], 2);
/// assert!(matches!(refused, Err(Error::NotPositiveSemidefinite { name: "P", .. })));
/// ```
pub fn check_covariance(name: &'static str, a: &[f64], n: usize) -> Result<(), Error> {
    if a.len() < n * n {
        return Err(Error::Dimension {
            name,
            value: a.len(),
            rule: "a covariance buffer holds n² entries",
        });
    }
    let mut sym = a[..n * n].to_vec();
    crate::model::checked_factor(name, &mut sym, n, &mut vec![0.0; n * n])
}
