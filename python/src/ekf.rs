//! `launch_estimation.ExtendedKalmanFilter`: FilterPy's `ExtendedKalmanFilter` as a subclass
//! of `KalmanFilter` (the same state, attributes, predict, copies and pickles), with
//! FilterPy's EKF update: `update(z, HJacobian, Hx, R=None, args=(), hx_args=(),
//! residual=numpy.subtract)`, `predict_update` and `predict_x`. The user's Jacobian and
//! measurement functions are called as FilterPy calls them (with the filter's x, then the
//! extra arguments); the update itself is the Joseph form in Rust.
#![allow(non_snake_case)]

use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::convert::{ensure_callable, read_matrix, read_vector, scalar, value_error, zeros};
use crate::guard;
use crate::kf_attrs::{A, KalmanFilter, PREDICTED, UPDATED};
use crate::kf_core::UpdateError;

/// FilterPy's `ExtendedKalmanFilter(dim_x, dim_z, dim_u=0)`.
#[pyclass(module = "launch_estimation", extends = KalmanFilter)]
#[derive(Debug)]
pub struct ExtendedKalmanFilter {}

/// `args` as FilterPy takes them: a tuple, or one value made a 1-tuple (None: none).
fn extra_args<'py>(args: Option<&Bound<'py, PyAny>>) -> Vec<Bound<'py, PyAny>> {
    match args {
        None => Vec::new(),
        Some(a) => match a.cast::<PyTuple>() {
            Ok(t) => t.iter().collect(),
            Err(_) => vec![a.clone()],
        },
    }
}

/// Calls `f(x, *args)`.
fn call_with<'py>(
    f: &Bound<'py, PyAny>,
    name: &str,
    x: &Bound<'py, PyAny>,
    args: &[Bound<'py, PyAny>],
) -> PyResult<Bound<'py, PyAny>> {
    ensure_callable(f, name)?;
    let all: Vec<Bound<'py, PyAny>> = std::iter::once(x.clone())
        .chain(args.iter().cloned())
        .collect();
    f.call1(PyTuple::new(f.py(), all)?)
}

/// Calls `f(x, *args)` with the filter's current x.
fn call_at_x<'py>(
    kf: &Bound<'py, KalmanFilter>,
    f: &Bound<'py, PyAny>,
    name: &str,
    args: &[Bound<'py, PyAny>],
) -> PyResult<Bound<'py, PyAny>> {
    let x = kf.try_borrow_mut()?.get(kf.py(), A::X);
    call_with(f, name, x.bind(kf.py()), args)
}

/// Brings `kf`'s state up to date with its array attributes, then calls
/// `HJacobian(x, *args)` (FilterPy's `args`) at that x.
fn jacobian_at_x<'py>(
    kf: &Bound<'py, KalmanFilter>,
    HJacobian: &Bound<'py, PyAny>,
    args: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    kf.try_borrow_mut()?.sync(kf.py())?;
    call_at_x(kf, HJacobian, "HJacobian", &extra_args(args))
}

/// One EKF update of `kf` at its current x: H = HJacobian(x, *args), y = residual(z,
/// Hx(x, *hx_args)), then the Joseph-form update with that H and y. `before`: the state to
/// record as the prior instead of the current one (predict_update's FilterPy order).
#[allow(clippy::too_many_arguments)]
fn ekf_update<'py>(
    kf: &Bound<'py, KalmanFilter>,
    z: &Bound<'py, PyAny>,
    H: &Bound<'py, PyAny>,
    Hx: &Bound<'py, PyAny>,
    R: Option<&Bound<'py, PyAny>>,
    hx_args: Option<&Bound<'py, PyAny>>,
    residual: Option<&Bound<'py, PyAny>>,
) -> PyResult<()> {
    let py = kf.py();
    let (n, m) = {
        let me = kf.try_borrow()?;
        (me.core.n, me.core.m)
    };
    let hx = call_at_x(kf, Hx, "Hx", &extra_args(hx_args))?;
    let z = match scalar(z) {
        Some(v) if m == 1 => PyTuple::new(py, [v])?.into_any(),
        _ => z.clone(),
    };
    let z = py
        .import("numpy")?
        .call_method1("asarray", (&z, "float64"))?;
    let y = match residual.filter(|r| !r.is_none()) {
        Some(r) => r.call1((&z, &hx))?,
        None => py.import("numpy")?.call_method1("subtract", (&z, &hx))?,
    };
    let mut Hm = zeros(m * n, "HJacobian")?;
    read_matrix(H, "the value of HJacobian(x)", m, n, false, &mut Hm)?;
    let mut yv = zeros(m, "y")?;
    read_vector(&y, "the residual y", m, true, false, &mut yv)?;
    let mut zv = zeros(m, "z")?;
    read_vector(&z, "z", m, true, true, &mut zv)?;
    let mut me = kf.try_borrow_mut()?;
    let Rm = me.override_matrix(R, "R", m, m, true)?;
    me.core
        .update_innovation(&zv, &yv, Rm.as_deref(), &Hm)
        .map_err(|UpdateError::SingularS| {
            value_error("S (the innovation covariance H P Hᵀ + R) is singular for this update")
        })?;
    me.invalidate(&UPDATED);
    Ok(())
}

