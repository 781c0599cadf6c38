//! Per-run records of the uav scenario (`runs.csv`): each run's RMS errors, Ljung–Box Q and
//! mean NIS after the burn-in. They are the campaign's ground truth: the Monte Carlo
//! aggregates are recomputed from them.

use serde::{Deserialize, Serialize};

use super::parameters::UavParams;
use crate::campaign::records::Row;

/// The statistics of one run (after the burn-in).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Run index.
    pub run: usize,
    /// RMS of the position estimation error x − x̂_{k|k}, m.
    pub rms_estimation_error: f64,
    /// RMS of the measurement error z − x, m.
    pub rms_measurement_error: f64,
    /// Ljung–Box Q of the normalised innovations e/√Σ.
    pub ljung_box_q: f64,
    /// Mean normalised innovation squared (1 for a consistent filter).
    pub mean_nis: f64,
}

/// Columns of `runs.csv`.
const RUNS_HEADER: [&str; 5] = [
    "run",
    "rms_estimation_error",
    "rms_measurement_error",
    "ljung_box_q",
    "mean_nis",
];

/// One row of `runs.csv`, keyed by run.
impl Row for RunRecord {
    type Params = UavParams;

    const FILE: &'static str = "runs.csv";

    fn header() -> Vec<&'static str> {
        RUNS_HEADER.to_vec()
    }

    fn grid(p: &UavParams) -> Vec<usize> {
        vec![p.runs]
    }

    fn to_row(&self) -> Vec<f64> {
        vec![
            self.run as f64,
            self.rms_estimation_error,
            self.rms_measurement_error,
            self.ljung_box_q,
            self.mean_nis,
        ]
    }

    fn from_row(row: &[f64]) -> Option<Self> {
        let &[run, est, meas, q, nis] = row else {
            return None;
        };
        Some(RunRecord {
            run: run as usize,
            rms_estimation_error: est,
            rms_measurement_error: meas,
            ljung_box_q: q,
            mean_nis: nis,
        })
    }
}
