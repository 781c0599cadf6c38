//! Per-run records of the boom scenario's noise Monte Carlo (`runs_noise.csv`): for each case
//! γ and run, the RMS errors of the WLS, the EKF, the UKF and the unscented RTS smoother over
//! the run's two turns ("+" and "−" with the same white noise on top). They are the
//! campaign's ground truth: the `noise_mc` rows of the summary are recomputed from them.

use super::parameters::{BoomParams, Method};
use crate::campaign::records::Row;

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

/// One row of `runs_noise.csv`, keyed by (γ index, run).
impl Row for NoiseRecord {
    type Params = BoomParams;

    const FILE: &'static str = "runs_noise.csv";

    fn header() -> Vec<&'static str> {
        HEADER.to_vec()
    }

    fn grid(p: &BoomParams) -> Vec<usize> {
        vec![p.case_gammas_deg.len(), p.tracking.runs]
    }

    fn to_row(&self) -> Vec<f64> {
        let mut row = vec![self.gamma_index as f64, self.run as f64];
        for (a, e) in self.rms {
            row.extend([a, e]);
        }
        row
    }

    fn from_row(row: &[f64]) -> Option<Self> {
        let &[g, run, a0, e0, a1, e1, a2, e2, a3, e3] = row else {
            return None;
        };
        Some(NoiseRecord {
            gamma_index: g as usize,
            run: run as usize,
            rms: [(a0, e0), (a1, e1), (a2, e2), (a3, e3)],
        })
    }
}
