//! The boom scenario's summary: every turn the report shows (the paper's cases, the γ sweep,
//! the 32 unit/weight option sets and their verdicts, the beyond-the-paper cases, the
//! tracking filters' cases, bias-free turns and noise Monte Carlo), reduced to the numbers of
//! `summary.json`.

use std::path::Path;

use serde::{Deserialize, Serialize};
use wls::boom::{
    AngleRecovery, AngleUnit, BoomConfig, BoomMethod, ErrorVariant, Sign, TrajectoryPoint, TurnRun,
    run_turn, sweep_gamma,
};

use super::parameters::{BoomParams, EstimatorParams, LimitParams, Method};
use super::records::{NOISE_METHODS, NoiseRecord};
use super::simulation::{Meter, TurnStats, readings, replay, stats, tracked_runs, wls_err};
use super::tracking::{TrackingModel, jerk_intensity};
use crate::campaign::ScenarioParams;
use crate::error::{Error, Result};
use crate::montecarlo::{par_runs, run_rng};

/// One turn's errors against the nominal trajectory, as the `cases` and alternatives tables
/// show them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TurnErrors {
    /// γ, degrees.
    pub gamma_deg: f64,
    /// The error variant.
    pub bias: Sign,
    /// Worst |α̂ − α_n| over the defined cycles after the start-up cycle, degrees.
    pub max_alpha_err_deg: f64,
    /// Worst |ε̂ − ε_n| over the defined cycles after the start-up cycle, °/s².
    pub max_eps_err_deg_s2: f64,
    /// Nominal α at the first undefined cycle, degrees (null: defined throughout). For the
    /// WLS family: no estimate that cycle (arcsin of |s| > 1, g² < a_x²); for the filters and
    /// the smoother: the first cycle whose step the library refused (singular innovation
    /// covariance, sigma-point covariance not PSD, a non-finite value), undefined from there
    /// to the end of the turn.
    pub undefined_from_alpha_deg: Option<f64>,
    /// Nominal α at the first cycle after the start-up cycle with δα > Δα or δε > Δε, an
    /// undefined cycle counting as over (the same rule for every method), degrees.
    pub first_violation_alpha_deg: Option<f64>,
}

impl TurnErrors {
    /// The errors of `run` at offset angle `gamma_deg`, from its statistics `s`.
    fn new(gamma_deg: f64, run: &TurnRun, s: &TurnStats) -> Self {
        Self {
            gamma_deg,
            bias: run.sign,
            max_alpha_err_deg: s.max_alpha_deg,
            max_eps_err_deg_s2: s.max_eps_deg,
            undefined_from_alpha_deg: s.undefined_from_deg,
            first_violation_alpha_deg: s.violation.map(|v| v.1),
        }
    }
}

/// One row of the `cases` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseSummary {
    /// The estimator.
    pub method: Method,
    /// Its errors.
    #[serde(flatten)]
    pub turn: TurnErrors,
}

/// One row of the noise Monte Carlo: white noise σ on top of ±Δa, `runs` turns per variant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseMcRow {
    /// The estimator (`wls`, `ekf`, `ukf`, `urts`).
    pub method: Method,
    /// γ, degrees.
    pub gamma_deg: f64,
    /// Monte Carlo runs (each a "+" and a "−" turn with the same noise draws).
    pub runs: usize,
    /// √(mean over the runs of the run's mean square δα), over the defined cycles after the
    /// start-up cycle, degrees.
    pub rms_alpha_err_deg: f64,
    /// The same for δε, °/s².
    pub rms_eps_err_deg_s2: f64,
}

/// One turn without bias or noise: what the method makes of exact readings (the
/// reference a constant bias is measured against).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BiasFreeRow {
    /// The estimator.
    pub method: Method,
    /// γ, degrees.
    pub gamma_deg: f64,
    /// As in [`CaseSummary`].
    pub max_alpha_err_deg: f64,
    /// As in [`CaseSummary`].
    pub max_eps_err_deg_s2: f64,
    /// As in [`CaseSummary`].
    pub undefined_from_alpha_deg: Option<f64>,
}

