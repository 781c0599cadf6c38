//! Steady-state Riccati equations: the filter DARE and the discrete LQR (its dual) by the
//! structured doubling algorithm (SDA), the CARE and continuous LQR by SDA after a Cayley
//! transform, each with a PBH detectability / stabilisability check and a residual check.
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
//! (ℋ + γI)(ℋ − γI)⁻¹ of its Hamiltonian (derivation in [`care`]).
//!
//! Checks. Before iterating, the PBH rank test rejects an undetectable mode on or outside
//! the stability boundary (|λ| ≥ 1 − 10⁻⁶ discrete, Re λ ≥ −10⁻⁶·max(1, |λ|) continuous)
//! and, for the discrete equations, an unreachable (noise) mode *on* the unit circle
//! (||λ| − 1| ≤ 10⁻⁶): the stabilising solution exists exactly when neither occurs. An
//! unreachable mode outside the circle is stabilised by the gain; the doubling is then
//! restarted from Q̃ + δI and polished by Newton's method (see [`dare`]). The CARE keeps
//! the stricter test (no unreachable mode with Re λ ≥ −10⁻⁶·max(1, |λ|)); a mode is "unseen" when the smallest singular value
//! of [λI − F; C] (C scaled to ‖F‖) is below `pbh_tolerance`·max(1, ‖F‖). After iterating,
//! the relative residual ‖Res‖_F / ‖P‖_F must be below `residual_tolerance` (10⁻¹⁰) and the
//! closed loop must be stable, or a typed [`Error`] says which check failed. R must be
//! positive definite (the doubling needs R⁻¹); a singular R is rejected with
//! [`Error::NotPositiveDefinite`].
#![allow(non_snake_case)]

use faer::linalg::solvers::{Llt, Solve};
use faer::{Mat, MatRef, Side};

use crate::model::check;
use crate::storage::Dims;
use crate::{Error, Model};

/// Tuning and tolerances of the Riccati solvers. `Default` is right for almost every use.
///
/// # Example
/// ```
/// use faer::mat;
/// use kalman::riccati::{RiccatiOptions, dare_with};
///
/// let opts = RiccatiOptions { max_iterations: 200, ..RiccatiOptions::default() };
/// let one = mat![[1.0]];
/// let ss = dare_with(one.as_ref(), one.as_ref(), one.as_ref(), one.as_ref(), None, &opts)?;
/// assert!(ss.relative_residual < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RiccatiOptions {
    /// Maximum number of doubling steps (each squares the convergence factor). Default 100.
    pub max_iterations: usize,
    /// Stop when ‖X_{k+1} − X_k‖_F ≤ `tolerance`·‖X_{k+1}‖_F. Default 1e-14.
    pub tolerance: f64,
    /// Accept the solution only if ‖residual‖_F ≤ `residual_tolerance`·‖X‖_F. Default 1e-10.
    pub residual_tolerance: f64,
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
            residual_tolerance: 1e-10,
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
#[derive(Debug, Clone)]
pub struct SteadyState {
    /// Steady-state prior covariance P = lim P_{k|k−1} (n×n), the DARE solution.
    pub prior: Mat<f64>,
    /// Steady-state posterior covariance P_{k|k} = P − K Σ Kᵀ (n×n).
    pub posterior: Mat<f64>,
    /// Filter (update) gain K = P Hᵀ Σ⁻¹ (n×m): x_{k|k} = x_{k|k−1} + K (z_k − H x_{k|k−1}).
    pub gain: Mat<f64>,
    /// One-step predictor gain K_p = (F P Hᵀ + S) Σ⁻¹ (n×m):
    /// x_{k+1|k} = F x_{k|k−1} + B u_k + K_p (z_k − H x_{k|k−1}).
    pub predictor_gain: Mat<f64>,
    /// Steady-state innovation covariance Σ = H P Hᵀ + R (m×m).
    pub innovation_cov: Mat<f64>,
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
/// let lqr = kalman::riccati::dlqr(one.as_ref(), one.as_ref(), one.as_ref(), one.as_ref(), None)?;
/// let x = (1.0 + 5f64.sqrt()) / 2.0;
/// assert!((lqr.cost[(0, 0)] - x).abs() < 1e-12 && (lqr.gain[(0, 0)] - x / (1.0 + x)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Lqr {
    /// State-feedback gain L = (R + BᵀXB)⁻¹(BᵀXA + Nᵀ) (m×n) for discrete problems, or
    /// L = R⁻¹(BᵀX + Nᵀ) for continuous ones; the control is u = −L x.
    pub gain: Mat<f64>,
    /// Cost-to-go matrix X (n×n, symmetric PSD), the Riccati solution.
    pub cost: Mat<f64>,
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
/// let ss = kalman::riccati::care(a.as_ref(), one.as_ref(), one.as_ref(), one.as_ref())?;
/// assert!((ss.gain[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct ContinuousSteadyState {
    /// P solving A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0 (n×n).
    pub covariance: Mat<f64>,
    /// Kalman–Bucy gain K = P Hᵀ R⁻¹ (n×m).
    pub gain: Mat<f64>,
    /// Doubling steps used.
    pub iterations: usize,
    /// ‖CARE residual‖_F / ‖P‖_F.
    pub relative_residual: f64,
}

// ---------------------------------------------------------------------------------------
// Public entry points
// ---------------------------------------------------------------------------------------

