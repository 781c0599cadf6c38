//! The engine's own functions, Pythonic: `filter` and `smooth` run a whole series through
//! `kalman::Filter` (the engine's step: update with z_k, then predict with u_k; exact
//! cross-covariance S; singular R; NaN entries skipped) in one call, and `dare`, `dlqr`,
//! `care` solve the Riccati equations. Engine errors become `ValueError`s carrying the
//! engine's message, which names the matrix and the rule.
#![allow(non_snake_case)]

use kalman::faer::Mat;
use kalman::{CovarianceForm, DynDims, Filter, Model, riccati, smoother::RtsSmoother};
use numpy::PyArray2;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{FilterRecord, array3_out, faer_out, mat, value_error};
use crate::guard;

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

/// The validated model and filter of `filter`/`smooth`.
fn build(
    args: &ModelArgs<'_, '_>,
    form: CovarianceForm,
    context: &str,
) -> PyResult<(Filter<DynDims>, usize, usize, usize)> {
    let F = mat(args.F, "F")?;
    let H = mat(args.H, "H")?;
    let Q = mat(args.Q, "Q")?;
    let R = mat(args.R, "R")?;
    let B = opt_mat(args.B, "B")?;
    let S = opt_mat(args.S, "S")?;
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
    let x0 = vector(args.x0, "x0", n)?;
    let P0 = mat(args.P0, "P0")?;
    let filter = Filter::new(model, &x0, &P0, form).map_err(&err)?;
    Ok((filter, n, m, p))
}

/// The model arguments shared by `filter` and `smooth`.
struct ModelArgs<'a, 'py> {
    F: &'a Bound<'py, PyAny>,
    H: &'a Bound<'py, PyAny>,
    Q: &'a Bound<'py, PyAny>,
    R: &'a Bound<'py, PyAny>,
    x0: &'a Bound<'py, PyAny>,
    P0: &'a Bound<'py, PyAny>,
    B: Option<&'a Bound<'py, PyAny>>,
    S: Option<&'a Bound<'py, PyAny>>,
}

/// Reads `zs` (N, m) and `us` (N, p) for a model with m measurements and p inputs.
fn series(
    zs: &Bound<'_, PyAny>,
    us: Option<&Bound<'_, PyAny>>,
    m: usize,
    p: usize,
) -> PyResult<(usize, Vec<f64>, Option<Vec<f64>>)> {
    let (steps, z) = crate::batch::read_series(zs, "zs", m, true)?;
    let u = match us {
        Some(us) if !us.is_none() => {
            if p == 0 {
                return Err(value_error(
                    "us is given but there is no B (no control input)",
                ));
            }
            let (k, u) = crate::batch::read_series(us, "us", p, false)?;
            if k != steps {
                return Err(value_error(format!("us has {k} steps but zs has {steps}")));
            }
            Some(u)
        }
        _ => None,
    };
    Ok((steps, z, u))
}

/// filter(F, H, Q, R, x0, P0, zs, us=None, B=None, S=None, form="joseph") → dict with
/// "x", "P" (filtered, x_{k|k}), "x_pred", "P_pred" (x_{k+1|k}), "log_likelihood", "nis"
/// (NaN on a step with no measurement). (x0, P0) is the prior of the first measurement;
/// step k updates with zs[k] and predicts with us[k]. S = E[w_k v_kᵀ] enters the prediction.
#[pyfunction]
#[pyo3(signature = (F, H, Q, R, x0, P0, zs, us = None, B = None, S = None, form = "joseph"))]
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
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
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
        let args = ModelArgs {
            F,
            H,
            Q,
            R,
            x0,
            P0,
            B,
            S,
        };
        let (mut f, n, m, p) = build(&args, form, "filter")?;
        let (steps, z, u) = series(zs, us, m, p)?;
        let mut rec = FilterRecord::new(steps, n);
        for k in 0..steps {
            let uk = u.as_ref().map(|u| &u[k * p..(k + 1) * p]);
            let info = f
                .step(&z[k * m..(k + 1) * m], uk)
                .map_err(engine("filter"))?;
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
    })
}

