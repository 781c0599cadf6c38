//! `kalman::fit` from Python: `fit` learns Q, R (optionally x0 and a diagonal P0) or the
//! items named as the command line's `--free` names them (`free=["F[0,0]", "Q[0,0]",
//! "R[0,0]"]`, [`kalman::fit::FreeSpec`]) of a linear Gaussian model from data by EM or
//! maximum likelihood; `fit_callable` fits a Python function θ → matrices by maximum
//! likelihood (derivatives by central differences). Standard errors and information
//! criteria come with both; fit errors become `ValueError`s.
#![allow(non_snake_case)]

use std::cell::RefCell;

use kalman::faer::Mat;
use kalman::fit::{
    EmOptions, Fit, FitError, FnMap, Free, FreeSpec, Interrupt, MleOptions, ParamMap, Series,
    StandardMap, Structure, System, em, mle,
};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::{faer_out, mat, read_vector, type_error, type_name, value_error};
use crate::guard;

fn structure(s: &str, name: &str) -> PyResult<Structure> {
    Ok(match s {
        "fixed" => Structure::Fixed,
        "scalar" => Structure::Scalar,
        "diag" => Structure::Diag,
        "full" => Structure::Full,
        other => {
            return Err(value_error(format!(
                "{name} = {other:?}; expected \"fixed\", \"scalar\", \"diag\" or \"full\""
            )));
        }
    })
}

/// A fit error as a `ValueError`; a parameterisation error (a bad free name) without the
/// library's "parameter vector:" prefix; an interrupted fit (Ctrl-C) as `KeyboardInterrupt`.
fn fit_err(context: &str) -> impl Fn(FitError) -> PyErr + '_ {
    move |e| match e {
        FitError::Parameters(m) => value_error(format!("{context}: {m}")),
        FitError::Interrupted => {
            pyo3::exceptions::PyKeyboardInterrupt::new_err(format!("{context} interrupted"))
        }
        e => value_error(format!("{context}: {e}")),
    }
}

/// The fits' interruption check: whether a signal handler (Ctrl-C's) raised, run with the
/// interpreter taken back for the moment it takes (the fits run with it released).
fn signalled() -> bool {
    Python::attach(|py| py.check_signals().is_err())
}

/// fit(F, H, Q, R, x0, P0, zs, method=None, q="diag", r="diag", free_x0=False,
/// free_p0_diag=False, max_iter=None, free=None, dt=None) → dict with the fitted "F",
/// "H", "Q", "R", "x0", "P0", "loglik", "iterations", "converged", "message", "boundary"
/// (parameters on a variance boundary), "theta", "std_errors" (observed information;
/// None when singular), "estimates" (each parameter's value by name), "correlation"
/// ({"names", "matrix"}; None when singular), "aic", "bic". Q and R are freed as
/// "scalar" (σ²·I), "diag", "full" (Cholesky with a log-diagonal) or kept "fixed"; F, H
/// are kept at the given values; the given Q, R, x0, P0 are the starting point.
/// free: a list of the command line's `--free` names instead of q, r, free_x0 and
/// free_p0_diag ("Q:scalar|diag|full", "R:…", "x0", "P0:diag", entries "F[i,j]",
/// "B[i,j]", "H[i,j]", "Q[i,j]", "R[i,j]", "P0[i,j]", "x0[i]", "Q:white-acceleration"
/// with dt the sampling interval); every entry not named keeps its value exactly, and
/// "std_errors" is then a dict as the command line's summary has it (the matrices freed
/// whole in their shapes, each named parameter by its name). method "em"
/// (Shumway–Stoffer; the default without free) or "mle" (L-BFGS with the exact score,
/// Nelder–Mead fallback; the default with free). zs: (N, m), NaN for missing entries.
#[pyfunction]
#[pyo3(signature = (F, H, Q, R, x0, P0, zs, method = None, q = "diag", r = "diag", free_x0 = false, free_p0_diag = false, max_iter = None, free = None, dt = None))]
pub(crate) fn fit<'py>(
    py: Python<'py>,
    F: &Bound<'py, PyAny>,
    H: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    P0: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    method: Option<&str>,
    q: &str,
    r: &str,
    free_x0: bool,
    free_p0_diag: bool,
    max_iter: Option<usize>,
    free: Option<Bound<'py, PyAny>>,
    dt: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_fit(
            py,
            [F, H, Q, R, x0, P0, zs],
            method,
            q,
            r,
            free_x0,
            free_p0_diag,
            max_iter,
            free,
            dt,
        )
    })
}

