//! The Rauch–Tung–Striebel fixed-interval smoother over a recorded forward pass of a
//! [`Filter`] on either storage path, with the smoothed covariances.
//!
//! After each filter step `k` the smoother records x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k} and
//! the cross-covariance C_k = Cov(x_k, x_{k+1} | z_0..z_k) = P_{k|k} Fᵀ − K_k Sᵀ (the second
//! term is the correlated-noise correction; it vanishes when S = 0 or z_k is missing). The
//! backward pass is
//!
//! J_k = C_k P_{k+1|k}⁻¹,  x_{k|N} = x_{k|k} + J_k (x_{k+1|N} − x_{k+1|k}),
//! P_{k|N} = P_{k|k} + J_k (P_{k+1|N} − P_{k+1|k}) J_kᵀ,
//!
//! where J_k comes from the solve P_{k+1|k} J_kᵀ = C_kᵀ by Cholesky — never an explicit
//! inverse. A singular P_{k+1|k} (e.g. a noise-free state component) takes the documented
//! fallback: the minimum-norm solution through the symmetric eigen-decomposition, with
//! eigenvalues below [`crate::RANK_TOL`]·λ_max treated as zero.
//!
//! The record and the backward pass are one type, [`Rts`], for both smoothers: the linear
//! [`RtsSmoother`] (`Rts<Linear>`) and the nonlinear
//! [`NonlinearRts`](crate::nonlinear::NonlinearRts) (`Rts<Nonlinear>`, C_k formed by the
//! EKF or UKF) differ only in how a step is read from the filter. [`Rts::smooth_sqrt`] runs
//! the same backward pass in square-root form (triangular factors of the smoothed
//! covariances, PSD by construction).
#![allow(non_snake_case)]

mod sqrt;

use std::marker::PhantomData;

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Par};

use crate::filter::diverged;
use crate::riccati::symmetrise;
use crate::storage::Dims;
use crate::{CovarianceForm, Error, Filter, MatrixInput, Model};

mod psd;
use psd::PsdSolve;
#[cfg(test)]
use psd::solve_psd;

pub use sqrt::SqrtSmoothed;

/// Recorder and backward pass of a Rauch–Tung–Striebel smoother (offline: it stores every
/// step), for the filter family `K`: [`RtsSmoother`] (`Rts<Linear>`) records a [`Filter`],
/// [`NonlinearRts`](crate::nonlinear::NonlinearRts) an EKF or UKF. The record — step after
/// step, column-major: filtered means x_{k|k} (n each) and covariances P_{k|k} (n×n), the
/// predicted x_{k+1|k} and P_{k+1|k}, and the cross-covariances C_k = cov(x_k, x_{k+1} |
/// z_0..z_k) (n×n) — and the backward pass are shared; the families differ only in how a
/// step is read from the filter.
///
/// # Example
/// ```
/// use kalman::smoother::{Linear, Rts};
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
///
/// // A random walk, q = r = 1, prior N(0, 1), measured as 1 and 3: the batch solution is
/// // x = (1, 2) (see [`Filter::run_smoothed`]).
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
/// let mut rts = Rts::<Linear>::new();
/// for z in [1.0, 3.0] {
///     filter.step(&[z], None)?;
///     rts.record(&filter)?;
/// }
/// assert_eq!(rts.len(), 2);
/// assert!((rts.smooth()?.means[(0, 1)] - 2.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Rts<K> {
    /// States per step, fixed by the first recorded step.
    n: usize,
    /// Numbers per stored mean: n, or more for a state on a manifold
    /// ([`crate::Dims::stored`]).
    stored: usize,
    steps: usize,
    xf: Vec<f64>,
    pf: Vec<f64>,
    xp: Vec<f64>,
    pp: Vec<f64>,
    ct: Vec<f64>,
    family: PhantomData<K>,
}

/// The family of [`RtsSmoother`]: the linear [`Filter`], with C_k = P_{k|k} Fᵀ − K_k Sᵀ
/// from the step's model.
///
/// # Example
/// ```
/// use kalman::smoother::{Linear, Rts, RtsSmoother};
///
/// // The alias and the generic name are one type.
/// let rts: Rts<Linear> = RtsSmoother::new();
/// assert!(rts.is_empty() && rts.len() == 0);
/// ```
#[derive(Debug, Clone, Copy)]
pub enum Linear {}

