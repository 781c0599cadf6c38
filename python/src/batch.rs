//! The whole-series methods of `KalmanFilter` (`batch_filter`, `rts_smoother`): one call
//! into Rust that loops over the steps without returning to Python, with the filter's own
//! model or FilterPy's per-step matrices (`Fs`, `Qs`, `Hs`, `Rs`, `Bs`).
#![allow(non_snake_case)]

use std::sync::Mutex;

use numpy::{PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::convert::{
    array3_out, check_covariance, copy_finite, entries, float_array, shape_str, value_error, zeros,
};
use crate::kf_core::{Core, Steps, UpdateError, rts};
use crate::linalg::add_mul_vec;
use crate::series::{
    Along, Gaps, Rule, Spec, control_columns, read_series, read_series_with, read_steps, reusable,
};

/// `batch_filter`'s per-step model arguments as given: each None (the filter's own matrix
/// at every step) or one matrix per step.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PerStepArgs<'a, 'py> {
    pub Fs: Option<&'a Bound<'py, PyAny>>,
    pub Qs: Option<&'a Bound<'py, PyAny>>,
    pub Hs: Option<&'a Bound<'py, PyAny>>,
    pub Rs: Option<&'a Bound<'py, PyAny>>,
    pub Bs: Option<&'a Bound<'py, PyAny>>,
}

/// The per-step model as read: each `None` (the filter's own) or the matrices of every step,
/// row-major, one after another.
#[derive(Clone, Copy, Debug, Default)]
struct Model<'a> {
    F: Option<&'a [f64]>,
    Q: Option<&'a [f64]>,
    H: Option<&'a [f64]>,
    R: Option<&'a [f64]>,
    B: Option<&'a [f64]>,
    /// The columns of B's matrices (the number of controls).
    p: usize,
}

