//! Shaping filters learned from a recorded signal: `model`'s exponential, irregular-rolling
//! and damped-cosine filters as a `kalman::fit::ParamMap` (exact discretisation at Δt: ZOH
//! with the Van Loan noise integral, stationary prior from the discrete Lyapunov equation),
//! fitted by maximum likelihood; and, for comparison, the classical way — least squares of
//! the correlation function on the sample autocovariance.
//!
//! The map lives here, where both `model` and `kalman` are visible, because neither library
//! depends on the other: `kalman::fit` defines the map interface, `model` the filters.
//!
//! Parameters, all on a log scale so that every iterate is a valid filter:
//! θ = (ln D, ln μ) for [`Kind::Exponential`] (`R(τ) = D e^{−μ|τ|}`, μ = 1/T),
//! (ln D, ln μ, ln β) for [`Kind::IrregularRolling`] (`R(τ) = D e^{−μ|τ|}(cos βτ + μ/β
//! sin β|τ|)`), (ln D, ln ξ, ln ω) for [`Kind::DampedCosine`] (`R(τ) = D e^{−ξ|τ|} cos ωτ`),
//! followed by ln r when the white measurement noise variance r is free ([`Noise::Free`]).
#![allow(non_snake_case)]

use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;
use faer::Mat;
use kalman::fit::{FitError, MleOptions, ParamMap, Series, System, mle};
use model::nalgebra::DMatrix;
use model::{DampedCosineShaping, ExponentialShaping, IrregularRollingShaping, ShapingFilter};

use crate::error::{Error, Result};

/// Which shaping filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// First-order Gauss–Markov: (D, μ).
    Exponential,
    /// Irregular rolling: (D, μ, β).
    IrregularRolling,
    /// Damped cosine: (D, ξ, ω).
    DampedCosine,
}

impl Kind {
    /// Number of filter parameters.
    pub fn len(self) -> usize {
        match self {
            Kind::Exponential => 2,
            Kind::IrregularRolling | Kind::DampedCosine => 3,
        }
    }

    /// Whether the filter has no parameter (never).
    pub fn is_empty(self) -> bool {
        false
    }

    /// Names of the natural parameters.
    pub fn names(self) -> &'static [&'static str] {
        match self {
            Kind::Exponential => &["D", "mu"],
            Kind::IrregularRolling => &["D", "mu", "beta"],
            Kind::DampedCosine => &["D", "xi", "omega"],
        }
    }

    /// The `model` filter with natural parameters `p`.
    fn filter(self, p: &[f64]) -> model::Result<Box<dyn ShapingFilter>> {
        Ok(match self {
            Kind::Exponential => Box::new(ExponentialShaping::new(p[0], 1.0 / p[1])?),
            Kind::IrregularRolling => Box::new(IrregularRollingShaping::new(p[0], p[1], p[2])?),
            Kind::DampedCosine => Box::new(DampedCosineShaping::new(p[0], p[1], p[2])?),
        })
    }

    /// The correlation function `R(τ)` at natural parameters `p` (`model`'s).
    ///
    /// # Errors
    /// [`Error::Model`] (context "shaping filter") for parameters the filter refuses.
    pub fn correlation(self, p: &[f64], tau: f64) -> Result<f64> {
        Ok(self
            .filter(p)
            .map_err(|source| Error::Model {
                context: "shaping filter",
                source,
            })?
            .correlation(tau))
    }
}

/// The white measurement noise added to the process.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Noise {
    /// Known variance r ≥ 0.
    Known(f64),
    /// Fitted: ln r is the last parameter.
    Free,
}

/// A shaping filter sampled every `dt`, observed with white noise, as a [`ParamMap`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapingMap {
    /// The filter.
    pub kind: Kind,
    /// Sampling interval, s.
    pub dt: f64,
    /// The measurement noise.
    pub noise: Noise,
}