/// The free items of `fit(free=...)`: a list (or tuple) of strings.
fn free_names(obj: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(type_error(
            "free must be a list of names such as [\"F[0,0]\", \"R:diag\"], not a str",
        ));
    }
    let items = obj.try_iter().map_err(|_| {
        type_error(format!(
            "free must be a list of names such as [\"F[0,0]\", \"R:diag\"], not {}",
            type_name(obj)
        ))
    })?;
    items
        .map(|item| {
            let item = item?;
            item.extract::<String>().map_err(|_| {
                type_error(format!(
                    "free: every item must be a str such as \"F[0,0]\", not {}",
                    type_name(&item)
                ))
            })
        })
        .collect()
}

/// [`fit`]'s work.
#[allow(clippy::too_many_arguments)]
fn run_fit<'py>(
    py: Python<'py>,
    [F, H, Q, R, x0, P0, zs]: [&Bound<'py, PyAny>; 7],
    method: Option<&str>,
    q: &str,
    r: &str,
    free_x0: bool,
    free_p0_diag: bool,
    max_iter: Option<usize>,
    free: Option<Bound<'py, PyAny>>,
    dt: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let (F, H, Q, R, P0) = (
        mat(F, "F")?,
        mat(H, "H")?,
        mat(Q, "Q")?,
        mat(R, "R")?,
        mat(P0, "P0")?,
    );
    let (n, m) = (F.nrows(), H.nrows());
    let mut x0v = vec![0.0; n];
    read_vector(x0, "x0", n, false, false, &mut x0v)?;
    let err = fit_err("fit");
    let base = System::new(&F, &H, &Q, &R, &x0v, &P0).map_err(&err)?;
    let spec = match &free {
        Some(names) => {
            let conflicts: Vec<&str> = [
                (q != "diag", "q"),
                (r != "diag", "r"),
                (free_x0, "free_x0"),
                (free_p0_diag, "free_p0_diag"),
            ]
            .into_iter()
            .filter_map(|(set, name)| set.then_some(name))
            .collect();
            if !conflicts.is_empty() {
                return Err(value_error(format!(
                    "fit: free=[...] names everything that is fitted; leave {} at the default \
                     (write Q:…, R:…, x0 or P0:diag in free instead)",
                    conflicts.join(", ")
                )));
            }
            if dt.is_some_and(|d| !(d.is_finite() && d > 0.0)) {
                return Err(value_error(format!(
                    "fit: dt = {}; it must be positive and finite",
                    dt.unwrap_or(f64::NAN)
                )));
            }
            let spec = FreeSpec::parse(&free_names(names)?).map_err(fit_err("fit: free"))?;
            if spec.is_empty() {
                return Err(value_error(
                    "fit: free is empty; name at least one of Q:…, R:…, x0, P0:diag or an entry such as F[0,0]",
                ));
            }
            Some(spec)
        }
        None if dt.is_some() => {
            return Err(value_error(
                "fit: dt is the sampling interval of free=[\"Q:white-acceleration\"]; it needs free",
            ));
        }
        None => None,
    };
    let map = match &spec {
        Some(spec) => spec.map(base, dt).map_err(fit_err("fit: free"))?,
        None => {
            let free = Free {
                q: structure(q, "q")?,
                r: structure(r, "r")?,
                x0: free_x0,
                p0_diag: free_p0_diag,
            };
            StandardMap::new(base, free).map_err(&err)?
        }
    };
    let (_, z) = crate::series::read_series(zs, "zs", m, true)?;
    let data = Series::new(&z, m).map_err(&err)?;
    let method = method.unwrap_or(if spec.is_some() { "mle" } else { "em" });
    let result = match method {
        "em" => {
            let mut opts = EmOptions {
                interrupt: Some(Interrupt(signalled)),
                ..EmOptions::default()
            };
            if let Some(k) = max_iter {
                opts.max_iter = k;
            }
            py.detach(|| em(&map, &data, &opts)).map_err(&err)?
        }
        "mle" => {
            let mut opts = MleOptions {
                interrupt: Some(Interrupt(signalled)),
                ..MleOptions::default()
            };
            if let Some(k) = max_iter {
                opts.max_iter = k as u64;
            }
            py.detach(|| {
                kalman::fit::check_identifiable(&map, &data)?;
                let theta0 = map.theta_of(map.base(), Some(&data));
                mle(&map, theta0, &data, &opts)
            })
            .map_err(&err)?
        }
        other => {
            return Err(value_error(format!(
                "method = {other:?}; expected \"em\" or \"mle\""
            )));
        }
    };
    let o = result_dict(py, &result, &map.names())?;
    let estimates = PyDict::new(py);
    for (name, v) in map.param_values(&result.theta).map_err(&err)? {
        estimates.set_item(name, v)?;
    }
    o.set_item("estimates", estimates)?;
    if spec.is_some() {
        o.set_item("std_errors", named_std_errors(py, &map, &result)?)?;
    }
    Ok(o)
}

