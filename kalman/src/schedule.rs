//! The Monte Carlo mode: for a time-invariant model and a fixed P0 the covariance and gain
//! sequence does not depend on the data, so [`GainSchedule`] computes it once (with the
//! engine's own [`Filter`], until the gain has converged to its steady state) and
//! [`ScheduledFilter`] runs measurement streams through it at the cost of the state update
//! alone: e_k = z_k − H x_{k|k−1}, x_{k|k} = x_{k|k−1} + K_k e_k,
//! x_{k+1|k} = F x_{k|k} + B u_k (+ S Σ_k⁻¹ e_k with cross-covariance).
//!
//! A step with a missing (NaN) entry changes the covariance sequence, so it falls back to
//! the full update: the runner restarts an internal [`Filter`] from x_{k|k−1} and the
//! scheduled P_{k|k−1}, runs full steps until its P_{k+1|k} is back at the steady state (to
//! `reentry_tolerance`), then returns to the steady gain. The estimates equal the full
//! filter's to rounding either way. Scheduled steps allocate nothing; entering the
//! fallback calls [`Filter::reset`], which validates P and may allocate once.
//!
//! [`GainSchedule::fixed_gain`] is the fixed-gain filter: one gain (the DARE's) for every
//! step.
#![allow(non_snake_case)]

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, Side};

use crate::filter::{add_mat_vec, check_step_inputs, diverged, propagate_mean};
use crate::model::load_vec;
use crate::riccati::SteadyState;
use crate::storage::{Buf, Dims};
use crate::{CovarianceForm, Error, Filter, MatrixInput, Model};

/// Convergence settings of [`GainSchedule::new`].
///
/// # Example
/// ```
/// use kalman::schedule::ScheduleOptions;
///
/// let opts = ScheduleOptions { max_steps: 500, ..ScheduleOptions::default() };
/// assert!(opts.tolerance > 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScheduleOptions {
    /// The schedule ends at the first step k with
    /// max|K_k − K_{k−1}| ≤ `tolerance`·max|K_k| and the same for S Σ_k⁻¹ and for
    /// P_{k+1|k} against P_{k|k−1}. Default 1e-14, so the steady gain is the filter's own
    /// fixed point to rounding.
    pub tolerance: f64,
    /// Give up (with an error) after this many steps. Default 1 000 000.
    pub max_steps: usize,
    /// The fallback returns to the steady gain when max|P_{k+1|k} − P∞| ≤
    /// `reentry_tolerance`·max|P∞|. Default 1e-14.
    pub reentry_tolerance: f64,
    /// Covariance form of the filter that computes the schedule and runs the fallback.
    pub form: CovarianceForm,
}

impl Default for ScheduleOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-14,
            max_steps: 1_000_000,
            reentry_tolerance: 1e-14,
            form: CovarianceForm::Joseph,
        }
    }
}

/// The data-independent gain sequence K_0, K_1, … of a time-invariant model from a fixed
/// P0, ending at the steady-state gain.
///
/// Memory: the transient's gains (n·m each) and prior covariances P_{k|k−1} (n² each, kept
/// for the missing-value fallback), `len()` of each.
#[derive(Debug, Clone)]
pub struct GainSchedule<D: Dims> {
    template: Filter<D>,
    model: Model<D>,
    gains: Vec<D::Nm>,
    cross: Vec<D::Nm>,
    priors: Vec<D::Nn>,
    steady_prior: D::Nn,
    opts: ScheduleOptions,
}