/// smooth(F, H, Q, R, x0, P0, zs, us=None, B=None, S=None) → dict with the RTS-smoothed
/// "x" (N, n) and "P" (N, n, n): the engine's filter (Joseph form) recorded step by step,
/// then `kalman::smoother::RtsSmoother`.
#[pyfunction]
#[pyo3(signature = (F, H, Q, R, x0, P0, zs, us = None, B = None, S = None))]
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
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let args = ModelArgs {
            F,
            H,
            Q,
            R,
            x0,
            P0,
            B,
            S,
        };
        let (mut f, n, m, p) = build(&args, CovarianceForm::Joseph, "smooth")?;
        let (steps, z, u) = series(zs, us, m, p)?;
        let mut rts = RtsSmoother::new();
        for k in 0..steps {
            let uk = u.as_ref().map(|u| &u[k * p..(k + 1) * p]);
            f.step(&z[k * m..(k + 1) * m], uk)
                .map_err(engine("smooth"))?;
            rts.record(&f).map_err(engine("smooth"))?;
        }
        let sm = rts.smooth().map_err(engine("smooth"))?;
        let nn = n * n;
        let mut ps = vec![0.0; steps * nn];
        for (k, c) in sm.covariances.iter().enumerate() {
            for i in 0..n {
                for j in 0..n {
                    ps[k * nn + i * n + j] = c[(i, j)];
                }
            }
        }
        let xs = Array2::from_shape_fn((steps, n), |(k, i)| sm.means[(i, k)]);
        let out = PyDict::new(py);
        out.set_item("x", PyArray2::from_owned_array(py, xs))?;
        out.set_item("P", array3_out(py, ps, steps, n, n))?;
        Ok(out)
    })
}

/// dare(F, H, Q, R, S=None) → dict with the steady-state prior covariance "P", the
/// posterior "P_post", the filter gain "K", the predictor gain "K_pred" and the innovation
/// covariance "innovation_cov" (the filter's DARE; structured doubling with a Newton polish).
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
    guard(|| {
        let (F, H, Q, R) = (mat(F, "F")?, mat(H, "H")?, mat(Q, "Q")?, mat(R, "R")?);
        let S = opt_mat(S, "S")?;
        let ss = riccati::dare(
            F.as_ref(),
            H.as_ref(),
            Q.as_ref(),
            R.as_ref(),
            S.as_ref().map(|s| s as &dyn kalman::MatrixInput),
        )
        .map_err(engine("dare"))?;
        let out = PyDict::new(py);
        out.set_item("P", faer_out(py, ss.prior.as_ref()))?;
        out.set_item("P_post", faer_out(py, ss.posterior.as_ref()))?;
        out.set_item("K", faer_out(py, ss.gain.as_ref()))?;
        out.set_item("K_pred", faer_out(py, ss.predictor_gain.as_ref()))?;
        out.set_item("innovation_cov", faer_out(py, ss.innovation_cov.as_ref()))?;
        Ok(out)
    })
}

/// dlqr(A, B, Q, R, N=None) → dict with the gain "K" (u = −K x) and the cost matrix "P" of
/// the discrete LQR (the dual DARE).
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
    guard(|| {
        let (A, B, Q, R) = (mat(A, "A")?, mat(B, "B")?, mat(Q, "Q")?, mat(R, "R")?);
        let N = opt_mat(N, "N")?;
        let lqr = riccati::dlqr(
            A.as_ref(),
            B.as_ref(),
            Q.as_ref(),
            R.as_ref(),
            N.as_ref().map(|s| s as &dyn kalman::MatrixInput),
        )
        .map_err(engine("dlqr"))?;
        let out = PyDict::new(py);
        out.set_item("K", faer_out(py, lqr.gain.as_ref()))?;
        out.set_item("P", faer_out(py, lqr.cost.as_ref()))?;
        Ok(out)
    })
}

/// care(A, H, Q, R) → dict with the steady-state covariance "P" and gain "K" of the
/// Kalman–Bucy filter (A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0).
#[pyfunction]
pub(crate) fn care<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    H: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let (A, H, Q, R) = (mat(A, "A")?, mat(H, "H")?, mat(Q, "Q")?, mat(R, "R")?);
        let ss = riccati::care(A.as_ref(), H.as_ref(), Q.as_ref(), R.as_ref())
            .map_err(engine("care"))?;
        let out = PyDict::new(py);
        out.set_item("P", faer_out(py, ss.covariance.as_ref()))?;
        out.set_item("K", faer_out(py, ss.gain.as_ref()))?;
        Ok(out)
    })
}