/// The command line summary's `std_errors`: the matrices freed whole in their shapes, each
/// named parameter by its name; None when the information is singular.
fn named_std_errors<'py>(
    py: Python<'py>,
    map: &StandardMap,
    fit: &Fit,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    let Some(cov) = &fit.uncertainty.covariance else {
        return Ok(None);
    };
    let se = map
        .matrix_std_errors(&fit.theta, cov)
        .map_err(fit_err("fit: standard errors"))?;
    let o = PyDict::new(py);
    if let Some(q) = &se.q {
        o.set_item("Q", faer_out(py, q.as_ref()))?;
    }
    if let Some(r) = &se.r {
        o.set_item("R", faer_out(py, r.as_ref()))?;
    }
    if let Some(x) = &se.x0 {
        o.set_item("x0", PyArray1::from_slice(py, x))?;
    }
    if let Some(p) = &se.p0 {
        let n = p.len();
        let P = Mat::from_fn(n, n, |i, j| if i == j { p[i] } else { 0.0 });
        o.set_item("P0", faer_out(py, P.as_ref()))?;
    }
    for (name, v) in se.params {
        o.set_item(name, v)?;
    }
    Ok(Some(o))
}

/// The keys every fit returns.
fn result_dict<'py>(
    py: Python<'py>,
    result: &Fit,
    names: &[String],
) -> PyResult<Bound<'py, PyDict>> {
    let s = &result.system;
    let o = PyDict::new(py);
    o.set_item("F", faer_out(py, s.f.as_ref()))?;
    o.set_item("H", faer_out(py, s.h.as_ref()))?;
    o.set_item("Q", faer_out(py, s.q.as_ref()))?;
    o.set_item("R", faer_out(py, s.r.as_ref()))?;
    o.set_item("x0", PyArray1::from_slice(py, &s.x0))?;
    o.set_item("P0", faer_out(py, s.p0.as_ref()))?;
    o.set_item("loglik", result.loglik)?;
    o.set_item("iterations", result.iterations)?;
    o.set_item("converged", result.converged)?;
    o.set_item("message", result.message.replace('\n', " "))?;
    o.set_item("boundary", result.boundary.clone())?;
    o.set_item("theta", PyArray1::from_slice(py, &result.theta))?;
    o.set_item(
        "std_errors",
        result
            .uncertainty
            .std_errors
            .as_ref()
            .map(|v| PyArray1::from_slice(py, v)),
    )?;
    let correlation = match &result.uncertainty.correlation {
        Some(c) => {
            let d = PyDict::new(py);
            d.set_item("names", PyList::new(py, names)?)?;
            d.set_item("matrix", faer_out(py, c.as_ref()))?;
            Some(d)
        }
        None => None,
    };
    o.set_item("correlation", correlation)?;
    o.set_item("aic", result.aic)?;
    o.set_item("bic", result.bic)?;
    Ok(o)
}

