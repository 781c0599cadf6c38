//! The smoother's solve with a symmetric PSD matrix, through Cholesky of its Jacobi
//! scaling or, when that is singular, the pseudo-inverse.
#![allow(non_snake_case)]

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::reborrow::ReborrowMut;
use faer::{Mat, MatMut, MatRef, Par, Side};

use crate::{Error, RANK_TOL};

/// Solves A X = B for symmetric PSD A. The solve runs on the Jacobi-scaled system
/// `(D⁻¹ A D⁻¹)(D X) = D⁻¹ B`, `D = diag(√A_ii)` (1 where `A_ii = 0`), so that its rank test
/// reads correlations, not units: a state known to 1e-6 rad/s beside one known to 10 m is
/// not a linear dependence. Cholesky of the scaled matrix, or, when it is (numerically)
/// singular, its pseudo-inverse through the eigen-decomposition, which gives a generalised
/// inverse of A (the same X as A⁺B whenever B's columns lie in A's range, as the RTS
/// smoother's `C_kᵀ` do).
#[cfg(test)]
pub(crate) fn solve_psd(A: MatRef<'_, f64>, B: MatRef<'_, f64>) -> Result<Mat<f64>, Error> {
    let mut X = Mat::zeros(A.nrows(), B.ncols());
    PsdSolve::new(A.nrows()).solve(A, B, X.as_mut())?;
    Ok(X)
}

/// The workspaces of [`solve_psd`] for one order n, so that a backward pass solves with
/// them at every step without allocating (the singular fallback through the
/// eigen-decomposition still allocates).
pub(crate) struct PsdSolve {
    d: Vec<f64>,
    S: Mat<f64>,
    L: Mat<f64>,
    buf: MemBuffer,
}

impl PsdSolve {
    pub(crate) fn new(n: usize) -> Self {
        let req = llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default());
        Self {
            d: vec![0.0; n],
            S: Mat::zeros(n, n),
            L: Mat::zeros(n, n),
            buf: MemBuffer::new(req),
        }
    }

    /// `X = A⁺ B` as [`solve_psd`], into `X` (n × B.ncols()).
    pub(crate) fn solve(
        &mut self,
        A: MatRef<'_, f64>,
        B: MatRef<'_, f64>,
        mut X: MatMut<'_, f64>,
    ) -> Result<(), Error> {
        let n = A.nrows();
        let d = &mut self.d;
        for (i, di) in d.iter_mut().enumerate() {
            *di = if A[(i, i)] > 0.0 {
                A[(i, i)].sqrt()
            } else {
                1.0
            };
        }
        for j in 0..n {
            for i in 0..n {
                self.S[(i, j)] = A[(i, j)] / (d[i] * d[j]);
            }
        }
        for j in 0..B.ncols() {
            for i in 0..n {
                X[(i, j)] = B[(i, j)] / d[i];
            }
        }
        let stack = MemStack::new(&mut self.buf);
        solve_psd_scaled(self.S.as_ref(), self.L.as_mut(), X.rb_mut(), stack)?;
        for j in 0..X.ncols() {
            for i in 0..n {
                X[(i, j)] /= d[i];
            }
        }
        Ok(())
    }
}

/// Overwrites B with the solution of S X = B for a Jacobi-scaled PSD S (unit or zero
/// diagonal): Cholesky when every pivot² exceeds `RANK_TOL` (the eigen route gives the same
/// solution to round-off, only slower), else the pseudo-inverse with eigenvalues at or
/// below `RANK_TOL·λ_max` treated as zero.
fn solve_psd_scaled(
    S: MatRef<'_, f64>,
    mut L: MatMut<'_, f64>,
    mut B: MatMut<'_, f64>,
    stack: &mut MemStack,
) -> Result<(), Error> {
    let n = S.nrows();
    let smax = (0..n).map(|i| S[(i, i)].abs()).fold(0.0, f64::max);
    L.copy_from(S);
    let factored = llt::factor::cholesky_in_place(
        L.rb_mut(),
        Default::default(),
        Par::Seq,
        stack,
        Default::default(),
    );
    if factored.is_ok() {
        let dmin = (0..n)
            .map(|i| L[(i, i)] * L[(i, i)])
            .fold(f64::INFINITY, f64::min);
        if dmin > RANK_TOL * smax {
            llt::solve::solve_in_place(L.as_ref(), B, Par::Seq, stack);
            return Ok(());
        }
    }
    let evd = S
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| Error::Factorisation {
            name: "P_{k+1|k}",
            reason: "symmetric eigen-decomposition failed in the smoother's singular fallback",
        })?;
    let U = evd.U();
    let s = evd.S().column_vector();
    let lmax = (0..n).map(|i| s[i].abs()).fold(0.0, f64::max);
    let mut UtB = U.transpose() * B.as_ref();
    for i in 0..n {
        let inv = if s[i] > RANK_TOL * lmax {
            1.0 / s[i]
        } else {
            0.0
        };
        for j in 0..UtB.ncols() {
            UtB[(i, j)] *= inv;
        }
    }
    B.copy_from(U * UtB);
    Ok(())
}
