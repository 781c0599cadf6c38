//! Integration tests of the `sensors` crate: statistics of every process against its theory,
//! reproducibility, and each sensor against its defining formulas (issue 7 "Done when").

#[path = "sensors/accel.rs"]
mod accel;
#[path = "sensors/config.rs"]
mod config;
#[path = "sensors/instruments.rs"]
mod instruments;
#[path = "sensors/level.rs"]
mod level;
#[path = "sensors/platform.rs"]
mod platform;
#[path = "sensors/processes.rs"]
mod processes;
#[path = "sensors/props.rs"]
mod props;
#[path = "sensors/stats.rs"]
mod stats;
