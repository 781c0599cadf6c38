//! The `model` crate from Python: `c2d` (discretisation with Van Loan noise) and
//! `fuel_model` (the paper's 7-state fuel-level model), with model errors as `ValueError`s.
#![allow(non_snake_case)]

use model::nalgebra::DMatrix;
use model::{Channels, ContinuousSs, Discretization, FuelParams, NoiseConvention, Realisation};
use numpy::PyArray2;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{rows_2d, value_error};
use crate::guard;

/// A 2-d float array argument as an nalgebra matrix (finite entries).
fn dmat(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<DMatrix<f64>> {
    let (r, c, buf) = rows_2d(obj, name)?;
    Ok(DMatrix::from_row_slice(r, c, &buf))
}

/// An nalgebra matrix as a new (r, c) array.
fn out<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    PyArray2::from_owned_array(
        py,
        Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]),
    )
}

/// Maps a model error to a `ValueError` naming the function.
fn err(context: &str) -> impl Fn(model::Error) -> PyErr + '_ {
    move |e| value_error(format!("{context}: {e}"))
}

/// c2d(A, B, C, D, dt, method="zoh", G=None, W=None, noise="van_loan", omega=None) →
/// dict with "F", "B", "H", "D" and, when the noise input G with intensity W is given,
/// "G", "J", "Q" of the discrete model (dx = (A x + B u) dt + G dβ, cov dβ = W dt).
/// method: "zoh", "tustin", "tustin_prewarp" (with omega, rad/s), "forward_euler",
/// "backward_euler"; noise: "van_loan" (Q = ∫ e^{Aτ} G W Gᵀ e^{Aᵀτ} dτ, G_d = I) or
/// "intensity_over_dt" (Q = W/dt through the mapped G).
#[pyfunction]
#[pyo3(signature = (A, B, C, D, dt, method = "zoh", G = None, W = None, noise = "van_loan", omega = None))]
pub(crate) fn c2d<'py>(
    py: Python<'py>,
    A: &Bound<'py, PyAny>,
    B: &Bound<'py, PyAny>,
    C: &Bound<'py, PyAny>,
    D: &Bound<'py, PyAny>,
    dt: f64,
    method: &str,
    G: Option<&Bound<'py, PyAny>>,
    W: Option<&Bound<'py, PyAny>>,
    noise: &str,
    omega: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let method = match (method, omega) {
            ("zoh", None) => Discretization::Zoh,
            ("tustin", None) => Discretization::Tustin,
            ("tustin_prewarp", Some(omega)) => Discretization::TustinPrewarp { omega },
            ("tustin_prewarp", None) => {
                return Err(value_error("method \"tustin_prewarp\" needs omega (rad/s)"));
            }
            ("forward_euler", None) => Discretization::ForwardEuler,
            ("backward_euler", None) => Discretization::BackwardEuler,
            (_, Some(_)) if method != "tustin_prewarp" => {
                return Err(value_error(format!(
                    "omega is only for method \"tustin_prewarp\", not {method:?}"
                )));
            }
            (other, _) => {
                return Err(value_error(format!(
                    "method = {other:?}; expected \"zoh\", \"tustin\", \"tustin_prewarp\", \
                     \"forward_euler\" or \"backward_euler\""
                )));
            }
        };
        let noise = match noise {
            "van_loan" => NoiseConvention::VanLoan,
            "intensity_over_dt" => NoiseConvention::IntensityOverDt,
            other => {
                return Err(value_error(format!(
                    "noise = {other:?}; expected \"van_loan\" or \"intensity_over_dt\""
                )));
            }
        };
        let mut sys = ContinuousSs::new(dmat(A, "A")?, dmat(B, "B")?, dmat(C, "C")?, dmat(D, "D")?)
            .map_err(err("c2d"))?;
        let with_noise = match (G, W) {
            (Some(g), Some(w)) if !g.is_none() && !w.is_none() => {
                sys = sys
                    .with_noise(dmat(g, "G")?, dmat(w, "W")?)
                    .map_err(err("c2d"))?;
                true
            }
            (None, None) => false,
            (Some(g), Some(w)) if g.is_none() && w.is_none() => false,
            _ => {
                return Err(value_error(
                    "c2d: give both G and W (noise input and intensity)",
                ));
            }
        };
        let d = sys.discretize(dt, method, noise).map_err(err("c2d"))?;
        let o = PyDict::new(py);
        o.set_item("F", out(py, d.f()))?;
        o.set_item("B", out(py, d.b()))?;
        o.set_item("H", out(py, d.h()))?;
        o.set_item("D", out(py, d.d()))?;
        if with_noise {
            o.set_item("G", out(py, d.g()))?;
            o.set_item("J", out(py, d.j()))?;
            o.set_item("Q", out(py, d.q()))?;
        }
        Ok(o)
    })
}

/// fuel_model(channels="level_and_tilt", realisation="paper", dt=None) → the paper's
/// 7-state fuel-level model with the default parameters: dict with "F" (A), "B" (noise
/// input), "H" (C), "D", "Q" (noise covariance), "R", "S" (E[w_k v_kᵀ]), "Qw" (B Q Bᵀ),
/// "known_input" (added to the state each step) and "dt".
#[pyfunction]
#[pyo3(signature = (channels = "level_and_tilt", realisation = "paper", dt = None))]
pub(crate) fn fuel_model<'py>(
    py: Python<'py>,
    channels: &str,
    realisation: &str,
    dt: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let channels = match channels {
            "level_and_tilt" => Channels::LevelAndTilt,
            "level_only" => Channels::LevelOnly,
            other => {
                return Err(value_error(format!(
                    "channels = {other:?}; expected \"level_and_tilt\" or \"level_only\""
                )));
            }
        };
        let realisation = match realisation {
            "paper" => Realisation::Paper,
            "exact_tustin" => Realisation::ExactTustin,
            "zoh" => Realisation::Zoh,
            other => {
                return Err(value_error(format!(
                    "realisation = {other:?}; expected \"paper\", \"exact_tustin\" or \"zoh\""
                )));
            }
        };
        let mut params = FuelParams::default();
        if let Some(dt) = dt {
            params.dt = dt;
        }
        let m = params
            .build(channels, realisation)
            .map_err(err("fuel_model"))?;
        let o = PyDict::new(py);
        o.set_item("F", out(py, &m.a))?;
        o.set_item("B", out(py, &m.b))?;
        o.set_item("H", out(py, &m.c))?;
        o.set_item("D", out(py, &m.d))?;
        o.set_item("Q", out(py, &m.q))?;
        o.set_item("R", out(py, &m.r))?;
        o.set_item("S", out(py, &m.s))?;
        o.set_item("Qw", out(py, &m.process_covariance))?;
        o.set_item(
            "known_input",
            numpy::PyArray1::from_slice(py, m.known_input.as_slice()),
        )?;
        o.set_item("dt", m.params.dt)?;
        Ok(o)
    })
}
