//! The flightpath scenario's summary: the nominal run's comparison table (truth, both
//! methods' estimates and bounds), the Monte Carlo honesty of the bounds (RMS normalised
//! error and 95 % coverage per error and pooled), the trajectory errors and the smoothed
//! NEES against its χ² band, and the verdict — every number the report shows.

use serde::Serialize;

use super::estimate::{self, Estimates};
use super::model::{N_ERR, N_KIN};
use super::parameters::FlightPathParams;
use super::records::{ERRORS, RunRecord};
use super::simulation::{Flight, flight, nees, rms_groups, smoothed_error, true_state};
use crate::error::Result;
use sensors::flight::TruthPoint;

/// A run's estimates and standard deviations of the twelve errors.
type EstStd = ([f64; N_ERR], [f64; N_ERR]);

/// One method's estimate of one error, in its display unit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MethodEstimate {
    /// The estimate.
    pub estimate: f64,
    /// Its standard deviation (smoothed, or the Cramér–Rao bound).
    pub std: f64,
}

/// One instrument error on the nominal run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterRow {
    /// Name.
    pub name: &'static str,
    /// Display unit.
    pub unit: &'static str,
    /// The truth (absent for a recorded flight).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth: Option<f64>,
    /// The filter–smoother's estimate.
    pub filter_smoother: MethodEstimate,
    /// The output-error estimate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output_error: Option<MethodEstimate>,
}

/// Monte Carlo honesty of one error's bounds.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct McEntry {
    /// Name.
    pub name: &'static str,
    /// RMS over runs of (estimate − truth)/std (1 for honest bounds).
    pub rms_normalised_error: f64,
    /// Fraction of runs whose ±1.96 std interval covers the truth.
    pub coverage95: f64,
}

/// The same pooled over every error and run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pooled {
    /// RMS normalised error over all errors and runs.
    pub rms_normalised_error: f64,
    /// Coverage over all errors and runs.
    pub coverage95: f64,
}

/// The Monte Carlo section.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MonteCarlo {
    /// Runs.
    pub runs: usize,
    /// Per error, the filter–smoother.
    pub filter_smoother: Vec<McEntry>,
    /// Per error, the output-error fit.
    pub output_error: Vec<McEntry>,
    /// Pooled, per method.
    pub pooled: PooledPair,
}

/// Pooled figures of both methods.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PooledPair {
    /// Filter–smoother.
    pub filter_smoother: Pooled,
    /// Output error.
    pub output_error: Pooled,
}

/// RMS trajectory errors of one group over every run and step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Group {
    /// Unit.
    pub unit: &'static str,
    /// Filtered x_{k|k}.
    pub filtered_rms: f64,
    /// Smoothed x_{k|N}.
    pub smoothed_rms: f64,
}

/// The smoothed NEES at mid-record, averaged over runs, with its χ² band.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NeesSummary {
    /// Mean over runs (n = 21 expected).
    pub mean: f64,
    /// χ²_{R·n} 95 % band of the mean, divided by R.
    pub band: [f64; 2],
    /// State dimension n.
    pub dof: usize,
}

/// The trajectory section.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Trajectory {
    /// Position (m).
    pub position: Group,
    /// Velocity (m/s).
    pub velocity: Group,
    /// Attitude (deg).
    pub attitude: Group,
    /// The smoothed NEES.
    pub nees_smoothed: NeesSummary,
}

/// The acceptance checks and the sentence they give.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// Largest |estimate − truth|/std on the nominal run, per method.
    pub nominal_max_normalised_error: [f64; 2],
    /// Every error's RMS normalised error within [0.6, 1.6], per method.
    pub rms_in_range: [bool; 2],
    /// Pooled coverage within [0.85, 1], per method.
    pub coverage_in_range: [bool; 2],
    /// Smoothed RMS below filtered in every group.
    pub smoothed_beats_filtered: bool,
    /// Mean smoothed NEES inside its band.
    pub nees_in_band: bool,
    /// The plain statement.
    pub text: String,
}

