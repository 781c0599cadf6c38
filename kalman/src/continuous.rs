//! Continuous time: the Kalman–Bucy Riccati ODE
//! Ṗ = A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q integrated by an adaptive Dormand–Prince 5(4) scheme
//! that keeps P symmetric, the Kalman–Bucy gain K = P Hᵀ R⁻¹, and the continuous/discrete
//! link: the matrix exponential and Van Loan's sampling of a continuous model.
//!
//! Here `Q` is the n×n intensity of the process noise as it enters the state (G Q_w Gᵀ for a
//! noise input matrix G and intensity Q_w) and `R` the m×m intensity of the measurement noise
//! (positive definite). The steady state of the ODE is the stabilising solution of the CARE,
//! [`crate::riccati::Care`].
#![allow(non_snake_case)]

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef};

use crate::Error;
use crate::MatrixInput;
use crate::model::{check, owned};
use crate::riccati::{Care, factor_pd, symmetrise, symmetrised, weighted_gram};

/// The Kalman–Bucy filter's covariance equation for a time-invariant continuous model.
///
/// # Example
/// ```
/// use faer::mat;
/// use kalman::continuous::{KalmanBucy, OdeOptions};
///
/// // Scalar ẋ = −x + w, z = x + v, q = r = 1: Ṗ = −2P − P² + 1, steady P = √2 − 1.
/// let (a, one) = (mat![[-1.0]], mat![[1.0]]);
/// let kb = KalmanBucy::new(a.as_ref(), one.as_ref(), one.as_ref(), one.as_ref())?;
/// let sol = kb.until_steady(mat![[0.0]].as_ref(), 1e-8, 100.0, &OdeOptions::default())?;
/// assert!((sol.covariance[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-7);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct KalmanBucy {
    A: Mat<f64>,
    H: Mat<f64>,
    Q: Mat<f64>,
    R: Mat<f64>,
    /// Hᵀ R⁻¹ H (n×n, symmetric), by a Cholesky solve.
    G: Mat<f64>,
}

/// Tolerances of the adaptive integration.
///
/// # Example
/// ```
/// use faer::mat;
/// use kalman::continuous::{KalmanBucy, OdeOptions};
///
/// let (zero, one) = (mat![[0.0]], mat![[1.0]]);
/// let kb = KalmanBucy::new(zero.as_ref(), one.as_ref(), one.as_ref(), one.as_ref())?;
/// // A step budget too small to reach t = 10 is a typed error, not a hang.
/// let tight = OdeOptions { max_steps: 2, ..OdeOptions::default() };
/// assert!(kb.integrate(mat![[1.0]].as_ref(), 10.0, &tight).is_err());
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdeOptions {
    /// Relative tolerance per entry. Default 1e-10.
    pub rtol: f64,
    /// Absolute tolerance per entry. Default 1e-12.
    pub atol: f64,
    /// Maximum number of accepted + rejected steps. Default 1 000 000.
    pub max_steps: usize,
}

impl Default for OdeOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-10,
            atol: 1e-12,
            max_steps: 1_000_000,
        }
    }
}

/// Result of integrating the Riccati ODE.
///
/// # Example
/// ```
/// use faer::mat;
/// use kalman::continuous::{KalmanBucy, OdeOptions};
///
/// // Ṗ = q for a random walk that is not measured informatively (H = 0): P(t) = P0 + q t.
/// let (zero, q, r) = (mat![[0.0]], mat![[2.0]], mat![[1.0]]);
/// let kb = KalmanBucy::new(zero.as_ref(), zero.as_ref(), q.as_ref(), r.as_ref())?;
/// let sol = kb.integrate(mat![[1.0]].as_ref(), 3.0, &OdeOptions::default())?;
/// assert!((sol.time - 3.0).abs() < 1e-12 && (sol.covariance[(0, 0)] - 7.0).abs() < 1e-9);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct OdeSolution {
    /// P at the final time (symmetric).
    pub covariance: Mat<f64>,
    /// The final time reached.
    pub time: f64,
    /// Accepted steps.
    pub steps: usize,
}