/// Steady state of the discrete filter for (F, H, Q, R) and an optional cross-covariance S
/// (n×m, `None` = 0), with default [`RiccatiOptions`].
///
/// Errors: a shape or finiteness error naming the matrix; [`Error::NotPositiveDefinite`]
/// for R; [`Error::NotDetectable`] for (F, H); [`Error::NotStabilisable`] for a mode of
/// (F̃, Q̃^{1/2}) on the unit circle that the noise does not reach (F̃ = F − S R⁻¹ H,
/// Q̃ = Q − S R⁻¹ Sᵀ; plain (F, Q^{1/2}) when S = 0);
/// [`Error::RiccatiNoConvergence`] / [`Error::RiccatiCheck`] if the result fails.
///
/// ```
/// use faer::mat;
/// // Random walk observed in unit noise, q = 1: P = (1 + √5)/2, K = P/(P + 1).
/// let ss = kalman::riccati::dare(
///     mat![[1.0]].as_ref(), mat![[1.0]].as_ref(), mat![[1.0]].as_ref(), mat![[1.0]].as_ref(), None,
/// ).expect("must succeed");
/// let p = (1.0 + 5f64.sqrt()) / 2.0;
/// assert!((ss.prior[(0, 0)] - p).abs() < 1e-12);
/// assert!((ss.gain[(0, 0)] - p / (p + 1.0)).abs() < 1e-12);
/// ```
pub fn dare(
    F: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    S: Option<MatRef<'_, f64>>,
) -> Result<SteadyState, Error> {
    dare_with(F, H, Q, R, S, &RiccatiOptions::default())
}

impl SteadyState {
    /// The steady state of an engine [`Model`] (either storage path): [`dare`] on its F, H,
    /// Q, R and S.
    ///
    /// # Errors
    /// As [`dare`].
    pub fn of<D: Dims>(model: &Model<D>) -> Result<Self, Error> {
        dare(model.f(), model.h(), model.q(), model.r(), model.s())
    }
}

/// [`dare`] with explicit options.
pub fn dare_with(
    F: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    S: Option<MatRef<'_, f64>>,
    opts: &RiccatiOptions,
) -> Result<SteadyState, Error> {
    let n = F.nrows();
    let m = H.nrows();
    check("F", F, n, n)?;
    check("H", H, m, n)?;
    check("Q", Q, n, n)?;
    check("R", R, m, m)?;
    if let Some(S) = S {
        check("S", S, n, m)?;
    }
    let names = Names {
        equation: "filter DARE",
        detect: Pair::Detect("(F, H)"),
        stab: Pair::Stab(if S.is_some() {
            "(F - S R^-1 H, (Q - S R^-1 S^T)^{1/2})"
        } else {
            "(F, Q^{1/2})"
        }),
    };
    let sol = discrete_dual(F, H, Q, R, S, opts, &names)?;
    let P = sol.x;
    // Σ = H P Hᵀ + R; K = P Hᵀ Σ⁻¹; K_p = (F P Hᵀ + S) Σ⁻¹; all by Cholesky solves.
    let HP = H * &P;
    let mut Sigma = &HP * H.transpose() + R;
    symmetrise(&mut Sigma);
    let llt = Sigma
        .llt(Side::Lower)
        .map_err(|_| Error::NotPositiveDefinite {
            name: "H P H^T + R",
            n: m,
            rule: "the steady-state innovation covariance must be invertible",
        })?;
    let gain = llt.solve(&HP).transpose().to_owned();
    let mut FPHt_S = F * (&P * H.transpose());
    if let Some(S) = S {
        FPHt_S += S;
    }
    let predictor_gain = llt.solve(FPHt_S.transpose()).transpose().to_owned();
    let mut posterior = &P - &gain * &HP;
    symmetrise(&mut posterior);
    Ok(SteadyState {
        prior: P,
        posterior,
        gain,
        predictor_gain,
        innovation_cov: Sigma,
        iterations: sol.iterations,
        relative_residual: sol.relative_residual,
    })
}

/// Discrete-time LQR for x_{k+1} = A x_k + B u_k with cost Σ xᵀQx + uᵀRu + 2xᵀN u
/// (`N` = `None` for no cross weight): solves X = AᵀXA + Q − (AᵀXB + N)(R + BᵀXB)⁻¹(BᵀXA + Nᵀ)
/// by the dual filter DARE (F = Aᵀ, H = Bᵀ, S = N) and returns L with u = −L x.
///
/// Errors: [`Error::NotStabilisable`] for (A, B) (modes on or outside the unit circle),
/// [`Error::NotDetectable`] for (Q^{1/2}, A) (modes on the unit circle: an unobserved
/// unstable mode off the circle is stabilised by the gain), shape/finiteness/PD errors
/// naming the matrix.
///
/// The UAV loop of Gridnev, Rusetsky and Rak (state weight diag(1, 0.1), input weight 1,
/// Δt = 0.25):
/// ```
/// use faer::mat;
/// let dt = 0.25;
/// let a = mat![[1.0, dt], [0.0, 1.0]];
/// let b = mat![[dt * dt / 2.0], [dt]];
/// let q = mat![[1.0, 0.0], [0.0, 0.1]];
/// let r = mat![[1.0]];
/// let lqr = kalman::riccati::dlqr(a.as_ref(), b.as_ref(), q.as_ref(), r.as_ref(), None).expect("must succeed");
/// // The closed loop A − B L is stable.
/// let cl = &a - &b * &lqr.gain;
/// let rho = cl.eigenvalues().expect("must succeed").iter().map(|l| l.norm()).fold(0.0, f64::max);
/// assert!(rho < 1.0);
/// ```
pub fn dlqr(
    A: MatRef<'_, f64>,
    B: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    N: Option<MatRef<'_, f64>>,
) -> Result<Lqr, Error> {
    dlqr_with(A, B, Q, R, N, &RiccatiOptions::default())
}