/// The unscented filter–smoother (cubature points, one pass) on the nominal run, beside
/// the iterated extended one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct UnscentedNominal {
    /// RMS error of the filtered trajectory: position (m), velocity (m/s), attitude (deg).
    pub filtered_rms: [f64; 3],
    /// RMS error of the smoothed trajectory, the same units.
    pub smoothed_rms: [f64; 3],
    /// The iterated extended smoother's smoothed RMS on the same run, the same units.
    pub extended_smoothed_rms: [f64; 3],
    /// Largest |estimate − truth|/σ over the twelve instrument errors.
    pub max_normalised_error: f64,
    /// The smoothed NEES of the whole state at mid-record.
    pub nees_mid: f64,
    /// Its χ²(21) 95 % band for one run.
    pub nees_band: [f64; 2],
}

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlightPathSummary {
    /// Always "flightpath".
    pub scenario: &'static str,
    /// Campaign seed.
    pub seed: u64,
    /// The parameters used.
    pub params: FlightPathParams,
    /// The nominal run (run 0): one row per instrument error.
    pub parameters: Vec<ParameterRow>,
    /// The Monte Carlo section.
    pub monte_carlo: MonteCarlo,
    /// The trajectory section.
    pub trajectory: Trajectory,
    /// Gated entries on the nominal run (air data, AHRS, GNSS) and wild points planted.
    pub nominal_rejected: [usize; 3],
    /// The output-error fit's iterations on the nominal run.
    pub nominal_output_error_iterations: usize,
    /// The output-error correlation matrix of the errors on the nominal run (row-major).
    pub nominal_output_error_correlation: Vec<Vec<f64>>,
    /// The unscented filter–smoother on the nominal run.
    pub nominal_unscented: UnscentedNominal,
    /// The verdict.
    pub verdict: Verdict,
}

/// The summary and what the plots need of the nominal run.
#[derive(Debug, Clone)]
pub struct Computed {
    /// `summary.json`.
    pub summary: FlightPathSummary,
    /// The nominal run's estimates.
    pub nominal: Estimates,
    /// Its grid's stamps.
    pub t: Vec<f64>,
    /// Its truth on the grid.
    pub truth: Vec<TruthPoint>,
    /// The Monte Carlo normalised errors per method (runs × errors).
    pub normalised: [Vec<[f64; N_ERR]>; 2],
}

/// The 95 % two-sided normal point, √χ²₁(0.95).
pub fn z95() -> f64 {
    kalman::chi2_quantile(0.95, 1).sqrt()
}

/// The nominal table of one record's estimates (truth when known), display units.
pub fn parameter_rows(est: &Estimates, truth: Option<&[f64; N_ERR]>) -> Vec<ParameterRow> {
    (0..N_ERR)
        .map(|j| {
            let (name, unit, f) = ERRORS[j];
            ParameterRow {
                name,
                unit,
                truth: truth.map(|t| t[j] * f),
                filter_smoother: MethodEstimate {
                    estimate: est.pass.smoothed[(N_KIN + j, 0)] * f,
                    std: est.pass.smoothed_var[(N_KIN + j, 0)].sqrt() * f,
                },
                output_error: est.output_error.as_ref().map(|o| MethodEstimate {
                    estimate: o.estimate[j] * f,
                    std: o.std[j] * f,
                }),
            }
        })
        .collect()
}

fn honesty(z: &[[f64; N_ERR]]) -> (Vec<McEntry>, Pooled) {
    let n = z.len().max(1) as f64;
    let c = z95();
    let entries = (0..N_ERR)
        .map(|j| McEntry {
            name: ERRORS[j].0,
            rms_normalised_error: (z.iter().map(|r| r[j] * r[j]).sum::<f64>() / n).sqrt(),
            coverage95: z.iter().filter(|r| r[j].abs() <= c).count() as f64 / n,
        })
        .collect();
    let all = n * N_ERR as f64;
    let pooled = Pooled {
        rms_normalised_error: (z.iter().flatten().map(|v| v * v).sum::<f64>() / all).sqrt(),
        coverage95: z.iter().flatten().filter(|v| v.abs() <= c).count() as f64 / all,
    };
    (entries, pooled)
}

