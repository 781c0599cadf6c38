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
//! let ss = kalman::riccati::Dare::new(&f, &h, &DMatrix::identity(2, 2), &dmatrix![1.0]).and_then(|p| p.solve())?;
//! let gain: DMatrix<f64> = ss.gain.to_nalgebra();
//! assert_eq!(gain.shape(), (2, 1));
//! let state: DVector<f64> = [1.0, 2.0][..].to_nalgebra();
//! assert_eq!(state.len(), 2);
//! # Ok::<(), kalman::Error>(())
//! ```

use faer::{Mat, MatRef};
use nalgebra::DMatrix;

use crate::riccati::{ContinuousSteadyState, Lqr, SteadyState};
use crate::smoother::Smoothed;

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

/// The whole smoothed track in nalgebra: `means` a `DMatrix` (column k is x_{k|N−1}),
/// `covariances` a `Vec<DMatrix>`.
impl ToNalgebra for Smoothed {
    type Output = Smoothed<DMatrix<f64>>;
    fn to_nalgebra(&self) -> Self::Output {
        Smoothed {
            means: self.means.to_nalgebra(),
            covariances: self.covariances.to_nalgebra(),
        }
    }
}

/// Every matrix of the steady state in nalgebra; counts and residual as they are.
impl ToNalgebra for SteadyState {
    type Output = SteadyState<DMatrix<f64>>;
    fn to_nalgebra(&self) -> Self::Output {
        SteadyState {
            prior: self.prior.to_nalgebra(),
            posterior: self.posterior.to_nalgebra(),
            gain: self.gain.to_nalgebra(),
            predictor_gain: self.predictor_gain.to_nalgebra(),
            innovation_cov: self.innovation_cov.to_nalgebra(),
            iterations: self.iterations,
            relative_residual: self.relative_residual,
        }
    }
}

/// Gain and cost in nalgebra.
impl ToNalgebra for Lqr {
    type Output = Lqr<DMatrix<f64>>;
    fn to_nalgebra(&self) -> Self::Output {
        Lqr {
            gain: self.gain.to_nalgebra(),
            cost: self.cost.to_nalgebra(),
            iterations: self.iterations,
            relative_residual: self.relative_residual,
        }
    }
}

/// Covariance and gain in nalgebra.
impl ToNalgebra for ContinuousSteadyState {
    type Output = ContinuousSteadyState<DMatrix<f64>>;
    fn to_nalgebra(&self) -> Self::Output {
        ContinuousSteadyState {
            covariance: self.covariance.to_nalgebra(),
            gain: self.gain.to_nalgebra(),
            iterations: self.iterations,
            relative_residual: self.relative_residual,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Entry-by-entry equality of a faer and a nalgebra matrix (a copy must be exact).
    fn same(a: &Mat<f64>, b: &DMatrix<f64>) -> bool {
        a.nrows() == b.nrows()
            && a.ncols() == b.ncols()
            && (0..a.nrows())
                .all(|i| (0..a.ncols()).all(|j| a[(i, j)].to_bits() == b[(i, j)].to_bits()))
    }

    #[test]
    fn result_structs_convert_every_matrix_and_keep_the_scalars() {
        let f = nalgebra::dmatrix![1.0, 0.5; 0.0, 1.0];
        let (h, q, r) = (
            nalgebra::dmatrix![1.0, 0.0],
            DMatrix::identity(2, 2) * 0.1,
            nalgebra::dmatrix![0.4],
        );
        let ss = crate::riccati::Dare::new(&f, &h, &q, &r)
            .and_then(|p| p.solve())
            .expect("solvable");
        let na = ss.to_nalgebra();
        assert!(
            same(&ss.prior, &na.prior)
                && same(&ss.posterior, &na.posterior)
                && same(&ss.gain, &na.gain)
        );
        assert!(
            same(&ss.predictor_gain, &na.predictor_gain)
                && same(&ss.innovation_cov, &na.innovation_cov)
        );
        assert_eq!(
            (na.iterations, na.relative_residual.to_bits()),
            (ss.iterations, ss.relative_residual.to_bits())
        );
        let b = nalgebra::dmatrix![0.125; 0.5];
        let lqr = crate::riccati::Dlqr::new(&f, &b, &q, &r)
            .and_then(|p| p.solve())
            .expect("solvable");
        let lna = lqr.to_nalgebra();
        assert!(
            same(&lqr.gain, &lna.gain)
                && same(&lqr.cost, &lna.cost)
                && lna.iterations == lqr.iterations
        );
        let a = nalgebra::dmatrix![-1.0];
        let one = nalgebra::dmatrix![1.0];
        let cs = crate::riccati::Care::new(&a, &one, &one, &one)
            .and_then(|p| p.solve())
            .expect("solvable");
        let cna = cs.to_nalgebra();
        assert!(same(&cs.covariance, &cna.covariance) && same(&cs.gain, &cna.gain));
        let smoothed = Smoothed {
            means: Mat::from_fn(2, 3, |i, j| (10 * i + j) as f64),
            covariances: vec![Mat::from_fn(2, 2, |i, j| (i + 2 * j) as f64); 3],
        };
        let sna = smoothed.to_nalgebra();
        assert!(same(&smoothed.means, &sna.means) && sna.covariances.len() == 3);
        assert!(
            smoothed
                .covariances
                .iter()
                .zip(&sna.covariances)
                .all(|(a, b)| same(a, b))
        );
    }

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
