//! Learning a linear Gaussian state-space model from data: the exact log-likelihood by the
//! prediction-error decomposition, its exact gradient, parameterisations of `(F, H, Q, R,
//! x0, P0)`, maximum likelihood, EM, standard errors and information criteria.
//!
//! # The likelihood
//! For a series `z_0 … z_{N−1}` with the model of the crate (`(x0, P0)` the prior of the
//! first measurement), the Gaussian log-likelihood factors into one-step *prior*
//! innovations (Schweppe, "Evaluation of likelihood functions for Gaussian signals"):
//!
//! ```text
//! ln L = Σ_k −½ ( e_kᵀ Σ_k⁻¹ e_k + ln det Σ_k + m_k ln 2π ),
//! e_k = z_k − H x_{k|k−1},   Σ_k = H P_{k|k−1} Hᵀ + R,
//! ```
//!
//! over the `m_k` observed (non-NaN) entries of `z_k` only: a partially missing `z_k`
//! contributes the marginal density of its observed rows, an all-missing one nothing.
//! [`log_likelihood`] evaluates it with the crate's [`Filter`] (any [`CovarianceForm`]);
//! [`log_likelihood_gradient`] evaluates it together with its exact gradient by the score
//! recursion (the filter differentiated analytically, one `∂x`, `∂P` pair per parameter;
//! Gupta & Mehra, "Computational aspects of maximum likelihood estimation and reduction in
//! sensitivity function calculations"). The two agree to round-off.
//!
//! # Parameters
//! A [`ParamMap`] maps an unconstrained vector `θ` to a [`System`]. [`StandardMap`] frees
//! `Q` and `R` as [`Structure::Scalar`] (`σ²·I`), [`Structure::Diag`] or
//! [`Structure::Full`] (a Cholesky factor with log-diagonal, so every iterate is PSD),
//! optionally `x0` and a diagonal `P0`, and any number of [`Param`]s: a single entry of
//! `F`, `B`, `H`, `Q`, `R`, `x0` or `P0` ([`Param::entry`]: an AR coefficient, a scale
//! factor, a bias), or one value shared by several entries with a coefficient each
//! ([`Param::shared`]: the intensity of a constant-velocity model's whole `Q`), through a
//! [`Transform`] (identity, log for a variance, tanh for a bounded coefficient). Every
//! entry not freed keeps the base system's value exactly, and the exact gradient runs
//! through `∂F`, `∂B`, `∂H`, `∂Q`, `∂R`, `∂x0`, `∂P0` alike. Any other map (a shaping
//! filter's `σ, μ, ω`, a discretised continuous model at a given Δt) is a user type
//! implementing [`ParamMap`], or a closure in [`FnMap`] (derivatives supplied, or by
//! central differences).
//!
//! ```
//! use kalman::fit::{Free, Matrix, MleOptions, Param, Series, StandardMap, System, mle};
//! # fn main() -> Result<(), kalman::fit::FitError> {
//! // An AR(1) seen through noise: φ = F[0,0], Q[0,0] and R[0,0] free, from φ = 0.
//! let base = System::new(&[[0.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[1.0]])?;
//! let free = [Matrix::F, Matrix::Q, Matrix::R].map(|m| Param::entry(m, 0, 0)).to_vec();
//! let map = StandardMap::with_params(base.clone(), Free::default(), free)?;
//! let z: Vec<f64> = (0..200).map(|k| (0.3 * k as f64).sin() + 0.2 * (2.1 * k as f64).cos()).collect();
//! let data = Series::new(&z, 1)?;
//! let fit = mle(&map, map.theta_of(&base, Some(&data)), &data, &MleOptions::default())?;
//! let values = map.param_values(&fit.theta)?; // [("F[0,0]", φ̂), ("Q[0,0]", …), ("R[0,0]", …)]
//! assert_eq!(values[0].0, "F[0,0]");
//! assert!(values[0].1 > 0.5, "a slow sinusoid is a persistent AR(1)");
//! # Ok(())
//! # }
//! ```
//!
//! The same likelihood, maximised the same way, serves two more forms: a nonlinear model's
//! parameters through the EKF ([`filter_error()`], the filter-error method; with no process
//! noise [`output_error()`]), and a continuous model's noise over a record's own time stamps
//! ([`SampledMap`]). States with no prior at all take the exact diffuse initialisation
//! ([`mle_diffuse`], [`diffuse`]).
//!
//! The observed information gives the standard errors, the correlation matrix
//! ([`Uncertainty::correlation`]) and, when it is singular, the parameters spanning each
//! direction the data do not identify ([`Uncertainty::unidentified`], named in the message
//! too).
//!
//! # Estimators
//! - [`mle`] (feature `argmin`): L-BFGS on `−ln L` with the exact gradient, Nelder–Mead as a
//!   fallback when L-BFGS fails.
//! - [`em`]: Shumway & Stoffer's EM ("An approach to time series smoothing and forecasting
//!   using the EM algorithm"), the M-step in closed form from the RTS smoother with the
//!   lag-one cross-covariances, honouring the `Scalar`/`Diag`/`Fixed` constraints.
//!
//! Both return a [`Fit`]: estimate, log-likelihood, iterations, a convergence flag with its
//! message, the parameters found on a variance boundary, the observed-information standard
//! errors ([`observed_information`]) and AIC/BIC.
//!
//! # Example
//! ```
//! use kalman::fit::{Free, Series, StandardMap, Structure, System, em, EmOptions};
//! # fn main() -> Result<(), kalman::fit::FitError> {
//! // A local-level model: Q and R unknown, started from 1 and 1.
//! let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
//! let z = [0.3, 0.1, 0.9, 1.4, 1.2, 2.0, 1.7, 2.5, 2.2, 3.1, 2.9, 3.3];
//! let data = Series::new(&z, 1)?;
//! let map = StandardMap::new(base, Free { q: Structure::Diag, r: Structure::Diag, ..Free::default() })?;
//! let fit = em(&map, &data, &EmOptions::default())?;
//! assert!(fit.converged);
//! assert!(fit.system.q[(0, 0)] > 0.0 && fit.system.r[(0, 0)] > 0.0);
//! # Ok(())
//! # }
//! ```
#![allow(non_snake_case)]

