//! The `wls` crate's solver from Python: `wls` returns the estimate with its diagnostics
//! (covariance, residuals, singular values, condition numbers, rank), with the crate's
//! errors as `ValueError`s.
#![allow(non_snake_case)]

use ::wls::nalgebra::{DMatrix, DVector};
use ::wls::solver::{SolveMethod, SolveOptions, Tikhonov, Weights, solve};
use numpy::ndarray::{Array1, Array2};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{copy_finite, float_array, shape_str, value_error};
use crate::guard;

/// A float array argument of 1 or 2 dimensions as (rows, cols, row-major data).
fn array(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let arr = float_array(obj, name)?;
    let ro = arr.readonly();
    let view = ro.as_array();
    if !matches!(view.ndim(), 1 | 2) {
        return Err(value_error(format!(
            "{name} has shape {}, expected a 1-d or 2-d array",
            shape_str(view.shape())
        )));
    }
    let mut buf = vec![0.0; view.len()];
    copy_finite(&view, name, &mut buf)?;
    Ok((view.shape().to_vec(), buf))
}

fn matrix(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<DMatrix<f64>> {
    match array(obj, name)? {
        (s, v) if s.len() == 2 => Ok(DMatrix::from_row_slice(s[0], s[1], &v)),
        (s, _) => Err(value_error(format!(
            "{name} has shape {}, expected a 2-d array",
            shape_str(&s)
        ))),
    }
}

fn vector(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<DVector<f64>> {
    let arr = float_array(obj, name)?;
    if arr.ndim() != 1 {
        return Err(value_error(format!(
            "{name} has shape {}, expected a 1-d array",
            shape_str(arr.shape())
        )));
    }
    Ok(DVector::from_vec(array(obj, name)?.1))
}

/// wls(H, z, weights=None, method="qr", scale_covariance=False, rank_tolerance=None,
/// tikhonov=None, prior_mean=None, operator=None) → dict: min ‖V^{1/2}(H x − z)‖²
/// (+ λ‖L(x − x_p)‖²) by QR of the whitened problem (or "normal_equations"). weights V:
/// None (identity), a 1-d array (diagonal) or a 2-d SPD matrix. Returns "x", "covariance",
/// "residuals", "weighted_sum_of_squares", "residual_variance" (None without degrees of
/// freedom), "singular_values", "condition_weighted", "condition_normal",
/// "condition_solved", "rank", "rank_tolerance".
#[pyfunction]
#[pyo3(signature = (H, z, weights = None, method = "qr", scale_covariance = false, rank_tolerance = None, tikhonov = None, prior_mean = None, operator = None))]
pub(crate) fn wls<'py>(
    py: Python<'py>,
    H: &Bound<'py, PyAny>,
    z: &Bound<'py, PyAny>,
    weights: Option<&Bound<'py, PyAny>>,
    method: &str,
    scale_covariance: bool,
    rank_tolerance: Option<f64>,
    tikhonov: Option<f64>,
    prior_mean: Option<&Bound<'py, PyAny>>,
    operator: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let method = match method {
            "qr" => SolveMethod::Qr,
            "normal_equations" => SolveMethod::NormalEquations,
            other => {
                return Err(value_error(format!(
                    "method = {other:?}; expected \"qr\" or \"normal_equations\""
                )));
            }
        };
        let H = matrix(H, "H")?;
        let z = vector(z, "z")?;
        let weights = match weights {
            Some(w) if !w.is_none() => match array(w, "weights")? {
                (s, v) if s.len() == 1 => Weights::Diagonal(DVector::from_vec(v)),
                (s, v) => Weights::Full(DMatrix::from_row_slice(s[0], s[1], &v)),
            },
            _ => Weights::Identity,
        };
        let tikhonov = match tikhonov {
            Some(lambda) => Some(Tikhonov {
                lambda,
                prior_mean: match prior_mean {
                    Some(p) if !p.is_none() => Some(vector(p, "prior_mean")?),
                    _ => None,
                },
                operator: match operator {
                    Some(o) if !o.is_none() => Some(matrix(o, "operator")?),
                    _ => None,
                },
            }),
            None => {
                if prior_mean.is_some_and(|p| !p.is_none())
                    || operator.is_some_and(|o| !o.is_none())
                {
                    return Err(value_error(
                        "prior_mean and operator need tikhonov (the weight λ)",
                    ));
                }
                None
            }
        };
        let options = SolveOptions {
            method,
            scale_covariance,
            rank_tolerance,
            tikhonov,
            prior: None,
        };
        let sol =
            solve(&H, &z, &weights, &options).map_err(|e| value_error(format!("wls: {e}")))?;
        let o = PyDict::new(py);
        let v = |x: &DVector<f64>| {
            PyArray1::from_owned_array(py, Array1::from_vec(x.as_slice().to_vec()))
        };
        let c = &sol.covariance;
        o.set_item("x", v(&sol.x))?;
        o.set_item(
            "covariance",
            PyArray2::from_owned_array(
                py,
                Array2::from_shape_fn((c.nrows(), c.ncols()), |(i, j)| c[(i, j)]),
            ),
        )?;
        o.set_item("residuals", v(&sol.residuals))?;
        o.set_item("weighted_sum_of_squares", sol.weighted_sum_of_squares)?;
        o.set_item("residual_variance", sol.residual_variance)?;
        o.set_item("singular_values", v(&sol.singular_values))?;
        o.set_item("condition_weighted", sol.condition_weighted)?;
        o.set_item("condition_normal", sol.condition_normal)?;
        o.set_item("condition_solved", sol.condition_solved)?;
        o.set_item("rank", sol.rank)?;
        o.set_item("rank_tolerance", sol.rank_tolerance)?;
        Ok(o)
    })
}
