//! The `fueling` scenario (SPEC F): when to stop fuelling a launch-vehicle tank on a rocking
//! sea platform. Relay logic, a one-channel Kalman filter and three two-channel filters decide
//! the stop from the same simulated world; Monte Carlo sweeps over tilt amplitude (the paper's
//! Fig. 1), rolling period, fill rate and damper time constant, and an amplitude × period
//! invariance table, give each strategy's systematic (mean) and random (std) fuelling error.
//!
//! Layout (the same in every scenario): [`parameters`] (the TOML-overridable defaults and the
//! sweeps they define), [`simulation`] (one run: truth world + strategies; the campaign's
//! slice of runs), [`records`] (per-run outcomes, `runs_<sweep>.csv`, full-precision `f64`:
//! the ground truth), [`summary`] (every number, from the records alone) and [`report`]
//! (CSV, SVG and `report.md`, formatting only). [`statistics`] gives every ratio its interval
//! and every strategy its tail; [`calibration`] searches [`search`]'s box for the parameters
//! the paper does not state (its own simulations: the design sharded with the runs, the
//! refinement in the closing stage, [`Closing`]); [`learned`] fits the paper's model back to
//! one simulated record (in the closing stage too). [`Fueling`] ties them to the campaign.

pub mod calibration;
pub mod calibration_records;
pub mod calibration_report;
pub mod learned;
pub mod parameters;
pub mod particle;
mod plots;
pub mod records;
pub mod report;
pub mod search;
pub mod simulation;
pub mod statistics;
pub mod summary;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::campaign::{Scenario, ScenarioParams};
use crate::error::{Error, Result};
use crate::montecarlo::Shard;
use parameters::FuelingParams;
use records::FuelingRecords;
use summary::Summary;

/// The paper's random-error ratios to relay logic (one-channel, two-channel) the
/// calibration aims at.
const PAPER: (f64, f64) = (summary::PAPER_KF1_RATIO, summary::PAPER_KF2_RATIO);

/// The fueling campaign's closing stage ([`Scenario::finish`]): the calibration's
/// refinement after its whole design, and the paper's model learned back from one record.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Closing {
    /// The refinement, sensitivity and fresh evaluation (absent when the search is off).
    pub calibration: Option<calibration_records::Refinement>,
    /// The learned-back fit.
    pub learned: Option<learned::LearnedBack>,
}

/// The fueling scenario, as the campaign runs it.
#[derive(Debug, Clone, Copy)]
pub struct Fueling;

impl Scenario for Fueling {
    const NAME: &'static str = "fueling";
    type Params = FuelingParams;
    type Records = FuelingRecords;
    type Summary = Summary;
    type Json = Summary;
    type Finish = Closing;

    fn set_runs(params: &mut FuelingParams, runs: usize) -> Result<()> {
        if runs < 2 {
            return Err(Error::Usage(format!(
                "--runs {runs}: the fueling scenario needs at least 2 runs per point"
            )));
        }
        params.set_runs(runs);
        Ok(())
    }

    fn simulate(
        params: &FuelingParams,
        seed: u64,
        shard: Shard,
        threads: Option<usize>,
    ) -> Result<FuelingRecords> {
        Ok(FuelingRecords {
            sweeps: simulation::simulate(params, seed, shard, threads)?,
            particle: particle::simulate(params, seed, shard, threads)?,
            design: calibration::design(params, seed, shard, threads, PAPER)?
                .iter()
                .map(calibration_records::DesignRecord::to_row)
                .collect(),
        })
    }

    fn has_finish(_params: &FuelingParams) -> bool {
        true
    }

    fn finish(
        params: &FuelingParams,
        seed: u64,
        records: &FuelingRecords,
        threads: Option<usize>,
    ) -> Result<Closing> {
        Ok(Closing {
            calibration: calibration::refine(
                params,
                seed,
                &calibration_records::design_from_table(&records.design)?,
                threads,
                PAPER,
            )?,
            learned: Some(learned::learn_back(params, seed)?),
        })
    }

    fn summarise(
        params: &FuelingParams,
        seed: u64,
        shard: Shard,
        records: &FuelingRecords,
        finish: Option<&Closing>,
        _threads: Option<usize>,
    ) -> Result<Summary> {
        let mut summary = summary::summarise(params, seed, shard, records)?;
        if let Some(f) = finish {
            summary.calibration = calibration::assemble(
                params,
                seed,
                &calibration_records::design_from_table(&records.design)?,
                f.calibration.as_ref(),
                PAPER,
            )?;
            summary.learned.clone_from(&f.learned);
        }
        Ok(summary)
    }

    fn json(summary: &Summary) -> &Summary {
        summary
    }

    fn write_outputs(summary: &Summary, dir: &Path) -> Result<()> {
        report::write_outputs(summary, dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::merge_check::shards_finish_merge;

    #[test]
    fn a_merge_reads_and_simulates_nothing() {
        let mut params = FuelingParams {
            amplitudes_deg: vec![0.0, 1.0],
            periods_s: vec![10.0],
            fill_rates_mm_s: vec![10.0],
            damper_times_s: vec![2.0],
            invariance_amplitudes_deg: vec![1.0],
            invariance_periods_s: vec![10.0],
            steps_mm: vec![10.0],
            ..FuelingParams::default()
        };
        params.calibration.design_sets = Some(3);
        params.calibration.runs_per_set = Some(4);
        params.calibration.refine_iterations = Some(2);
        params.particle.runs = 2;
        let config = toml::to_string(&params).expect("toml");
        let (in_finish, in_merge) = shards_finish_merge::<Fueling>("fueling", &config, 11, 4);
        assert!(in_finish > 0, "the closing stage simulates");
        assert_eq!(in_merge, 0, "the merge started a simulation");
    }
}
