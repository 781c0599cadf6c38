//! `cargo xtask`: the project's automation, one binary with one subcommand per task.
//!
//! Every task shells out to `$CARGO` from the workspace root found through
//! `CARGO_MANIFEST_DIR`, so it behaves the same from any working directory.

mod bench;
mod examples;
mod guide;
mod homes;
mod mutants;
mod notation;
mod python;
mod tidy;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{Context, Result, bail};

/// The subcommands with their one-line descriptions, in the order `--help` lists them.
const TASKS: &[(&str, &str)] = &[
    (
        "test",
        "run every crate's tests, property tests, doc tests, tidy and the Python package's \
         tests (needs Python 3.11+) [--proptest-cases N]",
    ),
    (
        "python",
        "build the Python package into a cached venv and run its pytest suite (part of `test`)",
    ),
    (
        "bench",
        "run the criterion benchmarks and print the ratios against each in-run baseline [--quick]",
    ),
    (
        "reproduce",
        "reproduce the three papers' results into reports/ (`scenarios all`)",
    ),
    (
        "ci",
        "fmt check, clippy -D warnings, docs with warnings denied, then `test`",
    ),
    (
        "docs",
        "build the guide (docs/, an mdBook) into target/guide/, installing mdbook if missing",
    ),
    (
        "tidy",
        "check file headers, trailing whitespace and manifest rules",
    ),
    (
        "doc-examples",
        "list the library items without a compiled doc example and the share with one",
    ),
    (
        "fuzz",
        "run the cargo-fuzz targets for the model and CSV parsers [--seconds N]",
    ),
    (
        "mutants",
        "sampled mutation testing of the library crates (cargo-mutants; not in CI) \
         [--crate C] [--file F] [--shard K/N] [--re REGEX] [--timeout S] [--target-dir D] [--skip-baseline] [--list]",
    ),
];

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(task) = args.first() else {
        print_help();
        return ExitCode::from(2);
    };
    let rest = &args[1..];
    let outcome = match task.as_str() {
        "-h" | "--help" | "help" => {
            print_help();
            return ExitCode::SUCCESS;
        }
        "test" => test(rest),
        "python" => known(rest, &[], &[]).and_then(|()| python::test()),
        "bench" => bench::bench(rest),
        "reproduce" => reproduce(rest),
        "ci" => ci(rest),
        "docs" => known(rest, &[], &[]).and_then(|()| guide::docs()),
        "tidy" => tidy_task(),
        "doc-examples" => doc_examples(),
        "fuzz" => fuzz(rest),
        "mutants" => mutants::mutants(rest),
        other => {
            eprintln!("xtask: unknown subcommand `{other}`\n");
            print_help();
            return ExitCode::from(2);
        }
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("xtask: {err:#}");
            ExitCode::FAILURE
        }
    }
}

fn print_help() {
    println!("usage: cargo xtask <subcommand> [options]\n\nsubcommands:");
    for (name, what) in TASKS {
        println!("  {name:<10} {what}");
    }
}

/// The workspace root: the parent of this crate's manifest directory.
pub(crate) fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// A `cargo` command rooted at the workspace.
pub(crate) fn cargo() -> Command {
    let mut cmd = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    cmd.current_dir(root());
    cmd
}

/// Runs a command, failing with its rendering if it does not exit 0.
pub(crate) fn run(mut cmd: Command) -> Result<()> {
    let shown = format!("{cmd:?}");
    eprintln!("$ {shown}");
    let status = cmd
        .status()
        .with_context(|| format!("could not start {shown}"))?;
    if !status.success() {
        bail!("{shown} failed with {status}");
    }
    Ok(())
}

/// Parses `--name VALUE` from `args`, if present.
fn option<'a>(args: &'a [String], name: &str) -> Result<Option<&'a str>> {
    match args.iter().position(|a| a == name) {
        None => Ok(None),
        Some(i) => args
            .get(i + 1)
            .map(|v| Some(v.as_str()))
            .with_context(|| format!("{name} needs a value")),
    }
}

/// Rejects arguments that a task does not know.
fn known(args: &[String], flags: &[&str], options: &[&str]) -> Result<()> {
    let mut i = 0;
    while i < args.len() {
        let a = args[i].as_str();
        if options.contains(&a) {
            i += 2;
        } else if flags.contains(&a) {
            i += 1;
        } else {
            bail!("unknown argument `{a}`");
        }
    }
    Ok(())
}

/// The packages `cargo test` builds: the workspace without the Python extension, which has no
/// Rust tests (its suite is pytest, run by `python::test`) and which maturin builds anew with
/// its own flags, and without the benchmarks, whose criterion dependency would only cost build
/// time (clippy checks them; `cargo xtask bench` runs them).
const RUST_TESTED: [&str; 5] = [
    "--workspace",
    "--exclude",
    "launch-estimation-python",
    "--exclude",
    "stochest-benches",
];

fn test(args: &[String]) -> Result<()> {
    known(args, &[], &["--proptest-cases"])?;
    let cases = option(args, "--proptest-cases")?.unwrap_or("256");
    let cases: u32 = cases
        .parse()
        .with_context(|| format!("--proptest-cases takes a whole number, not `{cases}`"))?;
    tidy_task()?;
    // Unit, integration and property tests of every crate with every feature, so the
    // `proptest` strategy features are exercised too. Benches are built (not run) by clippy.
    let mut cmd = cargo();
    cmd.args(["test"])
        .args(RUST_TESTED)
        .args(["--all-features", "--lib", "--bins", "--tests"])
        .env("PROPTEST_CASES", cases.to_string());
    run(cmd)?;
    let mut cmd = cargo();
    cmd.args(["test"])
        .args(RUST_TESTED)
        .args(["--all-features", "--doc"]);
    run(cmd)?;
    downstream()?;
    python::test()
}