/// `KalmanFilter.batch_filter`, FilterPy's: step k predicts with `Fs[k]`, `Qs[k]`, `Bs[k]`,
/// `us[k]` and updates with `zs[k]`, `Hs[k]`, `Rs[k]` (in that order, or the update first),
/// each per-step argument None for the filter's own matrix at every step, and a None item
/// for the filter's own at that step (FilterPy hands the item to `predict`/`update`, which
/// read None so). Controls act only where there is a B (the filter's, or `Bs[k]`); a None
/// item of `us` is no control. The four outputs are numpy arrays allocated once and written
/// in place (numpy backs large arrays with huge pages, so 10⁵ steps cost few page faults),
/// and the loop runs with the GIL released.
pub(crate) fn batch_filter<'py>(
    core: &mut Core,
    x_col: bool,
    py: Python<'py>,
    zs: &Bound<'py, PyAny>,
    per_step: PerStepArgs<'_, 'py>,
    us: Option<&Bound<'py, PyAny>>,
    update_first: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    let (n, m) = (core.n, core.m);
    let (steps, z) = read_series(zs, "zs", m, true)?;
    let along = Along { name: "zs", steps };
    let spec = |name, rows, cols, rule, own| Spec {
        name,
        rows,
        cols,
        rule,
        own,
    };
    let Fs = read_steps(
        per_step.Fs,
        &spec("Fs", n, n, Rule::Matrix, Some(&core.F)),
        along,
    )?;
    let Qs = read_steps(
        per_step.Qs,
        &spec("Qs", n, n, Rule::Covariance, Some(&core.Q)),
        along,
    )?;
    let Hs = read_steps(
        per_step.Hs,
        &spec("Hs", m, n, Rule::Matrix, Some(&core.H)),
        along,
    )?;
    let Rs = read_steps(
        per_step.Rs,
        &spec("Rs", m, m, Rule::Covariance, Some(&core.R)),
        along,
    )?;
    // The number of controls: the filter's (its B's columns, else dim_u), else that of the
    // first matrix of Bs; no control at all without a B anywhere.
    let Bs_arg = reusable(per_step.Bs)?;
    let Bs_cols = control_columns(Bs_arg.as_ref())?;
    let p = match (&core.B, Bs_cols) {
        (Some(_), _) => core.p,
        (None, None) => 0,
        (None, Some(_)) if core.p > 0 => core.p,
        (None, Some(c)) => c,
    };
    let Bs = read_steps(
        Bs_arg.as_ref(),
        &spec("Bs", n, p, Rule::Control, core.B.as_deref()),
        along,
    )?
    .filter(|_| p > 0);
    let u = match us {
        Some(us) if !us.is_none() && p > 0 => {
            let (k, u) = read_series_with(us, "us", p, Gaps::Zero)?;
            if k != steps {
                return Err(value_error(format!(
                    "us has {k} steps but zs has {steps} (us[{}] is {})",
                    k.min(steps),
                    if k < steps {
                        "missing"
                    } else {
                        "past the last step"
                    }
                )));
            }
            Some(u)
        }
        _ => None,
    };
    let model = Model {
        F: Fs.as_deref(),
        Q: Qs.as_deref(),
        H: Hs.as_deref(),
        R: Rs.as_deref(),
        B: Bs.as_deref(),
        p,
    };
    let mean_shape = if x_col {
        vec![steps, n, 1]
    } else {
        vec![steps, n]
    };
    let cov_shape = vec![steps, n, n];
    let [a, b, c, d] = [&mean_shape, &cov_shape, &mean_shape, &cov_shape]
        .map(|shape| crate::convert::np_zeros(py, shape));
    let outputs = [a?, b?, c?, d?];
    {
        let err = |e: &dyn std::fmt::Display| value_error(e.to_string());
        let [means, covs, means_p, covs_p] = outputs.each_ref().map(|a| a.try_readwrite());
        let (mut means, mut covs) = (means.map_err(|e| err(&e))?, covs.map_err(|e| err(&e))?);
        let (mut means_p, mut covs_p) =
            (means_p.map_err(|e| err(&e))?, covs_p.map_err(|e| err(&e))?);
        let out = Outputs {
            means: means.as_slice_mut().map_err(|e| err(&e))?,
            covs: covs.as_slice_mut().map_err(|e| err(&e))?,
            means_p: means_p.as_slice_mut().map_err(|e| err(&e))?,
            covs_p: covs_p.as_slice_mut().map_err(|e| err(&e))?,
        };
        let u = u.as_deref();
        // Ctrl-C: the loop, which runs without the GIL, takes it back every few thousand
        // steps to run Python's signal handlers; an exception they raise (KeyboardInterrupt)
        // stops the loop and the filter is put back as it was before the call.
        let signal: Mutex<Option<PyErr>> = Mutex::new(None);
        let interrupted = || {
            Python::attach(|py| match py.check_signals() {
                Ok(()) => false,
                Err(e) => {
                    if let Ok(mut slot) = signal.lock() {
                        *slot = Some(e);
                    }
                    true
                }
            })
        };
        let before = core.clone();
        let batch = Batch {
            core,
            model,
            z: &z,
            u,
            update_first,
            out,
            interrupted: &interrupted,
        };
        let result = py.detach(|| run(batch));
        if let Err(stop) = result {
            *core = before;
            return Err(match stop {
                Stop::Singular(k) => value_error(format!(
                    "batch_filter: S (the innovation covariance H P Hᵀ + R) is singular at \
                     step {k}"
                )),
                Stop::Interrupted => signal
                    .lock()
                    .ok()
                    .and_then(|mut e| e.take())
                    .unwrap_or_else(|| value_error("batch_filter: interrupted")),
            });
        }
    }
    PyTuple::new(py, outputs.map(|a| a.into_any()))
}

/// Where the batch loop writes: x and P after each update and after each prediction.
struct Outputs<'a> {
    means: &'a mut [f64],
    covs: &'a mut [f64],
    means_p: &'a mut [f64],
    covs_p: &'a mut [f64],
}

/// A dimension known at compile time or at run time: the batch loop is compiled for each
/// small state dimension, so its loops over the state unroll and carry no bounds checks.
trait Dim: Copy + Send {
    fn get(self) -> usize;
}

#[derive(Clone, Copy)]
struct Const<const N: usize>;

impl<const N: usize> Dim for Const<N> {
    #[inline(always)]
    fn get(self) -> usize {
        N
    }
}

#[derive(Clone, Copy)]
struct Dyn(usize);

impl Dim for Dyn {
    #[inline(always)]
    fn get(self) -> usize {
        self.0
    }
}

/// One `batch_filter` call: the filter, the per-step model, the series zs (N×m) and us
/// (N×p), the step order, where the results go, and the check for a pending signal (true:
/// stop), called every [`signal_interval`] steps.
struct Batch<'a> {
    core: &'a mut Core,
    model: Model<'a>,
    z: &'a [f64],
    u: Option<&'a [f64]>,
    update_first: bool,
    out: Outputs<'a>,
    interrupted: &'a (dyn Fn() -> bool + Sync),
}

