//! Seeded random models shared by the topic modules.

use faer::Mat;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// A seeded generator.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// An r×c matrix of standard normal entries.
pub fn randn(rng: &mut ChaCha8Rng, r: usize, c: usize) -> Mat<f64> {
    Mat::from_fn(r, c, |_, _| rng.sample::<f64, _>(StandardNormal))
}

/// Spectral radius.
pub fn rho(M: &Mat<f64>) -> f64 {
    M.eigenvalues()
        .expect("eig")
        .iter()
        .map(|l| l.norm())
        .fold(0.0, f64::max)
}

/// A random n×n matrix scaled to spectral radius `r`.
pub fn with_radius(rng: &mut ChaCha8Rng, n: usize, r: f64) -> Mat<f64> {
    let A = randn(rng, n, n);
    let s = rho(&A).max(1e-3);
    A * (r / s)
}

/// Symmetric positive definite n×n: L Lᵀ + eps I.
pub fn spd(rng: &mut ChaCha8Rng, n: usize, eps: f64) -> Mat<f64> {
    let L = randn(rng, n, n);
    let mut P = &L * L.transpose() * (1.0 / n as f64);
    for i in 0..n {
        P[(i, i)] += eps;
    }
    sym(P)
}

/// (P + Pᵀ)/2.
pub fn sym(P: Mat<f64>) -> Mat<f64> {
    let Pt = P.transpose().to_owned();
    (P + Pt) * 0.5
}

/// Frobenius norm of A − B relative to max(‖B‖, tiny).
pub fn rel(A: &Mat<f64>, B: &Mat<f64>) -> f64 {
    (A - B).norm_l2() / B.norm_l2().max(1e-300)
}

/// Minimum eigenvalue of a symmetric matrix.
pub fn min_eig(P: &Mat<f64>) -> f64 {
    sym(P.clone())
        .self_adjoint_eigenvalues(faer::Side::Lower)
        .expect("eig")
        .into_iter()
        .fold(f64::INFINITY, f64::min)
}

/// A random joint noise covariance [[R, Sᵀ], [S, Q]] (positive definite): (Q, R, S).
pub fn joint_noise(rng: &mut ChaCha8Rng, n: usize, m: usize) -> (Mat<f64>, Mat<f64>, Mat<f64>) {
    let W = spd(rng, n + m, 0.2);
    let R = W.as_ref().submatrix(0, 0, m, m).to_owned();
    let S = W.as_ref().submatrix(m, 0, n, m).to_owned();
    let Q = W.as_ref().submatrix(m, m, n, n).to_owned();
    (Q, R, S)
}
