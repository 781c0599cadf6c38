//! The `scenarios` crate's one integration-test binary: drives the built `scenarios`
//! program (and its library) per command family, one submodule each under `tests/cli/`
//! (a test crate's root resolves `mod x;` to `tests/x.rs`, hence the `#[path]`s).

#[path = "cli/boom.rs"]
mod boom;
#[path = "cli/common.rs"]
mod common;
#[path = "cli/diagnostics.rs"]
mod diagnostics;
#[path = "cli/fit.rs"]
mod fit;
#[path = "cli/fit_continuous.rs"]
mod fit_continuous;
#[path = "cli/fit_entries.rs"]
mod fit_entries;
#[path = "cli/flightpath.rs"]
mod flightpath;
#[path = "cli/flightpath_output_error.rs"]
mod flightpath_output_error;
#[path = "cli/fueling.rs"]
mod fueling;
#[path = "cli/hostile.rs"]
mod hostile;
#[path = "cli/input_errors.rs"]
mod input_errors;
#[path = "cli/irregular.rs"]
mod irregular;
#[path = "cli/output_safety.rs"]
mod output_safety;
#[path = "cli/plots.rs"]
mod plots;
#[path = "cli/steady.rs"]
mod steady;
#[path = "cli/transcripts.rs"]
mod transcripts;
#[path = "cli/uav.rs"]
mod uav;
#[path = "cli/userdata.rs"]
mod userdata;