/// The work (multiply-adds, with a per-step overhead) between two looks for a pending
/// signal (Ctrl-C): about 2²⁴, a few milliseconds.
const SIGNAL_WORK: usize = 1 << 24;

/// How many steps of an n-state, m-measurement filter make [`SIGNAL_WORK`]: a step costs
/// about n²(n + m) multiply-adds plus a fixed overhead of some 64, so a large filter looks
/// at every step and the smallest every 2¹⁸ steps.
fn signal_interval(n: usize, m: usize) -> usize {
    let work = n
        .saturating_mul(n)
        .saturating_mul(n.saturating_add(m))
        .saturating_add(64);
    (SIGNAL_WORK / work).max(1)
}

/// Why the batch loop stopped early.
enum Stop {
    /// S was singular at this step.
    Singular(usize),
    /// A signal handler raised (KeyboardInterrupt).
    Interrupted,
}

/// The batch loop, compiled per state dimension up to 8 and measurement dimension up to 3.
fn run(b: Batch<'_>) -> Result<(), Stop> {
    match b.core.n {
        1 => run_n(Const::<1>, b),
        2 => run_n(Const::<2>, b),
        3 => run_n(Const::<3>, b),
        4 => run_n(Const::<4>, b),
        5 => run_n(Const::<5>, b),
        6 => run_n(Const::<6>, b),
        7 => run_n(Const::<7>, b),
        8 => run_n(Const::<8>, b),
        n => run_n(Dyn(n), b),
    }
}

/// [`run`] for the state dimension `d`, dispatching on the measurement dimension.
fn run_n<D: Dim>(d: D, b: Batch<'_>) -> Result<(), Stop> {
    match b.core.m {
        1 => run_dim(d, Const::<1>, b),
        2 => run_dim(d, Const::<2>, b),
        3 => run_dim(d, Const::<3>, b),
        m => run_dim(d, Dyn(m), b),
    }
}

/// The loop itself. Each step reads the previous step's output rows (the filter's own state
/// at the first step) and writes its own rows of the four outputs. Steps whose z is complete
/// take the fast kernels below; a step with a missing entry, a P that is not exactly
/// symmetric or an S that is not positive definite (the general path then tries LU), the
/// last step (so that y, the priors and posteriors the filter exposes afterwards are those
/// of the last step, as in FilterPy) and the last step with a measurement (so that K, S and
/// the likelihood are those of the last update made, as FilterPy keeps them over skipped
/// updates) take `Core`'s general update and predict.
fn run_dim<D: Dim, E: Dim>(d: D, e: E, b: Batch<'_>) -> Result<(), Stop> {
    let Batch {
        core,
        model,
        z,
        u,
        update_first,
        out,
        interrupted,
    } = b;
    let (n, m) = (d.get(), e.get());
    let nn = n * n;
    let steps = z.len() / m;
    let p = u.map_or(0, |u| u.len() / steps.max(1));
    let mut w = Work::new(core, n, m, model);
    let (x0, P0) = (core.x.clone(), core.P.clone());
    // A prediction leaves P exactly symmetric when its Q is (F P Fᵀ by its upper triangle,
    // mirrored, plus Q); only the first update of an update-first run sees the initial P.
    // `symmetric`: whether the P the next update starts from is.
    let mut symmetric = is_symmetric(&P0, n);
    let Outputs {
        means,
        covs,
        means_p,
        covs_p,
    } = out;
    let last_update = (0..steps)
        .rev()
        .find(|&k| z[k * m..(k + 1) * m].iter().any(|v| !v.is_nan()));
    let every = signal_interval(n, m);
    let mut until_check = every; // a countdown: no division in the loop
    for k in 0..steps {
        until_check -= 1;
        if until_check == 0 {
            until_check = every;
            if interrupted() {
                return Err(Stop::Interrupted);
            }
        }
        w.load(k, n, m, &model);
        let general = k + 1 == steps || last_update == Some(k);
        let zk = &z[k * m..(k + 1) * m];
        let uk = u.map(|u| &u[k * p..(k + 1) * p]);
        let (x_done, x_post) = means.split_at_mut(k * n);
        let (P_done, P_post) = covs.split_at_mut(k * nn);
        let (xp_done, x_prior) = means_p.split_at_mut(k * n);
        let (Pp_done, P_prior) = covs_p.split_at_mut(k * nn);
        let post = (&mut x_post[..n], &mut P_post[..nn]);
        let prior = (&mut x_prior[..n], &mut P_prior[..nn]);
        // The state this step starts from: the last output rows of the other kind.
        let start = match (k, update_first) {
            (0, _) => (&x0[..], &P0[..]),
            (_, true) => (&xp_done[(k - 1) * n..], &Pp_done[(k - 1) * nn..]),
            (_, false) => (&x_done[(k - 1) * n..], &P_done[(k - 1) * nn..]),
        };
        if update_first {
            w.update(d, e, core, general, symmetric, zk, start, post)
                .map_err(|_| Stop::Singular(k))?;
            w.predict(d, core, general, uk, (&x_post[..n], &P_post[..nn]), prior);
            symmetric = w.q_symmetric;
        } else {
            w.predict(d, core, general, uk, start, prior);
            symmetric = w.q_symmetric;
            w.update(
                d,
                e,
                core,
                general,
                symmetric,
                zk,
                (&x_prior[..n], &P_prior[..nn]),
                post,
            )
            .map_err(|_| Stop::Singular(k))?;
        }
    }
    Ok(())
}