/// [`dlqr`] with explicit options.
pub fn dlqr_with(
    A: MatRef<'_, f64>,
    B: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    N: Option<MatRef<'_, f64>>,
    opts: &RiccatiOptions,
) -> Result<Lqr, Error> {
    let n = A.nrows();
    let m = B.ncols();
    check("A", A, n, n)?;
    check("B", B, n, m)?;
    check("Q", Q, n, n)?;
    check("R", R, m, m)?;
    if let Some(N) = N {
        check("N", N, n, m)?;
    }
    let names = Names {
        equation: "LQR DARE",
        // Detectability of (Aᵀ, Bᵀ) is stabilisability of (A, B), and stabilisability of
        // (Aᵀ, Q^{1/2}) is detectability of (Q^{1/2}, A).
        detect: Pair::Stab("(A, B)"),
        stab: Pair::Detect(if N.is_some() {
            "((Q - N R^-1 N^T)^{1/2}, A - B R^-1 N^T)"
        } else {
            "(Q^{1/2}, A)"
        }),
    };
    let sol = discrete_dual(A.transpose(), B.transpose(), Q, R, N, opts, &names)?;
    let X = sol.x;
    let BtX = B.transpose() * &X;
    let mut Sigma = &BtX * B + R;
    symmetrise(&mut Sigma);
    let llt = Sigma
        .llt(Side::Lower)
        .map_err(|_| Error::NotPositiveDefinite {
            name: "R + B^T X B",
            n: m,
            rule: "the LQR gain needs its inverse",
        })?;
    let mut rhs = &BtX * A;
    if let Some(N) = N {
        rhs += N.transpose();
    }
    let gain = llt.solve(&rhs);
    Ok(Lqr {
        gain,
        cost: X,
        iterations: sol.iterations,
        relative_residual: sol.relative_residual,
    })
}

/// Steady state of the Kalman–Bucy filter: the stabilising P of the filter CARE
/// A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0, where `Q` is the n×n process-noise intensity as it
/// enters the state (G Q_w Gᵀ for a noise input matrix G and intensity Q_w), and the gain
/// K = P Hᵀ R⁻¹.
///
/// Method: the dual control-form CARE X A_c + A_cᵀ X − X G X + Q = 0 (A_c = Aᵀ,
/// G = Hᵀ R⁻¹ H) has Hamiltonian ℋ = [[A_c, −G], [−Q, −A_cᵀ]]. With γ > ρ(ℋ) the Cayley
/// map (ℋ + γI)(ℋ − γI)⁻¹ sends its stable eigenvalues inside the unit circle, and the pencil
/// (ℋ + γI) − μ(ℋ − γI) is brought to the standard symplectic form of the SDA with
/// A_γ = A_c − γI, V = A_γ + G A_γ⁻ᵀ Q: A₀ = I + 2γV⁻¹, G₀ = 2γ V⁻¹ G A_γ⁻ᵀ,
/// H₀ = 2γ V⁻ᵀ Q A_γ⁻¹; the doubling then converges to X = P.
///
/// Errors as [`dare`] with the continuous stability boundary (Re λ ≥ 0).
///
/// ```
/// use faer::mat;
/// // ẋ = −x + w, z = x + v, q = r = 1: −2P − P² + 1 = 0, P = √2 − 1.
/// let ss = kalman::riccati::care(
///     mat![[-1.0]].as_ref(), mat![[1.0]].as_ref(), mat![[1.0]].as_ref(), mat![[1.0]].as_ref(),
/// ).expect("must succeed");
/// assert!((ss.covariance[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-12);
/// ```
pub fn care(
    A: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
) -> Result<ContinuousSteadyState, Error> {
    care_with(A, H, Q, R, &RiccatiOptions::default())
}

/// [`care`] with explicit options.
pub fn care_with(
    A: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    opts: &RiccatiOptions,
) -> Result<ContinuousSteadyState, Error> {
    let n = A.nrows();
    let m = H.nrows();
    check("A", A, n, n)?;
    check("H", H, m, n)?;
    check("Q", Q, n, n)?;
    check("R", R, m, m)?;
    let names = Names {
        equation: "filter CARE",
        detect: Pair::Detect("(A, H)"),
        stab: Pair::Stab("(A, Q^{1/2})"),
    };
    let sol = continuous_dual(A, H, Q, R, opts, &names)?;
    let P = sol.x;
    let llt = factor_r(R, "the Riccati solvers need R^-1")?;
    let gain = llt.solve(H * &P).transpose().to_owned();
    Ok(ContinuousSteadyState {
        covariance: P,
        gain,
        iterations: sol.iterations,
        relative_residual: sol.relative_residual,
    })
}

/// Continuous-time LQR for ẋ = A x + B u with cost ∫ xᵀQx + uᵀRu: solves
/// X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q = 0 and returns L = R⁻¹ Bᵀ X (u = −L x).
///
/// Errors: [`Error::NotStabilisable`] for (A, B), [`Error::NotDetectable`] for (Q^{1/2}, A)
/// (modes with Re λ ≥ 0), shape/finiteness/PD errors naming the matrix.
///
/// # Example
/// ```
/// use faer::mat;
///
/// // ẋ = u, cost ∫ x² + u²: X = 1, L = 1.
/// let (a, one) = (mat![[0.0]], mat![[1.0]]);
/// let lqr = kalman::riccati::clqr(a.as_ref(), one.as_ref(), one.as_ref(), one.as_ref())?;
/// assert!((lqr.gain[(0, 0)] - 1.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub fn clqr(
    A: MatRef<'_, f64>,
    B: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
) -> Result<Lqr, Error> {
    let n = A.nrows();
    let m = B.ncols();
    check("A", A, n, n)?;
    check("B", B, n, m)?;
    check("Q", Q, n, n)?;
    check("R", R, m, m)?;
    let names = Names {
        equation: "LQR CARE",
        detect: Pair::Stab("(A, B)"),
        stab: Pair::Detect("(Q^{1/2}, A)"),
    };
    let opts = RiccatiOptions::default();
    let sol = continuous_dual(A.transpose(), B.transpose(), Q, R, &opts, &names)?;
    let llt = factor_r(R, "the Riccati solvers need R^-1")?;
    let gain = llt.solve(B.transpose() * &sol.x);
    Ok(Lqr {
        gain,
        cost: sol.x,
        iterations: sol.iterations,
        relative_residual: sol.relative_residual,
    })
}

