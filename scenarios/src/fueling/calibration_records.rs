//! What the calibration's stages write and read: an evaluated set ([`Evaluation`]), the
//! design's record rows ([`DesignRecord`], the file `calibration_design.csv` of
//! [`super::records`]), the closing stage's numbers ([`Refinement`]) and the summary's
//! section built from them ([`Calibration`]). The search itself is the module `calibration`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::parameters::{FuelingParams, Search};
use super::records::{DESIGN_FILE, DESIGN_WIDTH};
use super::search::{BOX, Dim};
use super::statistics::RatioCi;
use crate::error::{Error, Result};

/// One evaluated set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// The searched parameters' values, in [`BOX`] order.
    pub values: Vec<f64>,
    /// std(one-channel KF)/std(relay) at the headline amplitude.
    pub kf1: RatioCi,
    /// std(two-channel KF)/std(relay) at the headline amplitude.
    pub kf2: RatioCi,
    /// Relay logic's random error at the headline amplitude, mm.
    pub relay_std_mm: f64,
    /// Two-channel invariance spread (max − min)/max over the corners (NaN if not computed).
    pub spread: f64,
    /// Fraction of runs in which relay logic or a filter never stopped.
    pub no_stop: f64,
    /// The objective J.
    pub cost: f64,
    /// Why the set could not be run (the model or a filter rejected it), if so.
    pub rejected: Option<String>,
}

/// How the two ratios move when one parameter moves by a tenth of its range either way.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sensitivity {
    /// The parameter.
    pub key: &'static str,
    /// Its value below and above the best set's.
    pub values: [f64; 2],
    /// One-channel ratio at those values.
    pub kf1: [f64; 2],
    /// Two-channel ratio at those values.
    pub kf2: [f64; 2],
}

/// The best set's ratio against the paper's figure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gap {
    /// The paper's figure.
    pub paper: f64,
    /// The ratio on the fresh seed, with its 95 % interval.
    pub ours: RatioCi,
    /// Signed distance from the 95 % interval to the paper's figure ± `tolerance` (0 if they
    /// overlap; > 0: every value in the interval is above).
    pub gap: f64,
}

/// The verdict, from the fresh-seed numbers.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// The paper quotes "≈ 0.40" and "≈ 0.25": read as ± this.
    pub tolerance: f64,
    /// One-channel ratio.
    pub kf1: Gap,
    /// Two-channel ratio.
    pub kf2: Gap,
    /// Both ratios' intervals reach the paper's figures within the tolerance.
    pub reproduced: bool,
    /// Parameters of the best set within 2 % of their range from a bound of the box (where a
    /// wider box might help).
    pub at_bounds: Vec<&'static str>,
}

/// The best set found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Best {
    /// The searched parameters' values.
    pub params: BTreeMap<&'static str, f64>,
    /// Its evaluation on the search streams (ratios with their standard errors).
    pub search: Evaluation,
    /// Its evaluation on a fresh seed.
    pub fresh: Evaluation,
    /// Runs per point of the fresh evaluation.
    pub fresh_runs: usize,
}

/// `summary.json`'s `calibration`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    /// The search setting.
    pub search: Search,
    /// Sets evaluated on the search streams (design and refinement).
    pub searched: usize,
    /// Of which in the Latin hypercube.
    pub design_sets: usize,
    /// Runs per set during the search.
    pub runs_per_set: usize,
    /// Monte Carlo runs simulated by the calibration in all (search, sensitivity, fresh).
    pub runs_used: usize,
    /// Seed of the search streams.
    pub search_seed: u64,
    /// Seed of the fresh evaluation.
    pub fresh_seed: u64,
    /// The headline amplitude, degrees.
    pub amplitude_deg: f64,
    /// The invariance corners (amplitude °, period s).
    pub corners: Vec<(f64, f64)>,
    /// Weight of the invariance spread.
    pub invariance_weight: f64,
    /// The paper's ratios the search aims at.
    pub paper: (f64, f64),
    /// The box.
    #[serde(rename = "box")]
    pub bounds: Vec<Dim>,
    /// The configured parameters on the search streams.
    pub defaults: Evaluation,
    /// The best set.
    pub best: Best,
    /// One-at-a-time sensitivity around the best set.
    pub sensitivity: Vec<Sensitivity>,
    /// The verdict.
    pub verdict: Verdict,
    /// The configured parameters with the best set in place and the search off (the content
    /// of `calibration.toml`).
    #[serde(skip)]
    pub best_params: FuelingParams,
    /// Every evaluation of the search, in order (`calibration_sets.csv`).
    #[serde(skip)]
    pub evaluations: Vec<Evaluation>,
}