/// Every number of the outputs, from the parameters and the records (and run 0 recomputed
/// from the seed for the nominal table and plots).
///
/// # Errors
/// As [`flight`] and the estimators.
pub fn summarise(p: &FlightPathParams, seed: u64, records: &[RunRecord]) -> Result<Computed> {
    let fl = flight(p, seed, 0)?;
    let mid = fl.grid.t.len() / 2;
    let nominal = estimate::both(&fl.data, &fl.grid, &fl.noise, p, &[mid])?;
    let errors = p.flight.errors.si();
    let nominal_unscented = unscented_nominal(p, &fl, &nominal, &errors)?;
    let truth = fl.truth;
    let t = truth.iter().map(|tp| tp.t).collect();
    let parameters = parameter_rows(&nominal, Some(&errors));
    let z = |est: &dyn Fn(&RunRecord) -> EstStd| -> Vec<[f64; N_ERR]> {
        records
            .iter()
            .map(|r| {
                let (e, s) = est(r);
                std::array::from_fn(|j| (e[j] - errors[j]) / s[j])
            })
            .collect()
    };
    let zf = z(&|r| (r.fs_estimate, r.fs_std));
    let zo = z(&|r| (r.oe_estimate, r.oe_std));
    let (fs_entries, fs_pooled) = honesty(&zf);
    let (oe_entries, oe_pooled) = honesty(&zo);
    let runs = records.len();
    let rn = runs.max(1) as f64;
    let group = |i: usize, unit: &'static str, f: f64| Group {
        unit,
        filtered_rms: (records
            .iter()
            .map(|r| r.filtered_rms[i].powi(2))
            .sum::<f64>()
            / rn)
            .sqrt()
            * f,
        smoothed_rms: (records
            .iter()
            .map(|r| r.smoothed_rms[i].powi(2))
            .sum::<f64>()
            / rn)
            .sqrt()
            * f,
    };
    let dof = N_KIN + N_ERR;
    let total_dof = dof * runs.max(1);
    let nees = NeesSummary {
        mean: records.iter().map(|r| r.nees_smoothed).sum::<f64>() / rn,
        band: [
            kalman::chi2_quantile(0.025, total_dof) / rn,
            kalman::chi2_quantile(0.975, total_dof) / rn,
        ],
        dof,
    };
    let trajectory = Trajectory {
        position: group(0, "m", 1.0),
        velocity: group(1, "m/s", 1.0),
        attitude: group(2, "deg", 180.0 / std::f64::consts::PI),
        nees_smoothed: nees,
    };
    let nominal_max = |m: usize| {
        parameters
            .iter()
            .map(|row| {
                let e = if m == 0 {
                    Some(row.filter_smoother)
                } else {
                    row.output_error
                };
                e.map_or(f64::NAN, |e| {
                    (e.estimate - row.truth.unwrap_or(f64::NAN)).abs() / e.std
                })
            })
            .fold(0.0, f64::max)
    };
    let in_range = |e: &[McEntry]| {
        e.iter()
            .all(|x| (0.6..=1.6).contains(&x.rms_normalised_error))
    };
    let cov = |p: &Pooled| (0.85..=1.0).contains(&p.coverage95);
    let groups = [
        trajectory.position,
        trajectory.velocity,
        trajectory.attitude,
    ];
    let mut verdict = Verdict {
        nominal_max_normalised_error: [nominal_max(0), nominal_max(1)],
        rms_in_range: [in_range(&fs_entries), in_range(&oe_entries)],
        coverage_in_range: [cov(&fs_pooled), cov(&oe_pooled)],
        smoothed_beats_filtered: groups.iter().all(|g| g.smoothed_rms < g.filtered_rms),
        nees_in_band: nees.mean >= nees.band[0] && nees.mean <= nees.band[1],
        text: String::new(),
    };
    verdict.text = verdict_text(&verdict, runs);
    let oe = nominal.output_error.as_ref();
    let summary = FlightPathSummary {
        scenario: "flightpath",
        seed,
        params: p.clone(),
        parameters,
        monte_carlo: MonteCarlo {
            runs,
            filter_smoother: fs_entries,
            output_error: oe_entries,
            pooled: PooledPair {
                filter_smoother: fs_pooled,
                output_error: oe_pooled,
            },
        },
        trajectory,
        nominal_rejected: nominal.pass.rejected,
        nominal_output_error_iterations: oe.map_or(0, |o| o.iterations),
        nominal_output_error_correlation: oe.map_or_else(Vec::new, |o| {
            o.correlation.chunks(N_ERR).map(<[f64]>::to_vec).collect()
        }),
        nominal_unscented,
        verdict,
    };
    Ok(Computed {
        summary,
        nominal,
        t,
        truth,
        normalised: [zf, zo],
    })
}