mod dense;
#[cfg(all(feature = "autodiff", feature = "argmin"))]
pub mod diffuse;
mod em;
mod entries;
mod error;
#[cfg(all(feature = "autodiff", feature = "argmin"))]
pub mod filter_error;
mod free_names;
mod info;
#[cfg(feature = "argmin")]
mod mle;
#[cfg(feature = "autodiff")]
pub mod output_error;
mod params;
#[cfg(feature = "argmin")]
mod priors;
#[cfg(all(feature = "autodiff", feature = "argmin"))]
pub mod sampled;
mod score;

pub(crate) use crate::kernels::LN_2PI;
use faer::Mat;

#[cfg(all(feature = "autodiff", feature = "argmin"))]
pub use diffuse::{diffuse_log_likelihood, diffuse_log_likelihood_gradient, mle_diffuse};
pub use em::{EM_DECREMENT, EmOptions, check_identifiable, em, em_step, em_with_progress};
pub use entries::{Entry, Matrix, Param, Transform};
pub use error::{FitError, Interrupt};
#[cfg(all(feature = "autodiff", feature = "argmin"))]
pub use filter_error::{
    AtTheta, MAX_FIXED_PARAMS, ParametricFit, ParametricModel, ekf_log_likelihood,
    ekf_log_likelihood_gradient, filter_error,
};
pub use free_names::{FreeSpec, white_acceleration_q};
pub use info::{Fit, Method, NULL_EIGENVALUE, Uncertainty, aic, bic, observed_information};
#[cfg(feature = "argmin")]
pub use mle::{MleOptions, mle, mle_records};
#[cfg(feature = "autodiff")]
pub use output_error::{
    OutputErrorCost, OutputErrorFit, OutputErrorOptions, output_error, output_error_cost,
};
pub use params::{Derivative, FnMap, Free, MatrixStdErrors, ParamMap, StandardMap, Structure};
#[cfg(feature = "argmin")]
pub use priors::{Prior, mle_records_with_priors};
#[cfg(all(feature = "autodiff", feature = "argmin"))]
pub use sampled::SampledMap;
pub use score::log_likelihood_gradient;

use crate::{CovarianceForm, DynDims, Filter, MatrixInput, Model};

/// A complete linear Gaussian model with its prior: `x_{k+1} = F x_k + B u_k + w_k`,
/// `z_k = H x_k + v_k`, `w ~ N(0, Q)`, `v ~ N(0, R)`, `x_0 ~ N(x0, P0)`.
///
/// # Example
/// ```
/// use kalman::CovarianceForm;
/// use kalman::fit::{Series, System, log_likelihood};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // One state, one observation z = 1, prior N(0, 1), R = 1: z ~ N(0, 2) exactly.
/// let sys = System::new(&[[1.0]], &[[1.0]], &[[0.0]], &[[1.0]], &[0.0], &[[1.0]])?;
/// let z = [1.0];
/// let ll = log_likelihood(&sys, &Series::new(&z, 1)?, CovarianceForm::Joseph)?;
/// let exact = -0.5 * ((2.0 * std::f64::consts::PI).ln() + 2.0_f64.ln() + 0.5);
/// assert!((ll - exact).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct System {
    /// Transition (n×n).
    pub f: Mat<f64>,
    /// Measurement (m×n).
    pub h: Mat<f64>,
    /// Process noise covariance (n×n).
    pub q: Mat<f64>,
    /// Measurement noise covariance (m×m).
    pub r: Mat<f64>,
    /// Control matrix (n×p; p = 0 without input).
    pub b: Mat<f64>,
    /// Prior mean of the first state (length n).
    pub x0: Vec<f64>,
    /// Prior covariance of the first state (n×n).
    pub p0: Mat<f64>,
}

