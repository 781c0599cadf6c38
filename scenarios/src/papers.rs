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

/// Every scenario, in the order `all` runs them.
pub const SCENARIOS: [Entry; 4] = [
    Entry::of::<Fueling>("F — fuel level on a rocking sea platform"),
    Entry::of::<Uav>("U — UAV control channel with a Kalman filter in the loop"),
    Entry::of::<Boom>("B — erector-boom angular acceleration (WLS, offset angle)"),
    Entry::of::<FlightPath>(
        "Flight-path reconstruction: filter–smoother and output error on a simulated flight",
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
    (scenario(dirs, "merge")?.merge)(dirs, out)
}

/// Runs the closing stage of the campaign whose shard directories are `dirs` into `out`.
///
/// # Errors
/// As [`campaign::finish`]; [`Error::Invalid`] for an unknown scenario name.
pub fn finish(dirs: &[PathBuf], out: &Path, threads: Option<usize>) -> Result<()> {
    (scenario(dirs, "finish")?.finish)(dirs, out, threads)
}

/// The entry of the scenario named in the first directory's `summary.json`.
fn scenario(dirs: &[PathBuf], command: &str) -> Result<&'static Entry> {
    let first = dirs
        .first()
        .ok_or_else(|| Error::Usage(format!("{command} needs at least one shard directory")))?;
    let name = campaign::scenario_of(first)?;
    SCENARIOS.iter().find(|e| e.name == name).ok_or_else(|| {
        Error::invalid(
            first.join("summary.json"),
            format!(
                "`scenario` is {name:?}, expected \"fueling\", \"uav\", \"boom\" or \"flightpath\""
            ),
        )
    })
}
