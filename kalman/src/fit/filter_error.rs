//! The parameters of a nonlinear model fitted through the extended Kalman filter's
//! likelihood: the *filter-error method* of flight-test identification (Maine & Iliff,
//! "Formulation and implementation of a practical algorithm for parameter estimation with
//! process and measurement noise", SIAM J. Appl. Math. 41, 1981; Jategaonkar, *Flight
//! Vehicle System Identification*, 2nd ed., ch. 5), a prediction-error method in the
//! statisticians' words.
//!
//! # The likelihood
//! A [`ParametricModel`] gives, for a parameter vector θ, the transition `f_θ`, the
//! measurement function `h_θ`, the noise covariances `Q_θ`, `R_θ` and the prior
//! `(x0_θ, P0_θ)` of the first measurement. The EKF (Joseph update, exact Jacobians)
//! linearises at its own estimates, and the Gaussian log-likelihood of its prior
//! innovations is
//!
//! ```text
//! ln L(θ) = Σ_k −½ ( e_kᵀ Σ_k⁻¹ e_k + ln det Σ_k + m_k ln 2π ),
//! e_k = z_k − h_θ(x_{k|k−1}),   Σ_k = H_k P_{k|k−1} H_kᵀ + R_θ,   H_k = ∂h_θ/∂x,
//! ```
//!
//! over the observed (non-NaN) entries of `z_k`, as the linear fit's ([`super`]). For a
//! linear model it is that likelihood exactly; for a nonlinear one it is the EKF's
//! approximation of it, the quantity the filter-error method maximises. With `Q_θ = 0` it is
//! the output-error criterion with the prior's weight.
//!
//! # The gradient
//! The whole filter pass is written over a generic scalar, so forward-mode automatic
//! differentiation gives the exact gradient: one pass per parameter in `num_dual::Dual64`
//! seeded on θ_j. The Jacobians inside the pass are themselves derivatives of `f_θ` and
//! `h_θ`, taken with a second, nested dual (`Dual<Dual64>`), so `∂H_k/∂θ` and `∂F_k/∂θ` —
//! the second derivatives the analytic score recursion of a nonlinear filter needs — come
//! out exact as well. The observed information is the central difference of that exact
//! gradient, as in the linear fit.
//!
//! # Example
//! ```
//! use kalman::fit::{MleOptions, ParametricModel, Series, filter_error};
//! use kalman::nonlinear::Scalar;
//!
//! /// x_{k+1} = a·x_k + w, z = x + v: the AR coefficient a is θ₀.
//! struct Ar1;
//! impl ParametricModel for Ar1 {
//!     fn dims(&self) -> (usize, usize, usize) { (1, 1, 1) }
//!     fn f<T: Scalar>(&self, th: &[T], x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
//!         out[0] = th[0] * x[0];
//!     }
//!     fn h<T: Scalar>(&self, _th: &[T], x: &[T], _k: usize, out: &mut [T]) { out[0] = x[0]; }
//!     fn q<T: Scalar>(&self, _th: &[T], _k: usize, out: &mut [T]) { out[0] = T::from(1.0); }
//!     fn r<T: Scalar>(&self, _th: &[T], _k: usize, out: &mut [T]) { out[0] = T::from(0.5); }
//!     fn x0<T: Scalar>(&self, _th: &[T], out: &mut [T]) { out[0] = T::from(0.0); }
//!     fn p0<T: Scalar>(&self, _th: &[T], out: &mut [T]) { out[0] = T::from(1.0); }
//! }
//! # fn main() -> Result<(), kalman::fit::FitError> {
//! let z: Vec<f64> = (0..300).map(|k| (0.05 * k as f64).sin() * 3.0).collect();
//! let fit = filter_error(&Ar1, vec![0.0], &[Series::new(&z, 1)?], &MleOptions::default())?;
//! assert!(fit.converged, "{}", fit.message);
//! assert!(fit.theta[0] > 0.9, "a slow sinusoid is a persistent AR(1)");
//! # Ok(())
//! # }
//! ```

use faer::Mat;
use num_dual::{Dual, Dual64};

use super::info::{Uncertainty, aic, bic, central_information};
use super::mle::{MleOptions, Objective, optimise};
use super::{FitError, LN_2PI, Series};
use crate::kernels::{cholesky, symmetrise};
use crate::nonlinear::{GenericModel, Scalar};

