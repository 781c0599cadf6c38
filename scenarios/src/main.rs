//! The `scenarios` command-line program: reproduces the papers (`fueling`, `uav`, `boom`,
//! `all`, `merge`) and runs users' own models and data (`filter`, `discretize`,
//! `steady-state`). Exit code 0 on success, 2 for input the user can fix (arguments, input
//! files, an output path that is refused), 1 for I/O and computation failures, 130 after
//! SIGINT/SIGTERM. Every error is one line on stderr naming the culprit.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{Args, Parser, Subcommand};
use scenarios::boom::Boom;
use scenarios::flightpath::FlightPath;
use scenarios::fueling::Fueling;
use scenarios::montecarlo::Shard;
use scenarios::uav::Uav;
use scenarios::{Campaign, Error, ValueError};

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
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = parse_whole::<u64>)]
    seed: u64,
    /// Monte Carlo runs per point (default: the scenario's own).
    #[arg(long, allow_negative_numbers = true, value_parser = parse_count)]
    runs: Option<usize>,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, allow_negative_numbers = true, value_parser = parse_count)]
    threads: Option<usize>,
    /// Run only slice K of N of the Monte Carlo runs; combine slices with `merge`.
    #[arg(long, value_name = "K/N", allow_hyphen_values = true, value_parser = parse_shard)]
    shard: Option<Shard>,
}

/// `flightpath`'s options: a campaign's, and a recorded flight instead of the simulation.
#[derive(Debug, Args)]
struct FlightpathArgs {
    #[command(flatten)]
    campaign: CampaignArgs,
    /// A recorded flight: one CSV with a `t` column [s] and the channels ax, ay, az [m/s²],
    /// p, q, r [rad/s], V [m/s], alpha, beta, phi, theta, psi [rad], north, east, alt [m];
    /// an empty cell where a sensor did not sample. The same report without truth columns.
    #[arg(long, value_name = "FLIGHT.csv")]
    data: Option<PathBuf>,
}

fn parse_shard(s: &str) -> Result<Shard, Error> {
    s.parse::<Shard>()
}

/// A whole number (the error says what is wrong with the text).
fn parse_whole<T: std::str::FromStr>(s: &str) -> Result<T, ValueError> {
    let digits = !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !digits {
        return Err(ValueError::NotWhole);
    }
    s.parse::<T>().map_err(|_| ValueError::TooLarge)
}

/// A count ≥ 1.
fn parse_count(s: &str) -> Result<usize, ValueError> {
    match parse_whole::<usize>(s)? {
        0 => Err(ValueError::Zero),
        n => Ok(n),
    }
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Paper F: fuel level on a rocking sea platform (relay logic vs one- and two-channel KF).
    Fueling(CampaignArgs),
    /// Paper U: UAV control channel with a discrete Kalman filter in the loop.
    Uav(CampaignArgs),
    /// Paper B: erector-boom angular acceleration by weighted least squares and offset angle.
    Boom(CampaignArgs),
    /// Flight-path reconstruction: filter–smoother and output error of the instrument errors
    /// on a simulated flight, or on a recorded one with --data.
    Flightpath(FlightpathArgs),
    /// All the scenarios (the three papers and flightpath), plus reports/README.md linking them.
    All(CampaignArgs),
    /// Run a sharded campaign's closing stage (the fueling calibration's refinement and
    /// learned-back fit, the uav run-0 trace) over its shard directories; give its output
    /// to `merge`.
    Finish {
        /// Shard output directories of one scenario.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Where to write the stage's file.
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Combine shard directories (`--shard K/N` runs) and the output of `finish` into the
    /// summary of one whole run (reads and formats only).
    Merge {
        /// Shard output directories of one scenario, and the output of `finish`.
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
    /// Learn a model's noise and free entries from data: a discrete model (mle or EM) or a
    /// continuous one over the record's own time stamps (mle).
    Fit(scenarios::fit::FitArgs),
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

/// Checks the output directory of the commands that write one: `--out -` is refused (standard
/// output takes one file), and `merge --out` must not be one of the shard directories.
fn check_directory_out(command: &Command) -> Result<(), Error> {
    let (name, out) = match command {
        Command::Fueling(a) => ("fueling", a.out.as_ref()),
        Command::Uav(a) => ("uav", a.out.as_ref()),
        Command::Boom(a) => ("boom", a.out.as_ref()),
        Command::Flightpath(a) => ("flightpath", a.campaign.out.as_ref()),
        Command::All(a) => ("all", a.out.as_ref()),
        Command::Merge { out, .. } => ("merge", Some(out)),
        Command::Finish { out, .. } => ("finish", Some(out)),
        Command::Filter(_) | Command::Discretize(_) | Command::SteadyState(_) | Command::Fit(_) => {
            return Ok(());
        }
    };
    let Some(out) = out else { return Ok(()) };
    if out.as_os_str() == "-" {
        return Err(Error::Usage(format!(
            "--out -: {name} writes a directory of files; standard output (-) is only for \
             filter, discretize and steady-state"
        )));
    }
    if let Command::Merge { dirs, .. } | Command::Finish { dirs, .. } = command
        && let Some(dir) = dirs
            .iter()
            .find(|d| scenarios::output::same_file(d.as_path(), out.as_path()))
    {
        return Err(Error::Usage(format!(
            "--out {}: is the shard directory {}; refusing to overwrite an input",
            out.display(),
            dir.display()
        )));
    }
    Ok(())
}

/// The option name of a clap argument as it renders (`--shard <K/N>` → `--shard`).
fn option_name(rendered: &str) -> String {
    rendered
        .split_once(' ')
        .map_or(rendered, |(name, _)| name)
        .to_string()
}

fn context_strings(e: &clap::Error, kind: ContextKind) -> Vec<String> {
    match e.get(kind) {
        Some(ContextValue::String(s)) => vec![s.clone()],
        Some(ContextValue::Strings(v)) => v.clone(),
        _ => Vec::new(),
    }
}

/// `a`, `a or b`, `a, b or c` (with `and` for `conjunction = "and"`).
fn list(items: &[String], conjunction: &str) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} {conjunction} {last}", init.join(", ")),
    }
}