/// The tracking formulation's settings as run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrackingSummary {
    /// White-jerk intensity q used, (°/s²)²/s.
    pub jerk_psd_deg2_s5: f64,
    /// Measurement σ the filters assume in the paper's cases (√R = Δa), m/s².
    pub r_std_cases_mps2: f64,
    /// Measurement σ the filters assume in the Monte Carlo (√(Δa² + σ²)), m/s².
    pub r_std_noise_mps2: f64,
    /// White-noise σ of the Monte Carlo, m/s².
    pub noise_std_mps2: f64,
}

/// What a constant ±Δa does to one method at one γ, next to its bias-free turn.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BiasEffect {
    /// The estimator.
    pub method: Method,
    /// γ, degrees.
    pub gamma_deg: f64,
    /// Worst δα without bias, degrees.
    pub bias_free_alpha_deg: f64,
    /// Worst δα over "+" and "−", degrees.
    pub with_bias_alpha_deg: f64,
    /// Worst δε over "+" and "−", °/s².
    pub with_bias_eps_deg_s2: f64,
    /// Nominal α where that worst δα occurs, degrees.
    pub alpha_at_worst_deg: f64,
    /// Both variants defined and within both limits.
    pub within_limits: bool,
}

/// The conditions the report's "Nonlinear filters against WLS" comment is written from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrackingVerdict {
    /// The γ the conditioning question is asked at (0 when it is a case γ, else the
    /// smallest case γ), degrees.
    pub low_gamma_deg: f64,
    /// Worst bias-free δα of the EKF, UKF and smoother at that γ, degrees.
    pub filters_bias_free_alpha_deg: f64,
    /// Worst bias-free δε of the EKF, UKF and smoother at that γ, °/s².
    pub filters_bias_free_eps_deg_s2: f64,
    /// The WLS's bias-free δα at that γ, degrees.
    pub wls_bias_free_alpha_deg: f64,
    /// The WLS's bias-free δε at that γ, °/s².
    pub wls_bias_free_eps_deg_s2: f64,
    /// The filters, bias-free at that γ, stay defined, within both limits and below the
    /// WLS's errors: carrying the state cures the 90° ill-conditioning without the offset.
    pub state_cures_conditioning: bool,
    /// Per method (WLS, EKF, UKF, smoother) and case γ: the bias's effect.
    pub bias_effects: Vec<BiasEffect>,
    /// The smoother's Monte Carlo RMS δα and δε are at most the UKF's at every case γ.
    pub smoother_not_worse: bool,
}

/// One row of the γ sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepRow {
    /// γ, degrees.
    pub gamma_deg: f64,
    /// Both variants within both limits over the whole turn (after start-up).
    pub within_limits: bool,
    /// Worst angle error over both variants, degrees.
    pub max_alpha_err_deg: f64,
    /// Worst ε error over both variants, °/s².
    pub max_eps_err_deg_s2: f64,
}

/// One row of the WLS unit/weight alternatives table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlternativeRow {
    /// The options.
    pub options: EstimatorParams,
    /// Its errors.
    #[serde(flatten)]
    pub turn: TurnErrors,
    /// Time of the first violation, s.
    pub first_violation_t_s: Option<f64>,
    /// The α error stayed within Δα (defined cycles, and no undefined cycle).
    pub alpha_within: bool,
    /// The ε error stayed within Δε (defined cycles, and no undefined cycle).
    pub eps_within: bool,
}

/// How one option set compares with the paper's Figs. 5 and 7.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlternativeVerdict {
    /// The options.
    pub options: EstimatorParams,
    /// γ = 0: both variants defined over the whole turn (paper: "the parameters are defined").
    pub defined_at_0: bool,
    /// γ = 0: δα within Δα for both variants (paper Fig. 5).
    pub alpha_within_at_0: bool,
    /// γ = 0: at most one variant exceeds Δε, only past α = 75° (paper: δε⁺ past 81°).
    pub eps_pattern_at_0: bool,
    /// γ = 10°: both variants within both limits (paper Fig. 7).
    pub within_at_10: bool,
    /// All four: the option set reproduces the paper's WLS figures.
    pub reproduces_paper: bool,
    /// γ = 0: the departures from the limits, e.g. "+: δε from 78.9° (28.8 s)".
    pub departures_at_0: Vec<String>,
    /// The feasible γ window of the sweep under these options, degrees.
    pub feasible_gamma_deg: Option<[f64; 2]>,
}

