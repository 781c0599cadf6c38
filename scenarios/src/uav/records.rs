//! Per-run records of the uav scenario (`runs.csv`): each run's RMS errors, Ljung–Box Q and
//! mean NIS after the burn-in. They are the campaign's ground truth: the Monte Carlo
//! aggregates are recomputed from them.

use serde::{Deserialize, Serialize};

use super::parameters::UavParams;
use crate::campaign::records::RecordFile;
use crate::error::{Error, Result};

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

/// The one record file, `runs.csv`, keyed by run.
pub fn record_files(p: &UavParams) -> Vec<RecordFile> {
    vec![RecordFile {
        name: "runs.csv".into(),
        header: RUNS_HEADER.to_vec(),
        grid: vec![p.runs],
    }]
}

/// The rows of `runs.csv`.
pub fn to_tables(records: &[RunRecord]) -> Vec<Vec<Vec<f64>>> {
    vec![
        records
            .iter()
            .map(|r| {
                vec![
                    r.run as f64,
                    r.rms_estimation_error,
                    r.rms_measurement_error,
                    r.ljung_box_q,
                    r.mean_nis,
                ]
            })
            .collect(),
    ]
}

/// The records from the rows of `runs.csv` (keys checked by the campaign).
///
/// # Errors
/// [`Error::Invalid`] for a table or row of the wrong shape.
pub fn from_tables(tables: Vec<Vec<Vec<f64>>>) -> Result<Vec<RunRecord>> {
    let [rows]: [Vec<Vec<f64>>; 1] = tables.try_into().map_err(|t: Vec<_>| {
        Error::invalid("runs.csv", format!("{} tables, expected 1", t.len()))
    })?;
    rows.into_iter()
        .map(|row| match row.as_slice() {
            &[run, est, meas, q, nis] => Ok(RunRecord {
                run: run as usize,
                rms_estimation_error: est,
                rms_measurement_error: meas,
                ljung_box_q: q,
                mean_nis: nis,
            }),
            _ => Err(Error::invalid(
                "runs.csv",
                format!("a row of {} fields, expected 5", row.len()),
            )),
        })
        .collect()
}