impl<D: Dims> GainSchedule<D> {
    /// Runs the covariance recursion of `model` from `P0` until the gain converges.
    ///
    /// # Errors
    /// Validation errors naming `P0` (as [`Filter::new`]); [`Error::Diverged`] naming the
    /// step at which the covariance recursion left the finite numbers (an unstable mode the
    /// measurements do not see); [`Error::RiccatiNoConvergence`] if the gain has not
    /// converged after `opts.max_steps` steps (e.g. an undetectable model).
    pub fn new(
        model: Model<D>,
        P0: &impl MatrixInput,
        opts: ScheduleOptions,
    ) -> Result<Self, Error> {
        let d = model.dims();
        let (n, m) = (d.n(), d.m());
        let zeros_n = vec![0.0; n];
        let zeros_m = vec![0.0; m];
        let template = Filter::new(model.clone(), &zeros_n, P0, opts.form)?;
        let mut f = template.clone();
        let mut gains: Vec<D::Nm> = Vec::new();
        let mut cross: Vec<D::Nm> = Vec::new();
        let mut priors: Vec<D::Nn> = Vec::new();
        for k in 0..opts.max_steps {
            priors.push(to_buf::<D::Nn>(f.predicted_covariance()));
            f.step(&zeros_m, None)?;
            gains.push(to_buf::<D::Nm>(f.gain()));
            if let Some(S) = model.s() {
                cross.push(to_buf::<D::Nm>(
                    cross_gain(S, f.innovation_covariance())?.as_ref(),
                ));
            }
            let P = to_buf::<D::Nn>(f.predicted_covariance());
            // The gain alone can settle while P diverges (an unobservable unstable mode the
            // gain never touches), so P must settle too.
            let p_settled = settled(&[priors[k].clone(), P.clone()], opts.tolerance);
            if k > 0
                && p_settled
                && settled(&gains, opts.tolerance)
                && (cross.is_empty() || settled(&cross, opts.tolerance))
            {
                let steady_prior = P;
                return Ok(Self {
                    template,
                    model,
                    gains,
                    cross,
                    priors,
                    steady_prior,
                    opts,
                });
            }
        }
        Err(Error::RiccatiNoConvergence {
            equation: "gain schedule",
            iterations: opts.max_steps,
            reason: "the filter gain did not settle",
        })
    }

    /// The fixed-gain filter: the steady-state gain of `steady` (from
    /// [`crate::riccati::Dare`] on the same model) for every step.
    ///
    /// # Errors
    /// [`Error::Shape`] if `steady` does not match the model's dimensions; validation errors
    /// naming `P0` for the steady prior.
    pub fn fixed_gain(model: Model<D>, steady: &SteadyState) -> Result<Self, Error> {
        let d = model.dims();
        let (n, m) = (d.n(), d.m());
        if steady.gain.nrows() != n || steady.gain.ncols() != m {
            return Err(Error::Shape {
                name: "K",
                rows: steady.gain.nrows(),
                cols: steady.gain.ncols(),
                expected_rows: n,
                expected_cols: m,
            });
        }
        let template = Filter::new(
            model.clone(),
            &vec![0.0; n],
            &steady.prior,
            CovarianceForm::Joseph,
        )?;
        let mut cross = Vec::new();
        if let Some(S) = model.s() {
            cross.push(to_buf::<D::Nm>(
                cross_gain(S, steady.innovation_cov.as_ref())?.as_ref(),
            ));
        }
        let P = to_buf::<D::Nn>(steady.prior.as_ref());
        Ok(Self {
            template,
            model,
            gains: vec![to_buf::<D::Nm>(steady.gain.as_ref())],
            cross,
            priors: vec![P.clone()],
            steady_prior: P,
            opts: ScheduleOptions::default(),
        })
    }

    /// Number of gains stored (the transient plus the final, steady one).
    pub fn len(&self) -> usize {
        self.gains.len()
    }

    /// Always false: a schedule holds at least the steady gain.
    pub fn is_empty(&self) -> bool {
        self.gains.is_empty()
    }

    /// Gain K_k of step k (the steady gain for k ≥ `len() − 1`).
    pub fn gain(&self, k: usize) -> MatRef<'_, f64> {
        let d = self.model.dims();
        let (n, m) = (d.n(), d.m());
        let i = k.min(self.gains.len() - 1);
        MatRef::from_column_major_slice(&self.gains[i].as_slice()[..n * m], n, m)
    }

    /// The steady-state prior covariance P∞ reached by the schedule.
    pub fn steady_prior(&self) -> MatRef<'_, f64> {
        let n = self.model.dims().n();
        MatRef::from_column_major_slice(&self.steady_prior.as_slice()[..n * n], n, n)
    }

    /// A runner for measurement streams starting at `x0` (allocates its workspace once;
    /// reuse it across streams with [`ScheduledFilter::reset`]).
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming `x0`.
    pub fn runner(&self, x0: &[f64]) -> Result<ScheduledFilter<'_, D>, Error> {
        let d = self.model.dims();
        let (n, m) = (d.n(), d.m());
        let mut r = ScheduledFilter {
            s: self,
            k: 0,
            taken: 0,
            xp: D::Nv::zeros(n),
            xf: D::Nv::zeros(n),
            e: D::Mv::zeros(m),
            full: self.template.clone(),
            in_full: false,
        };
        r.reset(x0)?;
        Ok(r)
    }
}