/// A beyond-the-paper case.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BeyondRow {
    /// What was added.
    pub label: Addition,
    /// Method.
    pub method: Method,
    /// γ, degrees.
    pub gamma_deg: f64,
    /// The error variant.
    pub bias: Sign,
    /// Centripetal term ω²·r in the readings.
    pub centripetal: bool,
    /// Noise σ per axis, m/s².
    pub noise_std_mps2: f64,
    /// As in [`CaseSummary`].
    pub max_alpha_err_deg: f64,
    /// As in [`CaseSummary`].
    pub max_eps_err_deg_s2: f64,
    /// No undefined cycle, both maxima within the limits.
    pub within_limits: bool,
}

/// `summary.json` of the scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoomSummary {
    /// Always "boom".
    pub scenario: String,
    /// Campaign seed (used only by the noisy beyond-the-paper cases).
    pub seed: u64,
    /// The parameters used.
    pub params: BoomParams,
    /// Δα (degrees) and Δε (°/s²).
    pub limits: LimitParams,
    /// Cycles excluded from the maxima at the start of each turn (the start-up cycle, which
    /// uses direct inversion whatever the method).
    pub startup_cycles_excluded: usize,
    /// ε_d of the turn, °/s².
    pub deceleration_deg_s2: f64,
    /// Duration of the nominal turn, s.
    pub turn_duration_s: f64,
    /// Cruise rate, rad/s.
    pub cruise_rate_rad_s: f64,
    /// The centripetal acceleration ω²r at the sensor at the cruise rate, m/s².
    pub centripetal_mps2: f64,
    /// `centripetal_mps2` in units of the limiting error Δa.
    pub centripetal_over_limit: f64,
    /// The sensor's range clips the "+" variant's a_y (g·cos α + ε·r + Δa > range) up to this
    /// nominal α, degrees (γ = 0); null if it never does.
    pub saturated_until_alpha_deg: Option<f64>,
    /// Direct, linear3, WLS, EKF, UKF and the unscented RTS smoother at each case γ under
    /// "+" and "−".
    pub cases: Vec<CaseSummary>,
    /// The tracking model's settings.
    pub tracking: TrackingSummary,
    /// WLS and the filters on exact readings (no bias, no noise) at each case γ.
    pub bias_free: Vec<BiasFreeRow>,
    /// The noise Monte Carlo: per case γ and method, RMS errors over `runs` noisy turns.
    pub noise_mc: Vec<NoiseMcRow>,
    /// What the report says about the filters against the WLS, as computed conditions.
    pub tracking_verdict: TrackingVerdict,
    /// The γ sweep of WLS.
    pub gamma_sweep: Vec<SweepRow>,
    /// The contiguous feasible window starting at the smallest feasible γ, degrees.
    pub feasible_gamma_deg: Option<[f64; 2]>,
    /// WLS unit/weight alternatives at γ = 0 and 10°.
    pub alternatives: Vec<AlternativeRow>,
    /// Per option set: does it reproduce the paper?
    pub alternative_verdicts: Vec<AlternativeVerdict>,
    /// Beyond the paper (empty when disabled).
    pub beyond_paper: Vec<BeyondRow>,
    /// The feasible γ window with the centripetal term on (beyond the paper).
    pub feasible_gamma_deg_centripetal: Option<[f64; 2]>,
}

/// What a beyond-the-paper case adds to the paper's constant errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Addition {
    /// The centripetal term ω²r in the readings.
    #[serde(rename = "centripetal ω²r on")]
    Centripetal,
    /// White noise on top of ±Δa.
    #[serde(rename = "noise on top of ±Δa")]
    Noise,
    /// Both.
    #[serde(rename = "centripetal and noise")]
    CentripetalAndNoise,
}

