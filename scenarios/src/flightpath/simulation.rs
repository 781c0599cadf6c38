//! One simulated flight end to end: the truth and record from `sensors::flight`, the
//! record as [`FlightData`], both estimators on it, and the per-run numbers (every
//! instrument error's estimate and standard deviation per method, the trajectory errors,
//! the smoothed NEES); and the shard's runs in parallel.

use faer::Mat;
use faer::linalg::solvers::Solve;
use sensors::flight::{FlightRecord, NoiseLevels, TruthPoint, simulate};

use super::data::{FlightData, Grid};
use super::estimate::{self, Estimates};
use super::model::{N_ERR, N_KIN};
use super::parameters::FlightPathParams;
use super::records::RunRecord;
use super::smoother::Pass;
use crate::error::{Error, Result};
use crate::montecarlo::{Shard, par_runs, run_rng};

/// The record as the estimators take it (SI channels, stamp order).
pub fn flight_data(rec: &FlightRecord) -> FlightData {
    FlightData {
        imu: rec.imu.iter().map(|s| (s.t, s.value)).collect(),
        air: rec.air.iter().map(|s| (s.t, s.value)).collect(),
        ahrs: rec.ahrs.iter().map(|s| (s.t, s.value)).collect(),
        gnss: rec.gnss.iter().map(|s| (s.t, s.value)).collect(),
    }
}

/// The truth at every stamp of the grid (the grid is the union of the samples' stamps).
pub fn truth_on_grid(rec: &FlightRecord, grid: &Grid) -> Result<Vec<TruthPoint>> {
    let mut all: Vec<TruthPoint> = rec
        .imu
        .iter()
        .map(|s| s.truth)
        .chain(rec.air.iter().map(|s| s.truth))
        .chain(rec.ahrs.iter().map(|s| s.truth))
        .chain(rec.gnss.iter().map(|s| s.truth))
        .collect();
    all.sort_by(|a, b| a.t.total_cmp(&b.t));
    all.dedup_by(|a, b| a.t.to_bits() == b.t.to_bits());
    if all.len() != grid.t.len() {
        return Err(Error::Usage(format!(
            "flightpath: {} truth stamps for a grid of {}",
            all.len(),
            grid.t.len()
        )));
    }
    Ok(all)
}

/// The filter's noise model from the simulation's noise levels.
pub fn noise_model(levels: &NoiseLevels, imu_rate_hz: f64) -> super::model::Noise {
    let mut r = [0.0; 9];
    r[..3].copy_from_slice(&levels.air);
    r[3..6].copy_from_slice(&levels.ahrs);
    r[6..].copy_from_slice(&levels.gnss);
    super::model::Noise {
        imu: levels.imu,
        imu_dt: 1.0 / imu_rate_hz,
        r,
    }
}

/// Errors of the estimate `x` (n×N) against the truth, RMS per group.
pub fn rms_groups(x: &Mat<f64>, truth: &[TruthPoint]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for (k, tp) in truth.iter().enumerate() {
        for i in 0..3 {
            s[0] += (x[(6 + i, k)] - tp.position[i]).powi(2);
            s[1] += (x[(i, k)] - tp.velocity[i]).powi(2);
            s[2] += super::model::wrap(x[(3 + i, k)] - tp.euler[i]).powi(2);
        }
    }
    let n = (3 * truth.len()) as f64;
    s.map(|v| (v / n).sqrt())
}

/// The true full state at a grid step.
pub fn true_state(tp: &TruthPoint, errors: &[f64; N_ERR]) -> Vec<f64> {
    let mut x = Vec::with_capacity(N_KIN + N_ERR);
    x.extend_from_slice(&tp.velocity);
    x.extend_from_slice(&tp.euler);
    x.extend_from_slice(&tp.position);
    x.extend_from_slice(errors);
    x
}

/// The smoothed estimate's error at grid step `k` against the true state `x_true`, the Euler
/// angles' differences wrapped to (−π, π].
pub fn smoothed_error(pass: &Pass, k: usize, x_true: &[f64]) -> Vec<f64> {
    (0..x_true.len())
        .map(|i| {
            let d = pass.smoothed[(i, k)] - x_true[i];
            if (3..6).contains(&i) {
                super::model::wrap(d)
            } else {
                d
            }
        })
        .collect()
}

