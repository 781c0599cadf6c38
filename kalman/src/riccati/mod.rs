//! Steady-state Riccati equations: the filter DARE and the discrete LQR (its dual) by the
//! structured doubling algorithm (SDA), the CARE and continuous LQR by SDA after a Cayley
//! transform, each with a PBH detectability / stabilisability check and a residual check.
//! All four are one builder, [`Riccati`], for a kind of [`Equation`]: [`Dare`], [`Dlqr`],
//! [`Care`] and [`Clqr`] are its aliases, called alike (`new`, optionally the cross term and
//! `options`, then `solve` or `residual`); an LQR is solved as the filter equation of its
//! dual.
//!
//! Notation as in the crate doc: the discrete model x_{k+1} = F x_k + w_k, z_k = H x_k + v_k,
//! cov(w) = Q, cov(v) = R, E[w_k v_kᵀ] = S. The steady-state *prior* covariance P solves the
//! filter DARE
//!
//! P = F P Fᵀ + Q − (F P Hᵀ + S)(H P Hᵀ + R)⁻¹(F P Hᵀ + S)ᵀ.
//!
//! Method. With F̃ = F − S R⁻¹ H and Q̃ = Q − S R⁻¹ Sᵀ the equation has no cross term; it is
//! the control-form DARE X = AᵀXA − AᵀXB(R + BᵀXB)⁻¹BᵀXA + Q with A = F̃ᵀ, B = Hᵀ, solved
//! by the SDA of Chu, Fan, Lin & Wang (2004): A₀ = A, G₀ = B R⁻¹ Bᵀ, H₀ = Q,
//! W = I + G_k H_k, A_{k+1} = A_k W⁻¹ A_k, G_{k+1} = G_k + A_k W⁻¹ G_k A_kᵀ,
//! H_{k+1} = H_k + A_kᵀ H_k W⁻¹ A_k; H_k → X quadratically. W⁻¹ is never formed: each
//! product is an LU solve. The CARE is mapped to the same iteration by the Cayley transform
//! (ℋ + γI)(ℋ − γI)⁻¹ of its Hamiltonian (derivation in [`Care`]).
//!
//! Checks. Before iterating, the PBH rank test rejects an undetectable mode on or outside
//! the stability boundary (|λ| ≥ 1 − 10⁻⁶ discrete, Re λ ≥ −10⁻⁶·max(1, |λ|) continuous)
//! and, for the discrete equations, an unreachable (noise) mode *on* the unit circle
//! (||λ| − 1| ≤ 10⁻⁶): the stabilising solution exists exactly when neither occurs. An
//! unreachable mode outside the circle is stabilised by the gain; the doubling is then
//! restarted from Q̃ + δI and polished by Newton's method (see [`Dare`]). The CARE keeps
//! the stricter test (no unreachable mode with Re λ ≥ −10⁻⁶·max(1, |λ|)); a mode is "unseen" when the smallest singular value
//! of [λI − F; C] (C scaled to ‖F‖) is below `pbh_tolerance`·max(1, ‖F‖). After iterating,
//! the relative residual ‖Res‖_F / ‖P‖_F must be within `residual_floor_factor` (100) times
//! the residual's round-off floor (see [`RiccatiOptions`]) and the closed loop must be
//! stable, or a typed [`Error`] says which check failed. Every loop is capped (doubling
//! steps, Newton steps, Smith squarings, QR sweeps), so a solve returns or fails in bounded
//! time. The CARE needs R positive definite; the DARE only H P Hᵀ + R (R + BᵀXB) at the
//! solution: a singular R is handled by shifting the unknown (see [`Dare`]).
#![allow(non_snake_case)]

mod builder;
mod care;
mod checks;
mod dare;
mod problem;
mod sda;
#[cfg(test)]
mod tests;

use faer::linalg::solvers::{Llt, Solve};
use faer::{Mat, MatRef, Side};

use crate::Error;

pub use builder::{
    Care, Clqr, Dare, Dlqr, Equation, FilterCare, FilterDare, LqrCare, LqrDare, Riccati,
};