impl Addition {
    /// The label in the report's table.
    pub fn label(self) -> &'static str {
        match self {
            Addition::Centripetal => "centripetal ω²r on",
            Addition::Noise => "noise on top of ±Δa",
            Addition::CentripetalAndNoise => "centripetal and noise",
        }
    }
}

/// Everything the outputs show, computed.
#[derive(Debug)]
pub struct Computed {
    /// `summary.json`.
    pub summary: BoomSummary,
    /// (method, γ) → (run "+", run "−"), for the error-curve CSVs and plots.
    pub case_runs: Vec<(Method, f64, TurnRun, TurnRun)>,
    /// The same for the tracking filters (EKF, UKF, unscented RTS).
    pub tracking_runs: Vec<(Method, f64, TurnRun, TurnRun)>,
    /// The nominal turn.
    pub trajectory: Vec<TrajectoryPoint>,
    /// The nominal turn in degrees with the variations of eq. (4) at Δa: rows t, α, ω, ε,
    /// dα, dε (s, °, °/s, °/s², °, °/s²).
    pub nominal: Vec<Vec<f64>>,
}

/// The rows of [`Computed::nominal`]: the variations of eq. (4) that a reading error Δa
/// causes at each point, dα = Δa/(g·cos α) and dε = (Δa + tan α·Δa)/r.
fn nominal_rows(params: &BoomParams, points: &[TrajectoryPoint]) -> Vec<Vec<f64>> {
    let (g, r, da) = (
        params.gravity_mps2,
        params.sensor_radius_m,
        params.limiting_error_mps2,
    );
    points
        .iter()
        .map(|p| {
            let d_eps = (da + p.alpha.tan() * da) / r;
            let d_alpha = da / (g * p.alpha.cos());
            std::iter::once(p.t)
                .chain([p.alpha, p.omega, p.epsilon, d_alpha, d_eps].map(f64::to_degrees))
                .collect()
        })
        .collect()
}