/// The RTS smoother of the linear [`Filter`] on either storage path. The common path is one
/// call, [`Filter::run_smoothed`]; record by hand (below) to pass control inputs or per-step
/// models ([`RtsSmoother::record_with`]) or to interleave other work.
///
/// # Example
/// ```
/// use kalman::smoother::RtsSmoother;
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
///
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.1]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[10.0]], CovarianceForm::Joseph)?;
/// let mut rts = RtsSmoother::new(); // n is taken from the first recorded step
/// for z in [1.0, 1.3, f64::NAN, 0.8] {
///     filter.step(&[z], None)?;
///     rts.record(&filter)?;
/// }
/// let s = rts.smooth()?;
/// // Smoothing never increases the variance; at the last step it equals the filter's.
/// assert!(s.covariances[0][(0, 0)] <= 10.0);
/// assert!((s.covariances[3][(0, 0)] - filter.covariance()[(0, 0)]).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub type RtsSmoother = Rts<Linear>;

/// The family of [`NonlinearRts`](crate::nonlinear::NonlinearRts): any
/// [`ForwardPass`](crate::nonlinear::ForwardPass) (the EKF and the UKF), which forms C_k
/// itself.
///
/// # Example
/// ```
/// use kalman::nonlinear::NonlinearRts;
/// use kalman::smoother::{Nonlinear, Rts};
///
/// // Nothing recorded: the backward pass is a typed error, not a panic.
/// let rts: Rts<Nonlinear> = NonlinearRts::new();
/// assert!(matches!(rts.smooth(), Err(kalman::Error::Dimension { name: "steps", .. })));
/// ```
#[derive(Debug, Clone, Copy)]
pub enum Nonlinear {}

/// Output of [`RtsSmoother::smooth`] and [`Filter::run_smoothed`].
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
///
/// // A constant observed twice in unit noise, prior N(0, 1): every smoothed estimate is the
/// // posterior of all data, mean (1 + 2)/3 = 1 and variance 1/3.
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.0]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
/// let s = filter.run_smoothed([[1.0], [2.0]])?;
/// assert_eq!((s.means.nrows(), s.means.ncols(), s.covariances.len()), (1, 2, 2));
/// for k in 0..2 {
///     assert!((s.means[(0, k)] - 1.0).abs() < 1e-12 && (s.covariances[k][(0, 0)] - 1.0 / 3.0).abs() < 1e-12);
/// }
/// # Ok::<(), kalman::Error>(())
/// ```
///
/// `M` is the matrix type: faer's `Mat<f64>` as returned, nalgebra's `DMatrix<f64>` after
/// `.to_nalgebra()` (feature `nalgebra`).
#[derive(Debug, Clone)]
pub struct Smoothed<M = Mat<f64>> {
    /// Smoothed means: column k is x_{k|N−1} (n×N).
    pub means: M,
    /// Smoothed covariances P_{k|N−1}, one n×n matrix per step.
    pub covariances: Vec<M>,
}

impl<K> Default for Rts<K> {
    fn default() -> Self {
        Self {
            n: 0,
            stored: 0,
            steps: 0,
            xf: Vec::new(),
            pf: Vec::new(),
            xp: Vec::new(),
            pp: Vec::new(),
            ct: Vec::new(),
            family: PhantomData,
        }
    }
}

impl<K> Rts<K> {
    /// An empty recorder; the number of states is fixed by the first recorded step.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of recorded steps.
    pub fn len(&self) -> usize {
        self.steps
    }

    /// Whether nothing is recorded.
    pub fn is_empty(&self) -> bool {
        self.steps == 0
    }

    /// Reserves room for `steps` more steps of `n` states, so that a long record does not
    /// copy its storage as it grows (three n×n matrices and two n-vectors per step).
    pub fn reserve(&mut self, n: usize, steps: usize) {
        let (v, m) = (n * steps, n * n * steps);
        self.xf.reserve(v);
        self.xp.reserve(v);
        self.pf.reserve(m);
        self.pp.reserve(m);
        self.ct.reserve(m);
    }

    /// Admits a step of a filter with `n` states: the first step fixes n, a later one must
    /// match it.
    ///
    /// # Errors
    /// [`Error::Dimension`] naming n if it differs from that of the steps recorded before.
    pub(crate) fn admit(&mut self, n: usize) -> Result<(), Error> {
        self.admit_stored(n, n)
    }

