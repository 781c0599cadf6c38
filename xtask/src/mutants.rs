//! `cargo xtask mutants`: sampled mutation testing of the library crates with `cargo-mutants`.
//!
//! Each mutant (one operator or return value changed on purpose) is built in a copy of the
//! tree and the mutated crate's unit and integration tests run against it; a mutant the tests
//! do not fail on is *missed* and names a place the tests are blind to. The run is sequential
//! (`-j 1`) with a per-mutant timeout, its build artifacts go to `target/mutants/build` (kept
//! warm between runs; `--target-dir` names another, so two runs can go side by side) and its
//! report to `target/mutants/<label>/mutants.out`.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};

use crate::{cargo, known, option, root};

/// The folders of the crates whose sources are mutated: the libraries (not the program or
/// the xtask).
const LIBRARY_CRATES: &[&str] = &["numerics", "model", "kalman", "wls", "sensors"];

/// Seconds a mutant's tests may run before it counts as a timeout. The unit and integration
/// suite of one crate, unoptimised and without [`LONG_RUNS`], takes up to about 60 s on this
/// machine (kalman's, beside a second run: 40–60 s; wls and model: under 10 s), so a tighter
/// limit would report an unmutated-speed run as a timeout.
const DEFAULT_TIMEOUT: &str = "180";

/// Tests left out of a mutant's run: long runs that take most of a crate's test time when the
/// crate is built unoptimised (as the mutants are, see `mutants`). Leaving a test out can
/// only turn a caught mutant into a missed one, never the reverse, so the counts stay
/// honest; `cargo xtask test` runs them as always.
const LONG_RUNS: &[&str] = &[
    // One million steps of the fuel filter (27 s unoptimised, all the other kalman tests
    // together about 15 s run one at a time); its short-run properties are checked by the
    // other engine tests.
    "engine::fuel::fuel_model_runs_a_million_steps",
];

/// The outcome files cargo-mutants writes, in the order they are reported.
const OUTCOMES: &[&str] = &["caught", "missed", "timeout", "unviable"];

pub(crate) fn mutants(args: &[String]) -> Result<()> {
    known(
        args,
        &["--list", "--skip-baseline"],
        &[
            "--crate",
            "--file",
            "--shard",
            "--timeout",
            "--re",
            "--target-dir",
        ],
    )?;
    let file = option(args, "--file")?;
    let krate = match (option(args, "--crate")?, file) {
        (Some(c), _) => c.to_owned(),
        // A file names its crate by its first path component.
        (None, Some(f)) => f.split('/').next().unwrap_or_default().to_owned(),
        (None, None) => String::new(),
    };
    if !krate.is_empty() && !LIBRARY_CRATES.contains(&krate.as_str()) {
        bail!(
            "`{krate}` is not a library crate; mutants runs on {}",
            LIBRARY_CRATES.join(", ")
        );
    }
    let shard = option(args, "--shard")?;
    if let Some(s) = shard {
        let valid = s.split_once('/').is_some_and(
            |(k, n)| matches!((k.parse::<u32>(), n.parse::<u32>()), (Ok(k), Ok(n)) if k < n),
        );
        if !valid {
            bail!("--shard takes K/N with 0 ≤ K < N, not `{s}`");
        }
    }
    // Two runs at once must not share a build directory: cargo builds every copy of the tree
    // into the same files (a path package's hash is relative to its workspace), so one run
    // could test the other's mutant.
    let target_dir = option(args, "--target-dir")?.map_or_else(
        || root().join("target").join("mutants").join("build"),
        std::path::PathBuf::from,
    );
    let timeout = option(args, "--timeout")?.unwrap_or(DEFAULT_TIMEOUT);
    timeout
        .parse::<u32>()
        .with_context(|| format!("--timeout takes whole seconds, not `{timeout}`"))?;
    ensure_installed()?;

    let crates: Vec<&str> = if krate.is_empty() {
        LIBRARY_CRATES.to_vec()
    } else {
        vec![krate.as_str()]
    };
    let mut cmd = cargo();
    cmd.args(["mutants", "--all-features"]);
    for c in &crates {
        cmd.args(["--package", &package_name(c)?]);
    }
    if let Some(f) = file {
        cmd.args(["--file", f]);
    }
    // Only the mutants whose names (as `--list` shows them) match, e.g. to re-check the
    // missed ones after adding tests.
    let re = option(args, "--re")?;
    if let Some(re) = re {
        cmd.args(["--re", re]);
    }
    if args.iter().any(|a| a == "--list") {
        cmd.arg("--list");
        return crate::run(cmd);
    }
    // The report directory is named after the selection, so runs of different shards or
    // filters keep their own reports.
    let re_label = re.map(|r| {
        let kept: String = r
            .chars()
            .filter(char::is_ascii_alphanumeric)
            .take(24)
            .collect();
        format!("re{kept}")
    });
    let label = [
        krate.as_str(),
        file.unwrap_or(""),
        shard.unwrap_or(""),
        re_label.as_deref().unwrap_or(""),
    ]
    .iter()
    .filter(|s| !s.is_empty())
    .map(|s| s.replace(['/', '*', '.', '{', '}', ','], "_"))
    .collect::<Vec<_>>()
    .join("-");
    let label = if label.is_empty() {
        "all".into()
    } else {
        label
    };
    let out = root().join("target").join("mutants").join(&label);
    // cargo-mutants creates its output directory but not the parents (a fresh clone has no
    // `target/` yet).
    std::fs::create_dir_all(root().join("target").join("mutants"))
        .context("creating target/mutants")?;
    if let Some(s) = shard {
        // Round-robin: shard K takes every N-th mutant, a sample spread over the whole file.
        cmd.args(["--shard", s, "--sharding", "round-robin"]);
    }
    // One mutant at a time (the machine is shared); only the mutated crate's unit and
    // integration tests judge a mutant, and only they are built (examples and doc tests are
    // usage, slow to build, and checked by `cargo xtask test`).
    // The baseline (the unmutated tree built and tested first) costs one full build: a
    // re-check of a few mutants after a run whose baseline passed may skip it.
    if args.iter().any(|a| a == "--skip-baseline") {
        cmd.args(["--baseline", "skip"]);
    }
    cmd.args(["--jobs", "1", "--timeout", timeout, "--output"])
        .arg(&out)
        .args([
            "--cargo-arg=--lib",
            "--cargo-arg=--tests",
            "--cargo-test-arg=--",
        ]);
    for test in LONG_RUNS {
        cmd.arg(format!("--cargo-test-arg=--skip={test}"));
    }
    // The workspace crates unoptimised (the dependencies keep the opt-level the manifest
    // gives them): a mutant in a generic function recompiles the crate's integration tests,
    // about 45 s at the test profile's opt-level 1 against 8 s at 0.
    cmd.env("CARGO_TARGET_DIR", target_dir)
        .env("CARGO_PROFILE_TEST_OPT_LEVEL", "0")
        // A property test that fails on a mutant must neither write its case into the
        // checkout's `*.proptest-regressions` files (they are the project's, and the failure
        // is the mutant's) nor spend time shrinking it: failing is all a mutant run needs.
        .env("PROPTEST_DISABLE_FAILURE_PERSISTENCE", "1")
        .env("PROPTEST_MAX_SHRINK_ITERS", "0");
    let shown = format!("{cmd:?}");
    eprintln!("$ {shown}");
    let started = Instant::now();
    let status = cmd
        .status()
        .with_context(|| format!("could not start {shown}"))?;
    let elapsed = started.elapsed().as_secs();
    // cargo-mutants exits 2 when a mutant was missed and 3 on a timeout: those are results.
    if !matches!(status.code(), Some(0 | 2 | 3)) {
        bail!("{shown} failed with {status}");
    }
    let report = Report::read(&out.join("mutants.out"))?;
    report.print();
    println!(
        "wall time {} min {} s; full report in {}",
        elapsed / 60,
        elapsed % 60,
        out.display()
    );
    if report.count("missed") > 0 {
        bail!("{} mutant(s) missed", report.count("missed"));
    }
    Ok(())
}

