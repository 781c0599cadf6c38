//! The `uav` scenario (being built).

use std::path::{Path, PathBuf};

use crate::Campaign;
use crate::error::{Error, Result};

/// Runs the scenario into `campaign.out_dir("uav")`.
pub fn run(campaign: &Campaign) -> Result<()> {
    let _ = campaign;
    Err(Error::Compute("the uav scenario is not built yet".into()))
}

/// Merges shard directories of this scenario into `out`.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let _ = (dirs, out);
    Err(Error::Compute("merging uav shards is not built yet".into()))
}
