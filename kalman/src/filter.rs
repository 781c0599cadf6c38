//! The filter: state, workspaces and the allocation-free step (update with `z_k`, then
//! prediction to `k + 1`). The Joseph and standard forms are in `dense` (an update stage and
//! a prediction stage), the square-root form in `sqrt` (one pre-array triangularised).
#![allow(non_snake_case)]

use crate::kernels::LN_2PI;
use faer::MatRef;

use crate::Error;
use crate::model::{MatrixInput, Model, ModelSource, check_vec, checked_factor, load, load_vec};
use crate::storage::{Buf, Dims, DynDims};

mod dense;
mod imm_mode;
mod sqrt;

/// The first entry of `values` that is NaN or infinite.
#[inline(always)]
pub(crate) fn diverged(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    values.into_iter().find(|v| !v.is_finite())
}

/// [`Error::Diverged`] naming `what` at `step` if the vector `x` or the diagonal of the
/// n×n matrix `P` has diverged.
#[inline(always)]
pub(crate) fn check_diverged(
    step: usize,
    (xname, x): (&'static str, &[f64]),
    (pname, P): (&'static str, &[f64]),
    n: usize,
) -> Result<(), Error> {
    if let Some(value) = diverged(x[..n].iter().copied()) {
        return Err(Error::Diverged {
            step,
            what: xname,
            value,
        });
    }
    if let Some(value) = diverged((0..n).map(|i| P[i + i * n])) {
        return Err(Error::Diverged {
            step,
            what: pname,
            value,
        });
    }
    Ok(())
}

/// How the covariance update is computed. All three give the same P in exact arithmetic.
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
///
/// // The three forms agree on a well-conditioned problem.
/// let mut last = Vec::new();
/// for form in [CovarianceForm::Joseph, CovarianceForm::Standard, CovarianceForm::SquareRoot] {
///     let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.1]], &[[1.0]])?;
///     let mut f = Filter::new(model, &[0.0], &[[1.0]], form)?;
///     f.step(&[1.0], None)?;
///     last.push(f.covariance()[(0, 0)]);
/// }
/// assert!((last[0] - last[1]).abs() < 1e-14 && (last[0] - last[2]).abs() < 1e-14);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
pub enum CovarianceForm {
    /// `P⁺ = (I − KH) P (I − KH)ᵀ + K R Kᵀ`: PSD for any gain, robust to round-off (default).
    #[default]
    Joseph,
    /// `P⁺ = P − K Σ Kᵀ` (one triangle computed, then mirrored): cheapest, least robust.
    Standard,
    /// A square factor `L` with `P = L Lᵀ` propagated by orthogonal (Householder LQ)
    /// triangularisation of a pre-array: P is PSD by construction. The triangularisation
    /// runs in the crate's own loops at O((m + 2n)³) with an (m + 2n)² workspace: meant for
    /// small and medium n (use Joseph for n in the hundreds).
    SquareRoot,
}

/// What one step produced (a small `Copy` struct; vectors and matrices are read through
/// [`Filter`]'s accessors).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepInfo {
    /// Index `k` of the step (0 for the first measurement).
    pub step: usize,
    /// Number of measurement entries used (entries that were not NaN).
    pub observed: usize,
    /// Rank of the innovation covariance over the observed entries (below `observed` when
    /// some channels are exact linear combinations of others, e.g. with singular R).
    pub rank: usize,
    /// Normalised innovation squared `eᵀ Σ⁺ e` (χ² with `rank` degrees of freedom for a
    /// consistent filter); `None` on a predict-only step (no measurement, so no statistic:
    /// averages over steps must skip it rather than count a zero).
    pub nis: Option<f64>,
    /// Gaussian log-likelihood of the innovation, `−½(eᵀΣ⁺e + log pdet Σ + rank·log 2π)`;
    /// 0 on a predict-only step (the log-likelihood of no data, so sums over steps stay
    /// right).
    pub log_likelihood: f64,
    /// Measurement linearisations done: 1 for an update of the linear filter, the EKF and
    /// the UKF, up to the cap for the iterated EKF (whose `nis` and `log_likelihood` are
    /// those of its last linearisation), 0 on a predict-only step.
    pub iterations: usize,
}

/// Everything that changes in a step: estimates and preallocated workspaces.
#[derive(Clone, Debug)]
struct State<D: Dims> {
    form: CovarianceForm,
    k: usize,
    /// `x_{k+1|k}`, `P_{k+1|k}` (before the first step: `x0`, `P0`).
    xp: D::Nv,
    pp: D::Nn,
    /// Square factor of `pp` (square-root form only).
    lp: D::Nn,
    /// `x_{k|k}`, `P_{k|k}`.
    xf: D::Nv,
    pf: D::Nn,
    e: D::Mv,
    sig: D::Mm,
    gain: D::Nm,
    info: StepInfo,
    /// Whether the last dense update factored Σ by Cholesky (else by the eigen fallback).
    chol: bool,
    // workspaces
    /// Which entries of `z_k` are observed (not NaN).
    mask: D::Mb,
    y: D::Mv,
    /// Square-root form: pivot column of each z row (`None` for a dependent row), and the
    /// z row of each pivot column.
    piv: D::Mo,
    pivrow: D::Mi,
    hp: D::Mn,
    u: D::Nm,
    kbar: D::Nm,
    tnm: D::Nm,
    sm: D::Nm,
    gbar: D::Nm,
    fact: D::Mm,
    eigv: D::Mm,
    eigw: D::Mv,
    a: D::Nn,
    t: D::Nn,
    xtmp: D::Nv,
    pivx: D::No,
    /// The square-root form's row-major (m + 2n)² pre-array (empty for the other forms).
    arr: Vec<f64>,
}

/// A linear Kalman filter on the storage path `D` ([`DynDims`] by default, or
/// [`crate::FixedDims`]).
///
/// `(x0, P0)` is the prior for the first measurement. Each [`Filter::step`] updates with
/// `z_k` and then predicts to `k + 1` with `u_k`, so after step `k` both the filtered
/// estimate `x_{k|k}` ([`Filter::state`], MATLAB's "current" form) and the one-step
/// predictor `x_{k+1|k}` ([`Filter::predicted_state`], the "delayed" form) are available.
/// A step allocates nothing.
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
///
/// // A random walk observed in unit noise; one step from the prior N(0, 1).
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.5]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
/// let info = filter.step(&[2.0], None)?;
/// // Gain 1/2: x = 1, P = 1/2; then the prediction adds Q.
/// assert!((filter.state()[0] - 1.0).abs() < 1e-12);
/// assert!((filter.covariance()[(0, 0)] - 0.5).abs() < 1e-12);
/// assert!((filter.predicted_covariance()[(0, 0)] - 1.0).abs() < 1e-12);
/// assert_eq!(info.observed, 1);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct Filter<D: Dims = DynDims> {
    model: Model<D>,
    st: State<D>,
}

