//! The campaign: what every paper scenario does, written once. A scenario implements
//! [`Scenario`] (parameters, a simulation of a slice of runs, per-run records, a summary
//! computed from them, a report that only formats); this module runs it, shards it and
//! merges shards.
//!
//! **One merge mechanism.** The run records a campaign writes (`runs_*.csv`, `runs.csv`) are
//! its ground truth. `summary.json` stores each record file's row count and FNV-1a checksum;
//! `merge` checks every shard's files against them, collects the rows (each run exactly
//! once, from whichever shard holds it), and recomputes everything else from the records
//! exactly as a single run does, so a merge of shards equals one run byte for byte in every
//! file.
//!
//! **The closing stage.** Work that needs the whole campaign's records and costs more than
//! reading them (the fueling calibration's refinement after its sharded design) is
//! [`Scenario::finish`]: a whole run does it after its runs; a sharded campaign does it in
//! `finish` over the shard directories, which writes [`FINISH_FILE`] (checked like a record
//! file). `merge` reads that file beside the shards' records and computes nothing.

pub mod records;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::config;
use crate::error::{Error, Result};
use crate::montecarlo::Shard;
use crate::output;
use records::{FileCheck, RecordFile, RunRecords};

/// What every paper scenario is asked to do: the command line's shared options.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// TOML file overriding the scenario's defaults.
    pub config: Option<PathBuf>,
    /// Output directory; `None` means `reports/<scenario>` (or `reports` for `all`).
    pub out: Option<PathBuf>,
    /// Campaign seed.
    pub seed: u64,
    /// Monte Carlo runs per point; `None` means the scenario's default.
    pub runs: Option<usize>,
    /// Worker threads; `None` means all cores.
    pub threads: Option<usize>,
    /// The slice of the runs to do.
    pub shard: Shard,
}

impl Campaign {
    /// The output directory of scenario `name`.
    pub fn out_dir(&self, name: &str) -> PathBuf {
        self.out
            .clone()
            .unwrap_or_else(|| Path::new("reports").join(name))
    }
}

/// The parameter struct of a paper scenario, as the campaign loads, overrides and checks it.
pub trait ScenarioParams:
    Serialize + DeserializeOwned + Default + Clone + PartialEq + std::fmt::Debug
{
    /// Sets the Monte Carlo runs per point to `runs` (already checked by
    /// [`Scenario::set_runs`]).
    fn set_runs(&mut self, runs: usize);

    /// Checks every value; `source` names the file in the error.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming `source`, the key and the rule broken.
    fn validate(&self, source: &Path) -> Result<()>;
}

/// One paper scenario: the steps the campaign runs, in order.
///
/// `run` = [`Scenario::simulate`] the shard's runs → write their records →
/// [`Scenario::summarise`] → [`Scenario::write_outputs`] and `summary.json`. `merge` = read
/// and check every shard's records → [`Scenario::from_tables`] → the same last two steps. A
/// new section of a report is a new field of the scenario's summary (computed in
/// `summarise`) and a new paragraph in its report (formatting only).
pub trait Scenario {
    /// The subcommand, the output folder under `reports/`, and `summary.json`'s `scenario`.
    const NAME: &'static str;
    /// The parameter struct a `--config` TOML file overrides (`deny_unknown_fields`).
    type Params: ScenarioParams;
    /// The per-run records of a campaign or of one shard.
    type Records: RunRecords<Self::Params>;
    /// Everything the outputs show, computed from the parameters and the records.
    type Summary;
    /// What `summary.json` holds (usually the summary itself, or part of it).
    type Json: Serialize;
    /// The closing stage's result, as [`FINISH_FILE`] holds it (`()` for none).
    type Finish: Serialize + DeserializeOwned + Default;

