//! The fueling scenario's summary, computed from the per-run records alone: each strategy's
//! systematic and random error per sweep point, straight-line fits against amplitude, the
//! ratios the paper quotes, the invariance table and the filters' model facts the report
//! explains (everything the report shows is a number computed here).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::calibration_records::Calibration;
use super::parameters::{FuelingParams, Sweep, Swept};
pub use super::records::PerStrategy;
use super::records::{FuelingRecords, PARTICLE_FILE, ParticleRecords, SweepRecords, particle_runs};
use super::statistics::{self, Margins, RatioCi, std_ratio};
use crate::error::{Error, Result};
use crate::montecarlo::Shard;

/// The paper's figures at 1°: random error of the one- and two-channel filters as a fraction
/// of relay logic's.
pub const PAPER_KF1_RATIO: f64 = 0.40;
/// See [`PAPER_KF1_RATIO`].
pub const PAPER_KF2_RATIO: f64 = 0.25;

/// Systematic and random error of one strategy at one point, mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stat {
    /// Mean fuelling error (systematic part), mm.
    pub mean_mm: f64,
    /// Sample standard deviation (random part), mm.
    pub std_mm: f64,
}

/// One sweep point: its coordinates and every strategy's statistics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Entry {
    /// Coordinates under their keys (e.g. `amplitude_deg`).
    #[serde(flatten)]
    pub at: BTreeMap<String, f64>,
    /// Statistics per strategy.
    #[serde(flatten)]
    pub stats: PerStrategy<Stat>,
}

/// A straight line `y = intercept + slope·A`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Line {
    /// Slope, mm per degree.
    pub slope_mm_per_deg: f64,
    /// Value at A = 0, mm.
    pub intercept_mm: f64,
}

/// Fits of one strategy's mean and std against amplitude.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Fits {
    /// Systematic error.
    pub mean: Line,
    /// Random error.
    pub std: Line,
}

/// Ratios of random errors to relay logic's at the largest amplitude, with the paper's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ratios {
    /// The amplitude, degrees.
    pub amplitude_deg: f64,
    /// std(strategy)/std(relay).
    pub std_over_relay: PerStrategy<f64>,
    /// The paper's one-channel ratio.
    pub paper_kf1: f64,
    /// The paper's two-channel ratio.
    pub paper_kf2: f64,
}

/// The invariance table: random error over amplitude × period.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Invariance {
    /// Rows, degrees.
    pub amplitudes_deg: Vec<f64>,
    /// Columns, s.
    pub periods_s: Vec<f64>,
    /// Random error per strategy, `[amplitude][period]`, mm.
    pub std_mm: PerStrategy<Vec<Vec<f64>>>,
    /// max − min of each strategy's table, mm (0 = perfectly invariant).
    pub std_spread_mm: PerStrategy<f64>,
}

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Always "fueling".
    pub scenario: &'static str,
    /// Runs per point of the amplitude sweep.
    pub runs_per_point: usize,
    /// Runs per point of the other sweeps.
    pub sweep_runs_per_point: usize,
    /// Campaign seed.
    pub seed: u64,
    /// The slice this summary covers, `K/N` (`None` for a whole or merged campaign; the
    /// campaign writes it into `summary.json`).
    #[serde(skip)]
    pub shard: Option<String>,
    /// Effective parameters.
    pub params: FuelingParams,
    /// The paper's Fig. 1.
    pub amplitude_sweep: Vec<Entry>,
    /// Straight-line fits of the amplitude sweep.
    pub amplitude_fits: PerStrategy<Fits>,
    /// Random-error ratios at the largest amplitude.
    pub at_max_amplitude: Ratios,
    /// Rolling-period sweep.
    pub period_sweep: Vec<Entry>,
    /// Fill-rate sweep.
    pub fill_rate_sweep: Vec<Entry>,
    /// Damper time-constant sweep.
    pub damper_sweep: Vec<Entry>,
    /// Quantization-step sweep.
    pub step_sweep: Vec<Entry>,
    /// H* on a mark (`random_target_phase` 0) against H* anywhere within a step (1).
    pub target_sweep: Vec<Entry>,
    /// Amplitude × period.
    pub invariance: Invariance,
    /// Runs in which a strategy never stopped within the simulated time (excluded from its
    /// statistics), over all sweeps.
    pub runs_without_stop: PerStrategy<usize>,
    /// Ratio intervals and tail quantiles (`statistics`).
    pub margins: Margins,
    /// The exact-likelihood particle filter against the two-channel KF in the amplitude
    /// sweep (absent when off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub particle: Option<ParticleComparison>,
    /// The search over the unstated parameters (absent when off, and in a shard).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Calibration>,
    /// The paper's model fitted back to one simulated record (absent in a shard).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub learned: Option<super::learned::LearnedBack>,
    /// The invariance table's points as sweep entries (`invariance.csv`).
    #[serde(skip)]
    pub invariance_entries: Vec<Entry>,
    /// Set when the filters' model gives the level reading no power at the Nyquist frequency
    /// (the exact-Tustin realisation), which the report explains.
    #[serde(skip)]
    pub nyquist_null: Option<NyquistNull>,
}