impl<D: Dims> Filter<D> {
    /// A filter for `model` with prior mean `x0` (length n) and covariance `P0` (n×n,
    /// symmetric PSD), using the covariance `form`. All workspaces are allocated here.
    ///
    /// # Errors
    /// [`Error::Shape`]/[`Error::NonFinite`] naming `x0` or `P0`; [`Error::NotSymmetric`]
    /// or [`Error::NotPositiveSemidefinite`] naming `P0`.
    pub fn new(
        model: Model<D>,
        x0: &[f64],
        P0: &impl MatrixInput,
        form: CovarianceForm,
    ) -> Result<Self, Error> {
        let d = model.dims;
        let (n, m) = (d.n(), d.m());
        let arr_len = if form == CovarianceForm::SquareRoot {
            (m + 2 * n) * (m + 2 * n)
        } else {
            0
        };
        let mut st = State::<D> {
            form,
            k: 0,
            xp: Buf::zeros(n),
            pp: Buf::zeros(n * n),
            lp: Buf::zeros(if form == CovarianceForm::SquareRoot {
                n * n
            } else {
                0
            }),
            xf: Buf::zeros(n),
            pf: Buf::zeros(n * n),
            e: Buf::zeros(m),
            sig: Buf::zeros(m * m),
            gain: Buf::zeros(n * m),
            info: StepInfo::default(),
            chol: true,
            mask: Buf::zeros(m),
            y: Buf::zeros(m),
            piv: Buf::zeros(m),
            pivrow: Buf::zeros(m),
            hp: Buf::zeros(m * n),
            u: Buf::zeros(n * m),
            kbar: Buf::zeros(n * m),
            tnm: Buf::zeros(n * m),
            sm: Buf::zeros(n * m),
            gbar: Buf::zeros(n * m),
            fact: Buf::zeros(m * m),
            eigv: Buf::zeros(m * m),
            eigw: Buf::zeros(m),
            a: Buf::zeros(n * n),
            t: Buf::zeros(n * n),
            xtmp: Buf::zeros(n),
            pivx: Buf::zeros(n),
            arr: vec![0.0; arr_len],
        };
        init_prior(&mut st, n, x0, P0)?;
        Ok(Filter { model, st })
    }

    /// Restarts the filter at step 0 with a new prior (validated like [`Filter::new`]; this
    /// may allocate for the PSD check, a step never does).
    ///
    /// # Errors
    /// As [`Filter::new`] for `x0` and `P0`.
    pub fn reset(&mut self, x0: &[f64], P0: &impl MatrixInput) -> Result<(), Error> {
        let n = self.model.dims.n();
        self.st.k = 0;
        self.st.info = StepInfo::default();
        init_prior(&mut self.st, n, x0, P0)
    }

