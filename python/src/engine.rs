//! The engine's own functions, Pythonic: `filter` and `smooth` run a whole series through
//! `kalman::Filter` (the engine's step: update with z_k, then predict with u_k; exact
//! cross-covariance S; singular R; NaN entries skipped; optionally a wild-point gate) in
//! one call, `filter_continuous` and `smooth_continuous` do the same for a continuous model
//! at a record's own time stamps (`kalman::sampling`), and `dare`, `dlqr`, `care` solve the
//! Riccati equations (their matrices may be integer or float32 arrays, converted, and R a
//! number for a single channel; the solvers run with the GIL released). Engine errors become `ValueError`s carrying the engine's message,
//! which names the matrix and the rule.
#![allow(non_snake_case)]

use kalman::faer::Mat;
use kalman::sampling::{ContinuousModel, Sampler};
use kalman::{DynDims, Filter, Model, riccati};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{faer_out, mat, mat_or_scalar, value_error};
use crate::guard;
use crate::pass::{
    Pass, SAMPLER_CAPACITY, Timing, covariance_form, engine, gate_option, time_stamps,
};

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

/// What a whole-series function returns: the filtered or the smoothed estimates.
#[derive(Clone, Copy)]
enum Output {
    /// `filter`'s dict (x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k}, log-likelihood, NIS).
    Filtered,
    /// `smooth`'s dict (the RTS-smoothed x, P).
    Smoothed,
}

impl Output {
    /// Runs `pass` for this output.
    fn run(self, py: Python<'_>, pass: Pass) -> PyResult<Bound<'_, PyDict>> {
        match self {
            Output::Filtered => pass.filtered(py),
            Output::Smoothed => pass.smoothed(py),
        }
    }

    /// The name of the discrete (`filter`/`smooth`) or continuous-discrete function.
    fn context(self, continuous: bool) -> &'static str {
        match (self, continuous) {
            (Output::Filtered, false) => "filter",
            (Output::Smoothed, false) => "smooth",
            (Output::Filtered, true) => "filter_continuous",
            (Output::Smoothed, true) => "smooth_continuous",
        }
    }
}

/// filter(F, H, Q, R, x0, P0, zs, us=None, B=None, S=None, form="joseph", gate=None,
/// gate_rule="entries") → dict with "x", "P" (filtered, x_{k|k}), "x_pred", "P_pred"
/// (x_{k+1|k}), "log_likelihood", "nis" (NaN on a step with no measurement). (x0, P0) is
/// the prior of the first measurement; step k updates with zs[k] and predicts with
/// us[k]. S = E[w_k v_kᵀ] enters the prediction. With gate (a probability in (0, 1)),
/// each step's measurements are screened against the prior before the update
/// (gate_rule "entries": each entry's e_i²/Σ_ii against χ²(1); "vector": the step's
/// eᵀΣ⁺e against χ²(rank Σ)), the rejected ones are skipped like NaN entries, and
/// "rejected" is a dict of 1-d arrays "step", "channel" (int64), "value", "nis".
#[pyfunction]
#[pyo3(signature = (F, H, Q, R, x0, P0, zs, us = None, B = None, S = None, form = "joseph", gate = None, gate_rule = "entries"))]
pub(crate) fn filter<'py>(
    py: Python<'py>,
    F: &Bound<'py, PyAny>,
    H: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    P0: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    us: Option<&Bound<'py, PyAny>>,
    B: Option<&Bound<'py, PyAny>>,
    S: Option<&Bound<'py, PyAny>>,
    form: &str,
    gate: Option<Bound<'py, PyAny>>,
    gate_rule: &str,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_discrete(
            Output::Filtered,
            py,
            [F, H, Q, R, x0, P0, zs],
            [us, B, S],
            form,
            gate,
            gate_rule,
        )
    })
}

/// smooth(F, H, Q, R, x0, P0, zs, us=None, B=None, S=None, form="joseph", gate=None,
/// gate_rule="entries") → dict with the RTS-smoothed "x" (N, n) and "P" (N, n, n): the
/// engine's filter recorded step by step (gated as in `filter`, and then with
/// "rejected"), then `kalman::smoother::RtsSmoother` (its square-root backward pass when
/// form = "sqrt").
#[pyfunction]
#[pyo3(signature = (F, H, Q, R, x0, P0, zs, us = None, B = None, S = None, form = "joseph", gate = None, gate_rule = "entries"))]
pub(crate) fn smooth<'py>(
    py: Python<'py>,
    F: &Bound<'py, PyAny>,
    H: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    P0: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    us: Option<&Bound<'py, PyAny>>,
    B: Option<&Bound<'py, PyAny>>,
    S: Option<&Bound<'py, PyAny>>,
    form: &str,
    gate: Option<Bound<'py, PyAny>>,
    gate_rule: &str,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_discrete(
            Output::Smoothed,
            py,
            [F, H, Q, R, x0, P0, zs],
            [us, B, S],
            form,
            gate,
            gate_rule,
        )
    })
}