/// A nonlinear model whose transition, measurement function, noise and prior depend on a
/// parameter vector θ, every function generic over the scalar (as
/// [`GenericModel`]'s) in θ and x alike, so that
/// [`filter_error`] differentiates the filter exactly. Matrices are written column-major
/// (`out[i + j·n]` is entry (i, j)).
pub trait ParametricModel {
    /// `(n, m, n_params)`: the state and measurement dimensions and the length of θ.
    fn dims(&self) -> (usize, usize, usize);
    /// The parameters' names, in θ's order (for messages and results). Default `θ0, θ1, …`.
    fn names(&self) -> Vec<String> {
        (0..self.dims().2).map(|i| format!("θ{i}")).collect()
    }
    /// The transition `f_θ(x, u, k)` into `out` (length n).
    fn f<T: Scalar>(&self, theta: &[T], x: &[T], u: Option<&[f64]>, k: usize, out: &mut [T]);
    /// The measurement function `h_θ(x, k)` into `out` (length m).
    fn h<T: Scalar>(&self, theta: &[T], x: &[T], k: usize, out: &mut [T]);
    /// `Q_θ` of the step from k to k + 1 (n×n, symmetric PSD).
    fn q<T: Scalar>(&self, theta: &[T], k: usize, out: &mut [T]);
    /// `R_θ` of step k (m×m, symmetric positive definite on the observed entries).
    fn r<T: Scalar>(&self, theta: &[T], k: usize, out: &mut [T]);
    /// The prior mean of the first state (length n).
    fn x0<T: Scalar>(&self, theta: &[T], out: &mut [T]);
    /// The prior covariance of the first state (n×n, symmetric PSD).
    fn p0<T: Scalar>(&self, theta: &[T], out: &mut [T]);
}

/// The most parameters [`AtTheta`] holds (its θ lives on the stack, so a filter step over
/// it allocates nothing).
pub const MAX_FIXED_PARAMS: usize = 64;

/// A [`ParametricModel`] at a fixed θ, as a [`GenericModel`]: the fitted model, ready for
/// [`AutoDiff`](crate::nonlinear::AutoDiff) and the crate's [`Ekf`](crate::nonlinear::Ekf),
/// [`Ukf`](crate::nonlinear::Ukf) and smoother.
#[derive(Clone, Debug)]
pub struct AtTheta<M> {
    model: M,
    theta: [f64; MAX_FIXED_PARAMS],
    len: usize,
}

impl<M: ParametricModel> AtTheta<M> {
    /// `model` at `theta`.
    ///
    /// # Errors
    /// [`FitError::Parameters`] if θ's length is not the model's, exceeds
    /// [`MAX_FIXED_PARAMS`] or an entry is not finite.
    pub fn new(model: M, theta: &[f64]) -> Result<Self, FitError> {
        check_theta(&model, theta)?;
        if theta.len() > MAX_FIXED_PARAMS {
            return Err(FitError::Parameters(format!(
                "{} parameters; a fixed model holds at most {MAX_FIXED_PARAMS}",
                theta.len()
            )));
        }
        let mut t = [0.0; MAX_FIXED_PARAMS];
        t[..theta.len()].copy_from_slice(theta);
        Ok(Self {
            model,
            theta: t,
            len: theta.len(),
        })
    }

    /// The prior `(x0, P0)` at θ (P0 column-major).
    pub fn prior(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.model.dims().0;
        let (mut x0, mut p0) = (vec![0.0; n], vec![0.0; n * n]);
        self.model.x0(self.theta(), &mut x0);
        self.model.p0(self.theta(), &mut p0);
        (x0, p0)
    }

    fn theta(&self) -> &[f64] {
        &self.theta[..self.len]
    }

    fn lifted<T: Scalar>(&self) -> [T; MAX_FIXED_PARAMS] {
        std::array::from_fn(|i| T::from(self.theta[i]))
    }
}

impl<M: ParametricModel> GenericModel for AtTheta<M> {
    fn f<T: Scalar>(&self, x: &[T], u: Option<&[f64]>, k: usize, out: &mut [T]) {
        let th = self.lifted::<T>();
        self.model.f(&th[..self.len], x, u, k, out);
    }
    fn h<T: Scalar>(&self, x: &[T], k: usize, out: &mut [T]) {
        let th = self.lifted::<T>();
        self.model.h(&th[..self.len], x, k, out);
    }
    fn q(&self, k: usize, out: &mut [f64]) {
        self.model.q(self.theta(), k, out);
    }
    fn r(&self, k: usize, out: &mut [f64]) {
        self.model.r(self.theta(), k, out);
    }
}

