//! The RTS backward pass in square-root form: each smoothed covariance is carried as a
//! triangular factor, so it is symmetric positive semidefinite by construction, never the
//! difference `P_{k+1|N} − P_{k+1|k}` of two covariances.
//!
//! The equations are on [`Rts::smooth_sqrt`].
#![allow(non_snake_case)]

use faer::Mat;

use super::{Rts, smoothed_finite};
use crate::nonlinear::linalg::{forward, psd_cholesky};
use crate::{Error, PSD_TOL, RANK_TOL};

/// What [`Rts::smooth_sqrt`] returns: the smoothed means and lower-triangular factors of the
/// smoothed covariances.
#[derive(Debug, Clone)]
pub struct SqrtSmoothed {
    /// Smoothed means: column k is x_{k|N−1} (n×N).
    pub means: Mat<f64>,
    /// Lower-triangular factors S_{k|N−1} with nonnegative diagonal, `S Sᵀ = P_{k|N−1}`, one
    /// n×n matrix per step.
    pub factors: Vec<Mat<f64>>,
}

impl SqrtSmoothed {
    /// The smoothed covariance `P_{k|N−1} = S Sᵀ` of step `k` (None past the last step),
    /// exactly symmetric (each pair of entries is one sum).
    pub fn covariance(&self, k: usize) -> Option<Mat<f64>> {
        let S = self.factors.get(k)?;
        let n = S.nrows();
        let mut P = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for i in j..n {
                // S is lower triangular: entries beyond column j of row j are zero.
                let v: f64 = (0..=j).map(|l| S[(i, l)] * S[(j, l)]).sum();
                P[(i, j)] = v;
                P[(j, i)] = v;
            }
        }
        Some(P)
    }
}