#[pymethods]
impl ExtendedKalmanFilter {
    /// ExtendedKalmanFilter(dim_x, dim_z, dim_u=0): FilterPy's defaults (x = 0, P = F = Q =
    /// I, R = I).
    #[new]
    #[pyo3(signature = (dim_x, dim_z, dim_u = None))]
    fn new(
        dim_x: &Bound<'_, PyAny>,
        dim_z: &Bound<'_, PyAny>,
        dim_u: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyClassInitializer<Self>> {
        let base = KalmanFilter::build(dim_x, dim_z, dim_u)?;
        Ok(PyClassInitializer::from(base).add_subclass(Self {}))
    }

    /// update(z, HJacobian, Hx, R=None, args=(), hx_args=(), residual=numpy.subtract):
    /// H = HJacobian(x, *args), y = residual(z, Hx(x, *hx_args)), K = P Hᵀ S⁻¹ (a solve),
    /// x ← x + K y, P ← (I − K H) P (I − K H)ᵀ + K R Kᵀ. z = None skips the update.
    #[pyo3(signature = (z, HJacobian, Hx, R = None, args = None, hx_args = None, residual = None))]
    #[allow(clippy::too_many_arguments)]
    fn update<'py>(
        slf: &Bound<'py, Self>,
        z: &Bound<'py, PyAny>,
        HJacobian: &Bound<'py, PyAny>,
        Hx: &Bound<'py, PyAny>,
        R: Option<&Bound<'py, PyAny>>,
        args: Option<&Bound<'py, PyAny>>,
        hx_args: Option<&Bound<'py, PyAny>>,
        residual: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let kf = slf.cast::<KalmanFilter>()?;
            if z.is_none() {
                return kf
                    .try_borrow_mut()?
                    .do_update(slf.py(), z, None, None, false);
            }
            let H = jacobian_at_x(kf, HJacobian, args)?;
            ekf_update(kf, z, &H, Hx, R, hx_args, residual)
        })
    }

    /// predict_x(u=0): x ← F x + B u (P unchanged).
    #[pyo3(signature = (u = None))]
    fn predict_x(slf: &Bound<'_, Self>, u: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        guard(|| {
            let py = slf.py();
            let kf = slf.cast::<KalmanFilter>()?;
            let mut me = kf.try_borrow_mut()?;
            me.sync(py)?;
            let u = me.read_u(u, me.controls())?;
            me.core.predict_x(u.as_deref());
            me.invalidate(&[A::X]);
            Ok(())
        })
    }

    /// predict_update(z, HJacobian, Hx, args=(), hx_args=(), u=0): FilterPy's one-call step:
    /// H = HJacobian(x, *args) at the current x, then the prediction, then the update with
    /// that H and y = z − Hx(x_pred, *hx_args). As in FilterPy, x_prior and P_prior hold the
    /// state before the prediction.
    #[pyo3(signature = (z, HJacobian, Hx, args = None, hx_args = None, u = None))]
    #[allow(clippy::too_many_arguments)]
    fn predict_update<'py>(
        slf: &Bound<'py, Self>,
        z: &Bound<'py, PyAny>,
        HJacobian: &Bound<'py, PyAny>,
        Hx: &Bound<'py, PyAny>,
        args: Option<&Bound<'py, PyAny>>,
        hx_args: Option<&Bound<'py, PyAny>>,
        u: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let kf = slf.cast::<KalmanFilter>()?;
            let H = jacobian_at_x(kf, HJacobian, args)?;
            let (x0, P0) = {
                let mut me = kf.try_borrow_mut()?;
                let (x0, P0) = (me.core.x.clone(), me.core.P.clone());
                let u = me.read_u(u, me.controls())?;
                me.core.predict(u.as_deref(), None, None, None);
                me.invalidate(&PREDICTED);
                (x0, P0)
            };
            ekf_update(kf, z, &H, Hx, None, hx_args, None)?;
            let mut me = kf.try_borrow_mut()?;
            me.core.x_prior.copy_from_slice(&x0);
            me.core.P_prior.copy_from_slice(&P0);
            me.invalidate(&[A::XPrior, A::PPrior]);
            Ok(())
        })
    }

    fn __repr__(slf: &Bound<'_, Self>) -> PyResult<String> {
        let kf = slf.cast::<KalmanFilter>()?.try_borrow()?;
        Ok(format!(
            "ExtendedKalmanFilter(dim_x={}, dim_z={}, dim_u={}, x={:?})",
            kf.core.n, kf.core.m, kf.dim_u, kf.core.x
        ))
    }
}