fn check_theta<M: ParametricModel>(model: &M, theta: &[f64]) -> Result<(), FitError> {
    let p = model.dims().2;
    if theta.len() != p {
        return Err(FitError::Parameters(format!(
            "θ has {} entries, the model has {p} parameters",
            theta.len()
        )));
    }
    if let Some(i) = theta.iter().position(|v| !v.is_finite()) {
        let names = model.names();
        let name = names.get(i).map_or("?", String::as_str);
        return Err(FitError::Parameters(format!(
            "entry {i} ({name}) is {}",
            theta[i]
        )));
    }
    Ok(())
}

fn check_record<M: ParametricModel>(model: &M, data: &Series<'_>) -> Result<(), FitError> {
    let m = model.dims().1;
    if data.m() != m {
        return Err(FitError::Data(format!(
            "the record's rows have {} measurements, the model's h gives m = {m}",
            data.m()
        )));
    }
    Ok(())
}

/// The EKF's log-likelihood of `data` at θ (see the [module](self) for its definition).
///
/// # Errors
/// [`FitError::Parameters`] for a θ of the wrong length or with a non-finite entry,
/// [`FitError::Data`] for a record whose rows are not the model's m,
/// [`FitError::NotPositiveDefinite`] at the step whose innovation covariance is not
/// positive definite, [`FitError::Diverged`] at the step where the filter's state,
/// covariance or likelihood stops being finite.
pub fn ekf_log_likelihood<M: ParametricModel>(
    model: &M,
    theta: &[f64],
    data: &Series<'_>,
) -> Result<f64, FitError> {
    check_theta(model, theta)?;
    check_record(model, data)?;
    Pass::new(model, data).run(model, theta, data)
}

/// [`ekf_log_likelihood`] and its exact gradient (forward-mode AD through the filter, one
/// pass per parameter).
///
/// # Errors
/// As [`ekf_log_likelihood`].
pub fn ekf_log_likelihood_gradient<M: ParametricModel>(
    model: &M,
    theta: &[f64],
    data: &Series<'_>,
) -> Result<(f64, Vec<f64>), FitError> {
    check_theta(model, theta)?;
    check_record(model, data)?;
    let mut pass = Pass::<Dual64>::new(model, data);
    let mut ll = 0.0;
    let mut g = vec![0.0; theta.len()];
    let mut th: Vec<Dual64> = theta.iter().map(|&t| Dual64::from(t)).collect();
    for j in 0..theta.len() {
        th[j].eps = 1.0;
        let v = pass.run(model, &th, data)?;
        th[j].eps = 0.0;
        ll = v.re;
        g[j] = v.eps;
    }
    if theta.is_empty() {
        ll = ekf_log_likelihood(model, theta, data)?;
    }
    Ok((ll, g))
}

/// The result of [`filter_error`].
#[derive(Clone, Debug)]
pub struct ParametricFit {
    /// θ at the optimum.
    pub theta: Vec<f64>,
    /// The parameters' names ([`ParametricModel::names`]).
    pub names: Vec<String>,
    /// The EKF log-likelihood at the optimum, summed over the records.
    pub loglik: f64,
    /// Optimiser iterations.
    pub iterations: usize,
    /// Whether the largest entry of `∇ ln L` is within [`MleOptions::grad_tol`].
    pub converged: bool,
    /// What happened, in words.
    pub message: String,
    /// The observed information and what it says about θ (as [`super::Fit::uncertainty`]).
    pub uncertainty: Uncertainty,
    /// Observed scalar measurements.
    pub n_obs: usize,
    /// Akaike's information criterion.
    pub aic: f64,
    /// The Bayesian information criterion.
    pub bic: f64,
}

