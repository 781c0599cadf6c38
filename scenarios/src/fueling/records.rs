//! Per-run records of the fueling scenario: each run's fuelling error per strategy, one
//! `runs_<sweep>.csv` per sweep (`point, run`, then one column per strategy, metres at full
//! precision), and `runs_particle.csv` for the particle filter's runs of the amplitude sweep
//! (`point, run`, its error and its restarts), and the calibration's design sets in
//! `calibration_design.csv` (one row per set, its evaluation). They are the campaign's
//! ground truth: everything else is recomputed from them.

use serde::{Deserialize, Serialize};

use crate::campaign::records::{RecordFile, RunRecords};
use crate::error::{Error, Result};

use super::parameters::{FuelingParams, Sweep};
use super::search::BOX;

/// The strategies, in the order of every per-run record and table.
pub const STRATEGIES: [&str; 5] = ["relay", "kf1", "kf2", "kf2_cross", "kf2_midstep"];

/// Human names of [`STRATEGIES`], for reports and legends.
pub const STRATEGY_LABELS: [&str; 5] = [
    "relay logic",
    "one-channel KF",
    "two-channel KF (paper)",
    "two-channel KF + cross-cov. S",
    "two-channel KF + mid-step",
];

/// Fuelling errors of one run, metres, in [`STRATEGIES`] order (NaN: never stopped).
pub type Outcome = [f64; 5];

/// One value per strategy, serialised under the strategy names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PerStrategy<T> {
    /// Relay logic: stop when the raw sensor reading reaches H*.
    pub relay: T,
    /// One-channel KF (level sensor only).
    pub kf1: T,
    /// Two-channel KF ignoring the cross-covariance (the paper).
    pub kf2: T,
    /// Two-channel KF with the cross-covariance S.
    pub kf2_cross: T,
    /// Two-channel KF (no S) fed the mid-step-compensated reading.
    pub kf2_midstep: T,
}

impl<T> PerStrategy<T> {
    /// The values `f(i)` for strategy `i` in [`STRATEGIES`] order.
    pub fn from_fn(mut f: impl FnMut(usize) -> T) -> Self {
        PerStrategy {
            relay: f(0),
            kf1: f(1),
            kf2: f(2),
            kf2_cross: f(3),
            kf2_midstep: f(4),
        }
    }
    /// The value of strategy `i`.
    pub fn get(&self, i: usize) -> &T {
        match i {
            0 => &self.relay,
            1 => &self.kf1,
            2 => &self.kf2,
            3 => &self.kf2_cross,
            _ => &self.kf2_midstep,
        }
    }
}

/// Per-run outcomes of one sweep: `records[point]` holds `(run index, outcome)` in run order.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRecords {
    /// The sweep's identifier.
    pub id: String,
    /// Outcomes per point.
    pub records: Vec<Vec<(usize, Outcome)>>,
}

/// Columns of a `runs_<sweep>.csv` file.
const RUNS_HEADER: [&str; 7] = [
    "point",
    "run",
    "relay_m",
    "kf1_m",
    "kf2_m",
    "kf2_cross_m",
    "kf2_midstep_m",
];

/// Every per-run record of a fueling campaign (or of one shard of it).
#[derive(Debug, Clone, PartialEq)]
pub struct FuelingRecords {
    /// The sweeps', in [`FuelingParams::sweeps`] order.
    pub sweeps: Vec<SweepRecords>,
    /// The particle filter's in the amplitude sweep (no points when it is off).
    pub particle: ParticleRecords,
    /// The rows of the calibration's design, in set order (none when the search is off;
    /// one row per set and its evaluation).
    pub design: Vec<Vec<f64>>,
}