    /// [`Self::admit`] for a state of `n` tangent dimensions stored in `stored` numbers.
    pub(crate) fn admit_stored(&mut self, n: usize, stored: usize) -> Result<(), Error> {
        if self.steps == 0 {
            (self.n, self.stored) = (n, stored);
        }
        if n != self.n {
            Err(mismatch(n))
        } else if stored != self.stored {
            Err(Error::Dimension {
                name: "stored",
                value: stored,
                rule: "the smoother's stored length must match the filter's",
            })
        } else {
            Ok(())
        }
    }

    /// Entries of a recorded mean and of a recorded covariance.
    pub(crate) fn mean_len(&self) -> usize {
        self.stored
    }
    pub(crate) fn covariance_len(&self) -> usize {
        self.n * self.n
    }

    /// Whether the recorded means are stored points of a manifold longer than n.
    pub(crate) fn is_stored(&self) -> bool {
        self.stored != self.n
    }

    /// Appends an admitted step: x_{k|k}, x_{k+1|k} (n each) and P_{k|k}, P_{k+1|k}, C_k
    /// (n×n).
    pub(crate) fn push(&mut self, xf: &[f64], xp: &[f64], [pf, pp, ct]: [MatRef<'_, f64>; 3]) {
        self.xf.extend_from_slice(xf);
        self.xp.extend_from_slice(xp);
        push(&mut self.pf, pf);
        push(&mut self.pp, pp);
        push(&mut self.ct, ct);
        self.steps += 1;
    }

    /// The RTS backward pass: J_k = C_k P_{k+1|k}⁺ (a PSD solve), x_{k|N} = x_{k|k} +
    /// J_k (x_{k+1|N} − x_{k+1|k}), P_{k|N} = P_{k|k} + J_k (P_{k+1|N} − P_{k+1|k}) J_kᵀ
    /// (symmetrised). `check(k, means, P_{k|N})` runs at each step before P_{k|N} is stored
    /// (the means of steps k..N already in place); its error ends the pass.
    ///
    /// # Errors
    /// [`Error::Dimension`] if nothing was recorded; [`Error::Factorisation`] if the eigen
    /// fallback for a singular P_{k+1|k} fails; `check`'s error.
    pub(crate) fn backward(
        &self,
        mut check: impl FnMut(usize, &Mat<f64>, &Mat<f64>) -> Result<(), Error>,
    ) -> Result<Smoothed, Error> {
        // Visited last step first: collected in that order, then reversed.
        let mut covs = Vec::with_capacity(self.steps);
        let means = self.backward_each(|k, means, P| {
            check(k, means, P)?;
            covs.push(P.clone());
            Ok(())
        })?;
        covs.reverse();
        Ok(Smoothed {
            means,
            covariances: covs,
        })
    }

    /// The backward pass of [`Self::backward`], handing each step's P_{k|N} to
    /// `visit(k, means, P_{k|N})` (last step first) instead of keeping them all; returns
    /// the smoothed means.
    pub(crate) fn backward_each(
        &self,
        visit: impl FnMut(usize, &Mat<f64>, &Mat<f64>) -> Result<(), Error>,
    ) -> Result<Mat<f64>, Error> {
        self.backward_on(None, visit)
    }

    /// The backward pass of [`Self::backward_each`], on the manifold `space` if given: the
    /// means are stored points (stored × N) and
    /// `x_{k|N} = x_{k|k} ⊞ J_k (x_{k+1|N} ⊟ x_{k+1|k})`, the covariances tangent.
    pub(crate) fn backward_on(
        &self,
        space: Option<&dyn crate::nonlinear::Manifold>,
        mut visit: impl FnMut(usize, &Mat<f64>, &Mat<f64>) -> Result<(), Error>,
    ) -> Result<Mat<f64>, Error> {
        let (n, N) = (self.n, self.steps);
        let ns = self.stored;
        self.require_steps()?;
        fn mat(v: &[f64], k: usize, n: usize) -> MatRef<'_, f64> {
            MatRef::from_column_major_slice(&v[k * n * n..(k + 1) * n * n], n, n)
        }
        fn vec(v: &[f64], k: usize, n: usize) -> MatRef<'_, f64> {
            MatRef::from_column_major_slice(&v[k * n..(k + 1) * n], n, 1)
        }
        let mut means = Mat::<f64>::zeros(ns, N);
        means
            .as_mut()
            .col_mut(N - 1)
            .copy_from(vec(&self.xf, N - 1, ns).col(0));
        let mut next = mat(&self.pf, N - 1, n).to_owned();
        visit(N - 1, &means, &next)?;
        // The manifold branch's workspaces: x_{k+1|N} ⊟ x_{k+1|k}, J_k times it, and the
        // stored points x_{k+1|N} and x_{k|N}.
        let (mut d, mut dv) = (vec![0.0; n], vec![0.0; n]);
        let (mut after, mut point) = (vec![0.0; ns], vec![0.0; ns]);
        // Jᵀ, the products and P_{k|N}: every step works in these.
        let mut solver = PsdSolve::new(n);
        let (mut Jt, mut diff) = (Mat::<f64>::zeros(n, n), Mat::<f64>::zeros(n, n));
        let (mut JD, mut P) = (Mat::<f64>::zeros(n, n), Mat::<f64>::zeros(n, n));
        let (mut dx, mut Jdx) = (Mat::<f64>::zeros(n, 1), Mat::<f64>::zeros(n, 1));
        for k in (0..N - 1).rev() {
            let Pp = mat(&self.pp, k, n);
            solver.solve(Pp, mat(&self.ct, k, n).transpose(), Jt.as_mut())?;
            let J = Jt.transpose();
            match space {
                None => {
                    let xp = vec(&self.xp, k, n);
                    for i in 0..n {
                        dx[(i, 0)] = means[(i, k + 1)] - xp[(i, 0)];
                    }
                    matmul(Jdx.as_mut(), Accum::Replace, J, dx.as_ref(), 1.0, Par::Seq);
                    let xf = vec(&self.xf, k, n);
                    for i in 0..n {
                        means[(i, k)] = xf[(i, 0)] + Jdx[(i, 0)];
                    }
                }
                Some(space) => {
                    for (i, a) in after.iter_mut().enumerate() {
                        *a = means[(i, k + 1)];
                    }
                    space.boxminus(&after, &self.xp[k * ns..(k + 1) * ns], &mut d);
                    for (i, v) in dv.iter_mut().enumerate() {
                        *v = (0..n).map(|j| J[(i, j)] * d[j]).sum();
                    }
                    space.boxplus(&self.xf[k * ns..(k + 1) * ns], &dv, &mut point);
                    for (i, v) in point.iter().enumerate() {
                        means[(i, k)] = *v;
                    }
                }
            }
            // P_{k|N} = P_{k|k} + J (P_{k+1|N} − P_{k+1|k}) Jᵀ.
            for j in 0..n {
                for i in 0..n {
                    diff[(i, j)] = next[(i, j)] - Pp[(i, j)];
                }
            }
            matmul(JD.as_mut(), Accum::Replace, J, diff.as_ref(), 1.0, Par::Seq);
            matmul(
                P.as_mut(),
                Accum::Replace,
                JD.as_ref(),
                Jt.as_ref(),
                1.0,
                Par::Seq,
            );
            let Pf = mat(&self.pf, k, n);
            for j in 0..n {
                for i in 0..n {
                    P[(i, j)] += Pf[(i, j)];
                }
            }
            symmetrise(&mut P);
            visit(k, &means, &P)?;
            std::mem::swap(&mut next, &mut P);
        }
        Ok(means)
    }
}

