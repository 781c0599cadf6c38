//! The whole-series methods of `KalmanFilter` (`batch_filter`, `rts_smoother`): one call
//! into Rust that loops over the steps without returning to Python.
#![allow(non_snake_case)]

use numpy::{PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::convert::{
    array3_out, copy_finite, float_array, read_vector, shape_str, type_error, type_name,
    value_error,
};
use crate::kf_core::{Core, rts};

/// Reads a whole series of vectors (`zs`, `us`): an array (N, len), (N, len, 1), or (N,)
/// when len = 1, or a sequence whose items are vectors, scalars or None (missing).
pub(crate) fn read_series(
    obj: &Bound<'_, PyAny>,
    name: &str,
    len: usize,
    missing_ok: bool,
) -> PyResult<(usize, Vec<f64>)> {
    if let Ok(arr) = float_array(obj, name) {
        let ro = arr.readonly();
        let view = ro.as_array();
        let steps = match view.shape() {
            [s] if len == 1 => *s,
            [s, l] if *l == len => *s,
            [s, l, 1] if *l == len => *s,
            s => {
                return Err(value_error(format!(
                    "{name} has shape {}, expected (N, {len}){}",
                    shape_str(s),
                    if len == 1 { " or (N,)" } else { "" }
                )));
            }
        };
        let out: Vec<f64> = view.iter().copied().collect();
        for &v in &out {
            if v.is_infinite() || (v.is_nan() && !missing_ok) {
                return Err(value_error(format!(
                    "{name} has a non-finite entry ({v}){}",
                    if missing_ok {
                        "; NaN marks a missing entry, infinities are refused"
                    } else {
                        ""
                    }
                )));
            }
        }
        return Ok((steps, out));
    }
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(type_error(format!(
            "{name} must be a sequence or a numpy.ndarray, not str"
        )));
    }
    let items = obj.try_iter().map_err(|_| {
        type_error(format!(
            "{name} must be a sequence or a numpy.ndarray, not {}",
            type_name(obj)
        ))
    })?;
    let mut out = Vec::new();
    let mut steps = 0;
    for item in items {
        let item = item?;
        let mut buf = vec![f64::NAN; len];
        if !(item.is_none() && missing_ok) {
            read_vector(
                &item,
                &format!("{name}[{steps}]"),
                len,
                true,
                missing_ok,
                &mut buf,
            )?;
        }
        out.extend_from_slice(&buf);
        steps += 1;
    }
    Ok((steps, out))
}

/// `KalmanFilter.batch_filter` with the filter's own F, Q, H, R, B.
pub(crate) fn batch_filter<'py>(
    core: &mut Core,
    x_col: bool,
    py: Python<'py>,
    zs: &Bound<'py, PyAny>,
    us: Option<&Bound<'py, PyAny>>,
    update_first: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    let (n, m) = (core.n, core.m);
    let (steps, z) = read_series(zs, "zs", m, true)?;
    let p = if core.B.is_some() { core.p } else { 0 };
    let u = match us {
        Some(us) if !us.is_none() && p > 0 => {
            let (k, u) = read_series(us, "us", p, false)?;
            if k != steps {
                return Err(value_error(format!("us has {k} steps but zs has {steps}")));
            }
            Some(u)
        }
        _ => None,
    };
    let mut means = vec![0.0; steps * n];
    let mut covs = vec![0.0; steps * n * n];
    let mut means_p = vec![0.0; steps * n];
    let mut covs_p = vec![0.0; steps * n * n];
    let nn = n * n;
    for k in 0..steps {
        let zk = &z[k * m..(k + 1) * m];
        let uk = u.as_ref().map(|u| &u[k * p..(k + 1) * p]);
        let upd = |core: &mut Core| {
            core.update(zk, None, None, false).map_err(|_| {
                value_error(format!(
                    "batch_filter: S (the innovation covariance H P Hᵀ + R) is \
                     singular at step {k}"
                ))
            })
        };
        if update_first {
            upd(core)?;
            means[k * n..(k + 1) * n].copy_from_slice(&core.x);
            covs[k * nn..(k + 1) * nn].copy_from_slice(&core.P);
            core.predict(uk, None, None, None);
            means_p[k * n..(k + 1) * n].copy_from_slice(&core.x);
            covs_p[k * nn..(k + 1) * nn].copy_from_slice(&core.P);
        } else {
            core.predict(uk, None, None, None);
            means_p[k * n..(k + 1) * n].copy_from_slice(&core.x);
            covs_p[k * nn..(k + 1) * nn].copy_from_slice(&core.P);
            upd(core)?;
            means[k * n..(k + 1) * n].copy_from_slice(&core.x);
            covs[k * nn..(k + 1) * nn].copy_from_slice(&core.P);
        }
    }

    let mean_out = |v: Vec<f64>| -> Bound<'py, PyAny> {
        if x_col {
            array3_out(py, v, steps, n, 1).into_any()
        } else {
            let arr = numpy::ndarray::Array2::from_shape_vec((steps, n), v)
                .unwrap_or_else(|_| numpy::ndarray::Array2::zeros((steps, n)));
            numpy::PyArray2::from_owned_array(py, arr).into_any()
        }
    };
    PyTuple::new(
        py,
        [
            mean_out(means),
            array3_out(py, covs, steps, n, n).into_any(),
            mean_out(means_p),
            array3_out(py, covs_p, steps, n, n).into_any(),
        ],
    )
}

/// `KalmanFilter.rts_smoother` with the filter's own F and Q.
pub(crate) fn rts_smoother<'py>(
    core: &Core,
    py: Python<'py>,
    Xs: &Bound<'py, PyAny>,
    Ps: &Bound<'py, PyAny>,
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
    let mut xs = vec![0.0; steps * n];
    copy_finite(&xa.readonly().as_array(), "Xs", &mut xs)?;
    let mut ps = vec![0.0; steps * n * n];
    copy_finite(&pa.readonly().as_array(), "Ps", &mut ps)?;
    let (x, P, K, Pp) = rts(&xs, &ps, steps, n, &core.F, &core.Q).map_err(|k| {
        value_error(format!(
            "rts_smoother: the predicted covariance F Ps[{k}] Fᵀ + Q is singular"
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
