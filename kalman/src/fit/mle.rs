//! Maximum likelihood by L-BFGS on `−ln L` with the exact gradient (argmin), with a
//! Nelder–Mead fallback.

use std::cell::RefCell;

use argmin::core::{CostFunction, Executor, Gradient, State, TerminationReason};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::neldermead::NelderMead;
use argmin::solver::quasinewton::LBFGS;

use super::dense::{lower_factor, solve_each_column};
use super::info::{Fit, Method, Run, finish_records, gradient_sum, information_of};
use super::{FitError, ParamMap, Series};
use faer::Mat;

/// Options of [`mle`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MleOptions {
    /// Iteration cap of L-BFGS (and of the Nelder–Mead fallback, times 20).
    pub max_iter: u64,
    /// Convergence: the largest gradient entry of `ln L` at the optimum, in log-likelihood
    /// units per unit of θ (θ holds log-variances, so this is a relative scale).
    pub grad_tol: f64,
    /// Called before every evaluation of the likelihood; `true` stops the fit with
    /// [`FitError::Interrupted`] (a user's Ctrl-C, a deadline). `None` never stops it.
    pub interrupt: Option<super::Interrupt>,
}

impl Default for MleOptions {
    fn default() -> Self {
        Self {
            max_iter: 500,
            grad_tol: 1e-4,
            interrupt: None,
        }
    }
}

/// A log-likelihood to maximise over θ: `ln L` with its exact gradient, and the observed
/// information at a point. [`mle_records`] maximises a [`ParamMap`]'s over its records, the
/// nonlinear filter-error fit an EKF's; both through [`optimise`].
pub(crate) trait Objective {
    /// `(ln L, ∇ ln L)` at θ.
    fn loglik_gradient(&self, theta: &[f64]) -> Result<(f64, Vec<f64>), FitError>;
    /// The observed information `−∇² ln L` at θ.
    fn information(&self, theta: &[f64]) -> Result<Mat<f64>, FitError>;
    /// What to try when the fit does not converge (completes "try …").
    fn hint(&self) -> &'static str {
        "another starting point or fewer free parameters"
    }
}

/// A [`ParamMap`]'s likelihood over independent records sharing θ.
pub(crate) struct Records<'a, M: ParamMap + ?Sized> {
    pub(crate) map: &'a M,
    pub(crate) records: &'a [Series<'a>],
}

impl<M: ParamMap + ?Sized> Objective for Records<'_, M> {
    fn loglik_gradient(&self, theta: &[f64]) -> Result<(f64, Vec<f64>), FitError> {
        gradient_sum(self.map, theta, self.records)
    }
    fn information(&self, theta: &[f64]) -> Result<Mat<f64>, FitError> {
        information_of(self.map, theta, self.records)
    }
    fn hint(&self) -> &'static str {
        "another starting point (the model file's Q, R), the EM method, or fewer free entries"
    }
}

/// The last few evaluations of `(ln L, ∇ ln L)`, so that a repeated θ costs nothing. One
/// pass gives both, and argmin asks for them separately — the line search for the cost and
/// then the gradient at each trial point, L-BFGS for the gradient at the accepted point
/// again — and [`optimise`] asks again at the start, before the Newton polish and for its
/// verdict.
struct Memo<'o, O: Objective + ?Sized> {
    objective: &'o O,
    kept: RefCell<Vec<Evaluation>>,
    /// The options' interruption check, and whether it has fired.
    interrupt: Option<super::Interrupt>,
    interrupted: std::cell::Cell<bool>,
}

/// θ with `ln L` and `∇ ln L` there.
type Evaluation = (Vec<f64>, f64, Vec<f64>);

/// Evaluations kept by [`Memo`] (the line search's last trials and L-BFGS's point).
const MEMO: usize = 4;

impl<'o, O: Objective + ?Sized> Memo<'o, O> {
    fn new(objective: &'o O, interrupt: Option<super::Interrupt>) -> Self {
        Self {
            objective,
            kept: RefCell::new(Vec::with_capacity(MEMO)),
            interrupt,
            interrupted: std::cell::Cell::new(false),
        }
    }

    /// [`FitError::Interrupted`] once the interruption check has fired (the optimisers
    /// take a failed evaluation for a bad trial point, so each stage asks here).
    fn check(&self) -> Result<(), FitError> {
        if self.interrupted.get() {
            Err(FitError::Interrupted)
        } else {
            Ok(())
        }
    }

