//! Output-error maximum likelihood (feature `autodiff`): unknown initial-state entries of a
//! deterministic nonlinear model — instrument biases and scale factors carried as constant
//! states, initial positions and velocities — fitted to a record by Gauss–Newton with
//! Levenberg–Marquardt damping, the sensitivities by forward-mode AD, with the Cramér–Rao
//! bounds and the correlation matrix.
//!
//! # The estimator
//! The model is a [`GenericModel`] integrated without process noise, its `f` driven by the
//! known inputs `u_k` (an IMU's readings), from the initial state `x0` whose entries `free`
//! form the parameter vector θ. With the crate's step convention (step k compares `z_k`
//! with `h(x_k, k)`, then predicts with `f(x_k, u_k, k)`):
//!
//! ```text
//! x_0 = x0(θ),   x_{k+1} = f(x_k, u_k, k),   y_k = h(x_k, k),   e_k = z_k − y_k,
//! J(θ) = ½ Σ_k e_kᵀ R_k⁻¹ e_k                      (observed rows of z_k only),
//! S_k = ∂y_k/∂θ,   M = Σ_k S_kᵀ R_k⁻¹ S_k,   g = Σ_k S_kᵀ R_k⁻¹ e_k = −∇J,
//! θ ← θ + δ,   (M + λ·diag M) δ = g.
//! ```
//!
//! `J` is the negative log-likelihood of Gaussian measurement noise up to a constant, so
//! its minimiser is the maximum-likelihood estimate; `M` is the Fisher information (for a
//! deterministic model the Gauss–Newton matrix *is* the expected information), and
//! `M⁻¹` is the Cramér–Rao bound on the covariance of θ̂. Column j of every `S_k` is the
//! derivative part of one pass over the record in [`num_dual::Dual64`] with the seed
//! `∂x_0/∂θ_j = e_{free[j]}`: exact to round-off, one pass per free entry, the p passes run
//! in lockstep so nothing of size N is stored. The same passes give `g`, so the gradient
//! `∇J = −g` is exact too ([`output_error_cost`] returns it).
//!
//! Each iteration first tries the Gauss–Newton step (λ = 0); when it does not decrease `J`
//! (or the integration from the trial point diverges), λ rises tenfold from 10⁻³ until a
//! step does (Marquardt, "An algorithm for least-squares estimation of nonlinear
//! parameters", 1963), and falls tenfold after each success. Every linear system is solved
//! in the Jacobi-scaled form `D⁻¹ M D⁻¹` (`D = diag(M)^½`, so parameters in metres and in
//! parts per million are treated alike) by a Cholesky factorisation; no matrix is inverted
//! except the covariance itself, which is the factorisation solved against the identity.
//!
//! **Convergence.** The Gauss–Newton step's length in Cramér–Rao standard deviations,
//! `√(δᵀ M δ)`, is at most [`OutputErrorOptions::tolerance`]. Near the optimum the decrease
//! a step predicts, `½ δᵀ M δ`, falls below the round-off of `J` itself (`10⁻¹²·J`), and
//! comparing costs can no longer judge it: such a step is taken as it is, so the iteration
//! goes on to the tolerance rather than stopping where the cost stops resolving. The fit is
//! stopped, unconverged, at the iteration cap or when no damping decreases `J`.
//!
//! **Estimating R** ([`OutputErrorOptions::estimate_r`]): the relaxation of Maine & Iliff and
//! of SIDPAC's `oe.m`: before every Gauss–Newton step `R` is set to the diagonal of the
//! residuals' mean squares at the current θ, `R_ii = Σ_k e_{k,i}² / N_i` over the `N_i`
//! observed entries of channel i (the maximiser of the likelihood in a diagonal R for that
//! θ), and the step is taken with that `R`. Each of the two moves lowers the concentrated
//! likelihood `Σ_i N_i ln R_ii`, and a step of zero length under the `R` of its own
//! residuals is a stationary point of it, so the convergence test above needs nothing
//! more. The `R_k` of the model are then used only for a channel with no observation.
//!
//! **Errors.** Shapes of `z`, `u` and `x0` against the dimensions, free indices out of range
//! or repeated, a record with no finite measurement, an `R_k` that is not positive definite
//! on the rows observed at step k, a state, output or sensitivity that is not finite (named
//! with the step where the integration diverged), and a Fisher information that is singular
//! (the parameters spanning each direction the data do not identify are named, as
//! [`super::Uncertainty::unidentified`] names them for [`super::mle`]).
//!
//! The bounds assume white measurement noise and an exact model. Real flight residuals are
//! coloured (turbulence, unmodelled dynamics), and then the Cramér–Rao bounds are
//! optimistic, often by a factor of 2–5 (Morelli & Klein, *Aircraft System
//! Identification*, ch. 6 and 10; Jategaonkar, *Flight Vehicle System Identification*,
//! ch. 4 and 10; Maine & Iliff, "Application of parameter estimation to aircraft stability
//! and control: the output-error approach", NASA RP-1168).
//!
//! # Example
//! ```
//! use kalman::DynDims;
//! use kalman::faer::Mat;
//! use kalman::fit::{OutputErrorOptions, output_error};
//! use kalman::nonlinear::{GenericModel, Scalar};
//!
//! /// Position from a biased accelerometer: x = (position, velocity, bias), u = reading.
//! struct Biased;
//! const DT: f64 = 0.1;
//! impl GenericModel for Biased {
//!     fn f<T: Scalar>(&self, x: &[T], u: Option<&[f64]>, _k: usize, out: &mut [T]) {
//!         let a = -x[2] + u.map_or(0.0, |u| u[0]);
//!         out[0] = x[0] + x[1] * DT;
//!         out[1] = x[1] + a * DT;
//!         out[2] = x[2];
//!     }
//!     fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
//!         out[0] = x[0];
//!     }
//!     fn q(&self, _k: usize, out: &mut [f64]) { out.fill(0.0); }
//!     fn r(&self, _k: usize, out: &mut [f64]) { out[0] = 0.01; }
//! }
//! # fn main() -> Result<(), kalman::fit::FitError> {
//! // The vehicle is at rest; the accelerometer reads 0.2 (its bias), so the integration
//! // drifts by −0.1 t² unless the bias is estimated.
//! let n = 50;
//! let u = Mat::from_fn(n, 1, |_, _| 0.2);
//! let z = Mat::from_fn(n, 1, |k, _| 0.01 * (1.7 * k as f64).sin()); // small "noise"
//! let fit = output_error(&Biased, DynDims::new(3, 1, 1)?, &[0.0, 0.0, 0.0], &[1, 2],
//!     z.as_ref(), Some(u.as_ref()), &OutputErrorOptions::default())?;
//! assert!(fit.converged);
//! assert!((fit.estimate[1] - 0.2).abs() < 3.0 * fit.std[1]); // the bias, within its bound
//! assert!(fit.correlation[(0, 1)].abs() < 1.0);
//! # Ok(())
//! # }
//! ```

