//! The continuous equations: the filter CARE ([`Care`]) and the continuous LQR ([`Clqr`]),
//! by the structured doubling algorithm after a Cayley transform.
#![allow(non_snake_case)]

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, Side};

use super::checks::{Modes, marginal_modes, pbh, psd_sqrt};
use super::sda::sda;
use super::{
    ContinuousSteadyState, Coupling, Inputs, Lqr, Names, Pair, RiccatiOptions, Solved, all_finite,
    factor_r, relative, spectral, symmetrise, symmetrised, weighted_gram,
};
use crate::Error;
use crate::MatrixInput;

/// The filter CARE A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0 of the Kalman–Bucy filter, where `Q`
/// is the n×n process-noise intensity as it enters the state (G Q_w Gᵀ for a noise input
/// matrix G and intensity Q_w); [`Care::solve`] gives the stabilising P and the gain
/// K = P Hᵀ R⁻¹ as a [`ContinuousSteadyState`].
///
/// Method: the dual control-form CARE X A_c + A_cᵀ X − X G X + Q = 0 (A_c = Aᵀ,
/// G = Hᵀ R⁻¹ H) has Hamiltonian ℋ = [[A_c, −G], [−Q, −A_cᵀ]]. With γ > ρ(ℋ) the Cayley
/// map (ℋ + γI)(ℋ − γI)⁻¹ sends its stable eigenvalues inside the unit circle, and the pencil
/// (ℋ + γI) − μ(ℋ − γI) is brought to the standard symplectic form of the SDA with
/// A_γ = A_c − γI, V = A_γ + G A_γ⁻ᵀ Q: A₀ = I + 2γV⁻¹, G₀ = 2γ V⁻¹ G A_γ⁻ᵀ,
/// H₀ = 2γ V⁻ᵀ Q A_γ⁻¹; the doubling then converges to X = P.
///
/// Errors of [`Care::solve`] as [`Dare`](super::Dare) with the continuous stability
/// boundary (Re λ ≥ 0).
///
/// # Example
/// ```
/// use faer::mat;
/// use kalman::riccati::Care;
///
/// // ẋ = −x + w, z = x + v, q = r = 1: −2P − P² + 1 = 0, P = √2 − 1.
/// let one = mat![[1.0]];
/// let ss = Care::new(mat![[-1.0]], &one, &one, &one)?.solve()?;
/// assert!((ss.covariance[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Care {
    pub(crate) inputs: Inputs,
    options: RiccatiOptions,
}

impl Care {
    /// The equation of ẋ = A x + w, z = H x + v with intensities Q (n×n) and R (m×m);
    /// default options.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming the first bad matrix (A n×n, H m×n,
    /// Q n×n, R m×m).
    pub fn new(
        A: impl MatrixInput,
        H: impl MatrixInput,
        Q: impl MatrixInput,
        R: impl MatrixInput,
    ) -> Result<Self, Error> {
        Ok(Self {
            inputs: Inputs::new(
                ["A", "H", "Q", "R"],
                Coupling::Measurement,
                [&A, &H, &Q, &R],
            )?,
            options: RiccatiOptions::default(),
        })
    }

    /// Replaces the default [`RiccatiOptions`].
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::{Care, RiccatiOptions};
    ///
    /// // ẋ = w, z = x + v, q = 4, r = 1: −P² + 4 = 0, P = 2, K = 2.
    /// let opts = RiccatiOptions { residual_tolerance: 1e-12, ..RiccatiOptions::default() };
    /// let ss = Care::new([[0.0]], [[1.0]], [[4.0]], [[1.0]])?.options(opts).solve()?;
    /// assert!((ss.covariance[(0, 0)] - 2.0).abs() < 1e-12 && (ss.gain[(0, 0)] - 2.0).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    #[must_use]
    pub fn options(self, options: RiccatiOptions) -> Self {
        Self { options, ..self }
    }