/// Runs one measurement stream through a [`GainSchedule`].
#[derive(Debug, Clone)]
pub struct ScheduledFilter<'a, D: Dims> {
    s: &'a GainSchedule<D>,
    /// The position in the schedule (it jumps to the steady gain when a fallback ends).
    k: usize,
    /// Steps taken since the last reset.
    taken: usize,
    xp: D::Nv,
    xf: D::Nv,
    e: D::Mv,
    full: Filter<D>,
    in_full: bool,
}

impl<D: Dims> ScheduledFilter<'_, D> {
    /// Restarts at step 0 with prior mean `x0` (the schedule's P0). Allocates nothing.
    ///
    /// # Errors
    /// [`Error::Shape`] / [`Error::NonFinite`] naming `x0`.
    pub fn reset(&mut self, x0: &[f64]) -> Result<(), Error> {
        let n = self.s.model.dims().n();
        load_vec("x0", x0, n, self.xp.as_mut_slice())?;
        self.xf.as_mut_slice()[..n].copy_from_slice(x0);
        self.k = 0;
        self.taken = 0;
        self.in_full = false;
        Ok(())
    }

    /// One step: update with `z_k` (NaN entries are missing and take the full-update
    /// fallback), then predict with `u_k` (`None` = zero input).
    ///
    /// # Errors
    /// [`Error::Shape`] naming `z` or `u` for a wrong length, [`Error::NonFinite`] for an
    /// infinite `z` entry or non-finite `u` entry (the state is then unchanged);
    /// [`Error::Diverged`] naming the step if an entry of the state is no longer finite (its
    /// estimates must not be used).
    #[inline]
    pub fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<(), Error> {
        let s = self.s;
        let d = s.model.dims();
        let (n, m, p) = (d.n(), d.m(), d.p());
        let missing = check_step_inputs(m, p, z, u)?;
        if missing || self.in_full {
            return self.full_step(z, u);
        }
        let idx = self.k.min(s.gains.len() - 1);
        let K = &s.gains[idx].as_slice()[..n * m];
        let F = &s.model.F.as_slice()[..n * n];
        let H = &s.model.H.as_slice()[..m * n];
        let xp = &mut self.xp.as_mut_slice()[..n];
        let xf = &mut self.xf.as_mut_slice()[..n];
        let e = &mut self.e.as_mut_slice()[..m];
        // e = z − H x_{k|k−1}
        e.copy_from_slice(&z[..m]);
        for j in 0..n {
            let xj = xp[j];
            for i in 0..m {
                e[i] -= H[i + j * m] * xj;
            }
        }
        // x_{k|k} = x_{k|k−1} + K e
        xf.copy_from_slice(xp);
        add_mat_vec(n, K, e, xf);
        // x_{k+1|k} = F x_{k|k} + B u (+ S Σ⁻¹ e)
        propagate_mean(n, p, F, &s.model.B.as_slice()[..n * p], xf, u, xp);
        if !s.cross.is_empty() {
            add_mat_vec(n, &s.cross[idx].as_slice()[..n * m], e, xp);
        }
        let step = self.taken;
        self.k += 1;
        self.taken += 1;
        for (what, x) in [("x_{k|k}", &*xf), ("x_{k+1|k}", &*xp)] {
            if let Some(value) = diverged(x.iter().copied()) {
                return Err(Error::Diverged { step, what, value });
            }
        }
        Ok(())
    }

    fn full_step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<(), Error> {
        let s = self.s;
        let n = s.model.dims().n();
        if !self.in_full {
            let P = if self.k < s.priors.len() {
                &s.priors[self.k]
            } else {
                &s.steady_prior
            };
            let P = MatRef::from_column_major_slice(&P.as_slice()[..n * n], n, n);
            self.full.reset(&self.xp.as_slice()[..n], &P)?;
            self.in_full = true;
        }
        // The internal filter counts from its restart: name the stream's step instead.
        let step = self.taken;
        self.full.step(z, u).map_err(|e| match e {
            Error::Diverged { what, value, .. } => Error::Diverged { step, what, value },
            e => e,
        })?;
        self.xf.as_mut_slice()[..n].copy_from_slice(self.full.state());
        self.xp.as_mut_slice()[..n].copy_from_slice(self.full.predicted_state());
        let e = self.full.innovation();
        self.e.as_mut_slice()[..e.len()].copy_from_slice(e);
        // Back on the schedule once the covariance is at the steady state again.
        let Pp = self.full.predicted_covariance();
        let Ps = &s.steady_prior.as_slice()[..n * n];
        let (mut diff, mut big) = (0.0_f64, 0.0_f64);
        for j in 0..n {
            for i in 0..n {
                diff = diff.max((Pp[(i, j)] - Ps[i + j * n]).abs());
                big = big.max(Ps[i + j * n].abs());
            }
        }
        if diff <= s.opts.reentry_tolerance * big {
            self.in_full = false;
            // (Any position at or past the last gain does the same: the gain index and the
            // prior of a later fallback both saturate there.)
            self.k = self.k.max(s.gains.len() - 1);
        }
        // The place in the schedule stands still during full steps: only the switch into them
        // reads it, and the return above puts it at the last gain.
        self.taken += 1;
        Ok(())
    }

    /// Filtered estimate x_{k|k} after the last step.
    pub fn state(&self) -> &[f64] {
        &self.xf.as_slice()[..self.s.model.dims().n()]
    }

    /// One-step prediction x_{k+1|k}.
    pub fn predicted_state(&self) -> &[f64] {
        &self.xp.as_slice()[..self.s.model.dims().n()]
    }

    /// Innovation e_k of the last step (0 in missing entries on a fallback step).
    pub fn innovation(&self) -> &[f64] {
        &self.e.as_slice()[..self.s.model.dims().m()]
    }

    /// Steps taken since the last reset.
    pub fn steps(&self) -> usize {
        self.taken
    }

    /// Whether the next step runs on the schedule (false while in the full-update fallback).
    pub fn on_schedule(&self) -> bool {
        !self.in_full
    }
}

