//! The uav scenario's summary: the design's facts (plant, gains, poles), the Kalman–Bucy
//! check, run 0's signals and spectra, and the Monte Carlo aggregates recomputed from the run
//! records — every number the report shows.

use kalman::diagnostics as spectrum;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::parameters::UavParams;
use super::records::RunRecord;
use super::simulation::{Trace, arr22, continuous, design, kalman_err, model_err, simulate};
use crate::error::{Error, Result};

/// Monte Carlo aggregates, recomputed from the run records by both `run` and `merge`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Aggregate {
    /// √(mean over runs of the mean-square position estimation error), m.
    pub rms_estimation_error: f64,
    /// √(mean over runs of the mean-square measurement error), m.
    pub rms_measurement_error: f64,
    /// Their ratio.
    pub rms_ratio: f64,
    /// 1 − rms_ratio²: the fraction of the measurement noise power the filter removes.
    pub noise_power_removed: f64,
    /// Σ Q over the runs (χ² with h·runs degrees of freedom for white innovations).
    pub pooled_ljung_box_q: f64,
    /// Degrees of freedom h·runs.
    pub pooled_dof: usize,
    /// The χ² quantile at 1 − α the pooled Q must stay below.
    pub pooled_bound: f64,
    /// Fraction of runs whose own Q is below the χ²_h quantile at 1 − α.
    pub runs_passing_fraction: f64,
    /// Mean NIS over runs.
    pub mean_nis: f64,
    /// Pooled test passed.
    pub whiteness_pass: bool,
}

fn aggregate(p: &UavParams, records: &[RunRecord]) -> Aggregate {
    let n = records.len().max(1) as f64;
    let ms = |f: &dyn Fn(&RunRecord) -> f64| records.iter().map(|r| f(r).powi(2)).sum::<f64>() / n;
    let est = ms(&|r| r.rms_estimation_error).sqrt();
    let meas = ms(&|r| r.rms_measurement_error).sqrt();
    let q: f64 = records.iter().map(|r| r.ljung_box_q).sum();
    let dof = p.whiteness_lags * records.len();
    let bound = kalman::chi2_quantile(1.0 - p.whiteness_alpha, dof);
    let single = kalman::chi2_quantile(1.0 - p.whiteness_alpha, p.whiteness_lags);
    Aggregate {
        rms_estimation_error: est,
        rms_measurement_error: meas,
        rms_ratio: est / meas,
        noise_power_removed: 1.0 - (est / meas).powi(2),
        pooled_ljung_box_q: q,
        pooled_dof: dof,
        pooled_bound: bound,
        runs_passing_fraction: records.iter().filter(|r| r.ljung_box_q < single).count() as f64 / n,
        mean_nis: records.iter().map(|r| r.mean_nis).sum::<f64>() / n,
        whiteness_pass: q < bound,
    }
}

/// A spectrum node of the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PsdNode {
    /// Node name (paper's numbering).
    pub name: String,
    /// What the node carries.
    pub description: String,
    /// CSV of its spectrum (f_hz, then one PSD column per signal).
    pub csv: String,
    /// SVG of its spectrum.
    pub svg: String,
    /// The first signal's mean PSD over f > 0, units²/Hz.
    pub mean_level: f64,
    /// The first signal's mean PSD over the upper half band (fs/4, fs/2], units²/Hz.
    pub high_band_level: f64,
    /// The level a white sequence of the theoretical variance would have (2σ²/fs), if the
    /// node should be white.
    pub white_level: Option<f64>,
    /// `mean_level / white_level` (1 for a white node at its theoretical variance).
    pub level_over_white: Option<f64>,
}

/// K_d/Δt against the Kalman–Bucy gain at one Δt.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GainRow {
    /// Δt, s.
    pub dt_s: f64,
    /// Discrete steady-state filter gain divided by Δt, 1/s (R_d = R_c/Δt).
    pub discrete_gain_over_dt: [f64; 2],
    /// ‖K_d/Δt − K_c‖/‖K_c‖.
    pub relative_gap: f64,
}

