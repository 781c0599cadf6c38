//! Both estimators on one record, set up the same way for a simulated flight and for a
//! user's CSV: the prior from the record's first readings ([`FlightData::initial_state`])
//! and the configured priors, the gated filter–smoother, and the output-error fit on the
//! gated measurements.
//!
//! **Iterated smoother.** The filter–smoother is the iterated extended smoother: a first
//! EKF–RTS pass on the model itself, then [`SMOOTHER_ITERATIONS`] passes on the model
//! linearised about the previous pass's smoothed trajectory, each from the same prior
//! (see [`smoother`]'s documentation for why a single pass is over-confident in the
//! air-data scale factors).

use faer::Mat;
use kalman::fit::{self, OutputErrorOptions};

use super::data::{FlightData, Grid};
use super::model::{FlightModel, M, N_ERR, N_KIN, Noise};
use super::parameters::FlightPathParams;
use super::smoother::{self, Pass, Settings};
use crate::error::{Error, Result};

/// The output-error fit's instrument errors.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputError {
    /// Estimates (SI, state order).
    pub estimate: [f64; N_ERR],
    /// Cramér–Rao bounds.
    pub std: [f64; N_ERR],
    /// Correlation matrix of the errors (row-major 12×12).
    pub correlation: Vec<f64>,
    /// Gauss–Newton iterations.
    pub iterations: usize,
    /// Whether the fit converged.
    pub converged: bool,
}

/// Both estimators' results on one record.
#[derive(Debug, Clone)]
pub struct Estimates {
    /// The filter–smoother pass.
    pub pass: Pass,
    /// The output-error fit, if it ran.
    pub output_error: Option<OutputError>,
}

/// The filter–smoother settings for a record: x0 from the first readings, zero errors.
pub fn settings(data: &FlightData, grid: &Grid, noise: &Noise, p: &FlightPathParams) -> Settings {
    let mut x0 = data.initial_state(grid.t[0]).to_vec();
    x0.extend_from_slice(&[0.0; N_ERR]);
    let mut prior_std = p.kinematic_prior_si().to_vec();
    prior_std.extend_from_slice(&p.error_prior_si());
    debug_assert_eq!(x0.len(), N_KIN + N_ERR);
    Settings {
        noise: *noise,
        prior_std,
        x0,
        gate: p.gate_threshold(),
        gate_reset: p.gate_reset,
        augmented: true,
    }
}

/// Linearised passes after the first (see the module documentation). Two reach the fixed
/// point to well within the smoothed standard deviations on the simulated flights: a
/// third moves no instrument-error estimate by more than a few per cent of its bound.
pub const SMOOTHER_ITERATIONS: usize = 1;

/// The iterated filter–smoother over `grid` (the measurements already [`consumed`]) from
/// the prior `s`: the EKF–RTS pass, then `iterations` passes linearised about the
/// previous smoothed trajectory; the smoothed covariance is kept at the steps `keep_cov`.
///
/// # Errors
/// As [`smoother::run`].
pub fn filter_smoother(
    grid: &Grid,
    s: &Settings,
    iterations: usize,
    keep_cov: &[usize],
) -> Result<Pass> {
    let mut pass = smoother::run(grid, s, if iterations == 0 { keep_cov } else { &[] })?;
    for i in 0..iterations {
        let keep: &[usize] = if i + 1 == iterations { keep_cov } else { &[] };
        pass = smoother::run_about(grid, s, keep, Some(pass.smoothed))?;
    }
    Ok(pass)
}

/// The grid with the first reading of air data, AHRS and GNSS removed: the prior x0 is
/// made from them, so using them again as measurements would count them twice.
pub fn consumed(data: &FlightData, grid: &Grid) -> Grid {
    let mut g = grid.clone();
    for (offset, t0) in [(0, data.air[0].0), (3, data.ahrs[0].0), (6, data.gnss[0].0)] {
        if let Some(k) = g.t.iter().position(|t| t.to_bits() == t0.to_bits()) {
            g.z[k][offset..offset + 3].fill(f64::NAN);
        }
    }
    g
}

/// Runs both estimators on `data` (its grid `grid`); the smoothed covariance is kept at
/// the steps `keep_cov`.
///
/// # Errors
/// As [`filter_smoother`].
pub fn both(
    data: &FlightData,
    grid: &Grid,
    noise: &Noise,
    p: &FlightPathParams,
    keep_cov: &[usize],
) -> Result<Estimates> {
    let s = settings(data, grid, noise, p);
    let grid = &consumed(data, grid);
    let pass = filter_smoother(grid, &s, SMOOTHER_ITERATIONS, keep_cov)?;
    let output_error = Some(output_error(grid, noise, p, &pass)?);
    Ok(Estimates { pass, output_error })
}

/// The unscented filter–smoother on `data` (one pass, [`smoother::run_unscented`]) from
/// the same prior and gate as [`both`]'s; the smoothed covariance is kept at `keep_cov`.
///
/// # Errors
/// As [`smoother::run_unscented`].
pub fn unscented(
    data: &FlightData,
    grid: &Grid,
    noise: &Noise,
    p: &FlightPathParams,
    keep_cov: &[usize],
) -> Result<Pass> {
    let s = settings(data, grid, noise, p);
    smoother::run_unscented(&consumed(data, grid), &s, keep_cov)
}

/// The output-error fit of the instrument errors and the initial kinematic state on the
/// gated measurements (every entry of x0 free), from the smoothed x_{0|N} as the starting
/// point (the optimum does not depend on it; a start near it saves Gauss–Newton passes).
///
/// # Errors
/// [`Error::Fit`] if the fit fails (a non-identified direction, a non-finite pass).
pub fn output_error(
    grid: &Grid,
    noise: &Noise,
    p: &FlightPathParams,
    pass: &Pass,
) -> Result<OutputError> {
    let model = FlightModel::new(grid, noise, true);
    let n = model.n();
    let big_n = grid.t.len();
    let dims = kalman::DynDims::new(n, M, 0).map_err(|source| Error::Kalman {
        context: "flightpath output error",
        source,
    })?;
    let x0: Vec<f64> = (0..n).map(|i| pass.smoothed[(i, 0)]).collect();
    let free: Vec<usize> = (0..n).collect();
    let z = Mat::from_fn(big_n, M, |k, i| pass.gated[k][i]);
    let options = OutputErrorOptions {
        max_iterations: p.output_error_iterations,
        ..OutputErrorOptions::default()
    };
    let fit = fit::output_error(&model, dims, &x0, &free, z.as_ref(), None, &options).map_err(
        |source| Error::Fit {
            context: "flightpath output error",
            source,
        },
    )?;
    let mut estimate = [0.0; N_ERR];
    let mut std = [0.0; N_ERR];
    estimate.copy_from_slice(&fit.estimate[N_KIN..]);
    std.copy_from_slice(&fit.std[N_KIN..]);
    let correlation = (0..N_ERR)
        .flat_map(|i| (0..N_ERR).map(move |j| (i, j)))
        .map(|(i, j)| fit.correlation[(N_KIN + i, N_KIN + j)])
        .collect();
    Ok(OutputError {
        estimate,
        std,
        correlation,
        iterations: fit.iterations,
        converged: fit.converged,
    })
}
