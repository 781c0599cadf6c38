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

    /// Computes every number the outputs show.
    ///
    /// # Errors
    /// A library error on valid parameters.
    fn summarise(
        params: &Self::Params,
        seed: u64,
        shard: Shard,
        records: &Self::Records,
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
    #[serde(default)]
    records: Vec<FileCheck>,
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
    let summary = S::summarise(
        &params,
        campaign.seed,
        campaign.shard,
        &records,
        campaign.threads,
    )?;
    write::<S>(
        &campaign.out_dir(S::NAME),
        &params,
        campaign.shard,
        &records,
        &summary,
    )
}

/// Writes the record files, the outputs and `summary.json` (with the records' checks).
fn write<S: Scenario>(
    dir: &Path,
    params: &S::Params,
    shard: Shard,
    records: &S::Records,
    summary: &S::Summary,
) -> Result<()> {
    let mut checks = Vec::new();
    for (layout, rows) in S::record_files(params).iter().zip(S::to_tables(records)) {
        let text = records::csv_text(&layout.header, &rows);
        output::write_atomic(&dir.join(&layout.name), text.as_bytes())?;
        checks.push(records::check_of(&layout.name, &text));
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

/// Merges shard directories of scenario `S` into `out`: checks that they come from one
/// campaign, reads and checks every record file, requires each run exactly once, and
/// recomputes every output from the records.
///
/// # Errors
/// [`Error::Usage`] for no directory; [`Error::Invalid`] naming the directory or file for a
/// shard of another scenario or campaign, a damaged record file, a run held twice, or runs
/// that no directory holds; read and write errors. Nothing is written on error.
pub fn merge<S: Scenario>(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let Some(first_dir) = dirs.first() else {
        return Err(Error::Usage(
            "merge needs at least one shard directory".into(),
        ));
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
                "merge of {} ({}): runs {} of the {total} in {} are in none of them: a shard \
                 is missing",
                list(dirs),
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
    let summary = S::summarise(&params, head.seed, Shard::ALL, &records, None)?;
    write::<S>(out, &params, Shard::ALL, &records, &summary)
}

/// One entry of [`run_all`]: a scenario's name, its one-line title, and how to run it.
pub type Entry = (&'static str, &'static str, fn(&Campaign) -> Result<()>);

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
    for (k, (name, _, run)) in entries.iter().enumerate() {
        eprintln!(
            "scenarios all: [{:>6.1} s] {name} ({}/{}) …",
            started.elapsed().as_secs_f64(),
            k + 1,
            entries.len()
        );
        let one = std::time::Instant::now();
        run(&Campaign {
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
    for (dir, title, _) in entries {
        index.push_str(&format!(
            "- [{title}]({dir}/report.md) — [summary]({dir}/summary.json)\n"
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