mod record;

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, Side};

use super::FitError;
use super::info::{NULL_EIGENVALUE, correlation, directions_text, unidentified};
use crate::nonlinear::GenericModel;
use crate::storage::Dims;
use record::{Problem, Weights, combine, cost_of, mean_squares, not_finite};

/// Options of [`output_error`].
///
/// ```
/// use kalman::fit::OutputErrorOptions;
/// let relaxed = OutputErrorOptions { estimate_r: true, ..OutputErrorOptions::default() };
/// assert_eq!(relaxed.max_iterations, 100);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutputErrorOptions {
    /// Gauss–Newton iterations at most (each one accepted step).
    pub max_iterations: usize,
    /// Convergence: the Gauss–Newton step's length in Cramér–Rao standard deviations,
    /// `√(δᵀ M δ)` (see the module documentation).
    pub tolerance: f64,
    /// Re-estimate R as the diagonal of the residuals' mean squares before every step
    /// (the relaxation of Maine & Iliff); otherwise the model's `R_k` weigh the residuals.
    pub estimate_r: bool,
}

impl Default for OutputErrorOptions {
    /// 100 iterations, a step of 10⁻⁶ standard deviations, R from the model.
    fn default() -> Self {
        Self {
            max_iterations: 100,
            tolerance: 1e-6,
            estimate_r: false,
        }
    }
}