/// The unscented filter–smoother on the nominal flight `fl`, against its truth and beside
/// the extended smoother's estimates `nominal`.
fn unscented_nominal(
    p: &FlightPathParams,
    fl: &Flight,
    nominal: &Estimates,
    errors: &[f64; N_ERR],
) -> Result<UnscentedNominal> {
    let mid = fl.grid.t.len() / 2;
    let pass = estimate::unscented(&fl.data, &fl.grid, &fl.noise, p, &[mid])?;
    let display = |v: [f64; 3]| [v[0], v[1], v[2].to_degrees()];
    let max_normalised_error = (0..N_ERR)
        .map(|j| {
            (pass.smoothed[(N_KIN + j, 0)] - errors[j]).abs()
                / pass.smoothed_var[(N_KIN + j, 0)].sqrt()
        })
        .fold(0.0, f64::max);
    let x_true = true_state(&fl.truth[mid], errors);
    let dof = N_KIN + N_ERR;
    Ok(UnscentedNominal {
        filtered_rms: display(rms_groups(&pass.filtered, &fl.truth)),
        smoothed_rms: display(rms_groups(&pass.smoothed, &fl.truth)),
        extended_smoothed_rms: display(rms_groups(&nominal.pass.smoothed, &fl.truth)),
        max_normalised_error,
        nees_mid: nees(
            &smoothed_error(&pass, mid, &x_true),
            &pass.smoothed_cov_at[0],
        ),
        nees_band: [
            kalman::chi2_quantile(0.025, dof),
            kalman::chi2_quantile(0.975, dof),
        ],
    })
}

/// The verdict in words, from the checks.
fn verdict_text(v: &Verdict, runs: usize) -> String {
    let method = ["filter–smoother", "output error"];
    let mut parts = Vec::new();
    for m in 0..2 {
        let ok =
            v.nominal_max_normalised_error[m] <= 4.0 && v.rms_in_range[m] && v.coverage_in_range[m];
        parts.push(format!(
            "{}: {} (nominal run within {:.1} σ of the truth; over {runs} runs the RMS normalised \
             error {} [0.6, 1.6] and the pooled 95 % coverage {} [0.85, 1])",
            method[m],
            if ok {
                "its bounds are honest"
            } else {
                "its bounds are NOT honest"
            },
            v.nominal_max_normalised_error[m],
            if v.rms_in_range[m] {
                "of every error lies in"
            } else {
                "of some error lies outside"
            },
            if v.coverage_in_range[m] {
                "lies in"
            } else {
                "is outside"
            },
        ));
    }
    parts.push(format!(
        "the smoothed trajectory {} the filtered one in every group, and the smoothed NEES {} \
         its χ² band",
        if v.smoothed_beats_filtered {
            "beats"
        } else {
            "does NOT beat"
        },
        if v.nees_in_band {
            "lies in"
        } else {
            "lies outside"
        },
    ));
    let mut s = parts.join("; ");
    s.push('.');
    s
}