impl Rts<Linear> {
    /// Records the step the filter has just taken with its own (time-invariant) model.
    ///
    /// # Errors
    /// [`Error::Dimension`] if the filter's n differs from that of the steps recorded before.
    pub fn record<D: Dims>(&mut self, filter: &Filter<D>) -> Result<(), Error> {
        self.record_with(filter, filter.model())
    }

    /// Records the step the filter has just taken with `model` (time-varying systems: the
    /// model passed to [`Filter::step_with`] for that step).
    ///
    /// # Errors
    /// [`Error::Dimension`] if n differs from that of the steps recorded before, or the
    /// model's n from the filter's.
    pub fn record_with<D: Dims>(
        &mut self,
        filter: &Filter<D>,
        model: &Model<D>,
    ) -> Result<(), Error> {
        let n = filter.state().len();
        self.admit(n)?;
        if model.dims().n() != n {
            return Err(mismatch(n));
        }
        let Pf = filter.covariance();
        // C_k = P_{k|k} Fᵀ − K_k Sᵀ.
        let mut C = Pf * model.f().transpose();
        if let Some(S) = model.s() {
            C -= filter.gain() * S.transpose();
        }
        self.push(
            filter.state(),
            filter.predicted_state(),
            [Pf, filter.predicted_covariance(), C.as_ref()],
        );
        Ok(())
    }