/// `eᵀ P⁻¹ e` by a Cholesky solve (NaN if P is not positive definite).
pub fn nees(e: &[f64], p: &Mat<f64>) -> f64 {
    let n = e.len();
    let Ok(llt) = p.as_ref().llt(faer::Side::Lower) else {
        return f64::NAN;
    };
    let mut rhs = Mat::<f64>::zeros(n, 1);
    for i in 0..n {
        rhs[(i, 0)] = e[i];
    }
    let sol = llt.solve(&rhs);
    (0..n).map(|i| e[i] * sol[(i, 0)]).sum()
}

/// One simulated flight as the estimators take it.
#[derive(Debug, Clone)]
pub struct Flight {
    /// The record.
    pub data: FlightData,
    /// Its grid.
    pub grid: Grid,
    /// The truth on the grid.
    pub truth: Vec<TruthPoint>,
    /// The filter's noise model.
    pub noise: super::model::Noise,
}

/// Run `run` of the campaign seeded `seed`, simulated.
///
/// # Errors
/// A bad flight configuration.
pub fn flight(p: &FlightPathParams, seed: u64, run: usize) -> Result<Flight> {
    let mut rng = run_rng(seed, run as u64);
    let rec = simulate(&p.flight, &mut rng).map_err(|source| Error::Sensors {
        context: "flightpath flight",
        source,
    })?;
    let data = flight_data(&rec);
    let grid = data.grid();
    let truth = truth_on_grid(&rec, &grid)?;
    Ok(Flight {
        data,
        grid,
        truth,
        noise: noise_model(&p.flight.noise_si(), p.flight.imu.rate_hz),
    })
}

/// One run: the flight, both estimators, and its numbers (with the full estimates for the
/// nominal run's plots).
///
/// # Errors
/// A bad flight configuration, or an estimator failing on the record.
pub fn run_one(
    p: &FlightPathParams,
    seed: u64,
    run: usize,
) -> Result<(RunRecord, Estimates, Vec<TruthPoint>)> {
    let Flight {
        data,
        grid,
        truth,
        noise,
    } = flight(p, seed, run)?;
    let mid = grid.t.len() / 2;
    let est = estimate::both(&data, &grid, &noise, p, &[mid])?;
    let errors = p.flight.errors.si();
    let fs = &est.pass;
    let mut r = RunRecord {
        run,
        fs_estimate: [0.0; N_ERR],
        fs_std: [0.0; N_ERR],
        oe_estimate: [f64::NAN; N_ERR],
        oe_std: [f64::NAN; N_ERR],
        filtered_rms: rms_groups(&fs.filtered, &truth),
        smoothed_rms: rms_groups(&fs.smoothed, &truth),
        nees_smoothed: f64::NAN,
        rejected: fs.rejected.map(|v| v as f64),
    };
    for j in 0..N_ERR {
        r.fs_estimate[j] = fs.smoothed[(N_KIN + j, 0)];
        r.fs_std[j] = fs.smoothed_var[(N_KIN + j, 0)].sqrt();
    }
    if let Some(oe) = &est.output_error {
        r.oe_estimate = oe.estimate;
        r.oe_std = oe.std;
    }
    let x_true = true_state(&truth[mid], &errors);
    r.nees_smoothed = nees(&smoothed_error(fs, mid, &x_true), &fs.smoothed_cov_at[0]);
    Ok((r, est, truth))
}

/// The runs of `shard` (records only), in run order.
///
/// # Errors
/// As [`run_one`]; the worker pool failing to start.
pub fn simulate_runs(
    p: &FlightPathParams,
    seed: u64,
    shard: Shard,
    threads: Option<usize>,
) -> Result<Vec<RunRecord>> {
    par_runs(shard.runs(p.runs), threads, "flightpath", |i| {
        run_one(p, seed, i).map(|(r, _, _)| r)
    })?
    .into_iter()
    .collect()
}