fn to_mat(
    name: &'static str,
    a: &impl MatrixInput,
    r: usize,
    c: usize,
) -> Result<Mat<f64>, FitError> {
    crate::model::check(name, a, r, c)?;
    Ok(Mat::from_fn(r, c, |i, j| a.at(i, j)))
}

impl System {
    /// A system without control input. Shapes and finiteness are checked here; symmetry and
    /// PSD of `Q`, `R`, `P0` when a filter is built from it.
    ///
    /// # Errors
    /// [`FitError::Model`] with a shape or non-finite error naming the matrix.
    pub fn new(
        F: &impl MatrixInput,
        H: &impl MatrixInput,
        Q: &impl MatrixInput,
        R: &impl MatrixInput,
        x0: &[f64],
        P0: &impl MatrixInput,
    ) -> Result<Self, FitError> {
        let n = F.nrows();
        let m = H.nrows();
        if n == 0 || m == 0 {
            return Err(crate::Error::Dimension {
                name: if n == 0 { "n" } else { "m" },
                value: 0,
                rule: "must be at least 1",
            }
            .into());
        }
        let x0v = to_mat("x0", &Mat::from_fn(x0.len(), 1, |i, _| x0[i]), n, 1)?;
        Ok(Self {
            f: to_mat("F", F, n, n)?,
            h: to_mat("H", H, m, n)?,
            q: to_mat("Q", Q, n, n)?,
            r: to_mat("R", R, m, m)?,
            b: Mat::zeros(n, 0),
            x0: (0..n).map(|i| x0v[(i, 0)]).collect(),
            p0: to_mat("P0", P0, n, n)?,
        })
    }

    /// Adds the control matrix `B` (n×p).
    ///
    /// # Errors
    /// [`FitError::Model`] naming `B`.
    pub fn with_control(mut self, B: &impl MatrixInput) -> Result<Self, FitError> {
        self.b = to_mat("B", B, self.n(), B.ncols())?;
        Ok(self)
    }

    /// Number of states.
    pub fn n(&self) -> usize {
        self.f.nrows()
    }
    /// Number of measurements.
    pub fn m(&self) -> usize {
        self.h.nrows()
    }
    /// Number of control inputs.
    pub fn p(&self) -> usize {
        self.b.ncols()
    }

    /// The crate's validated [`Model`] of this system.
    ///
    /// # Errors
    /// As [`Model::new`] (e.g. an indefinite `Q`).
    pub fn model(&self) -> Result<Model<DynDims>, crate::Error> {
        self.model_on(DynDims::new(self.n(), self.m(), self.p())?)
    }

    /// [`System::model`] on the storage path `dims` (whose n, m, p must match).
    ///
    /// # Errors
    /// As [`Model::new`].
    pub fn model_on<D: crate::Dims>(&self, dims: D) -> Result<Model<D>, crate::Error> {
        let model = Model::new(dims, &self.f, &self.h, &self.q, &self.r)?;
        if self.p() > 0 {
            model.with_control(&self.b)
        } else {
            Ok(model)
        }
    }
}

/// A recorded series: `N` measurement vectors of length `m` (row-major, NaN = missing) and
/// optionally `N` input vectors of length `p`.
///
/// # Example
/// ```
/// use kalman::CovarianceForm;
/// use kalman::fit::{Series, System, log_likelihood};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // One state, one observation z = 1, prior N(0, 1), R = 1: z ~ N(0, 2) exactly.
/// let sys = System::new(&[[1.0]], &[[1.0]], &[[0.0]], &[[1.0]], &[0.0], &[[1.0]])?;
/// let z = [1.0];
/// let ll = log_likelihood(&sys, &Series::new(&z, 1)?, CovarianceForm::Joseph)?;
/// let exact = -0.5 * ((2.0 * std::f64::consts::PI).ln() + 2.0_f64.ln() + 0.5);
/// assert!((ll - exact).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Series<'a> {
    z: &'a [f64],
    m: usize,
    u: &'a [f64],
    p: usize,
    len: usize,
}