/// Relative residual ‖F P Fᵀ + Q − (F P Hᵀ + S)(H P Hᵀ + R)⁻¹(⋯)ᵀ − P‖_F / ‖P‖_F of a
/// candidate filter-DARE solution (0 when both the residual and P vanish). Used by the
/// solvers' own check and by tests.
pub fn dare_residual(
    F: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    S: Option<MatRef<'_, f64>>,
    P: MatRef<'_, f64>,
) -> f64 {
    match dare_residual_matrix(F, H, Q, R, S, P) {
        Some(res) => relative(res.norm_l2(), P.norm_l2()),
        None => f64::INFINITY,
    }
}

/// The DARE residual matrix F P Fᵀ + Q − (F P Hᵀ + S) Σ⁻¹ (⋯)ᵀ − P (`None` if Σ is not
/// positive definite).
fn dare_residual_matrix(
    F: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    S: Option<MatRef<'_, f64>>,
    P: MatRef<'_, f64>,
) -> Option<Mat<f64>> {
    let mut Sigma = H * P * H.transpose() + R;
    symmetrise(&mut Sigma);
    let mut C = F * P * H.transpose();
    if let Some(S) = S {
        C += S;
    }
    let llt = Sigma.llt(Side::Lower).ok()?;
    let corr = &C * llt.solve(C.transpose());
    let mut res = F * P * F.transpose() + Q - corr - P;
    symmetrise(&mut res);
    Some(res)
}

/// One Newton (Hewer) correction of a DARE solution: with the closed loop
/// A_cl = F − K_p H, the correction E solves the Stein equation E − A_cl E A_clᵀ = Res(P),
/// here by Smith's doubling E = Σ_k A_cl^k Res (A_clᵀ)^k (squaring A_cl each step). Returns
/// `None` if the closed loop is not contractive enough for the doubling to converge.
fn newton_polish(
    F: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    S: Option<MatRef<'_, f64>>,
    P: &Mat<f64>,
) -> Option<Mat<f64>> {
    let res = dare_residual_matrix(F, H, Q, R, S, P.as_ref())?;
    let mut Sigma = H * P * H.transpose() + R;
    symmetrise(&mut Sigma);
    let llt = Sigma.llt(Side::Lower).ok()?;
    let mut C = F * (P * H.transpose());
    if let Some(S) = S {
        C += S;
    }
    let Kp = llt.solve(C.transpose()).transpose().to_owned();
    let mut T = F - &Kp * H;
    let mut E = res;
    for _ in 0..64 {
        let mut E_next = &E + &T * &E * T.transpose();
        symmetrise(&mut E_next);
        let change = (&E_next - &E).norm_l2();
        E = E_next;
        T = &T * &T;
        if !all_finite(T.as_ref()) || !all_finite(E.as_ref()) {
            return None;
        }
        if change <= f64::EPSILON * E.norm_l2() || T.norm_l2() <= f64::EPSILON {
            let mut Pn = P + &E;
            symmetrise(&mut Pn);
            return Some(Pn);
        }
    }
    None
}

/// Relative residual ‖A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q‖_F / ‖P‖_F of a candidate filter-CARE
/// solution.
pub fn care_residual(
    A: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    P: MatRef<'_, f64>,
) -> f64 {
    let HP = H * P;
    let corr = match R.llt(Side::Lower) {
        Ok(llt) => HP.transpose() * llt.solve(&HP),
        Err(_) => return f64::INFINITY,
    };
    let res = A * P + P * A.transpose() - corr + Q;
    relative(res.norm_l2(), P.norm_l2())
}

// ---------------------------------------------------------------------------------------
// Internals
// ---------------------------------------------------------------------------------------

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

/// Error labels: `detect` is reported when the (F, H)-like pair of the filter form fails,
/// `stab` when the (F, Q^{1/2})-like pair fails.
struct Names {
    equation: &'static str,
    detect: Pair,
    stab: Pair,
}

struct Solved {
    x: Mat<f64>,
    iterations: usize,
    relative_residual: f64,
}

fn relative(num: f64, den: f64) -> f64 {
    if num == 0.0 {
        0.0
    } else if den > 0.0 {
        num / den
    } else {
        f64::INFINITY
    }
}

/// The Cholesky factor of the positive definite `R`, or [`Error::NotPositiveDefinite`]
/// naming R with `rule` (what needs R⁻¹).
pub(crate) fn factor_r(R: MatRef<'_, f64>, rule: &'static str) -> Result<Llt<f64>, Error> {
    R.llt(Side::Lower).map_err(|_| Error::NotPositiveDefinite {
        name: "R",
        n: R.nrows(),
        rule,
    })
}

pub(crate) fn all_finite(M: MatRef<'_, f64>) -> bool {
    (0..M.ncols()).all(|j| (0..M.nrows()).all(|i| M[(i, j)].is_finite()))
}

pub(crate) fn symmetrise(M: &mut Mat<f64>) {
    let n = M.nrows();
    for j in 0..n {
        for i in j + 1..n {
            let v = 0.5 * (M[(i, j)] + M[(j, i)]);
            M[(i, j)] = v;
            M[(j, i)] = v;
        }
    }
}