/// Computes every number of the outputs (the scenario is deterministic: the noisy
/// beyond-the-paper cases draw from streams of the campaign seed).
///
/// # Errors
/// An invalid parameter set (named by key) or a library error.
pub fn summarise(
    params: &BoomParams,
    seed: u64,
    records: &[NoiseRecord],
    threads: Option<usize>,
    config_path: &Path,
) -> Result<Computed> {
    params.validate(config_path)?;
    let trajectory = params
        .rotation_profile()
        .trajectory()
        .map_err(|e| Error::invalid(config_path, format!("profile: {e}")))?;
    let points = trajectory.points;
    let limits = params.limits();
    let variants = params.variants();
    let opt = params.estimator;
    let mut case_gammas = params.case_gammas_deg.clone();
    case_gammas.extend(params.sweep_gammas_deg());
    case_gammas.extend([0.0, 10.0]);
    Meter::new(params, false, 0.0, run_rng(seed, 0)).check(&case_gammas)?;

    // The paper's cases: deterministic, so the noise stream is irrelevant (no noise).
    let turn = |cfg: &BoomConfig, v: &ErrorVariant, mut meter: Meter| -> Result<TurnRun> {
        let read = |p: &TrajectoryPoint, g: f64, v: &ErrorVariant| meter.read(p, g, v);
        run_turn(&points, cfg, read, v, limits).map_err(wls_err("run_turn"))
    };
    let quiet = || Meter::new(params, false, 0.0, run_rng(seed, 0));
    let mut case_runs = Vec::new();
    let mut cases = Vec::new();
    for &gamma_deg in &params.case_gammas_deg {
        for (method, wls_method) in [
            (Method::Direct, BoomMethod::Direct),
            (Method::Linear3, BoomMethod::Linear3),
            (Method::Wls, BoomMethod::Wls),
        ] {
            let cfg = params.config(wls_method, gamma_deg, &opt);
            let plus = turn(&cfg, &variants[0], quiet())?;
            let minus = turn(&cfg, &variants[1], quiet())?;
            for run in [&plus, &minus] {
                let turn = TurnErrors::new(gamma_deg, run, &stats(run));
                cases.push(CaseSummary { method, turn });
            }
            case_runs.push((method, gamma_deg, plus, minus));
        }
    }

    // The tracking filters on the paper's cases, on the very readings the WLS saw, and all
    // four on exact readings (no bias) for reference.
    let q = jerk_intensity(params, &points);
    let nominal_variant = ErrorVariant {
        sign: Sign::Nominal,
        size: 0.0,
    };
    let mut tracking_runs = Vec::new();
    let mut bias_free = Vec::new();
    for &gamma_deg in &params.case_gammas_deg {
        let model = TrackingModel::new(params, gamma_deg, false, 0.0, q)?;
        let g = gamma_deg.to_radians();
        let mut by_variant = Vec::new();
        for v in &variants {
            let z = readings(&points, &mut quiet(), g, v);
            by_variant.push(tracked_runs(&points, &model.track(&z)?, v.sign, limits));
        }
        let [plus, minus]: [[TurnRun; 3]; 2] = by_variant
            .try_into()
            .map_err(|_| Error::Degenerate("the boom cases have two variants"))?;
        for (method, p, m) in [Method::Ekf, Method::Ukf, Method::Urts]
            .into_iter()
            .zip(plus)
            .zip(minus)
            .map(|((a, p), m)| (a, p, m))
        {
            for run in [&p, &m] {
                let turn = TurnErrors::new(gamma_deg, run, &stats(run));
                cases.push(CaseSummary { method, turn });
            }
            tracking_runs.push((method, gamma_deg, p, m));
        }
        let z = readings(&points, &mut quiet(), g, &nominal_variant);
        let wls_cfg = params.config(BoomMethod::Wls, gamma_deg, &opt);
        let wls_run = replay(&points, &wls_cfg, &z, &nominal_variant, limits)?;
        let [e, u, sm] = tracked_runs(&points, &model.track(&z)?, Sign::Nominal, limits);
        for (method, run) in [
            (Method::Wls, wls_run),
            (Method::Ekf, e),
            (Method::Ukf, u),
            (Method::Urts, sm),
        ] {
            let s = stats(&run);
            bias_free.push(BiasFreeRow {
                method,
                gamma_deg,
                max_alpha_err_deg: s.max_alpha_deg,
                max_eps_err_deg_s2: s.max_eps_deg,
                undefined_from_alpha_deg: s.undefined_from_deg,
            });
        }
    }

    // The noise Monte Carlo, from the run records.
    let mut noise_mc = Vec::new();
    for (gi, &gamma) in params.case_gammas_deg.iter().enumerate() {
        let rows: Vec<&NoiseRecord> = records.iter().filter(|r| r.gamma_index == gi).collect();
        for (j, method) in NOISE_METHODS.into_iter().enumerate() {
            let n = rows.len().max(1) as f64;
            let ms = |f: fn((f64, f64)) -> f64| {
                (rows.iter().map(|r| f(r.rms[j]).powi(2)).sum::<f64>() / n).sqrt()
            };
            noise_mc.push(NoiseMcRow {
                method,
                gamma_deg: gamma,
                runs: rows.len(),
                rms_alpha_err_deg: ms(|(a, _)| a),
                rms_eps_err_deg_s2: ms(|(_, e)| e),
            });
        }
    }

    // The γ sweep (WLS, main options).
    let gammas_deg = params.sweep_gammas_deg();
    let gammas: Vec<f64> = gammas_deg.iter().map(|g| g.to_radians()).collect();
    let sweep = |centripetal: bool, o: &EstimatorParams| -> Result<wls::boom::GammaSweepReport> {
        let mut meter = Meter::new(params, centripetal, 0.0, run_rng(seed, 0));
        let read = |p: &TrajectoryPoint, g: f64, v: &ErrorVariant| meter.read(p, g, v);
        let base = params.config(BoomMethod::Wls, 0.0, o);
        sweep_gamma(&points, &base, read, &variants, &gammas, limits)
            .map_err(wls_err("sweep_gamma"))
    };
    let report = sweep(false, &opt)?;
    let window_deg = |w: Option<(f64, f64)>| w.map(|(a, b)| [a.to_degrees(), b.to_degrees()]);
    let gamma_sweep = report
        .rows
        .iter()
        .zip(&gammas_deg)
        .map(|(r, &g)| SweepRow {
            gamma_deg: g,
            within_limits: r.feasible,
            max_alpha_err_deg: r.max_angle_error.to_degrees(),
            max_eps_err_deg_s2: r.max_epsilon_error.to_degrees(),
        })
        .collect();
    let feasible_gamma_deg =
        window_deg(report.window).map(|[a, b]| [nearest(&gammas_deg, a), nearest(&gammas_deg, b)]);

    // The unit/weight alternatives, one job per option set (in a fixed order, so the result
    // does not depend on the number of threads).
    let mut option_sets = Vec::new();
    for epsilon_unit in [AngleUnit::Radian, AngleUnit::Degree] {
        for epsilon_rate_unit in [AngleUnit::Radian, AngleUnit::Degree] {
            for fixed_point in [true, false] {
                for ax_weight_cos in [true, false] {
                    for angle_recovery in [AngleRecovery::Arcsin, AngleRecovery::Atan2] {
                        option_sets.push(EstimatorParams {
                            epsilon_unit,
                            epsilon_rate_unit,
                            fixed_point,
                            ax_weight_cos,
                            angle_recovery,
                        });
                    }
                }
            }
        }
    }
    let alternative = |o: &EstimatorParams| -> Result<(AlternativeVerdict, Vec<AlternativeRow>)> {
        let mut rows = Vec::new();
        for gamma in [0.0, 10.0] {
            let cfg = params.config(BoomMethod::Wls, gamma, o);
            for v in &variants {
                let run = turn(&cfg, v, quiet())?;
                let s = stats(&run);
                let defined = s.undefined_from_deg.is_none();
                rows.push(AlternativeRow {
                    options: *o,
                    turn: TurnErrors::new(gamma, &run, &s),
                    first_violation_t_s: s.violation.map(|v| v.0),
                    alpha_within: defined && s.max_alpha_deg <= params.limits.alpha_deg,
                    eps_within: defined && s.max_eps_deg <= params.limits.eps_deg_s2,
                });
            }
        }
        let mut v = verdict(*o, &rows);
        v.feasible_gamma_deg = window_deg(sweep(false, o)?.window)
            .map(|[a, b]| [nearest(&gammas_deg, a), nearest(&gammas_deg, b)]);
        Ok((v, rows))
    };
    let mut alternatives = Vec::new();
    let mut alternative_verdicts = Vec::new();
    for done in par_runs(0..option_sets.len(), threads, "boom", |i| {
        alternative(&option_sets[i])
    })? {
        let (v, rows) = done?;
        alternative_verdicts.push(v);
        alternatives.extend(rows);
    }

    // Beyond the paper: centripetal term, and noise on top of the constant errors.
    let mut beyond_paper = Vec::new();
    let mut feasible_gamma_deg_centripetal = None;
    if params.beyond.enabled {
        let mut stream = 1;
        for (label, centripetal, noise) in [
            (Addition::Centripetal, true, 0.0),
            (Addition::Noise, false, params.beyond.noise_std_mps2),
            (
                Addition::CentripetalAndNoise,
                true,
                params.beyond.noise_std_mps2,
            ),
        ] {
            for (method, wls_method) in [
                (Method::Direct, BoomMethod::Direct),
                (Method::Wls, BoomMethod::Wls),
            ] {
                for &gamma in &params.case_gammas_deg {
                    let cfg = params.config(wls_method, gamma, &opt);
                    for v in &variants {
                        let meter = Meter::new(params, centripetal, noise, run_rng(seed, stream));
                        stream += 1;
                        let s = stats(&turn(&cfg, v, meter)?);
                        beyond_paper.push(BeyondRow {
                            label,
                            method,
                            gamma_deg: gamma,
                            bias: v.sign,
                            centripetal,
                            noise_std_mps2: noise,
                            max_alpha_err_deg: s.max_alpha_deg,
                            max_eps_err_deg_s2: s.max_eps_deg,
                            within_limits: s.undefined_from_deg.is_none()
                                && s.max_alpha_deg <= params.limits.alpha_deg
                                && s.max_eps_deg <= params.limits.eps_deg_s2,
                        });
                    }
                }
            }
        }
        feasible_gamma_deg_centripetal = window_deg(sweep(true, &opt)?.window)
            .map(|[a, b]| [nearest(&gammas_deg, a), nearest(&gammas_deg, b)]);
    }

    let last = points.last().map_or(0.0, |p| p.t);
    let cruise = points.iter().map(|p| p.omega).fold(0.0, f64::max);
    let saturated_until_alpha_deg = points
        .iter()
        .filter(|p| {
            params.gravity_mps2 * p.alpha.cos()
                + p.epsilon * params.sensor_radius_m
                + params.limiting_error_mps2
                > params.range_mps2
        })
        .map(|p| p.alpha.to_degrees())
        .reduce(f64::max);
    Ok(Computed {
        summary: BoomSummary {
            scenario: "boom".into(),
            seed,
            params: params.clone(),
            limits: params.limits,
            startup_cycles_excluded: 1,
            deceleration_deg_s2: trajectory.deceleration_deg_s2,
            turn_duration_s: last,
            cruise_rate_rad_s: cruise,
            centripetal_mps2: cruise.powi(2) * params.sensor_radius_m,
            centripetal_over_limit: cruise.powi(2) * params.sensor_radius_m
                / params.limiting_error_mps2.max(f64::MIN_POSITIVE),
            saturated_until_alpha_deg,
            cases,
            tracking: TrackingSummary {
                jerk_psd_deg2_s5: q / 1f64.to_radians().powi(2),
                r_std_cases_mps2: params.limiting_error_mps2,
                r_std_noise_mps2: params
                    .limiting_error_mps2
                    .hypot(params.tracking.noise_std_mps2),
                noise_std_mps2: params.tracking.noise_std_mps2,
            },
            tracking_verdict: tracking_verdict(
                params,
                &case_runs,
                &tracking_runs,
                &bias_free,
                &noise_mc,
            ),
            bias_free,
            noise_mc,
            gamma_sweep,
            feasible_gamma_deg,
            alternatives,
            alternative_verdicts,
            beyond_paper,
            feasible_gamma_deg_centripetal,
        },
        case_runs,
        tracking_runs,
        nominal: nominal_rows(params, &points),
        trajectory: points,
    })
}