/// One record file per sweep, `runs_<sweep>.csv`, in [`FuelingParams::sweeps`] order: keys
/// (point, run), then the outcome; then `runs_particle.csv` unless the particle filter is
/// off.
impl RunRecords<FuelingParams> for FuelingRecords {
    fn record_files(params: &FuelingParams) -> Vec<RecordFile> {
        let mut files: Vec<RecordFile> = params
            .sweeps()
            .iter()
            .map(|sweep| RecordFile {
                name: format!("runs_{}.csv", sweep.id),
                header: RUNS_HEADER.to_vec(),
                grid: vec![sweep.points.len(), sweep.runs],
            })
            .collect();
        files.extend(particle_record_files(params));
        files.extend(design_record_files(params));
        files
    }

    fn to_tables(&self) -> Vec<Vec<Vec<f64>>> {
        let mut tables = sweep_tables(&self.sweeps);
        tables.extend(self.particle.to_tables());
        if !self.design.is_empty() {
            tables.push(self.design.clone());
        }
        tables
    }

    /// The records of every sweep from the rows of its file; [`Error::Invalid`] if the number
    /// of tables or a row's width does not fit the sweeps.
    fn from_tables(params: &FuelingParams, mut tables: Vec<Vec<Vec<f64>>>) -> Result<Self> {
        let design = if design_record_files(params).is_empty() {
            Vec::new()
        } else {
            let rows = tables.pop().ok_or_else(|| {
                Error::invalid(DESIGN_FILE, "no record file for the calibration's design")
            })?;
            if let Some(row) = rows.iter().find(|r| r.len() != DESIGN_WIDTH) {
                return Err(Error::invalid(
                    DESIGN_FILE,
                    format!("a row of {} fields, expected {DESIGN_WIDTH}", row.len()),
                ));
            }
            rows
        };
        let sweeps = params.sweeps();
        let particle = if particle_runs(params) > 0 {
            if tables.len() != sweeps.len() + 1 {
                return Err(Error::invalid(
                    PARTICLE_FILE,
                    format!(
                        "{} record files for {} sweeps and the particle filter's",
                        tables.len(),
                        sweeps.len()
                    ),
                ));
            }
            tables
                .pop()
                .map(|rows| ParticleRecords::from_table(params, rows))
                .transpose()?
                .unwrap_or_default()
        } else {
            ParticleRecords::default()
        };
        Ok(FuelingRecords {
            sweeps: sweeps_from_tables(&sweeps, tables)?,
            particle,
            design,
        })
    }
}

fn sweep_tables(sweeps: &[SweepRecords]) -> Vec<Vec<Vec<f64>>> {
    sweeps.iter().map(|rec| point_rows(&rec.records)).collect()
}

fn sweeps_from_tables(sweeps: &[Sweep], tables: Vec<Vec<Vec<f64>>>) -> Result<Vec<SweepRecords>> {
    if tables.len() != sweeps.len() {
        return Err(Error::invalid(
            "runs_*.csv",
            format!("{} record files for {} sweeps", tables.len(), sweeps.len()),
        ));
    }
    sweeps
        .iter()
        .zip(tables)
        .map(|(sweep, rows)| {
            Ok(SweepRecords {
                id: sweep.id.to_string(),
                records: from_point_rows(
                    &format!("runs_{}.csv", sweep.id),
                    sweep.points.len(),
                    rows,
                )?,
            })
        })
        .collect()
}

/// Records per point: `(run, values)` in run order.
type PointRecords<const K: usize> = Vec<Vec<(usize, [f64; K])>>;

/// The rows `point, run, values…` of per-point records, in point and then record order.
fn point_rows<const K: usize>(records: &[Vec<(usize, [f64; K])>]) -> Vec<Vec<f64>> {
    records
        .iter()
        .enumerate()
        .flat_map(|(p, runs)| {
            runs.iter().map(move |(run, o)| {
                let mut row = vec![p as f64, *run as f64];
                row.extend_from_slice(o);
                row
            })
        })
        .collect()
}