/// Symmetric PSD square root (negative eigenvalues from rounding clamped to 0).
fn psd_sqrt(Q: MatRef<'_, f64>) -> Result<Mat<f64>, Error> {
    let mut Qs = Q.to_owned();
    symmetrise(&mut Qs);
    let evd = Qs
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| Error::RiccatiNoConvergence {
            equation: "Q^{1/2}",
            iterations: 0,
            reason: "symmetric eigendecomposition failed",
        })?;
    let U = evd.U();
    let s = evd.S().column_vector();
    let n = Qs.nrows();
    let mut US = U.to_owned();
    for j in 0..n {
        let r = s[j].max(0.0).sqrt();
        for i in 0..n {
            US[(i, j)] *= r;
        }
    }
    Ok(&US * U.transpose())
}

/// Which eigenvalues a PBH test looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Modes {
    /// On or outside the stability boundary: what detectability needs.
    OnOrOutside,
    /// On the boundary only: what the existence of a stabilising solution needs of the
    /// noise (or state-weight) pair.
    On,
}

/// Eigenvalues of F on (or outside) the stability boundary, within `margin`: |λ| ≥ 1 − margin
/// (|1 − |λ|| ≤ margin for [`Modes::On`]) discrete, Re λ ≥ −margin·max(1, |λ|)
/// (|Re λ| ≤ margin·max(1, |λ|)) continuous; one of each conjugate pair.
fn marginal_modes(
    F: MatRef<'_, f64>,
    continuous: bool,
    which: Modes,
    opts: &RiccatiOptions,
) -> Result<Vec<(f64, f64)>, Error> {
    if F.nrows() == 0 {
        return Ok(Vec::new());
    }
    let eig = F.eigenvalues().map_err(|_| Error::RiccatiNoConvergence {
        equation: "PBH test",
        iterations: 0,
        reason: "eigenvalue computation failed",
    })?;
    let margin = opts.marginal_margin;
    Ok(eig
        .into_iter()
        .filter(|l| l.im >= 0.0)
        .filter(|l| {
            let modulus = l.norm();
            match (continuous, which) {
                (true, Modes::OnOrOutside) => l.re >= -margin * modulus.max(1.0),
                (true, Modes::On) => l.re.abs() <= margin * modulus.max(1.0),
                (false, Modes::OnOrOutside) => modulus >= 1.0 - margin,
                (false, Modes::On) => (modulus - 1.0).abs() <= margin,
            }
        })
        .map(|l| (l.re, l.im))
        .collect())
}

/// PBH test: returns the first of the (marginal or unstable) `modes` of F whose
/// eigenvector C does not see, i.e. σ_min([λI − F; C]) small. C (p×n) is rescaled to ‖F‖_F
/// so the test does not depend on the units of the output.
fn pbh(
    F: MatRef<'_, f64>,
    C: MatRef<'_, f64>,
    modes: &[(f64, f64)],
    opts: &RiccatiOptions,
) -> Result<Option<(f64, f64)>, Error> {
    let n = F.nrows();
    let p = C.nrows();
    let fnorm = F.norm_l2();
    let scale = fnorm.max(1.0);
    let cnorm = C.norm_l2();
    let cscale = if cnorm > 0.0 { scale / cnorm } else { 0.0 };
    for &(re, im) in modes {
        // Real embedding of the complex matrix M = [λI − F; C]: [[Re M, −Im M], [Im M, Re M]]
        // has the singular values of M, each twice.
        let complex = im > 0.0;
        let (rows, cols) = if complex {
            (2 * (n + p), 2 * n)
        } else {
            (n + p, n)
        };
        let mut M = Mat::<f64>::zeros(rows, cols);
        let blocks: &[(usize, usize, f64)] = if complex {
            &[(0, 0, 1.0), (n + p, n, 1.0)]
        } else {
            &[(0, 0, 1.0)]
        };
        for &(r0, c0, _) in blocks {
            for j in 0..n {
                for i in 0..n {
                    M[(r0 + i, c0 + j)] = -F[(i, j)];
                }
                M[(r0 + j, c0 + j)] += re;
                for i in 0..p {
                    M[(r0 + n + i, c0 + j)] = C[(i, j)] * cscale;
                }
            }
        }
        if complex {
            for j in 0..n {
                M[(j, n + j)] = -im; // −Im M in the top-right block
                M[(n + p + j, j)] = im; // Im M in the bottom-left block
            }
        }
        let sv = M
            .singular_values()
            .map_err(|_| Error::RiccatiNoConvergence {
                equation: "PBH test",
                iterations: 0,
                reason: "singular value decomposition failed",
            })?;
        let smin = sv.iter().copied().fold(f64::INFINITY, f64::min);
        if smin <= opts.pbh_tolerance * scale {
            return Ok(Some((re, im)));
        }
    }
    Ok(None)
}

