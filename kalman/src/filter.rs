//! The filter: state, workspaces and the allocation-free step (update with `z_k`, then
//! prediction to `k + 1`) in the Joseph, standard and square-root covariance forms.
#![allow(non_snake_case)]

use faer::MatRef;

use crate::Error;
use crate::kernels::{Gemm, RANK_TOL, cholesky, jacobi_eigen, lq_rows, mirror_lower};
use crate::model::{
    MatrixInput, Model, ModelSource, check_vec, load, load_vec, psd_factor, symmetrise,
};
use crate::storage::{Buf, Dims, Dyn};

/// ln(2π), for the Gaussian log-likelihood.
const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// How the covariance update is computed. All three give the same P in exact arithmetic.
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, Dyn, Filter, Model};
///
/// // The three forms agree on a well-conditioned problem.
/// let mut last = Vec::new();
/// for form in [CovarianceForm::Joseph, CovarianceForm::Standard, CovarianceForm::SquareRoot] {
///     let model = Model::new(Dyn::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.1]], &[[1.0]])?;
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
    /// consistent filter); 0 on a predict-only step.
    pub nis: f64,
    /// Gaussian log-likelihood of the innovation, `−½(eᵀΣ⁺e + log pdet Σ + rank·log 2π)`;
    /// 0 on a predict-only step.
    pub log_likelihood: f64,
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
    mask: D::Mv,
    y: D::Mv,
    piv: D::Mv,
    pivrow: D::Mv,
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
    pivx: D::Nv,
    arr: D::Array,
}

/// A linear Kalman filter on the storage path `D` ([`Dyn`] by default, or
/// [`crate::Fixed`]).
///
/// `(x0, P0)` is the prior for the first measurement. Each [`Filter::step`] updates with
/// `z_k` and then predicts to `k + 1` with `u_k`, so after step `k` both the filtered
/// estimate `x_{k|k}` ([`Filter::state`], MATLAB's "current" form) and the one-step
/// predictor `x_{k+1|k}` ([`Filter::predicted_state`], the "delayed" form) are available.
/// A step allocates nothing.
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, Dyn, Filter, Model};
///
/// // A random walk observed in unit noise; one step from the prior N(0, 1).
/// let model = Model::new(Dyn::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.5]], &[[1.0]])?;
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
pub struct Filter<D: Dims = Dyn> {
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
            arr: Buf::zeros(arr_len),
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
    /// infinite `z` entry or a non-finite `u` entry. The state is unchanged on error.
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
    symmetrise("P0", P.as_mut_slice(), n)?;
    let mut L = vec![0.0; n * n];
    psd_factor("P0", P.as_slice(), n, &mut L)?;
    if st.form == CovarianceForm::SquareRoot {
        st.lp.as_mut_slice()[..n * n].copy_from_slice(&L);
    }
    st.xp = x.clone();
    st.xf = x;
    st.pp = P.clone();
    st.pf = P;
    Ok(())
}

/// `C = alpha·op(A)·op(B) (+ C)` with contiguous operands (leading dimension = rows).
#[inline(always)]
fn mm<D: Dims>(
    d: &D,
    c: &mut [f64],
    (rows, cols, inner): (usize, usize, usize),
    alpha: f64,
    acc: bool,
    (a, ta): (&[f64], bool),
    (b, tb): (&[f64], bool),
    lower: bool,
) {
    d.gemm(
        Gemm {
            rows,
            cols,
            inner,
            alpha,
            acc,
            a,
            lda: if ta { inner } else { rows },
            ta,
            b,
            ldb: if tb { cols } else { inner },
            tb,
            ldc: rows,
            lower,
        },
        c,
    );
}

/// The validation of one step's inputs, shared by [`Filter::step`] and
/// [`crate::schedule::ScheduledFilter::step`]: `z` of length `m` with no infinite entry (NaN
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
    let mut observed = 0;
    for (mi, zi) in mask.iter_mut().zip(z) {
        if zi.is_nan() {
            *mi = 0.0;
        } else {
            *mi = 1.0;
            observed += 1;
        }
    }
    Ok(observed)
}