/// Tuning and tolerances of the Riccati solvers, given to any of them by `.options(…)`.
/// `Default` is right for almost every use.
///
/// # Example
/// ```
/// use kalman::riccati::{Dare, RiccatiOptions};
///
/// let opts = RiccatiOptions { max_iterations: 200, ..RiccatiOptions::default() };
/// let ss = Dare::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?.options(opts).solve()?;
/// assert!(ss.relative_residual < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RiccatiOptions {
    /// Maximum number of doubling steps (each squares the convergence factor). Default 100.
    pub max_iterations: usize,
    /// Stop when ‖X_{k+1} − X_k‖_F ≤ `tolerance`·‖X_{k+1}‖_F. Default 1e-14.
    pub tolerance: f64,
    /// An optional absolute cap on the relative residual ‖residual‖_F / ‖X‖_F, on top of
    /// the floor-relative gate of `residual_floor_factor`. Default +∞ (no cap): the gate
    /// that scales with the problem is the one that decides.
    pub residual_tolerance: f64,
    /// Accept the solution only if its relative residual is at most this multiple of the
    /// residual's round-off floor: the relative residual that rounding the exact solution
    /// to double precision can cause, ε·(Σ of the norms of the equation's terms)/‖X‖_F
    /// (for the CARE ε·(2‖A‖‖X‖ + ‖G‖‖X‖² + ‖Q‖)/‖X‖ with G = Hᵀ R⁻¹ H, for the DARE
    /// ε·(‖F‖²‖X‖ + ‖X‖ + ‖Q‖ + 2(‖F‖‖X‖‖H‖ + ‖S‖)‖K‖ + ‖K‖²‖Σ‖)/‖X‖ with
    /// K = (F X Hᵀ + S) Σ⁻¹, Frobenius norms). A
    /// well-conditioned problem has a floor near ε and must be solved to near round-off; a
    /// hard one (CAREX #17, floor 5·10⁻⁷) is accepted at the best residual its
    /// conditioning allows. This is the normwise backward error of the answer (the
    /// residual over the equation's term sizes, as in Sun's backward error of the
    /// Riccati equations) bounded by `residual_floor_factor`·ε; the answer itself is
    /// refined by Newton's method until rounding stalls it, so the gate refuses only a
    /// solve that went wrong. Default 100.
    pub residual_floor_factor: f64,
    /// PBH rank threshold relative to max(1, ‖F‖_F). Default 1e-7.
    pub pbh_tolerance: f64,
    /// Modes within this distance inside the stability boundary count as marginal (and are
    /// PBH-tested). Default 1e-6.
    pub marginal_margin: f64,
}

impl Default for RiccatiOptions {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-14,
            residual_tolerance: f64::INFINITY,
            residual_floor_factor: 100.0,
            pbh_tolerance: 1e-7,
            marginal_margin: 1e-6,
        }
    }
}

/// Steady state of the discrete Kalman filter (solution of the filter DARE).
///
/// # Example
/// ```
/// use kalman::riccati::SteadyState;
/// use kalman::{DynDims, Model};
///
/// // The steady state of an engine model: random walk, q = 1, r = 1.
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]])?;
/// let ss = SteadyState::of(&model)?;
/// let p = (1.0 + 5f64.sqrt()) / 2.0; // the golden ratio
/// assert!((ss.prior[(0, 0)] - p).abs() < 1e-12);
/// assert!((ss.posterior[(0, 0)] - p / (p + 1.0)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
///
/// `M` is the matrix type: faer's `Mat<f64>` as returned, nalgebra's `DMatrix<f64>` after
/// `.to_nalgebra()` (feature `nalgebra`).
#[derive(Debug, Clone)]
pub struct SteadyState<M = Mat<f64>> {
    /// Steady-state prior covariance P = lim P_{k|k−1} (n×n), the DARE solution.
    pub prior: M,
    /// Steady-state posterior covariance P_{k|k} = P − K Σ Kᵀ (n×n).
    pub posterior: M,
    /// Filter (update) gain K = P Hᵀ Σ⁻¹ (n×m): x_{k|k} = x_{k|k−1} + K (z_k − H x_{k|k−1}).
    pub gain: M,
    /// One-step predictor gain K_p = (F P Hᵀ + S) Σ⁻¹ (n×m):
    /// x_{k+1|k} = F x_{k|k−1} + B u_k + K_p (z_k − H x_{k|k−1}).
    pub predictor_gain: M,
    /// Steady-state innovation covariance Σ = H P Hᵀ + R (m×m).
    pub innovation_cov: M,
    /// Doubling steps used.
    pub iterations: usize,
    /// ‖DARE residual‖_F / ‖P‖_F (0 when P = 0).
    pub relative_residual: f64,
}

/// Discrete-time LQR solution: cost matrix X and gain L with u_k = −L x_k.
///
/// # Example
/// ```
/// use faer::mat;
///
/// // x_{k+1} = x_k + u_k with cost Σ x² + u²: X = (1 + √5)/2, L = X/(1 + X).
/// let one = mat![[1.0]];
/// let lqr = kalman::riccati::Dlqr::new(&one, &one, &one, &one)?.solve()?;
/// let x = (1.0 + 5f64.sqrt()) / 2.0;
/// assert!((lqr.cost[(0, 0)] - x).abs() < 1e-12 && (lqr.gain[(0, 0)] - x / (1.0 + x)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
///
/// `M` is the matrix type: faer's `Mat<f64>` as returned, nalgebra's `DMatrix<f64>` after
/// `.to_nalgebra()` (feature `nalgebra`).
#[derive(Debug, Clone)]
pub struct Lqr<M = Mat<f64>> {
    /// State-feedback gain L = (R + BᵀXB)⁻¹(BᵀXA + Nᵀ) (m×n) for discrete problems, or
    /// L = R⁻¹(BᵀX + Nᵀ) for continuous ones; the control is u = −L x.
    pub gain: M,
    /// Cost-to-go matrix X (n×n, symmetric PSD), the Riccati solution.
    pub cost: M,
    /// Doubling steps used.
    pub iterations: usize,
    /// ‖Riccati residual‖_F / ‖X‖_F.
    pub relative_residual: f64,
}