/// Builds and runs `tests/downstream`, a user's project outside the workspace that depends on
/// the library crates by path with only the features a user enables. It shares the
/// workspace's target directory, so only the project itself is compiled anew.
fn downstream() -> Result<()> {
    let target =
        std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), PathBuf::from);
    let mut cmd = cargo();
    cmd.args(["test", "--manifest-path"])
        .arg(root().join("tests/downstream/Cargo.toml"))
        .env("CARGO_TARGET_DIR", target);
    run(cmd).context("the downstream user project (tests/downstream)")
}

fn reproduce(args: &[String]) -> Result<()> {
    // Progress as plain lines with the elapsed time (readable in a log as on a terminal):
    // the build, then one line per scenario from `scenarios all`, then where the reports are.
    let start = std::time::Instant::now();
    let stamp = |what: &str| {
        let s = start.elapsed().as_secs();
        eprintln!("reproduce: [{:>2} min {:>2} s] {what}", s / 60, s % 60);
    };
    stamp("building the scenarios program (release; several minutes on a cold build)");
    let mut cmd = cargo();
    cmd.args(["build", "--release", "--quiet", "--package", "scenarios"]);
    run(cmd).context("building the scenarios program")?;
    stamp("built; running `scenarios all` (fueling, uav, boom, flightpath)");
    // Where the index is: `reports/`, or the `--out` given among `args`.
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map_or_else(|| root().join("reports"), PathBuf::from);
    let mut cmd = cargo();
    cmd.args([
        "run",
        "--release",
        "--quiet",
        "--package",
        "scenarios",
        "--",
        "all",
        "--out",
    ])
    .arg(&out)
    .args(args);
    run(cmd).context("reproducing the papers' results (`scenarios all`)")?;
    stamp(&format!("done: {}", out.join("README.md").display()));
    Ok(())
}

fn ci(args: &[String]) -> Result<()> {
    known(args, &[], &["--proptest-cases"])?;
    let mut cmd = cargo();
    cmd.args(["fmt", "--all", "--check"]);
    run(cmd)?;
    // The user project outside the workspace, whose code-line counts its tests compare.
    let mut cmd = cargo();
    cmd.args(["fmt", "--check", "--manifest-path"])
        .arg(root().join("tests/downstream/Cargo.toml"));
    run(cmd)?;
    let mut cmd = cargo();
    cmd.args([
        "clippy",
        "--workspace",
        "--all-targets",
        "--all-features",
        "--",
        "-D",
        "warnings",
    ]);
    run(cmd)?;
    let mut cmd = cargo();
    cmd.args(["doc", "--workspace", "--no-deps", "--all-features"])
        .env("RUSTDOCFLAGS", "-D warnings");
    run(cmd)?;
    test(args)
}

fn doc_examples() -> Result<()> {
    let items = examples::scan(&root())?;
    for item in items.iter().filter(|i| !i.has_example) {
        println!("no example: {} ({})", item.what, item.at);
    }
    let with = items.iter().filter(|i| i.has_example).count();
    println!(
        "doc examples: {with} of {} top-level public items of {} ({:.1} %, required {:.0} %)",
        items.len(),
        examples::CRATES.join(", "),
        100.0 * examples::share(&items),
        100.0 * examples::REQUIRED
    );
    Ok(())
}

fn tidy_task() -> Result<()> {
    let problems = tidy::check(&root())?;
    let items = examples::scan(&root())?;
    eprintln!(
        "tidy: {:.1} % of {} library items carry a compiled doc example",
        100.0 * examples::share(&items),
        items.len()
    );
    if problems.is_empty() {
        eprintln!("tidy: ok");
        return Ok(());
    }
    for p in &problems {
        eprintln!("tidy: {p}");
    }
    bail!("tidy found {} problem(s)", problems.len())
}

fn fuzz(args: &[String]) -> Result<()> {
    known(args, &[], &["--seconds"])?;
    let seconds = option(args, "--seconds")?.unwrap_or("60");
    let fuzz_dir = root().join("fuzz");
    if !fuzz_dir.join("Cargo.toml").exists() {
        bail!("no fuzz targets yet (expected {})", fuzz_dir.display());
    }
    let targets = std::fs::read_dir(fuzz_dir.join("fuzz_targets"))
        .context("listing fuzz/fuzz_targets")?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let p = e.path();
            let stem = p.file_stem()?.to_string_lossy().into_owned();
            (p.extension()? == "rs").then_some(stem)
        })
        .collect::<Vec<_>>();
    for target in targets {
        let mut cmd = cargo();
        // cargo-fuzz needs nightly-only sanitizer flags; RUSTC_BOOTSTRAP lets the stable
        // toolchain accept them, and the fuzz crate is outside the workspace.
        cmd.current_dir(&fuzz_dir)
            .env("RUSTC_BOOTSTRAP", "1")
            .args([
                "fuzz",
                "run",
                &target,
                "--",
                &format!("-max_total_time={seconds}"),
            ]);
        run(cmd).with_context(|| {
            format!("fuzz target {target} (is cargo-fuzz installed? `cargo install cargo-fuzz`)")
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn workspace_is_tidy() {
        let problems = super::tidy::check(&super::root()).expect("tidy could read the tree");
        assert!(
            problems.is_empty(),
            "tidy problems:\n{}",
            problems.join("\n")
        );
    }
}
