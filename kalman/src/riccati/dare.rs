//! The discrete equations: the filter DARE ([`Dare`]), its dual the discrete LQR
//! ([`Dlqr`]), the residual, Newton's polish and the decorrelate–test–double driver.
#![allow(non_snake_case)]

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, Side};

use super::checks::{Modes, marginal_modes, pbh, psd_sqrt};
use super::sda::sda;
use super::{
    Coupling, Inputs, Lqr, Names, Pair, RiccatiOptions, Solved, SteadyState, all_finite, factor_r,
    relative, spectral, symmetrise, symmetrised, weighted_gram,
};
use crate::MatrixInput;
use crate::storage::Dims;
use crate::{Error, Model};

/// The filter DARE of (F, H, Q, R), with an optional cross-covariance S (n×m) and
/// [`RiccatiOptions`]; [`Dare::solve`] gives the [`SteadyState`].
///
/// Errors of [`Dare::solve`]: [`Error::NotPositiveDefinite`] for R; [`Error::NotDetectable`]
/// for (F, H); [`Error::NotStabilisable`] for a mode of (F̃, Q̃^{1/2}) on the unit circle
/// that the noise does not reach (F̃ = F − S R⁻¹ H, Q̃ = Q − S R⁻¹ Sᵀ; plain (F, Q^{1/2})
/// when S = 0); [`Error::RiccatiNoConvergence`] / [`Error::RiccatiCheck`] if the result
/// fails. Shape and finiteness errors naming the matrix come from the builder's own calls.
///
/// # Example
/// ```
/// use faer::mat;
/// use kalman::riccati::Dare;
///
/// // Random walk observed in unit noise, q = 1: P = (1 + √5)/2, K = P/(P + 1).
/// let one = mat![[1.0]];
/// let ss = Dare::new(&one, &one, &one, &one)?.solve()?;
/// let p = (1.0 + 5f64.sqrt()) / 2.0;
/// assert!((ss.prior[(0, 0)] - p).abs() < 1e-12);
/// assert!((ss.gain[(0, 0)] - p / (p + 1.0)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Dare {
    inputs: Inputs,
    options: RiccatiOptions,
}

impl Dare {
    /// The equation of x_{k+1} = F x_k + w_k, z_k = H x_k + v_k with cov(w) = Q (n×n),
    /// cov(v) = R (m×m) and no cross-covariance; default options.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming the first bad matrix (F n×n, H m×n,
    /// Q n×n, R m×m).
    pub fn new(
        F: impl MatrixInput,
        H: impl MatrixInput,
        Q: impl MatrixInput,
        R: impl MatrixInput,
    ) -> Result<Self, Error> {
        Ok(Self {
            inputs: Inputs::new(
                ["F", "H", "Q", "R"],
                Coupling::Measurement,
                [&F, &H, &Q, &R],
            )?,
            options: RiccatiOptions::default(),
        })
    }