/// Whether the n×n `a` is exactly symmetric.
fn is_symmetric(a: &[f64], n: usize) -> bool {
    (0..n).all(|i| (0..i).all(|j| a[i * n + j].to_bits() == a[j * n + i].to_bits()))
}

/// Σ aᵢ bᵢ, summed in order.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |s, (x, y)| s + x * y)
}

/// `row += f · v`.
#[inline(always)]
fn axpy(row: &mut [f64], f: f64, v: &[f64]) {
    for (r, x) in row.iter_mut().zip(v) {
        *r += f * x;
    }
}

/// `out = Σ_l c_l · v_l` over the rows v_l (the length of `out`) of `v`, in the order of l:
/// a row of a product, summed in the order of a dot product, written without clearing it
/// first.
#[inline(always)]
fn combine(out: &mut [f64], c: &[f64], v: &[f64]) {
    let n = out.len();
    for (o, x) in out.iter_mut().zip(v) {
        *o = c[0] * x;
    }
    for (l, &cl) in c.iter().enumerate().skip(1) {
        axpy(out, cl, &v[l * n..(l + 1) * n]);
    }
}

/// A state (x, P) a kernel reads, and one it writes.
type State<'a> = (&'a [f64], &'a [f64]);
type StateMut<'a> = (&'a mut [f64], &'a mut [f64]);

/// Runs `Core`'s general `step` from `from` and copies its state into `to`.
fn via_core<T>(
    core: &mut Core,
    from: State<'_>,
    to: StateMut<'_>,
    step: impl FnOnce(&mut Core) -> T,
) -> T {
    core.x.copy_from_slice(from.0);
    core.P.copy_from_slice(from.1);
    let result = step(core);
    to.0.copy_from_slice(&core.x);
    to.1.copy_from_slice(&core.P);
    result
}

/// The model of the current step (copied from the filter, or from the per-step matrices at
/// each step) and the workspaces of the fast kernels, row-major.
struct Work {
    F: Vec<f64>,
    /// Fᵀ: F x is a sum of its rows.
    Ft: Vec<f64>,
    Q: Vec<f64>,
    /// Whether Q is exactly symmetric.
    q_symmetric: bool,
    H: Vec<f64>,
    R: Vec<f64>,
    B: Option<Vec<f64>>,
    alpha_sq: f64,
    /// F P (n×n).
    fp: Vec<f64>,
    /// H P (m×n), which is (P Hᵀ)ᵀ for a symmetric P.
    hp: Vec<f64>,
    /// S = H P Hᵀ + R and its Cholesky factor L (m×m), 1/L_aa (m).
    s: Vec<f64>,
    l: Vec<f64>,
    dinv: Vec<f64>,
    /// Kᵀ and (K S − P Hᵀ)ᵀ (m×n).
    kt: Vec<f64>,
    ct: Vec<f64>,
    /// The innovation y (m).
    y: Vec<f64>,
}

