//! Per-run records of the flightpath scenario (`runs.csv`): each run's estimates and
//! standard deviations of the twelve instrument errors for both methods, the trajectory
//! errors, the smoothed NEES and the gated counts — the campaign's ground truth, from which
//! the Monte Carlo aggregates are recomputed.

use std::sync::OnceLock;

use super::model::N_ERR;
use super::parameters::FlightPathParams;
use crate::campaign::records::Row;

/// The instrument errors: name, display unit, factor from SI to that unit.
pub const ERRORS: [(&str, &str, f64); N_ERR] = [
    ("accel_bias_x", "m/s²", 1.0),
    ("accel_bias_y", "m/s²", 1.0),
    ("accel_bias_z", "m/s²", 1.0),
    ("gyro_bias_p", "deg/s", 180.0 / std::f64::consts::PI),
    ("gyro_bias_q", "deg/s", 180.0 / std::f64::consts::PI),
    ("gyro_bias_r", "deg/s", 180.0 / std::f64::consts::PI),
    ("airspeed_scale", "-", 1.0),
    ("airspeed_bias", "m/s", 1.0),
    ("alpha_scale", "-", 1.0),
    ("alpha_bias", "deg", 180.0 / std::f64::consts::PI),
    ("beta_scale", "-", 1.0),
    ("beta_bias", "deg", 180.0 / std::f64::consts::PI),
];

/// The per-run numbers (one row of `runs.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct RunRecord {
    /// Run index.
    pub run: usize,
    /// Filter–smoother estimates and standard deviations of the 12 errors (SI).
    pub fs_estimate: [f64; N_ERR],
    /// Their smoothed standard deviations.
    pub fs_std: [f64; N_ERR],
    /// Output-error estimates (NaN when the fit is not part of the run).
    pub oe_estimate: [f64; N_ERR],
    /// Their Cramér–Rao bounds.
    pub oe_std: [f64; N_ERR],
    /// RMS filtered errors (position m, velocity m/s, attitude rad).
    pub filtered_rms: [f64; 3],
    /// RMS smoothed errors.
    pub smoothed_rms: [f64; 3],
    /// NEES of the whole smoothed state at the middle of the record.
    pub nees_smoothed: f64,
    /// Gated entries per sensor (air data, AHRS, GNSS).
    pub rejected: [f64; 3],
}

/// Fields per row.
const WIDTH: usize = 1 + 4 * N_ERR + 6 + 1 + 3;

/// One row of `runs.csv`, keyed by run.
impl Row for RunRecord {
    type Params = FlightPathParams;

    const FILE: &'static str = "runs.csv";

    /// Columns of `runs.csv`: the run, then per method and error the estimate and standard
    /// deviation (SI), the trajectory RMS, the NEES and the gated counts.
    fn header() -> Vec<&'static str> {
        static HEADER: OnceLock<Vec<&'static str>> = OnceLock::new();
        HEADER
            .get_or_init(|| {
                let mut h: Vec<String> = vec!["run".into()];
                for what in ["fs_estimate", "fs_std", "oe_estimate", "oe_std"] {
                    for (name, _, _) in ERRORS {
                        h.push(format!("{what}_{name}"));
                    }
                }
                for what in ["filtered_rms", "smoothed_rms"] {
                    for g in ["position", "velocity", "attitude"] {
                        h.push(format!("{what}_{g}"));
                    }
                }
                h.push("nees_smoothed".into());
                for s in ["air_data", "ahrs", "gnss"] {
                    h.push(format!("rejected_{s}"));
                }
                h.into_iter()
                    .map(|s| &*Box::leak(s.into_boxed_str()))
                    .collect()
            })
            .clone()
    }

    fn grid(p: &FlightPathParams) -> Vec<usize> {
        vec![p.runs]
    }

    fn to_row(&self) -> Vec<f64> {
        let mut row = Vec::with_capacity(WIDTH);
        row.push(self.run as f64);
        for a in [
            &self.fs_estimate,
            &self.fs_std,
            &self.oe_estimate,
            &self.oe_std,
        ] {
            row.extend_from_slice(a);
        }
        row.extend_from_slice(&self.filtered_rms);
        row.extend_from_slice(&self.smoothed_rms);
        row.push(self.nees_smoothed);
        row.extend_from_slice(&self.rejected);
        row
    }

    fn from_row(row: &[f64]) -> Option<Self> {
        if row.len() != WIDTH {
            return None;
        }
        let take = |i: usize| -> [f64; N_ERR] { std::array::from_fn(|j| row[1 + i * N_ERR + j]) };
        let b = 1 + 4 * N_ERR;
        Some(RunRecord {
            run: row[0] as usize,
            fs_estimate: take(0),
            fs_std: take(1),
            oe_estimate: take(2),
            oe_std: take(3),
            filtered_rms: [row[b], row[b + 1], row[b + 2]],
            smoothed_rms: [row[b + 3], row[b + 4], row[b + 5]],
            nees_smoothed: row[b + 6],
            rejected: [row[b + 7], row[b + 8], row[b + 9]],
        })
    }
}