/// Maximum-likelihood θ of a nonlinear model through the EKF likelihood, over independent
/// records sharing θ (each starting from the model's prior): the same optimiser as
/// [`super::mle`] (warm-up from far starts, L-BFGS with the exact gradient, Nelder–Mead
/// fallback, Newton polish), then the observed information, standard errors, correlation
/// and the non-identified directions. A variance parameter is best written through a
/// transform inside the model (`exp` of θ_i), so every iterate is valid.
///
/// # Errors
/// [`FitError::NothingFree`] for a model without parameters, [`FitError::Data`] for no
/// record, and the errors of [`ekf_log_likelihood`] at θ0 and at the optimum.
pub fn filter_error<M: ParametricModel>(
    model: &M,
    theta0: Vec<f64>,
    records: &[Series<'_>],
    opts: &MleOptions,
) -> Result<ParametricFit, FitError> {
    if model.dims().2 == 0 {
        return Err(FitError::NothingFree);
    }
    if records.is_empty() {
        return Err(FitError::Data("no record to fit".into()));
    }
    check_theta(model, &theta0)?;
    for data in records {
        check_record(model, data)?;
    }
    let objective = EkfRecords { model, records };
    let n_obs: usize = records.iter().map(Series::observed).sum();
    let (theta, iterations, converged, mut message) = optimise(&objective, theta0, n_obs, opts)?;
    let (loglik, _) = objective.loglik_gradient(&theta)?;
    let information = objective.information(&theta)?;
    let names = model.names();
    let uncertainty = Uncertainty::new(information, &names, &mut message);
    let k = theta.len();
    Ok(ParametricFit {
        uncertainty,
        names,
        loglik,
        iterations,
        converged,
        message,
        n_obs,
        aic: aic(loglik, k),
        bic: bic(loglik, k, n_obs),
        theta,
    })
}

/// The EKF likelihood of records sharing θ, for the optimiser.
struct EkfRecords<'a, M> {
    model: &'a M,
    records: &'a [Series<'a>],
}

impl<M: ParametricModel> Objective for EkfRecords<'_, M> {
    fn loglik_gradient(&self, theta: &[f64]) -> Result<(f64, Vec<f64>), FitError> {
        let mut ll = 0.0;
        let mut g = vec![0.0; theta.len()];
        for data in self.records {
            let (l, gi) = ekf_log_likelihood_gradient(self.model, theta, data)?;
            ll += l;
            g.iter_mut().zip(gi).for_each(|(a, b)| *a += b);
        }
        Ok((ll, g))
    }

    fn information(&self, theta: &[f64]) -> Result<Mat<f64>, FitError> {
        central_information(theta, |t| self.loglik_gradient(t))
    }

    fn hint(&self) -> &'static str {
        "another starting point, a transform that keeps every variance positive, or fewer parameters"
    }
}

/// The workspaces of one filter pass over the scalar `T` (allocated once per pass set).
struct Pass<T> {
    n: usize,
    m: usize,
    x: Vec<T>,
    xn: Vec<T>,
    p: Vec<T>,
    jac: Vec<T>,
    hx: Vec<T>,
    q: Vec<T>,
    r: Vec<T>,
    /// `A P` of the Joseph form and `F P` of the predict (n × n).
    tmp: Vec<T>,
    /// `I − K Hₒ` (n × n).
    a: Vec<T>,
    /// A right-hand side solved against `Σ` (m_k).
    w: Vec<T>,
    /// Observed rows of step k.
    obs: Vec<usize>,
    e: Vec<T>,
    /// `P Hᵀ` (n × m_k), then the gain `K` in place.
    ph: Vec<T>,
    /// `Σ`, then its Cholesky factor (m_k × m_k).
    s: Vec<T>,
    /// Nested duals for the Jacobians: θ lifted, x seeded, f or h out.
    thd: Vec<Dual<T>>,
    xd: Vec<Dual<T>>,
    od: Vec<Dual<T>>,
}

impl<T: Scalar> Pass<T> {
    fn new<M: ParametricModel>(model: &M, _data: &Series<'_>) -> Self {
        let (n, m, p) = model.dims();
        let z = || T::from(0.0);
        let zd = || Dual::new(z(), z());
        Self {
            n,
            m,
            x: vec![z(); n],
            xn: vec![z(); n],
            p: vec![z(); n * n],
            jac: vec![z(); n.max(m) * n],
            hx: vec![z(); m],
            q: vec![z(); n * n],
            r: vec![z(); m * m],
            tmp: vec![z(); n * n],
            a: vec![z(); n * n],
            w: vec![z(); m],
            obs: Vec::with_capacity(m),
            e: vec![z(); m],
            ph: vec![z(); n * m],
            s: vec![z(); m * m],
            thd: vec![zd(); p],
            xd: vec![zd(); n],
            od: vec![zd(); n.max(m)],
        }
    }