/// [`filter`]'s and [`smooth`]'s work: the discrete model of the Python signature
/// `(F, H, Q, R, x0, P0, zs)` and the optional `(us, B, S)`, its filter, and the pass.
fn run_discrete<'py>(
    output: Output,
    py: Python<'py>,
    [F, H, Q, R, x0, P0, zs]: [&Bound<'py, PyAny>; 7],
    [us, B, S]: [Option<&Bound<'py, PyAny>>; 3],
    form: &str,
    gate: Option<Bound<'py, PyAny>>,
    gate_rule: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let context = output.context(false);
    let form = covariance_form(form)?;
    let gate = gate_option(gate.as_ref(), gate_rule)?;
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
    let pass = Pass::new(filter, Timing::Own, zs, us, gate, context)?;
    output.run(py, pass)
}

/// filter_continuous(A, C, W, R, x0, P0, t, zs, us=None, B=None, form="joseph",
/// gate=None, gate_rule="entries") → `filter`'s dict for a continuous model
/// ẋ = A x + B u + w (W the intensity of w as it enters the state, G Qc Gᵀ) measured at
/// the time stamps t (N,), non-decreasing: z(t_k) = C x(t_k) + v_k, cov(v_k) = R. Each
/// interval is sampled exactly (F = e^{AΔt}, the input by zero-order hold, Q by Van
/// Loan); (x0, P0) is the prior of the first row's measurement, step k updates with
/// zs[k] and predicts with us[k] over t[k+1] − t[k] (the last row over 0: its "x_pred"
/// is its "x"). Equal stamps are one instant. gate and gate_rule as in `filter`.
#[pyfunction]
#[pyo3(signature = (A, C, W, R, x0, P0, t, zs, us = None, B = None, form = "joseph", gate = None, gate_rule = "entries"))]
pub(crate) fn filter_continuous<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    C: &Bound<'py, PyAny>,
    W: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    P0: &Bound<'py, PyAny>,
    t: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    us: Option<&Bound<'py, PyAny>>,
    B: Option<&Bound<'py, PyAny>>,
    form: &str,
    gate: Option<Bound<'py, PyAny>>,
    gate_rule: &str,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_continuous(
            Output::Filtered,
            py,
            [A, C, W, R, x0, P0, t, zs],
            [us, B],
            form,
            gate,
            gate_rule,
        )
    })
}

/// smooth_continuous(A, C, W, R, x0, P0, t, zs, us=None, B=None, form="joseph",
/// gate=None, gate_rule="entries") → `smooth`'s dict for the continuous model of
/// `filter_continuous`: the RTS smoother over its (gated) pass, each step recorded with
/// the model sampled for it.
#[pyfunction]
#[pyo3(signature = (A, C, W, R, x0, P0, t, zs, us = None, B = None, form = "joseph", gate = None, gate_rule = "entries"))]
pub(crate) fn smooth_continuous<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    C: &Bound<'py, PyAny>,
    W: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    P0: &Bound<'py, PyAny>,
    t: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    us: Option<&Bound<'py, PyAny>>,
    B: Option<&Bound<'py, PyAny>>,
    form: &str,
    gate: Option<Bound<'py, PyAny>>,
    gate_rule: &str,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_continuous(
            Output::Smoothed,
            py,
            [A, C, W, R, x0, P0, t, zs],
            [us, B],
            form,
            gate,
            gate_rule,
        )
    })
}