    /// The stabilising covariance and the Kalman–Bucy gain.
    ///
    /// # Errors
    /// As listed on [`Care`].
    pub fn solve(&self) -> Result<ContinuousSteadyState, Error> {
        let ([A, H, Q, R], _) = self.inputs.views();
        let names = Names {
            equation: "filter CARE",
            detect: Pair::Detect("(A, H)"),
            stab: Pair::Stab("(A, Q^{1/2})"),
        };
        let sol = continuous_dual(A, H, Q, R, &self.options, &names)?;
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

    /// Relative residual ‖A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q‖_F / ‖P‖_F of a candidate solution P
    /// (+∞ when R is not positive definite).
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming P unless it is n×n and finite.
    ///
    /// # Example
    /// ```
    /// use kalman::riccati::Care;
    ///
    /// // ẋ = −x + w, z = x + v, q = r = 1: P = √2 − 1 solves −2P − P² + 1 = 0.
    /// let care = Care::new([[-1.0]], [[1.0]], [[1.0]], [[1.0]])?;
    /// assert!(care.residual([[2f64.sqrt() - 1.0]])? < 1e-15);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn residual(&self, P: impl MatrixInput) -> Result<f64, Error> {
        let P = self.inputs.candidate("P", &P)?;
        let ([A, H, Q, R], _) = self.inputs.views();
        Ok(residual(A, H, Q, R, P.as_ref()))
    }
}

/// The continuous-time LQR for ẋ = A x + B u with cost ∫ xᵀQx + uᵀRu: [`Clqr::solve`]
/// solves X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q = 0 and returns the [`Lqr`] gain L = R⁻¹ Bᵀ X
/// (u = −L x).
///
/// Errors of [`Clqr::solve`]: [`Error::NotStabilisable`] for (A, B), [`Error::NotDetectable`]
/// for (Q^{1/2}, A) (modes with Re λ ≥ 0), PD errors naming the matrix.
///
/// # Example
/// ```
/// use kalman::riccati::Clqr;
///
/// // ẋ = u, cost ∫ x² + u²: X = 1, L = 1.
/// let lqr = Clqr::new([[0.0]], [[1.0]], [[1.0]], [[1.0]])?.solve()?;
/// assert!((lqr.gain[(0, 0)] - 1.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Clqr {
    inputs: Inputs,
    options: RiccatiOptions,
}

impl Clqr {
    /// The problem of A (n×n), B (n×m), state weight Q (n×n) and input weight R (m×m);
    /// default options.
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

    /// Replaces the default [`RiccatiOptions`].
    #[must_use]
    pub fn options(self, options: RiccatiOptions) -> Self {
        Self { options, ..self }
    }

    /// The stabilising cost matrix X and the gain L.
    ///
    /// # Errors
    /// As listed on [`Clqr`].
    pub fn solve(&self) -> Result<Lqr, Error> {
        let ([A, B, Q, R], _) = self.inputs.views();
        let names = Names {
            equation: "LQR CARE",
            detect: Pair::Stab("(A, B)"),
            stab: Pair::Detect("(Q^{1/2}, A)"),
        };
        let sol = continuous_dual(A.transpose(), B.transpose(), Q, R, &self.options, &names)?;
        let llt = factor_r(R, "the Riccati solvers need R^-1")?;
        let gain = llt.solve(B.transpose() * &sol.x);
        Ok(Lqr {
            gain,
            cost: sol.x,
            iterations: sol.iterations,
            relative_residual: sol.relative_residual,
        })
    }

    /// Relative residual ‖X A + Aᵀ X − X B R⁻¹ Bᵀ X + Q‖_F / ‖X‖_F of a candidate cost
    /// matrix X (the filter-form residual of the dual, see [`Care::residual`]).
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming X unless it is n×n and finite.
    pub fn residual(&self, cost: impl MatrixInput) -> Result<f64, Error> {
        let X = self.inputs.candidate("X", &cost)?;
        let ([A, B, Q, R], _) = self.inputs.views();
        Ok(residual(A.transpose(), B.transpose(), Q, R, X.as_ref()))
    }
}

/// [`Care::residual`] on faer views (the solver's own check).
fn residual(
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
    let G = weighted_gram(H, &llt);
    let Hc = symmetrised(Q);
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
    let relative_residual = residual(A, H, Q, R, X.as_ref());
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