    /// `ln L` at θ (over `T`: with dual θ, its derivative too).
    fn run<M: ParametricModel>(
        &mut self,
        model: &M,
        theta: &[T],
        data: &Series<'_>,
    ) -> Result<T, FitError> {
        let (n, m) = (self.n, self.m);
        let zero = T::from(0.0);
        for (d, &t) in self.thd.iter_mut().zip(theta) {
            *d = Dual::new(t, zero);
        }
        model.x0(theta, &mut self.x);
        model.p0(theta, &mut self.p);
        symmetrise(&mut self.p, n);
        let mut ll = zero;
        for k in 0..data.len() {
            let z = data.z(k);
            self.obs.clear();
            self.obs.extend((0..m).filter(|&i| !z[i].is_nan()));
            if !self.obs.is_empty() {
                ll += self.update(model, theta, z, k)?;
            }
            let u = (data.p() > 0).then(|| data.u(k));
            self.predict(model, theta, u, k)?;
            if !ll.re().is_finite() {
                return Err(FitError::Diverged {
                    what: "the log-likelihood",
                    step: k,
                });
            }
        }
        Ok(ll)
    }

    /// The Jacobian of h at x into `jac` (m × n) and h(x) into `hx`.
    fn h_jacobian<M: ParametricModel>(&mut self, model: &M, k: usize) {
        let (n, m) = (self.n, self.m);
        let (zero, one) = (T::from(0.0), T::from(1.0));
        for j in 0..n {
            for (i, d) in self.xd.iter_mut().enumerate() {
                *d = Dual::new(self.x[i], if i == j { one } else { zero });
            }
            model.h(&self.thd, &self.xd, k, &mut self.od[..m]);
            for i in 0..m {
                self.jac[i + j * m] = self.od[i].eps;
            }
        }
        if n == 0 {
            return;
        }
        for i in 0..m {
            self.hx[i] = self.od[i].re;
        }
    }

    /// The Jacobian of f at x into `jac` (n × n) and f(x) into `xn`.
    fn f_jacobian<M: ParametricModel>(&mut self, model: &M, u: Option<&[f64]>, k: usize) {
        let n = self.n;
        let (zero, one) = (T::from(0.0), T::from(1.0));
        for j in 0..n {
            for (i, d) in self.xd.iter_mut().enumerate() {
                *d = Dual::new(self.x[i], if i == j { one } else { zero });
            }
            model.f(&self.thd, &self.xd, u, k, &mut self.od[..n]);
            for i in 0..n {
                self.jac[i + j * n] = self.od[i].eps;
            }
        }
        for i in 0..n {
            self.xn[i] = self.od[i].re;
        }
    }