    /// The backward pass over all recorded steps.
    ///
    /// # Errors
    /// [`Error::Dimension`] if nothing was recorded; [`Error::Factorisation`] if the eigen
    /// fallback for a singular P_{k+1|k} fails; [`Error::Diverged`] naming the step if a
    /// smoothed mean or variance is not finite.
    pub fn smooth(&self) -> Result<Smoothed, Error> {
        let n = self.n;
        self.backward(|k, means, P| {
            smoothed_finite(
                k,
                (0..n).map(|i| means[(i, k)]),
                ("P_{k|N}", (0..n).map(|i| P[(i, i)])),
            )
        })
    }
}

impl<D: Dims> Filter<D> {
    /// Runs the filter over `measurements` (one m-vector per step, NaN entries missing, no
    /// control input) and returns the Rauch–Tung–Striebel smoothed means and covariances of
    /// every step: the common offline path in one call. The filter is left after the last
    /// step, so [`Filter::state`] is the filtered estimate there. For control inputs or
    /// per-step models, record by hand with [`RtsSmoother`].
    ///
    /// # Errors
    /// The errors of [`Filter::step`] (naming the measurement's shape, or the step that
    /// diverged) and of [`RtsSmoother::smooth`] ([`Error::Dimension`] for no measurements).
    ///
    /// # Example
    /// ```
    /// use kalman::{CovarianceForm, DynDims, Filter, Model};
    ///
    /// // Random walk, q = r = 1, prior N(0, 1), measurements 1 and 3.
    /// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]])?;
    /// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
    /// let s = filter.run_smoothed([[1.0], [3.0]])?;
    /// // The batch least-squares solution: information matrix [[3, −1], [−1, 2]], rhs [1, 3]
    /// // gives x = (1, 2) with variances 2/5 and 3/5.
    /// assert!((s.means[(0, 0)] - 1.0).abs() < 1e-12 && (s.means[(0, 1)] - 2.0).abs() < 1e-12);
    /// assert!((s.covariances[0][(0, 0)] - 0.4).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn run_smoothed<Z: AsRef<[f64]>>(
        &mut self,
        measurements: impl IntoIterator<Item = Z>,
    ) -> Result<Smoothed, Error> {
        let mut rts = RtsSmoother::new();
        for z in measurements {
            self.step(z.as_ref(), None)?;
            rts.record(self)?;
        }
        rts.smooth()
    }
}

impl<D: Dims> Model<D> {
    /// The offline path in one call: filters the `measurements` — one row per step
    /// and one column per measurement (N×m; a nalgebra `DVector` of N scalar measurements
    /// with the feature `nalgebra`), NaN entries missing, no control input — from the prior
    /// `N(x0, P0)` in the Joseph form, and returns the Rauch–Tung–Striebel smoothed means
    /// and covariances of every step. The same as [`Filter::new`] followed by
    /// [`Filter::run_smoothed`], without keeping the filter; with the feature `nalgebra`,
    /// `.to_nalgebra()` on the result gives a `DMatrix` of means (column k is x_{k|N−1}) and
    /// a `Vec<DMatrix>` of covariances.
    ///
    /// # Errors
    /// [`Error::Shape`] naming `measurements` if they do not have m columns; otherwise as
    /// [`Filter::new`] (naming `x0` or `P0`) and [`Filter::run_smoothed`].
    ///
    /// # Example
    /// ```
    /// use kalman::Model;
    ///
    /// // A constant observed as 1, (missing), 3 in unit noise, prior N(0, 100): every
    /// // smoothed mean is the posterior mean of the constant, (1 + 3)/(2 + 1/100).
    /// let model = Model::from_matrices(&[[1.0]], &[[1.0]], &[[0.0]], &[[1.0]])?;
    /// let s = model.smooth(&[0.0], &[[100.0]], &[[1.0], [f64::NAN], [3.0]])?;
    /// let mean = 4.0 / 2.01;
    /// assert!((0..3).all(|k| (s.means[(0, k)] - mean).abs() < 1e-12));
    /// assert!((s.covariances[1][(0, 0)] - 1.0 / 2.01).abs() < 1e-12);
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn smooth(
        &self,
        x0: &[f64],
        P0: &impl MatrixInput,
        measurements: &impl MatrixInput,
    ) -> Result<Smoothed, Error> {
        let m = self.dims.m();
        let z = measurements;
        if z.ncols() != m {
            return Err(Error::Shape {
                name: "measurements",
                rows: z.nrows(),
                cols: z.ncols(),
                expected_rows: z.nrows(),
                expected_cols: m,
            });
        }
        let rows = (0..z.nrows()).map(|k| (0..m).map(|j| z.at(k, j)).collect::<Vec<_>>());
        Filter::new(self.clone(), x0, P0, CovarianceForm::Joseph)?.run_smoothed(rows)
    }
}