    /// One step with the filter's own model: update with `z_k` (NaN entries are missing;
    /// all NaN is a predict-only step), then predict to `k + 1` with the control `u_k`
    /// (`None` = zero input).
    ///
    /// # Errors
    /// [`Error::Shape`] naming `z` or `u` for a wrong length; [`Error::NonFinite`] for an
    /// infinite `z` entry or a non-finite `u` entry (the state is then unchanged).
    /// [`Error::Diverged`] if the step's estimates are no longer finite (checked on x and
    /// the diagonal of P, an O(n) test that catches the first overflow, before NaN spreads
    /// to the other estimates): the step counts as taken, its estimates must not be used.
    #[inline]
    pub fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, Error> {
        step_impl(&self.model, &mut self.st, z, u)
    }

    /// One step with an external model of the same dimensions (time-varying systems).
    ///
    /// # Errors
    /// As [`Filter::step`], plus [`Error::Dimension`] if `model`'s dimensions differ.
    pub fn step_with(
        &mut self,
        model: &Model<D>,
        z: &[f64],
        u: Option<&[f64]>,
    ) -> Result<StepInfo, Error> {
        let (a, b) = (model.dims, self.model.dims);
        if (a.n(), a.m(), a.p()) != (b.n(), b.m(), b.p()) {
            return Err(Error::Dimension {
                name: "n",
                value: a.n(),
                rule: "a time-varying model must keep the filter's n, m, p",
            });
        }
        step_impl(model, &mut self.st, z, u)
    }

    /// One step with the model that `source` gives for the current step index.
    ///
    /// # Errors
    /// As [`Filter::step_with`], plus [`Error::NoModel`].
    pub fn step_source<S: ModelSource<D> + ?Sized>(
        &mut self,
        source: &S,
        z: &[f64],
        u: Option<&[f64]>,
    ) -> Result<StepInfo, Error> {
        let k = self.st.k;
        let model = source.model(k).ok_or(Error::NoModel { step: k })?;
        self.step_with(model, z, u)
    }

    /// The filter's model.
    pub fn model(&self) -> &Model<D> {
        &self.model
    }
    /// The covariance form.
    pub fn form(&self) -> CovarianceForm {
        self.st.form
    }
    /// Number of steps taken.
    pub fn steps(&self) -> usize {
        self.st.k
    }
    /// What the last step produced.
    pub fn last_step(&self) -> StepInfo {
        self.st.info
    }
    /// Filtered estimate `x_{k|k}` after step `k` (before any step: `x0`).
    pub fn state(&self) -> &[f64] {
        &self.st.xf.as_slice()[..self.model.dims.n()]
    }
    /// Filtered covariance `P_{k|k}`.
    pub fn covariance(&self) -> MatRef<'_, f64> {
        let n = self.model.dims.n();
        MatRef::from_column_major_slice(&self.st.pf.as_slice()[..n * n], n, n)
    }
    /// One-step prediction `x_{k+1|k}` (the prior of the next step; before any step: `x0`).
    pub fn predicted_state(&self) -> &[f64] {
        &self.st.xp.as_slice()[..self.model.dims.n()]
    }
    /// Predicted covariance `P_{k+1|k}`.
    pub fn predicted_covariance(&self) -> MatRef<'_, f64> {
        let n = self.model.dims.n();
        MatRef::from_column_major_slice(&self.st.pp.as_slice()[..n * n], n, n)
    }
    /// Innovation `e_k = z_k − H x_{k|k−1}` of the last step (0 in missing entries).
    pub fn innovation(&self) -> &[f64] {
        &self.st.e.as_slice()[..self.model.dims.m()]
    }
    /// Innovation covariance `Σ_k = H P_{k|k−1} Hᵀ + R` of the last step over the observed
    /// entries (rows and columns of missing entries are zero).
    pub fn innovation_covariance(&self) -> MatRef<'_, f64> {
        let m = self.model.dims.m();
        MatRef::from_column_major_slice(&self.st.sig.as_slice()[..m * m], m, m)
    }
    /// Filter gain `K_k = P_{k|k−1} Hᵀ Σ_k⁺` of the last step (n×m; zero columns for
    /// missing entries), so that `x_{k|k} = x_{k|k−1} + K_k e_k`.
    pub fn gain(&self) -> MatRef<'_, f64> {
        let (n, m) = (self.model.dims.n(), self.model.dims.m());
        MatRef::from_column_major_slice(&self.st.gain.as_slice()[..n * m], n, m)
    }
}