impl<K> Rts<K> {
    /// The backward pass over all recorded steps in square-root form: the same means and
    /// covariances as [`Rts::smooth`] to round-off where both apply, with each covariance as
    /// a triangular factor, PSD by construction.
    ///
    /// At step k the record holds the joint covariance of `(x_{k+1}, x_k)` given `z_0..z_k`,
    /// `[[P_{k+1|k}, C_kᵀ], [C_k, P_{k|k}]]`. Its lower Cholesky factor `[[L₁₁, 0], [L₂₁, L₂₂]]`
    /// holds the whole step: `J_k = L₂₁ L₁₁⁻¹` (since `C_k = L₂₁ L₁₁ᵀ` and `P_{k+1|k} = L₁₁
    /// L₁₁ᵀ`), and `L₂₂ L₂₂ᵀ = P_{k|k} − J_k P_{k+1|k} J_kᵀ`, the covariance of x_k given
    /// x_{k+1} (a Schur complement, PSD when the joint is). So
    ///
    /// `x_{k|N} = x_{k|k} + L₂₁ L₁₁⁻¹ (x_{k+1|N} − x_{k+1|k})`,
    /// `S_{k|N} = tria([L₂₂, L₂₁ L₁₁⁻¹ S_{k+1|N}])`,
    ///
    /// with `tria` the lower factor of a QR decomposition of the transpose (`A Aᵀ = S Sᵀ`,
    /// diagonal made nonnegative) and `S_{N−1|N} = chol(P_{N−1|N−1})`: the covariance form's
    /// recursion rewritten through the Schur-complement identity above, over any recorded
    /// forward pass — the linear filter, the EKF or the (square-root) UKF — so the unscented
    /// RTS smoother runs in square-root form too. A semidefinite joint (a noise-free
    /// component) takes zero pivots: their columns of the factor are zero and the solve gives
    /// those components zero weight, the minimum-norm choice.
    ///
    /// # Errors
    /// [`Error::Dimension`] if nothing was recorded or the steps' states are stored
    /// points of a manifold; [`Error::NotPositiveSemidefinite`]
    /// naming `P_{N|N}` or the joint covariance of a step whose record is not positive
    /// semidefinite (a forward pass whose P_{k+1|k} and C_k are inconsistent);
    /// [`Error::Diverged`] naming the step if a smoothed mean or factor is not finite.
    ///
    /// # Example
    /// ```
    /// use kalman::smoother::RtsSmoother;
    /// use kalman::{CovarianceForm, DynDims, Filter, Model};
    ///
    /// // A random walk, q = r = 1, prior N(0, 1), measured as 1 and 3: the batch solution is
    /// // x = (1, 2), with P_{0|1} = 2/5 (the inverse of the information [[3, −1], [−1, 2]]).
    /// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]])?;
    /// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
    /// let mut rts = RtsSmoother::new();
    /// for z in [1.0, 3.0] {
    ///     filter.step(&[z], None)?;
    ///     rts.record(&filter)?;
    /// }
    /// let s = rts.smooth_sqrt()?;
    /// assert!((s.means[(0, 0)] - 1.0).abs() < 1e-14 && (s.means[(0, 1)] - 2.0).abs() < 1e-14);
    /// assert!((s.factors[0][(0, 0)].powi(2) - 0.4).abs() < 1e-14);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn smooth_sqrt(&self) -> Result<SqrtSmoothed, Error> {
        let (n, N) = (self.n, self.steps);
        self.require_steps()?;
        if self.is_stored() {
            return Err(Error::Dimension {
                name: "stored",
                value: self.stored,
                rule: "the square-root pass smooths vector states; a manifold's: smooth_on",
            });
        }
        let (nn, w) = (n * n, 2 * n);
        let mut means = Mat::<f64>::zeros(n, N);
        let mut factors = vec![Mat::<f64>::zeros(n, n); N];
        let (mut L, mut inv) = (vec![0.0; w * w], vec![0.0; w]);
        let last = N - 1;
        psd_cholesky(
            &self.pf[last * nn..(last + 1) * nn],
            n,
            &mut L,
            &mut inv,
            RANK_TOL,
            PSD_TOL,
        )
        .map_err(|pivot| not_psd("P_{N|N}", n, pivot))?;
        factors[last] = Mat::from_fn(n, n, |i, j| L[i + j * n]);
        for i in 0..n {
            means[(i, last)] = self.xf[last * n + i];
        }
        check(last, &means, &factors[last])?;
        let mut joint = vec![0.0; w * w];
        let (mut l11, mut dx, mut col) = (vec![0.0; nn], vec![0.0; n], vec![0.0; n]);
        // Aᵀ for A = [L₂₂, L₂₁ L₁₁⁻¹ S_{k+1|N}] (n × 2n): every entry is written each step.
        let mut At = Mat::<f64>::zeros(w, n);
        for k in (0..last).rev() {
            let (pp, ct, pf) = (
                &self.pp[k * nn..(k + 1) * nn],
                &self.ct[k * nn..(k + 1) * nn],
                &self.pf[k * nn..(k + 1) * nn],
            );
            // [[P_{k+1|k}, C_kᵀ], [C_k, P_{k|k}]] (C_k = cov(x_k, x_{k+1}): rows x_k).
            for j in 0..n {
                for i in 0..n {
                    joint[i + j * w] = pp[i + j * n];
                    joint[n + i + j * w] = ct[i + j * n];
                    joint[i + (n + j) * w] = ct[j + i * n];
                    joint[n + i + (n + j) * w] = pf[i + j * n];
                }
            }
            psd_cholesky(&joint, w, &mut L, &mut inv, RANK_TOL, PSD_TOL)
                .map_err(|pivot| not_psd("[[P_{k+1|k}, C_k^T], [C_k, P_{k|k}]]", w, pivot))?;
            for j in 0..n {
                for i in 0..n {
                    l11[i + j * n] = L[i + j * w];
                }
            }
            let L21 = |i: usize, j: usize| L[n + i + j * w];
            // x_{k|N} = x_{k|k} + L₂₁ L₁₁⁻¹ (x_{k+1|N} − x_{k+1|k}).
            for i in 0..n {
                dx[i] = means[(i, k + 1)] - self.xp[k * n + i];
            }
            forward(&l11, &inv[..n], n, &mut dx);
            for i in 0..n {
                let s: f64 = (0..n).map(|j| L21(i, j) * dx[j]).sum();
                means[(i, k)] = self.xf[k * n + i] + s;
            }
            // Aᵀ, then S = tria(A).
            for i in 0..n {
                for j in 0..n {
                    At[(j, i)] = L[n + i + (n + j) * w];
                }
            }
            for j in 0..n {
                for (i, c) in col.iter_mut().enumerate() {
                    *c = factors[k + 1][(i, j)];
                }
                forward(&l11, &inv[..n], n, &mut col);
                for i in 0..n {
                    At[(n + j, i)] = (0..n).map(|l| L21(i, l) * col[l]).sum();
                }
            }
            factors[k] = tria(&At);
            check(k, &means, &factors[k])?;
        }
        Ok(SqrtSmoothed { means, factors })
    }
}

/// The lower factor `S` (n×n, nonnegative diagonal) with `S Sᵀ = A Aᵀ`, from the QR
/// decomposition `Aᵀ = Q R` (`S = Rᵀ`) of the given `Aᵀ` (at least n rows).
fn tria(At: &Mat<f64>) -> Mat<f64> {
    let R = At.qr().thin_R().to_owned();
    let n = R.ncols();
    Mat::from_fn(n, n, |i, j| {
        if i < j {
            0.0
        } else {
            // Column j of S is row j of R, its sign made that of a nonnegative diagonal.
            R[(j, i)] * if R[(j, j)] < 0.0 { -1.0 } else { 1.0 }
        }
    })
}

/// [`Error::NotPositiveSemidefinite`] for a factorisation that met the negative `pivot`.
fn not_psd(name: &'static str, n: usize, pivot: f64) -> Error {
    Error::NotPositiveSemidefinite {
        name,
        n,
        min_eigenvalue: pivot,
        tol: PSD_TOL,
    }
}

/// [`Error::Diverged`] naming step `k` if its smoothed mean or factor is not finite.
fn check(k: usize, means: &Mat<f64>, S: &Mat<f64>) -> Result<(), Error> {
    let n = S.nrows();
    smoothed_finite(
        k,
        (0..n).map(|i| means[(i, k)]),
        ("S_{k|N}", S.col_iter().flat_map(|c| c.iter().copied())),
    )
}