/// The Kalman–Bucy check.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KalmanBucyCheck {
    /// Continuous measurement-noise intensity R_c = R·Δt, m²·s.
    pub measurement_intensity: f64,
    /// The CARE gain K_c, 1/s.
    pub care_gain: [f64; 2],
    /// The Riccati ODE's limit from P₀, 1/s.
    pub ode_steady_gain: [f64; 2],
    /// ‖K_ode − K_care‖/‖K_care‖.
    pub ode_vs_care: f64,
    /// K_d/Δt for each checked Δt (largest first).
    pub table: Vec<GainRow>,
    /// The gap shrinks as Δt does, is below the tolerance at the smallest Δt, and the ODE
    /// agrees with the CARE to 1e-6.
    pub consistent: bool,
}

/// `summary.json` of the scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UavSummary {
    /// Always "uav".
    pub scenario: String,
    /// Campaign seed.
    pub seed: u64,
    /// Monte Carlo runs in the whole campaign.
    pub runs: usize,
    /// The parameters used.
    pub params: UavParams,
    /// F, B, Q_d of the sampled plant (row-major).
    pub f: [[f64; 2]; 2],
    /// Control input matrix (Δt²/2, Δt).
    pub b: [f64; 2],
    /// Van Loan process-noise covariance.
    pub q_d: [[f64; 2]; 2],
    /// LQR gain L.
    pub lqr_gain: [f64; 2],
    /// Steady-state filter gain K (DARE).
    pub filter_gain: [f64; 2],
    /// Steady prior covariance P (DARE).
    pub steady_prior_covariance: [[f64; 2]; 2],
    /// The representative run's last filter gain against the DARE gain, relative.
    pub running_gain_vs_dare: f64,
    /// Reference feedforward N_x, N_u.
    pub feedforward: [f64; 3],
    /// ρ of the whole closed loop (plant + predictor), [[F − BL, BL], [0, F − K_p H]].
    pub closed_loop_spectral_radius: f64,
    /// ρ(F − BL).
    pub controller_spectral_radius: f64,
    /// ρ(F − K_p H) = ρ((I − KH)F).
    pub filter_spectral_radius: f64,
    /// Closed-loop poles (re, im).
    pub closed_loop_poles: Vec<[f64; 2]>,
    /// Filter poles (re, im).
    pub filter_poles: Vec<[f64; 2]>,
    /// Pooled Ljung–Box test of the normalised innovations passed.
    pub innovation_whiteness_pass: bool,
    /// RMS position estimation error over the runs (after burn-in), m.
    pub rms_estimation_error: f64,
    /// RMS measurement error over the runs, m.
    pub rms_measurement_error: f64,
    /// All Monte Carlo aggregates.
    pub monte_carlo: Aggregate,
    /// Mean position over the last quarter of the representative run, m (tracks the step).
    pub tracking_mean_last_quarter: f64,
    /// Run 0: the normalised innovations' autocorrelation at lags 1..=50 falls outside
    /// ±1.96/√N at this fraction of lags (≈ 0.05 for a white sequence).
    pub innovation_acf_outside_fraction: f64,
    /// Spectrum nodes.
    pub psd_nodes: Vec<PsdNode>,
    /// The measurement noise's PSD level 2R/fs, m²/Hz (the floor of the sensor output z).
    pub measurement_noise_floor: f64,
    /// The sensor output's upper-half-band level over the estimate's (how much the filter
    /// attenuates f > fs/4), if both nodes are present.
    pub high_band_attenuation: Option<f64>,
    /// Kalman–Bucy vs discrete gains.
    pub kalman_bucy: KalmanBucyCheck,
    /// Per-run records (this shard's runs, or all).
    pub run_records: Vec<RunRecord>,
}

fn poles(m: &DMatrix<f64>) -> Result<Vec<[f64; 2]>> {
    Ok(model::eigenvalues(m)
        .map_err(model_err("eigenvalues"))?
        .iter()
        .map(|c| [c.re, c.im])
        .collect())
}

