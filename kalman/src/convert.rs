//! Results in the caller's world: `.to_nalgebra()` on every matrix, vector and list of
//! matrices the crate returns (feature `nalgebra`).
//!
//! Every result of this crate is a faer matrix (`MatRef` from the accessors of
//! [`crate::Filter`], [`crate::Model`], the nonlinear filters and the gain schedule; owned
//! `Mat` in [`crate::riccati::SteadyState`], [`crate::riccati::Lqr`],
//! [`crate::smoother::Smoothed`], …), a list of them (`Vec<Mat>`, the smoothed covariances) or
//! a slice (`&[f64]`, states and innovations). One trait, [`ToNalgebra`], converts any of
//! them, so the idiom is the same everywhere: take the field or accessor, call
//! `.to_nalgebra()`.
//!
//! ```
//! use kalman::ToNalgebra;
//! use kalman::nalgebra::{DMatrix, DVector, dmatrix};
//!
//! let f: DMatrix<f64> = dmatrix![1.0, 1.0; 0.0, 1.0];
//! let h = dmatrix![1.0, 0.0];
//! let ss = kalman::riccati::dare(&f, &h, &DMatrix::identity(2, 2), &dmatrix![1.0], None)?;
//! let gain: DMatrix<f64> = ss.gain.to_nalgebra();
//! assert_eq!(gain.shape(), (2, 1));
//! let state: DVector<f64> = [1.0, 2.0][..].to_nalgebra();
//! assert_eq!(state.len(), 2);
//! # Ok::<(), kalman::Error>(())
//! ```

use faer::{Mat, MatRef};

/// Conversion of a result of this crate into the nalgebra type a nalgebra user works with:
/// matrices to `DMatrix<f64>`, vectors (`[f64]`) to `DVector<f64>`, lists of matrices to
/// `Vec<DMatrix<f64>>`, `Option`s of any of these to `Option`s. Each call copies (the
/// crate's storage is faer's).
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, DynDims, Filter, Model, ToNalgebra};
/// use kalman::nalgebra::dmatrix;
///
/// // nalgebra in: a random walk, q = r = 1, prior N(0, 1).
/// let one = dmatrix![1.0];
/// let model = Model::new(DynDims::new(1, 1, 0)?, &one, &one, &one, &one)?;
/// let mut filter = Filter::new(model, &[0.0], &one, CovarianceForm::Joseph)?;
/// filter.step(&[2.0], None)?;
/// // nalgebra out: gain 1/2, x = 1, P = 1/2.
/// let (k, x, p) = (filter.gain().to_nalgebra(), filter.state().to_nalgebra(), filter.covariance().to_nalgebra());
/// assert!((k[(0, 0)] - 0.5).abs() < 1e-12 && (x[0] - 1.0).abs() < 1e-12);
/// assert!((p - dmatrix![0.5]).norm() < 1e-12);
/// assert!(filter.model().s().to_nalgebra().is_none()); // no cross-covariance
/// # Ok::<(), kalman::Error>(())
/// ```
pub trait ToNalgebra {
    /// The nalgebra type of the result.
    type Output;
    /// A copy in nalgebra's storage.
    fn to_nalgebra(&self) -> Self::Output;
}

impl ToNalgebra for MatRef<'_, f64> {
    type Output = nalgebra::DMatrix<f64>;
    fn to_nalgebra(&self) -> Self::Output {
        nalgebra::DMatrix::from_fn(self.nrows(), self.ncols(), |i, j| self[(i, j)])
    }
}

impl ToNalgebra for Mat<f64> {
    type Output = nalgebra::DMatrix<f64>;
    fn to_nalgebra(&self) -> Self::Output {
        self.as_ref().to_nalgebra()
    }
}

impl ToNalgebra for [f64] {
    type Output = nalgebra::DVector<f64>;
    fn to_nalgebra(&self) -> Self::Output {
        nalgebra::DVector::from_column_slice(self)
    }
}

impl ToNalgebra for [Mat<f64>] {
    type Output = Vec<nalgebra::DMatrix<f64>>;
    fn to_nalgebra(&self) -> Self::Output {
        self.iter().map(ToNalgebra::to_nalgebra).collect()
    }
}

impl ToNalgebra for Vec<Mat<f64>> {
    type Output = Vec<nalgebra::DMatrix<f64>>;
    fn to_nalgebra(&self) -> Self::Output {
        self.as_slice().to_nalgebra()
    }
}

impl<T: ToNalgebra + ?Sized> ToNalgebra for &T {
    type Output = T::Output;
    fn to_nalgebra(&self) -> Self::Output {
        (**self).to_nalgebra()
    }
}

impl<T: ToNalgebra> ToNalgebra for Option<T> {
    type Output = Option<T::Output>;
    fn to_nalgebra(&self) -> Self::Output {
        self.as_ref().map(ToNalgebra::to_nalgebra)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrices_and_vectors_keep_every_entry_in_place() {
        // Distinct entries, so a transposition or a row/column-major mix-up shows.
        let m = Mat::from_fn(3, 2, |i, j| (10 * i + j) as f64);
        let n = m.to_nalgebra();
        assert_eq!(n.shape(), (3, 2));
        for i in 0..3 {
            for j in 0..2 {
                assert!((n[(i, j)] - m[(i, j)]).abs() < f64::MIN_POSITIVE);
            }
        }
        let v = [1.5, -2.5].as_slice().to_nalgebra();
        assert!((v[1] + 2.5).abs() < f64::MIN_POSITIVE);
        let list = vec![m.clone(), m].to_nalgebra();
        assert_eq!(list.len(), 2);
        let none: Option<Mat<f64>> = None;
        assert!(none.to_nalgebra().is_none());
    }
}
