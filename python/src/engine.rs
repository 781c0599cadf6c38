//! The engine's own functions, Pythonic: `filter` and `smooth` run a whole series through
//! `kalman::Filter` (the engine's step: update with z_k, then predict with u_k; exact
//! cross-covariance S; singular R; NaN entries skipped) in one call, and `dare`, `dlqr`,
//! `care` solve the Riccati equations. Engine errors become `ValueError`s carrying the
//! engine's message, which names the matrix and the rule.
#![allow(non_snake_case)]

use kalman::faer::Mat;
use kalman::{CovarianceForm, DynDims, Filter, Model, StepInfo, riccati, smoother::RtsSmoother};
use numpy::PyArray2;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{FilterRecord, array3_out, copy_mat, faer_out, mat, value_error};

/// An optional matrix argument (`None` → absent).
fn opt_mat(obj: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<Mat<f64>>> {
    match obj {
        Some(o) if !o.is_none() => mat(o, name).map(Some),
        _ => Ok(None),
    }
}

/// A vector argument of length `len`.
fn vector(obj: &Bound<'_, PyAny>, name: &str, len: usize) -> PyResult<Vec<f64>> {
    let mut out = vec![0.0; len];
    crate::convert::read_vector(obj, name, len, false, false, &mut out)?;
    Ok(out)
}

/// Maps an engine error to a `ValueError` naming the function.
fn engine(context: &str) -> impl Fn(kalman::Error) -> PyErr + '_ {
    move |e| value_error(format!("{context}: {e}"))
}

/// The engine's filter of `filter`/`smooth` and the series it runs over: zs (N, m) and
/// us (N, p), row-major.
struct Run {
    filter: Filter<DynDims>,
    n: usize,
    m: usize,
    p: usize,
    steps: usize,
    z: Vec<f64>,
    u: Option<Vec<f64>>,
    context: &'static str,
}