/// Decorrelate, run the PBH tests, and solve the filter-form DARE for (F, H, Q, R, S);
/// returns the prior P.
fn discrete_dual(
    F: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    S: Option<MatRef<'_, f64>>,
    opts: &RiccatiOptions,
    names: &Names,
) -> Result<Solved, Error> {
    let llt = factor_r(R, "the Riccati solvers need R^-1")?;
    // F̃ = F − S R⁻¹ H, Q̃ = Q − S R⁻¹ Sᵀ.
    let (Ft, Qt) = match S {
        Some(S) => {
            let RinvSt = llt.solve(S.transpose());
            let RinvH = llt.solve(H);
            let mut Qt = Q - S * &RinvSt;
            symmetrise(&mut Qt);
            (F - S * &RinvH, Qt)
        }
        None => (F.to_owned(), Q.to_owned()),
    };
    // F̃ = F − S R⁻¹ H has F's eigenvalues when S = 0: one eigen-decomposition then.
    let modes = marginal_modes(F, false, Modes::OnOrOutside, opts)?;
    if let Some((re, im)) = pbh(F, H, &modes, opts)? {
        return Err(names.detect.error(re, im));
    }
    // A stabilising solution exists when (F̃, Q̃^{1/2}) has no unreachable mode *on* the
    // unit circle; an unreachable mode outside it is stabilised through the gain (F = 2,
    // Q = 0, H = R = 1: P = 3).
    let modes_t = marginal_modes(Ft.as_ref(), false, Modes::On, opts)?;
    if !modes_t.is_empty() {
        let Qh = psd_sqrt(Qt.as_ref())?;
        if let Some((re, im)) = pbh(Ft.transpose(), Qh.as_ref(), &modes_t, opts)? {
            return Err(names.stab.error(re, im));
        }
    }
    let mut G = H.transpose() * llt.solve(H);
    symmetrise(&mut G);
    let mut Qs = Qt.clone();
    symmetrise(&mut Qs);
    let (mut X, mut iterations) = sda(
        Ft.transpose().to_owned(),
        G.clone(),
        Qs.clone(),
        opts,
        names.equation,
    )?;
    // Ill-conditioned problems leave the doubling a little short of full accuracy: up to two
    // Newton corrections, each kept only if it lowers the residual.
    let mut newton_steps = 2;
    let rho0 = closed_loop_radius(Ft.as_ref(), H, R, &X);
    if rho0.is_nan() || rho0 >= 1.0 {
        // Q̃ leaves an unstable mode unexcited: the doubling from Q̃ then converges to a
        // solution that does not stabilise it (X = 0 for Q̃ = 0). The doubling from
        // Q̃ + δI does (every mode is then reachable), and lies within O(δ) of the
        // stabilising solution; Newton's method from a stabilising start stays stabilising
        // and removes the O(δ) in a few quadratic steps. δ is relative to the scale of X
        // (that of Q̃, or of (Hᵀ R⁻¹ H)⁻¹ when Q̃ vanishes).
        let gnorm = G.norm_l2();
        let scale = Qs
            .norm_l2()
            .max(if gnorm > 0.0 { 1.0 / gnorm } else { 1.0 });
        let n = Qs.nrows();
        let Qd = &Qs + (1e-8 * scale) * Mat::<f64>::identity(n, n);
        let (Xd, it) = sda(Ft.transpose().to_owned(), G, Qd, opts, names.equation)?;
        X = Xd;
        iterations += it;
        newton_steps = 20;
    }
    let mut relative_residual = dare_residual(F, H, Q, R, S, X.as_ref());
    for _ in 0..newton_steps {
        if relative_residual <= 1e-3 * opts.residual_tolerance {
            break;
        }
        match newton_polish(F, H, Q, R, S, &X) {
            Some(Xn) => {
                let r = dare_residual(F, H, Q, R, S, Xn.as_ref());
                if r < relative_residual {
                    X = Xn;
                    relative_residual = r;
                } else {
                    break;
                }
            }
            None => break,
        }
    }
    let rho = closed_loop_radius(Ft.as_ref(), H, R, &X);
    // Written so that a NaN residual or radius fails the check.
    let ok = relative_residual <= opts.residual_tolerance && rho < 1.0;
    if !ok {
        return Err(Error::RiccatiCheck {
            equation: names.equation,
            residual: relative_residual,
            tolerance: opts.residual_tolerance,
            closed_loop: rho,
        });
    }
    Ok(Solved {
        x: X,
        iterations,
        relative_residual,
    })
}

/// Spectral radius of the predictor's closed loop F̃ − F̃ X Hᵀ Σ⁻¹ H (= F − K_p H) for a
/// candidate DARE solution X (+∞ if Σ = H X Hᵀ + R is not positive definite).
fn closed_loop_radius(
    Ft: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    X: &Mat<f64>,
) -> f64 {
    let mut Sigma = H * X * H.transpose() + R;
    symmetrise(&mut Sigma);
    match Sigma.llt(Side::Lower) {
        Ok(l) => {
            let Kt = l.solve(H * X * Ft.transpose());
            let cl = Ft - Kt.transpose() * H;
            spectral(cl.as_ref(), false)
        }
        Err(_) => f64::INFINITY,
    }
}