/// The result of [`output_error`].
///
/// ```
/// use kalman::DynDims;
/// use kalman::faer::Mat;
/// use kalman::fit::{OutputErrorOptions, output_error};
/// use kalman::nonlinear::{GenericModel, Scalar};
/// /// x_{k+1} = 0.9 x_k, measured directly with R = 0.01.
/// struct Decay;
/// impl GenericModel for Decay {
///     fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
///         out[0] = x[0] * 0.9;
///     }
///     fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) { out[0] = x[0]; }
///     fn q(&self, _k: usize, out: &mut [f64]) { out[0] = 0.0; }
///     fn r(&self, _k: usize, out: &mut [f64]) { out[0] = 0.01; }
/// }
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let z = Mat::from_fn(20, 1, |k, _| 3.0 * 0.9_f64.powi(k as i32));
/// let fit = output_error(&Decay, DynDims::new(1, 1, 0)?, &[1.0], &[0], z.as_ref(), None,
///     &OutputErrorOptions::default())?;
/// // Linear in x0: one Gauss–Newton step lands on it; σ² = R / Σ 0.81^k.
/// assert!((fit.x0[0] - 3.0).abs() < 1e-12 && fit.iterations == 1);
/// let info: f64 = (0..20).map(|k| 0.81_f64.powi(k) / 0.01).sum();
/// assert!((fit.covariance[(0, 0)] * info - 1.0).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct OutputErrorFit {
    /// The initial state with the free entries at their estimates (length n).
    pub x0: Vec<f64>,
    /// The free entries, in the order of `free`.
    pub estimate: Vec<f64>,
    /// The Cramér–Rao bound `M⁻¹` on the covariance of the estimate (symmetric).
    pub covariance: Mat<f64>,
    /// The standard errors (square roots of the covariance's diagonal).
    pub std: Vec<f64>,
    /// The correlation matrix `cov_ij / (std_i std_j)`.
    pub correlation: Mat<f64>,
    /// The diagonal of R at convergence (length m): estimated, or the model's `R_0`.
    pub r: Vec<f64>,
    /// `J = ½ Σ e_kᵀ R_k⁻¹ e_k` at the estimate (with the estimated R when it is estimated).
    pub cost: f64,
    /// Gauss–Newton steps taken.
    pub iterations: usize,
    /// Whether the convergence test was met (not merely the iteration cap or a stall).
    pub converged: bool,
    /// The Fisher information `M = Σ S_kᵀ R_k⁻¹ S_k` at the estimate.
    pub information: Mat<f64>,
    /// Number of observed scalar measurements.
    pub n_obs: usize,
}

/// The cost `J`, its exact gradient `∇J` and the Fisher information `M` at one θ
/// ([`output_error_cost`], whose example shows one).
#[derive(Clone, Debug)]
pub struct OutputErrorCost {
    /// `J = ½ Σ e_kᵀ R_k⁻¹ e_k`.
    pub cost: f64,
    /// `∇J = −Σ S_kᵀ R_k⁻¹ e_k`, in the order of `free`.
    pub gradient: Vec<f64>,
    /// `M = Σ S_kᵀ R_k⁻¹ S_k`.
    pub information: Mat<f64>,
}

