//! The `scenarios` command-line program: reproduces the papers (`fueling`, `uav`, `boom`,
//! `all`, `merge`) and runs users' own models and data (`filter`, `discretize`,
//! `steady-state`). Exit code 0 on success, 2 for input the user can fix, 1 otherwise.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use scenarios::fueling::Fueling;
use scenarios::montecarlo::Shard;
use scenarios::uav::Uav;
use scenarios::{Campaign, Error};

/// Stochastic estimation for launch and flight-test measurement: the papers' scenarios and
/// the engine's front door for recorded data.
#[derive(Debug, Parser)]
#[command(name = "scenarios", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Options shared by the paper scenarios.
#[derive(Debug, Args)]
struct CampaignArgs {
    /// TOML file overriding the scenario's default parameters (unknown keys are an error).
    #[arg(long, value_name = "FILE.toml")]
    config: Option<PathBuf>,
    /// Output directory (default: reports/<scenario>, or reports/ for `all`).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Campaign seed; run i draws from a stream derived from (seed, i) alone.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Monte Carlo runs per point (default: the scenario's own).
    #[arg(long)]
    runs: Option<usize>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long)]
    threads: Option<usize>,
    /// Run only slice K of N of the Monte Carlo runs; combine slices with `merge`.
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    shard: Option<Shard>,
}

fn parse_shard(s: &str) -> Result<Shard, String> {
    s.parse::<Shard>().map_err(|e| e.to_string())
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Paper F: fuel level on a rocking sea platform (relay logic vs one- and two-channel KF).
    Fueling(CampaignArgs),
    /// Paper U: UAV control channel with a discrete Kalman filter in the loop.
    Uav(CampaignArgs),
    /// Paper B: erector-boom angular acceleration by weighted least squares and offset angle.
    Boom(CampaignArgs),
    /// All three papers, plus reports/README.md linking them.
    All(CampaignArgs),
    /// Combine shard directories (`--shard K/N` runs) into the summary of one whole run.
    Merge {
        /// Shard output directories of one scenario.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Where to write the merged report.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
    },
    /// Filter (or smooth) recorded data with a discrete model.
    Filter(scenarios::userdata::FilterArgs),
    /// Discretise a continuous model.
    Discretize(scenarios::userdata::DiscretizeArgs),
    /// Steady-state covariance and gain of a discrete model (DARE).
    SteadyState(scenarios::userdata::SteadyStateArgs),
}

impl CampaignArgs {
    fn campaign(self) -> Campaign {
        Campaign {
            config: self.config,
            out: self.out,
            seed: self.seed,
            runs: self.runs,
            threads: self.threads,
            shard: self.shard.unwrap_or(Shard::ALL),
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let outcome: Result<(), Error> = match cli.command {
        Command::Fueling(a) => scenarios::campaign::run::<Fueling>(&a.campaign()),
        Command::Uav(a) => scenarios::campaign::run::<Uav>(&a.campaign()),
        Command::Boom(a) => scenarios::boom::run(&a.campaign()),
        Command::All(a) => scenarios::papers::all(&a.campaign()),
        Command::Merge { dirs, out } => scenarios::papers::merge(&dirs, &out),
        Command::Filter(a) => scenarios::userdata::filter(&a),
        Command::Discretize(a) => scenarios::userdata::discretize(&a),
        Command::SteadyState(a) => scenarios::userdata::steady_state(&a),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("scenarios: {err}");
            ExitCode::from(err.exit_code())
        }
    }
}