/// PBH tests and SDA-after-Cayley for the filter-form CARE A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0.
fn continuous_dual(
    A: MatRef<'_, f64>,
    H: MatRef<'_, f64>,
    Q: MatRef<'_, f64>,
    R: MatRef<'_, f64>,
    opts: &RiccatiOptions,
    names: &Names,
) -> Result<Solved, Error> {
    let n = A.nrows();
    let llt = factor_r(R, "the Riccati solvers need R^-1")?;
    // The CARE keeps the stricter test (no unreachable mode on or right of the imaginary
    // axis): its doubling has no restart for a Q that leaves an unstable mode unexcited.
    let modes = marginal_modes(A, true, Modes::OnOrOutside, opts)?;
    if let Some((re, im)) = pbh(A, H, &modes, opts)? {
        return Err(names.detect.error(re, im));
    }
    if !modes.is_empty() {
        let Qh = psd_sqrt(Q)?;
        if let Some((re, im)) = pbh(A.transpose(), Qh.as_ref(), &modes, opts)? {
            return Err(names.stab.error(re, im));
        }
    }
    let mut G = H.transpose() * llt.solve(H);
    symmetrise(&mut G);
    let mut Hc = Q.to_owned();
    symmetrise(&mut Hc);
    let Ac = A.transpose().to_owned();
    // γ ≥ ‖ℋ‖_F > ρ(ℋ): ℋ − γI is non-singular, so the Cayley transform exists.
    let gamma = 1.01
        * (2.0 * Ac.squared_norm_l2() + G.squared_norm_l2() + Hc.squared_norm_l2()).sqrt()
        + f64::MIN_POSITIVE.sqrt();
    let I = Mat::<f64>::identity(n, n);
    let Ag = &Ac - gamma * &I;
    let Ag_lu = Ag.partial_piv_lu();
    let Y = Ag_lu.solve_transpose(&Hc); // A_γ⁻ᵀ Q
    let V = &Ag + &G * &Y;
    let V_lu = V.partial_piv_lu();
    // V⁻¹ itself is the SDA's initial matrix here (A₀ = I + 2γV⁻¹): obtained as the solve V X = I.
    let A0 = &I + (2.0 * gamma) * V_lu.solve(&I);
    let Z = Ag_lu.solve(&G); // A_γ⁻¹ G, so G A_γ⁻ᵀ = Zᵀ
    let mut G0 = (2.0 * gamma) * V_lu.solve(Z.transpose());
    let mut H0 = (2.0 * gamma) * V_lu.solve_transpose(Y.transpose()); // V⁻ᵀ Q A_γ⁻¹
    symmetrise(&mut G0);
    symmetrise(&mut H0);
    if !all_finite(A0.as_ref()) || !all_finite(G0.as_ref()) || !all_finite(H0.as_ref()) {
        return Err(Error::RiccatiNoConvergence {
            equation: names.equation,
            iterations: 0,
            reason: "Cayley transform singular",
        });
    }
    let (X, iterations) = sda(A0, G0, H0, opts, names.equation)?;
    let relative_residual = care_residual(A, H, Q, R, X.as_ref());
    let Kt = llt.solve(H * &X);
    let cl = A.to_owned() - Kt.transpose() * H;
    let abscissa = spectral(cl.as_ref(), true);
    let ok = relative_residual <= opts.residual_tolerance && abscissa < 0.0;
    if !ok {
        return Err(Error::RiccatiCheck {
            equation: names.equation,
            residual: relative_residual,
            tolerance: opts.residual_tolerance,
            closed_loop: abscissa,
        });
    }
    Ok(Solved {
        x: X,
        iterations,
        relative_residual,
    })
}

/// Spectral radius (discrete) or spectral abscissa (continuous); +∞ if the eigenvalue
/// computation fails.
pub(crate) fn spectral(M: MatRef<'_, f64>, continuous: bool) -> f64 {
    match M.eigenvalues() {
        Ok(e) if continuous => e.iter().map(|l| l.re).fold(f64::NEG_INFINITY, f64::max),
        Ok(e) => e.iter().map(|l| l.norm()).fold(0.0, f64::max),
        Err(_) => f64::INFINITY,
    }
}