    /// `(ln L, ∇ ln L)` at `p`, from the memo when `p` was evaluated lately.
    fn eval(&self, p: &[f64]) -> Result<(f64, Vec<f64>), FitError> {
        if self.interrupted.get() || self.interrupt.is_some_and(|stop| stop.fired()) {
            self.interrupted.set(true);
            return Err(FitError::Interrupted);
        }
        if let Some((_, ll, g)) = self.kept.borrow().iter().find(|(t, _, _)| t == p) {
            return Ok((*ll, g.clone()));
        }
        let (ll, g) = self.objective.loglik_gradient(p)?;
        let mut kept = self.kept.borrow_mut();
        if kept.len() == MEMO {
            kept.remove(0);
        }
        kept.push((p.to_vec(), ll, g.clone()));
        Ok((ll, g))
    }
}

/// `−ln L / n_obs` and its gradient (scaled so that the optimiser's tolerances do not depend
/// on the series length), evaluated through the fit's [`Memo`].
struct Problem<'o, 'm, O: Objective + ?Sized> {
    memo: &'m Memo<'o, O>,
    scale: f64,
}

impl<'o, 'm, O: Objective + ?Sized> Problem<'o, 'm, O> {
    fn new(memo: &'m Memo<'o, O>, scale: f64) -> Self {
        Self { memo, scale }
    }

    fn eval(&self, p: &[f64]) -> Result<(f64, Vec<f64>), FitError> {
        self.memo.eval(p)
    }
}

impl<O: Objective + ?Sized> CostFunction for Problem<'_, '_, O> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        match self.eval(p) {
            Ok((ll, _)) if ll.is_finite() => Ok(-ll * self.scale),
            Ok(_) => Ok(f64::INFINITY),
            Err(e) => Err(argmin::core::Error::msg(e.to_string())),
        }
    }
}

impl<O: Objective + ?Sized> Gradient for Problem<'_, '_, O> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, p: &Vec<f64>) -> Result<Vec<f64>, argmin::core::Error> {
        let (_, g) = self
            .eval(p)
            .map_err(|e| argmin::core::Error::msg(e.to_string()))?;
        Ok(g.into_iter().map(|v| -v * self.scale).collect())
    }
}

/// Nelder–Mead's cost: failures become +∞ (the simplex steps away from them).
struct Robust<'o, 'm, O: Objective + ?Sized>(Problem<'o, 'm, O>);

impl<O: Objective + ?Sized> CostFunction for Robust<'_, '_, O> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        Ok(self.0.cost(p).unwrap_or(f64::INFINITY))
    }
}

/// L-BFGS on the scaled problem. It stops when the Euclidean norm of the scaled gradient
/// is below `grad_tol·scale` (which implies the verdict's `max |∇ ln L| ≤ grad_tol`: one
/// rule in the verdict's units, not a second, stricter one), or when the scaled cost moves
/// by less than 1e-14 between iterations — the round-off of `−ln L/n_obs`, where the line
/// search can no longer tell a better point from a worse one (see [`newton_polish`]).
fn lbfgs<O: Objective + ?Sized>(
    problem: Problem<'_, '_, O>,
    theta0: Vec<f64>,
    max_iter: u64,
    grad_tol: f64,
) -> Result<(Vec<f64>, u64, bool), String> {
    let ls = MoreThuenteLineSearch::new();
    let tol = grad_tol * problem.scale;
    let solver = LBFGS::new(ls, 10)
        .with_tolerance_grad(tol)
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

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |a, x| a.max(x.abs()))
}

