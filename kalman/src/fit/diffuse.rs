//! The exact diffuse initialisation: states with no prior at all (a level, a trend, a bias
//! nobody has measured), their likelihood and its maximum, without a large `P0` standing in
//! for "unknown" and losing the first update's digits to it.
//!
//! # The likelihood
//! The prior of the first state is `P0 = P∗ + κ P∞` with `κ → ∞`: `P∞` the identity on the
//! diffuse states and zero elsewhere, `P∗` the given `P0` with the diffuse rows and columns
//! removed. The filter carries `P∗` and `P∞` apart (Durbin & Koopman, *Time Series Analysis
//! by State Space Methods*, 2nd ed., §5.2 and §6.4, in the univariate form of Koopman &
//! Durbin, "Filtering and smoothing of state vector for diffuse state-space models", J. Time
//! Ser. Anal. 24, 2003): the observed entries of each `z_k` are decorrelated by the Cholesky
//! factor `L` of their `R` and processed one at a time. For a row `h` with
//! `F∞ = h P∞ hᵀ`, `F∗ = h P∗ hᵀ + 1`, `M∞ = P∞ hᵀ`, `M∗ = P∗ hᵀ` and `v` the innovation:
//!
//! ```text
//! F∞ > 0:  K = M∞/F∞,  x += K v,  P∗ += K Kᵀ F∗ − K M∗ᵀ − M∗ Kᵀ,  P∞ −= K Kᵀ F∞,
//!          ln L −= ½ (ln 2π + ln F∞)
//! F∞ = 0:  K = M∗/F∗,  x += K v,  P∗ −= K Kᵀ F∗,
//!          ln L −= ½ (ln 2π + ln F∗ + v²/F∗)
//! ```
//!
//! (the first branch is the `κ → ∞` limit of the ordinary update, the `ln κ` term dropped),
//! then `ln L −= Σ ln L_ii` for the decorrelation, and the prediction `x ← F x + B u`,
//! `P∗ ← F P∗ Fᵀ + Q`, `P∞ ← F P∞ Fᵀ`. Once `P∞` is zero this is the ordinary filter's
//! likelihood. The result is the *diffuse log-likelihood* of Durbin & Koopman (their eq. 7.4),
//! the number statsmodels reports with `use_exact_diffuse=True`. `F∞` counts as zero below
//! `1e-9·‖h‖²` (`P∞`'s entries are at most 1).
//!
//! # The gradient
//! The pass is written over a generic scalar; with the map's `∂System/∂θ_j` seeded into a
//! `num_dual::Dual64`, one pass per parameter gives the exact gradient, and the observed
//! information is its central difference, as in the other fits.
//!
//! # Example
//! ```
//! use kalman::fit::{Free, MleOptions, Series, StandardMap, Structure, System, mle_diffuse};
//! # fn main() -> Result<(), kalman::fit::FitError> {
//! // A local level with no prior on the level: state 0 is diffuse.
//! let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[0.0]])?;
//! let free = Free { q: Structure::Diag, r: Structure::Diag, ..Free::default() };
//! let map = StandardMap::new(base.clone(), free)?;
//! let z = [10.3, 10.1, 10.9, 11.4, 11.2, 12.0, 11.7, 12.5, 12.2, 13.1, 12.9, 13.3];
//! let data = Series::new(&z, 1)?;
//! let fit = mle_diffuse(&map, map.theta_of(&base, Some(&data)), &[0], &data, &MleOptions::default())?;
//! assert!(fit.converged, "{}", fit.message);
//! # Ok(())
//! # }
//! ```

use num_dual::Dual64;

use super::info::{Fit, assemble, central_information};
use super::mle::{MleOptions, Objective, check_start, optimise_and_measure};
use super::{FitError, LN_2PI, ParamMap, Series, System};
use crate::kernels::{Real, cholesky, symmetrise};
use crate::nonlinear::Scalar;

