//! `launch_estimation`: the estimation engine from Python — a FilterPy-compatible
//! `KalmanFilter` whose state lives in Rust (with its extended, unscented and fixed-lag
//! companions), and the engine's whole-series functions.
//!
//! Notation (as in the Rust crates): n states, m measurements, p control inputs;
//! x_{k+1} = F x_k + B u_k + w_k, z_k = H x_k + v_k, cov(w) = Q, cov(v) = R,
//! E[w_k v_kᵀ] = S. FilterPy's `M` (used by `update_correlated`) is the cross-covariance of
//! the *prior state error* with v_k; for a prior x_{k|k−1} built by the prediction from
//! step k − 1 it is the S of the step before: M_k = S_{k−1} (see the module docstring).
//!
//! Every entry point runs inside `guard`: errors are `ValueError`/`TypeError` with one
//! line naming the argument, and a panic (a bug) becomes a `RuntimeError` instead of
//! unwinding into the interpreter.
#![deny(missing_docs)]

mod batch;
mod convert;
mod ekf;
mod engine;
mod fit_fns;
mod fixed_lag;
mod fleet;
mod imm;
mod kf;
mod kf_attrs;
mod kf_compat;
mod kf_core;
mod linalg;
mod model_fns;
mod nonlinear;
mod particle_fns;
mod pass;
mod series;
mod sigma;
mod ukf;
mod ukf_batch;
mod ukf_core;
mod ukf_state;
mod wls_fns;

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// Runs `f`, turning a panic into a `RuntimeError` (the last line of defence: no input
/// should reach one, but none may unwind into Python).
pub(crate) fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(PyRuntimeError::new_err(format!(
                "internal error in launch_estimation (a bug, please report it): {}",
                what.replace('\n', " ")
            )))
        }
    }
}

/// Panics inside [`guard`], so the tests can check that a panic becomes a `RuntimeError`.
#[pyfunction]
fn _panic_for_test() -> PyResult<()> {
    guard(|| -> PyResult<()> { panic!("deliberate panic for the test of the guard") })
}

/// The Python module.
#[pymodule]
fn launch_estimation(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<kf::KalmanFilter>()?;
    kf_attrs::ArrayAttribute::install(&m.py().get_type::<kf::KalmanFilter>())?;
    m.add_class::<ekf::ExtendedKalmanFilter>()?;
    m.add_class::<ukf::UnscentedKalmanFilter>()?;
    m.add_class::<fixed_lag::FixedLagSmoother>()?;
    m.add_class::<imm::IMMEstimator>()?;
    m.add_class::<sigma::MerweScaledSigmaPoints>()?;
    m.add_class::<sigma::JulierSigmaPoints>()?;
    m.add_class::<sigma::SimplexSigmaPoints>()?;
    m.add_function(wrap_pyfunction!(engine::filter, m)?)?;
    m.add_function(wrap_pyfunction!(engine::smooth, m)?)?;
    m.add_function(wrap_pyfunction!(fleet::filter_batch, m)?)?;
    m.add_function(wrap_pyfunction!(engine::filter_continuous, m)?)?;
    m.add_function(wrap_pyfunction!(engine::smooth_continuous, m)?)?;
    m.add_function(wrap_pyfunction!(engine::dare, m)?)?;
    m.add_function(wrap_pyfunction!(engine::dlqr, m)?)?;
    m.add_function(wrap_pyfunction!(engine::care, m)?)?;
    m.add_function(wrap_pyfunction!(model_fns::c2d, m)?)?;
    m.add_function(wrap_pyfunction!(model_fns::fuel_model, m)?)?;
    m.add_function(wrap_pyfunction!(wls_fns::wls, m)?)?;
    m.add_function(wrap_pyfunction!(nonlinear::ekf, m)?)?;
    m.add_function(wrap_pyfunction!(nonlinear::ukf, m)?)?;
    m.add_function(wrap_pyfunction!(particle_fns::particle_filter, m)?)?;
    m.add_function(wrap_pyfunction!(fit_fns::fit, m)?)?;
    m.add_function(wrap_pyfunction!(fit_fns::fit_callable, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_test, m)?)?;
    Ok(())
}