/// Newton steps `θ ← θ + I⁻¹ ∇ ln L` on the observed information `I`, while
/// `max |∇ ln L|` exceeds `grad_tol` (at most [`NEWTON_STEPS`]).
///
/// Why it is needed: near the optimum the remaining gain of `ln L` is `½ gᵀI⁻¹g`, which for
/// a long record falls below the round-off of `ln L` itself (a sum of `n_obs` terms) while
/// the gradient — exact, from the score recursion, and free of that cancellation — is still
/// above the tolerance. A line search judged on the cost stalls there (L-BFGS stops on its
/// cost-change test); a Newton step needs only the gradient and the information and
/// converges quadratically. Each step is accepted when it shrinks the gradient in the
/// information's metric `gᵀI⁻¹g` (the Newton decrement, the squared distance to the
/// optimum in standard errors), halving it up to four times; it stops when the information
/// is not positive definite (no Newton direction) or no halving helps. Returns θ and the
/// number of steps taken.
fn newton_polish<O: Objective + ?Sized>(
    memo: &Memo<'_, O>,
    mut theta: Vec<f64>,
    grad_tol: f64,
) -> Result<(Vec<f64>, usize), FitError> {
    let k = theta.len();
    let (_, mut g) = memo.eval(&theta)?;
    let mut steps = 0;
    while steps < NEWTON_STEPS && max_abs(&g) > grad_tol {
        let mut l = super::flat(&memo.objective.information(&theta)?);
        if !lower_factor(&mut l, k) {
            break;
        }
        let decrement = |g: &[f64]| {
            let mut d = g.to_vec();
            solve_each_column(&l, k, &mut d, 1);
            (d.iter().zip(g).map(|(a, b)| a * b).sum::<f64>(), d)
        };
        let (d0, delta) = decrement(&g);
        let mut accepted = None;
        let mut t = 1.0;
        for _ in 0..5 {
            let trial: Vec<f64> = theta.iter().zip(&delta).map(|(a, d)| a + t * d).collect();
            if let Ok((ll, gt)) = memo.eval(&trial)
                && ll.is_finite()
                && decrement(&gt).0 < d0
            {
                accepted = Some((trial, gt));
                break;
            }
            t *= 0.5;
        }
        let Some((trial, gt)) = accepted else { break };
        theta = trial;
        g = gt;
        steps += 1;
    }
    Ok((theta, steps))
}

/// Steps toward the optimum from a start orders of magnitude off, before L-BFGS.
///
/// Why: from variances four orders of magnitude off (Q = R = 1 on data of variance 10⁴),
/// `ln L` is so steep and so curved in θ that L-BFGS's first step — the gradient itself, of
/// size 10⁵ — lands where the line search finds no decrease it can certify, and L-BFGS stops
/// after one iteration. While the gradient per observation exceeds 1 in some entry (a unit
/// change of that θ would move `ln L` by more than one per observation: far from any
/// optimum, whose gradient is 0), this takes steps along the gradient scaled to a largest
/// entry of 1 (a factor e on a variance), halving a step until `ln L` rises (at most 8
/// halvings; at most [`WARM_STEPS`] steps). A good start has a small gradient and takes no
/// step. Returns θ and the number of steps.
fn warm_up<O: Objective + ?Sized>(
    memo: &Memo<'_, O>,
    mut theta: Vec<f64>,
    n_obs: f64,
) -> Result<(Vec<f64>, usize), FitError> {
    let (mut ll, mut g) = memo.eval(&theta)?;
    let mut steps = 0;
    while steps < WARM_STEPS && max_abs(&g) > n_obs {
        let big = max_abs(&g);
        let mut t = 1.0;
        let mut accepted = None;
        for _ in 0..9 {
            let trial: Vec<f64> = theta.iter().zip(&g).map(|(a, d)| a + t * d / big).collect();
            if let Ok((lt, gt)) = memo.eval(&trial)
                && lt.is_finite()
                && lt > ll
            {
                accepted = Some((trial, lt, gt));
                break;
            }
            t *= 0.5;
        }
        let Some((trial, lt, gt)) = accepted else {
            break;
        };
        theta = trial;
        ll = lt;
        g = gt;
        steps += 1;
    }
    Ok((theta, steps))
}

/// Cap on [`warm_up`]'s steps (each moves a log-variance by at most 1: 50 cover a start
/// e⁵⁰ ≈ 10²¹ off).
const WARM_STEPS: usize = 50;

/// Cap on the Newton steps after L-BFGS (quadratic convergence needs two or three).
const NEWTON_STEPS: usize = 8;

/// Maximum-likelihood estimate of θ from `theta0`: L-BFGS (memory 10, Moré–Thuente line
/// search) on `−ln L/n_obs` with the exact gradient of [`super::log_likelihood_gradient`]. If
/// L-BFGS fails (e.g. a trial point makes an innovation covariance singular), Nelder–Mead
/// restarts from the best point so far and L-BFGS polishes its result. Newton steps on the
/// observed information finish the job when L-BFGS stops on its cost's round-off with the
/// gradient still above the tolerance. Converged means the
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
    mle_records(map, theta0, std::slice::from_ref(data), opts)
}