    /// Applies `--runs` to the parameters: at least one run, unless the scenario says more.
    ///
    /// # Errors
    /// [`Error::Usage`] if the scenario cannot run that many.
    fn set_runs(params: &mut Self::Params, runs: usize) -> Result<()> {
        if runs == 0 {
            return Err(Error::Usage("--runs must be ≥ 1".into()));
        }
        params.set_runs(runs);
        Ok(())
    }

    /// Checks every value; `source` names the file in the error ([`ScenarioParams::validate`]).
    ///
    /// # Errors
    /// [`Error::Invalid`] naming `source`, the key and the rule broken.
    fn validate(params: &Self::Params, source: &Path) -> Result<()> {
        params.validate(source)
    }

    /// The record files of a campaign with these parameters (none for a deterministic one;
    /// [`RunRecords::record_files`]).
    fn record_files(params: &Self::Params) -> Vec<RecordFile> {
        Self::Records::record_files(params)
    }

    /// Simulates the runs of `shard`; run `i` draws from `montecarlo::run_rng(seed, i)`.
    ///
    /// # Errors
    /// A library error on valid parameters, or the worker pool failing to start.
    fn simulate(
        params: &Self::Params,
        seed: u64,
        shard: Shard,
        threads: Option<usize>,
    ) -> Result<Self::Records>;

    /// The rows of each record file, in [`Scenario::record_files`] order, keys first
    /// ([`RunRecords::to_tables`]).
    fn to_tables(records: &Self::Records) -> Vec<Vec<Vec<f64>>> {
        records.to_tables()
    }

    /// The records back from the rows of each record file (checked and in key order;
    /// [`RunRecords::from_tables`]).
    ///
    /// # Errors
    /// [`Error::Invalid`] if the rows do not fit the parameters.
    fn from_tables(params: &Self::Params, tables: Vec<Vec<Vec<f64>>>) -> Result<Self::Records> {
        Self::Records::from_tables(params, tables)
    }

    /// Whether a campaign with these parameters has a closing stage ([`Scenario::finish`]).
    fn has_finish(_params: &Self::Params) -> bool {
        false
    }

    /// The closing stage: what needs the whole campaign's records (every shard's) and is too
    /// costly to repeat in `merge`. Called only when [`Scenario::has_finish`].
    ///
    /// # Errors
    /// A library error on valid parameters, or the worker pool failing to start.
    fn finish(
        _params: &Self::Params,
        _seed: u64,
        _records: &Self::Records,
        _threads: Option<usize>,
    ) -> Result<Self::Finish> {
        Ok(Self::Finish::default())
    }

    /// Computes every number the outputs show from the records and, for a whole campaign
    /// with a closing stage, its result (`None` in a shard). No Monte Carlo run and no fit
    /// belongs here (they are `simulate`'s and `finish`'s); the uav scenario replays run 0
    /// for its traces here in a shard only (a whole run and a merge read them from its
    /// closing stage), and the boom and flight-path scenarios compute their deterministic
    /// nominal cases here.
    ///
    /// # Errors
    /// A library error on valid parameters.
    fn summarise(
        params: &Self::Params,
        seed: u64,
        shard: Shard,
        records: &Self::Records,
        finish: Option<&Self::Finish>,
        threads: Option<usize>,
    ) -> Result<Self::Summary>;

    /// The part of the summary written to `summary.json`.
    fn json(summary: &Self::Summary) -> &Self::Json;

    /// Writes the CSVs, plots and `report.md` of `summary` into `dir` (formatting only).
    ///
    /// # Errors
    /// [`Error::Write`] naming the file.
    fn write_outputs(summary: &Self::Summary, dir: &Path) -> Result<()>;
}

/// `summary.json`: the scenario's summary, then the shard (absent for a whole or merged
/// campaign) and the check of every record file.
#[derive(Debug, Serialize)]
struct Envelope<'a, J> {
    #[serde(flatten)]
    summary: &'a J,
    #[serde(skip_serializing_if = "Option::is_none")]
    shard: Option<String>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    records: Vec<FileCheck>,
}