impl KalmanBucy {
    /// The Riccati equation of ẋ = A x + w, z = H x + v with intensities Q (n×n, of w as it
    /// enters the state) and R (m×m, positive definite).
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming the matrix; [`Error::NotPositiveDefinite`]
    /// for R.
    pub fn new(
        A: impl MatrixInput,
        H: impl MatrixInput,
        Q: impl MatrixInput,
        R: impl MatrixInput,
    ) -> Result<Self, Error> {
        let m = Care::new(A, H, Q, R)?.inputs;
        let llt = factor_pd("R", m.r.as_ref(), "the Kalman-Bucy gain needs R^-1")?;
        Ok(Self {
            G: weighted_gram(m.c.as_ref(), &llt),
            Q: symmetrised(m.q.as_ref()),
            A: m.a,
            H: m.c,
            R: m.r,
        })
    }

    /// Ṗ at P: A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q (symmetrised).
    pub fn derivative(&self, P: MatRef<'_, f64>) -> Mat<f64> {
        let AP = &self.A * P;
        let mut D = &AP + AP.transpose() - P * (&self.G * P) + &self.Q;
        symmetrise(&mut D);
        D
    }

    /// The Kalman–Bucy gain K = P Hᵀ R⁻¹ (n×m) at P.
    ///
    /// # Errors
    /// [`Error::Shape`] if P is not n×n.
    pub fn gain(&self, P: MatRef<'_, f64>) -> Result<Mat<f64>, Error> {
        let n = self.A.nrows();
        check("P", P, n, n)?;
        let llt = factor_pd("R", self.R.as_ref(), "the Kalman-Bucy gain needs R^-1")?;
        Ok(llt.solve(&self.H * P).transpose().to_owned())
    }

    /// Integrates Ṗ from `P0` at time 0 to time `t1` (adaptive Dormand–Prince 5(4), P
    /// symmetrised after every step).
    ///
    /// # Errors
    /// Shape/finiteness errors naming `P0`; [`Error::RiccatiNoConvergence`] if the step
    /// budget runs out or P becomes non-finite.
    pub fn integrate(
        &self,
        P0: MatRef<'_, f64>,
        t1: f64,
        opts: &OdeOptions,
    ) -> Result<OdeSolution, Error> {
        self.run(P0, t1, None, opts)
    }

    /// Integrates from `P0` until ‖Ṗ‖_F ≤ `rel_rate`·‖P‖_F (per unit time) or `t_max`,
    /// whichever is first; the result approximates the ODE's limit, the CARE solution, to
    /// about `rel_rate` / (closed-loop decay rate). An explicit scheme hovers near a stable
    /// fixed point at a rate of roughly `rtol`·|λ_max|, so choose `rel_rate` ≳ 100·`rtol`
    /// (1e-8 with the default options).
    ///
    /// # Errors
    /// As [`KalmanBucy::integrate`]; also [`Error::RiccatiNoConvergence`] if `t_max` is
    /// reached before the rate criterion.
    pub fn until_steady(
        &self,
        P0: MatRef<'_, f64>,
        rel_rate: f64,
        t_max: f64,
        opts: &OdeOptions,
    ) -> Result<OdeSolution, Error> {
        let sol = self.run(P0, t_max, Some(rel_rate), opts)?;
        if sol.time >= t_max {
            return Err(Error::RiccatiNoConvergence {
                equation: "Kalman-Bucy ODE",
                iterations: sol.steps,
                reason: "P did not settle before t_max",
            });
        }
        Ok(sol)
    }

