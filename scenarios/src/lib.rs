//! Reproduction of the three source papers, and the front door for users' own models and data.
//!
//! The `scenarios` binary (see `main.rs`) is a thin clap layer over this library:
//!
//! | module | what it owns |
//! |---|---|
//! | [`fueling`] | paper F: Monte Carlo of the fuelling stop command (relay logic against one- and two-channel Kalman filters), sweeps, fits, report |
//! | [`uav`] | paper U: the UAV channel's closed loop (LQR + discrete Kalman filter), Welch spectra at four nodes, whiteness test, Kalman–Bucy check |
//! | [`boom`] | paper B: the erector-boom estimators over the turn, ±Δa variants, γ sweep, units/weights study |
//! | [`userdata`] | `filter`, `discretize`, `steady-state` on users' own model files and CSV logs |
//! | [`fit`] | `fit`: Q, R, x0, P0 of a user's model file learned from a CSV log (MLE or EM) |
//! | [`output`] | whole-or-nothing file writing (temporary name, then rename), CSV/JSON |
//! | [`plot`] | the one SVG line-plot function every report uses |
//! | [`campaign`] | what every scenario does, written once: the [`campaign::Scenario`] trait, `run`, `merge`, `all`, checked run-record files |
//! | [`papers`] | the three scenarios by name, for `all` and `merge` |
//! | [`montecarlo`] | per-run seeds, `--shard K/N` slices, parallel runs with a progress bar |
//! | [`config`] | TOML parameter overrides that reject unknown keys by name |
//! | [`error`] | the CLI's typed error; exit code 2 for anything the user can fix |
//!
//! The scenarios compute nothing the libraries own: models come from `model`, filtering and
//! Riccati equations from `kalman`, least squares from `wls`, the simulated world from
//! `sensors`. Every random stream derives from `(seed, run index)` alone, so results do not
//! depend on the number of threads, and summaries are recomputed from per-run records, so a
//! sharded campaign merges into the same bytes.
#![deny(missing_docs)]

pub mod boom;
pub mod campaign;
pub mod config;
pub mod error;
pub mod fit;
pub mod flightpath;
pub mod fueling;
pub mod montecarlo;
pub mod output;
pub mod papers;
pub mod plot;
pub mod uav;
pub mod userdata;

pub use campaign::Campaign;
pub use error::{Error, ValueError};

/// The README's and the guide's Rust snippets, compiled and run as this crate's doc tests
/// (`cargo test --doc`): the crate depends on every library the snippets use, so a snippet
/// that stops matching the code fails the test command.
#[cfg(doctest)]
mod guide {
    #[doc = include_str!("../../README.md")]
    struct Readme;
    #[doc = include_str!("../../docs/getting-started.md")]
    struct GettingStarted;
    #[doc = include_str!("../../docs/records.md")]
    struct Records;
    #[doc = include_str!("../../docs/library.md")]
    struct Library;
    #[doc = include_str!("../../docs/fitting.md")]
    struct Fitting;
    #[doc = include_str!("../../docs/nonlinear.md")]
    struct Nonlinear;
    #[doc = include_str!("../../docs/particles.md")]
    struct Particles;
    #[doc = include_str!("../../docs/imm.md")]
    struct Imm;
    #[doc = include_str!("../../docs/cli.md")]
    struct Cli;
    #[doc = include_str!("../../docs/python.md")]
    struct Python;
    #[doc = include_str!("../../docs/filterpy.md")]
    struct FilterPy;
    #[doc = include_str!("../../docs/papers.md")]
    struct Papers;
    #[doc = include_str!("../../docs/math.md")]
    struct Math;
}
