//! The unscented filter's attribute dict, read and written: x and P, R for an update, and
//! the results of a prediction or an update put back (all at once, after the call's work).
#![allow(non_snake_case)]

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::{scalar, zeros};
use crate::sigma::item;
use crate::ukf_core::{Ctx, arr1, arr2, read_mat, read_noise};

/// `numpy.<f>(*args)`.
pub(crate) fn np_call<'py>(
    py: Python<'py>,
    f: &str,
    args: impl pyo3::call::PyCallArgs<'py>,
) -> PyResult<Bound<'py, PyAny>> {
    crate::sigma::numpy(py)?.getattr(f)?.call1(args)
}

/// The filter's x (n) and P (n × n), read from the dict.
pub(crate) fn state(c: &Ctx<'_>) -> PyResult<(Vec<f64>, Vec<f64>)> {
    let mut x = zeros(c.n, "x")?;
    crate::convert::read_vector(
        &item(&c.d, pyo3::intern!(c.d.py(), "x"))?,
        "x",
        c.n,
        true,
        false,
        &mut x,
    )?;
    let P = read_mat(&item(&c.d, pyo3::intern!(c.d.py(), "P"))?, "P", c.n, c.n)?;
    Ok((x, P))
}

/// Writes a prediction into the dict.
pub(crate) fn write_predicted(c: &Ctx<'_>, p: &crate::ukf_core::Predicted) -> PyResult<()> {
    let (py, n) = (c.py, c.n);
    c.d.set_item(pyo3::intern!(c.d.py(), "x"), arr1(py, &p.x))?;
    c.d.set_item(pyo3::intern!(c.d.py(), "P"), arr2(py, p.P.clone(), n, n)?)?;
    c.d.set_item(
        pyo3::intern!(c.d.py(), "sigmas_f"),
        arr2(py, p.sigmas_f.clone(), c.N, n)?,
    )?;
    c.d.set_item(pyo3::intern!(c.d.py(), "x_prior"), arr1(py, &p.x))?;
    c.d.set_item(
        pyo3::intern!(c.d.py(), "P_prior"),
        arr2(py, p.P.clone(), n, n)?,
    )?;
    Ok(())
}

/// Writes an update into the dict (FilterPy's likelihoods then recomputed on demand).
pub(crate) fn write_updated(c: &Ctx<'_>, u: &crate::ukf_core::Updated) -> PyResult<()> {
    let (py, n, m) = (c.py, c.n, c.m);
    let d = &c.d;
    d.set_item(
        pyo3::intern!(d.py(), "sigmas_h"),
        arr2(py, u.sigmas_h.clone(), c.N, m)?,
    )?;
    d.set_item(pyo3::intern!(d.py(), "S"), arr2(py, u.S.clone(), m, m)?)?;
    d.set_item(pyo3::intern!(d.py(), "SI"), arr2(py, u.SI.clone(), m, m)?)?;
    d.set_item(pyo3::intern!(d.py(), "K"), arr2(py, u.K.clone(), n, m)?)?;
    d.set_item(pyo3::intern!(d.py(), "y"), arr1(py, &u.y))?;
    d.set_item(pyo3::intern!(d.py(), "x"), arr1(py, &u.x))?;
    d.set_item(pyo3::intern!(d.py(), "P"), arr2(py, u.P.clone(), n, n)?)?;
    d.set_item(pyo3::intern!(d.py(), "z"), arr1(py, &u.z))?;
    d.set_item(pyo3::intern!(d.py(), "x_post"), arr1(py, &u.x))?;
    d.set_item(
        pyo3::intern!(d.py(), "P_post"),
        arr2(py, u.P.clone(), n, n)?,
    )?;
    for k in ["_log_likelihood", "_likelihood", "_mahalanobis"] {
        d.set_item(k, py.None())?;
    }
    Ok(())
}

/// `update(None)`: no measurement; z becomes a column of None, the posterior the prior.
pub(crate) fn write_no_update(c: &Ctx<'_>) -> PyResult<()> {
    write_no_update_z(c.py, &c.d, c.m)?;
    for (to, from) in [("x_post", "x"), ("P_post", "P")] {
        c.d.set_item(to, item(&c.d, from)?.call_method0("copy")?)?;
    }
    Ok(())
}

/// R for an update: the argument (a scalar r meaning r·I) or the filter's R.
pub(crate) fn update_noise<'py>(
    c: &Ctx<'py>,
    R: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Vec<f64>, Bound<'py, PyAny>)> {
    let m = c.m;
    let obj = match R.filter(|r| !r.is_none()) {
        Some(r) if scalar(r).is_some() => {
            let eye = np_call(c.py, "eye", (m,))?;
            eye.call_method1("__mul__", (r,))?
        }
        Some(r) => r.clone(),
        None => item(&c.d, pyo3::intern!(c.d.py(), "R"))?,
    };
    Ok((read_noise(&obj, "R", m)?, obj))
}

/// The initial z: a (dim_z, 1) column of None, as FilterPy's.
pub(crate) fn write_no_update_z(py: Python<'_>, d: &Bound<'_, PyDict>, m: usize) -> PyResult<()> {
    let nones = PyList::new(py, (0..m).map(|_| py.None()).collect::<Vec<_>>())?;
    let z = np_call(py, "array", (PyList::new(py, [nones])?,))?.getattr("T")?;
    d.set_item(pyo3::intern!(d.py(), "z"), z)
}