/// `out = aᵀ` for the n×n `a`.
fn transpose(a: &[f64], n: usize, out: &mut [f64]) {
    for (i, row) in a.chunks_exact(n).enumerate() {
        for (j, &v) in row.iter().enumerate() {
            out[j * n + i] = v;
        }
    }
}

impl Work {
    /// The filter's model (the per-step B, when there is one, is loaded by [`Work::load`]).
    fn new(core: &Core, n: usize, m: usize, model: Model<'_>) -> Self {
        let zeros = |rows: usize, cols: usize| vec![0.0; rows * cols];
        let mut Ft = zeros(n, n);
        transpose(&core.F, n, &mut Ft);
        let B = match model.B {
            Some(_) => Some(vec![0.0; n * model.p]),
            None => core.B.clone(),
        };
        Self {
            F: core.F.clone(),
            Ft,
            Q: core.Q.clone(),
            q_symmetric: is_symmetric(&core.Q, n),
            H: core.H.clone(),
            R: core.R.clone(),
            B,
            alpha_sq: core.alpha_sq,
            fp: zeros(n, n),
            hp: zeros(m, n),
            s: zeros(m, m),
            l: zeros(m, m),
            dinv: zeros(m, 1),
            kt: zeros(m, n),
            ct: zeros(m, n),
            y: zeros(m, 1),
        }
    }

    /// Takes step k's matrices from the per-step model (those it has; the others stay the
    /// filter's).
    fn load(&mut self, k: usize, n: usize, m: usize, model: &Model<'_>) {
        let at = |all: &[f64], size: usize, out: &mut [f64]| {
            out.copy_from_slice(&all[k * size..(k + 1) * size]);
        };
        if let Some(Fs) = model.F {
            at(Fs, n * n, &mut self.F);
            transpose(&self.F, n, &mut self.Ft);
        }
        if let Some(Qs) = model.Q {
            at(Qs, n * n, &mut self.Q);
            self.q_symmetric = is_symmetric(&self.Q, n);
        }
        if let Some(Hs) = model.H {
            at(Hs, m * n, &mut self.H);
        }
        if let Some(Rs) = model.R {
            at(Rs, m * m, &mut self.R);
        }
        if let (Some(Bs), Some(B)) = (model.B, self.B.as_mut()) {
            let size = B.len();
            at(Bs, size, B);
        }
    }

    /// `Core::predict` from `from` into `to` (`general`: by `Core` itself): x = F x + B u,
    /// P = α² F P Fᵀ + Q with the upper triangle of F P Fᵀ mirrored, as `Core` does.
    #[inline(always)]
    fn predict<D: Dim>(
        &mut self,
        d: D,
        core: &mut Core,
        general: bool,
        u: Option<&[f64]>,
        from: State<'_>,
        to: StateMut<'_>,
    ) {
        if general {
            let (F, Q, B) = (&self.F, &self.Q, self.B.as_deref());
            return via_core(core, from, to, |core| core.predict(u, Some(F), Some(Q), B));
        }
        let n = d.get();
        let (F, Ft, Q) = (&self.F[..n * n], &self.Ft[..n * n], &self.Q[..n * n]);
        let (x, P) = (&from.0[..n], &from.1[..n * n]);
        let (xo, Po) = (&mut to.0[..n], &mut to.1[..n * n]);
        combine(xo, x, Ft);
        if let (Some(B), Some(u)) = (self.B.as_deref(), u) {
            add_mul_vec(B, u, xo);
        }
        // T = F P, row i = Σ_j F_ij P_j; the upper triangle of T Fᵀ, T_i · F_j for j ≥ i;
        // then α² · + Q.
        let T = &mut self.fp[..n * n];
        for (row, f) in T.chunks_exact_mut(n).zip(F.chunks_exact(n)) {
            combine(row, f, P);
        }
        for i in 0..n {
            let ti = &T[i * n..(i + 1) * n];
            for j in i..n {
                let s = self.alpha_sq * dot(ti, &F[j * n..(j + 1) * n]);
                Po[i * n + j] = s + Q[i * n + j];
                Po[j * n + i] = s + Q[j * n + i];
            }
        }
    }