/// Whether the last two entries of `seq` agree to `tol` relative (max norm).
fn settled<B: Buf<f64>>(seq: &[B], tol: f64) -> bool {
    let (a, b) = (seq[seq.len() - 1].as_slice(), seq[seq.len() - 2].as_slice());
    let big = a.iter().fold(0.0_f64, |acc, v| acc.max(v.abs()));
    let diff = a
        .iter()
        .zip(b)
        .fold(0.0_f64, |acc, (x, y)| acc.max((x - y).abs()));
    diff <= tol * big
}

fn to_buf<B: Buf<f64>>(M: MatRef<'_, f64>) -> B {
    let (r, c) = (M.nrows(), M.ncols());
    let mut b = B::zeros(r * c);
    let s = b.as_mut_slice();
    for j in 0..c {
        for i in 0..r {
            s[i + j * r] = M[(i, j)];
        }
    }
    b
}

/// S Σ⁻¹ (Σ⁺ when Σ is singular, through the symmetric eigen-decomposition with the
/// engine's [`crate::RANK_TOL`]).
fn cross_gain(S: MatRef<'_, f64>, Sigma: MatRef<'_, f64>) -> Result<Mat<f64>, Error> {
    let m = Sigma.nrows();
    let smax = (0..m).map(|i| Sigma[(i, i)].abs()).fold(0.0, f64::max);
    if let Ok(llt) = Sigma.llt(Side::Lower) {
        let L = llt.L();
        let dmin = (0..m)
            .map(|i| L[(i, i)] * L[(i, i)])
            .fold(f64::INFINITY, f64::min);
        // A regular Σ could also go down the eigen-decomposition (S Σ⁺ = S Σ⁻¹ to round-off,
        // only slower): this test chooses the faster path.
        if dmin > crate::RANK_TOL * smax {
            return Ok(llt.solve(S.transpose()).transpose().to_owned());
        }
    }
    let evd = Sigma
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| Error::Factorisation {
            name: "H P H^T + R",
            reason: "symmetric eigen-decomposition failed",
        })?;
    let U = evd.U();
    let w = evd.S().column_vector();
    let wmax = (0..m).map(|i| w[i].abs()).fold(0.0, f64::max);
    let mut SU = S * U;
    for j in 0..m {
        let inv = if w[j] > crate::RANK_TOL * wmax {
            1.0 / w[j]
        } else {
            0.0
        };
        for i in 0..SU.nrows() {
            SU[(i, j)] *= inv;
        }
    }
    Ok(SU * U.transpose())
}