    fn run(
        &self,
        P0: MatRef<'_, f64>,
        t1: f64,
        rate: Option<f64>,
        opts: &OdeOptions,
    ) -> Result<OdeSolution, Error> {
        let n = self.A.nrows();
        check("P0", P0, n, n)?;
        // Dormand–Prince 5(4) tableau (the right-hand side does not depend on t, so the
        // nodes c_i are not needed).
        const A2: [f64; 1] = [1.0 / 5.0];
        const A3: [f64; 2] = [3.0 / 40.0, 9.0 / 40.0];
        const A4: [f64; 3] = [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0];
        const A5: [f64; 4] = [
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
        ];
        const A6: [f64; 5] = [
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
        ];
        const B5: [f64; 7] = [
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
            0.0,
        ];
        const B4: [f64; 7] = [
            5179.0 / 57600.0,
            0.0,
            7571.0 / 16695.0,
            393.0 / 640.0,
            -92097.0 / 339200.0,
            187.0 / 2100.0,
            1.0 / 40.0,
        ];
        let mut P = P0.to_owned();
        symmetrise(&mut P);
        let mut t = 0.0_f64;
        let mut k1 = self.derivative(P.as_ref());
        // The first step is a guess the error control corrects (a rejected step shrinks, an
        // accepted one grows), so its scale and the 0.01 in it change the step count only.
        let scale = (self.A.norm_l2() + self.G.norm_l2() * P.norm_l2().max(1.0)).max(1e-12);
        let mut h = (0.01 / scale).min(t1.max(f64::MIN_POSITIVE));
        let mut steps = 0usize;
        let comb = |P: &Mat<f64>, ks: &[&Mat<f64>], a: &[f64], h: f64| -> Mat<f64> {
            let mut Y = P.clone();
            for (k, &c) in ks.iter().zip(a) {
                if c != 0.0 {
                    Y += (h * c) * *k;
                }
            }
            Y
        };
        for _ in 0..opts.max_steps {
            let settled = rate.is_some_and(|r| k1.norm_l2() <= r * P.norm_l2());
            if settled {
                return Ok(OdeSolution {
                    covariance: P,
                    time: t,
                    steps,
                });
            }
            if t >= t1 {
                return Ok(OdeSolution {
                    covariance: P,
                    time: t,
                    steps,
                });
            }
            let h_step = h.min(t1 - t);
            let k2 = self.derivative(comb(&P, &[&k1], &A2, h_step).as_ref());
            let k3 = self.derivative(comb(&P, &[&k1, &k2], &A3, h_step).as_ref());
            let k4 = self.derivative(comb(&P, &[&k1, &k2, &k3], &A4, h_step).as_ref());
            let k5 = self.derivative(comb(&P, &[&k1, &k2, &k3, &k4], &A5, h_step).as_ref());
            let k6 = self.derivative(comb(&P, &[&k1, &k2, &k3, &k4, &k5], &A6, h_step).as_ref());
            let mut Pn = comb(&P, &[&k1, &k2, &k3, &k4, &k5, &k6], &B5[..6], h_step);
            symmetrise(&mut Pn);
            let k7 = self.derivative(Pn.as_ref());
            let ks = [&k1, &k2, &k3, &k4, &k5, &k6, &k7];
            let mut err = 0.0_f64;
            for j in 0..n {
                for i in 0..n {
                    let mut e = 0.0;
                    for (k, (b5, b4)) in ks.iter().zip(B5.iter().zip(B4.iter())) {
                        // (Only |e| is used below.)
                        e += (b5 - b4) * k[(i, j)];
                    }
                    let sc = opts.atol + opts.rtol * P[(i, j)].abs().max(Pn[(i, j)].abs());
                    err = err.max((h_step * e).abs() / sc);
                }
            }
            if !err.is_finite() || !Pn.norm_l2().is_finite() {
                // (`<` and `≤` differ only at a step of exactly 1e-300.)
                if h_step < 1e-300 {
                    break;
                }
                h = h_step * 0.1;
                continue;
            }
            if err <= 1.0 {
                t += h_step;
                P = Pn;
                k1 = k7;
                steps += 1;
            }
            let factor = if err == 0.0 {
                5.0
            } else {
                (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
            };
            h = h_step * factor;
        }
        Err(Error::RiccatiNoConvergence {
            equation: "Kalman-Bucy ODE",
            iterations: steps,
            reason: "step budget exhausted or P became non-finite",
        })
    }
}

/// Matrix exponential e^{A} by scaling and squaring with the Padé approximant of the degree
/// (3, 5, 7, 9 or 13) that A's 1-norm needs (Higham 2005); the Padé quotient is a solve, not
/// an inverse: `numerics::Expm`, the workspace's one exponential, also behind the sampler of
/// continuous models.
///
/// # Errors
/// [`Error::Shape`] if A is not square, [`Error::NonFinite`] for a non-finite entry, and
/// [`Error::NonFinite`] naming `e^A` if the exponential overflows f64.
///
/// # Example
/// ```
/// use faer::mat;
///
/// let e = kalman::continuous::expm(mat![[0.0, 1.0], [0.0, 0.0]].as_ref())?;
/// assert!((e[(0, 1)] - 1.0).abs() < 1e-15 && (e[(1, 1)] - 1.0).abs() < 1e-15);
/// # Ok::<(), kalman::Error>(())
/// ```
pub fn expm(A: impl MatrixInput) -> Result<Mat<f64>, Error> {
    let n = A.nrows();
    check("A", &A, n, n)?;
    let mut work = numerics::Expm::new(n);
    let input = work.input(n);
    for j in 0..n {
        for i in 0..n {
            input[i + j * n] = A.at(i, j);
        }
    }
    let mut out = vec![0.0; n * n];
    if !work.run(n, &mut out) {
        return Err(overflow("e^A", n, &out));
    }
    Ok(Mat::from_fn(n, n, |i, j| out[i + j * n]))
}

/// Van Loan's sampling of ẋ = A x + w (w of intensity `Q`, n×n, as it enters the state) at
/// interval `dt`: returns (F, Q_d) with F = e^{AΔt} and Q_d = ∫₀^Δt e^{Aτ} Q e^{Aᵀτ} dτ
/// (symmetrised), computed by `numerics::van_loan`. Measurement noise of intensity R_c
/// averaged over the interval has
/// covariance R_c / Δt.
///
/// # Errors
/// Shape/finiteness errors naming `A` or `Q`; [`Error::Dimension`] for a non-positive `dt`.
///
/// # Example
/// ```
/// use faer::mat;
///
/// // Random walk of intensity 3 sampled every 0.5 s: F = 1, Q_d = 1.5.
/// let (f, qd) = kalman::continuous::van_loan(mat![[0.0]].as_ref(), mat![[3.0]].as_ref(), 0.5)?;
/// assert!((f[(0, 0)] - 1.0).abs() < 1e-15 && (qd[(0, 0)] - 1.5).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub fn van_loan(
    A: impl MatrixInput,
    Q: impl MatrixInput,
    dt: f64,
) -> Result<(Mat<f64>, Mat<f64>), Error> {
    let (A, Q) = (owned(&A), owned(&Q));
    let (A, Q) = (A.as_ref(), Q.as_ref());
    let n = A.nrows();
    check("A", A, n, n)?;
    check("Q", Q, n, n)?;
    if !(dt > 0.0 && dt.is_finite()) {
        return Err(Error::Dimension {
            name: "dt",
            value: 0,
            rule: "the sampling interval must be positive and finite",
        });
    }
    let a: Vec<f64> = A.col_iter().flat_map(|c| c.iter().copied()).collect();
    let q: Vec<f64> = Q.col_iter().flat_map(|c| c.iter().copied()).collect();
    let (mut f, mut qd) = (vec![0.0; n * n], vec![0.0; n * n]);
    if !numerics::van_loan(&a, &q, n, dt, &mut f, &mut qd) {
        f.extend_from_slice(&qd);
        return Err(overflow("the Van Loan exponential (F, Q_d)", n, &f));
    }
    let at = |v: &[f64]| Mat::from_fn(n, n, |i, j| v[i + j * n]);
    Ok((at(&f), at(&qd)))
}