    /// `Core::update` (Joseph form) from `from` into `to` for a complete z, a symmetric P and
    /// an S that Cholesky accepts (factored from the same triangle `Core` reads); otherwise,
    /// or when `general`, by `Core` itself. `Err`: S singular.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn update<D: Dim, E: Dim>(
        &mut self,
        d: D,
        e: E,
        core: &mut Core,
        general: bool,
        symmetric: bool,
        z: &[f64],
        from: State<'_>,
        to: StateMut<'_>,
    ) -> Result<(), UpdateError> {
        let fast = !general && symmetric && z.iter().all(|v| !v.is_nan());
        if fast && self.joseph(d, e, z, from, (&mut *to.0, &mut *to.1)) {
            return Ok(());
        }
        let (R, H) = (&self.R, &self.H);
        via_core(core, from, to, |core| {
            core.update(z, Some(R), Some(H), false)
        })
    }

    /// The Joseph update of [`Work::update`]; `false`, with `to` not written, when S is not
    /// positive definite. With A = (I − K H) P = P − K (H P), FilterPy's
    /// (I − K H) P (I − K H)ᵀ + K R Kᵀ is A + (K S − P Hᵀ) Kᵀ for any K: its upper triangle,
    /// mirrored.
    #[inline(always)]
    fn joseph<D: Dim, E: Dim>(
        &mut self,
        d: D,
        e: E,
        z: &[f64],
        from: State<'_>,
        to: StateMut<'_>,
    ) -> bool {
        let (n, m) = (d.get(), e.get());
        let (H, R) = (&self.H[..m * n], &self.R[..m * m]);
        let (x, P) = (&from.0[..n], &from.1[..n * n]);
        let y = &mut self.y[..m];
        for ((ya, za), h) in y.iter_mut().zip(z).zip(H.chunks_exact(n)) {
            *ya = za - dot(h, x);
        }
        let hp = &mut self.hp[..m * n];
        for (row, h) in hp.chunks_exact_mut(n).zip(H.chunks_exact(n)) {
            combine(row, h, P);
        }
        let S = &mut self.s[..m * m];
        for a in 0..m {
            for b in 0..m {
                S[a * m + b] = dot(&H[a * n..(a + 1) * n], &hp[b * n..(b + 1) * n]) + R[a * m + b];
            }
        }
        // Cholesky of Sᵀ from its lower triangle (S's upper one), as `Core` factors it:
        // L_ab (a ≥ b) is stored at l[b, a].
        let (L, dinv) = (&mut self.l[..m * m], &mut self.dinv[..m]);
        L.copy_from_slice(S);
        for a in 0..m {
            let mut dg = L[a * m + a];
            for c in 0..a {
                dg -= L[c * m + a] * L[c * m + a];
            }
            if dg.is_nan() || dg <= 0.0 {
                return false;
            }
            let dg = dg.sqrt();
            L[a * m + a] = dg;
            dinv[a] = 1.0 / dg;
            for b in a + 1..m {
                let mut s = L[a * m + b];
                for c in 0..a {
                    s -= L[c * m + b] * L[c * m + a];
                }
                L[a * m + b] = s * dinv[a];
            }
        }
        // Kᵀ = S⁻ᵀ (P Hᵀ)ᵀ = S⁻ᵀ H P: L Lᵀ Kᵀ = H P, all columns at once.
        let kt = &mut self.kt[..m * n];
        kt.copy_from_slice(hp);
        for a in 0..m {
            let (done, rest) = kt.split_at_mut(a * n);
            let row = &mut rest[..n];
            for c in 0..a {
                axpy(row, -L[c * m + a], &done[c * n..(c + 1) * n]);
            }
            row.iter_mut().for_each(|v| *v *= dinv[a]);
        }
        for a in (0..m).rev() {
            let (head, tail) = kt.split_at_mut((a + 1) * n);
            let row = &mut head[a * n..];
            for c in a + 1..m {
                axpy(row, -L[a * m + c], &tail[(c - a - 1) * n..(c - a) * n]);
            }
            row.iter_mut().for_each(|v| *v *= dinv[a]);
        }
        // (K S − P Hᵀ)ᵀ, row a = Σ_b S_ba Kᵀ_b − (H P)_a.
        let ct = &mut self.ct[..m * n];
        for (a, row) in ct.chunks_exact_mut(n).enumerate() {
            row.fill(0.0);
            for b in 0..m {
                axpy(row, S[b * m + a], &kt[b * n..(b + 1) * n]);
            }
            axpy(row, -1.0, &hp[a * n..(a + 1) * n]);
        }
        let (xo, Po) = (&mut to.0[..n], &mut to.1[..n * n]);
        xo.copy_from_slice(x);
        for a in 0..m {
            axpy(xo, y[a], &kt[a * n..(a + 1) * n]);
        }
        // The upper triangle: P_ij − Σ_a K_ia (H P)_aj + Σ_a (K S − P Hᵀ)_ia K_ja.
        for i in 0..n {
            for j in i..n {
                let mut v = P[i * n + j];
                for a in 0..m {
                    v -= kt[a * n + i] * hp[a * n + j];
                }
                for a in 0..m {
                    v += ct[a * n + i] * kt[a * n + j];
                }
                Po[i * n + j] = v;
                Po[j * n + i] = v;
            }
        }
        true
    }
}

