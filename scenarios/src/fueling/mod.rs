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
//! and every strategy its tail; [`calibration`] searches [`search`]'s box for the parameters the paper does not
//! state (its own simulations, not sharded); [`learned`] fits the paper's model back to one
//! simulated record (not sharded either). [`Fueling`] ties them to the campaign.

pub mod calibration;
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

use crate::campaign::{Scenario, ScenarioParams};
use crate::error::{Error, Result};
use crate::montecarlo::Shard;
use parameters::FuelingParams;
use records::FuelingRecords;
use summary::Summary;

/// The fueling scenario, as the campaign runs it.
#[derive(Debug, Clone, Copy)]
pub struct Fueling;

impl Scenario for Fueling {
    const NAME: &'static str = "fueling";
    type Params = FuelingParams;
    type Records = FuelingRecords;
    type Summary = Summary;
    type Json = Summary;

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
        })
    }

    fn summarise(
        params: &FuelingParams,
        seed: u64,
        shard: Shard,
        records: &FuelingRecords,
        threads: Option<usize>,
    ) -> Result<Summary> {
        let mut summary = summary::summarise(params, seed, shard, records)?;
        // Not sharded: a function of (params, seed) alone, computed by a whole run and by
        // `merge` alike, skipped by a shard (see `calibration`).
        if shard == Shard::ALL {
            summary.calibration = calibration::calibrate(
                params,
                seed,
                threads,
                (summary::PAPER_KF1_RATIO, summary::PAPER_KF2_RATIO),
            )?;
            summary.learned = Some(learned::learn_back(params, seed)?);
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