/// The Jacobi-scaled information `D⁻¹ M D⁻¹` and the scales `D` (1 where `M_jj` is zero),
/// refused when singular, naming the parameters of each direction the data do not identify.
fn scaled(info: &Mat<f64>, names: &[String]) -> Result<(Mat<f64>, Vec<f64>), FitError> {
    let p = info.nrows();
    let d: Vec<f64> = (0..p)
        .map(|j| {
            let v = info[(j, j)];
            if v > 0.0 && v.is_finite() {
                v.sqrt()
            } else {
                1.0
            }
        })
        .collect();
    let ms = Mat::from_fn(p, p, |i, j| {
        if info[(i, i)] > 0.0 && info[(j, j)] > 0.0 {
            info[(i, j)] / (d[i] * d[j])
        } else {
            0.0
        }
    });
    let mut a = super::flat(&ms);
    let mut v = vec![0.0; p * p];
    let mut w = vec![0.0; p];
    crate::kernels::jacobi_eigen(&mut a, p, &mut v, &mut w);
    let top = w.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
    let low = w.iter().fold(f64::INFINITY, |a, &x| a.min(x));
    if low.is_nan() || low <= NULL_EIGENVALUE * top || ms.llt(Side::Lower).is_err() {
        let dirs = unidentified(&ms, names);
        let mut what: Vec<String> = dirs.iter().flatten().map(|(n, _)| n.clone()).collect();
        what.sort();
        what.dedup();
        return Err(FitError::NotIdentifiable {
            what: what.join(", "),
            why: format!(
                "the Fisher information is singular (smallest eigenvalue of its Jacobi-scaled form {low:.1e} of the largest): the data do not identify the direction(s) {} of θ",
                directions_text(&dirs)
            ),
        });
    }
    Ok((ms, d))
}

/// The step `δ` solving `(M + λ diag M) δ = g` in the scaled form (`None` if the damped
/// matrix is not positive definite, which a checked `ms` never is).
fn step(ms: &Mat<f64>, d: &[f64], g: &[f64], lambda: f64) -> Option<Vec<f64>> {
    let p = ms.nrows();
    let a = Mat::from_fn(p, p, |i, j| ms[(i, j)] + if i == j { lambda } else { 0.0 });
    let llt = a.llt(Side::Lower).ok()?;
    let rhs = Mat::from_fn(p, 1, |i, _| g[i] / d[i]);
    let y = llt.solve(&rhs);
    Some((0..p).map(|i| y[(i, 0)] / d[i]).collect())
}

/// The Cramér–Rao covariance `M⁻¹ = D⁻¹ (D⁻¹ M D⁻¹)⁻¹ D⁻¹`, from the Cholesky factor of the
/// scaled information solved against the identity, symmetrised.
fn covariance(ms: &Mat<f64>, d: &[f64]) -> Option<Mat<f64>> {
    let p = ms.nrows();
    let llt = ms.llt(Side::Lower).ok()?;
    let inv = llt.solve(Mat::<f64>::identity(p, p));
    Some(Mat::from_fn(p, p, |i, j| {
        0.5 * (inv[(i, j)] + inv[(j, i)]) / (d[i] * d[j])
    }))
}

fn theta_of(x0: &[f64], free: &[usize]) -> Vec<f64> {
    free.iter().map(|&i| x0[i]).collect()
}