/// The exact diffuse log-likelihood of `data` under `sys`, the states listed in `diffuse`
/// (0-based, distinct) having no prior (see the [module](self)); `sys.x0` and `sys.p0` give
/// the prior of the others (their rows and columns of the diffuse states are ignored).
///
/// # Errors
/// [`FitError::Parameters`] for a diffuse index out of range or repeated,
/// [`FitError::Data`] for a record whose width is not the model's,
/// [`FitError::NotPositiveDefinite`] at a step whose observed `R` is not positive definite,
/// [`FitError::Diverged`] where the pass stops being finite.
///
/// # Example
/// ```
/// use kalman::fit::{Series, System, diffuse_log_likelihood};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // A local level: after one observation the level is known with variance R, so the
/// // diffuse likelihood of one row is −½ ln 2π (the ln κ of the limit dropped).
/// let sys = System::new(&[[1.0]], &[[1.0]], &[[2.0]], &[[3.0]], &[0.0], &[[0.0]])?;
/// let ll = diffuse_log_likelihood(&sys, &[0], &Series::new(&[5.0], 1)?)?;
/// assert!((ll + 0.5 * (2.0 * std::f64::consts::PI).ln()).abs() < 1e-15);
/// # Ok(())
/// # }
/// ```
pub fn diffuse_log_likelihood(
    sys: &System,
    diffuse: &[usize],
    data: &Series<'_>,
) -> Result<f64, FitError> {
    check_diffuse(diffuse, sys.n())?;
    data.check(sys)?;
    let m = Matrices::<f64>::of(sys, None);
    pass(&m, diffuse, data)
}

/// The exact diffuse log-likelihood at θ of a [`ParamMap`] and its exact gradient.
///
/// # Errors
/// As [`diffuse_log_likelihood`] and the map's.
///
/// # Example
/// ```
/// use kalman::fit::{Free, Series, StandardMap, Structure, System, diffuse_log_likelihood_gradient};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[0.0]])?;
/// let free = Free { q: Structure::Diag, r: Structure::Diag, ..Free::default() };
/// let map = StandardMap::new(base, free)?;
/// let data = Series::new(&[1.0, 1.4, 0.9, 1.7, 2.2], 1)?;
/// let (ll, grad) = diffuse_log_likelihood_gradient(&map, &[0.0, 0.0], &[0], &data)?;
/// assert!(ll.is_finite() && grad.len() == 2);
/// # Ok(())
/// # }
/// ```
pub fn diffuse_log_likelihood_gradient<M: ParamMap + ?Sized>(
    map: &M,
    theta: &[f64],
    diffuse: &[usize],
    data: &Series<'_>,
) -> Result<(f64, Vec<f64>), FitError> {
    let sys = map.system(theta)?;
    check_diffuse(diffuse, sys.n())?;
    data.check(&sys)?;
    let derivatives = map.derivatives(theta)?;
    let mut ll = f64::NAN;
    let mut grad = Vec::with_capacity(theta.len());
    for d in &derivatives {
        let m = Matrices::<Dual64>::of(&sys, Some(d));
        let v = pass(&m, diffuse, data)?;
        ll = v.re;
        grad.push(v.eps);
    }
    if derivatives.is_empty() {
        ll = diffuse_log_likelihood(&sys, diffuse, data)?;
    }
    Ok((ll, grad))
}

/// Maximum likelihood under the exact diffuse initialisation of the states `diffuse`: the
/// optimiser of [`super::mle`] on [`diffuse_log_likelihood_gradient`], the observed
/// information by central differences of that exact gradient, and the [`Fit`] with the
/// diffuse log-likelihood (`fit.loglik`), standard errors, correlation and AIC/BIC.
///
/// # Errors
/// [`FitError::NothingFree`] for a map without parameters, [`FitError::Parameters`] for a
/// θ0 of the wrong length, and those of [`diffuse_log_likelihood`].
///
/// # Example
/// ```
/// use kalman::fit::{Free, MleOptions, Series, StandardMap, Structure, System, mle_diffuse};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // A level and a trend, neither with a prior: both states diffuse.
/// let base = System::new(
///     &[[1.0, 1.0], [0.0, 1.0]], &[[1.0, 0.0]], &[[1.0, 0.0], [0.0, 0.1]], &[[1.0]],
///     &[0.0, 0.0], &[[0.0, 0.0], [0.0, 0.0]],
/// )?;
/// let map = StandardMap::new(base.clone(), Free { r: Structure::Diag, ..Free::default() })?;
/// let z: Vec<f64> = (0..40).map(|k| 0.5 * k as f64 + (1.3 * k as f64).sin()).collect();
/// let data = Series::new(&z, 1)?;
/// let fit = mle_diffuse(&map, map.theta_of(&base, Some(&data)), &[0, 1], &data, &MleOptions::default())?;
/// assert!(fit.converged && fit.system.r[(0, 0)] > 0.0);
/// # Ok(())
/// # }
/// ```
pub fn mle_diffuse<M: ParamMap + ?Sized>(
    map: &M,
    theta0: Vec<f64>,
    diffuse: &[usize],
    data: &Series<'_>,
    opts: &MleOptions,
) -> Result<Fit, FitError> {
    check_start(map, &theta0)?;
    let objective = Diffuse { map, diffuse, data };
    let n_obs = data.observed();
    let (theta, loglik, information, run) = optimise_and_measure(&objective, theta0, n_obs, opts)?;
    assemble(
        map,
        theta,
        std::slice::from_ref(data),
        loglik,
        information,
        run,
    )
}