/// One set of the design as its record holds it: the evaluation without the text of a
/// rejection (which the closing stage supplies, [`Refinement::rejections`]).
#[derive(Debug, Clone, PartialEq)]
pub struct DesignRecord {
    /// 0 for the configured set, `i` for the Latin hypercube's set `i − 1`.
    pub set: usize,
    /// Its evaluation on the search streams; `rejected` is `Some("")` for a rejected set.
    pub evaluation: Evaluation,
    /// Monte Carlo runs the evaluation simulated.
    pub runs_used: usize,
}

impl DesignRecord {
    /// The record's row, in the header order of [`super::records::design_record_files`].
    pub fn to_row(&self) -> Vec<f64> {
        let e = &self.evaluation;
        let mut row = vec![self.set as f64];
        row.extend(&e.values);
        for r in [e.kf1, e.kf2] {
            row.extend([r.ratio, r.se, r.lo, r.hi, r.runs as f64]);
        }
        row.extend([
            e.relay_std_mm,
            e.spread,
            e.no_stop,
            e.cost,
            f64::from(u8::from(e.rejected.is_some())),
            self.runs_used as f64,
        ]);
        row
    }

    /// The record of `row`, or `None` if it does not have the header's width.
    pub fn from_row(row: &[f64]) -> Option<Self> {
        let [set, rest @ ..] = row else { return None };
        if row.len() != DESIGN_WIDTH {
            return None;
        }
        let (values, r) = rest.split_at(BOX.len());
        let ratio = |r: &[f64]| RatioCi {
            ratio: r[0],
            se: r[1],
            lo: r[2],
            hi: r[3],
            runs: r[4] as usize,
        };
        Some(Self {
            set: *set as usize,
            evaluation: Evaluation {
                values: values.to_vec(),
                kf1: ratio(&r[0..5]),
                kf2: ratio(&r[5..10]),
                relay_std_mm: r[10],
                spread: r[11],
                no_stop: r[12],
                cost: r[13],
                rejected: (r[14] != 0.0).then(String::new),
            },
            runs_used: r[15] as usize,
        })
    }
}

/// The records of a design table, checked: one per set in set order.
///
/// # Errors
/// [`Error::Invalid`] naming [`DESIGN_FILE`] for a row of the wrong width.
pub fn design_from_table(rows: &[Vec<f64>]) -> Result<Vec<DesignRecord>> {
    rows.iter()
        .map(|row| {
            DesignRecord::from_row(row).ok_or_else(|| {
                Error::invalid(
                    DESIGN_FILE,
                    format!("a row of {} fields, expected {DESIGN_WIDTH}", row.len()),
                )
            })
        })
        .collect()
}

/// An evaluation of the refinement, with the unit coordinates it was made at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refined {
    /// The set, in unit coordinates (clamped to the cube).
    pub units: Vec<f64>,
    /// Its evaluation on the search streams.
    pub evaluation: Evaluation,
}

/// Why a design set was rejected.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Rejection {
    /// The set, as in [`DesignRecord::set`].
    pub set: usize,
    /// The model's or the filter's message.
    pub message: String,
}

/// What the calibration computes once the whole design is in: the Nelder–Mead refinement,
/// the sensitivity around the best set and its fresh evaluation (the campaign's closing
/// stage, after every shard).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    /// The refinement's evaluations, in order.
    pub refined: Vec<Refined>,
    /// Two evaluations per parameter (below, above the best set), in [`BOX`] order.
    pub sensitivity: Vec<Evaluation>,
    /// The best set on the fresh seed.
    pub fresh: Evaluation,
    /// Monte Carlo runs of the refinement, the sensitivity and the fresh evaluation.
    pub runs_used: usize,
    /// The messages of the rejected design sets, in set order.
    pub rejections: Vec<Rejection>,
}