/// The output-error cost `J`, its exact gradient and the Fisher information at the
/// initial state `x0` (the parameters being its entries `free`), weighed by the model's
/// `R_k`. See the [module documentation](self) for the equations.
///
/// # Errors
/// As [`output_error`], except that a singular information is returned, not refused.
///
/// # Example
/// ```
/// use kalman::DynDims;
/// use kalman::faer::Mat;
/// use kalman::fit::output_error_cost;
/// use kalman::nonlinear::{GenericModel, Scalar};
/// struct Decay;
/// impl GenericModel for Decay {
///     fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
///         out[0] = x[0] * 0.5;
///     }
///     fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) { out[0] = x[0]; }
///     fn q(&self, _k: usize, out: &mut [f64]) { out[0] = 0.0; }
///     fn r(&self, _k: usize, out: &mut [f64]) { out[0] = 1.0; }
/// }
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // y_k = 0.5^k x0, z = 0: J = ½ x0² Σ 0.25^k, M = Σ 0.25^k (two steps: 1.25).
/// let z = Mat::<f64>::zeros(2, 1);
/// let c = output_error_cost(&Decay, DynDims::new(1, 1, 0)?, &[2.0], &[0], z.as_ref(), None)?;
/// assert!((c.cost - 2.5).abs() < 1e-14 && (c.gradient[0] - 2.5).abs() < 1e-14);
/// assert!((c.information[(0, 0)] - 1.25).abs() < 1e-14);
/// # Ok(())
/// # }
/// ```
pub fn output_error_cost<G: GenericModel>(
    model: &G,
    dims: impl Dims,
    x0: &[f64],
    free: &[usize],
    measurements: MatRef<'_, f64>,
    inputs: Option<MatRef<'_, f64>>,
) -> Result<OutputErrorCost, FitError> {
    let problem = Problem::new(model, dims, x0, free, measurements, inputs)?;
    let theta = theta_of(x0, free);
    let groups = problem.pass(&theta, &Weights::Model, true)?;
    let (cost, information, g) = combine(&groups, &Weights::Model, free.len());
    Ok(OutputErrorCost {
        cost,
        gradient: g.iter().map(|v| -v).collect(),
        information,
    })
}

