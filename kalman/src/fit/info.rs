//! What a fit returns: the estimate with its log-likelihood, convergence and boundary
//! flags, the observed information and standard errors, AIC and BIC.

use faer::Mat;

use super::dense::{lower_factor, solve_each_column};
use super::params::data_scale;
use super::score::log_likelihood_gradient;
use super::{FitError, ParamMap, Series, System};

/// The estimator that produced a [`Fit`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Maximum likelihood by L-BFGS (Nelder–Mead fallback).
    Mle,
    /// Expectation–maximisation (Shumway–Stoffer).
    Em,
}

/// The result of the estimators `mle` and `em` of this module.
#[derive(Clone, Debug)]
pub struct Fit {
    /// The estimator.
    pub method: Method,
    /// The parameter vector at the optimum.
    pub theta: Vec<f64>,
    /// The fitted system.
    pub system: System,
    /// The exact Gaussian log-likelihood at the optimum (with the `−½ m_k ln 2π` terms).
    pub loglik: f64,
    /// Optimiser iterations (EM: E/M cycles).
    pub iterations: usize,
    /// Whether the estimator met its convergence test.
    pub converged: bool,
    /// What happened, in words (and what to try when not converged).
    pub message: String,
    /// Names of the parameters whose variance sits on the boundary (numerically zero): the
    /// optimum is on the edge of the parameter space and their standard errors are not
    /// meaningful.
    pub boundary: Vec<String>,
    /// The observed information and what it says about θ.
    pub uncertainty: Uncertainty,
    /// Number of observed scalar measurements.
    pub n_obs: usize,
    /// Akaike's information criterion `2k − 2 ln L`.
    pub aic: f64,
    /// The Bayesian information criterion `k ln(n_obs) − 2 ln L`.
    pub bic: f64,
}

/// What the observed information at an optimum says about θ: its inverse, the standard
/// errors and correlations, or, when it is singular, the directions the data do not identify.
/// [`Fit`] and [`super::ParametricFit`] carry one.
///
/// ```
/// use kalman::fit::{EmOptions, Free, Series, StandardMap, Structure, System, em};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let free = Free { q: Structure::Scalar, r: Structure::Scalar, ..Free::default() };
/// let map = StandardMap::new(base, free)?;
/// let z = [0.3, 1.1, 0.8, 1.9, 2.4, 2.2, 3.1, 3.9, 3.5, 4.2, 4.0, 4.9, 5.6, 5.1];
/// let fit = em(&map, &Series::new(&z, 1)?, &EmOptions::default())?;
/// let u = &fit.uncertainty;
/// if let (Some(cov), Some(se)) = (&u.covariance, &u.std_errors) {
///     // The standard errors are the square roots of the covariance's diagonal.
///     assert!((se[0] * se[0] - cov[(0, 0)]).abs() <= 1e-12 * cov[(0, 0)]);
/// } else {
///     assert!(!u.unidentified.is_empty()); // a singular information names its directions
/// }
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct Uncertainty {
    /// The observed information `−∇² ln L` at the optimum (`n_params`²).
    pub information: Mat<f64>,
    /// The covariance of θ, the inverse of the observed information, or `None` when that
    /// is not positive definite (a flat direction: a parameter the data do not identify).
    pub covariance: Option<Mat<f64>>,
    /// The standard errors of θ (square roots of the covariance's diagonal).
    pub std_errors: Option<Vec<f64>>,
    /// The correlation matrix of θ (`cov_ij / (se_i se_j)`), `None` with the covariance.
    /// To first order it is also the correlation of the parameters' values `v_i(θ_i)` (each
    /// transform is monotone, so the delta method rescales rows and columns only).
    pub correlation: Option<Mat<f64>>,
    /// When the observed information is singular: one entry per direction it does not
    /// identify (an eigenvector of an eigenvalue below [`NULL_EIGENVALUE`] of the largest),
    /// the parameters spanning it with their weights in it (the eigenvector's entries, of
    /// magnitude at least 0.2), largest first. Empty when the information is positive
    /// definite.
    pub unidentified: Vec<Vec<(String, f64)>>,
}