/// [`mle`] over several independent records sharing θ (manoeuvres, runs, days): the
/// log-likelihood, its gradient and the observed information are the sums of the
/// records', every record starting from the map's prior `(x0, P0)`. With one record it is
/// [`mle`].
///
/// # Errors
/// As [`mle`]; [`FitError::Data`] for an empty list or a record whose dimensions do not
/// match the map.
///
/// # Example
/// ```
/// use kalman::fit::{Free, MleOptions, Series, StandardMap, Structure, System, mle_records};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let map = StandardMap::new(base.clone(), Free { q: Structure::Scalar, r: Structure::Scalar, ..Free::default() })?;
/// let (a, b) = ([0.3, 0.1, 0.9, 1.4, 1.2, 2.0, 1.7], [5.0, 5.4, 4.9, 5.8, 6.1, 5.7, 6.6]);
/// let records = [Series::new(&a, 1)?, Series::new(&b, 1)?];
/// let fit = mle_records(&map, map.theta_of(&base, Some(&records[0])), &records, &MleOptions::default())?;
/// assert_eq!(fit.n_obs, 14);
/// # Ok(())
/// # }
/// ```
pub fn mle_records<M: ParamMap + ?Sized>(
    map: &M,
    theta0: Vec<f64>,
    records: &[Series<'_>],
    opts: &MleOptions,
) -> Result<Fit, FitError> {
    if records.is_empty() {
        return Err(FitError::Data("no record to fit".into()));
    }
    check_start(map, &theta0)?;
    let sys0 = map.system(&theta0)?;
    for data in records {
        data.check(&sys0)?;
    }
    super::info::check_prior_scale(&sys0, records)?;
    let n_obs: usize = records.iter().map(Series::observed).sum();
    let (theta, iterations, converged, message) =
        optimise(&Records { map, records }, theta0, n_obs, opts)?;
    finish_records(
        map,
        theta,
        records,
        Method::Mle,
        iterations,
        converged,
        message,
    )
}

/// [`optimise`], then `ln L` and the observed information at the optimum: θ, `ln L`, the
/// information and the run's record, what [`super::info::assemble`] takes.
pub(crate) fn optimise_and_measure<O: Objective + ?Sized>(
    objective: &O,
    theta0: Vec<f64>,
    n_obs: usize,
    opts: &MleOptions,
) -> Result<(Vec<f64>, f64, Mat<f64>, Run), FitError> {
    let (theta, iterations, converged, message) = optimise(objective, theta0, n_obs, opts)?;
    let (loglik, _) = objective.loglik_gradient(&theta)?;
    let information = objective.information(&theta)?;
    let run = Run {
        method: Method::Mle,
        iterations,
        converged,
        message,
    };
    Ok((theta, loglik, information, run))
}

/// Refuses a map with nothing free and a start of the wrong length.
pub(crate) fn check_start<M: ParamMap + ?Sized>(map: &M, theta0: &[f64]) -> Result<(), FitError> {
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
    Ok(())
}

/// Maximises `objective` from `theta0`: [`warm_up`] from a start far off, L-BFGS (memory
/// 10, Moré–Thuente line search) on `−ln L/n_obs` with the exact gradient, Nelder–Mead
/// restarted from the best point when L-BFGS fails, and [`newton_polish`] on the observed
/// information. Returns θ, the iterations, the verdict (the largest entry of `∇ ln L` within
/// [`MleOptions::grad_tol`]) and its message.
pub(crate) fn optimise<O: Objective + ?Sized>(
    objective: &O,
    theta0: Vec<f64>,
    n_obs: usize,
    opts: &MleOptions,
) -> Result<(Vec<f64>, usize, bool, String), FitError> {
    // The likelihood must be defined at the start.
    let memo = Memo::new(objective, opts.interrupt);
    memo.eval(&theta0)?;
    let scale = 1.0 / n_obs as f64;
    let mk = || Problem::new(&memo, scale);
    let mut notes = Vec::new();
    let (theta0, warm) = warm_up(&memo, theta0, n_obs as f64)?;
    memo.check()?;
    let mut iterations = warm;
    if warm > 0 {
        notes.push(format!(
            "{warm} normalised gradient step(s) from a start far from the optimum before L-BFGS"
        ));
    }
    let theta = match lbfgs(mk(), theta0.clone(), opts.max_iter, opts.grad_tol) {
        Ok((t, it, _)) => {
            iterations += it as usize;
            t
        }
        Err(e) => {
            memo.check()?;
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
            memo.check()?;
            iterations += res.state().get_iter() as usize;
            let t = res
                .state()
                .get_best_param()
                .cloned()
                .unwrap_or(theta0.clone());
            match lbfgs(mk(), t.clone(), opts.max_iter, opts.grad_tol) {
                Ok((t2, it, _)) => {
                    iterations += it as usize;
                    t2
                }
                Err(_) => t,
            }
        }
    };
    memo.check()?;
    let (theta, steps) = newton_polish(&memo, theta, opts.grad_tol)?;
    memo.check()?;
    if steps > 0 {
        iterations += steps;
        notes.push(format!(
            "{steps} Newton step(s) on the observed information after L-BFGS (its cost had reached round-off)"
        ));
    }
    let (_, g) = memo.eval(&theta)?;
    let gmax = max_abs(&g);
    let converged = gmax <= opts.grad_tol;
    let mut message = if converged {
        format!("converged after {iterations} iterations (max |∇ ln L| = {gmax:.2e})")
    } else {
        format!(
            "not converged after {iterations} iterations: max |∇ ln L| = {gmax:.2e} > {:.0e}; try {}",
            opts.grad_tol,
            objective.hint()
        )
    };
    for n in notes {
        message.push_str("; ");
        message.push_str(&n);
    }
    Ok((theta, iterations, converged, message))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{Free, StandardMap, Structure, System, log_likelihood_gradient};
    use rand::{RngExt, SeedableRng};
    use rand_distr::StandardNormal;

    /// An AR(1) of Q = 0.5 seen through R = 1, 2000 samples, Q and R free.
    fn problem() -> (StandardMap, Vec<f64>) {
        let base =
            System::new(&[[0.95]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[5.0]]).expect("system");
        let free = Free {
            q: Structure::Scalar,
            r: Structure::Scalar,
            ..Free::default()
        };
        let mut g = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut x = 0.0;
        let z = (0..2000)
            .map(|_| {
                x = 0.95 * x + 0.5f64.sqrt() * g.sample::<f64, _>(StandardNormal);
                x + g.sample::<f64, _>(StandardNormal)
            })
            .collect();
        (StandardMap::new(base, free).expect("map"), z)
    }

    #[test]
    fn newton_polish_reaches_a_gradient_line_search_cannot() {
        // From 0.3 off the optimum in both log-variances, Newton on the observed information
        // must bring max |∇ ln L| below 1e-7 — about 1e-10 per sample, far below what a
        // line search on the cost (round-off ≈ 1e-16·|ln L| ≈ 3e-13 per step) could judge
        // here — in a few quadratically convergent steps, and raise ln L doing so.
        let (map, z) = problem();
        let data = Series::new(&z, 1).expect("series");
        let fit = mle(&map, vec![0.0, 0.0], &data, &MleOptions::default()).expect("fit");
        assert!(fit.converged, "{}", fit.message);
        let start: Vec<f64> = fit.theta.iter().map(|t| t + 0.3).collect();
        let (ll0, _) = log_likelihood_gradient(&map, &start, &data).expect("start");
        let (theta, steps) = newton_polish(
            &Memo::new(
                &Records {
                    map: &map,
                    records: std::slice::from_ref(&data),
                },
                None,
            ),
            start,
            1e-7,
        )
        .expect("polish");
        let (ll, g) = log_likelihood_gradient(&map, &theta, &data).expect("end");
        assert!(max_abs(&g) <= 1e-7, "{g:?} after {steps} steps");
        assert!((1..=6).contains(&steps), "{steps} steps");
        assert!(ll > ll0, "{ll} ≤ {ll0}");
        // The same optimum L-BFGS found, to well within its standard errors.
        let se = fit.uncertainty.std_errors.expect("standard errors");
        for i in 0..2 {
            assert!((theta[i] - fit.theta[i]).abs() < 1e-2 * se[i], "θ{i}");
        }
    }

    #[test]
    fn lbfgs_stops_on_the_verdicts_gradient_rule() {
        // The verdict and L-BFGS's own gradient test are one rule: a converged fit's
        // gradient is within the tolerance, and a tighter tolerance is met too.
        let (map, z) = problem();
        let data = Series::new(&z, 1).expect("series");
        for grad_tol in [1e-2, 1e-6] {
            let opts = MleOptions {
                grad_tol,
                ..MleOptions::default()
            };
            let fit = mle(&map, vec![0.0, 0.0], &data, &opts).expect("fit");
            let (_, g) = log_likelihood_gradient(&map, &fit.theta, &data).expect("gradient");
            assert!(fit.converged && max_abs(&g) <= grad_tol, "{}", fit.message);
        }
    }
}
