//! The `flightpath` scenario: flight-path reconstruction and data-compatibility checking.
//! A simulated flight (`sensors::flight`: IMU, air data, AHRS and GNSS with instrument
//! errors, jittered stamps, dropouts and wild points) or a user's recorded flight is
//! checked for kinematic consistency by two estimators side by side: the EKF with the
//! instrument errors as augmented states followed by the extended RTS smoother, iterated
//! once on the model linearised about its smoothed trajectory, and the
//! output-error maximum-likelihood fit of the same errors with Cramér–Rao bounds
//! (`kalman::fit::output_error`).
//!
//! Layout: [`model`] (the kinematic equations as a `GenericModel`), [`data`] (records and
//! the filter's grid), [`smoother`] (the gated EKF + RTS, and its linearised pass), [`estimate`] (both estimators on
//! one record), then the campaign's files as in every scenario: [`parameters`],
//! [`records`], [`simulation`], [`summary`], [`report`].

pub mod data;
pub mod estimate;
pub mod model;
pub mod parameters;
pub mod records;
pub mod report;
pub mod simulation;
pub mod smoother;
pub mod summary;
pub mod userflight;

use std::path::Path;

use crate::campaign::Scenario;
use crate::error::Result;
use crate::montecarlo::Shard;
use parameters::FlightPathParams;
use records::RunRecord;
use summary::{Computed, FlightPathSummary};

/// The flightpath scenario, as the campaign runs it.
#[derive(Debug, Clone, Copy)]
pub struct FlightPath;

impl Scenario for FlightPath {
    const NAME: &'static str = "flightpath";
    type Params = FlightPathParams;
    type Records = Vec<RunRecord>;
    type Summary = Computed;
    type Json = FlightPathSummary;
    type Finish = ();

    fn simulate(
        params: &FlightPathParams,
        seed: u64,
        shard: Shard,
        threads: Option<usize>,
    ) -> Result<Vec<RunRecord>> {
        simulation::simulate_runs(params, seed, shard, threads)
    }

    fn summarise(
        params: &FlightPathParams,
        seed: u64,
        _shard: Shard,
        records: &Vec<RunRecord>,
        _finish: Option<&()>,
        _threads: Option<usize>,
    ) -> Result<Computed> {
        summary::summarise(params, seed, records)
    }

    fn json(summary: &Computed) -> &FlightPathSummary {
        &summary.summary
    }

    fn write_outputs(summary: &Computed, dir: &Path) -> Result<()> {
        report::write_outputs(summary, dir)
    }
}

#[cfg(test)]
mod tests;