impl Uncertainty {
    /// The covariance, standard errors and correlation of θ from the observed information
    /// `information` of the parameters `names`; a singular information's directions are also
    /// said in `message`.
    pub(crate) fn new(information: Mat<f64>, names: &[String], message: &mut String) -> Self {
        let covariance = spd_inverse(&information);
        let unidentified = explain_unidentified(&information, covariance.as_ref(), names, message);
        Self {
            std_errors: covariance.as_ref().map(std_errors_of),
            correlation: covariance.as_ref().and_then(correlation),
            covariance,
            unidentified,
            information,
        }
    }
}

/// Akaike's information criterion `2k − 2 ln L` for `k` free parameters.
///
/// ```
/// assert!((kalman::fit::aic(-10.0, 3) - 26.0).abs() < 1e-12);
/// ```
pub fn aic(loglik: f64, k: usize) -> f64 {
    2.0 * k as f64 - 2.0 * loglik
}

/// The Bayesian information criterion `k ln(n_obs) − 2 ln L`.
///
/// ```
/// assert!((kalman::fit::bic(-10.0, 2, 100) - (2.0 * 100f64.ln() + 20.0)).abs() < 1e-12);
/// ```
pub fn bic(loglik: f64, k: usize, n_obs: usize) -> f64 {
    k as f64 * (n_obs as f64).ln() - 2.0 * loglik
}

/// The observed information `−∇² ln L(θ)`: central differences of the exact gradient with
/// step `h = 1e-4·max(1, |θ_j|)` (error `O(h²)` relative to the third derivative),
/// symmetrised.
///
/// # Errors
/// As [`super::log_likelihood_gradient`].
///
/// # Example
/// ```
/// use kalman::fit::{Free, Series, StandardMap, Structure, System, observed_information};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[1.0]])?;
/// let map = StandardMap::new(base, Free { r: Structure::Scalar, ..Free::default() })?;
/// let z = [0.5, -0.3, 1.2, 0.4, 0.9];
/// let info = observed_information(&map, &[0.0], &Series::new(&z, 1)?)?;
/// assert!(info[(0, 0)].is_finite());
/// # Ok(())
/// # }
/// ```
pub fn observed_information<M: ParamMap + ?Sized>(
    map: &M,
    theta: &[f64],
    data: &Series<'_>,
) -> Result<Mat<f64>, FitError> {
    information_of(map, theta, std::slice::from_ref(data))
}