    /// The update with the observed rows of `z_k`; returns the step's `ln L` term.
    fn update<M: ParametricModel>(
        &mut self,
        model: &M,
        theta: &[T],
        z: &[f64],
        k: usize,
    ) -> Result<T, FitError> {
        let (n, m, mk) = (self.n, self.m, self.obs.len());
        let zero = T::from(0.0);
        self.h_jacobian(model, k);
        model.r(theta, k, &mut self.r);
        for (a, &i) in self.obs.iter().enumerate() {
            self.e[a] = T::from(z[i]) - self.hx[i];
        }
        // P Hₒᵀ (n × mk), Hₒ the observed rows of the Jacobian.
        for (a, &i) in self.obs.iter().enumerate() {
            for r in 0..n {
                let mut acc = zero;
                for c in 0..n {
                    acc += self.p[r + c * n] * self.jac[i + c * m];
                }
                self.ph[r + a * n] = acc;
            }
        }
        // Σ = Hₒ P Hₒᵀ + Rₒ.
        for (b, &j) in self.obs.iter().enumerate() {
            for (a, &i) in self.obs.iter().enumerate() {
                let mut acc = self.r[i + j * m];
                for c in 0..n {
                    acc += self.jac[i + c * m] * self.ph[c + b * n];
                }
                self.s[a + b * mk] = acc;
            }
        }
        symmetrise(&mut self.s[..mk * mk], mk);
        if !cholesky(&mut self.s[..mk * mk], mk, 0.0) {
            return Err(FitError::NotPositiveDefinite {
                name: "innovation covariance",
                step: k,
            });
        }
        let mut ln_det = zero;
        for a in 0..mk {
            ln_det += self.s[a + a * mk].ln();
        }
        ln_det *= 2.0;
        // w = Σ⁻¹ e, then the quadratic form eᵀ w.
        self.w[..mk].copy_from_slice(&self.e[..mk]);
        crate::kernels::cholesky_solve(&self.s[..mk * mk], mk, &mut self.w[..mk]);
        let mut quad = zero;
        for a in 0..mk {
            quad += self.e[a] * self.w[a];
        }
        // K = P Hₒᵀ Σ⁻¹: each row of P Hₒᵀ solved against Σ (Σ symmetric), in place.
        for r in 0..n {
            for a in 0..mk {
                self.w[a] = self.ph[r + a * n];
            }
            crate::kernels::cholesky_solve(&self.s[..mk * mk], mk, &mut self.w[..mk]);
            for a in 0..mk {
                self.ph[r + a * n] = self.w[a];
            }
        }
        // x ← x + K e.
        for r in 0..n {
            let mut acc = zero;
            for a in 0..mk {
                acc += self.ph[r + a * n] * self.e[a];
            }
            self.x[r] += acc;
        }
        // Joseph: P ← (I − K Hₒ) P (I − K Hₒ)ᵀ + K Rₒ Kᵀ.
        for c in 0..n {
            for r in 0..n {
                let mut acc = if r == c { T::from(1.0) } else { zero };
                for (b, &i) in self.obs.iter().enumerate() {
                    acc -= self.ph[r + b * n] * self.jac[i + c * m];
                }
                self.a[r + c * n] = acc;
            }
        }
        congruence(&self.a, &mut self.p, &mut self.tmp, n);
        for c in 0..n {
            for r in 0..n {
                let mut acc = zero;
                for (b, &j) in self.obs.iter().enumerate() {
                    for (a, &i) in self.obs.iter().enumerate() {
                        acc += self.ph[r + a * n] * self.r[i + j * m] * self.ph[c + b * n];
                    }
                }
                self.p[r + c * n] += acc;
            }
        }
        symmetrise(&mut self.p, n);
        Ok((quad + ln_det + T::from(mk as f64 * LN_2PI)) * T::from(-0.5))
    }

    /// x ← f(x), P ← F P Fᵀ + Q.
    fn predict<M: ParametricModel>(
        &mut self,
        model: &M,
        theta: &[T],
        u: Option<&[f64]>,
        k: usize,
    ) -> Result<(), FitError> {
        let n = self.n;
        self.f_jacobian(model, u, k);
        model.q(theta, k, &mut self.q);
        congruence(&self.jac[..n * n], &mut self.p, &mut self.tmp, n);
        for (a, &b) in self.p.iter_mut().zip(&self.q) {
            *a += b;
        }
        symmetrise(&mut self.p, n);
        std::mem::swap(&mut self.x, &mut self.xn);
        if self.x.iter().any(|v| !v.re().is_finite()) {
            return Err(FitError::Diverged {
                what: "the predicted state",
                step: k,
            });
        }
        if self.p.iter().any(|v| !v.re().is_finite()) {
            return Err(FitError::Diverged {
                what: "the predicted covariance",
                step: k,
            });
        }
        Ok(())
    }
}

/// `p ← a p aᵀ` (n × n, column-major), through the scratch `tmp`.
fn congruence<T: Scalar>(a: &[T], p: &mut [T], tmp: &mut [T], n: usize) {
    product(tmp, n, |i, l| a[i + l * n], |l, j| p[l + j * n]);
    product(p, n, |i, l| tmp[i + l * n], |l, j| a[j + l * n]);
}

/// `c[i, j] = Σ_l a(i, l) b(l, j)` (n × n, column-major), the factors given by entry.
#[inline(always)]
fn product<T: Scalar>(
    c: &mut [T],
    n: usize,
    a: impl Fn(usize, usize) -> T,
    b: impl Fn(usize, usize) -> T,
) {
    for j in 0..n {
        for i in 0..n {
            let mut acc = T::from(0.0);
            for l in 0..n {
                acc += a(i, l) * b(l, j);
            }
            c[i + j * n] = acc;
        }
    }
}