/// Per-point records of `points` points from the rows `point, run, values…` of `file`.
///
/// # Errors
/// [`Error::Invalid`] naming `file` for a row of the wrong width or a point outside
/// `0..points`.
fn from_point_rows<const K: usize>(
    file: &str,
    points: usize,
    rows: Vec<Vec<f64>>,
) -> Result<PointRecords<K>> {
    let mut records = vec![Vec::new(); points];
    for row in rows {
        let width = || {
            Error::invalid(
                file,
                format!("a row of {} fields, expected {}", row.len(), K + 2),
            )
        };
        let [p, run, o @ ..] = row.as_slice() else {
            return Err(width());
        };
        let values: [f64; K] = o.try_into().map_err(|_| width())?;
        let slot = records
            .get_mut(*p as usize)
            .ok_or_else(|| Error::invalid(file, format!("point {p} outside the sweep")))?;
        slot.push((*run as usize, values));
    }
    Ok(records)
}

/// One run's particle filter: the fuelling error (NaN: never stopped) and the restarts.
pub type ParticleOutcome = [f64; 2];

/// Per-run outcomes: `records[point]` holds `(run index, outcome)` in run order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParticleRecords {
    /// Outcomes per amplitude point.
    pub records: Vec<Vec<(usize, ParticleOutcome)>>,
}

/// Columns of `runs_particle.csv`.
const PARTICLE_HEADER: [&str; 4] = ["point", "run", "particle_m", "restarts"];

/// The record file's name.
pub const PARTICLE_FILE: &str = "runs_particle.csv";

/// Runs per amplitude point of the strategy under `params` (0: off).
pub fn particle_runs(params: &FuelingParams) -> usize {
    params.particle.runs.min(params.runs_per_point)
}

/// The record file of a campaign with `params` (none when the strategy is off).
pub fn particle_record_files(params: &FuelingParams) -> Vec<RecordFile> {
    let runs = particle_runs(params);
    if runs == 0 {
        return Vec::new();
    }
    vec![RecordFile {
        name: PARTICLE_FILE.to_string(),
        header: PARTICLE_HEADER.to_vec(),
        grid: vec![params.amplitudes_deg.len(), runs],
    }]
}

impl ParticleRecords {
    /// The rows of the record file (no table when the strategy is off: no points).
    pub fn to_tables(&self) -> Vec<Vec<Vec<f64>>> {
        if self.records.is_empty() {
            return Vec::new();
        }
        vec![point_rows(&self.records)]
    }

    /// The records from the rows of the record file.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the file for a row of the wrong width or a point outside
    /// the sweep.
    pub fn from_table(params: &FuelingParams, rows: Vec<Vec<f64>>) -> Result<Self> {
        Ok(Self {
            records: from_point_rows(PARTICLE_FILE, params.amplitudes_deg.len(), rows)?,
        })
    }
}

/// The record file of the design: one row per set, the configured set first (set 0), then
/// the Latin hypercube's sets (1 … `design_sets`).
pub const DESIGN_FILE: &str = "calibration_design.csv";

/// The record file of the design for `params` (none when the search is off).
pub fn design_record_files(params: &FuelingParams) -> Vec<RecordFile> {
    let Some(plan) = params.calibration.plan() else {
        return Vec::new();
    };
    let mut header = vec!["set"];
    header.extend(BOX.iter().map(|d| d.key));
    header.extend(DESIGN_COLUMNS);
    vec![RecordFile {
        name: DESIGN_FILE.to_string(),
        header,
        grid: vec![plan.design_sets + 1],
    }]
}

/// The fields of a row of the design's record file: the set, the searched parameters, then
/// the evaluation's sixteen numbers (the ratios with their intervals, the relay's error, the
/// spread, the no-stop fraction, the cost, the rejected flag and the runs used).
pub const DESIGN_WIDTH: usize = 1 + BOX.len() + DESIGN_COLUMNS.len();

/// The columns of the design's record file after the set and the searched parameters.
const DESIGN_COLUMNS: [&str; 16] = [
    "kf1_ratio",
    "kf1_se",
    "kf1_lo",
    "kf1_hi",
    "kf1_runs",
    "kf2_ratio",
    "kf2_se",
    "kf2_lo",
    "kf2_hi",
    "kf2_runs",
    "relay_std_mm",
    "spread",
    "no_stop",
    "cost",
    "rejected",
    "runs_used",
];