/// [`Error::NonFinite`] naming `name` (n×n) at the first non-finite entry of `values`, one
/// or more n×n column-major matrices (an exponential that overflowed).
fn overflow(name: &'static str, n: usize, values: &[f64]) -> Error {
    let bad = values.iter().position(|x| !x.is_finite()).unwrap_or(0) % (n * n).max(1);
    Error::NonFinite {
        name,
        rows: n,
        cols: n,
        row: bad % n.max(1),
        col: bad / n.max(1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::mat;

    /// A sampling interval that is zero, negative, infinite or NaN is named, not integrated
    /// (a negative one would run the model backwards, an infinite one overflow).
    /// An exponential that overflows f64 is an error naming it, not a matrix of ∞/NaN.
    #[test]
    fn an_overflowing_van_loan_is_an_error_naming_it() {
        let err = van_loan(mat![[1000.0]].as_ref(), mat![[1.0]].as_ref(), 1.0).expect_err("e^1000");
        assert!(
            matches!(err, Error::NonFinite { name, .. } if name.contains("Van Loan")),
            "{err:?}"
        );
        let err = expm(mat![[1000.0]].as_ref()).expect_err("e^1000");
        assert!(
            matches!(err, Error::NonFinite { name: "e^A", .. }),
            "{err:?}"
        );
    }

    #[test]
    fn van_loan_refuses_a_sampling_interval_that_is_not_positive_and_finite() {
        let (A, Q) = (mat![[-1.0]], mat![[1.0]]);
        for dt in [0.0, -0.1, f64::INFINITY, f64::NAN] {
            let err = van_loan(A.as_ref(), Q.as_ref(), dt).expect_err("a bad dt");
            assert!(
                matches!(err, Error::Dimension { name: "dt", .. }),
                "dt {dt}: {err}"
            );
        }
        assert!(van_loan(A.as_ref(), Q.as_ref(), 0.1).is_ok());
    }

    #[test]
    fn expm_rotation_and_nilpotent() {
        // ‖A‖₁ = 10 needs one halving before the [13/13] Padé approximant, 40 needs three
        // (θ₁₃ ≈ 5.37); the Padé approximant alone is far off at 40.
        for w in [10.0_f64, 40.0] {
            let E = expm(mat![[0.0, w], [-w, 0.0]].as_ref()).expect("must succeed");
            // Tolerance: a rotation's squarings keep the norm 1, each adding ~1e-16 of
            // round-off to the phase; 1e-12 is ample.
            assert!(
                (E[(0, 0)] - w.cos()).abs() < 1e-12 && (E[(0, 1)] - w.sin()).abs() < 1e-12,
                "w {w}"
            );
        }
        let E = expm(mat![[0.0, 0.25], [0.0, 0.0]].as_ref()).expect("must succeed");
        assert!((E[(0, 1)] - 0.25).abs() < 1e-15 && (E[(1, 1)] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn van_loan_white_acceleration() {
        // Double integrator with white acceleration q: Q_d = q [[Δt³/3, Δt²/2], [Δt²/2, Δt]].
        let (dt, q) = (0.25, 0.1);
        let (F, Qd) = van_loan(
            mat![[0.0, 1.0], [0.0, 0.0]].as_ref(),
            mat![[0.0, 0.0], [0.0, q]].as_ref(),
            dt,
        )
        .expect("must succeed");
        assert!((F[(0, 1)] - dt).abs() < 1e-15);
        let want = [
            [q * dt.powi(3) / 3.0, q * dt * dt / 2.0],
            [q * dt * dt / 2.0, q * dt],
        ];
        for i in 0..2 {
            for j in 0..2 {
                assert!((Qd[(i, j)] - want[i][j]).abs() < 1e-15, "{i}{j}");
            }
        }
    }

    #[test]
    fn scalar_ode_matches_closed_form() {
        // ṗ = −2p − p² + 1 from p(0) = 0: p(t) = tanh-type closed form; compare the limit.
        let kb = KalmanBucy::new(
            mat![[-1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
            mat![[1.0]].as_ref(),
        )
        .expect("must succeed");
        let sol = kb
            .integrate(mat![[0.0]].as_ref(), 1.0, &OdeOptions::default())
            .expect("must succeed");
        // Exact: p(t) = (e^{2√2 t} − 1) / ((1 + √2) e^{2√2 t} + (√2 − 1)).
        let r = 2f64.sqrt();
        let e = (2.0 * r).exp();
        let exact = (e - 1.0) / ((1.0 + r) * e + (r - 1.0));
        // Tolerance: rtol 1e-10 per step, ~30 steps.
        assert!(
            (sol.covariance[(0, 0)] - exact).abs() < 1e-9,
            "{} vs {exact}",
            sol.covariance[(0, 0)]
        );
        // Each accepted step advances t, so reaching t = 1 took at least one, and a budget of
        // fewer attempts (accepted + rejected) than the accepted steps cannot get there.
        assert!(sol.steps >= 1);
        let short = OdeOptions {
            max_steps: sol.steps - 1,
            ..OdeOptions::default()
        };
        assert!(kb.integrate(mat![[0.0]].as_ref(), 1.0, &short).is_err());
    }

    #[test]
    fn a_derivative_that_overflows_is_an_error_not_a_nan_covariance() {
        // ṗ = −p² at p₀ = 1e160: p₀² overflows, every trial step is non-finite whatever its
        // length, and the integration must end in the typed error (after shrinking the step
        // below 1e-300), not accept a non-finite P and return it at t₁.
        let (zero, one) = (mat![[0.0]], mat![[1.0]]);
        let kb = KalmanBucy::new(zero.as_ref(), one.as_ref(), zero.as_ref(), one.as_ref())
            .expect("must succeed");
        let got = kb.integrate(mat![[1e160]].as_ref(), 1.0, &OdeOptions::default());
        assert!(
            matches!(got, Err(Error::RiccatiNoConvergence { iterations: 0, .. })),
            "{got:?}"
        );
        // The same equation from p₀ = 1 is harmless: p(t) = 1/(1 + t).
        let sol = kb
            .integrate(mat![[1.0]].as_ref(), 1.0, &OdeOptions::default())
            .expect("must succeed");
        assert!((sol.covariance[(0, 0)] - 0.5).abs() < 1e-9);
    }

    #[test]
    fn step_count_grows_as_the_fifth_root_of_the_tolerance() {
        // Unmeasured rotation (H = 0): Ṗ = A P + P Aᵀ + Q is linear and P keeps oscillating
        // at frequency 2, so the step size stays set by the accuracy, not by a transient.
        // The 5(4) pair's error estimate is O(h⁵), so steps h ∝ tol^{1/5}: a tolerance 10⁵
        // times tighter takes about 10 times as many steps. A wrong tableau entry lowers
        // the order (more steps) or breaks the estimate; [6, 16] allows for the step
        // controller's safety factor and the last, shortened step.
        let kb = KalmanBucy::new(
            mat![[0.0, 1.0], [-1.0, 0.0]].as_ref(),
            mat![[0.0, 0.0]].as_ref(),
            mat![[0.1, 0.0], [0.0, 0.0]].as_ref(),
            mat![[1.0]].as_ref(),
        )
        .expect("must succeed");
        let steps = |rtol: f64| {
            let opts = OdeOptions {
                rtol,
                atol: rtol * 1e-2,
                max_steps: 1_000_000,
            };
            let P0 = mat![[1.0, 0.0], [0.0, 0.0]];
            kb.integrate(P0.as_ref(), 20.0, &opts)
                .expect("must succeed")
                .steps as f64
        };
        let (coarse, fine) = (steps(1e-6), steps(1e-11));
        let ratio = fine / coarse;
        assert!(
            (6.0..16.0).contains(&ratio),
            "{fine} / {coarse} steps = {ratio}"
        );
    }
}
