//! The `uav` scenario (SPEC U): one UAV control channel — a sampled double integrator driven by
//! white acceleration noise, a position sensor, the discrete Kalman filter in the loop and LQ
//! state feedback tracking a unit step — simulated closed loop, with the signals and Welch
//! spectra at the paper's four nodes, the closed-loop and filter poles, an innovation
//! whiteness test, Monte Carlo RMS errors, and the Kalman–Bucy gain against the discrete one.
//!
//! Mechanisms come from the libraries: `model` discretises (ZOH + Van Loan) and gives the
//! poles; `kalman` runs the filter and solves the DARE, the discrete LQR, the CARE and the
//! Kalman–Bucy Riccati ODE. This module only wires them and writes the report.
//!
//! Layout (the same in every scenario): [`parameters`], [`simulation`] (design and one
//! closed-loop run), [`records`] (`runs.csv`, the ground truth), [`summary`] (every number)
//! and [`report`] (formatting only); the Welch PSD, autocorrelation and Ljung–Box test are
//! `kalman::diagnostics`'.
//!
//! **Control law.** `kalman::Filter::step` updates with z_k and then predicts with u_k in
//! one call, so u_k is computed before z_k is processed, from the one-step prediction
//! x̂_{k|k−1} (the "prediction estimator" form, a one-sample computational delay as in a real
//! autopilot): u_k = −L(x̂_{k|k−1} − N_x r_k) + N_u r_k, where (N_x, N_u) solve
//! [[F − I, B], [H, 0]]·[N_x; N_u] = [0; 1] (reference-tracking feedforward: the state N_x r is
//! an equilibrium of the plant under the input N_u r with output r; for the double integrator
//! N_x = (1, 0), N_u = 0). By the separation principle the closed-loop poles are those of
//! F − BL and of the predictor F − K_p H, K_p = F K.

pub mod parameters;
pub mod records;
pub mod report;
pub mod simulation;
pub mod summary;

use std::path::Path;

use crate::campaign::Scenario;
use crate::error::Result;
use crate::montecarlo::Shard;
use parameters::UavParams;
use records::RunRecord;
use simulation::Trace;
use summary::{Computed, UavSummary};

/// The uav scenario, as the campaign runs it.
#[derive(Debug, Clone, Copy)]
pub struct Uav;

impl Scenario for Uav {
    const NAME: &'static str = "uav";
    type Params = UavParams;
    type Records = Vec<RunRecord>;
    type Summary = Computed;
    type Json = UavSummary;
    type Finish = Trace;

    fn simulate(
        params: &UavParams,
        seed: u64,
        shard: Shard,
        threads: Option<usize>,
    ) -> Result<Vec<RunRecord>> {
        simulation::simulate_runs(params, seed, shard, threads)
    }

    fn has_finish(_params: &UavParams) -> bool {
        true
    }

    /// Run 0's trace (one closed-loop simulation), so that a merge simulates nothing.
    fn finish(
        params: &UavParams,
        seed: u64,
        _records: &Vec<RunRecord>,
        _threads: Option<usize>,
    ) -> Result<Trace> {
        summary::trace(params, seed)
    }

    fn summarise(
        params: &UavParams,
        seed: u64,
        _shard: Shard,
        records: &Vec<RunRecord>,
        finish: Option<&Trace>,
        _threads: Option<usize>,
    ) -> Result<Computed> {
        summary::summarise(params, seed, records, finish)
    }

    fn json(summary: &Computed) -> &UavSummary {
        &summary.summary
    }

    fn write_outputs(summary: &Computed, dir: &Path) -> Result<()> {
        report::write_outputs(summary, dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::merge_check::shards_finish_merge;

    /// The closing stage is run 0's one simulation; the merge starts none (run 0's trace is
    /// read from `finish.toml`) and writes the whole run's bytes.
    #[test]
    fn a_merge_reads_and_simulates_nothing() {
        let config = "steps = 1024\nwelch_segment = 64\n";
        let (in_finish, in_merge) = shards_finish_merge::<Uav>("uav", config, 5, 4);
        assert_eq!(in_finish, 1, "the closing stage is run 0");
        assert_eq!(in_merge, 0, "the merge started a simulation");
    }
}