fn rho(m: &DMatrix<f64>) -> Result<f64> {
    model::spectral_radius(m).map_err(model_err("spectral radius"))
}

fn norm2(a: [f64; 2]) -> f64 {
    a[0].hypot(a[1])
}

fn kalman_bucy(p: &UavParams) -> Result<(KalmanBucyCheck, Vec<[f64; 3]>)> {
    let sys = continuous(p)?;
    let a = sys.a();
    let gwg = sys.g() * sys.w() * sys.g().transpose();
    let qc = &gwg;
    let h = sys.c();
    let rc = p.measurement_variance * p.dt_s;
    let rcm = faer::mat![[rc]];
    let care = kalman::riccati::Care::new(a, h, qc, &rcm)
        .and_then(|c| c.solve())
        .map_err(kalman_err("CARE"))?;
    let kc = [care.gain[(0, 0)], care.gain[(1, 0)]];
    let kb = kalman::continuous::KalmanBucy::new(a, h, qc, rcm.as_ref())
        .map_err(kalman_err("Kalman–Bucy"))?;
    let [p0, p1] = p.initial_covariance;
    let pinit = faer::mat![[p0, 0.0], [0.0, p1]];
    let opts = kalman::continuous::OdeOptions::default();
    let steady = kb
        .until_steady(pinit.as_ref(), 1e-10, 1e4, &opts)
        .map_err(kalman_err("Riccati ODE"))?;
    let kode = kb
        .gain(steady.covariance.as_ref())
        .map_err(kalman_err("Kalman–Bucy gain"))?;
    let kode = [kode[(0, 0)], kode[(1, 0)]];
    let ode_vs_care = norm2([kode[0] - kc[0], kode[1] - kc[1]]) / norm2(kc);
    // Transient K_c(t) at the sample instants of the first 20 s (or of the run).
    let mut transient = Vec::new();
    let mut pt = pinit.clone();
    let horizon = (20.0 / p.dt_s).ceil() as usize;
    for k in 0..=horizon.min(p.steps) {
        let g = kb
            .gain(pt.as_ref())
            .map_err(kalman_err("Kalman–Bucy gain"))?;
        transient.push([k as f64 * p.dt_s, g[(0, 0)], g[(1, 0)]]);
        pt = kb
            .integrate(pt.as_ref(), p.dt_s, &opts)
            .map_err(kalman_err("Riccati ODE"))?
            .covariance;
    }
    let mut dts = p.gain_check_dts.clone();
    dts.sort_by(|a, b| b.total_cmp(a));
    dts.dedup_by(|a, b| (*a - *b).abs() <= 1e-15 * b.abs());
    let mut table = Vec::new();
    for dt in dts {
        let d = model::discretize(
            &sys,
            dt,
            model::Discretization::Zoh,
            model::NoiseConvention::VanLoan,
        )
        .map_err(model_err("discretisation"))?;
        let ss = kalman::riccati::Dare::new(d.f(), d.h(), d.q(), [[rc / dt]])
            .and_then(|d| d.solve())
            .map_err(kalman_err("filter DARE"))?;
        let kd = [ss.gain[(0, 0)] / dt, ss.gain[(1, 0)] / dt];
        table.push(GainRow {
            dt_s: dt,
            discrete_gain_over_dt: kd,
            relative_gap: norm2([kd[0] - kc[0], kd[1] - kc[1]]) / norm2(kc),
        });
    }
    let shrinking = table
        .windows(2)
        .all(|w| w[1].relative_gap <= w[0].relative_gap);
    let last = table.last().map_or(f64::INFINITY, |r| r.relative_gap);
    let consistent = shrinking && last <= p.gain_tolerance && ode_vs_care <= 1e-6;
    Ok((
        KalmanBucyCheck {
            measurement_intensity: rc,
            care_gain: kc,
            ode_steady_gain: kode,
            ode_vs_care,
            table,
            consistent,
        },
        transient,
    ))
}