/// What `merge` reads from a shard's `summary.json`.
#[derive(Debug, Deserialize)]
struct Header<P> {
    scenario: String,
    seed: u64,
    params: P,
    #[serde(default)]
    shard: Option<String>,
    /// `"finish"` for the output of `finish`.
    #[serde(default)]
    stage: Option<String>,
    #[serde(default)]
    records: Vec<FileCheck>,
}

/// The file of the closing stage's result (TOML: it keeps NaN and infinities, which JSON
/// cannot), in a whole campaign's directory and in the output of `finish`.
pub const FINISH_FILE: &str = "finish.toml";

/// The `stage` of `finish`'s `summary.json`.
const FINISH_STAGE: &str = "finish";

/// `summary.json` of the output of `finish`: which campaign, and the check of its file.
#[derive(Debug, Serialize)]
struct FinishEnvelope<'a, P> {
    scenario: &'static str,
    seed: u64,
    params: &'a P,
    stage: &'static str,
    records: Vec<FileCheck>,
}

/// The text of [`FINISH_FILE`] for `finish`.
fn finish_text<S: Scenario>(finish: &S::Finish) -> Result<String> {
    toml::to_string(finish).map_err(|source| Error::SerialiseToml {
        dest: FINISH_FILE.to_string(),
        source,
    })
}

/// The closing stage's result from the text of `path`.
fn parse_finish<S: Scenario>(path: &Path, text: &str) -> Result<S::Finish> {
    config::parse_toml(path, text)
}

/// Loads, overrides and validates the parameters of `campaign`.
///
/// # Errors
/// As [`config::load_or_default`], [`Scenario::set_runs`] and [`Scenario::validate`].
pub fn params<S: Scenario>(campaign: &Campaign) -> Result<S::Params> {
    let mut params: S::Params = config::load_or_default(campaign.config.as_deref())?;
    if let Some(runs) = campaign.runs {
        S::set_runs(&mut params, runs)?;
    }
    let source = campaign
        .config
        .clone()
        .unwrap_or_else(|| PathBuf::from("<defaults>"));
    S::validate(&params, &source)?;
    Ok(params)
}

/// Runs scenario `S` into `campaign.out_dir(S::NAME)`.
///
/// # Errors
/// A bad configuration (exit code 2), a library error or an I/O error.
pub fn run<S: Scenario>(campaign: &Campaign) -> Result<()> {
    let params = params::<S>(campaign)?;
    let records = S::simulate(&params, campaign.seed, campaign.shard, campaign.threads)?;
    // A whole campaign closes itself; a shard leaves that to `finish`.
    let finish = if campaign.shard == Shard::ALL && S::has_finish(&params) {
        let value = S::finish(&params, campaign.seed, &records, campaign.threads)?;
        Some(finish_text::<S>(&value)?)
    } else {
        None
    };
    // The summary reads the stage's result back from its text, as `merge` does.
    let value = finish
        .as_deref()
        .map(|text| parse_finish::<S>(Path::new(FINISH_FILE), text))
        .transpose()?;
    let summary = S::summarise(
        &params,
        campaign.seed,
        campaign.shard,
        &records,
        value.as_ref(),
        campaign.threads,
    )?;
    write::<S>(
        &campaign.out_dir(S::NAME),
        &params,
        campaign.shard,
        &records,
        finish.as_deref(),
        &summary,
    )
}