/// Output-error maximum likelihood of the entries `free` of the initial state `x0`: the
/// model integrated deterministically from `x0` with the inputs `u_k` (the rows of
/// `inputs`, N×p), its outputs compared with the measurements `z_k` (the rows of
/// `measurements`, N×m, NaN = not sampled), fitted by damped Gauss–Newton with the
/// sensitivities by forward-mode AD. The [module documentation](self) has the equations,
/// the convergence test, the relaxation for R and an example.
///
/// # Errors
/// - [`FitError::Model`] with [`crate::Error::Shape`] naming `x0`, `z` or `u` of the wrong
///   shape (`u` is required when `dims` has p > 0), or [`crate::Error::NonFinite`] naming
///   `x0` or `u`;
/// - [`FitError::NothingFree`] for an empty `free`, [`FitError::Parameters`] for an index
///   out of range or repeated;
/// - [`FitError::Data`] for an infinite entry of `z`, [`FitError::NoMeasurements`] when
///   every entry is NaN;
/// - [`FitError::NotPositiveDefinite`] naming `R` and the step whose observed block of
///   `R_k` is not positive definite;
/// - [`FitError::Model`] with [`crate::Error::Diverged`] naming the quantity (state,
///   output, residual, sensitivity), its value and the step where the integration from the
///   starting point diverged (a trial point that diverges is a rejected step, not an error);
/// - [`FitError::NotIdentifiable`] naming the parameters spanning each direction of a
///   singular Fisher information (or a channel whose residuals vanish when R is
///   estimated).
pub fn output_error<G: GenericModel>(
    model: &G,
    dims: impl Dims,
    x0: &[f64],
    free: &[usize],
    measurements: MatRef<'_, f64>,
    inputs: Option<MatRef<'_, f64>>,
    options: &OutputErrorOptions,
) -> Result<OutputErrorFit, FitError> {
    let problem = Problem::new(model, dims, x0, free, measurements, inputs)?;
    let p = free.len();
    let names = problem.names();
    let fallback = problem.model_r_diag();
    let mut theta = theta_of(x0, free);
    let mut weights = if options.estimate_r {
        Weights::Diag(vec![1.0; problem.m])
    } else {
        Weights::Model
    };
    let mut groups = problem.pass(&theta, &weights, true)?;
    let mut lambda = 0.0_f64;
    let mut iterations = 0;
    let mut converged = false;
    loop {
        if options.estimate_r {
            weights = Weights::Diag(mean_squares(&groups, &fallback)?);
        }
        let (cost, info, g) = combine(&groups, &weights, p);
        if !cost.is_finite() {
            return Err(not_finite("the cost J", problem.len() - 1, cost));
        }
        let (ms, d) = scaled(&info, &names)?;
        let Some(gn) = step(&ms, &d, &g, 0.0) else {
            break;
        };
        let decrement: f64 = gn.iter().zip(&g).map(|(a, b)| a * b).sum::<f64>().max(0.0);
        if decrement.sqrt() <= options.tolerance {
            converged = true;
            break;
        }
        if iterations >= options.max_iterations {
            break;
        }
        // Damped trials until one lowers J under the current weights; a step whose
        // predicted decrease J cannot resolve is taken as it is.
        let mut accepted = None;
        if 0.5 * decrement <= UNRESOLVED * cost {
            lambda = 0.0;
            accepted = Some(theta.iter().zip(&gn).map(|(t, s)| t + s).collect());
        }
        while accepted.is_none() && lambda <= MAX_DAMPING {
            let delta = if lambda > 0.0 {
                step(&ms, &d, &g, lambda)
            } else {
                Some(gn.clone())
            };
            if let Some(delta) = delta {
                let trial: Vec<f64> = theta.iter().zip(&delta).map(|(t, s)| t + s).collect();
                let trial_cost = match problem.pass(&trial, &weights, false) {
                    Ok(gr) => cost_of(&gr, &weights),
                    Err(FitError::Model(crate::Error::Diverged { .. })) => f64::INFINITY,
                    Err(e) => return Err(e),
                };
                if trial_cost <= cost {
                    accepted = Some(trial);
                    break;
                }
            }
            lambda = if lambda > 0.0 {
                lambda * 10.0
            } else {
                MIN_DAMPING
            };
        }
        let Some(trial) = accepted else {
            break;
        };
        iterations += 1;
        lambda = if lambda > MIN_DAMPING {
            lambda / 10.0
        } else {
            0.0
        };
        theta = trial;
        groups = problem.pass(&theta, &weights, true)?;
    }
    let (cost, information, _) = combine(&groups, &weights, p);
    let (ms, d) = scaled(&information, &names)?;
    let covariance = covariance(&ms, &d).ok_or_else(|| FitError::NotIdentifiable {
        what: names.join(", "),
        why: "the Fisher information is not positive definite".into(),
    })?;
    let std: Vec<f64> = (0..p).map(|i| covariance[(i, i)].max(0.0).sqrt()).collect();
    let correlation = correlation(&covariance).unwrap_or_else(|| Mat::identity(p, p));
    let mut x0_fit = x0.to_vec();
    for (&i, &t) in free.iter().zip(&theta) {
        x0_fit[i] = t;
    }
    let r = match &weights {
        Weights::Diag(r) => r.clone(),
        Weights::Model => fallback,
    };
    Ok(OutputErrorFit {
        x0: x0_fit,
        estimate: theta,
        covariance,
        std,
        correlation,
        r,
        cost,
        iterations,
        converged,
        information,
        n_obs: problem.n_obs(),
    })
}

/// A predicted decrease below this fraction of J is below what J's round-off resolves
/// (sums of thousands of squares carry errors of ~10⁻¹³ of J): such a step is taken without
/// comparing costs. In standard deviations it is at most `√(2·10⁻¹²·J)`, 2·10⁻⁵ at J = 200.
const UNRESOLVED: f64 = 1e-12;
/// The first Levenberg–Marquardt damping tried after a Gauss–Newton step fails.
const MIN_DAMPING: f64 = 1e-3;
/// The damping beyond which the fit stops as stalled (the step is then ~10⁻¹⁰ of the
/// gradient-descent step in scaled units: nothing a larger λ could still find).
const MAX_DAMPING: f64 = 1e10;