/// The level reading's power at the Nyquist frequency in the filters' two-channel model, over
/// δ²/12, at the largest amplitude: this campaign's realisation against the paper's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NyquistNull {
    /// This campaign's realisation.
    pub ours: f64,
    /// The paper's realisation (NaN if its model cannot be built).
    pub paper: f64,
}

/// Mean and sample standard deviation of the finite values, metres in, mm out.
fn stat(values: impl Iterator<Item = f64>) -> Stat {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).map(|x| x * 1e3).collect();
    let n = v.len() as f64;
    if v.is_empty() {
        return Stat {
            mean_mm: f64::NAN,
            std_mm: f64::NAN,
        };
    }
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    Stat {
        mean_mm: mean,
        std_mm: var.sqrt(),
    }
}

/// Least-squares straight line through the finite points.
pub fn fit_line(points: &[(f64, f64)]) -> Line {
    let p: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let n = p.len() as f64;
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { f64::NAN };
    Line {
        slope_mm_per_deg: slope,
        intercept_mm: my - slope * mx,
    }
}

fn entries(sweep: &Sweep, rec: &SweepRecords) -> Vec<Entry> {
    sweep
        .points
        .iter()
        .zip(&rec.records)
        .map(|((xs, _), runs)| Entry {
            at: sweep
                .keys
                .iter()
                .zip(xs)
                .map(|(k, x)| ((*k).to_string(), *x))
                .collect(),
            stats: PerStrategy::from_fn(|i| stat(runs.iter().map(|(_, o)| o[i]))),
        })
        .collect()
}

