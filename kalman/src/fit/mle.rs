//! Maximum likelihood by L-BFGS on `−ln L` with the exact gradient (argmin), with a
//! Nelder–Mead fallback.

use argmin::core::{CostFunction, Executor, Gradient, State, TerminationReason};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::neldermead::NelderMead;
use argmin::solver::quasinewton::LBFGS;

use super::info::{Fit, Method, finish};
use super::score::log_likelihood_gradient;
use super::{FitError, ParamMap, Series};

/// Options of [`mle`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MleOptions {
    /// Iteration cap of L-BFGS (and of the Nelder–Mead fallback, times 20).
    pub max_iter: u64,
    /// Convergence: the largest gradient entry of `ln L` at the optimum, in log-likelihood
    /// units per unit of θ (θ holds log-variances, so this is a relative scale).
    pub grad_tol: f64,
}

impl Default for MleOptions {
    fn default() -> Self {
        Self {
            max_iter: 500,
            grad_tol: 1e-4,
        }
    }
}

/// `−ln L / n_obs` and its gradient (scaled so that the optimiser's tolerances do not depend
/// on the series length).
struct Problem<'a, M: ParamMap + ?Sized> {
    map: &'a M,
    data: &'a Series<'a>,
    scale: f64,
}

impl<M: ParamMap + ?Sized> CostFunction for Problem<'_, M> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        match log_likelihood_gradient(self.map, p, self.data) {
            Ok((ll, _)) if ll.is_finite() => Ok(-ll * self.scale),
            Ok(_) => Ok(f64::INFINITY),
            Err(e) => Err(argmin::core::Error::msg(e.to_string())),
        }
    }
}

impl<M: ParamMap + ?Sized> Gradient for Problem<'_, M> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, p: &Vec<f64>) -> Result<Vec<f64>, argmin::core::Error> {
        let (_, g) = log_likelihood_gradient(self.map, p, self.data)
            .map_err(|e| argmin::core::Error::msg(e.to_string()))?;
        Ok(g.into_iter().map(|v| -v * self.scale).collect())
    }
}

/// Nelder–Mead's cost: failures become +∞ (the simplex steps away from them).
struct Robust<'a, M: ParamMap + ?Sized>(Problem<'a, M>);

impl<M: ParamMap + ?Sized> CostFunction for Robust<'_, M> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        Ok(self.0.cost(p).unwrap_or(f64::INFINITY))
    }
}

fn lbfgs<M: ParamMap + ?Sized>(
    problem: Problem<'_, M>,
    theta0: Vec<f64>,
    max_iter: u64,
) -> Result<(Vec<f64>, u64, bool), String> {
    let ls = MoreThuenteLineSearch::new();
    let solver = LBFGS::new(ls, 10)
        .with_tolerance_grad(1e-10)
        .and_then(|s| s.with_tolerance_cost(1e-14))
        .map_err(|e| e.to_string())?;
    let res = Executor::new(problem, solver)
        .configure(|st| st.param(theta0).max_iters(max_iter))
        .run()
        .map_err(|e| e.to_string())?;
    let st = res.state();
    let best = st
        .get_best_param()
        .cloned()
        .ok_or("L-BFGS returned no parameter")?;
    let hit_cap = matches!(
        st.get_termination_reason(),
        Some(TerminationReason::MaxItersReached)
    );
    Ok((best, st.get_iter(), hit_cap))
}

/// Maximum-likelihood estimate of θ from `theta0`: L-BFGS (memory 10, Moré–Thuente line
/// search) on `−ln L/n_obs` with the exact gradient of [`log_likelihood_gradient`]. If
/// L-BFGS fails (e.g. a trial point makes an innovation covariance singular), Nelder–Mead
/// restarts from the best point so far and L-BFGS polishes its result. Converged means the
/// largest entry of `∇ ln L` is below [`MleOptions::grad_tol`]; otherwise the [`Fit`] says
/// so in `converged` and `message` (never a silent stop).
///
/// # Errors
/// [`FitError::NothingFree`] for a map without parameters, [`FitError::Parameters`] for a
/// θ0 of the wrong length; the map's errors at θ0 and at the optimum.
///
/// # Example
/// ```
/// use kalman::fit::{Free, MleOptions, Series, StandardMap, Structure, System, mle};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let map = StandardMap::new(base.clone(), Free { q: Structure::Scalar, r: Structure::Scalar, ..Free::default() })?;
/// let z = [0.3, 0.1, 0.9, 1.4, 1.2, 2.0, 1.7, 2.5, 2.2, 3.1, 2.9, 3.3];
/// let data = Series::new(&z, 1)?;
/// let fit = mle(&map, map.theta_of(&base, Some(&data)), &data, &MleOptions::default())?;
/// assert!(fit.converged, "{}", fit.message);
/// # Ok(())
/// # }
/// ```
pub fn mle<M: ParamMap + ?Sized>(
    map: &M,
    theta0: Vec<f64>,
    data: &Series<'_>,
    opts: &MleOptions,
) -> Result<Fit, FitError> {
    if map.n_params() == 0 {
        return Err(FitError::NothingFree);
    }
    if theta0.len() != map.n_params() {
        return Err(FitError::Parameters(format!(
            "θ0 has {} entries, the map has {}",
            theta0.len(),
            map.n_params()
        )));
    }
    data.check(&map.system(&theta0)?)?;
    // The likelihood must be defined at the start.
    log_likelihood_gradient(map, &theta0, data)?;
    let scale = 1.0 / data.observed() as f64;
    let mk = || Problem { map, data, scale };
    let mut notes = Vec::new();
    let mut iterations = 0;
    let theta = match lbfgs(mk(), theta0.clone(), opts.max_iter) {
        Ok((t, it, _)) => {
            iterations += it as usize;
            t
        }
        Err(e) => {
            notes.push(format!("L-BFGS failed ({e}); Nelder–Mead fallback"));
            let k = theta0.len();
            let mut simplex = vec![theta0.clone()];
            for i in 0..k {
                let mut v = theta0.clone();
                v[i] += 0.5;
                simplex.push(v);
            }
            let nm = NelderMead::new(simplex)
                .with_sd_tolerance(1e-12)
                .map_err(|e| FitError::Optimiser(e.to_string()))?;
            let res = Executor::new(Robust(mk()), nm)
                .configure(|st| st.max_iters(opts.max_iter * 20))
                .run()
                .map_err(|e| FitError::Optimiser(e.to_string()))?;
            iterations += res.state().get_iter() as usize;
            let t = res
                .state()
                .get_best_param()
                .cloned()
                .unwrap_or(theta0.clone());
            match lbfgs(mk(), t.clone(), opts.max_iter) {
                Ok((t2, it, _)) => {
                    iterations += it as usize;
                    t2
                }
                Err(_) => t,
            }
        }
    };
    let (_, g) = log_likelihood_gradient(map, &theta, data)?;
    let gmax = g.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let converged = gmax <= opts.grad_tol;
    let mut message = if converged {
        format!("converged after {iterations} iterations (max |∇ ln L| = {gmax:.2e})")
    } else {
        format!(
            "not converged after {iterations} iterations: max |∇ ln L| = {gmax:.2e} > {:.0e}; try another starting point (the model file's Q, R), the EM method, or fewer free entries",
            opts.grad_tol
        )
    };
    for n in notes {
        message.push_str("; ");
        message.push_str(&n);
    }
    finish(
        map,
        theta,
        data,
        Method::Mle,
        iterations,
        converged,
        message,
    )
}