/// Writes the record files, the closing stage's file, the outputs and `summary.json` (with
/// the records' checks).
fn write<S: Scenario>(
    dir: &Path,
    params: &S::Params,
    shard: Shard,
    records: &S::Records,
    finish: Option<&str>,
    summary: &S::Summary,
) -> Result<()> {
    let mut checks = Vec::new();
    for (layout, rows) in S::record_files(params).iter().zip(S::to_tables(records)) {
        let text = records::csv_text(&layout.header, &rows);
        output::write_atomic(&dir.join(&layout.name), text.as_bytes())?;
        checks.push(records::check_of(&layout.name, &text));
    }
    if let Some(text) = finish {
        output::write_atomic(&dir.join(FINISH_FILE), text.as_bytes())?;
        checks.push(records::check_of(FINISH_FILE, text));
    }
    S::write_outputs(summary, dir)?;
    let envelope = Envelope {
        summary: S::json(summary),
        shard: (shard != Shard::ALL).then(|| shard.to_string()),
        records: checks,
    };
    output::write_json(&dir.join("summary.json"), &envelope)
}

/// The `scenario` field of `dir/summary.json`.
///
/// # Errors
/// [`Error::Read`] or [`Error::Invalid`] naming the file.
pub fn scenario_of(dir: &Path) -> Result<String> {
    #[derive(Deserialize)]
    struct Name {
        scenario: String,
    }
    let path = dir.join("summary.json");
    let text = config::read_text(&path)?;
    let name: Name = serde_json::from_str(&text)
        .map_err(|e| Error::invalid(&path, format!("not a scenario summary: {e}")))?;
    Ok(name.scenario)
}