/// The sweep value (degrees) closest to `x` (degrees), so the summary shows the sweep's own
/// round numbers rather than a radian round trip.
fn nearest(grid: &[f64], x: f64) -> f64 {
    grid.iter()
        .copied()
        .min_by(|a, b| (a - x).abs().total_cmp(&(b - x).abs()))
        .unwrap_or(x)
}

fn verdict(options: EstimatorParams, rows: &[AlternativeRow]) -> AlternativeVerdict {
    let at = |g: f64| {
        rows.iter()
            .filter(move |r| (r.turn.gamma_deg - g).abs() < 1e-9)
    };
    let defined_at_0 = at(0.0).all(|r| r.turn.undefined_from_alpha_deg.is_none());
    let alpha_within_at_0 = at(0.0).all(|r| r.alpha_within);
    let over: Vec<&AlternativeRow> = at(0.0).filter(|r| !r.eps_within).collect();
    let eps_pattern_at_0 = over.len() <= 1
        && over
            .iter()
            .all(|r| r.turn.first_violation_alpha_deg.is_some_and(|a| a > 75.0));
    let within_at_10 = at(10.0).all(|r| r.alpha_within && r.eps_within);
    let departures_at_0 = at(0.0)
        .filter(|r| !(r.alpha_within && r.eps_within))
        .map(|r| {
            let what = match (r.alpha_within, r.eps_within) {
                (false, false) => "δα and δε",
                (false, true) => "δα",
                _ => "δε",
            };
            let from = match (r.turn.first_violation_alpha_deg, r.first_violation_t_s) {
                (Some(a), Some(t)) => format!(" over from {a:.1}° ({t:.1} s)"),
                _ => String::new(),
            };
            let undefined = r
                .turn
                .undefined_from_alpha_deg
                .map_or(String::new(), |a| format!(", undefined from {a:.1}°"));
            format!("{}: {what}{from}{undefined}", r.turn.bias.label())
        })
        .collect();
    AlternativeVerdict {
        options,
        defined_at_0,
        alpha_within_at_0,
        eps_pattern_at_0,
        within_at_10,
        reproduces_paper: defined_at_0 && alpha_within_at_0 && eps_pattern_at_0 && within_at_10,
        departures_at_0,
        feasible_gamma_deg: None,
    }
}