    /// Adds the cross-covariance S = E[w_k v_kᵀ] (n×m).
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming S.
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::Dare;
    ///
    /// // F = H = Q = R = 1 and S = 1/2: P = P + 1 − (P + 1/2)²/(P + 1), so P² = 3/4.
    /// let ss = Dare::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?.cross_covariance([[0.5]])?.solve()?;
    /// assert!((ss.prior[(0, 0)] - 0.75f64.sqrt()).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn cross_covariance(self, S: impl MatrixInput) -> Result<Self, Error> {
        Ok(Self {
            inputs: self.inputs.with_cross("S", &S)?,
            ..self
        })
    }

    /// Replaces the default [`RiccatiOptions`].
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::{Dare, RiccatiOptions};
    ///
    /// // A stricter residual check still accepts the scalar random walk, P = (1 + √5)/2.
    /// let opts = RiccatiOptions { residual_tolerance: 1e-13, ..RiccatiOptions::default() };
    /// let ss = Dare::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?.options(opts).solve()?;
    /// assert!((ss.prior[(0, 0)] - (1.0 + 5f64.sqrt()) / 2.0).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    #[must_use]
    pub fn options(self, options: RiccatiOptions) -> Self {
        Self { options, ..self }
    }

    /// The stabilising solution, its gains and innovation covariance.
    ///
    /// # Errors
    /// As listed on [`Dare`].
    pub fn solve(&self) -> Result<SteadyState, Error> {
        let ([F, H, Q, R], S) = self.inputs.views();
        let m = H.nrows();
        let names = Names {
            equation: "filter DARE",
            detect: Pair::Detect("(F, H)"),
            stab: Pair::Stab(if S.is_some() {
                "(F - S R^-1 H, (Q - S R^-1 S^T)^{1/2})"
            } else {
                "(F, Q^{1/2})"
            }),
        };
        let sol = discrete_dual(F, H, Q, R, S, &self.options, &names)?;
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

    /// Relative residual ‖F P Fᵀ + Q − (F P Hᵀ + S)(H P Hᵀ + R)⁻¹(⋯)ᵀ − P‖_F / ‖P‖_F of a
    /// candidate solution P (0 when both the residual and P vanish; +∞ when H P Hᵀ + R is
    /// not positive definite). The solver's own acceptance check, open for tests.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming P unless it is n×n and finite.
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::Dare;
    ///
    /// // The golden ratio solves the scalar random walk's DARE p = p + 1 − p²/(p + 1); 2 does not.
    /// let dare = Dare::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])?;
    /// assert!(dare.residual([[(1.0 + 5f64.sqrt()) / 2.0]])? < 1e-15);
    /// // At P = 2: residual 2 + 1 − 4/3 − 2 = −1/3, relative to ‖P‖ = 2.
    /// assert!((dare.residual([[2.0]])? - 1.0 / 6.0).abs() < 1e-15);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn residual(&self, P: impl MatrixInput) -> Result<f64, Error> {
        let P = self.inputs.candidate("P", &P)?;
        let ([F, H, Q, R], S) = self.inputs.views();
        Ok(residual(F, H, Q, R, S, P.as_ref()))
    }
}

impl SteadyState {
    /// The steady state of an engine [`Model`] (either storage path): [`Dare`] on its F, H,
    /// Q, R and S.
    ///
    /// # Errors
    /// As [`Dare::solve`].
    pub fn of<D: Dims>(model: &Model<D>) -> Result<Self, Error> {
        let mut dare = Dare::new(model.f(), model.h(), model.q(), model.r())?;
        if let Some(s) = model.s() {
            dare = dare.cross_covariance(s)?;
        }
        dare.solve()
    }
}

/// The discrete-time LQR for x_{k+1} = A x_k + B u_k with cost Σ xᵀQx + uᵀRu + 2xᵀN u (no
/// cross weight N unless given): [`Dlqr::solve`] solves
/// X = AᵀXA + Q − (AᵀXB + N)(R + BᵀXB)⁻¹(BᵀXA + Nᵀ) by the dual filter DARE (F = Aᵀ,
/// H = Bᵀ, S = N) and returns the [`Lqr`] gain L with u = −L x.
///
/// Errors of [`Dlqr::solve`]: [`Error::NotStabilisable`] for (A, B) (modes on or outside the
/// unit circle), [`Error::NotDetectable`] for (Q^{1/2}, A) (modes on the unit circle: an
/// unobserved unstable mode off the circle is stabilised by the gain), PD errors naming the
/// matrix. Shape and finiteness errors come from the builder's own calls.
///
/// The UAV loop of Gridnev, Rusetsky and Rak (state weight diag(1, 0.1), input weight 1,
/// Δt = 0.25):
/// ```
/// use faer::mat;
/// use kalman::riccati::Dlqr;
///
/// let dt = 0.25;
/// let a = mat![[1.0, dt], [0.0, 1.0]];
/// let b = mat![[dt * dt / 2.0], [dt]];
/// let lqr = Dlqr::new(&a, &b, mat![[1.0, 0.0], [0.0, 0.1]], mat![[1.0]])?.solve()?;
/// // The closed loop A − B L is stable.
/// let cl = &a - &b * &lqr.gain;
/// let rho = cl.eigenvalues().expect("must succeed").iter().map(|l| l.norm()).fold(0.0, f64::max);
/// assert!(rho < 1.0);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Dlqr {
    inputs: Inputs,
    options: RiccatiOptions,
}

impl Dlqr {
    /// The problem of A (n×n), B (n×m), state weight Q (n×n) and input weight R (m×m), with
    /// no cross weight and default options.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming the first bad matrix.
    pub fn new(
        A: impl MatrixInput,
        B: impl MatrixInput,
        Q: impl MatrixInput,
        R: impl MatrixInput,
    ) -> Result<Self, Error> {
        Ok(Self {
            inputs: Inputs::new(["A", "B", "Q", "R"], Coupling::Input, [&A, &B, &Q, &R])?,
            options: RiccatiOptions::default(),
        })
    }