impl<'a> Series<'a> {
    /// A series of `z.len() / m` measurement vectors, row `k` being `z[k·m .. (k+1)·m]`.
    ///
    /// # Errors
    /// [`FitError::Data`] if `m` is 0 or does not divide `z.len()`, or an entry is infinite;
    /// [`FitError::NoMeasurements`] if every entry is NaN (or the series is empty).
    pub fn new(z: &'a [f64], m: usize) -> Result<Self, FitError> {
        if m == 0 || z.len() % m != 0 {
            return Err(FitError::Data(format!(
                "{} measurement values do not form rows of length m = {m}",
                z.len()
            )));
        }
        if let Some(i) = z.iter().position(|v| v.is_infinite()) {
            return Err(FitError::Data(format!(
                "z has an infinite entry at step {}, row {}",
                i / m,
                i % m
            )));
        }
        let s = Self {
            z,
            m,
            u: &[],
            p: 0,
            len: z.len() / m,
        };
        if s.observed() == 0 {
            return Err(FitError::NoMeasurements);
        }
        Ok(s)
    }

    /// Adds the known inputs: `u.len() = len()·p`, row-major, all finite.
    ///
    /// # Errors
    /// [`FitError::Data`] for a wrong length or a non-finite entry.
    pub fn with_inputs(mut self, u: &'a [f64], p: usize) -> Result<Self, FitError> {
        if u.len() != self.len * p {
            return Err(FitError::Data(format!(
                "u has {} values, expected {} steps × p = {p}",
                u.len(),
                self.len
            )));
        }
        if let Some(i) = u.iter().position(|v| !v.is_finite()) {
            return Err(FitError::Data(format!(
                "u has a non-finite entry at step {}, row {}",
                i / p,
                i % p
            )));
        }
        self.u = u;
        self.p = p;
        Ok(self)
    }

    /// Number of time steps N.
    pub fn len(&self) -> usize {
        self.len
    }
    /// Whether the series has no step (never true for a constructed series).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
    /// Measurement dimension m.
    pub fn m(&self) -> usize {
        self.m
    }
    /// Input dimension p (0 without inputs).
    pub fn p(&self) -> usize {
        self.p
    }
    /// Measurement vector `z_k`.
    pub fn z(&self, k: usize) -> &'a [f64] {
        &self.z[k * self.m..(k + 1) * self.m]
    }
    /// Input vector `u_k` (empty without inputs).
    pub fn u(&self, k: usize) -> &'a [f64] {
        &self.u[k * self.p..(k + 1) * self.p]
    }
    /// Number of observed (non-NaN) scalar measurements.
    pub fn observed(&self) -> usize {
        self.z.iter().filter(|v| !v.is_nan()).count()
    }

    pub(crate) fn check(&self, sys: &System) -> Result<(), FitError> {
        if sys.m() != self.m {
            return Err(FitError::Data(format!(
                "the data have m = {} measurement columns, the model H has {} rows",
                self.m,
                sys.m()
            )));
        }
        if sys.p() != self.p && !(self.p == 0 && sys.p() > 0) {
            return Err(FitError::Data(format!(
                "the data have p = {} input columns, the model B has {} columns",
                self.p,
                sys.p()
            )));
        }
        Ok(())
    }
}

/// The exact Gaussian log-likelihood of `data` under `sys`, from the prior innovations of
/// the crate's [`Filter`] in the covariance form `form` (the sum of
/// [`crate::StepInfo::log_likelihood`]; a singular innovation covariance uses its
/// pseudo-determinant over its rank).
///
/// # Errors
/// [`FitError::Model`] if `sys` is not a valid model or prior; [`FitError::Data`] if the
/// data's dimensions do not match.
///
/// # Example
/// ```
/// use kalman::CovarianceForm;
/// use kalman::fit::{Series, System, log_likelihood};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // One state, one observation z = 1, prior N(0, 1), R = 1: z ~ N(0, 2) exactly.
/// let sys = System::new(&[[1.0]], &[[1.0]], &[[0.0]], &[[1.0]], &[0.0], &[[1.0]])?;
/// let z = [1.0];
/// let ll = log_likelihood(&sys, &Series::new(&z, 1)?, CovarianceForm::Joseph)?;
/// let exact = -0.5 * ((2.0 * std::f64::consts::PI).ln() + 2.0_f64.ln() + 0.5);
/// assert!((ll - exact).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
pub fn log_likelihood(
    sys: &System,
    data: &Series<'_>,
    form: CovarianceForm,
) -> Result<f64, FitError> {
    data.check(sys)?;
    let mut filter = Filter::new(sys.model()?, &sys.x0, &sys.p0, form)?;
    let mut ll = 0.0;
    for k in 0..data.len() {
        let u = if data.p() > 0 { Some(data.u(k)) } else { None };
        ll += filter.step(data.z(k), u)?.log_likelihood;
    }
    Ok(ll)
}

/// Column-major copy of a faer matrix.
pub(crate) fn flat(a: &Mat<f64>) -> Vec<f64> {
    let mut v = Vec::with_capacity(a.nrows() * a.ncols());
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            v.push(a[(i, j)]);
        }
    }
    v
}