fn to_faer(m: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

fn symmetric(m: &DMatrix<f64>) -> DMatrix<f64> {
    let mut s = m.clone();
    numerics::symmetrise(s.as_mut_slice(), m.nrows());
    s
}

impl ShapingMap {
    /// θ of natural parameters `p` (and `r` when free).
    pub fn theta_of(&self, p: &[f64], r: f64) -> Vec<f64> {
        let mut t: Vec<f64> = p.iter().map(|v| v.ln()).collect();
        if self.noise == Noise::Free {
            t.push(r.ln());
        }
        t
    }
}

impl ParamMap for ShapingMap {
    fn n_params(&self) -> usize {
        self.kind.len() + usize::from(self.noise == Noise::Free)
    }

    fn names(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .kind
            .names()
            .iter()
            .map(|n| format!("ln {n}"))
            .collect();
        if self.noise == Noise::Free {
            v.push("ln r".into());
        }
        v
    }

    fn system(&self, theta: &[f64]) -> std::result::Result<System, FitError> {
        if theta.len() != self.n_params() {
            return Err(FitError::Parameters(format!(
                "θ has {} entries, the shaping map {}",
                theta.len(),
                self.n_params()
            )));
        }
        let k = self.kind.len();
        let p: Vec<f64> = theta[..k].iter().map(|v| v.exp()).collect();
        let r = match self.noise {
            Noise::Known(r) => r,
            Noise::Free => theta[k].exp(),
        };
        let bad = |e: model::Error| FitError::Parameters(format!("θ = {theta:?}: {e}"));
        let d = self
            .kind
            .filter(&p)
            .and_then(|f| {
                f.discretize(
                    self.dt,
                    model::Discretization::Zoh,
                    model::NoiseConvention::VanLoan,
                )
            })
            .map_err(bad)?;
        let Q = symmetric(&d.process_covariance());
        let P0 = symmetric(&model::discrete_lyapunov(d.f(), &Q).map_err(bad)?);
        let R = d.output_noise_covariance()[(0, 0)] + r;
        let n = d.f().nrows();
        System::new(
            &to_faer(d.f()),
            &to_faer(d.h()),
            &to_faer(&Q),
            &[[R]],
            &vec![0.0; n],
            &to_faer(&P0),
        )
    }

    fn log_variances(&self) -> Vec<usize> {
        let mut v = vec![0];
        if self.noise == Noise::Free {
            v.push(self.kind.len());
        }
        v
    }
}

/// A shaping filter fitted to a signal.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapingFit {
    /// Natural parameters (D, rate, frequency) and r last when free.
    pub values: Vec<f64>,
    /// Their standard errors (delta method from the log scale: se(p) = p·se(ln p)); `None`
    /// when the observed information is not positive definite.
    pub std_errors: Option<Vec<f64>>,
    /// Log-likelihood at the optimum.
    pub loglik: f64,
    /// Whether the optimiser converged.
    pub converged: bool,
    /// Iterations taken.
    pub iterations: usize,
    /// The optimiser's account of its stop.
    pub message: String,
}

/// The optimiser's options for a shaping map. The map's derivatives are central
/// differences of the discretised matrices (step 1e-6 relative, round-off ≈ 1e-10
/// relative), so the score carries an error of about 1e-10 per sample and unit of ln L
/// slope: 1e-4 is at that floor for records of thousands of samples. 1e-3 stops where the
/// remaining step, |∇ ln L|/λ_min(information) with λ_min ≳ N/10, is below 1e-5 in ln p
/// for N ≥ 1000 — a thousandth of the standard errors such records give.
pub const MLE_OPTIONS: MleOptions = MleOptions {
    max_iter: 500,
    grad_tol: 1e-3,
    interrupt: None,
};