/// The conditions of the "Nonlinear filters against WLS" comment.
fn tracking_verdict(
    params: &BoomParams,
    case_runs: &[(Method, f64, TurnRun, TurnRun)],
    tracking_runs: &[(Method, f64, TurnRun, TurnRun)],
    bias_free: &[BiasFreeRow],
    noise_mc: &[NoiseMcRow],
) -> TrackingVerdict {
    let same = |a: f64, b: f64| (a - b).abs() < 1e-9;
    let low_gamma_deg = if params.case_gammas_deg.iter().any(|&g| same(g, 0.0)) {
        0.0
    } else {
        params
            .case_gammas_deg
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
    };
    let free = |m: Method| {
        bias_free
            .iter()
            .find(|r| r.method == m && same(r.gamma_deg, low_gamma_deg))
    };
    let filters = [Method::Ekf, Method::Ukf, Method::Urts];
    let (mut fa, mut fe, mut f_defined) = (0.0f64, 0.0f64, true);
    for m in filters {
        if let Some(r) = free(m) {
            fa = fa.max(r.max_alpha_err_deg);
            fe = fe.max(r.max_eps_err_deg_s2);
            f_defined &= r.undefined_from_alpha_deg.is_none();
        }
    }
    let (wa, we) = free(Method::Wls).map_or((f64::NAN, f64::NAN), |r| {
        (r.max_alpha_err_deg, r.max_eps_err_deg_s2)
    });
    let lim = params.limits;
    let state_cures_conditioning =
        f_defined && fa <= lim.alpha_deg && fe <= lim.eps_deg_s2 && fa < wa && fe < we;
    let mut bias_effects = Vec::new();
    for (method, gamma, plus, minus) in case_runs
        .iter()
        .filter(|r| r.0 == Method::Wls)
        .chain(tracking_runs)
    {
        let (mut worst, mut at, mut eps) = (0.0f64, 0.0f64, 0.0f64);
        for run in [plus, minus] {
            for c in run.cycles.iter().skip(1).filter(|c| c.defined) {
                if c.angle_error > worst {
                    worst = c.angle_error;
                    at = c.alpha;
                }
                eps = eps.max(c.epsilon_error);
            }
        }
        let within = [plus, minus]
            .iter()
            .all(|r| r.first_violation.is_none() && r.first_undefined.is_none());
        bias_effects.push(BiasEffect {
            method: *method,
            gamma_deg: *gamma,
            bias_free_alpha_deg: bias_free
                .iter()
                .find(|r| r.method == *method && same(r.gamma_deg, *gamma))
                .map_or(f64::NAN, |r| r.max_alpha_err_deg),
            with_bias_alpha_deg: worst.to_degrees(),
            with_bias_eps_deg_s2: eps.to_degrees(),
            alpha_at_worst_deg: at.to_degrees(),
            within_limits: within,
        });
    }
    let mc = |m: Method, g: f64| {
        noise_mc
            .iter()
            .find(|r| r.method == m && same(r.gamma_deg, g))
    };
    let smoother_not_worse =
        params
            .case_gammas_deg
            .iter()
            .all(|&g| match (mc(Method::Urts, g), mc(Method::Ukf, g)) {
                (Some(s), Some(f)) => {
                    s.rms_alpha_err_deg <= f.rms_alpha_err_deg
                        && s.rms_eps_err_deg_s2 <= f.rms_eps_err_deg_s2
                }
                _ => false,
            });
    TrackingVerdict {
        low_gamma_deg,
        filters_bias_free_alpha_deg: fa,
        filters_bias_free_eps_deg_s2: fe,
        wls_bias_free_alpha_deg: wa,
        wls_bias_free_eps_deg_s2: we,
        state_cures_conditioning,
        bias_effects,
        smoother_not_worse,
    }
}