impl Run {
    /// Validates the model and the series given as the Python signature lists them:
    /// `(F, H, Q, R, x0, P0, zs)` and the optional `(us, B, S)`.
    fn new(
        [F, H, Q, R, x0, P0, zs]: [&Bound<'_, PyAny>; 7],
        [us, B, S]: [Option<&Bound<'_, PyAny>>; 3],
        form: CovarianceForm,
        context: &'static str,
    ) -> PyResult<Self> {
        let F = mat(F, "F")?;
        let H = mat(H, "H")?;
        let Q = mat(Q, "Q")?;
        let R = mat(R, "R")?;
        let B = opt_mat(B, "B")?;
        let S = opt_mat(S, "S")?;
        let (n, m) = (F.nrows(), H.nrows());
        let p = B.as_ref().map_or(0, |b| b.ncols());
        let err = engine(context);
        let mut model =
            Model::new(DynDims::new(n, m, p).map_err(&err)?, &F, &H, &Q, &R).map_err(&err)?;
        if let Some(B) = &B {
            model = model.with_control(B).map_err(&err)?;
        }
        if let Some(S) = &S {
            model = model.with_cross_covariance(S).map_err(&err)?;
        }
        let x0 = vector(x0, "x0", n)?;
        let P0 = mat(P0, "P0")?;
        let filter = Filter::new(model, &x0, &P0, form).map_err(&err)?;
        let (steps, z, u) = series(zs, us, m, p)?;
        Ok(Self {
            filter,
            n,
            m,
            p,
            steps,
            z,
            u,
            context,
        })
    }

    /// Step k: the update with zs[k], then the prediction with us[k].
    fn step(&mut self, k: usize) -> PyResult<StepInfo> {
        let (m, p) = (self.m, self.p);
        let uk = self.u.as_ref().map(|u| &u[k * p..(k + 1) * p]);
        self.filter
            .step(&self.z[k * m..(k + 1) * m], uk)
            .map_err(engine(self.context))
    }
}

/// Reads `zs` (N, m) and `us` (N, p) for a model with m measurements and p inputs.
fn series(
    zs: &Bound<'_, PyAny>,
    us: Option<&Bound<'_, PyAny>>,
    m: usize,
    p: usize,
) -> PyResult<(usize, Vec<f64>, Option<Vec<f64>>)> {
    let (steps, z) = crate::series::read_series(zs, "zs", m, true)?;
    let u = match us {
        Some(us) if !us.is_none() => {
            if p == 0 {
                return Err(value_error(
                    "us is given but there is no B (no control input)",
                ));
            }
            let (k, u) = crate::series::read_series(us, "us", p, false)?;
            if k != steps {
                return Err(value_error(format!("us has {k} steps but zs has {steps}")));
            }
            Some(u)
        }
        _ => None,
    };
    Ok((steps, z, u))
}

py_function! {
    /// filter(F, H, Q, R, x0, P0, zs, us=None, B=None, S=None, form="joseph") → dict with
    /// "x", "P" (filtered, x_{k|k}), "x_pred", "P_pred" (x_{k+1|k}), "log_likelihood", "nis"
    /// (NaN on a step with no measurement). (x0, P0) is the prior of the first measurement;
    /// step k updates with zs[k] and predicts with us[k]. S = E[w_k v_kᵀ] enters the
    /// prediction.
    fn filter(F, H, Q, R, x0, P0, zs; us = None, B = None, S = None; form: &str = "joseph")
        => run_filter
}

/// [`filter`]'s work.
fn run_filter<'py>(
    py: Python<'py>,
    model: [&Bound<'py, PyAny>; 7],
    controls: [Option<&Bound<'py, PyAny>>; 3],
    form: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let form = match form {
        "joseph" => CovarianceForm::Joseph,
        "standard" => CovarianceForm::Standard,
        "sqrt" => CovarianceForm::SquareRoot,
        other => {
            return Err(value_error(format!(
                "form = {other:?}; expected \"joseph\", \"standard\" or \"sqrt\""
            )));
        }
    };
    let mut run = Run::new(model, controls, form, "filter")?;
    let mut rec = FilterRecord::new(run.steps, run.n);
    for k in 0..run.steps {
        let info = run.step(k)?;
        let f = &run.filter;
        rec.set(
            k,
            f.state(),
            f.covariance(),
            f.predicted_state(),
            f.predicted_covariance(),
            info.log_likelihood,
            info.nis,
        );
    }
    rec.into_dict(py)
}

py_function! {
    /// smooth(F, H, Q, R, x0, P0, zs, us=None, B=None, S=None) → dict with the RTS-smoothed
    /// "x" (N, n) and "P" (N, n, n): the engine's filter (Joseph form) recorded step by step,
    /// then `kalman::smoother::RtsSmoother`.
    fn smooth(F, H, Q, R, x0, P0, zs; us = None, B = None, S = None) => run_smooth
}

/// [`smooth`]'s work.
fn run_smooth<'py>(
    py: Python<'py>,
    model: [&Bound<'py, PyAny>; 7],
    controls: [Option<&Bound<'py, PyAny>>; 3],
) -> PyResult<Bound<'py, PyDict>> {
    let mut run = Run::new(model, controls, CovarianceForm::Joseph, "smooth")?;
    let (steps, n) = (run.steps, run.n);
    let mut rts = RtsSmoother::new();
    for k in 0..steps {
        run.step(k)?;
        rts.record(&run.filter).map_err(engine("smooth"))?;
    }
    let sm = rts.smooth().map_err(engine("smooth"))?;
    let nn = n * n;
    let mut ps = vec![0.0; steps * nn];
    for (out, c) in ps.chunks_exact_mut(nn).zip(&sm.covariances) {
        copy_mat(out, c.as_ref());
    }
    let xs = Array2::from_shape_fn((steps, n), |(k, i)| sm.means[(i, k)]);
    let out = PyDict::new(py);
    out.set_item("x", PyArray2::from_owned_array(py, xs))?;
    out.set_item("P", array3_out(py, ps, steps, n, n))?;
    Ok(out)
}

/// The two discrete Riccati equations behind `dare` and `dlqr`.
#[derive(Clone, Copy)]
enum Discrete {
    /// The filter's DARE (F, H, Q, R, S).
    Filter,
    /// The LQR's dual DARE (A, B, Q, R, N).
    Lqr,
}

/// `dare`/`dlqr`: the four matrices and the optional coupling term, read under the names
/// of `kind`'s Python signature, solved, and returned as a dict.
fn discrete_riccati<'py>(
    kind: Discrete,
    py: Python<'py>,
    args: [&Bound<'py, PyAny>; 4],
    [coupling]: [Option<&Bound<'py, PyAny>>; 1],
) -> PyResult<Bound<'py, PyDict>> {
    let (names, coupling_name, context) = match kind {
        Discrete::Filter => (["F", "H", "Q", "R"], "S", "dare"),
        Discrete::Lqr => (["A", "B", "Q", "R"], "N", "dlqr"),
    };
    let ([a, b, q, r], [na, nb, nq, nr]) = (args, names);
    let (a, b, q, r) = (mat(a, na)?, mat(b, nb)?, mat(q, nq)?, mat(r, nr)?);
    let coupling = opt_mat(coupling, coupling_name)?;
    let outputs = match kind {
        Discrete::Filter => {
            let mut dare = riccati::Dare::new(&a, &b, &q, &r).map_err(engine(context))?;
            if let Some(s) = &coupling {
                dare = dare.cross_covariance(s).map_err(engine(context))?;
            }
            let ss = dare.solve().map_err(engine(context))?;
            vec![
                ("P", ss.prior),
                ("P_post", ss.posterior),
                ("K", ss.gain),
                ("K_pred", ss.predictor_gain),
                ("innovation_cov", ss.innovation_cov),
            ]
        }
        Discrete::Lqr => {
            let mut dlqr = riccati::Dlqr::new(&a, &b, &q, &r).map_err(engine(context))?;
            if let Some(n) = &coupling {
                dlqr = dlqr.cross_weight(n).map_err(engine(context))?;
            }
            let lqr = dlqr.solve().map_err(engine(context))?;
            vec![("K", lqr.gain), ("P", lqr.cost)]
        }
    };
    let out = PyDict::new(py);
    for (key, value) in outputs {
        out.set_item(key, faer_out(py, value.as_ref()))?;
    }
    Ok(out)
}

py_function! {
    /// dare(F, H, Q, R, S=None) → dict with the steady-state prior covariance "P", the
    /// posterior "P_post", the filter gain "K", the predictor gain "K_pred" and the
    /// innovation covariance "innovation_cov" (the filter's DARE; structured doubling with a
    /// Newton polish).
    fn dare(F, H, Q, R; S = None) => discrete_riccati(Discrete::Filter)
}

py_function! {
    /// dlqr(A, B, Q, R, N=None) → dict with the gain "K" (u = −K x) and the cost matrix "P"
    /// of the discrete LQR (the dual DARE).
    fn dlqr(A, B, Q, R; N = None) => discrete_riccati(Discrete::Lqr)
}

py_function! {
    /// care(A, H, Q, R) → dict with the steady-state covariance "P" and gain "K" of the
    /// Kalman–Bucy filter (A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0).
    fn care(A, H, Q, R) => run_care
}

/// [`care`]'s work.
fn run_care<'py>(
    py: Python<'py>,
    [A, H, Q, R]: [&Bound<'py, PyAny>; 4],
) -> PyResult<Bound<'py, PyDict>> {
    let (A, H, Q, R) = (mat(A, "A")?, mat(H, "H")?, mat(Q, "Q")?, mat(R, "R")?);
    let ss = riccati::Care::new(&A, &H, &Q, &R)
        .and_then(|c| c.solve())
        .map_err(engine("care"))?;
    let out = PyDict::new(py);
    out.set_item("P", faer_out(py, ss.covariance.as_ref()))?;
    out.set_item("K", faer_out(py, ss.gain.as_ref()))?;
    Ok(out)
}