/// [`filter_continuous`]'s and [`smooth_continuous`]'s work: the continuous model of the
/// Python signature `(A, C, W, R, x0, P0, t, zs)` and the optional `(us, B)`, its sampler,
/// the filter (built on the Δt = 0 model) and the pass at the time stamps.
fn run_continuous<'py>(
    output: Output,
    py: Python<'py>,
    [A, C, W, R, x0, P0, t, zs]: [&Bound<'py, PyAny>; 8],
    [us, B]: [Option<&Bound<'py, PyAny>>; 2],
    form: &str,
    gate: Option<Bound<'py, PyAny>>,
    gate_rule: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let context = output.context(true);
    let form = covariance_form(form)?;
    let gate = gate_option(gate.as_ref(), gate_rule)?;
    let mut sampler = sampler([A, C, W, R], B, context)?;
    let n = sampler.continuous().n();
    let err = engine(context);
    let first = sampler.at(0.0).map_err(&err)?.clone();
    let x0 = vector(x0, "x0", n)?;
    let P0 = mat(P0, "P0")?;
    let filter = Filter::new(first, &x0, &P0, form).map_err(&err)?;
    let t = time_stamps(t)?;
    let timing = Timing::Sampled {
        sampler: Box::new(sampler),
        t,
    };
    let pass = Pass::new(filter, timing, zs, us, gate, context)?;
    output.run(py, pass)
}

/// The sampler of the continuous model `(A, C, W, R)` with the optional `B`: shapes are
/// checked here, naming the argument as Python spells it (the engine calls C "H"), then
/// `kalman::sampling::ContinuousModel` checks W and R (symmetric PSD).
fn sampler(
    [A, C, W, R]: [&Bound<'_, PyAny>; 4],
    B: Option<&Bound<'_, PyAny>>,
    context: &str,
) -> PyResult<Sampler> {
    let (A, C, W, R) = (mat(A, "A")?, mat(C, "C")?, mat(W, "W")?, mat(R, "R")?);
    let B = opt_mat(B, "B")?;
    let shape = |a: &Mat<f64>| format!("({}, {})", a.nrows(), a.ncols());
    let n = A.nrows();
    if n == 0 || A.ncols() != n {
        return Err(value_error(format!(
            "{context}: A has shape {}, expected a square (n, n) matrix with n ≥ 1",
            shape(&A)
        )));
    }
    let m = C.nrows();
    if m == 0 || C.ncols() != n {
        return Err(value_error(format!(
            "{context}: C has shape {}, expected (m, {n}) with m ≥ 1: one row per measurement,              one column per state of A",
            shape(&C)
        )));
    }
    for (name, a, rows) in [("W", &W, n), ("R", &R, m)] {
        if (a.nrows(), a.ncols()) != (rows, rows) {
            return Err(value_error(format!(
                "{context}: {name} has shape {}, expected ({rows}, {rows})",
                shape(a)
            )));
        }
    }
    if let Some(B) = &B
        && (B.nrows() != n || B.ncols() == 0)
    {
        return Err(value_error(format!(
            "{context}: B has shape {}, expected ({n}, p) with p ≥ 1",
            shape(B)
        )));
    }
    let err = engine(context);
    let mut model = ContinuousModel::new(&A, &C, &W, &R).map_err(&err)?;
    if let Some(B) = &B {
        model = model.with_control(B).map_err(&err)?;
    }
    Sampler::new(model, SAMPLER_CAPACITY).map_err(&err)
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
    let (a, b, q, r) = (mat(a, na)?, mat(b, nb)?, mat(q, nq)?, mat_or_scalar(r, nr)?);
    let coupling = opt_mat(coupling, coupling_name)?;
    let outputs = match kind {
        Discrete::Filter => {
            let mut dare = riccati::Dare::new(&a, &b, &q, &r).map_err(engine(context))?;
            if let Some(s) = &coupling {
                dare = dare.cross_covariance(s).map_err(engine(context))?;
            }
            let ss = py.detach(|| dare.solve()).map_err(engine(context))?;
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
            let lqr = py.detach(|| dlqr.solve()).map_err(engine(context))?;
            vec![("K", lqr.gain), ("P", lqr.cost)]
        }
    };
    let out = PyDict::new(py);
    for (key, value) in outputs {
        out.set_item(key, faer_out(py, value.as_ref()))?;
    }
    Ok(out)
}

/// dare(F, H, Q, R, S=None) → dict with the steady-state prior covariance "P", the
/// posterior "P_post", the filter gain "K", the predictor gain "K_pred" and the
/// innovation covariance "innovation_cov" (the filter's DARE; structured doubling with a
/// Newton polish).
#[pyfunction]
#[pyo3(signature = (F, H, Q, R, S = None))]
pub(crate) fn dare<'py>(
    py: Python<'py>,
    F: &Bound<'py, PyAny>,
    H: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    S: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| discrete_riccati(Discrete::Filter, py, [F, H, Q, R], [S]))
}

/// dlqr(A, B, Q, R, N=None) → dict with the gain "K" (u = −K x) and the cost matrix "P"
/// of the discrete LQR (the dual DARE).
#[pyfunction]
#[pyo3(signature = (A, B, Q, R, N = None))]
pub(crate) fn dlqr<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    B: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    N: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| discrete_riccati(Discrete::Lqr, py, [A, B, Q, R], [N]))
}

/// care(A, H, Q, R) → dict with the steady-state covariance "P" and gain "K" of the
/// Kalman–Bucy filter (A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0).
#[pyfunction]
#[pyo3(signature = (A, H, Q, R))]
pub(crate) fn care<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    H: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| run_care(py, [A, H, Q, R]))
}

/// [`care`]'s work.
fn run_care<'py>(
    py: Python<'py>,
    [A, H, Q, R]: [&Bound<'py, PyAny>; 4],
) -> PyResult<Bound<'py, PyDict>> {
    let (A, H, Q, R) = (
        mat(A, "A")?,
        mat(H, "H")?,
        mat(Q, "Q")?,
        mat_or_scalar(R, "R")?,
    );
    let care = riccati::Care::new(&A, &H, &Q, &R).map_err(engine("care"))?;
    let ss = py.detach(|| care.solve()).map_err(engine("care"))?;
    let out = PyDict::new(py);
    out.set_item("P", faer_out(py, ss.covariance.as_ref()))?;
    out.set_item("K", faer_out(py, ss.gain.as_ref()))?;
    Ok(out)
}
