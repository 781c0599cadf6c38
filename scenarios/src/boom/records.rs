//! Per-run records of the boom scenario's noise Monte Carlo (`runs_noise.csv`): for each case
//! γ and run, the RMS errors of the WLS, the EKF, the UKF and the unscented RTS smoother over
//! the run's two turns ("+" and "−" with the same white noise on top). They are the
//! campaign's ground truth: the `noise_mc` rows of the summary are recomputed from them.

use super::parameters::{BoomParams, Method};
use crate::campaign::records::RecordFile;
use crate::error::{Error, Result};

/// The methods of the Monte Carlo, in column order.
pub const NOISE_METHODS: [Method; 4] = [Method::Wls, Method::Ekf, Method::Ukf, Method::Urts];

/// One run at one γ.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseRecord {
    /// Index of γ in `case_gammas_deg`.
    pub gamma_index: usize,
    /// Run index.
    pub run: usize,
    /// Per method of [`NOISE_METHODS`]: (RMS δα in degrees, RMS δε in °/s²) over both turns'
    /// defined cycles after the start-up cycle.
    pub rms: [(f64, f64); 4],
}

/// Columns of `runs_noise.csv`.
const HEADER: [&str; 10] = [
    "gamma",
    "run",
    "wls_rms_alpha_deg",
    "wls_rms_eps_deg_s2",
    "ekf_rms_alpha_deg",
    "ekf_rms_eps_deg_s2",
    "ukf_rms_alpha_deg",
    "ukf_rms_eps_deg_s2",
    "urts_rms_alpha_deg",
    "urts_rms_eps_deg_s2",
];

/// The one record file, `runs_noise.csv`, keyed by (γ index, run).
pub fn record_files(p: &BoomParams) -> Vec<RecordFile> {
    vec![RecordFile {
        name: "runs_noise.csv".into(),
        header: HEADER.to_vec(),
        grid: vec![p.case_gammas_deg.len(), p.tracking.runs],
    }]
}

/// The rows of `runs_noise.csv` (the records are in key order).
pub fn to_tables(records: &[NoiseRecord]) -> Vec<Vec<Vec<f64>>> {
    vec![
        records
            .iter()
            .map(|r| {
                let mut row = vec![r.gamma_index as f64, r.run as f64];
                for (a, e) in r.rms {
                    row.extend([a, e]);
                }
                row
            })
            .collect(),
    ]
}

/// The records from the rows of `runs_noise.csv` (keys checked by the campaign).
///
/// # Errors
/// [`Error::Invalid`] for a table or row of the wrong shape.
pub fn from_tables(tables: Vec<Vec<Vec<f64>>>) -> Result<Vec<NoiseRecord>> {
    let [rows]: [Vec<Vec<f64>>; 1] = tables.try_into().map_err(|t: Vec<_>| {
        Error::invalid("runs_noise.csv", format!("{} tables, expected 1", t.len()))
    })?;
    rows.into_iter()
        .map(|row| match row.as_slice() {
            &[g, run, a0, e0, a1, e1, a2, e2, a3, e3] => Ok(NoiseRecord {
                gamma_index: g as usize,
                run: run as usize,
                rms: [(a0, e0), (a1, e1), (a2, e2), (a3, e3)],
            }),
            _ => Err(Error::invalid(
                "runs_noise.csv",
                format!("a row of {} fields, expected {}", row.len(), HEADER.len()),
            )),
        })
        .collect()
}