/// The package name in the manifest of the crate in folder `dir` (it may differ from the
/// folder's name).
fn package_name(dir: &str) -> Result<String> {
    let path = root().join(dir).join("Cargo.toml");
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    text.lines()
        .find_map(|l| {
            let value = l
                .trim()
                .strip_prefix("name")?
                .trim_start()
                .strip_prefix('=')?;
            Some(value.trim().trim_matches('"').to_owned())
        })
        .with_context(|| format!("no package name in {}", path.display()))
}

/// Installs cargo-mutants from the Rust package registry if `cargo mutants` does not run.
fn ensure_installed() -> Result<()> {
    let present = cargo()
        .args(["mutants", "--version"])
        .output()
        .is_ok_and(|o| o.status.success());
    if present {
        return Ok(());
    }
    eprintln!("cargo-mutants is not installed; installing it");
    let mut cmd = cargo();
    cmd.args(["install", "--locked", "cargo-mutants"]);
    crate::run(cmd).context("installing cargo-mutants")?;
    let mut check = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()));
    check.args(["mutants", "--version"]);
    crate::run(check).context("cargo-mutants still does not run after installing it")
}

/// The mutants of one run by outcome, each line `file:line:col: description`.
#[derive(Debug)]
struct Report {
    lines: BTreeMap<&'static str, Vec<String>>,
}

impl Report {
    fn read(dir: &Path) -> Result<Self> {
        let mut lines = BTreeMap::new();
        for &outcome in OUTCOMES {
            let path = dir.join(format!("{outcome}.txt"));
            let text = std::fs::read_to_string(&path).unwrap_or_default();
            lines.insert(
                outcome,
                text.lines()
                    .filter(|l| !l.trim().is_empty())
                    .map(str::to_owned)
                    .collect(),
            );
        }
        Ok(Self { lines })
    }

    fn count(&self, outcome: &str) -> usize {
        self.lines.get(outcome).map_or(0, Vec::len)
    }

    fn print(&self) {
        let mut per_file: BTreeMap<&str, [usize; 4]> = BTreeMap::new();
        for (i, &outcome) in OUTCOMES.iter().enumerate() {
            for line in &self.lines[outcome] {
                let file = line.split(':').next().unwrap_or(line);
                per_file.entry(file).or_default()[i] += 1;
            }
        }
        println!(
            "\n{:<32} {:>7} {:>7} {:>7} {:>8} {:>9}",
            "file", "caught", "missed", "timeout", "unviable", "caught %"
        );
        for (file, [caught, missed, timeout, unviable]) in &per_file {
            // A timeout fails the run, so it counts as caught among the viable mutants.
            let viable = caught + missed + timeout;
            let pct = if viable == 0 {
                "-".to_owned()
            } else {
                format!("{:.0}", 100.0 * (caught + timeout) as f64 / viable as f64)
            };
            println!("{file:<32} {caught:>7} {missed:>7} {timeout:>7} {unviable:>8} {pct:>9}");
        }
        println!(
            "total: {} caught, {} missed, {} timeout, {} unviable",
            self.count("caught"),
            self.count("missed"),
            self.count("timeout"),
            self.count("unviable")
        );
        if self.count("missed") > 0 {
            println!("\nmissed:");
            for line in &self.lines["missed"] {
                println!("  {line}");
            }
        }
    }
}
