//! `kalman::fit` from Python: `fit` learns Q, R (and optionally x0 and a diagonal P0) of a
//! linear Gaussian model from data by EM or maximum likelihood, with standard errors and
//! information criteria; fit errors become `ValueError`s.
#![allow(non_snake_case)]

use kalman::fit::{EmOptions, Free, MleOptions, Series, StandardMap, Structure, System, em, mle};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{faer_out, mat, read_vector, value_error};

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

py_function! {
    /// fit(F, H, Q, R, x0, P0, zs, method="em", q="diag", r="diag", free_x0=False,
    /// free_p0_diag=False, max_iter=None) → dict with the fitted "F", "H", "Q", "R", "x0",
    /// "P0", "loglik", "iterations", "converged", "message", "boundary" (parameters on a
    /// variance boundary), "theta", "std_errors" (observed information; None when singular),
    /// "aic", "bic". Q and R are freed as "scalar" (σ²·I), "diag", "full" (Cholesky with a
    /// log-diagonal) or kept "fixed"; F, H are kept at the given values; the given Q, R, x0,
    /// P0 are the starting point. method "em" (Shumway–Stoffer) or "mle" (L-BFGS with the
    /// exact score, Nelder–Mead fallback). zs: (N, m), NaN for missing entries.
    fn fit(
        F, H, Q, R, x0, P0, zs;
        method: &str = "em", q: &str = "diag", r: &str = "diag", free_x0: bool = false,
        free_p0_diag: bool = false, max_iter: Option<usize> = None
    ) => run_fit
}

/// [`fit`]'s work.
fn run_fit<'py>(
    py: Python<'py>,
    [F, H, Q, R, x0, P0, zs]: [&Bound<'py, PyAny>; 7],
    method: &str,
    q: &str,
    r: &str,
    free_x0: bool,
    free_p0_diag: bool,
    max_iter: Option<usize>,
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
    let err = |e: kalman::fit::FitError| value_error(format!("fit: {e}"));
    let base = System::new(&F, &H, &Q, &R, &x0v, &P0).map_err(err)?;
    let free = Free {
        q: structure(q, "q")?,
        r: structure(r, "r")?,
        x0: free_x0,
        p0_diag: free_p0_diag,
    };
    let map = StandardMap::new(base, free).map_err(err)?;
    let (_, z) = crate::series::read_series(zs, "zs", m, true)?;
    let data = Series::new(&z, m).map_err(err)?;
    let result = match method {
        "em" => {
            let mut opts = EmOptions::default();
            if let Some(k) = max_iter {
                opts.max_iter = k;
            }
            em(&map, &data, &opts).map_err(err)?
        }
        "mle" => {
            let mut opts = MleOptions::default();
            if let Some(k) = max_iter {
                opts.max_iter = k as u64;
            }
            let theta0 = map.theta_of(map.base(), Some(&data));
            mle(&map, theta0, &data, &opts).map_err(err)?
        }
        other => {
            return Err(value_error(format!(
                "method = {other:?}; expected \"em\" or \"mle\""
            )));
        }
    };
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
            .std_errors
            .as_ref()
            .map(|v| PyArray1::from_slice(py, v)),
    )?;
    o.set_item("aic", result.aic)?;
    o.set_item("bic", result.bic)?;
    Ok(o)
}