/// The diffuse likelihood of one record as the optimiser's objective.
struct Diffuse<'a, M: ?Sized> {
    map: &'a M,
    diffuse: &'a [usize],
    data: &'a Series<'a>,
}

impl<M: ParamMap + ?Sized> Objective for Diffuse<'_, M> {
    fn loglik_gradient(&self, theta: &[f64]) -> Result<(f64, Vec<f64>), FitError> {
        diffuse_log_likelihood_gradient(self.map, theta, self.diffuse, self.data)
    }
    fn information(&self, theta: &[f64]) -> Result<faer::Mat<f64>, FitError> {
        central_information(theta, |t| self.loglik_gradient(t))
    }
    fn hint(&self) -> &'static str {
        "another starting point or fewer free entries"
    }
}

fn check_diffuse(diffuse: &[usize], n: usize) -> Result<(), FitError> {
    for (k, &i) in diffuse.iter().enumerate() {
        if i >= n {
            return Err(FitError::Parameters(format!(
                "diffuse state {i} does not exist (the model has n = {n})"
            )));
        }
        if diffuse[..k].contains(&i) {
            return Err(FitError::Parameters(format!(
                "diffuse state {i} is listed twice"
            )));
        }
    }
    Ok(())
}

/// The system's matrices over the scalar `T` (column-major), with one derivative as the dual
/// part when `T` is a dual number.
struct Matrices<T> {
    n: usize,
    m: usize,
    p: usize,
    f: Vec<T>,
    b: Vec<T>,
    h: Vec<T>,
    q: Vec<T>,
    r: Vec<T>,
    x0: Vec<T>,
    p0: Vec<T>,
}

impl<T: Seed> Matrices<T> {
    fn of(sys: &System, d: Option<&super::Derivative>) -> Self {
        let lift = |a: &faer::Mat<f64>, da: Option<&faer::Mat<f64>>| -> Vec<T> {
            let mut out = Vec::with_capacity(a.nrows() * a.ncols());
            for j in 0..a.ncols() {
                for i in 0..a.nrows() {
                    out.push(T::seeded(a[(i, j)], da.map_or(0.0, |da| da[(i, j)])));
                }
            }
            out
        };
        let d0 = super::Derivative::default();
        let d = d.unwrap_or(&d0);
        Self {
            n: sys.n(),
            m: sys.m(),
            p: sys.p(),
            f: lift(&sys.f, d.f.as_ref()),
            b: lift(&sys.b, d.b.as_ref()),
            h: lift(&sys.h, d.h.as_ref()),
            q: lift(&sys.q, d.q.as_ref()),
            r: lift(&sys.r, d.r.as_ref()),
            x0: sys
                .x0
                .iter()
                .enumerate()
                .map(|(i, &v)| T::seeded(v, d.x0.as_ref().map_or(0.0, |dx| dx[i])))
                .collect(),
            p0: lift(&sys.p0, d.p0.as_ref()),
        }
    }
}

/// The scalars of the pass: `f64`, and `Dual64` carrying one derivative.
trait Seed: Scalar + Real {
    /// `v + ε·dv` (for `f64`, `v`).
    fn seeded(v: f64, dv: f64) -> Self;
}

impl Seed for f64 {
    fn seeded(v: f64, _dv: f64) -> Self {
        v
    }
}

impl Seed for Dual64 {
    fn seeded(v: f64, dv: f64) -> Self {
        Dual64::new(v, dv)
    }
}