    /// Adds the cross weight N (n×m) of the cost term 2xᵀN u.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming N.
    pub fn cross_weight(self, N: impl MatrixInput) -> Result<Self, Error> {
        Ok(Self {
            inputs: self.inputs.with_cross("N", &N)?,
            ..self
        })
    }

    /// Replaces the default [`RiccatiOptions`].
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::{Dlqr, RiccatiOptions};
    ///
    /// // x_{k+1} = 2 x_k + u_k, cost Σ x² + u²: X = 2 + √5 (from X² − 4X − 1 = 0), L = 2X/(1 + X).
    /// let opts = RiccatiOptions { max_iterations: 50, ..RiccatiOptions::default() };
    /// let lqr = Dlqr::new([[2.0]], [[1.0]], [[1.0]], [[1.0]])?.options(opts).solve()?;
    /// let x = 2.0 + 5f64.sqrt();
    /// assert!((lqr.cost[(0, 0)] - x).abs() < 1e-12 && (lqr.gain[(0, 0)] - 2.0 * x / (1.0 + x)).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    #[must_use]
    pub fn options(self, options: RiccatiOptions) -> Self {
        Self { options, ..self }
    }

    /// The stabilising cost matrix X and the gain L.
    ///
    /// # Errors
    /// As listed on [`Dlqr`].
    pub fn solve(&self) -> Result<Lqr, Error> {
        let ([A, B, Q, R], N) = self.inputs.views();
        let m = B.ncols();
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
        let sol = discrete_dual(A.transpose(), B.transpose(), Q, R, N, &self.options, &names)?;
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

    /// Relative residual ‖AᵀXA + Q − (AᵀXB + N)(R + BᵀXB)⁻¹(⋯)ᵀ − X‖_F / ‖X‖_F of a
    /// candidate cost matrix X (`cost`; the filter-form residual of the dual, see
    /// [`Dare::residual`]).
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming X unless it is n×n and finite.
    pub fn residual(&self, cost: impl MatrixInput) -> Result<f64, Error> {
        let X = self.inputs.candidate("X", &cost)?;
        let ([A, B, Q, R], N) = self.inputs.views();
        Ok(residual(A.transpose(), B.transpose(), Q, R, N, X.as_ref()))
    }
}

/// [`Dare::residual`] on faer views (the solvers' own check).
pub(super) fn residual(
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
    let G = weighted_gram(H, &llt);
    let Qs = symmetrised(Qt.as_ref());
    let (mut X, mut iterations) = sda(
        Ft.transpose().to_owned(),
        G.clone(),
        Qs.clone(),
        opts,
        names.equation,
    )?;
    // Ill-conditioned problems leave the doubling short of full accuracy (an unstable mode
    // the noise does not reach, with the closed loop near the unit circle, costs several
    // digits): Newton corrections, each kept only if it lowers the residual, until the
    // residual is far inside the tolerance. From a stabilising start they converge
    // quadratically, so the cap is seldom reached.
    let newton_steps = 20;
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
    }
    // Newton–Hewer iterates from a stabilising start stay stabilising and decrease
    // monotonically (in the PSD order) onto the stabilising solution, but the residual norm
    // need not fall at every step: follow the iteration while the closed loop stays stable
    // and keep the iterate with the smallest residual.
    let mut relative_residual = residual(F, H, Q, R, S, X.as_ref());
    let mut current = X.clone();
    for _ in 0..newton_steps {
        if relative_residual <= 1e-3 * opts.residual_tolerance {
            break;
        }
        let Some(next) = newton_polish(F, H, Q, R, S, &current) else {
            break;
        };
        let r = residual(F, H, Q, R, S, next.as_ref());
        // Written so that a NaN residual or radius stops the iteration.
        if !(r.is_finite() && closed_loop_radius(Ft.as_ref(), H, R, &next) < 1.0) {
            break;
        }
        // `<=` would be equivalent: it keeps the later of two iterates whose residuals agree
        // to the last bit, which happens only once Newton has stalled at round-off, where the
        // two differ by round-off and pass the acceptance below alike.
        if r < relative_residual {
            X = next.clone();
            relative_residual = r;
        }
        current = next;
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
