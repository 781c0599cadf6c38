//! Several records sharing θ, each from its own prior: manoeuvres flown from different
//! trim states, runs started at different levels. The likelihood is the sum of the
//! records' ([`super::mle_records`]), record i's filter starting from `(x0_i, P0_i)` instead
//! of the map's prior, which is then fixed (a free entry of x0 or P0 has no effect and is
//! reported as not identified). The returned [`Fit`]'s `system` carries the map's own prior.
#![allow(non_snake_case)]

use faer::Mat;

use super::info::{Fit, assemble, central_information};
use super::mle::{MleOptions, Objective, check_start, optimise_and_measure};
use super::score::log_likelihood_gradient;
use super::{Derivative, FitError, ParamMap, Series, System};
use crate::MatrixInput;

/// The prior of one record's first state.
///
/// # Example
/// ```
/// use kalman::fit::Prior;
/// let p = Prior::new(&[1.0, 0.0], &[[4.0, 0.0], [0.0, 1.0]])?;
/// assert_eq!(p.x0(), &[1.0, 0.0]);
/// # Ok::<(), kalman::fit::FitError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Prior {
    x0: Vec<f64>,
    p0: Mat<f64>,
}

impl Prior {
    /// `x0` (length n) and `P0` (n×n, symmetric PSD).
    ///
    /// # Errors
    /// [`FitError::Model`] for a `P0` of the wrong shape, not finite, not symmetric or not
    /// positive semidefinite; [`FitError::Data`] for a non-finite `x0`.
    pub fn new(x0: &[f64], P0: &impl MatrixInput) -> Result<Self, FitError> {
        let n = x0.len();
        if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
            return Err(FitError::Data(format!(
                "x0[{i}] of a record's prior is {}",
                x0[i]
            )));
        }
        // The system's own checks of P0 (shape, symmetry, PSD), on a 1-output shell.
        let eye = Mat::<f64>::identity(n, n);
        let h = Mat::<f64>::zeros(1, n);
        let sys = System::new(&eye, &h, &eye, &[[1.0]], x0, P0)?;
        Ok(Self {
            x0: sys.x0,
            p0: sys.p0,
        })
    }

    /// The prior mean.
    pub fn x0(&self) -> &[f64] {
        &self.x0
    }

    /// The prior covariance.
    pub fn p0(&self) -> &Mat<f64> {
        &self.p0
    }
}

/// `map` with its prior replaced by `prior` (and the prior's derivatives zero).
struct WithPrior<'a, M: ?Sized> {
    map: &'a M,
    prior: &'a Prior,
}

impl<M: ParamMap + ?Sized> ParamMap for WithPrior<'_, M> {
    fn n_params(&self) -> usize {
        self.map.n_params()
    }
    fn names(&self) -> Vec<String> {
        self.map.names()
    }
    fn system(&self, theta: &[f64]) -> Result<System, FitError> {
        let mut sys = self.map.system(theta)?;
        if self.prior.x0.len() != sys.n() {
            return Err(FitError::Data(format!(
                "a record's prior has {} states, the model n = {}",
                self.prior.x0.len(),
                sys.n()
            )));
        }
        sys.x0.clone_from(&self.prior.x0);
        sys.p0 = self.prior.p0.clone();
        Ok(sys)
    }
    fn derivatives(&self, theta: &[f64]) -> Result<Vec<Derivative>, FitError> {
        let mut d = self.map.derivatives(theta)?;
        for di in &mut d {
            di.x0 = None;
            di.p0 = None;
        }
        Ok(d)
    }
    fn log_variances(&self) -> Vec<usize> {
        self.map.log_variances()
    }
}

/// The records' summed likelihood, each from its own prior.
struct PerRecord<'a, M: ?Sized> {
    maps: Vec<WithPrior<'a, M>>,
    records: &'a [Series<'a>],
}

impl<M: ParamMap + ?Sized> Objective for PerRecord<'_, M> {
    fn loglik_gradient(&self, theta: &[f64]) -> Result<(f64, Vec<f64>), FitError> {
        let mut ll = 0.0;
        let mut g = vec![0.0; theta.len()];
        for (map, data) in self.maps.iter().zip(self.records) {
            let (l, gi) = log_likelihood_gradient(map, theta, data)?;
            ll += l;
            g.iter_mut().zip(gi).for_each(|(a, b)| *a += b);
        }
        Ok((ll, g))
    }
    fn information(&self, theta: &[f64]) -> Result<Mat<f64>, FitError> {
        central_information(theta, |t| self.loglik_gradient(t))
    }
}

/// [`super::mle_records`] with record i filtered from `priors[i]`.
///
/// # Errors
/// [`FitError::Data`] for no record, a different number of records and priors, or a prior
/// of the wrong size; otherwise as [`super::mle_records`].
///
/// # Example
/// ```
/// use kalman::fit::{Free, MleOptions, Prior, Series, StandardMap, Structure, System, mle_records_with_priors};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // Two runs of a local level, one started near 0 and one near 50.
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[1.0]])?;
/// let map = StandardMap::new(base.clone(), Free { q: Structure::Diag, r: Structure::Diag, ..Free::default() })?;
/// let (a, b) = ([0.3, 0.1, 0.9, 1.4, 1.2, 2.0, 1.7], [50.2, 50.9, 49.8, 51.1, 51.6, 50.7, 52.0]);
/// let records = [Series::new(&a, 1)?, Series::new(&b, 1)?];
/// let priors = [Prior::new(&[0.0], &[[1.0]])?, Prior::new(&[50.0], &[[1.0]])?];
/// let fit = mle_records_with_priors(&map, map.theta_of(&base, None), &records, &priors, &MleOptions::default())?;
/// assert!(fit.converged, "{}", fit.message);
/// # Ok(())
/// # }
/// ```
pub fn mle_records_with_priors<M: ParamMap + ?Sized>(
    map: &M,
    theta0: Vec<f64>,
    records: &[Series<'_>],
    priors: &[Prior],
    opts: &MleOptions,
) -> Result<Fit, FitError> {
    if records.is_empty() {
        return Err(FitError::Data("no record to fit".into()));
    }
    if records.len() != priors.len() {
        return Err(FitError::Data(format!(
            "{} records and {} priors: give one prior per record",
            records.len(),
            priors.len()
        )));
    }
    check_start(map, &theta0)?;
    let maps: Vec<WithPrior<'_, M>> = priors
        .iter()
        .map(|prior| WithPrior { map, prior })
        .collect();
    for (m, data) in maps.iter().zip(records) {
        data.check(&m.system(&theta0)?)?;
    }
    let objective = PerRecord { maps, records };
    let n_obs: usize = records.iter().map(Series::observed).sum();
    let (theta, loglik, information, run) = optimise_and_measure(&objective, theta0, n_obs, opts)?;
    assemble(map, theta, records, loglik, information, run)
}