/// The filter pass (see the [module](self)).
fn pass<T: Seed>(m: &Matrices<T>, diffuse: &[usize], data: &Series<'_>) -> Result<T, FitError> {
    let (n, mm, p) = (m.n, m.m, m.p);
    let zero = T::from(0.0);
    let mut x = m.x0.clone();
    let mut ps = m.p0.clone();
    let mut pi = vec![zero; n * n];
    for &i in diffuse {
        x[i] = zero;
        for j in 0..n {
            ps[i + j * n] = zero;
            ps[j + i * n] = zero;
        }
        pi[i + i * n] = T::from(1.0);
    }
    let mut ll = zero;
    let (mut l, mut hr, mut zr) = (vec![zero; mm * mm], vec![zero; mm * n], vec![zero; mm]);
    let (mut minf, mut mstar, mut gain) = (vec![zero; n], vec![zero; n], vec![zero; n]);
    let (mut tmp, mut fx) = (vec![zero; n * n], vec![zero; n]);
    for k in 0..data.len() {
        let z = data.z(k);
        let obs: Vec<usize> = (0..mm).filter(|&i| !z[i].is_nan()).collect();
        let o = obs.len();
        if o > 0 {
            // L Lᵀ = R of the observed entries; rows of L⁻¹ H and L⁻¹ z by forward substitution.
            for (b, &j) in obs.iter().enumerate() {
                for (a, &i) in obs.iter().enumerate() {
                    l[a + b * o] = m.r[i + j * mm];
                }
            }
            if !cholesky(&mut l[..o * o], o, 0.0) {
                return Err(FitError::NotPositiveDefinite {
                    name: "measurement noise covariance of the observed entries",
                    step: k,
                });
            }
            for a in 0..o {
                let mut zi = T::from(z[obs[a]]);
                for c in 0..a {
                    zi -= l[a + c * o] * zr[c];
                }
                zr[a] = zi / l[a + a * o];
                for col in 0..n {
                    let mut v = m.h[obs[a] + col * mm];
                    for c in 0..a {
                        v -= l[a + c * o] * hr[c + col * mm];
                    }
                    hr[a + col * mm] = v / l[a + a * o];
                }
                ll -= l[a + a * o].ln();
            }
            for a in 0..o {
                let h = |c: usize| hr[a + c * mm];
                let mut v = zr[a];
                let mut hh = 0.0;
                for c in 0..n {
                    v -= h(c) * x[c];
                    hh += h(c).value() * h(c).value();
                }
                let (mut finf, mut fstar) = (zero, T::from(1.0));
                for i in 0..n {
                    let (mut a1, mut a2) = (zero, zero);
                    for c in 0..n {
                        a1 += pi[i + c * n] * h(c);
                        a2 += ps[i + c * n] * h(c);
                    }
                    minf[i] = a1;
                    mstar[i] = a2;
                }
                for i in 0..n {
                    finf += h(i) * minf[i];
                    fstar += h(i) * mstar[i];
                }
                if finf.value() > 1e-9 * hh {
                    for i in 0..n {
                        gain[i] = minf[i] / finf;
                        x[i] += gain[i] * v;
                    }
                    for j in 0..n {
                        for i in 0..n {
                            let (ki, kj) = (gain[i], gain[j]);
                            ps[i + j * n] =
                                ps[i + j * n] + ki * kj * fstar - ki * mstar[j] - mstar[i] * kj;
                            pi[i + j * n] -= ki * kj * finf;
                        }
                    }
                    ll -= (T::from(LN_2PI) + finf.ln()) * 0.5;
                } else {
                    if fstar.value() <= 0.0 || fstar.value().is_nan() {
                        return Err(FitError::NotPositiveDefinite {
                            name: "innovation covariance",
                            step: k,
                        });
                    }
                    for i in 0..n {
                        gain[i] = mstar[i] / fstar;
                        x[i] += gain[i] * v;
                    }
                    for j in 0..n {
                        for i in 0..n {
                            ps[i + j * n] -= gain[i] * gain[j] * fstar;
                        }
                    }
                    ll -= (T::from(LN_2PI) + fstar.ln() + v * v / fstar) * 0.5;
                }
                symmetrise(&mut ps, n);
                symmetrise(&mut pi, n);
            }
        }
        // x ← F x + B u, P∗ ← F P∗ Fᵀ + Q, P∞ ← F P∞ Fᵀ.
        let u = if p > 0 { data.u(k) } else { &[][..] };
        for i in 0..n {
            let mut acc = zero;
            for c in 0..n {
                acc += m.f[i + c * n] * x[c];
            }
            for c in 0..p {
                acc += m.b[i + c * n] * u[c];
            }
            fx[i] = acc;
        }
        x.copy_from_slice(&fx);
        for cov in [&mut ps, &mut pi] {
            for j in 0..n {
                for i in 0..n {
                    let mut acc = zero;
                    for c in 0..n {
                        acc += m.f[i + c * n] * cov[c + j * n];
                    }
                    tmp[i + j * n] = acc;
                }
            }
            for j in 0..n {
                for i in 0..n {
                    let mut acc = zero;
                    for c in 0..n {
                        acc += tmp[i + c * n] * m.f[j + c * n];
                    }
                    cov[i + j * n] = acc;
                }
            }
        }
        for (a, &qv) in ps.iter_mut().zip(&m.q) {
            *a += qv;
        }
        symmetrise(&mut ps, n);
        if !(ll.value().is_finite() && x.iter().all(|v| v.value().is_finite())) {
            return Err(FitError::Diverged {
                what: "the diffuse pass's state or likelihood",
                step: k,
            });
        }
    }
    Ok(ll)
}