fn step_impl<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    z: &[f64],
    u: Option<&[f64]>,
) -> Result<StepInfo, Error> {
    let d = model.dims;
    let observed = check_inputs(&d, st, z, u)?;
    let mut info = match st.form {
        CovarianceForm::SquareRoot => step_sqrt(model, st, z, u),
        _ => step_dense(model, st, z, u, observed),
    };
    info.step = st.k;
    info.observed = observed;
    st.k += 1;
    st.info = info;
    Ok(info)
}

/// `e = z − H x` in observed entries, 0 in missing ones.
#[inline(always)]
fn innovation(m: usize, n: usize, H: &[f64], x: &[f64], z: &[f64], mask: &[f64], e: &mut [f64]) {
    for i in 0..m {
        e[i] = if mask[i] > 0.0 {
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

/// Joseph and standard forms.
#[inline(always)]
fn step_dense<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    z: &[f64],
    u: Option<&[f64]>,
    observed: usize,
) -> StepInfo {
    let d = model.dims;
    let (n, m, p) = (d.n(), d.m(), d.p());
    let F = model.F.as_slice();
    let H = model.H.as_slice();
    let Q = model.Q.as_slice();
    let R = model.R.as_slice();
    let B = model.B.as_slice();
    let mut info = StepInfo::default();
    let has_s = model.S.is_some() && observed > 0;
    let mut chol_used = true;

    if observed == 0 {
        st.xf.as_mut_slice()[..n].copy_from_slice(&st.xp.as_slice()[..n]);
        st.pf.as_mut_slice()[..n * n].copy_from_slice(&st.pp.as_slice()[..n * n]);
        st.e.as_mut_slice()[..m].fill(0.0);
        st.sig.as_mut_slice()[..m * m].fill(0.0);
        st.gain.as_mut_slice()[..n * m].fill(0.0);
    } else {
        let mask = st.mask.as_slice();
        let xp = st.xp.as_slice();
        let pp = st.pp.as_slice();
        let e = st.e.as_mut_slice();
        innovation(m, n, H, xp, z, mask, e);
        // HP = H·P (m×n), masked rows zeroed.
        let hp = st.hp.as_mut_slice();
        mm(
            &d,
            hp,
            (m, n, n),
            1.0,
            false,
            (H, false),
            (pp, false),
            false,
        );
        for i in 0..m {
            if mask[i] <= 0.0 {
                for j in 0..n {
                    hp[i + j * m] = 0.0;
                }
            }
        }
        // Σ = (HP)·Hᵀ + R over observed entries; a missing entry gets a unit diagonal
        // (its gain column is zero, so it drops out exactly).
        let sig = st.sig.as_mut_slice();
        mm(&d, sig, (m, m, n), 1.0, false, (hp, false), (H, true), true);
        let mut maxdiag = 0.0_f64;
        for j in 0..m {
            for i in j..m {
                let v = if mask[i] > 0.0 && mask[j] > 0.0 {
                    sig[i + j * m] + R[i + j * m]
                } else if i == j {
                    1.0
                } else {
                    0.0
                };
                sig[i + j * m] = v;
            }
            maxdiag = maxdiag.max(sig[j + j * m]);
        }
        mirror_lower(sig, m);
        // U = P Hᵀ = (HP)ᵀ.
        let uu = st.u.as_mut_slice();
        for j in 0..m {
            for i in 0..n {
                uu[i + j * n] = hp[j + i * m];
            }
        }
        let masked = (m - observed) as f64;
        let fact = st.fact.as_mut_slice();
        fact[..m * m].copy_from_slice(&sig[..m * m]);
        let kbar = st.kbar.as_mut_slice();
        let K = st.gain.as_mut_slice();
        let y = st.y.as_mut_slice();
        let eigv = st.eigv.as_mut_slice();
        let chol = cholesky(fact, m, RANK_TOL * maxdiag);
        chol_used = chol;
        let (rank, logdet);
        if chol {
            // kbar = U L⁻ᵀ, K = kbar L⁻¹, y = L⁻¹ e.
            whiten_chol(n, m, fact, uu, kbar);
            unwhiten_chol(n, m, fact, kbar, K);
            for i in 0..m {
                let mut s = e[i];
                for l in 0..i {
                    s -= fact[i + l * m] * y[l];
                }
                y[i] = s / fact[i + i * m];
            }
            // log det Σ = 2 ln Π L_ii: one logarithm unless the product leaves the normal
            // range (then one per pivot).
            let mut prod = 1.0;
            for i in 0..m {
                prod *= fact[i + i * m];
            }
            logdet = if prod.is_normal() && prod.is_finite() {
                2.0 * prod.ln()
            } else {
                (0..m).map(|i| 2.0 * fact[i + i * m].ln()).sum()
            };
            rank = observed;
        } else {
            // Rank-revealing fallback: Σ = V Λ Vᵀ, Z = V Λ₊^{-1/2} (dropped columns zero),
            // Σ⁺ = Z Zᵀ.
            let w = st.eigw.as_mut_slice();
            // The failed Cholesky overwrote part of `fact`: start again from Σ.
            fact[..m * m].copy_from_slice(&sig[..m * m]);
            jacobi_eigen(fact, m, eigv, w);
            let lmax = w[..m].iter().fold(0.0_f64, |a, b| a.max(*b));
            let mut r = 0usize;
            let mut ld = 0.0;
            for j in 0..m {
                if w[j] > RANK_TOL * lmax {
                    r += 1;
                    ld += w[j].ln();
                    let s = 1.0 / w[j].sqrt();
                    for i in 0..m {
                        eigv[i + j * m] *= s;
                    }
                } else {
                    eigv[j * m..j * m + m].fill(0.0);
                }
            }
            // Missing entries contributed unit eigenvalues (ln 1 = 0) to the count.
            rank = r.saturating_sub(masked as usize);
            logdet = ld;
            mm(
                &d,
                kbar,
                (n, m, m),
                1.0,
                false,
                (uu, false),
                (eigv, false),
                false,
            );
            mm(
                &d,
                K,
                (n, m, m),
                1.0,
                false,
                (kbar, false),
                (eigv, true),
                false,
            );
            for j in 0..m {
                let mut s = 0.0;
                for i in 0..m {
                    s += eigv[i + j * m] * e[i];
                }
                y[j] = s;
            }
        }
        let nis: f64 = y[..m].iter().map(|v| v * v).sum();
        info.rank = rank;
        info.nis = nis;
        info.log_likelihood = -0.5 * (nis + logdet + rank as f64 * LN_2PI);
        // x⁺ = x⁻ + K e.
        let xf = st.xf.as_mut_slice();
        xf[..n].copy_from_slice(&xp[..n]);
        add_mat_vec(n, K, &e[..m], xf);
        let pf = st.pf.as_mut_slice();
        match st.form {
            CovarianceForm::Standard => {
                // P⁺ = P − K Σ Kᵀ = P − kbar kbarᵀ (lower triangle, then mirrored).
                pf[..n * n].copy_from_slice(&pp[..n * n]);
                mm(
                    &d,
                    pf,
                    (n, n, m),
                    -1.0,
                    true,
                    (kbar, false),
                    (kbar, true),
                    true,
                );
            }
            _ => {
                // Joseph: P⁺ = A P Aᵀ + K R Kᵀ with A = I − K H, applied as the identity
                // minus a rank-m term from each side (O(n²m) instead of O(n³), same
                // expression): T = A P = P − K (HP), A P Aᵀ = T − (T Hᵀ) Kᵀ.
                let t = st.t.as_mut_slice();
                t[..n * n].copy_from_slice(&pp[..n * n]);
                mm(&d, t, (n, n, m), -1.0, true, (K, false), (hp, false), false);
                let th = st.tnm.as_mut_slice();
                mm(&d, th, (n, m, n), 1.0, false, (t, false), (H, true), false);
                pf[..n * n].copy_from_slice(&t[..n * n]);
                mm(&d, pf, (n, n, m), -1.0, true, (th, false), (K, true), true);
                // K R Kᵀ: gain columns of missing entries are zero, so R needs no masking.
                mm(&d, th, (n, m, m), 1.0, false, (K, false), (R, false), false);
                mm(&d, pf, (n, n, m), 1.0, true, (th, false), (K, true), true);
            }
        }
        mirror_lower(pf, n);
    }

    // Prediction: x_{k+1|k} = F x⁺ + B u (+ S Σ⁺ e),
    // P_{k+1|k} = F P⁺ Fᵀ + Q (− F K Sᵀ − S Kᵀ Fᵀ − S Σ⁺ Sᵀ).
    let xf = st.xf.as_slice();
    let pf = st.pf.as_slice();
    let xp = st.xp.as_mut_slice();
    propagate_mean(n, p, F, B, xf, u, xp);
    let t = st.t.as_mut_slice();
    let pp = st.pp.as_mut_slice();
    mm(&d, t, (n, n, n), 1.0, false, (F, false), (pf, false), false);
    mm(&d, pp, (n, n, n), 1.0, false, (t, false), (F, true), true);
    for j in 0..n {
        for i in j..n {
            pp[i + j * n] += Q[i + j * n];
        }
    }
    if let Some(S) = model.S.as_ref().filter(|_| has_s) {
        {
            let S = S.as_slice();
            let mask = st.mask.as_slice();
            let sm = st.sm.as_mut_slice();
            for j in 0..m {
                let keep = mask[j] > 0.0;
                for i in 0..n {
                    sm[i + j * n] = if keep { S[i + j * n] } else { 0.0 };
                }
            }
            // gbar = S Z (Z = L⁻ᵀ or V Λ₊^{-1/2}), so S Σ⁺ e = gbar y and S Σ⁺ Sᵀ = gbar gbarᵀ.
            let gbar = st.gbar.as_mut_slice();
            if chol_used {
                whiten_chol(n, m, st.fact.as_slice(), sm, gbar);
            } else {
                mm(
                    &d,
                    gbar,
                    (n, m, m),
                    1.0,
                    false,
                    (sm, false),
                    (st.eigv.as_slice(), false),
                    false,
                );
            }
            add_mat_vec(n, gbar, &st.y.as_slice()[..m], xp);
            let fk = st.tnm.as_mut_slice();
            mm(
                &d,
                fk,
                (n, m, n),
                1.0,
                false,
                (F, false),
                (st.gain.as_slice(), false),
                false,
            );
            mm(&d, pp, (n, n, m), -1.0, true, (fk, false), (sm, true), true);
            mm(&d, pp, (n, n, m), -1.0, true, (sm, false), (fk, true), true);
            mm(
                &d,
                pp,
                (n, n, m),
                -1.0,
                true,
                (gbar, false),
                (gbar, true),
                true,
            );
        }
    }
    mirror_lower(pp, n);
    st.chol = chol_used;
    info
}

/// `out = U L⁻ᵀ` for lower-triangular `L` (m×m), `U` n×m (column forward substitution).
#[inline(always)]
fn whiten_chol(n: usize, m: usize, L: &[f64], U: &[f64], out: &mut [f64]) {
    for j in 0..m {
        let (done, rest) = out.split_at_mut(j * n);
        let oj = &mut rest[..n];
        oj.copy_from_slice(&U[j * n..j * n + n]);
        for k in 0..j {
            let l = L[j + k * m];
            for (o, dk) in oj.iter_mut().zip(&done[k * n..k * n + n]) {
                *o -= l * dk;
            }
        }
        let inv = 1.0 / L[j + j * m];
        for o in oj.iter_mut() {
            *o *= inv;
        }
    }
}

/// `out = W L⁻¹` for lower-triangular `L` (column back substitution).
#[inline(always)]
fn unwhiten_chol(n: usize, m: usize, L: &[f64], W: &[f64], out: &mut [f64]) {
    for j in (0..m).rev() {
        let (head, rest) = out.split_at_mut((j + 1) * n);
        let oj = &mut head[j * n..j * n + n];
        oj.copy_from_slice(&W[j * n..j * n + n]);
        for k in j + 1..m {
            let l = L[k + j * m];
            for (o, dk) in oj.iter_mut().zip(&rest[(k - j - 1) * n..(k - j) * n]) {
                *o -= l * dk;
            }
        }
        let inv = 1.0 / L[j + j * m];
        for o in oj.iter_mut() {
            *o *= inv;
        }
    }
}

/// Square-root form. One pre-array, row-major, `m + 2n` rows by `m + 2n` columns:
///
/// ```text
///   [ Gv  H L ]   z rows (m)       Gv, Gw: rows of G with G Gᵀ = [[R, Sᵀ], [S, Q]]
///   [ 0     L ]   current rows (n)  L: factor of P_{k|k-1}
///   [ Gw  F L ]   next rows (n)
/// ```
///
/// Householder LQ of the z rows gives `Σ^{1/2}` and, in the rows below, the whitened gains
/// `K̄ = P Hᵀ Σ^{-T/2}` and `K̄ₚ = (F P Hᵀ + S) Σ^{-T/2}`; triangularising the remaining
/// columns of each block separately gives the factors of `P_{k|k}` and `P_{k+1|k}`. Rows of
/// missing entries are zero and drop out as rank-deficient rows.
#[inline(always)]
fn step_sqrt<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    z: &[f64],
    u: Option<&[f64]>,
) -> StepInfo {
    let d = model.dims;
    let (n, m, p) = (d.n(), d.m(), d.p());
    let F = model.F.as_slice();
    let H = model.H.as_slice();
    let B = model.B.as_slice();
    let G = model.joint.as_slice();
    let ldg = n + m;
    let ld = m + 2 * n;
    let mask = st.mask.as_slice();
    let lp = st.lp.as_slice();
    // HL (m×n) into hp, FL (n×n) into t.
    let hl = st.hp.as_mut_slice();
    mm(
        &d,
        hl,
        (m, n, n),
        1.0,
        false,
        (H, false),
        (lp, false),
        false,
    );
    let fl = st.t.as_mut_slice();
    mm(
        &d,
        fl,
        (n, n, n),
        1.0,
        false,
        (F, false),
        (lp, false),
        false,
    );
    let arr = &mut st.arr.as_mut_slice()[..ld * ld];
    let mut maxdiag = 0.0_f64;
    for i in 0..m {
        let row = &mut arr[i * ld..(i + 1) * ld];
        if mask[i] > 0.0 {
            for j in 0..n + m {
                row[j] = G[i + j * ldg];
            }
            for j in 0..n {
                row[n + m + j] = hl[i + j * m];
            }
            maxdiag = maxdiag.max(row.iter().map(|v| v * v).sum());
        } else {
            row.fill(0.0);
        }
    }
    for i in 0..n {
        let row = &mut arr[(m + i) * ld..(m + i + 1) * ld];
        row[..n + m].fill(0.0);
        for j in 0..n {
            row[n + m + j] = lp[i + j * n];
        }
        let row = &mut arr[(m + n + i) * ld..(m + n + i + 1) * ld];
        for j in 0..n + m {
            row[j] = G[m + i + j * ldg];
        }
        for j in 0..n {
            row[n + m + j] = fl[i + j * n];
        }
    }
    let piv = st.piv.as_mut_slice();
    let r = lq_rows(arr, ld, 0..m, ld, 0, ld, RANK_TOL * maxdiag, piv);
    let pivx = st.pivx.as_mut_slice();
    lq_rows(arr, ld, m..m + n, m + n, r, ld, 0.0, pivx);
    lq_rows(arr, ld, m + n..m + 2 * n, m + 2 * n, r, ld, 0.0, pivx);

    // Innovation and its whitened form y = Σ^{-1/2} e over the pivot rows.
    let xp = st.xp.as_mut_slice();
    let e = st.e.as_mut_slice();
    innovation(m, n, H, xp, z, mask, e);
    let y = st.y.as_mut_slice();
    let pivrow = st.pivrow.as_mut_slice();
    let mut logdet = 0.0;
    for i in 0..m {
        if piv[i] >= 0.0 {
            let c = piv[i] as usize;
            let mut s = e[i];
            for l in 0..c {
                s -= arr[i * ld + l] * y[l];
            }
            let dgl = arr[i * ld + c];
            y[c] = s / dgl;
            pivrow[c] = i as f64;
            logdet += 2.0 * dgl.abs().ln();
        }
    }
    let nis: f64 = y[..r].iter().map(|v| v * v).sum();
    let info = StepInfo {
        rank: r,
        nis,
        log_likelihood: if r > 0 {
            -0.5 * (nis + logdet + r as f64 * LN_2PI)
        } else {
            0.0
        },
        ..StepInfo::default()
    };
    // x_{k|k} = x⁻ + K̄ y;  x_{k+1|k} = F x⁻ + B u + K̄ₚ y.
    let xf = st.xf.as_mut_slice();
    let xt = st.xtmp.as_mut_slice();
    propagate_mean(n, p, F, B, xp, u, xt);
    for i in 0..n {
        let mut a = xp[i];
        let mut b = xt[i];
        for l in 0..r {
            a += arr[(m + i) * ld + l] * y[l];
            b += arr[(m + n + i) * ld + l] * y[l];
        }
        xf[i] = a;
        xp[i] = b;
    }
    // Factors and covariances.
    let lf = st.a.as_mut_slice();
    let lpm = st.lp.as_mut_slice();
    for j in 0..n {
        for i in 0..n {
            lf[i + j * n] = arr[(m + i) * ld + r + j];
            lpm[i + j * n] = arr[(m + n + i) * ld + r + j];
        }
    }
    let pf = st.pf.as_mut_slice();
    mm(&d, pf, (n, n, n), 1.0, false, (lf, false), (lf, true), true);
    mirror_lower(pf, n);
    let pp = st.pp.as_mut_slice();
    mm(
        &d,
        pp,
        (n, n, n),
        1.0,
        false,
        (lpm, false),
        (lpm, true),
        true,
    );
    mirror_lower(pp, n);
    // Σ = Σ^{1/2} Σ^{T/2} over observed entries, and the gain K from K Σ^{1/2} = K̄.
    let sig = st.sig.as_mut_slice();
    for j in 0..m {
        for i in 0..m {
            let mut s = 0.0;
            for l in 0..r {
                s += arr[i * ld + l] * arr[j * ld + l];
            }
            sig[i + j * m] = s;
        }
    }
    let K = st.gain.as_mut_slice();
    K[..n * m].fill(0.0);
    for l in (0..r).rev() {
        let il = pivrow[l] as usize;
        let dgl = arr[il * ld + l];
        for row in 0..n {
            let mut s = arr[(m + row) * ld + l];
            for i2 in 0..m {
                if piv[i2] > l as f64 {
                    s -= K[row + i2 * n] * arr[i2 * ld + l];
                }
            }
            K[row + il * n] = s / dgl;
        }
    }
    info
}
