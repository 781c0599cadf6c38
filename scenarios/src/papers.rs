//! The papers' scenarios by name: `all` runs each of them, and `finish` and `merge` pick the
//! scenario named in the shards' `summary.json`. The only module that knows every scenario; the
//! campaign machinery itself ([`crate::campaign`]) knows none.

use std::path::{Path, PathBuf};

use crate::boom::Boom;
use crate::campaign::{self, Campaign, Entry};
use crate::error::{Error, Result};
use crate::flightpath::FlightPath;
use crate::fueling::Fueling;
use crate::uav::Uav;

/// Every scenario: name (subcommand and folder), title for `reports/README.md`, runner.
pub const SCENARIOS: [Entry; 4] = [
    (
        "fueling",
        "F — fuel level on a rocking sea platform",
        campaign::run::<Fueling>,
    ),
    (
        "uav",
        "U — UAV control channel with a Kalman filter in the loop",
        campaign::run::<Uav>,
    ),
    (
        "boom",
        "B — erector-boom angular acceleration (WLS, offset angle)",
        campaign::run::<Boom>,
    ),
    (
        "flightpath",
        "Flight-path reconstruction: filter–smoother and output error on a simulated flight",
        campaign::run::<FlightPath>,
    ),
];

/// Runs every scenario into `<out>/<name>` and writes `<out>/README.md` linking their
/// reports.
///
/// # Errors
/// As [`campaign::run_all`].
pub fn all(campaign: &Campaign) -> Result<()> {
    campaign::run_all(campaign, &SCENARIOS)
}

/// Merges shard directories (and the output of `finish`) into `out`; the scenario is the one
/// the first directory's `summary.json` names.
///
/// # Errors
/// As [`campaign::merge`]; [`Error::Invalid`] for an unknown scenario name.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<()> {
    match scenario(dirs, "merge")? {
        "fueling" => campaign::merge::<Fueling>(dirs, out),
        "uav" => campaign::merge::<Uav>(dirs, out),
        "boom" => campaign::merge::<Boom>(dirs, out),
        _ => campaign::merge::<FlightPath>(dirs, out),
    }
}

/// Runs the closing stage of the campaign whose shard directories are `dirs` into `out`.
///
/// # Errors
/// As [`campaign::finish`]; [`Error::Invalid`] for an unknown scenario name.
pub fn finish(dirs: &[PathBuf], out: &Path, threads: Option<usize>) -> Result<()> {
    match scenario(dirs, "finish")? {
        "fueling" => campaign::finish::<Fueling>(dirs, out, threads),
        "uav" => campaign::finish::<Uav>(dirs, out, threads),
        "boom" => campaign::finish::<Boom>(dirs, out, threads),
        _ => campaign::finish::<FlightPath>(dirs, out, threads),
    }
}

/// The scenario named in the first directory's `summary.json`, one of [`SCENARIOS`].
fn scenario(dirs: &[PathBuf], command: &str) -> Result<&'static str> {
    let first = dirs
        .first()
        .ok_or_else(|| Error::Usage(format!("{command} needs at least one shard directory")))?;
    let name = campaign::scenario_of(first)?;
    SCENARIOS
        .iter()
        .map(|(n, _, _)| *n)
        .find(|n| *n == name)
        .ok_or_else(|| {
            Error::invalid(
                first.join("summary.json"),
                format!(
                    "`scenario` is {name:?}, expected \"fueling\", \"uav\", \"boom\" or \"flightpath\""
                ),
            )
        })
}