/// The structured doubling algorithm on a control-form DARE in standard symplectic form
/// X = H₀ + A₀ᵀ X (I + G₀ X)⁻¹ A₀. Returns (X, iterations).
fn sda(
    mut A: Mat<f64>,
    mut G: Mat<f64>,
    mut Hh: Mat<f64>,
    opts: &RiccatiOptions,
    equation: &'static str,
) -> Result<(Mat<f64>, usize), Error> {
    let n = A.nrows();
    let I = Mat::<f64>::identity(n, n);
    for it in 1..=opts.max_iterations {
        let W = &I + &G * &Hh;
        let lu = W.partial_piv_lu();
        let WA = lu.solve(&A); // W⁻¹ A_k
        let WG = lu.solve(&G); // W⁻¹ G_k
        let A_next = &A * &WA;
        let mut G_next = &G + &A * &WG * A.transpose();
        let mut H_next = &Hh + A.transpose() * (&Hh * &WA);
        symmetrise(&mut G_next);
        symmetrise(&mut H_next);
        if !all_finite(A_next.as_ref())
            || !all_finite(G_next.as_ref())
            || !all_finite(H_next.as_ref())
        {
            return Err(Error::RiccatiNoConvergence {
                equation,
                iterations: it,
                reason: "doubling iterate became non-finite (I + G H singular or divergent)",
            });
        }
        let change = (&H_next - &Hh).norm_l2();
        let scale = H_next.norm_l2();
        A = A_next;
        G = G_next;
        Hh = H_next;
        if change <= opts.tolerance * scale {
            return Ok((Hh, it));
        }
    }
    Err(Error::RiccatiNoConvergence {
        equation,
        iterations: opts.max_iterations,
        reason: "doubling did not reach the tolerance",
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::mat;

    #[test]
    fn scalar_dare_closed_form() {
        // p = f²p r/(p + r) + q with f = 0.9, q = 0.5, r = 2: quadratic p² + (r(1 − f²) − q)p − qr = 0.
        let (f, q, r) = (0.9_f64, 0.5, 2.0);
        let b = r * (1.0 - f * f) - q;
        let p = (-b + (b * b + 4.0 * q * r).sqrt()) / 2.0;
        let ss = dare(
            mat![[f]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[q]].as_ref(),
            mat![[r]].as_ref(),
            None,
        )
        .expect("must succeed");
        // Tolerance: a few ulps of p ≈ 1 after ~10 doubling steps.
        assert!(
            (ss.prior[(0, 0)] - p).abs() < 1e-13,
            "{} vs {p}",
            ss.prior[(0, 0)]
        );
        assert!((ss.gain[(0, 0)] - p / (p + r)).abs() < 1e-13);
        assert!((ss.posterior[(0, 0)] - p * r / (p + r)).abs() < 1e-13);
    }

    #[test]
    fn zero_noise_stable_gives_zero() {
        let ss = dare(
            mat![[0.5]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[0.0]].as_ref(),
            mat![[1.0]].as_ref(),
            None,
        )
        .expect("must succeed");
        assert!(ss.prior[(0, 0)].abs() < 1e-300);
    }

    #[test]
    fn undetectable_and_unstabilisable_are_typed() {
        let F = mat![[1.2, 0.0], [0.0, 0.5]];
        let H = mat![[0.0, 1.0]];
        let Q = mat![[1.0, 0.0], [0.0, 1.0]];
        let R = mat![[1.0]];
        let e = dare(F.as_ref(), H.as_ref(), Q.as_ref(), R.as_ref(), None)
            .expect_err("must be an error");
        assert!(
            matches!(e, Error::NotDetectable { pair: "(F, H)", .. }),
            "{e}"
        );
        // A mode on the unit circle that the noise does not reach has no stabilising
        // solution: refused.
        let F1 = mat![[1.0, 0.0], [0.0, 0.5]];
        let H = mat![[1.0, 1.0]];
        let Q = mat![[0.0, 0.0], [0.0, 1.0]];
        let e = dare(F1.as_ref(), H.as_ref(), Q.as_ref(), R.as_ref(), None)
            .expect_err("must be an error");
        assert!(
            matches!(e, Error::NotStabilisable { re, im, .. } if (re - 1.0).abs() < 1e-12 && im == 0.0),
            "{e}"
        );
        // The same on the circle at an angle: a rotation without noise.
        let (c, s) = (0.6_f64.cos(), 0.6_f64.sin());
        let e = dare(
            mat![[c, -s], [s, c]].as_ref(),
            mat![[1.0, 0.0]].as_ref(),
            Mat::<f64>::zeros(2, 2).as_ref(),
            R.as_ref(),
            None,
        )
        .expect_err("must be an error");
        assert!(
            matches!(e, Error::NotStabilisable { im, .. } if im > 0.5),
            "{e}"
        );
        // Complex unstable pair, unobservable.
        let c = 1.1 * 0.6_f64.cos();
        let s = 1.1 * 0.6_f64.sin();
        let F = mat![[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 0.3]];
        let H = mat![[0.0, 0.0, 1.0]];
        let Q = Mat::<f64>::identity(3, 3);
        let e = dare(F.as_ref(), H.as_ref(), Q.as_ref(), R.as_ref(), None)
            .expect_err("must be an error");
        assert!(
            matches!(e, Error::NotDetectable { im, .. } if im > 0.5),
            "{e}"
        );
    }

    #[test]
    fn unreached_unstable_modes_off_the_circle_have_a_stabilising_solution() {
        // F = 2, Q = 0, H = R = 1: p = 4p − 4p²/(p + 1) ⇔ p² − 3p = 0. The root p = 0 leaves
        // the closed loop at 2; p = 3 gives K_p = F p/(p + 1) = 1.5, closed loop
        // 2 − 1.5 = 0.5: the stabilising solution, posterior p − p²/(p + 1) = 0.75.
        let ss = dare(
            mat![[2.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[0.0]].as_ref(),
            mat![[1.0]].as_ref(),
            None,
        )
        .expect("stabilising solution exists");
        // 1e-12: a few Newton steps from a 1e-8 perturbation, quadratic convergence.
        assert!(
            (ss.prior[(0, 0)] - 3.0).abs() < 1e-12,
            "{}",
            ss.prior[(0, 0)]
        );
        assert!((ss.posterior[(0, 0)] - 0.75).abs() < 1e-12);
        assert!((ss.predictor_gain[(0, 0)] - 1.5).abs() < 1e-12);
        // Two states: the unreached mode 1.2 is seen through H and stabilised by the gain.
        let F = mat![[1.2, 0.0], [0.0, 0.5]];
        let H = mat![[1.0, 1.0]];
        let Q = mat![[0.0, 0.0], [0.0, 1.0]];
        let R = mat![[1.0]];
        let ss = dare(F.as_ref(), H.as_ref(), Q.as_ref(), R.as_ref(), None)
            .expect("stabilising solution exists");
        let cl = &F - &ss.predictor_gain * &H;
        assert!(spectral(cl.as_ref(), false) < 1.0);
        // Independent check: the residual of the DARE itself.
        assert!(
            dare_residual(
                F.as_ref(),
                H.as_ref(),
                Q.as_ref(),
                R.as_ref(),
                None,
                ss.prior.as_ref()
            ) < 1e-12
        );
    }

    #[test]
    fn scalar_care_and_clqr() {
        let ss = care(
            mat![[-1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
        )
        .expect("must succeed");
        assert!((ss.covariance[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-13);
        // Unstable a = 2, b = 1, q = r = 1: 4X − X² + 1 = 0, X = 2 + √5, L = X.
        let l = clqr(
            mat![[2.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
        )
        .expect("must succeed");
        assert!((l.gain[(0, 0)] - (2.0 + 5f64.sqrt())).abs() < 1e-12);
    }

    #[test]
    fn shape_and_pd_errors_name_the_matrix() {
        let e = dare(
            mat![[1.0]].as_ref(),
            mat![[1.0, 0.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            None,
        )
        .expect_err("must be an error");
        assert!(matches!(e, Error::Shape { name: "H", .. }), "{e}");
        let e = dare(
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[0.0]].as_ref(),
            None,
        )
        .expect_err("must be an error");
        assert!(
            matches!(e, Error::NotPositiveDefinite { name: "R", .. }),
            "{e}"
        );
        let e = dare(
            mat![[f64::NAN]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            None,
        )
        .expect_err("must be an error");
        assert!(matches!(e, Error::NonFinite { name: "F", .. }), "{e}");
    }
}