/// Steady state of the continuous Kalman–Bucy filter (solution of the filter CARE).
///
/// # Example
/// ```
/// use faer::mat;
///
/// // ẋ = −x + w, z = x + v, unit intensities: P = √2 − 1, K = P.
/// let (a, one) = (mat![[-1.0]], mat![[1.0]]);
/// let ss = kalman::riccati::Care::new(&a, &one, &one, &one)?.solve()?;
/// assert!((ss.gain[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
///
/// `M` is the matrix type: faer's `Mat<f64>` as returned, nalgebra's `DMatrix<f64>` after
/// `.to_nalgebra()` (feature `nalgebra`).
#[derive(Debug, Clone)]
pub struct ContinuousSteadyState<M = Mat<f64>> {
    /// P solving A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0 (n×n).
    pub covariance: M,
    /// Kalman–Bucy gain K = P Hᵀ R⁻¹ (n×m).
    pub gain: M,
    /// Doubling steps used.
    pub iterations: usize,
    /// ‖CARE residual‖_F / ‖P‖_F.
    pub relative_residual: f64,
}

#[derive(Debug, Clone, Copy)]
enum Pair {
    Detect(&'static str),
    Stab(&'static str),
}

impl Pair {
    fn error(&self, re: f64, im: f64) -> Error {
        match *self {
            Pair::Detect(pair) => Error::NotDetectable { pair, re, im },
            Pair::Stab(pair) => Error::NotStabilisable { pair, re, im },
        }
    }
}

/// `num/den` for two norms (`den ≥ 0`): 0 for a zero residual (also over a zero solution),
/// +∞ for a non-zero residual over a zero solution.
fn relative(num: f64, den: f64) -> f64 {
    if num == 0.0 { 0.0 } else { num / den }
}

/// Hᵀ R⁻¹ H from the Cholesky factor of R, symmetrised.
pub(crate) fn weighted_gram(H: MatRef<'_, f64>, r_llt: &Llt<f64>) -> Mat<f64> {
    let mut G = H.transpose() * r_llt.solve(H);
    symmetrise(&mut G);
    G
}

/// A symmetrised copy of `M`.
pub(crate) fn symmetrised(M: MatRef<'_, f64>) -> Mat<f64> {
    let mut S = M.to_owned();
    symmetrise(&mut S);
    S
}

/// The Cholesky factor of the positive definite `M` (its lower triangle), or
/// [`Error::NotPositiveDefinite`] naming it `name` with `rule` (what needs M⁻¹).
pub(crate) fn factor_pd(
    name: &'static str,
    M: MatRef<'_, f64>,
    rule: &'static str,
) -> Result<Llt<f64>, Error> {
    M.llt(Side::Lower).map_err(|_| Error::NotPositiveDefinite {
        name,
        n: M.nrows(),
        rule,
    })
}

pub(crate) fn all_finite(M: MatRef<'_, f64>) -> bool {
    (0..M.ncols()).all(|j| (0..M.nrows()).all(|i| M[(i, j)].is_finite()))
}

/// `M ← (M + Mᵀ)/2` for a square faer matrix, by the workspace's one symmetrisation
/// (`numerics::symmetrise`, on a column-major copy: a faer matrix's columns may be padded).
pub(crate) fn symmetrise(M: &mut Mat<f64>) {
    let n = M.nrows();
    let mut a: Vec<f64> = M.col_iter().flat_map(|c| c.iter().copied()).collect();
    numerics::symmetrise(&mut a, n);
    for j in 0..n {
        for i in 0..n {
            M[(i, j)] = a[i + j * n];
        }
    }
}

/// Spectral radius (discrete) or spectral abscissa (continuous) by the bounded QR
/// iteration of [`checks::eigenvalues`]; +∞ if it fails (the caller's check then refuses).
pub(crate) fn spectral(M: MatRef<'_, f64>, continuous: bool) -> f64 {
    match checks::eigenvalues(M, "closed loop") {
        Ok(e) if continuous => e.iter().map(|l| l.0).fold(f64::NEG_INFINITY, f64::max),
        Ok(e) => e.iter().map(|l| l.0.hypot(l.1)).fold(0.0, f64::max),
        Err(_) => f64::INFINITY,
    }
}
