//! The papers' scenarios by name: `all` runs each of them and `merge` picks the scenario
//! named in the shards' `summary.json`. The only module that knows every scenario; the
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

/// Merges shard directories into `out`; the scenario is the one the first directory's
/// `summary.json` names.
///
/// # Errors
/// As [`campaign::merge`]; [`Error::Invalid`] for an unknown scenario name.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let first = dirs
        .first()
        .ok_or_else(|| Error::Usage("merge needs at least one shard directory".into()))?;
    match campaign::scenario_of(first)?.as_str() {
        "fueling" => campaign::merge::<Fueling>(dirs, out),
        "uav" => campaign::merge::<Uav>(dirs, out),
        "boom" => campaign::merge::<Boom>(dirs, out),
        "flightpath" => campaign::merge::<FlightPath>(dirs, out),
        other => Err(Error::invalid(
            first.join("summary.json"),
            format!(
                "`scenario` is {other:?}, expected \"fueling\", \"uav\", \"boom\" or \"flightpath\""
            ),
        )),
    }
}
