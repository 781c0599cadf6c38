//! `launch_estimation.UnscentedKalmanFilter`: FilterPy 2.0.0's `UnscentedKalmanFilter` with
//! its constructor, attributes and methods. The attributes live in an ordinary instance
//! `__dict__` (x, P, Q, R, K, y, S, SI, z, x_prior, P_prior, x_post, P_post, sigmas_f,
//! sigmas_h, Wm, Wc, points_fn, fx, hx, x_mean, z_mean, residual_x, residual_z, state_add,
//! msqrt, …), as FilterPy's do, so assigning, editing in place, copying, pickling and
//! FilterPy's `Saver` behave as with FilterPy; each method reads them, runs the filter's
//! arithmetic and loops in Rust (`ukf_core.rs`) and writes the results back only when the
//! whole call succeeded. `vectorized=True` calls fx, hx and the residual functions once
//! with all sigma points (rows of a 2-D array) instead of once per point.
#![allow(non_snake_case)]

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString, PyTuple};

use crate::convert::{ensure_callable, memory_error, value_error, zeros};
use crate::guard;
use crate::linalg::Factor;
use crate::sigma::{dict_of, item, item_or};
use crate::ukf_core::{Ctx, arr2, read_mat, read_noise, read_z};
use crate::ukf_state::{
    np_call, state, update_noise, write_no_update, write_no_update_z, write_predicted,
    write_updated,
};

/// FilterPy's `UnscentedKalmanFilter(dim_x, dim_z, dt, hx, fx, points, sqrt_fn=None,
/// x_mean_fn=None, z_mean_fn=None, residual_x=None, residual_z=None, state_add=None)`, plus
/// `vectorized=False`.
#[pyclass(module = "launch_estimation", dict, subclass)]
#[derive(Debug)]
pub struct UnscentedKalmanFilter {}

/// The positive dimension `name`.
fn dim(v: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    match v.extract::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(value_error(format!(
            "{name} must be a positive integer, not {}",
            v.repr().map(|r| r.to_string()).unwrap_or_default()
        ))),
    }
}

/// The keyword arguments for fx/hx (None when there are none).
fn kw<'a, 'py>(k: Option<&'a Bound<'py, PyDict>>) -> Option<&'a Bound<'py, PyDict>> {
    k.filter(|d| !d.is_empty())
}

/// Runs `f`; if it fails, puts the dict back as it was before (a snapshot taken first).
fn atomically<'py, T>(d: &Bound<'py, PyDict>, f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    let snapshot = d.copy()?;
    f().inspect_err(|_| {
        d.clear();
        let _ = d.update(snapshot.as_mapping());
    })
}

/// The number kept in the dict under `key`, or else `compute()`'s, then kept there (FilterPy
/// computes the likelihoods and the Mahalanobis distance on first use; an update clears them).
fn kept<'py>(
    d: &Bound<'py, PyDict>,
    key: &Bound<'py, PyString>,
    compute: impl FnOnce() -> PyResult<f64>,
) -> PyResult<f64> {
    if let Some(v) = d.get_item(key)?.filter(|v| !v.is_none()) {
        return v.extract();
    }
    let v = compute()?;
    d.set_item(key, v)?;
    Ok(v)
}

/// m, the innovation y and the m×m matrix `name` (S or SI) the last update left in the dict.
fn last_update(d: &Bound<'_, PyDict>, name: &str) -> PyResult<(usize, Vec<f64>, Vec<f64>)> {
    let m: usize = item(d, pyo3::intern!(d.py(), "_dim_z"))?.extract()?;
    let mut y = zeros(m, "y")?;
    crate::convert::read_vector(
        &item(d, pyo3::intern!(d.py(), "y"))?,
        "y",
        m,
        true,
        false,
        &mut y,
    )?;
    let matrix = read_mat(&item(d, name)?, name, m, m)?;
    Ok((m, y, matrix))
}