impl<K> Rts<K> {
    /// [`Error::Dimension`] naming `steps` when nothing is recorded (a backward pass needs a
    /// step).
    pub(crate) fn require_steps(&self) -> Result<(), Error> {
        if self.steps == 0 {
            return Err(Error::Dimension {
                name: "steps",
                value: 0,
                rule: "record at least one filter step",
            });
        }
        Ok(())
    }
}

/// [`Error::Diverged`] naming step `k` if an entry of its smoothed mean `x`, or of `p`
/// (the diagonal of P_{k|N}, or the entries of its factor, as `p.0` names them), is not
/// finite.
fn smoothed_finite(
    k: usize,
    x: impl IntoIterator<Item = f64>,
    p: (&'static str, impl IntoIterator<Item = f64>),
) -> Result<(), Error> {
    let x_bad = diverged(x).map(|v| ("x_{k|N}", v));
    match x_bad.or_else(|| diverged(p.1).map(|v| (p.0, v))) {
        Some((what, value)) => Err(Error::Diverged {
            step: k,
            what,
            value,
        }),
        None => Ok(()),
    }
}

/// The error for a step whose n (`value`) does not match the record's.
fn mismatch(value: usize) -> Error {
    Error::Dimension {
        name: "n",
        value,
        rule: "the smoother's n must match the filter's",
    }
}

fn push(v: &mut Vec<f64>, M: MatRef<'_, f64>) {
    for j in 0..M.ncols() {
        for i in 0..M.nrows() {
            v.push(M[(i, j)]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DynDims;

    #[test]
    fn model_smooth_is_the_batch_posterior_across_a_gap_and_names_a_bad_prior() {
        // Random walk, q = r = 1, prior N(0, 1), z = (1, missing, 3). Batch information
        // matrix of (x0, x1, x2): prior 1 + measurement 1 on x0 and x2, dynamics
        // [[1, −1], [−1, 1]] per transition:
        // Λ = [[3, −1, 0], [−1, 2, −1], [0, −1, 2]], η = (1, 0, 3), det Λ = 7; the smoothed
        // means are Λ⁻¹η and the variances Λ⁻¹'s diagonal.
        let model = Model::from_matrices(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]]).expect("valid");
        let s = model
            .smooth(&[0.0], &[[1.0]], &[[1.0], [f64::NAN], [3.0]])
            .expect("runs");
        // Λ⁻¹ = adj(Λ)/7 with adj = [[3, 2, 1], [2, 6, 3], [1, 3, 5]].
        let inv = [[3.0, 2.0, 1.0], [2.0, 6.0, 3.0], [1.0, 3.0, 5.0]];
        for k in 0..3 {
            let mean = (inv[k][0] * 1.0 + inv[k][2] * 3.0) / 7.0;
            assert!((s.means[(0, k)] - mean).abs() < 1e-12, "mean {k}");
            assert!(
                (s.covariances[k][(0, 0)] - inv[k][k] / 7.0).abs() < 1e-12,
                "var {k}"
            );
        }
        let bad = model.smooth(&[0.0], &[[-1.0]], &[[1.0]]);
        assert!(matches!(
            bad,
            Err(Error::NotPositiveSemidefinite { name: "P0", .. })
        ));
        let wide = model.smooth(&[0.0], &[[1.0]], &[[1.0, 2.0]]);
        assert!(matches!(
            wide,
            Err(Error::Shape {
                name: "measurements",
                cols: 2,
                expected_cols: 1,
                ..
            })
        ));
    }

    #[test]
    fn scalar_random_walk_two_steps() {
        // x1 = x0 + w, q = 1; z_k = x_k + v, r = 1; prior x0 ~ N(0, 1).
        let model = Model::new(
            DynDims::new(1, 1, 0).expect("must succeed"),
            &[[1.0]],
            &[[1.0]],
            &[[1.0]],
            &[[1.0]],
        )
        .expect("must succeed");
        let mut f =
            Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph).expect("must succeed");
        let mut s = RtsSmoother::new();
        assert_eq!((s.len(), s.is_empty()), (0, true));
        for z in [1.0, 3.0] {
            f.step(&[z], None).expect("must succeed");
            s.record(&f).expect("must succeed");
        }
        assert_eq!((s.len(), s.is_empty()), (2, false));
        let out = s.smooth().expect("must succeed");
        // Batch: information matrix [[1+1+1, −1], [−1, 1+1]], rhs [1, 3]: x = [5/5, 10/5]/… solve.
        // det = 3·2 − 1 = 5; x0 = (2·1 + 1·3)/5 = 1, x1 = (1·1 + 3·3)/5 = 2.
        assert!((out.means[(0, 0)] - 1.0).abs() < 1e-14);
        assert!((out.means[(0, 1)] - 2.0).abs() < 1e-14);
        // Smoothed variances: diagonal of the inverse information matrix: 2/5, 3/5.
        assert!((out.covariances[0][(0, 0)] - 0.4).abs() < 1e-14);
        assert!((out.covariances[1][(0, 0)] - 0.6).abs() < 1e-14);
    }

    #[test]
    fn singular_predicted_covariance_takes_the_fallback() {
        let a = faer::mat![[2.0, 0.0], [0.0, 0.0]];
        let b = faer::mat![[4.0], [0.0]];
        let x = solve_psd(a.as_ref(), b.as_ref()).expect("must succeed");
        assert!((x[(0, 0)] - 2.0).abs() < 1e-15 && x[(1, 0)].abs() < 1e-15);
    }

    #[test]
    fn a_factor_with_a_tiny_pivot_takes_the_fallback_too() {
        // Correlation ρ = 1 − 1e-14 between two states of scales 10 and 1e-6: the scaled
        // matrix [[1, ρ], [ρ, 1]] has the eigenvalue 1 − ρ ≤ RANK_TOL·λ_max, so the solve
        // must treat it as singular. With B = A (1, 1)ᵀ (in the range) the scaled solution
        // y = D X of the pseudo-inverse is the minimum-norm one, along (1, 1): y₁ = y₂. The
        // Cholesky answer would be y = D (1, 1)ᵀ = (10, 1e-6). A X = B holds to round-off.
        let (s1, s2, rho) = (10.0, 1e-6, 1.0 - 1e-14);
        let a = faer::mat![[s1 * s1, rho * s1 * s2], [rho * s1 * s2, s2 * s2]];
        let b = faer::mat![[s1 * s1 + rho * s1 * s2], [rho * s1 * s2 + s2 * s2]];
        let x = solve_psd(a.as_ref(), b.as_ref()).expect("must succeed");
        // D X minimum-norm in the scaled system: both scaled components (s1·x1, s2·x2) equal.
        let (y1, y2) = (s1 * x[(0, 0)], s2 * x[(1, 0)]);
        assert!((y1 - y2).abs() < 1e-6 * y1.abs(), "{x:?}");
        let r = &a * &x - &b;
        assert!(r[(0, 0)].abs() < 1e-12 * b[(0, 0)].abs(), "{r:?}");
        assert!(r[(1, 0)].abs() < 1e-12 * s1 * s2, "{r:?}");
    }

    #[test]
    fn states_of_very_different_scales_are_not_a_dependence() {
        // diag(100, 1e-14) is perfectly conditioned once scaled: the solve must be the exact
        // (4, 1e14), not the truncated (4, 0) a rank test on the raw diagonal would give (the
        // smoother's gyro-bias variance of 1e-12 (rad/s)² beside position variances of m²).
        let a = faer::mat![[100.0, 0.0], [0.0, 1e-14]];
        let b = faer::mat![[400.0], [1.0]];
        let x = solve_psd(a.as_ref(), b.as_ref()).expect("must succeed");
        assert!(
            (x[(0, 0)] - 4.0).abs() < 1e-14 && (x[(1, 0)] - 1e14).abs() < 1.0,
            "{x:?}"
        );
    }
}