/// `ln L` and its gradient summed over independent records sharing θ.
pub(crate) fn gradient_sum<M: ParamMap + ?Sized>(
    map: &M,
    theta: &[f64],
    records: &[Series<'_>],
) -> Result<(f64, Vec<f64>), FitError> {
    let mut ll = 0.0;
    let mut g = vec![0.0; theta.len()];
    for data in records {
        let (l, gi) = log_likelihood_gradient(map, theta, data)?;
        ll += l;
        for (a, b) in g.iter_mut().zip(gi) {
            *a += b;
        }
    }
    Ok((ll, g))
}

/// [`observed_information`] of independent records sharing θ (the sum of theirs).
pub(crate) fn information_of<M: ParamMap + ?Sized>(
    map: &M,
    theta: &[f64],
    records: &[Series<'_>],
) -> Result<Mat<f64>, FitError> {
    central_information(theta, |t| gradient_sum(map, t, records))
}

/// `−∇² ln L` at θ by central differences of an exact gradient `grad` (step 1e-4·max(|θ_j|,
/// 1): the gradient is exact, so the step only has to beat its round-off), symmetrised.
pub(crate) fn central_information(
    theta: &[f64],
    grad: impl Fn(&[f64]) -> Result<(f64, Vec<f64>), FitError>,
) -> Result<Mat<f64>, FitError> {
    let k = theta.len();
    let mut h = Mat::zeros(k, k);
    let mut t = theta.to_vec();
    for j in 0..k {
        let step = 1e-4 * theta[j].abs().max(1.0);
        t[j] = theta[j] + step;
        let (_, gp) = grad(&t)?;
        t[j] = theta[j] - step;
        let (_, gm) = grad(&t)?;
        t[j] = theta[j];
        for i in 0..k {
            h[(i, j)] = -(gp[i] - gm[i]) / (2.0 * step);
        }
    }
    for j in 0..k {
        for i in j + 1..k {
            let s = 0.5 * (h[(i, j)] + h[(j, i)]);
            h[(i, j)] = s;
            h[(j, i)] = s;
        }
    }
    Ok(h)
}

/// The inverse of an SPD matrix by Cholesky solves against the identity (`None` if not PD).
pub(crate) fn spd_inverse(a: &Mat<f64>) -> Option<Mat<f64>> {
    let k = a.nrows();
    let mut l = super::flat(a);
    if !lower_factor(&mut l, k) {
        return None;
    }
    let mut x = vec![0.0; k * k];
    for i in 0..k {
        x[i + i * k] = 1.0;
    }
    solve_each_column(&l, k, &mut x, k);
    let mut m = Mat::from_fn(k, k, |i, j| x[i + j * k]);
    for j in 0..k {
        for i in j + 1..k {
            let s = 0.5 * (m[(i, j)] + m[(j, i)]);
            m[(i, j)] = s;
            m[(j, i)] = s;
        }
    }
    Some(m)
}

/// An eigenvalue of the observed information below this fraction of the largest marks a
/// direction the data do not identify (its standard error would exceed the best-determined
/// one's by 10⁴ or more).
pub const NULL_EIGENVALUE: f64 = 1e-8;

/// The directions of θ that `information` does not identify, named (see
/// [`Uncertainty::unidentified`]). With no eigenvalue below the threshold (a matrix that is only
/// just indefinite to its Cholesky factorisation) the smallest one's direction is given.
pub(crate) fn unidentified(information: &Mat<f64>, names: &[String]) -> Vec<Vec<(String, f64)>> {
    let k = information.nrows();
    if k == 0 {
        return Vec::new();
    }
    let mut a = super::flat(information);
    let mut v = vec![0.0; k * k];
    let mut w = vec![0.0; k];
    crate::kernels::jacobi_eigen(&mut a, k, &mut v, &mut w);
    let top = w.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
    let mut null: Vec<usize> = (0..k).filter(|&j| w[j] <= NULL_EIGENVALUE * top).collect();
    if null.is_empty()
        && let Some(j) = (0..k).min_by(|&a, &b| w[a].total_cmp(&w[b]))
    {
        null.push(j);
    }
    null.into_iter()
        .map(|j| {
            let col = &v[j * k..(j + 1) * k];
            // a sign convention: the largest entry positive
            let big = col
                .iter()
                .fold(0.0_f64, |a, &x| if x.abs() > a.abs() { x } else { a });
            let sign = if big < 0.0 { -1.0 } else { 1.0 };
            let mut named: Vec<(String, f64)> = col
                .iter()
                .enumerate()
                .filter(|(_, x)| x.abs() >= 0.2)
                .map(|(i, &x)| (names[i].clone(), sign * x))
                .collect();
            named.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
            named
        })
        .collect()
}

/// The correlation matrix of a covariance (`None` if a variance is not positive).
pub(crate) fn correlation(cov: &Mat<f64>) -> Option<Mat<f64>> {
    let k = cov.nrows();
    let sd: Vec<f64> = (0..k).map(|i| cov[(i, i)].sqrt()).collect();
    if sd.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return None;
    }
    Some(Mat::from_fn(k, k, |i, j| {
        if i == j {
            1.0
        } else {
            (cov[(i, j)] / (sd[i] * sd[j])).clamp(-1.0, 1.0)
        }
    }))
}

/// The square roots of a covariance's diagonal.
pub(crate) fn std_errors_of(cov: &Mat<f64>) -> Vec<f64> {
    (0..cov.nrows())
        .map(|i| cov[(i, i)].max(0.0).sqrt())
        .collect()
}

/// The directions of [`unidentified`] as the messages write them: each `[+0.71·a −0.71·b]`,
/// separated by commas.
pub(crate) fn directions_text(dirs: &[Vec<(String, f64)>]) -> String {
    let text: Vec<String> = dirs
        .iter()
        .map(|d| {
            let parts: Vec<String> = d.iter().map(|(n, w)| format!("{w:+.2}·{n}")).collect();
            format!("[{}]", parts.join(" "))
        })
        .collect();
    text.join(", ")
}

/// When `covariance` is `None` (the information is not positive definite): the directions
/// the data do not identify, named, and said in `message`; empty otherwise.
pub(crate) fn explain_unidentified(
    information: &Mat<f64>,
    covariance: Option<&Mat<f64>>,
    names: &[String],
    message: &mut String,
) -> Vec<Vec<(String, f64)>> {
    if covariance.is_some() {
        return Vec::new();
    }
    let dirs = unidentified(information, names);
    let text = directions_text(&dirs);
    message.push_str(&format!(
        "; the observed information is not positive definite: the data do not identify the direction(s) {} of θ; no standard errors",
        text
    ));
    dirs
}

/// Builds the [`Fit`] at θ: log-likelihood, information, standard errors, boundary flags.
pub(crate) fn finish<M: ParamMap + ?Sized>(
    map: &M,
    theta: Vec<f64>,
    data: &Series<'_>,
    method: Method,
    iterations: usize,
    converged: bool,
    message: String,
) -> Result<Fit, FitError> {
    let records = std::slice::from_ref(data);
    finish_records(map, theta, records, method, iterations, converged, message)
}

/// [`finish`] over independent records sharing θ.
pub(crate) fn finish_records<M: ParamMap + ?Sized>(
    map: &M,
    theta: Vec<f64>,
    records: &[Series<'_>],
    method: Method,
    iterations: usize,
    converged: bool,
    message: String,
) -> Result<Fit, FitError> {
    let (loglik, _) = gradient_sum(map, &theta, records)?;
    let information = information_of(map, &theta, records)?;
    let run = Run {
        method,
        iterations,
        converged,
        message,
    };
    assemble(map, theta, records, loglik, information, run)
}

/// How an estimator ended: the fields of a [`Fit`] it decides.
pub(crate) struct Run {
    pub(crate) method: Method,
    pub(crate) iterations: usize,
    pub(crate) converged: bool,
    pub(crate) message: String,
}

/// The [`Fit`] at θ from its log-likelihood and observed information: covariance, standard
/// errors, boundary flags, the non-identified directions, correlation and AIC/BIC.
pub(crate) fn assemble<M: ParamMap + ?Sized>(
    map: &M,
    theta: Vec<f64>,
    records: &[Series<'_>],
    loglik: f64,
    information: Mat<f64>,
    run: Run,
) -> Result<Fit, FitError> {
    let Run {
        method,
        iterations,
        converged,
        mut message,
    } = run;
    let system = map.system(&theta)?;
    // A variance below 1e-8 of the data's variance is numerically zero: the boundary.
    let scale = records.iter().map(data_scale).sum::<f64>() / records.len().max(1) as f64;
    let floor = (1e-8 * scale).ln();
    let names = map.names();
    let boundary: Vec<String> = map
        .log_variances()
        .into_iter()
        .filter(|&i| theta[i] < floor)
        .map(|i| names[i].clone())
        .collect();
    if !boundary.is_empty() {
        message.push_str(&format!(
            "; on the boundary: {} (variance numerically zero; its standard error is not meaningful)",
            boundary.join(", ")
        ));
    }
    let uncertainty = Uncertainty::new(information, &names, &mut message);
    let n_obs = records.iter().map(Series::observed).sum();
    let k = theta.len();
    Ok(Fit {
        method,
        system,
        loglik,
        iterations,
        converged,
        message,
        boundary,
        uncertainty,
        n_obs,
        aic: aic(loglik, k),
        bic: bic(loglik, k, n_obs),
        theta,
    })
}

/// How many times the data's variance a prior variance (seen through H) may be before the
/// first update, `P0 − P0 Hᵀ (H P0 Hᵀ + R)⁻¹ H P0`, loses more than 9 of its 16 digits.
pub(crate) const MAX_PRIOR_RATIO: f64 = 1e9;

/// Refuses a prior so wide that the first update loses most of its digits
/// ([`MAX_PRIOR_RATIO`]): such a prior stands for "unknown", which the exact diffuse
/// initialisation (`mle_diffuse`) states without the round-off.
pub(crate) fn check_prior_scale(sys: &System, records: &[Series<'_>]) -> Result<(), FitError> {
    let scale = records.iter().map(data_scale).fold(0.0_f64, f64::max);
    let (n, m) = (sys.n(), sys.m());
    for i in 0..n {
        let seen: f64 = (0..m).map(|j| sys.h[(j, i)].powi(2)).sum();
        let p = sys.p0[(i, i)];
        if p * seen > MAX_PRIOR_RATIO * scale {
            return Err(FitError::Model(crate::Error::InvalidOption {
                name: "P0",
                value: p,
                rule: "a prior variance this large against the data's variance loses more than \
                       9 of the 16 digits of the first update: give the states with no prior \
                       as diffuse instead (the exact diffuse initialisation: \
                       kalman::fit::mle_diffuse, `scenarios fit --diffuse`)",
            }));
        }
    }
    Ok(())
}