#[pymethods]
impl UnscentedKalmanFilter {
    /// The object; `__init__` fills its dict.
    #[new]
    #[pyo3(signature = (*_args, **_kwargs))]
    fn new(_args: &Bound<'_, PyTuple>, _kwargs: Option<&Bound<'_, PyDict>>) -> Self {
        Self {}
    }

    /// FilterPy's defaults: x = 0 (a (dim_x,) array), P = Q = I, R = I, the weights of
    /// `points`; `vectorized` makes fx, hx and the residual functions take all sigma points
    /// at once.
    #[pyo3(signature = (
        dim_x, dim_z, dt, hx, fx, points, sqrt_fn = None, x_mean_fn = None, z_mean_fn = None,
        residual_x = None, residual_z = None, state_add = None, vectorized = false
    ))]
    #[allow(clippy::too_many_arguments)]
    fn __init__(
        slf: &Bound<'_, Self>,
        dim_x: &Bound<'_, PyAny>,
        dim_z: &Bound<'_, PyAny>,
        dt: &Bound<'_, PyAny>,
        hx: &Bound<'_, PyAny>,
        fx: &Bound<'_, PyAny>,
        points: &Bound<'_, PyAny>,
        sqrt_fn: Option<&Bound<'_, PyAny>>,
        x_mean_fn: Option<&Bound<'_, PyAny>>,
        z_mean_fn: Option<&Bound<'_, PyAny>>,
        residual_x: Option<&Bound<'_, PyAny>>,
        residual_z: Option<&Bound<'_, PyAny>>,
        state_add: Option<&Bound<'_, PyAny>>,
        vectorized: bool,
    ) -> PyResult<()> {
        guard(|| {
            let py = slf.py();
            let d = dict_of(slf.as_any())?;
            let (n, m) = (dim(dim_x, "dim_x")?, dim(dim_z, "dim_z")?);
            for (name, f) in [("hx", hx), ("fx", fx)] {
                ensure_callable(f, name)?;
            }
            let N: usize = points.call_method0("num_sigmas")?.extract()?;
            let none = py.None().into_bound(py);
            let or = |v: Option<&Bound<'_, PyAny>>, np_default: &str| -> PyResult<Py<PyAny>> {
                match v.filter(|v| !v.is_none()) {
                    Some(v) => Ok(v.clone().unbind()),
                    None if np_default.is_empty() => Ok(py.None()),
                    None => Ok(crate::sigma::np_attr(py, np_default)?.unbind()),
                }
            };
            let zeros_of = |shape: (usize, usize)| np_call(py, "zeros", (shape,));
            d.set_item(pyo3::intern!(d.py(), "x"), np_call(py, "zeros", (n,))?)?;
            d.set_item(pyo3::intern!(d.py(), "P"), np_call(py, "eye", (n,))?)?;
            d.set_item(
                pyo3::intern!(d.py(), "x_prior"),
                np_call(py, "zeros", (n,))?,
            )?;
            d.set_item(pyo3::intern!(d.py(), "P_prior"), np_call(py, "eye", (n,))?)?;
            d.set_item(pyo3::intern!(d.py(), "Q"), np_call(py, "eye", (n,))?)?;
            d.set_item(pyo3::intern!(d.py(), "R"), np_call(py, "eye", (m,))?)?;
            d.set_item(pyo3::intern!(d.py(), "_dim_x"), n)?;
            d.set_item(pyo3::intern!(d.py(), "_dim_z"), m)?;
            d.set_item(pyo3::intern!(d.py(), "points_fn"), points)?;
            d.set_item(pyo3::intern!(d.py(), "_dt"), dt)?;
            d.set_item(pyo3::intern!(d.py(), "_num_sigmas"), N)?;
            d.set_item(pyo3::intern!(d.py(), "hx"), hx)?;
            d.set_item(pyo3::intern!(d.py(), "fx"), fx)?;
            d.set_item(pyo3::intern!(d.py(), "x_mean"), or(x_mean_fn, "")?)?;
            d.set_item(pyo3::intern!(d.py(), "z_mean"), or(z_mean_fn, "")?)?;
            d.set_item(
                pyo3::intern!(d.py(), "_log_likelihood"),
                f64::MIN_POSITIVE.ln(),
            )?;
            d.set_item(pyo3::intern!(d.py(), "_likelihood"), f64::MIN_POSITIVE)?;
            d.set_item(pyo3::intern!(d.py(), "_mahalanobis"), &none)?;
            d.set_item(pyo3::intern!(d.py(), "msqrt"), or(sqrt_fn, "")?)?;
            d.set_item(pyo3::intern!(d.py(), "Wm"), points.getattr("Wm")?)?;
            d.set_item(pyo3::intern!(d.py(), "Wc"), points.getattr("Wc")?)?;
            d.set_item(
                pyo3::intern!(d.py(), "residual_x"),
                or(residual_x, "subtract")?,
            )?;
            d.set_item(
                pyo3::intern!(d.py(), "residual_z"),
                or(residual_z, "subtract")?,
            )?;
            d.set_item(pyo3::intern!(d.py(), "state_add"), or(state_add, "add")?)?;
            d.set_item(pyo3::intern!(d.py(), "sigmas_f"), zeros_of((N, n))?)?;
            d.set_item(pyo3::intern!(d.py(), "sigmas_h"), zeros_of((N, m))?)?;
            d.set_item(pyo3::intern!(d.py(), "K"), zeros_of((n, m))?)?;
            d.set_item(pyo3::intern!(d.py(), "y"), np_call(py, "zeros", (m,))?)?;
            write_no_update_z(py, &d, m)?;
            d.set_item(pyo3::intern!(d.py(), "S"), zeros_of((m, m))?)?;
            d.set_item(pyo3::intern!(d.py(), "SI"), zeros_of((m, m))?)?;
            d.set_item(pyo3::intern!(d.py(), "x_post"), np_call(py, "zeros", (n,))?)?;
            d.set_item(pyo3::intern!(d.py(), "P_post"), np_call(py, "eye", (n,))?)?;
            d.set_item(pyo3::intern!(d.py(), "vectorized"), vectorized)?;
            Ok(())
        })
    }

    /// predict(dt=None, UT=None, fx=None, **fx_args): sigma points at (x, P), fx(χ, dt,
    /// **fx_args) for each, their unscented transform with Q; sigmas_f then holds the points
    /// redrawn at the prior (FilterPy 2.0.0), x_prior and P_prior the prior.
    #[pyo3(signature = (dt = None, UT = None, fx = None, **fx_args))]
    fn predict<'py>(
        slf: &Bound<'py, Self>,
        dt: Option<&Bound<'py, PyAny>>,
        UT: Option<&Bound<'py, PyAny>>,
        fx: Option<&Bound<'py, PyAny>>,
        fx_args: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<()> {
        guard(|| {
            let c = Ctx::new(slf.as_any(), UT)?;
            let (x, P) = state(&c)?;
            let Qo = item(&c.d, pyo3::intern!(c.d.py(), "Q"))?;
            let Q = read_noise(&Qo, "Q", c.n)?;
            let dt = item_or(dt, &c.d, pyo3::intern!(c.d.py(), "_dt"))?;
            let fx = item_or(fx, &c.d, pyo3::intern!(c.d.py(), "fx"))?;
            let p = crate::ukf_core::predict(&c, &x, &P, (&Q, &Qo), &fx, &dt, kw(fx_args))?;
            write_predicted(&c, &p)
        })
    }

    /// update(z, R=None, UT=None, hx=None, **hx_args): hx(χ, **hx_args) for each point of
    /// sigmas_f, their transform with R (a scalar r: r·I), the cross-covariance, K = P_xz S⁻¹
    /// (solved), y = residual_z(z, ẑ), x = state_add(x, K y), P = P − K S Kᵀ. z = None
    /// skips the update (x_post, P_post = x, P).
    #[pyo3(signature = (z, R = None, UT = None, hx = None, **hx_args))]
    fn update<'py>(
        slf: &Bound<'py, Self>,
        z: &Bound<'py, PyAny>,
        R: Option<&Bound<'py, PyAny>>,
        UT: Option<&Bound<'py, PyAny>>,
        hx: Option<&Bound<'py, PyAny>>,
        hx_args: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<()> {
        guard(|| {
            let c = Ctx::new(slf.as_any(), UT)?;
            if z.is_none() {
                return write_no_update(&c);
            }
            let (x, P) = state(&c)?;
            let sf = read_mat(
                &item(&c.d, pyo3::intern!(c.d.py(), "sigmas_f"))?,
                "sigmas_f",
                c.N,
                c.n,
            )?;
            let (Rv, Ro) = update_noise(&c, R)?;
            let hx = item_or(hx, &c.d, pyo3::intern!(c.d.py(), "hx"))?;
            let zv = read_z(z, c.m)?;
            let u = crate::ukf_core::update(&c, &x, &P, &sf, zv, (&Rv, &Ro), &hx, kw(hx_args))?;
            write_updated(&c, &u)
        })
    }

    /// compute_process_sigmas(dt, fx=None, **fx_args): sigmas_f = fx(χ, dt) at the points
    /// of (x, P).
    #[pyo3(signature = (dt, fx = None, **fx_args))]
    fn compute_process_sigmas<'py>(
        slf: &Bound<'py, Self>,
        dt: &Bound<'py, PyAny>,
        fx: Option<&Bound<'py, PyAny>>,
        fx_args: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<()> {
        guard(|| {
            let c = Ctx::new(slf.as_any(), None)?;
            let (x, P) = state(&c)?;
            let fx = item_or(fx, &c.d, pyo3::intern!(c.d.py(), "fx"))?;
            let sig = c.sigmas(&x, &P)?;
            let sf = c.apply(
                &fx,
                "fx",
                &sig,
                c.n,
                c.n,
                std::slice::from_ref(dt),
                kw(fx_args),
            )?;
            c.d.set_item(
                pyo3::intern!(c.d.py(), "sigmas_f"),
                arr2(c.py, sf, c.N, c.n)?,
            )
        })
    }

    /// cross_variance(x, z, sigmas_f, sigmas_h) → P_xz = Σ Wc_i residual_x(χ_i, x)
    /// residual_z(h_i, z)ᵀ, (dim_x, dim_z).
    fn cross_variance<'py>(
        slf: &Bound<'py, Self>,
        x: &Bound<'py, PyAny>,
        z: &Bound<'py, PyAny>,
        sigmas_f: &Bound<'py, PyAny>,
        sigmas_h: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            let c = Ctx::new(slf.as_any(), None)?;
            let mut xv = zeros(c.n, "x")?;
            crate::convert::read_vector(x, "x", c.n, true, false, &mut xv)?;
            let zv = read_z(z, c.m)?;
            let sf = read_mat(sigmas_f, "sigmas_f", c.N, c.n)?;
            let sh = read_mat(sigmas_h, "sigmas_h", c.N, c.m)?;
            arr2(c.py, c.cross(&xv, &zv, &sf, &sh)?, c.n, c.m)
        })
    }

    /// batch_filter(zs, Rs=None, dts=None, UT=None, saver=None) → (means, covariances):
    /// predict then update for each z (None: no update), Rs[i] and dts[i] per step; the
    /// loop runs in Rust and writes the filter's attributes once at the end (every step when
    /// a saver is given, which is then saved). Interrupted or failed, the filter is left as
    /// it was before the call.
    #[pyo3(signature = (zs, Rs = None, dts = None, UT = None, saver = None))]
    fn batch_filter<'py>(
        slf: &Bound<'py, Self>,
        zs: &Bound<'py, PyAny>,
        Rs: Option<&Bound<'py, PyAny>>,
        dts: Option<&Bound<'py, PyAny>>,
        UT: Option<&Bound<'py, PyAny>>,
        saver: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let c = Ctx::new(slf.as_any(), UT)?;
            atomically(&c.d, || {
                crate::ukf_batch::batch_filter(&c, zs, Rs, dts, saver)
            })
        })
    }

    /// rts_smoother(Xs, Ps, Qs=None, dts=None, UT=None) → (xs, ps, Ks): the unscented RTS
    /// smoother over batch_filter's output, with fx and the filter's points, Qs[k] (default
    /// the filter's Q) and dts[k] (a scalar: every step). K is solved, not formed by inv.
    #[pyo3(signature = (Xs, Ps, Qs = None, dts = None, UT = None))]
    fn rts_smoother<'py>(
        slf: &Bound<'py, Self>,
        Xs: &Bound<'py, PyAny>,
        Ps: &Bound<'py, PyAny>,
        Qs: Option<&Bound<'py, PyAny>>,
        dts: Option<&Bound<'py, PyAny>>,
        UT: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let c = Ctx::new(slf.as_any(), UT)?;
            crate::ukf_batch::rts_smoother(&c, Xs, Ps, Qs, dts)
        })
    }

    /// ln N(y; 0, S) of the last update (computed on first use, as FilterPy's).
    #[getter]
    fn log_likelihood(slf: &Bound<'_, Self>) -> PyResult<f64> {
        guard(|| {
            let d = dict_of(slf.as_any())?;
            kept(&d, pyo3::intern!(d.py(), "_log_likelihood"), || {
                let (m, y, S) = last_update(&d, "S")?;
                let mut f = Factor::try_new(m).ok_or_else(|| memory_error(m * m, "S"))?;
                if !f.factor(&S, m) {
                    return Ok(f64::NEG_INFINITY);
                }
                let mut work = zeros(m, "y")?;
                let q = f.quad(&y, &mut work);
                Ok(-0.5 * (m as f64 * (2.0 * std::f64::consts::PI).ln() + f.log_abs_det() + q))
            })
        })
    }

    /// exp(log_likelihood), floored at the smallest positive float (FilterPy's rule).
    #[getter]
    fn likelihood(slf: &Bound<'_, Self>) -> PyResult<f64> {
        let d = guard(|| dict_of(slf.as_any()))?;
        kept(&d, pyo3::intern!(d.py(), "_likelihood"), || {
            let l = Self::log_likelihood(slf)?.exp();
            Ok(if l > 0.0 { l } else { f64::MIN_POSITIVE })
        })
    }

    /// √(yᵀ SI y) of the last update.
    #[getter]
    fn mahalanobis(slf: &Bound<'_, Self>) -> PyResult<f64> {
        guard(|| {
            let d = dict_of(slf.as_any())?;
            kept(&d, pyo3::intern!(d.py(), "_mahalanobis"), || {
                let (m, y, SI) = last_update(&d, "SI")?;
                let q: f64 = (0..m)
                    .map(|i| y[i] * (0..m).map(|j| SI[i * m + j] * y[j]).sum::<f64>())
                    .sum();
                Ok(q.sqrt())
            })
        })
    }

    fn __repr__(slf: &Bound<'_, Self>) -> PyResult<String> {
        let d = dict_of(slf.as_any())?;
        let mut out = vec!["UnscentedKalmanFilter object".to_string()];
        for k in [
            "x",
            "P",
            "x_prior",
            "P_prior",
            "Q",
            "R",
            "S",
            "K",
            "y",
            "sigmas_f",
            "sigmas_h",
            "Wm",
            "Wc",
            "residual_x",
            "residual_z",
            "msqrt",
            "hx",
            "fx",
            "x_mean",
            "z_mean",
            "vectorized",
        ] {
            if let Some(v) = d.get_item(k)? {
                out.push(format!("{k} = {}", v.repr()?));
            }
        }
        Ok(out.join("\n"))
    }

    /// Pickle and copy support: the constructor's arguments, then the dict.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let py = slf.py();
            let d = dict_of(slf.as_any())?;
            let args = PyTuple::new(
                py,
                ["_dim_x", "_dim_z", "_dt", "hx", "fx", "points_fn"]
                    .iter()
                    .map(|k| item(&d, k))
                    .collect::<PyResult<Vec<_>>>()?,
            )?;
            (slf.get_type(), args, d.copy()?).into_pyobject(py)
        })
    }
}