/// fit_callable(model, theta0, zs, F=None, H=None, Q=None, R=None, x0=None, P0=None,
/// max_iter=None, log_variances=None) → the dict of fit (with "estimates" and
/// "correlation" under the names "θ[i]"). model(theta) — theta a 1-d float array —
/// returns a dict with some of "F", "H", "Q", "R", "x0", "P0"; the others are fixed at
/// the keyword arguments (x0 defaults to zeros). θ is fitted by maximum likelihood from
/// theta0 (L-BFGS, the gradient by central differences of ln L, Nelder–Mead fallback);
/// log_variances lists the indices of θ that are logarithms of variances (for the
/// "boundary" flag). An exception raised by model, a return that is not a dict, an
/// unknown key or a matrix of the wrong shape is raised as a ValueError or TypeError
/// naming it.
#[pyfunction]
#[pyo3(signature = (model, theta0, zs, F = None, H = None, Q = None, R = None, x0 = None, P0 = None, max_iter = None, log_variances = None))]
pub(crate) fn fit_callable<'py>(
    py: Python<'py>,
    model: &Bound<'py, PyAny>,
    theta0: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    F: Option<&Bound<'py, PyAny>>,
    H: Option<&Bound<'py, PyAny>>,
    Q: Option<&Bound<'py, PyAny>>,
    R: Option<&Bound<'py, PyAny>>,
    x0: Option<&Bound<'py, PyAny>>,
    P0: Option<&Bound<'py, PyAny>>,
    max_iter: Option<usize>,
    log_variances: Option<Vec<usize>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_fit_callable(
            py,
            [model, theta0, zs],
            [F, H, Q, R, x0, P0],
            max_iter,
            log_variances,
        )
    })
}

const KEYS: [&str; 6] = ["F", "H", "Q", "R", "x0", "P0"];

/// The fixed matrices and the shapes every call must return.
struct Callable<'a, 'py> {
    model: &'a Bound<'py, PyAny>,
    /// F, H, Q, R, P0 (index 4 unused: x0 is `x0`), as given or from model(theta0).
    fixed: [Option<Mat<f64>>; 6],
    x0: Option<Vec<f64>>,
    /// (n, m) once known.
    dims: Option<(usize, usize)>,
}

impl Callable<'_, '_> {
    fn shape(&self, key: &str) -> Option<(usize, usize)> {
        let (n, m) = self.dims?;
        Some(match key {
            "F" | "Q" | "P0" => (n, n),
            "H" => (m, n),
            "R" => (m, m),
            _ => (n, 1),
        })
    }

    /// The system of model(theta), the missing matrices from `fixed`.
    fn system(&self, theta: &[f64]) -> PyResult<System> {
        let py = self.model.py();
        let out = self
            .model
            .call1((PyArray1::from_slice(py, theta),))
            .map_err(|e| {
                let msg = format!("fit_callable: model(theta) raised {e}");
                let err = value_error(msg);
                err.set_cause(py, Some(e));
                err
            })?;
        let dict = out.cast::<PyDict>().map_err(|_| {
            type_error(format!(
                "fit_callable: model(theta) must return a dict with some of F, H, Q, R, x0, P0, not {}",
                type_name(&out)
            ))
        })?;
        let asarray = py.import("numpy")?.getattr("asarray")?;
        let mut mats: [Option<Mat<f64>>; 6] = self.fixed.clone();
        let mut x0 = self.x0.clone();
        for (k, v) in dict.iter() {
            let key: String = k.extract().map_err(|_| {
                type_error(format!(
                    "fit_callable: model(theta) returned a key {} that is not a str",
                    type_name(&k)
                ))
            })?;
            let Some(idx) = KEYS.iter().position(|&c| c == key) else {
                return Err(value_error(format!(
                    "fit_callable: model(theta) returned the unknown key {key:?}; expected some of F, H, Q, R, x0, P0"
                )));
            };
            let name = format!("model(theta)[{key:?}]");
            if key == "x0" {
                let len = self.dims.map_or_else(|| v.len().unwrap_or(0), |d| d.0);
                let mut buf = vec![0.0; len];
                read_vector(&v, &name, len, true, false, &mut buf)?;
                x0 = Some(buf);
            } else {
                // a nested list is taken as NumPy takes it
                let v = asarray.call1((&v,)).map_err(|e| {
                    type_error(format!(
                        "fit_callable: {name} is not an array of floats: {e}"
                    ))
                })?;
                let a = mat(&v, &name)?;
                if let Some((r, c)) = self.shape(&key)
                    && (a.nrows(), a.ncols()) != (r, c)
                {
                    return Err(value_error(format!(
                        "fit_callable: {name} has shape ({}, {}); expected ({r}, {c})",
                        a.nrows(),
                        a.ncols()
                    )));
                }
                mats[idx] = Some(a);
            }
        }
        let get = |i: usize| {
            mats[i].as_ref().ok_or_else(|| {
                value_error(format!(
                    "fit_callable: {} is neither returned by model(theta) nor given as a keyword argument",
                    KEYS[i]
                ))
            })
        };
        let (F, H, Q, R, P0) = (get(0)?, get(1)?, get(2)?, get(3)?, get(5)?);
        let x0 = x0.unwrap_or_else(|| vec![0.0; F.nrows()]);
        System::new(F, H, Q, R, &x0, P0).map_err(fit_err("fit_callable: model(theta)"))
    }
}