/// `KalmanFilter.rts_smoother`, FilterPy's: the step from k to k + 1 uses `Fs[k + 1]` and
/// `Qs[k + 1]` (each None for the filter's own at every step; a None item the filter's own
/// at that step), so `Fs[0]` and `Qs[0]` are read and checked but not used.
pub(crate) fn rts_smoother<'py>(
    core: &Core,
    py: Python<'py>,
    Xs: &Bound<'py, PyAny>,
    Ps: &Bound<'py, PyAny>,
    Fs: Option<&Bound<'py, PyAny>>,
    Qs: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let n = core.n;
    let xa = float_array(Xs, "Xs")?;
    let pa = float_array(Ps, "Ps")?;
    let xs_shape = xa.shape().to_vec();
    let steps = match xs_shape.as_slice() {
        [s, l] if *l == n => *s,
        [s, l, 1] if *l == n => *s,
        s => {
            return Err(value_error(format!(
                "Xs has shape {}, expected (N, {n}, 1) or (N, {n})",
                shape_str(s)
            )));
        }
    };
    if pa.shape() != [steps, n, n] {
        return Err(value_error(format!(
            "Ps has shape {}, expected ({steps}, {n}, {n}) to match Xs",
            shape_str(pa.shape())
        )));
    }
    let what = "rts_smoother's buffers";
    let size = entries(steps, entries(n, n, what)?, what)?;
    let mut xs = zeros(entries(steps, n, what)?, what)?;
    copy_finite(&xa.readonly().as_array(), "Xs", &mut xs)?;
    let mut ps = zeros(size, what)?;
    copy_finite(&pa.readonly().as_array(), "Ps", &mut ps)?;
    for (k, pk) in ps.chunks_exact(n * n).enumerate() {
        check_covariance(&format!("Ps[{k}]"), pk, n)?;
    }
    let (pp, gains) = (zeros(size, what)?, zeros(size, what)?);
    let along = Along { name: "Xs", steps };
    let spec = |name, rule, own| Spec {
        name,
        rows: n,
        cols: n,
        rule,
        own,
    };
    let Fs = read_steps(Fs, &spec("Fs", Rule::Matrix, Some(&core.F)), along)?;
    let Qs = read_steps(Qs, &spec("Qs", Rule::Covariance, Some(&core.Q)), along)?;
    let F = Fs.as_deref().map_or(Steps::Same(&core.F), Steps::Each);
    let Q = Qs.as_deref().map_or(Steps::Same(&core.Q), Steps::Each);
    let (x, P, K, Pp) = rts((xs, ps), (pp, gains), steps, n, F, Q).map_err(|k| {
        let name = |given: bool, own: &str, each: &str| {
            if given {
                format!("{each}[{}]", k + 1)
            } else {
                own.to_string()
            }
        };
        let (f, q) = (name(Fs.is_some(), "F", "Fs"), name(Qs.is_some(), "Q", "Qs"));
        value_error(format!(
            "rts_smoother: the predicted covariance Pp[{k}] = {f} Ps[{k}] {f}ᵀ + {q} is \
             singular"
        ))
    })?;
    let x_out = if xs_shape.len() == 3 {
        array3_out(py, x, steps, n, 1).into_any()
    } else {
        let arr = numpy::ndarray::Array2::from_shape_vec((steps, n), x)
            .unwrap_or_else(|_| numpy::ndarray::Array2::zeros((steps, n)));
        numpy::PyArray2::from_owned_array(py, arr).into_any()
    };
    PyTuple::new(
        py,
        [
            x_out,
            array3_out(py, P, steps, n, n).into_any(),
            array3_out(py, K, steps, n, n).into_any(),
            array3_out(py, Pp, steps, n, n).into_any(),
        ],
    )
}