fn either(items: &[String]) -> String {
    list(items, "or")
}

/// The parser's error as one line naming the argument (clap's own is error, usage and hint
/// on several lines).
fn one_line(e: &clap::Error) -> String {
    let arg = context_strings(e, ContextKind::InvalidArg)
        .iter()
        .map(|a| option_name(a))
        .collect::<Vec<_>>();
    let args = list(&arg, "and");
    let arg = either(&arg);
    let value = context_strings(e, ContextKind::InvalidValue).join(" ");
    let valid = either(&context_strings(e, ContextKind::ValidValue));
    let suggestion = {
        let mut s = context_strings(e, ContextKind::SuggestedArg);
        s.extend(context_strings(e, ContextKind::SuggestedSubcommand));
        s.extend(context_strings(e, ContextKind::SuggestedValue));
        if s.is_empty() {
            String::new()
        } else {
            format!(" (did you mean {}?)", either(&s))
        }
    };
    let commands =
        "fueling, uav, boom, flightpath, all, merge, filter, discretize, steady-state or fit";
    match e.kind() {
        ErrorKind::ValueValidation => {
            let why = std::error::Error::source(e).map_or_else(String::new, ToString::to_string);
            format!("{arg} {value}: {why}")
        }
        ErrorKind::InvalidValue if value.is_empty() => format!("{arg}: a value is required"),
        ErrorKind::InvalidValue => format!("{arg} {value}: expected {valid}{suggestion}"),
        ErrorKind::UnknownArgument => format!("unknown argument {arg}{suggestion}"),
        ErrorKind::InvalidSubcommand => {
            let cmd = context_strings(e, ContextKind::InvalidSubcommand).join(" ");
            format!("unknown command {cmd}: expected {commands}{suggestion}")
        }
        ErrorKind::MissingRequiredArgument => format!("{args}: required but not given"),
        ErrorKind::MissingSubcommand | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            format!("a command is required: {commands} (see scenarios --help)")
        }
        ErrorKind::ArgumentConflict => {
            let prior = either(&context_strings(e, ContextKind::PriorArg));
            format!("{arg}: cannot be used with {prior}")
        }
        _ => {
            // Any other kind: clap's first line, without its `error: ` prefix.
            let text = e.render().to_string();
            let first = text.lines().next().unwrap_or("invalid arguments");
            first.strip_prefix("error: ").unwrap_or(first).to_string()
        }
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) => {
            e.exit()
        }
        Err(e) => {
            eprintln!("scenarios: {}", one_line(&e).replace(['\n', '\r'], " "));
            return ExitCode::from(2);
        }
    };
    if let Err(err) = scenarios::output::remove_partial_files_on_interrupt() {
        eprintln!("scenarios: {err}");
        return ExitCode::from(err.exit_code());
    }
    if let Err(err) = check_directory_out(&cli.command) {
        eprintln!("scenarios: {err}");
        return ExitCode::from(err.exit_code());
    }
    let outcome: Result<(), Error> = match cli.command {
        Command::Fueling(a) => scenarios::campaign::run::<Fueling>(&a.campaign()),
        Command::Uav(a) => scenarios::campaign::run::<Uav>(&a.campaign()),
        Command::Boom(a) => scenarios::campaign::run::<Boom>(&a.campaign()),
        Command::Flightpath(a) => match a.data {
            Some(data) => scenarios::flightpath::userflight::run(
                &data,
                a.campaign.config.as_deref(),
                a.campaign.out.as_deref(),
            ),
            None => scenarios::campaign::run::<FlightPath>(&a.campaign.campaign()),
        },
        Command::All(a) => scenarios::papers::all(&a.campaign()),
        Command::Merge { dirs, out } => scenarios::papers::merge(&dirs, &out),
        Command::Finish { dirs, out, threads } => scenarios::papers::finish(&dirs, &out, threads),
        Command::Filter(a) => scenarios::userdata::filter(&a),
        Command::Discretize(a) => scenarios::userdata::discretize(&a),
        Command::SteadyState(a) => scenarios::userdata::steady_state(&a),
        Command::Fit(a) => scenarios::fit::fit(&a),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            // One line whatever a message holds (a path or a library's text may not).
            let text = err.to_string().replace(['\n', '\r'], " ");
            eprintln!("scenarios: {text}");
            ExitCode::from(err.exit_code())
        }
    }
}
