//! The matrix inputs every constructor takes: [`MatrixInput`] over faer and nalgebra
//! matrices, row-major arrays and vectors, and [`Diagonal`].

use faer::{Mat, MatRef};

/// Anything that can be read as a dense real matrix: faer `Mat`/`MatRef`, row-major nested
/// arrays `[[f64; C]; R]` and vectors `Vec<Vec<f64>>`, nalgebra matrices (feature
/// `nalgebra`).
///
/// # Example
/// ```
/// use kalman::MatrixInput;
///
/// let a = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]];
/// assert_eq!((a.nrows(), a.ncols()), (2, 3));
/// assert!((a.at(1, 0) - 4.0).abs() < 1e-15);
/// let m = faer::mat![[1.0, 2.0], [3.0, 4.0]];
/// assert!((m.at(0, 1) - 2.0).abs() < 1e-15);
/// ```
pub trait MatrixInput {
    /// Number of rows.
    fn nrows(&self) -> usize;
    /// Number of columns.
    fn ncols(&self) -> usize;
    /// Entry `(i, j)`.
    fn at(&self, i: usize, j: usize) -> f64;
}

impl MatrixInput for MatRef<'_, f64> {
    fn nrows(&self) -> usize {
        MatRef::nrows(self)
    }
    fn ncols(&self) -> usize {
        MatRef::ncols(self)
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        self[(i, j)]
    }
}

impl MatrixInput for Mat<f64> {
    fn nrows(&self) -> usize {
        Mat::nrows(self)
    }
    fn ncols(&self) -> usize {
        Mat::ncols(self)
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        self[(i, j)]
    }
}

impl<const R: usize, const C: usize> MatrixInput for [[f64; C]; R] {
    fn nrows(&self) -> usize {
        R
    }
    fn ncols(&self) -> usize {
        C
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        self[i][j]
    }
}

/// Row-major nested vectors, one `Vec` per row. A row shorter than the longest reads as NaN
/// where it has no entry, so every loader refuses a ragged matrix as a non-finite entry at
/// the first missing position (naming the matrix, the row and the column).
///
/// ```
/// use kalman::{DynDims, Error, Model};
/// let d = DynDims::new(2, 1, 0)?;
/// let f = vec![vec![1.0, 0.1], vec![0.0, 1.0]];
/// let h = vec![vec![1.0, 0.0]];
/// let q = vec![vec![1e-4, 0.0], vec![0.0, 1e-3]];
/// assert!(Model::new(d, &f, &h, &q, &vec![vec![0.01]]).is_ok());
/// let ragged = vec![vec![1.0, 0.1], vec![0.0]];
/// let err = Model::new(d, &ragged, &h, &q, &vec![vec![0.01]]).unwrap_err();
/// assert!(matches!(err, Error::NonFinite { name: "F", row: 1, col: 1, .. }));
/// # Ok::<(), kalman::Error>(())
/// ```
impl MatrixInput for [Vec<f64>] {
    fn nrows(&self) -> usize {
        self.len()
    }
    fn ncols(&self) -> usize {
        self.iter().map(Vec::len).max().unwrap_or(0)
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        self[i].get(j).copied().unwrap_or(f64::NAN)
    }
}

impl MatrixInput for Vec<Vec<f64>> {
    fn nrows(&self) -> usize {
        self.as_slice().nrows()
    }
    fn ncols(&self) -> usize {
        self.as_slice().ncols()
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        self.as_slice().at(i, j)
    }
}

/// A diagonal matrix given by its diagonal (numpy's `np.diag`): `Diagonal([1.0, 4.0])` is
/// `[[1, 0], [0, 4]]`. For the diagonal covariances that most priors and noise models are.
///
/// ```
/// use kalman::{Diagonal, MatrixInput};
/// let p0 = Diagonal([100.0; 3]);
/// assert_eq!((p0.nrows(), p0.ncols()), (3, 3));
/// assert!((p0.at(1, 1) - 100.0).abs() < 1e-15 && p0.at(0, 2).abs() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diagonal<V>(pub V);

impl<V: AsRef<[f64]>> MatrixInput for Diagonal<V> {
    fn nrows(&self) -> usize {
        self.0.as_ref().len()
    }
    fn ncols(&self) -> usize {
        self.0.as_ref().len()
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        if i == j { self.0.as_ref()[i] } else { 0.0 }
    }
}

impl<T: MatrixInput + ?Sized> MatrixInput for &T {
    fn nrows(&self) -> usize {
        (**self).nrows()
    }
    fn ncols(&self) -> usize {
        (**self).ncols()
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        (**self).at(i, j)
    }
}

#[cfg(feature = "nalgebra")]
impl<R: nalgebra::Dim, C: nalgebra::Dim, S: nalgebra::RawStorage<f64, R, C>> MatrixInput
    for nalgebra::Matrix<f64, R, C, S>
{
    fn nrows(&self) -> usize {
        self.shape().0
    }
    fn ncols(&self) -> usize {
        self.shape().1
    }
    fn at(&self, i: usize, j: usize) -> f64 {
        self[(i, j)]
    }
}