fn init_prior<D: Dims>(
    st: &mut State<D>,
    n: usize,
    x0: &[f64],
    P0: &impl MatrixInput,
) -> Result<(), Error> {
    let mut x = D::Nv::zeros(n);
    let mut P = D::Nn::zeros(n * n);
    load_vec("x0", x0, n, x.as_mut_slice())?;
    load("P0", P0, n, n, P.as_mut_slice())?;
    let mut L = vec![0.0; n * n];
    checked_factor("P0", P.as_mut_slice(), n, &mut L)?;
    if st.form == CovarianceForm::SquareRoot {
        st.lp.as_mut_slice()[..n * n].copy_from_slice(&L);
    }
    st.xp = x.clone();
    st.xf = x;
    st.pp = P.clone();
    st.pf = P;
    Ok(())
}

/// The validation of one step's inputs, shared by [`Filter::step`] and the
/// scheduled filter's step: `z` of length `m` with no infinite entry (NaN
/// marks a missing entry), `u` (if any) of length `p` and finite. Returns whether `z` has a
/// missing entry; [`Error::Shape`] or [`Error::NonFinite`] naming `z` or `u`.
#[inline(always)]
pub(crate) fn check_step_inputs(
    m: usize,
    p: usize,
    z: &[f64],
    u: Option<&[f64]>,
) -> Result<bool, Error> {
    if z.len() != m {
        return Err(Error::Shape {
            name: "z",
            rows: z.len(),
            cols: 1,
            expected_rows: m,
            expected_cols: 1,
        });
    }
    if let Some(u) = u {
        check_vec("u", u, p)?;
    }
    let mut missing = false;
    for (i, v) in z.iter().enumerate() {
        if v.is_nan() {
            missing = true;
        } else if v.is_infinite() {
            return Err(Error::NonFinite {
                name: "z",
                rows: m,
                cols: 1,
                row: i,
                col: 0,
            });
        }
    }
    Ok(missing)
}

/// Validates the step inputs and sets the observation mask; returns the number of observed
/// entries.
#[inline(always)]
fn check_inputs<D: Dims>(
    d: &D,
    st: &mut State<D>,
    z: &[f64],
    u: Option<&[f64]>,
) -> Result<usize, Error> {
    check_step_inputs(d.m(), d.p(), z, u)?;
    let mask = st.mask.as_mut_slice();
    for (mi, zi) in mask.iter_mut().zip(z) {
        *mi = !zi.is_nan();
    }
    Ok(mask.iter().filter(|&&o| o).count())
}

#[inline(always)]
fn step_impl<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    z: &[f64],
    u: Option<&[f64]>,
) -> Result<StepInfo, Error> {
    let d = model.dims;
    let observed = check_inputs(&d, st, z, u)?;
    let mut info = match st.form {
        CovarianceForm::SquareRoot => sqrt::step(model, st, z, u),
        CovarianceForm::Joseph | CovarianceForm::Standard => dense::step(model, st, z, u, observed),
    };
    info.step = st.k;
    info.observed = observed;
    if observed == 0 {
        info.nis = None;
    }
    st.k += 1;
    st.info = info;
    let n = d.n();
    check_diverged(
        info.step,
        ("x_{k|k}", st.xf.as_slice()),
        ("P_{k|k}", st.pf.as_slice()),
        n,
    )?;
    check_diverged(
        info.step,
        ("x_{k+1|k}", st.xp.as_slice()),
        ("P_{k+1|k}", st.pp.as_slice()),
        n,
    )?;
    Ok(info)
}

/// `e = z − H x` in observed entries, 0 in missing ones.
#[inline(always)]
fn innovation(m: usize, n: usize, H: &[f64], x: &[f64], z: &[f64], mask: &[bool], e: &mut [f64]) {
    for i in 0..m {
        e[i] = if mask[i] {
            let mut s = z[i];
            for j in 0..n {
                s -= H[i + j * m] * x[j];
            }
            s
        } else {
            0.0
        };
    }
}

/// `out += A v` for the column-major `rows`×`v.len()` matrix `A` (column by column).
#[inline(always)]
pub(crate) fn add_mat_vec(rows: usize, A: &[f64], v: &[f64], out: &mut [f64]) {
    for (j, vj) in v.iter().enumerate() {
        for (o, a) in out[..rows].iter_mut().zip(&A[j * rows..j * rows + rows]) {
            *o += a * vj;
        }
    }
}

/// `x_out = F x + B u` (`x`, `u` of lengths n, p).
#[inline(always)]
pub(crate) fn propagate_mean(
    n: usize,
    p: usize,
    F: &[f64],
    B: &[f64],
    x: &[f64],
    u: Option<&[f64]>,
    out: &mut [f64],
) {
    out[..n].fill(0.0);
    add_mat_vec(n, F, &x[..n], out);
    if let Some(u) = u {
        add_mat_vec(n, B, &u[..p], out);
    }
}
