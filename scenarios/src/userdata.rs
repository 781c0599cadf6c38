//! Users' own models and recorded data through the engine (being built).

use crate::error::{Error, Result};

/// Options of `scenarios filter`.
#[derive(Debug, clap::Args)]
pub struct FilterArgs {}

/// Options of `scenarios discretize`.
#[derive(Debug, clap::Args)]
pub struct DiscretizeArgs {}

/// Options of `scenarios steady-state`.
#[derive(Debug, clap::Args)]
pub struct SteadyStateArgs {}

/// `scenarios filter`.
pub fn filter(args: &FilterArgs) -> Result<()> {
    let _ = args;
    Err(Error::Compute("filter is not built yet".into()))
}

/// `scenarios discretize`.
pub fn discretize(args: &DiscretizeArgs) -> Result<()> {
    let _ = args;
    Err(Error::Compute("discretize is not built yet".into()))
}

/// `scenarios steady-state`.
pub fn steady_state(args: &SteadyStateArgs) -> Result<()> {
    let _ = args;
    Err(Error::Compute("steady-state is not built yet".into()))
}