/// Computes the summary from the records.
///
/// # Errors
/// [`Error::Invalid`] if the records do not match the parameters' sweeps.
pub fn summarise(
    p: &FuelingParams,
    seed: u64,
    shard: Shard,
    all_records: &FuelingRecords,
) -> Result<Summary> {
    let records = all_records.sweeps.as_slice();
    let sweeps = p.sweeps();
    if sweeps.len() != records.len()
        || sweeps
            .iter()
            .zip(records)
            .any(|(s, r)| s.id != r.id || s.points.len() != r.records.len())
    {
        return Err(Error::invalid(
            "runs_*.csv",
            "the per-run records do not match the parameters' sweeps",
        ));
    }
    let all: Vec<Vec<Entry>> = sweeps
        .iter()
        .zip(records)
        .map(|(s, r)| entries(s, r))
        .collect();
    let amp = &all[0];
    let xs: Vec<f64> = amp.iter().map(|e| e.at["amplitude_deg"]).collect();
    let fits = PerStrategy::from_fn(|i| {
        let mean: Vec<(f64, f64)> = xs
            .iter()
            .zip(amp)
            .map(|(x, e)| (*x, e.stats.get(i).mean_mm))
            .collect();
        let std: Vec<(f64, f64)> = xs
            .iter()
            .zip(amp)
            .map(|(x, e)| (*x, e.stats.get(i).std_mm))
            .collect();
        Fits {
            mean: fit_line(&mean),
            std: fit_line(&std),
        }
    });
    let (top_i, top_x) =
        xs.iter().enumerate().fold(
            (0, f64::NEG_INFINITY),
            |b, (i, &x)| if x > b.1 { (i, x) } else { b },
        );
    let top = &amp[top_i].stats;
    let at_max_amplitude = Ratios {
        amplitude_deg: top_x,
        std_over_relay: PerStrategy::from_fn(|i| top.get(i).std_mm / top.relay.std_mm),
        paper_kf1: PAPER_KF1_RATIO,
        paper_kf2: PAPER_KF2_RATIO,
    };
    let inv = &all[6];
    let np = p.invariance_periods_s.len();
    let std_mm = PerStrategy::from_fn(|i| {
        inv.chunks(np)
            .map(|row| row.iter().map(|e| e.stats.get(i).std_mm).collect())
            .collect::<Vec<Vec<f64>>>()
    });
    let std_spread_mm = PerStrategy::from_fn(|i| {
        let v = std_mm.get(i).iter().flatten().copied();
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
        hi - lo
    });
    let runs_without_stop = PerStrategy::from_fn(|i| {
        records
            .iter()
            .flat_map(|s| s.records.iter().flatten())
            .filter(|(_, o)| !o[i].is_finite())
            .count()
    });
    let invariance_entries = all[6].clone();
    let particle = compare_particle(p, &all_records.particle, &records[0])?;
    let margins = statistics::margins(&sweeps, records, top_i, seed);
    let nyquist_null = level_nyquist_power(p, top_x, p.realisation.to_model())
        .filter(|&ours| ours < NYQUIST_NULL)
        .map(|ours| NyquistNull {
            ours,
            paper: level_nyquist_power(p, top_x, model::Realisation::Paper).unwrap_or(f64::NAN),
        });
    let mut it = all.into_iter();
    let mut next = || it.next().unwrap_or_default();
    let amplitude_sweep = next();
    let period_sweep = next();
    let fill_rate_sweep = next();
    let damper_sweep = next();
    let step_sweep = next();
    let target_sweep = next();
    Ok(Summary {
        scenario: "fueling",
        runs_per_point: p.runs_per_point,
        sweep_runs_per_point: p.sweep_runs_per_point,
        seed,
        shard: (shard != Shard::ALL).then(|| shard.to_string()),
        params: p.clone(),
        amplitude_sweep,
        amplitude_fits: fits,
        at_max_amplitude,
        period_sweep,
        fill_rate_sweep,
        damper_sweep,
        step_sweep,
        target_sweep,
        invariance: Invariance {
            amplitudes_deg: p.invariance_amplitudes_deg.clone(),
            periods_s: p.invariance_periods_s.clone(),
            std_mm,
            std_spread_mm,
        },
        runs_without_stop,
        margins,
        particle,
        calibration: None,
        learned: None,
        invariance_entries,
        nyquist_null,
    })
}

/// The particle filter against the paper's two-channel KF at one amplitude, on the same runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParticleEntry {
    /// The amplitude, degrees.
    pub amplitude_deg: f64,
    /// The particle filter's fuelling error, mm.
    pub particle: Stat,
    /// The two-channel KF's on the same runs, mm.
    pub kf2: Stat,
    /// std(particle filter)/std(relay logic), on the runs where both stopped.
    pub particle_to_relay: RatioCi,
    /// std(two-channel KF)/std(relay logic), on the same runs.
    pub kf2_to_relay: RatioCi,
    /// std(particle filter)/std(two-channel KF): below 1, the particle filter is better.
    pub particle_to_kf2: RatioCi,
    /// Runs in which the particle filter never stopped.
    pub runs_without_stop: usize,
    /// Runs in which it restarted at least once (see the module documentation).
    pub runs_restarted: usize,
}

/// Where the particle filter's random error differs from the two-channel KF's beyond the
/// 95 % interval of their ratio.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParticleVerdict {
    /// Amplitudes at which the whole interval of std(PF)/std(KF) is below 1, degrees.
    pub better_deg: Vec<f64>,
    /// Amplitudes at which it is above 1.
    pub worse_deg: Vec<f64>,
    /// Amplitudes at which it contains 1 (no difference shown).
    pub undecided_deg: Vec<f64>,
}

/// `summary.json`'s `particle`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParticleComparison {
    /// Particles N.
    pub particles: usize,
    /// Runs per amplitude (the first this many of the sweep's).
    pub runs: usize,
    /// One entry per amplitude of the sweep.
    pub entries: Vec<ParticleEntry>,
    /// The verdict.
    pub verdict: ParticleVerdict,
}