/// Lags of the innovation autocorrelation figure.
pub const ACF_LAGS: usize = 50;

/// Everything computed, before writing.
#[derive(Debug)]
pub struct Computed {
    /// `summary.json`.
    pub summary: UavSummary,
    /// Run 0's signals.
    pub(super) trace: Trace,
    /// Autocorrelation of run 0's normalised innovations, lags 0..=ACF_LAGS, and its ±bound.
    pub acf: (Vec<f64>, f64),
    /// Kalman–Bucy gain K_c(t) at the sample instants: (t, K_c position, K_c velocity).
    pub transient: Vec<[f64; 3]>,
    /// Per spectrum node: the node, its signals' labels, and their Welch PSDs.
    pub spectra: Vec<(PsdNode, Vec<&'static str>, Vec<spectrum::Psd>)>,
}

/// Run 0's closed-loop trace: the scenario's closing stage (its signals and spectra).
///
/// # Errors
/// A library error on valid parameters.
pub fn trace(p: &UavParams, seed: u64) -> Result<Trace> {
    simulate(p, &design(p)?, seed, 0)
}

/// Computes every number of the outputs from the parameters, the run records (this
/// shard's, or all of them) and run 0's trace (the closing stage's; a shard, which has no
/// closing stage, simulates run 0 itself).
///
/// # Errors
/// A library error on valid parameters.
pub fn summarise(
    p: &UavParams,
    seed: u64,
    run_records: &[RunRecord],
    run0: Option<&Trace>,
) -> Result<Computed> {
    let d = design(p)?;
    // Closed loop with the predictor: [x; e], e = x − x̂_{k|k−1}.
    let bl = &d.b * &d.l;
    let fbl = &d.f - &bl;
    let fkh = &d.f - &d.k_pred * &d.h;
    let mut acl = DMatrix::zeros(4, 4);
    acl.view_mut((0, 0), (2, 2)).copy_from(&fbl);
    acl.view_mut((0, 2), (2, 2)).copy_from(&bl);
    acl.view_mut((2, 2), (2, 2)).copy_from(&fkh);

    let (kb, transient) = kalman_bucy(p)?;
    let trace = match run0 {
        Some(t) => t.clone(),
        None => simulate(p, &d, seed, 0)?,
    };
    let agg = aggregate(p, run_records);

    let fs = 1.0 / p.dt_s;
    let seg = p.welch_segment;
    let col = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { (0..trace.t.len()).map(f).collect() };
    let welch = |x: &[f64]| {
        spectrum::welch(x, fs, seg).map_err(|source| Error::Kalman {
            context: "welch",
            source,
        })
    };
    let q11 = d.q[(0, 0)];
    let sigma = d.h[(0, 0)].powi(2) * d.p_prior[(0, 0)] + d.r;
    let mut spectra = Vec::new();
    type Node = (
        &'static str,
        &'static str,
        Vec<&'static str>,
        Vec<Vec<f64>>,
        Option<f64>,
    );
    let nodes: Vec<Node> = vec![
        (
            "1_noise_generator_W",
            "node 1: noise generator output W (position and velocity components of w_k)",
            vec!["w_position", "w_velocity"],
            vec![col(&|k| trace.w[k][0]), col(&|k| trace.w[k][1])],
            Some(2.0 * q11 / fs),
        ),
        (
            "2_sensor_output_z",
            "node 2: sensor output z (filter input), with the true position",
            vec!["z", "x_position"],
            vec![col(&|k| trace.z[k]), col(&|k| trace.x[k][0])],
            None,
        ),
        (
            "3_filter_output",
            "node 3: filter output x̂ (position), with its input z",
            vec!["xhat_position", "z"],
            vec![col(&|k| trace.xhat[k][0]), col(&|k| trace.z[k])],
            None,
        ),
        (
            "4_error_signal",
            "node 4: error signal — the innovation z − H x̂⁻ (white), with the estimation error",
            vec!["innovation", "estimation_error"],
            vec![
                col(&|k| trace.innovation[k]),
                col(&|k| trace.x[k][0] - trace.xhat[k][0]),
            ],
            Some(2.0 * sigma / fs),
        ),
        (
            "control_u",
            "control signal U = −L(x̂⁻ − N_x r) + N_u r",
            vec!["u"],
            vec![col(&|k| trace.u[k])],
            None,
        ),
    ];
    for (name, description, labels, signals, white) in nodes {
        let k0 = p.burn_in_steps;
        let mut ps = Vec::new();
        for s in &signals {
            ps.push(welch(&s[k0..])?);
        }
        let first = &ps[0];
        let mean_level = first.psd[1..].iter().sum::<f64>() / (first.psd.len() - 1) as f64;
        let upper = &first.psd[first.psd.len() / 2 + 1..];
        let high_band_level = upper.iter().sum::<f64>() / upper.len().max(1) as f64;
        spectra.push((
            PsdNode {
                name: name.into(),
                description: description.into(),
                csv: format!("psd_{name}.csv"),
                svg: format!("psd_{name}.svg"),
                mean_level,
                high_band_level,
                white_level: white,
                level_over_white: white.map(|w| mean_level / w),
            },
            labels,
            ps,
        ));
    }

    let nu: Vec<f64> = (p.burn_in_steps..trace.t.len())
        .map(|k| trace.innovation[k] / trace.innovation_var[k].sqrt())
        .collect();
    let acf = spectrum::autocorrelation(&nu, ACF_LAGS);
    let acf_bound = 1.96 / (nu.len() as f64).sqrt();
    let acf_outside =
        acf[1..].iter().filter(|r| r.abs() > acf_bound).count() as f64 / ACF_LAGS as f64;
    let last_q: Vec<f64> = trace.x[3 * trace.x.len() / 4..]
        .iter()
        .map(|x| x[0])
        .collect();
    let tracking = last_q.iter().sum::<f64>() / last_q.len().max(1) as f64;
    let g_last = trace.gain.last().copied().unwrap_or([0.0; 2]);
    let kd = [d.k[(0, 0)], d.k[(1, 0)]];
    let summary = UavSummary {
        scenario: "uav".into(),
        seed,
        runs: p.runs,
        params: p.clone(),
        f: arr22(&d.f),
        b: [d.b[(0, 0)], d.b[(1, 0)]],
        q_d: arr22(&d.q),
        lqr_gain: [d.l[(0, 0)], d.l[(0, 1)]],
        filter_gain: kd,
        steady_prior_covariance: arr22(&d.p_prior),
        running_gain_vs_dare: norm2([g_last[0] - kd[0], g_last[1] - kd[1]]) / norm2(kd),
        feedforward: [d.nx[0], d.nx[1], d.nu],
        closed_loop_spectral_radius: rho(&acl)?,
        controller_spectral_radius: rho(&fbl)?,
        filter_spectral_radius: rho(&fkh)?,
        closed_loop_poles: poles(&acl)?,
        filter_poles: poles(&fkh)?,
        innovation_whiteness_pass: agg.whiteness_pass,
        rms_estimation_error: agg.rms_estimation_error,
        rms_measurement_error: agg.rms_measurement_error,
        monte_carlo: agg,
        tracking_mean_last_quarter: tracking,
        innovation_acf_outside_fraction: acf_outside,
        psd_nodes: spectra.iter().map(|s| s.0.clone()).collect(),
        measurement_noise_floor: 2.0 * p.measurement_variance * p.dt_s,
        high_band_attenuation: match (spectra.get(1), spectra.get(2)) {
            (Some(z), Some(x)) => Some(z.0.high_band_level / x.0.high_band_level),
            _ => None,
        },
        kalman_bucy: kb,
        run_records: run_records.to_vec(),
    };
    Ok(Computed {
        summary,
        trace,
        acf: (acf, acf_bound),
        transient,
        spectra,
    })
}