/// [`fit_callable`]'s work. The GIL is held throughout: every evaluation calls `model`.
#[allow(clippy::too_many_arguments)]
fn run_fit_callable<'py>(
    py: Python<'py>,
    [model, theta0, zs]: [&Bound<'py, PyAny>; 3],
    [F, H, Q, R, x0, P0]: [Option<&Bound<'py, PyAny>>; 6],
    max_iter: Option<usize>,
    log_variances: Option<Vec<usize>>,
) -> PyResult<Bound<'py, PyDict>> {
    if !model.is_callable() {
        return Err(type_error(format!(
            "fit_callable: model must be callable (theta → dict of matrices), not {}",
            type_name(model)
        )));
    }
    let len = theta0.len().map_err(|_| {
        type_error(format!(
            "fit_callable: theta0 must be a 1-d sequence of floats, not {}",
            type_name(theta0)
        ))
    })?;
    if len == 0 {
        return Err(value_error(
            "fit_callable: theta0 is empty; nothing is free",
        ));
    }
    let mut theta = vec![0.0; len];
    read_vector(theta0, "theta0", len, true, false, &mut theta)?;
    let mut fixed: [Option<Mat<f64>>; 6] = Default::default();
    for (i, arg) in [F, H, Q, R, None, P0].into_iter().enumerate() {
        if let Some(a) = arg {
            fixed[i] = Some(mat(a, KEYS[i])?);
        }
    }
    let mut c = Callable {
        model,
        fixed,
        x0: None,
        dims: None,
    };
    // The shapes are those of the system at theta0.
    let start = c.system(&theta)?;
    c.dims = Some((start.n(), start.h.nrows()));
    if let Some(x) = x0 {
        let mut v = vec![0.0; start.n()];
        read_vector(x, "x0", start.n(), true, false, &mut v)?;
        c.x0 = Some(v);
    }
    let m = start.h.nrows();
    let (_, z) = crate::series::read_series(zs, "zs", m, true)?;
    let err = fit_err("fit_callable");
    let data = Series::new(&z, m).map_err(&err)?;
    if let Some(bad) = log_variances.iter().flatten().find(|&&i| i >= len) {
        return Err(value_error(format!(
            "fit_callable: log_variances holds {bad}, but theta0 has {len} entries"
        )));
    }
    // The first Python error ends the fit and is raised as it is.
    let raised: RefCell<Option<PyErr>> = RefCell::new(None);
    let system = |t: &[f64]| {
        if raised.borrow().is_some() {
            return Err(FitError::Parameters("model(theta) raised".into()));
        }
        c.system(t).map_err(|e| {
            let msg = e.to_string();
            *raised.borrow_mut() = Some(e);
            FitError::Parameters(msg)
        })
    };
    let map = FnMap::new(len, system).with_log_variances(log_variances.unwrap_or_default());
    let mut opts = MleOptions {
        interrupt: Some(Interrupt(signalled)),
        ..MleOptions::default()
    };
    if let Some(k) = max_iter {
        opts.max_iter = k as u64;
    }
    let result = mle(&map, theta, &data, &opts);
    if let Some(e) = raised.borrow_mut().take() {
        return Err(e);
    }
    let result = result.map_err(&err)?;
    let names = map.names();
    let o = result_dict(py, &result, &names)?;
    let estimates = PyDict::new(py);
    for (name, v) in names.iter().zip(&result.theta) {
        estimates.set_item(name, v)?;
    }
    o.set_item("estimates", estimates)?;
    Ok(o)
}