/// The comparison from the particle filter's records and the amplitude sweep's (`None` when
/// the strategy is off).
///
/// # Errors
/// [`Error::Invalid`] naming the record file if a particle run has no counterpart in the
/// amplitude sweep.
pub fn compare_particle(
    params: &FuelingParams,
    records: &ParticleRecords,
    amplitude: &SweepRecords,
) -> Result<Option<ParticleComparison>> {
    if records.records.is_empty() {
        return Ok(None);
    }
    let mut entries = Vec::with_capacity(records.records.len());
    for ((a, runs), sweep) in params
        .amplitudes_deg
        .iter()
        .zip(&records.records)
        .zip(&amplitude.records)
    {
        let mut pf = Vec::with_capacity(runs.len());
        let mut relay = Vec::with_capacity(runs.len());
        let mut kf2 = Vec::with_capacity(runs.len());
        for (run, o) in runs {
            let (_, other) = sweep.iter().find(|(r, _)| r == run).ok_or_else(|| {
                Error::invalid(
                    PARTICLE_FILE,
                    format!("run {run} at {a}° is not in runs_amplitude.csv"),
                )
            })?;
            pf.push(o[0]);
            relay.push(other[0]);
            kf2.push(other[2]);
        }
        entries.push(ParticleEntry {
            amplitude_deg: *a,
            particle: stat(pf.iter().copied()),
            kf2: stat(kf2.iter().copied()),
            particle_to_relay: std_ratio(&pf, &relay),
            kf2_to_relay: std_ratio(&kf2, &relay),
            particle_to_kf2: std_ratio(&pf, &kf2),
            runs_without_stop: pf.iter().filter(|e| !e.is_finite()).count(),
            runs_restarted: runs.iter().filter(|(_, o)| o[1] > 0.0).count(),
        });
    }
    let at = |f: &dyn Fn(&RatioCi) -> bool| -> Vec<f64> {
        entries
            .iter()
            .filter(|e| f(&e.particle_to_kf2))
            .map(|e| e.amplitude_deg)
            .collect()
    };
    let verdict = ParticleVerdict {
        better_deg: at(&|r| r.hi < 1.0),
        worse_deg: at(&|r| r.lo > 1.0),
        undecided_deg: at(&|r| !(r.hi < 1.0 || r.lo > 1.0)),
    };
    Ok(Some(ParticleComparison {
        particles: params.particle.particles,
        runs: particle_runs(params),
        entries,
        verdict,
    }))
}

/// Nyquist power of a measurement channel of the filters' model, relative to the
/// quantization noise variance δ²/12, below which the channel counts as having none. Exact
/// Tustin gives ≈ 1e-39 (round-off), the paper's and the ZOH realisations ≈ 2.5e-3.
const NYQUIST_NULL: f64 = 1e-9;

/// Nyquist power of the level channel z2 of the two-channel model (`model::FuelModel::
/// nyquist_measurement_power`) over δ²/12, for the world of `p` at `amplitude_deg` built with
/// `realisation` (`None` if the model cannot be built).
fn level_nyquist_power(
    p: &FuelingParams,
    amplitude_deg: f64,
    realisation: model::Realisation,
) -> Option<f64> {
    let fuel = p.world(amplitude_deg, Swept::Nothing).fuel;
    let m = fuel
        .build(model::Channels::LevelAndTilt, realisation)
        .ok()?;
    let power = m.nyquist_measurement_power().ok()?;
    Some(power[1] / (fuel.delta.powi(2) / 12.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_recovers_a_line() {
        let pts: Vec<(f64, f64)> = (0..5)
            .map(|i| (f64::from(i), 2.0 + 3.0 * f64::from(i)))
            .collect();
        let l = fit_line(&pts);
        // Exact data: only round-off separates the fit from (3, 2).
        assert!((l.slope_mm_per_deg - 3.0).abs() < 1e-12);
        assert!((l.intercept_mm - 2.0).abs() < 1e-12);
    }

    #[test]
    fn stat_skips_runs_without_a_stop() {
        let s = stat([0.001, f64::NAN, 0.003].into_iter());
        assert!((s.mean_mm - 2.0).abs() < 1e-12);
        assert!((s.std_mm - 2f64.sqrt()).abs() < 1e-12);
    }
}