/// Maximum likelihood of `map` on `z` (one channel, NaN = missing) from natural parameters
/// `start` (and `r0` when the noise is free).
///
/// # Errors
/// [`Error::Fit`] (context "shaping-filter fit") with the fitting library's error.
pub fn fit_mle(map: &ShapingMap, z: &[f64], start: &[f64], r0: f64) -> Result<ShapingFit> {
    let err = |source: FitError| Error::Fit {
        context: "shaping-filter fit",
        source,
    };
    let data = Series::new(z, 1).map_err(err)?;
    let fit = mle(map, map.theta_of(start, r0), &data, &MLE_OPTIONS).map_err(err)?;
    let values: Vec<f64> = fit.theta.iter().map(|t| t.exp()).collect();
    let std_errors = fit
        .uncertainty
        .std_errors
        .as_ref()
        .map(|se| se.iter().zip(&values).map(|(s, v)| s * v).collect());
    Ok(ShapingFit {
        values,
        std_errors,
        loglik: fit.loglik,
        converged: fit.converged,
        iterations: fit.iterations,
        message: fit.message,
    })
}

/// The classical estimate: the correlation function's parameters by least squares on the
/// sample autocovariance `ĉ_k` at lags 1..=`max_lag` (lag 0 left out: white measurement
/// noise sits there only), `Σ_k (ĉ_k − R(kΔt))²`, minimised over the log parameters by
/// Nelder–Mead from `start` (natural parameters).
///
/// # Errors
/// [`Error::TooFewSamples`] if the signal has fewer than `max_lag + 2` observed samples;
/// [`Error::Optimiser`] if Nelder–Mead fails; [`Error::NothingEvaluated`] if it ends without
/// a best point.
pub fn fit_acf(kind: Kind, z: &[f64], dt: f64, max_lag: usize, start: &[f64]) -> Result<Vec<f64>> {
    let observed: Vec<f64> = z.iter().copied().filter(|v| !v.is_nan()).collect();
    if observed.len() < max_lag + 2 || max_lag == 0 {
        return Err(Error::TooFewSamples {
            observed: observed.len(),
            lags: max_lag,
        });
    }
    let mean = observed.iter().sum::<f64>() / observed.len() as f64;
    let var = observed.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / observed.len() as f64;
    let rho = kalman::diagnostics::autocorrelation(z, max_lag);
    let c: Vec<f64> = rho.iter().map(|r| r * var).collect();
    let problem = AcfCost {
        kind,
        dt,
        c,
        scale: var.max(f64::MIN_POSITIVE),
    };
    let t0: Vec<f64> = start.iter().map(|v| v.ln()).collect();
    let mut simplex = vec![t0.clone()];
    for i in 0..t0.len() {
        let mut v = t0.clone();
        v[i] += 0.3;
        simplex.push(v);
    }
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(1e-10)
        .map_err(acf_error)?;
    let res = Executor::new(problem, solver)
        .configure(|s| s.max_iters(4000))
        .run()
        .map_err(acf_error)?;
    let best = res.state.best_param.ok_or(Error::NothingEvaluated {
        stage: "autocorrelation fit",
    })?;
    Ok(best.iter().map(|t| t.exp()).collect())
}

/// The optimiser's failure in the autocorrelation fit.
fn acf_error(source: argmin::core::Error) -> Error {
    Error::Optimiser {
        stage: "autocorrelation fit",
        source,
    }
}

struct AcfCost {
    kind: Kind,
    dt: f64,
    c: Vec<f64>,
    scale: f64,
}

impl CostFunction for AcfCost {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, t: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        let p: Vec<f64> = t.iter().map(|v| v.exp()).collect();
        let Ok(f) = self.kind.filter(&p) else {
            return Ok(f64::MAX);
        };
        let s: f64 = (1..self.c.len())
            .map(|k| ((self.c[k] - f.correlation(k as f64 * self.dt)) / self.scale).powi(2))
            .sum();
        Ok(if s.is_finite() { s } else { f64::MAX })
    }
}

#[cfg(test)]
mod tests;
