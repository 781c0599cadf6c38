//! Results in the caller's world: `.to_nalgebra()` on every matrix and vector the crate
//! returns (feature `nalgebra`).
//!
//! Every result of this crate is a faer matrix (`MatRef` from the [`crate::Filter`] and
//! [`crate::Model`] accessors, owned `Mat` in [`crate::riccati::SteadyState`],
//! [`crate::riccati::Lqr`], [`crate::smoother::Smoothed`], …) or a slice (`&[f64]` states).
//! One trait, [`ToNalgebra`], converts any of them, so the idiom is the same everywhere:
//!
//! ```
//! use kalman::ToNalgebra;
//! use nalgebra::{DMatrix, DVector, dmatrix};
//!
//! let f: DMatrix<f64> = dmatrix![1.0, 1.0; 0.0, 1.0];
//! let ss = kalman::riccati::dare(&f, &dmatrix![1.0, 0.0], &DMatrix::identity(2, 2), &dmatrix![1.0], None)?;
//! let gain: DMatrix<f64> = ss.gain.to_nalgebra();
//! assert_eq!(gain.shape(), (2, 1));
//! let state: DVector<f64> = [1.0, 2.0][..].to_nalgebra();
//! assert_eq!(state.len(), 2);
//! # Ok::<(), kalman::Error>(())
//! ```

use faer::{Mat, MatRef};

/// Conversion of a result of this crate into the nalgebra type a nalgebra user works with:
/// matrices to `DMatrix<f64>`, vectors (`&[f64]`) to `DVector<f64>`, lists of matrices to
/// `Vec<DMatrix<f64>>`. Each call copies (the crate's storage is faer's).
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