/// `a, b, c` for a list of directories.
fn list(dirs: &[PathBuf]) -> String {
    dirs.iter()
        .map(|d| d.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// `point 3, run 7` for the key `[3, 7]` of `layout`.
fn describe(layout: &RecordFile, key: &[usize]) -> String {
    layout
        .header
        .iter()
        .zip(key)
        .map(|(name, k)| format!("{name} {k}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `3–5, 9` for a sorted list of indices.
fn ranges(indices: &[usize]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < indices.len() {
        let mut j = i;
        while j + 1 < indices.len() && indices[j + 1] == indices[j] + 1 {
            j += 1;
        }
        out.push(if i == j {
            indices[i].to_string()
        } else {
            format!("{}–{}", indices[i], indices[j])
        });
        i = j + 1;
    }
    out.join(", ")
}

/// A campaign read back from its directories: the parameters and seed they share, the
/// runs' records from the shard (or whole-run) directories, and the closing stage's file
/// from the first directory that holds one.
struct Gathered<S: Scenario> {
    params: S::Params,
    seed: u64,
    records: S::Records,
    /// The path and text of [`FINISH_FILE`], checked.
    finish: Option<(PathBuf, String)>,
}

/// Reads the directories of one campaign of `S`: checks that they come from one campaign,
/// reads and checks every record file of the run directories, requires each run exactly
/// once, and finds the closing stage's file if one of them holds it.
///
/// # Errors
/// [`Error::Usage`] for no run directory; [`Error::Invalid`] naming the directory or file for
/// a directory of another scenario or campaign, a damaged file, a run held twice, or runs
/// that no directory holds; read errors.
fn gather<S: Scenario>(dirs: &[PathBuf], command: &str) -> Result<Gathered<S>> {
    let Some(first_dir) = dirs.first() else {
        return Err(Error::Usage(format!(
            "{command} needs at least one shard directory"
        )));
    };
    let mut headers: Vec<Header<S::Params>> = Vec::new();
    for dir in dirs {
        let path = dir.join("summary.json");
        let text = config::read_text(&path)?;
        let h: Header<S::Params> = serde_json::from_str(&text)
            .map_err(|e| Error::invalid(&path, format!("not a {} summary: {e}", S::NAME)))?;
        if h.scenario != S::NAME {
            return Err(Error::invalid(
                &path,
                format!("`scenario` is {:?}, expected {:?}", h.scenario, S::NAME),
            ));
        }
        if let Some(f) = headers.first()
            && (f.seed != h.seed || f.params != h.params)
        {
            return Err(Error::invalid(
                &path,
                format!(
                    "belongs to another campaign: seed or `params` differ from {}",
                    first_dir.join("summary.json").display()
                ),
            ));
        }
        headers.push(h);
    }
    let head = &headers[0];
    S::validate(&head.params, &first_dir.join("summary.json"))?;
    let mut finish = None;
    for (dir, h) in dirs.iter().zip(&headers) {
        if let Some(check) = h.records.iter().find(|c| c.file == FINISH_FILE) {
            let path = dir.join(FINISH_FILE);
            let text = config::read_text(&path)?;
            records::verify(&path, &text, check)?;
            finish = Some((path, text));
            break;
        }
    }
    // The runs come from the shard and whole-run directories, not from `finish`'s.
    let (dirs, headers): (Vec<&PathBuf>, Vec<&Header<S::Params>>) = dirs
        .iter()
        .zip(&headers)
        .filter(|(_, h)| h.stage.as_deref() != Some(FINISH_STAGE))
        .unzip();
    if dirs.is_empty() {
        return Err(Error::Usage(format!(
            "{command}: every directory given is the output of `finish`; give the shard \
             directories too"
        )));
    }
    let dirs: Vec<PathBuf> = dirs.into_iter().cloned().collect();
    let layouts = S::record_files(&head.params);
    let mut tables = Vec::with_capacity(layouts.len());
    for layout in &layouts {
        // key → (row, index of the directory it came from)
        let mut rows: BTreeMap<Vec<usize>, (Vec<f64>, usize)> = BTreeMap::new();
        for (d, (dir, h)) in dirs.iter().zip(&headers).enumerate() {
            let path = dir.join(&layout.name);
            let check = h
                .records
                .iter()
                .find(|c| c.file == layout.name)
                .ok_or_else(|| {
                    Error::invalid(
                        dir.join("summary.json"),
                        format!("has no check for the record file {}", layout.name),
                    )
                })?;
            let text = config::read_text(&path)?;
            for (key, row) in records::parse(&path, &text, layout, check)? {
                if let Some((_, other)) = rows.get(&key) {
                    return Err(Error::invalid(
                        &path,
                        format!(
                            "{} appears in more than one shard: {} and {}",
                            describe(layout, &key),
                            dirs[*other].display(),
                            dir.display()
                        ),
                    ));
                }
                rows.insert(key, (row, d));
            }
        }
        let expected: usize = layout.grid.iter().product();
        if rows.len() != expected {
            let total = layout.grid.last().copied().unwrap_or(0);
            let mut present = vec![0usize; total];
            for key in rows.keys() {
                if let Some(&run) = key.last() {
                    present[run] += 1;
                }
            }
            let per_run = expected / total.max(1);
            let missing: Vec<usize> = (0..total).filter(|&r| present[r] < per_run).collect();
            let shards = headers
                .iter()
                .filter_map(|h| h.shard.as_deref())
                .collect::<Vec<_>>();
            return Err(Error::Usage(format!(
                "{command} of {} ({}): runs {} of the {total} in {} are in none of them: a \
                 shard is missing",
                list(&dirs),
                if shards.is_empty() {
                    "whole campaigns".to_string()
                } else {
                    format!("shards {}", shards.join(", "))
                },
                ranges(&missing),
                layout.name
            )));
        }
        tables.push(rows.into_values().map(|(row, _)| row).collect());
    }
    let params = head.params.clone();
    let records = S::from_tables(&params, tables)?;
    Ok(Gathered {
        params,
        seed: head.seed,
        records,
        finish,
    })
}

/// Merges shard directories of scenario `S` into `out`: checks that they come from one
/// campaign, reads and checks every record file, requires each run exactly once, with
/// the output of `finish` among them when the scenario has a closing stage, and writes the
/// outputs of the whole campaign. Reads records and formats; computes no stage.
///
/// # Errors
/// [`Error::Usage`] for no shard directory; [`Error::Invalid`] naming the directory or file
/// for a directory of another scenario or campaign, a damaged file, a run held twice, or
/// runs that no directory holds; [`Error::Usage`] when the closing stage's file is in none
/// of the directories; read and write errors. Nothing is written on error.
pub fn merge<S: Scenario>(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let g = gather::<S>(dirs, "merge")?;
    let finish = if S::has_finish(&g.params) {
        let Some((path, text)) = g.finish else {
            return Err(Error::Usage(format!(
                "merge of {}: none of them holds {FINISH_FILE}, the {} campaign's closing \
                 stage: run `scenarios finish <shard dirs> --out <dir>` and give that \
                 directory to merge too",
                list(dirs),
                S::NAME
            )));
        };
        let value = parse_finish::<S>(&path, &text)?;
        Some((text, value))
    } else {
        None
    };
    let summary = S::summarise(
        &g.params,
        g.seed,
        Shard::ALL,
        &g.records,
        finish.as_ref().map(|(_, v)| v),
        None,
    )?;
    write::<S>(
        out,
        &g.params,
        Shard::ALL,
        &g.records,
        finish.as_ref().map(|(t, _)| t.as_str()),
        &summary,
    )
}

/// Runs the closing stage of scenario `S` over its shard directories into `out`: reads and
/// checks them as [`merge`] does, computes [`Scenario::finish`] and writes [`FINISH_FILE`]
/// with a `summary.json` naming the campaign (nothing but the file when the scenario has no
/// closing stage for these parameters, so every campaign can be closed alike).
///
/// # Errors
/// As [`merge`] (but for the closing stage's file) and [`Scenario::finish`]; write errors.
pub fn finish<S: Scenario>(dirs: &[PathBuf], out: &Path, threads: Option<usize>) -> Result<()> {
    let g = gather::<S>(dirs, "finish")?;
    let mut checks = Vec::new();
    if S::has_finish(&g.params) {
        let text = finish_text::<S>(&S::finish(&g.params, g.seed, &g.records, threads)?)?;
        output::write_atomic(&out.join(FINISH_FILE), text.as_bytes())?;
        checks.push(records::check_of(FINISH_FILE, &text));
    }
    output::write_json(
        &out.join("summary.json"),
        &FinishEnvelope {
            scenario: S::NAME,
            seed: g.seed,
            params: &g.params,
            stage: FINISH_STAGE,
            records: checks,
        },
    )
}

/// One scenario as the commands that name it reach it: its name (subcommand, folder and
/// `summary.json`'s `scenario`), its one-line title for `reports/README.md`, and its
/// [`run`], [`finish`] and [`merge`].
#[derive(Debug, Clone, Copy)]
pub struct Entry {
    /// The scenario's name ([`Scenario::NAME`]).
    pub name: &'static str,
    /// Its title in `reports/README.md`.
    pub title: &'static str,
    /// [`run`] for it.
    pub run: fn(&Campaign) -> Result<()>,
    /// [`finish`] for it.
    pub finish: fn(&[PathBuf], &Path, Option<usize>) -> Result<()>,
    /// [`merge`] for it.
    pub merge: fn(&[PathBuf], &Path) -> Result<()>,
}

impl Entry {
    /// The entry of scenario `S` with the title `title`.
    pub const fn of<S: Scenario>(title: &'static str) -> Self {
        Self {
            name: S::NAME,
            title,
            run: run::<S>,
            finish: finish::<S>,
            merge: merge::<S>,
        }
    }
}

/// Runs every scenario of `entries` into `<out>/<name>` and writes `<out>/README.md` linking
/// their reports.
///
/// # Errors
/// [`Error::Usage`] for a `--config` (each scenario takes its own); as [`run`].
pub fn run_all(campaign: &Campaign, entries: &[Entry]) -> Result<()> {
    let root = campaign
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("reports"));
    if campaign.config.is_some() {
        return Err(Error::Usage(
            "`all` takes no --config: give each scenario's file to that scenario".into(),
        ));
    }
    // One progress line per scenario on stderr (a terminal or not: a log, CI, a pipe).
    let started = std::time::Instant::now();
    for (k, entry) in entries.iter().enumerate() {
        let name = entry.name;
        eprintln!(
            "scenarios all: [{:>6.1} s] {name} ({}/{}) …",
            started.elapsed().as_secs_f64(),
            k + 1,
            entries.len()
        );
        let one = std::time::Instant::now();
        (entry.run)(&Campaign {
            out: Some(root.join(name)),
            ..campaign.clone()
        })?;
        eprintln!(
            "scenarios all: [{:>6.1} s] {name} done in {:.1} s",
            started.elapsed().as_secs_f64(),
            one.elapsed().as_secs_f64()
        );
    }
    let mut index = String::from(
        "# Reproduced results\n\nGenerated by `cargo xtask reproduce` (`scenarios all`); \
         do not edit by hand.\n\n",
    );
    for Entry { name, title, .. } in entries {
        index.push_str(&format!(
            "- [{title}]({name}/report.md) — [summary]({name}/summary.json)\n"
        ));
    }
    output::write_atomic(&root.join("README.md"), index.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_join_consecutive_runs() {
        assert_eq!(ranges(&[3, 4, 5, 9]), "3–5, 9");
        assert_eq!(ranges(&[0]), "0");
        assert_eq!(ranges(&[]), "");
    }
}

/// The check shared by the scenarios' merge tests: two shards, `finish` and `merge` of `S`
/// with the configuration `config` (TOML), the simulations each step starts counted on this
/// thread, and a whole run to compare the merge with.
#[cfg(test)]
pub(crate) mod merge_check {
    use std::path::PathBuf;

    use super::{Campaign, Scenario, finish, merge, run};
    use crate::montecarlo::{Shard, simulations_started};

    /// Runs the three steps and the whole campaign in a scratch directory named after `tag`;
    /// asserts that each shard simulates and that the merged directory equals the whole
    /// run's file for file, and returns the simulations `finish` and `merge` started.
    pub(crate) fn shards_finish_merge<S: Scenario>(
        tag: &str,
        config: &str,
        seed: u64,
        runs: usize,
    ) -> (usize, usize) {
        let dir = std::env::temp_dir().join(format!("{tag}-merge-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch");
        let file = dir.join("small.toml");
        std::fs::write(&file, config).expect("config");
        let campaign = |shard: Shard, out: &str| Campaign {
            config: Some(file.clone()),
            out: Some(dir.join(out)),
            seed,
            runs: Some(runs),
            threads: Some(1),
            shard,
        };
        let shards: Vec<PathBuf> = (1..=2).map(|k| dir.join(format!("s{k}"))).collect();
        for index in 1..=2 {
            let started = simulations_started();
            run::<S>(&campaign(Shard { index, count: 2 }, &format!("s{index}"))).expect("shard");
            assert!(simulations_started() > started, "a shard simulates");
        }
        let started = simulations_started();
        finish::<S>(&shards, &dir.join("fin"), Some(1)).expect("finish");
        let in_finish = simulations_started() - started;
        let mut inputs = shards.clone();
        inputs.push(dir.join("fin"));
        let started = simulations_started();
        merge::<S>(&inputs, &dir.join("merged")).expect("merge");
        let in_merge = simulations_started() - started;
        run::<S>(&campaign(Shard::ALL, "whole")).expect("whole");
        for entry in std::fs::read_dir(dir.join("whole")).expect("whole dir") {
            let name = entry.expect("entry").file_name();
            let whole = std::fs::read(dir.join("whole").join(&name)).expect("whole file");
            let merged = std::fs::read(dir.join("merged").join(&name)).expect("merged file");
            assert!(whole == merged, "{name:?} differs");
        }
        let _ = std::fs::remove_dir_all(&dir);
        (in_finish, in_merge)
    }
}
