//! The `uav` scenario (SPEC U): one UAV control channel — a sampled double integrator driven by
//! white acceleration noise, a position sensor, the discrete Kalman filter in the loop and LQ
//! state feedback tracking a unit step — simulated closed loop, with the signals and Welch
//! spectra at the paper's four nodes, the closed-loop and filter poles, an innovation
//! whiteness test, Monte Carlo RMS errors, and the Kalman–Bucy gain against the discrete one.
//!
//! Mechanisms come from the libraries: `model` discretises (ZOH + Van Loan) and gives the
//! poles; `kalman` runs the filter and solves the DARE, the discrete LQR, the CARE and the
//! Kalman–Bucy Riccati ODE. This module only wires them and writes the report.
//!
//! **Control law.** `kalman::Filter::step` updates with z_k and then predicts with u_k in
//! one call, so u_k is computed before z_k is processed, from the one-step prediction
//! x̂_{k|k−1} (the "prediction estimator" form, a one-sample computational delay as in a real
//! autopilot): u_k = −L(x̂_{k|k−1} − N_x r_k) + N_u r_k, where (N_x, N_u) solve
//! [[F − I, B], [H, 0]]·[N_x; N_u] = [0; 1] (reference-tracking feedforward: the state N_x r is
//! an equilibrium of the plant under the input N_u r with output r; for the double integrator
//! N_x = (1, 0), N_u = 0). By the separation principle the closed-loop poles are those of
//! F − BL and of the predictor F − K_p H, K_p = F K.

pub mod spectrum;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use faer::{Mat, MatRef};
use kalman::{CovarianceForm, Fixed, FixedFilter, Model};
use nalgebra::{DMatrix, Matrix3, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::Campaign;
use crate::error::{Error, Result};
use crate::montecarlo::{par_runs, run_rng};
use crate::output;
use crate::plot::{Figure, Scale, Series, line_plot};

/// Every parameter of the scenario: SPEC U's defaults, overridable by `--config`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UavParams {
    /// Sampling interval Δt, s (0.25: F = [[1, 0.25], [0, 1]]).
    pub dt_s: f64,
    /// Steps per run (4096).
    pub steps: usize,
    /// Intensity q of the white acceleration noise, (m/s²)²/Hz (0.1).
    pub accel_noise_intensity: f64,
    /// Measurement-noise variance R, m² (1).
    pub measurement_variance: f64,
    /// LQR state weight diag(q₁, q₂) ((1, 0.1)).
    pub lqr_state_weight: [f64; 2],
    /// LQR input weight (1).
    pub lqr_input_weight: f64,
    /// Time of the unit step of the position reference, s (10).
    pub step_time_s: f64,
    /// Step height, m (1).
    pub step_amplitude: f64,
    /// Prior covariance diag(P₀) of the filter; the true initial state is drawn from it.
    pub initial_covariance: [f64; 2],
    /// Monte Carlo runs when `--runs` is not given (100).
    pub runs: usize,
    /// Steps excluded from the RMS and whiteness statistics at the start of a run (the
    /// filter's start-up transient; 40 steps = 10 s).
    pub burn_in_steps: usize,
    /// Welch segment length, samples (power of two; 256).
    pub welch_segment: usize,
    /// Lags h of the Ljung–Box test (20).
    pub whiteness_lags: usize,
    /// Significance level of the whiteness test (0.01).
    pub whiteness_alpha: f64,
    /// Sampling intervals at which K_d/Δt is compared with the Kalman–Bucy gain, s.
    pub gain_check_dts: Vec<f64>,
    /// Largest relative gap ‖K_d/Δt − K_c‖/‖K_c‖ at the smallest checked Δt (0.01).
    pub gain_tolerance: f64,
}

impl Default for UavParams {
    fn default() -> Self {
        Self {
            dt_s: 0.25,
            steps: 4096,
            accel_noise_intensity: 0.1,
            measurement_variance: 1.0,
            lqr_state_weight: [1.0, 0.1],
            lqr_input_weight: 1.0,
            step_time_s: 10.0,
            step_amplitude: 1.0,
            initial_covariance: [1.0, 1.0],
            runs: 100,
            burn_in_steps: 40,
            welch_segment: 256,
            whiteness_lags: 20,
            whiteness_alpha: 0.01,
            gain_check_dts: vec![0.25, 0.1, 0.05, 0.01, 0.001],
            gain_tolerance: 0.01,
        }
    }
}

impl UavParams {
    /// Checks every value, naming the key of the first bad one.
    ///
    /// # Errors
    /// [`Error::Invalid`] for `path`, naming the key and the rule.
    pub fn validate(&self, path: &Path) -> Result<()> {
        let bad = |key: &str, value: f64, rule: &str| {
            Err(Error::invalid(path, format!("`{key}` = {value}: {rule}")))
        };
        for (key, value) in [
            ("dt_s", self.dt_s),
            ("accel_noise_intensity", self.accel_noise_intensity),
            ("measurement_variance", self.measurement_variance),
            ("lqr_state_weight[0]", self.lqr_state_weight[0]),
            ("lqr_state_weight[1]", self.lqr_state_weight[1]),
            ("lqr_input_weight", self.lqr_input_weight),
            ("initial_covariance[0]", self.initial_covariance[0]),
            ("initial_covariance[1]", self.initial_covariance[1]),
            ("gain_tolerance", self.gain_tolerance),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return bad(key, value, "must be finite and > 0");
            }
        }
        for (key, value) in [
            ("step_time_s", self.step_time_s),
            ("step_amplitude", self.step_amplitude.abs()),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return bad(key, value, "must be finite and ≥ 0");
            }
        }
        if !(self.whiteness_alpha > 0.0 && self.whiteness_alpha < 0.5) {
            return bad(
                "whiteness_alpha",
                self.whiteness_alpha,
                "must lie in (0, 0.5)",
            );
        }
        if self.welch_segment < 8 || !self.welch_segment.is_power_of_two() {
            return bad(
                "welch_segment",
                self.welch_segment as f64,
                "must be a power of two ≥ 8",
            );
        }
        if self.steps < self.burn_in_steps + self.welch_segment.max(4 * self.whiteness_lags) {
            return bad(
                "steps",
                self.steps as f64,
                "must exceed burn_in_steps + max(welch_segment, 4·whiteness_lags)",
            );
        }
        if self.steps > 10_000_000 {
            return bad("steps", self.steps as f64, "at most 10⁷");
        }
        if self.whiteness_lags == 0 {
            return bad("whiteness_lags", 0.0, "must be ≥ 1");
        }
        if self.runs == 0 {
            return bad("runs", 0.0, "must be ≥ 1");
        }
        if self.gain_check_dts.is_empty() {
            return Err(Error::invalid(path, "`gain_check_dts` must not be empty"));
        }
        for &d in &self.gain_check_dts {
            if !(d.is_finite() && d > 0.0 && d <= 10.0) {
                return bad("gain_check_dts", d, "each Δt must lie in (0, 10] s");
            }
        }
        Ok(())
    }
}

fn to_faer(m: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

fn to_na(m: MatRef<'_, f64>) -> DMatrix<f64> {
    DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

fn arr22(m: &DMatrix<f64>) -> [[f64; 2]; 2] {
    [[m[(0, 0)], m[(0, 1)]], [m[(1, 0)], m[(1, 1)]]]
}

fn model_err(context: &'static str) -> impl Fn(model::Error) -> Error {
    move |e| Error::Compute(format!("uav: {context}: {e}"))
}

fn kalman_err(context: &'static str) -> impl Fn(kalman::Error) -> Error {
    move |e| Error::Compute(format!("uav: {context}: {e}"))
}

/// The continuous channel: ẋ = A x + B u + G w, z = H x + v with A = [[0, 1], [0, 0]],
/// B = G = (0, 1)ᵀ, H = (1, 0), W = q.
fn continuous(p: &UavParams) -> Result<model::ContinuousSs> {
    let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
    let h = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
    model::ContinuousSs::new(a, b.clone(), h, DMatrix::zeros(1, 1))
        .and_then(|s| s.with_noise(b, DMatrix::from_element(1, 1, p.accel_noise_intensity)))
        .map_err(model_err("continuous model"))
}

/// Everything that does not depend on the random draws.
#[derive(Debug, Clone)]
struct Design {
    f: DMatrix<f64>,
    b: DMatrix<f64>,
    h: DMatrix<f64>,
    q: DMatrix<f64>,
    /// Factor of Q_d for drawing w_k.
    q_factor: DMatrix<f64>,
    r: f64,
    /// LQR gain (1×2).
    l: DMatrix<f64>,
    /// Steady-state filter gain K (2×1) and predictor gain K_p (2×1).
    k: DMatrix<f64>,
    k_pred: DMatrix<f64>,
    /// Steady prior covariance.
    p_prior: DMatrix<f64>,
    nx: [f64; 2],
    nu: f64,
}

fn design(p: &UavParams) -> Result<Design> {
    let sys = continuous(p)?;
    let d = model::discretize(
        &sys,
        p.dt_s,
        model::Method::Zoh,
        model::NoiseConvention::VanLoan,
    )
    .map_err(model_err("discretisation"))?;
    let (f, b, h, q) = (d.f().clone(), d.b().clone(), d.h().clone(), d.q().clone());
    let q_factor = model::psd_factor(&q).map_err(model_err("Q_d factor"))?;
    let r = p.measurement_variance;
    let [q1, q2] = p.lqr_state_weight;
    let lqr = kalman::riccati::dlqr(
        to_faer(&f).as_ref(),
        to_faer(&b).as_ref(),
        faer::mat![[q1, 0.0], [0.0, q2]].as_ref(),
        faer::mat![[p.lqr_input_weight]].as_ref(),
        None,
    )
    .map_err(kalman_err("discrete LQR"))?;
    let ss = kalman::riccati::dare(
        to_faer(&f).as_ref(),
        to_faer(&h).as_ref(),
        to_faer(&q).as_ref(),
        faer::mat![[r]].as_ref(),
        None,
    )
    .map_err(kalman_err("filter DARE"))?;
    // Reference feedforward: [[F − I, B], [H, 0]]·[N_x; N_u] = [0; 0; 1].
    let m = Matrix3::new(
        f[(0, 0)] - 1.0,
        f[(0, 1)],
        b[(0, 0)],
        f[(1, 0)],
        f[(1, 1)] - 1.0,
        b[(1, 0)],
        h[(0, 0)],
        h[(0, 1)],
        0.0,
    );
    let n = m.lu().solve(&Vector3::new(0.0, 0.0, 1.0)).ok_or_else(|| {
        Error::Compute(
            "uav: [[F − I, B], [H, 0]] is singular: the plant cannot hold a constant output".into(),
        )
    })?;
    Ok(Design {
        l: to_na(lqr.gain.as_ref()),
        k: to_na(ss.gain.as_ref()),
        k_pred: to_na(ss.predictor_gain.as_ref()),
        p_prior: to_na(ss.prior.as_ref()),
        f,
        b,
        h,
        q,
        q_factor,
        r,
        nx: [n[0], n[1]],
        nu: n[2],
    })
}

/// One closed-loop run's time series.
#[derive(Debug, Clone, Default)]
struct Trace {
    t: Vec<f64>,
    reference: Vec<f64>,
    x: Vec<[f64; 2]>,
    w: Vec<[f64; 2]>,
    z: Vec<f64>,
    xhat: Vec<[f64; 2]>,
    u: Vec<f64>,
    innovation: Vec<f64>,
    innovation_var: Vec<f64>,
    gain: Vec<[f64; 2]>,
}

/// Simulates one closed-loop run from the stream of run `run`.
fn simulate(p: &UavParams, d: &Design, seed: u64, run: usize) -> Result<Trace> {
    let mut rng = run_rng(seed, run as u64);
    let mut normal = || -> f64 { rng.sample(StandardNormal) };
    let model = Model::new(
        Fixed::<2, 1, 1>::new(),
        &arr22(&d.f),
        &[[d.h[(0, 0)], d.h[(0, 1)]]],
        &arr22(&d.q),
        &[[d.r]],
    )
    .and_then(|m| m.with_control(&[[d.b[(0, 0)]], [d.b[(1, 0)]]]))
    .map_err(kalman_err("filter model"))?;
    let [p0, p1] = p.initial_covariance;
    let mut filter: FixedFilter<2, 1, 1> = kalman::Filter::new(
        model,
        &[0.0, 0.0],
        &[[p0, 0.0], [0.0, p1]],
        CovarianceForm::Joseph,
    )
    .map_err(kalman_err("filter"))?;
    let mut x = [p0.sqrt() * normal(), p1.sqrt() * normal()];
    let (f, b, l, lq) = (&d.f, &d.b, &d.l, &d.q_factor);
    let mut tr = Trace::default();
    let sr = d.r.sqrt();
    for k in 0..p.steps {
        let t = k as f64 * p.dt_s;
        let r = if t >= p.step_time_s {
            p.step_amplitude
        } else {
            0.0
        };
        let xp = filter.predicted_state();
        let u = -(l[(0, 0)] * (xp[0] - d.nx[0] * r) + l[(0, 1)] * (xp[1] - d.nx[1] * r)) + d.nu * r;
        let z = d.h[(0, 0)] * x[0] + d.h[(0, 1)] * x[1] + sr * normal();
        filter
            .step(&[z], Some(&[u]))
            .map_err(kalman_err("filter step"))?;
        let xf = filter.state();
        let g = filter.gain();
        let (n0, n1) = (normal(), normal());
        let w = [
            lq[(0, 0)] * n0 + lq[(0, 1)] * n1,
            lq[(1, 0)] * n0 + lq[(1, 1)] * n1,
        ];
        tr.t.push(t);
        tr.reference.push(r);
        tr.x.push(x);
        tr.w.push(w);
        tr.z.push(z);
        tr.xhat.push([xf[0], xf[1]]);
        tr.u.push(u);
        tr.innovation.push(filter.innovation()[0]);
        tr.innovation_var
            .push(filter.innovation_covariance()[(0, 0)]);
        tr.gain.push([g[(0, 0)], g[(1, 0)]]);
        x = [
            f[(0, 0)] * x[0] + f[(0, 1)] * x[1] + b[(0, 0)] * u + w[0],
            f[(1, 0)] * x[0] + f[(1, 1)] * x[1] + b[(1, 0)] * u + w[1],
        ];
    }
    Ok(tr)
}

/// The statistics of one run (after the burn-in).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Run index.
    pub run: usize,
    /// RMS of the position estimation error x − x̂_{k|k}, m.
    pub rms_estimation_error: f64,
    /// RMS of the measurement error z − x, m.
    pub rms_measurement_error: f64,
    /// Ljung–Box Q of the normalised innovations e/√Σ.
    pub ljung_box_q: f64,
    /// Mean normalised innovation squared (1 for a consistent filter).
    pub mean_nis: f64,
}

fn record(p: &UavParams, run: usize, tr: &Trace) -> RunRecord {
    let k0 = p.burn_in_steps;
    let n = (tr.t.len() - k0) as f64;
    let rms =
        |f: &dyn Fn(usize) -> f64| ((k0..tr.t.len()).map(|k| f(k).powi(2)).sum::<f64>() / n).sqrt();
    let nu: Vec<f64> = (k0..tr.t.len())
        .map(|k| tr.innovation[k] / tr.innovation_var[k].sqrt())
        .collect();
    RunRecord {
        run,
        rms_estimation_error: rms(&|k| tr.x[k][0] - tr.xhat[k][0]),
        rms_measurement_error: rms(&|k| tr.z[k] - tr.x[k][0]),
        ljung_box_q: spectrum::ljung_box(&nu, p.whiteness_lags),
        mean_nis: nu.iter().map(|v| v * v).sum::<f64>() / n,
    }
}

/// Monte Carlo aggregates, recomputed from the run records by both `run` and `merge`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Aggregate {
    /// √(mean over runs of the mean-square position estimation error), m.
    pub rms_estimation_error: f64,
    /// √(mean over runs of the mean-square measurement error), m.
    pub rms_measurement_error: f64,
    /// Their ratio.
    pub rms_ratio: f64,
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
    let a = to_faer(sys.a());
    let gwg = sys.g() * sys.w() * sys.g().transpose();
    let qc = to_faer(&gwg);
    let h = to_faer(sys.c());
    let rc = p.measurement_variance * p.dt_s;
    let rcm = faer::mat![[rc]];
    let care = kalman::riccati::care(a.as_ref(), h.as_ref(), qc.as_ref(), rcm.as_ref())
        .map_err(kalman_err("CARE"))?;
    let kc = [care.gain[(0, 0)], care.gain[(1, 0)]];
    let kb = kalman::continuous::KalmanBucy::new(a.as_ref(), h.as_ref(), qc.as_ref(), rcm.as_ref())
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
            model::Method::Zoh,
            model::NoiseConvention::VanLoan,
        )
        .map_err(model_err("discretisation"))?;
        let ss = kalman::riccati::dare(
            to_faer(d.f()).as_ref(),
            to_faer(d.h()).as_ref(),
            to_faer(d.q()).as_ref(),
            faer::mat![[rc / dt]].as_ref(),
            None,
        )
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
const ACF_LAGS: usize = 50;

/// Everything computed, before writing.
struct Computed {
    summary: UavSummary,
    trace: Trace,
    /// Autocorrelation of run 0's normalised innovations, lags 0..=ACF_LAGS, and its ±bound.
    acf: (Vec<f64>, f64),
    transient: Vec<[f64; 3]>,
    spectra: Vec<(
        PsdNode,
        Vec<&'static str>,
        spectrum::Psd,
        Vec<spectrum::Psd>,
    )>,
}

/// Computes the scenario for the runs in `runs` of a campaign of `total` runs.
fn compute(
    p: &UavParams,
    seed: u64,
    total: usize,
    runs: std::ops::Range<usize>,
    threads: Option<usize>,
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
    let trace = simulate(p, &d, seed, 0)?;
    let results = par_runs(runs, threads, "uav", |i| {
        simulate(p, &d, seed, i).map(|tr| record(p, i, &tr))
    })?;
    let run_records = results.into_iter().collect::<Result<Vec<_>>>()?;
    let agg = aggregate(p, &run_records);

    let fs = 1.0 / p.dt_s;
    let seg = p.welch_segment;
    let col = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { (0..trace.t.len()).map(f).collect() };
    let welch = |x: &[f64]| spectrum::welch(x, fs, seg);
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
        let first = ps[0].clone();
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
            },
            labels,
            first,
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
        runs: total,
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
        kalman_bucy: kb,
        run_records,
    };
    Ok(Computed {
        summary,
        trace,
        acf: (acf, acf_bound),
        transient,
        spectra,
    })
}

fn load(campaign: &Campaign) -> Result<UavParams> {
    let mut p: UavParams = crate::config::load_or_default(campaign.config.as_deref())?;
    let path = campaign
        .config
        .clone()
        .unwrap_or_else(|| PathBuf::from("<defaults>"));
    if let Some(r) = campaign.runs {
        if r == 0 {
            return Err(Error::Usage("--runs must be ≥ 1".into()));
        }
        p.runs = r;
    }
    p.validate(&path)?;
    Ok(p)
}

/// Runs the scenario into `campaign.out_dir("uav")`.
///
/// # Errors
/// A bad configuration (exit code 2), a library error or an I/O error.
pub fn run(campaign: &Campaign) -> Result<()> {
    let p = load(campaign)?;
    let runs = campaign.shard.runs(p.runs);
    let c = compute(&p, campaign.seed, p.runs, runs, campaign.threads)?;
    write_outputs(&campaign.out_dir("uav"), &c)
}

/// Merges shard directories: the run records are concatenated (each run exactly once), the
/// Monte Carlo aggregates recomputed, and everything else — identical in every shard, as it
/// does not depend on the shard — checked and copied from the first.
///
/// # Errors
/// Shards from different campaigns, missing or duplicated runs, unreadable files.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let mut summaries = Vec::new();
    for d in dirs {
        let path = d.join("summary.json");
        let text = crate::config::read_text(&path)?;
        let s: UavSummary = serde_json::from_str(&text)
            .map_err(|e| Error::invalid(&path, format!("not a uav summary: {e}")))?;
        summaries.push((path, s));
    }
    let Some((first_path, first)) = summaries.first() else {
        return Err(Error::Usage(
            "merge needs at least one shard directory".into(),
        ));
    };
    let strip = |s: &UavSummary| UavSummary {
        run_records: Vec::new(),
        monte_carlo: Aggregate::default(),
        innovation_whiteness_pass: false,
        rms_estimation_error: 0.0,
        rms_measurement_error: 0.0,
        ..s.clone()
    };
    let reference = strip(first);
    let mut records = Vec::new();
    for (path, s) in &summaries {
        if strip(s) != reference {
            return Err(Error::invalid(
                path,
                format!(
                    "comes from a different campaign than {} (parameters, seed or run count differ)",
                    first_path.display()
                ),
            ));
        }
        records.extend(s.run_records.iter().cloned());
    }
    records.sort_by_key(|r| r.run);
    for (i, r) in records.iter().enumerate() {
        if r.run != i {
            return Err(Error::Usage(format!(
                "uav merge: run {} is {} (each of the {} runs must appear exactly once)",
                i,
                if r.run < i { "duplicated" } else { "missing" },
                first.runs
            )));
        }
    }
    if records.len() != first.runs {
        return Err(Error::Usage(format!(
            "uav merge: {} of {} runs present",
            records.len(),
            first.runs
        )));
    }
    let agg = aggregate(&first.params, &records);
    let merged = UavSummary {
        innovation_whiteness_pass: agg.whiteness_pass,
        rms_estimation_error: agg.rms_estimation_error,
        rms_measurement_error: agg.rms_measurement_error,
        monte_carlo: agg,
        run_records: records,
        ..first.clone()
    };
    let from = first_path.parent().unwrap_or(Path::new("."));
    output::copy_files(from, out)?;
    let report_text = report(&merged);
    output::write_json(&out.join("summary.json"), &merged)?;
    output::write_atomic(&out.join("report.md"), report_text.as_bytes())
}

fn write_outputs(dir: &Path, c: &Computed) -> Result<()> {
    let s = &c.summary;
    let tr = &c.trace;
    let rows: Vec<Vec<f64>> = (0..tr.t.len())
        .map(|k| {
            vec![
                tr.t[k],
                tr.reference[k],
                tr.x[k][0],
                tr.x[k][1],
                tr.w[k][0],
                tr.w[k][1],
                tr.z[k],
                tr.xhat[k][0],
                tr.xhat[k][1],
                tr.u[k],
                tr.innovation[k],
                tr.innovation_var[k],
                tr.gain[k][0],
                tr.gain[k][1],
            ]
        })
        .collect();
    output::write_csv(
        &dir.join("signals.csv"),
        &[
            "t_s",
            "reference",
            "x_position",
            "x_velocity",
            "w_position",
            "w_velocity",
            "z",
            "xhat_position",
            "xhat_velocity",
            "u",
            "innovation",
            "innovation_variance",
            "gain_position",
            "gain_velocity",
        ],
        &rows,
    )?;
    // The paper's figures show the signal at a node; a 100 s window keeps them readable
    // (the CSV has the whole run).
    let window = |k: usize| -> Vec<(f64, f64)> {
        rows.iter()
            .take_while(|r| r[0] <= 100.0)
            .map(|r| (r[0], r[k]))
            .collect()
    };
    let fig = |file: &str, title: &str, y: &str, ss: Vec<Series>| -> Result<()> {
        line_plot(
            &dir.join(file),
            &Figure {
                title,
                x_label: "t, s",
                y_label: y,
                y_scale: Scale::Linear,
            },
            &ss,
        )
    };
    fig(
        "signal_node1_W.svg",
        "Node 1: noise generator output W (paper Fig. 4, top)",
        "w_k components",
        vec![
            Series::line("W position, m", window(4)),
            Series::line("W velocity, m/s", window(5)),
        ],
    )?;
    fig(
        "signal_node2_z.svg",
        "Node 2: sensor output z (paper Fig. 5, top; Fig. 3 A)",
        "m",
        vec![
            Series::line("z", window(6)),
            Series::line("true position x", window(2)),
            Series::line("reference r", window(1)),
        ],
    )?;
    fig(
        "signal_node3_filter.svg",
        "Nodes 2 → 3: filter input z and output x̂ (paper Fig. 3 A/B)",
        "m",
        vec![
            Series::line("filter input z", window(6)),
            Series::line("filter output x̂", window(7)),
            Series::line("reference r", window(1)),
        ],
    )?;
    let est_err: Vec<(f64, f64)> = rows
        .iter()
        .take_while(|r| r[0] <= 100.0)
        .map(|r| (r[0], r[2] - r[7]))
        .collect();
    fig(
        "signal_node4_error.svg",
        "Node 4: error signal — innovation z − Hx̂⁻ (paper Fig. 6, top)",
        "m",
        vec![
            Series::line("innovation", window(10)),
            Series::line("estimation error x − x̂", est_err),
        ],
    )?;
    for (node, labels, _, ps) in &c.spectra {
        let mut header = vec!["f_hz"];
        header.extend(labels.iter().copied());
        let table: Vec<Vec<f64>> = (0..ps[0].freq.len())
            .map(|i| {
                let mut row = vec![ps[0].freq[i]];
                row.extend(ps.iter().map(|p| p.psd[i]));
                row
            })
            .collect();
        output::write_csv(&dir.join(&node.csv), &header, &table)?;
        let mut ss: Vec<Series> = labels
            .iter()
            .zip(ps)
            .map(|(l, p)| {
                Series::line(
                    format!("PSD of {l}"),
                    p.freq
                        .iter()
                        .copied()
                        .zip(p.psd.iter().copied())
                        .skip(1)
                        .collect(),
                )
            })
            .collect();
        let f_end = ps[0].freq.last().copied().unwrap_or(1.0);
        if let Some(w) = node.white_level {
            ss.push(Series::line(
                "white level 2σ²/fs (theory)",
                vec![(ps[0].freq[1], w), (f_end, w)],
            ));
        }
        let title = format!("Welch PSD, {}", node.description);
        line_plot(
            &dir.join(&node.svg),
            &Figure {
                title: &title,
                x_label: "f, Hz",
                y_label: "PSD, units²/Hz (log)",
                y_scale: Scale::Log,
            },
            &ss,
        )?;
    }
    // Gain transient: Kalman–Bucy K_c(t) (Riccati ODE) against the running K_k/Δt.
    let dt = s.params.dt_s;
    let horizon = c.transient.last().map_or(0.0, |r| r[0]);
    let disc = |j: usize| -> Vec<(f64, f64)> {
        tr.t.iter()
            .zip(&tr.gain)
            .take_while(|(t, _)| **t <= horizon)
            .map(|(t, g)| (*t, g[j] / dt))
            .collect()
    };
    let cont =
        |j: usize| -> Vec<(f64, f64)> { c.transient.iter().map(|r| (r[0], r[j + 1])).collect() };
    output::write_csv(
        &dir.join("gain_transient.csv"),
        &["t_s", "kc_position", "kc_velocity"],
        &c.transient.iter().map(|r| r.to_vec()).collect::<Vec<_>>(),
    )?;
    line_plot(
        &dir.join("gain_transient.svg"),
        &Figure {
            title: "Kalman–Bucy gain K_c(t) (Riccati ODE) vs discrete K_k/Δt",
            x_label: "t, s",
            y_label: "gain, 1/s",
            y_scale: Scale::Linear,
        },
        &[
            Series::line("K_c position (ODE)", cont(0)),
            Series::line("K_c velocity (ODE)", cont(1)),
            Series::points("K_k/Δt position (discrete)", disc(0)),
            Series::points("K_k/Δt velocity (discrete)", disc(1)),
        ],
    )?;
    let (acf, bound) = &c.acf;
    output::write_csv(
        &dir.join("innovation_acf.csv"),
        &["lag", "autocorrelation", "bound_95"],
        &acf.iter()
            .enumerate()
            .map(|(k, r)| vec![k as f64, *r, *bound])
            .collect::<Vec<_>>(),
    )?;
    let lags = acf.len().saturating_sub(1) as f64;
    line_plot(
        &dir.join("innovation_acf.svg"),
        &Figure {
            title: "Run 0: autocorrelation of the normalised innovations e/√Σ",
            x_label: "lag, steps",
            y_label: "ρ_k",
            y_scale: Scale::Linear,
        },
        &[
            Series::points(
                "ρ_k",
                acf.iter()
                    .enumerate()
                    .skip(1)
                    .map(|(k, r)| (k as f64, *r))
                    .collect(),
            ),
            Series::line("+1.96/√N", vec![(1.0, *bound), (lags, *bound)]),
            Series::line("−1.96/√N", vec![(1.0, -*bound), (lags, -*bound)]),
        ],
    )?;
    output::write_csv(
        &dir.join("runs.csv"),
        &[
            "run",
            "rms_estimation_error",
            "rms_measurement_error",
            "ljung_box_q",
            "mean_nis",
        ],
        &s.run_records
            .iter()
            .map(|r| {
                vec![
                    r.run as f64,
                    r.rms_estimation_error,
                    r.rms_measurement_error,
                    r.ljung_box_q,
                    r.mean_nis,
                ]
            })
            .collect::<Vec<_>>(),
    )?;
    output::write_json(&dir.join("summary.json"), s)?;
    output::write_atomic(&dir.join("report.md"), report(s).as_bytes())
}

fn fmt_poles(p: &[[f64; 2]]) -> String {
    p.iter()
        .map(|[re, im]| {
            if im.abs() < 1e-12 {
                format!("{re:.4}")
            } else {
                format!(
                    "{re:.4} {} {:.4}i",
                    if *im < 0.0 { "−" } else { "+" },
                    im.abs()
                )
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The text of report.md (from the summary alone, so `merge` rewrites it).
fn report(s: &UavSummary) -> String {
    let p = &s.params;
    let mc = &s.monte_carlo;
    let kb = &s.kalman_bucy;
    let yes = |b: bool| if b { "yes" } else { "NO" };
    let mut r = String::new();
    let _ = writeln!(
        r,
        "# U — UAV control channel with a discrete Kalman filter in the loop\n\n\
         Generated by `scenarios uav`; do not edit by hand. Seed {}, {} Monte Carlo runs of {} \
         steps (Δt = {} s); statistics skip the first {} steps (filter start-up). Figures \
         come from run 0. The paper's first experiment (white noise alone, no step) is \
         `step_amplitude = 0.0` in a `--config` file.\n\n\
         Plant: the sampled double integrator F = [[{:.4}, {:.4}], [{:.4}, {:.4}]], \
         B = ({:.5}, {:.4})ᵀ, H = (1, 0); process noise from white acceleration of intensity \
         q = {} by Van Loan, Q_d = [[{:.3e}, {:.3e}], [{:.3e}, {:.3e}]]; R = {}. LQR \
         (Q = diag({}, {}), R_u = {}): L = ({:.4}, {:.4}). Steady filter gain (DARE) \
         K = ({:.4}, {:.4}).\n\n\
         Control law: u_k = −L(x̂_{{k|k−1}} − N_x r_k) + N_u r_k with N_x = ({:.3}, {:.3}), \
         N_u = {:.3}: the reference-tracking feedforward solves [[F − I, B], [H, 0]]·[N_x; N_u] \
         = [0; 1]. The control is computed from the one-step prediction (available before z_k \
         is processed: a one-sample computational delay), so the closed loop is \
         [[F − BL, BL], [0, F − K_p H]] in (x, x − x̂⁻), K_p = F K.\n",
        s.seed,
        s.runs,
        p.steps,
        p.dt_s,
        p.burn_in_steps,
        s.f[0][0],
        s.f[0][1],
        s.f[1][0],
        s.f[1][1],
        s.b[0],
        s.b[1],
        p.accel_noise_intensity,
        s.q_d[0][0],
        s.q_d[0][1],
        s.q_d[1][0],
        s.q_d[1][1],
        p.measurement_variance,
        p.lqr_state_weight[0],
        p.lqr_state_weight[1],
        p.lqr_input_weight,
        s.lqr_gain[0],
        s.lqr_gain[1],
        s.filter_gain[0],
        s.filter_gain[1],
        s.feedforward[0],
        s.feedforward[1],
        s.feedforward[2],
    );
    let _ = writeln!(r, "## The paper's claims next to ours\n");
    let _ = writeln!(r, "| paper | ours | comment |\n|---|---|---|");
    let _ = writeln!(
        r,
        "| F = [[1, 0.25], [0, 1]] (position and its rate) | F = [[{:.2}, {:.2}], [{:.2}, {:.2}]] | same; B, H, q, R, L are the project's assumed defaults (the paper gives none) |",
        s.f[0][0], s.f[0][1], s.f[1][0], s.f[1][1]
    );
    let _ = writeln!(
        r,
        "| \"if A − BL is asymptotically stable, the filter for the closed system is stable too\" | ρ(F − BL) = {:.4}, ρ(filter) = {:.4}, ρ(closed loop) = {:.4}; closed-loop poles {}; filter poles {} | agrees (separation principle: the closed-loop poles are the controller's and the filter's) |",
        s.controller_spectral_radius,
        s.filter_spectral_radius,
        s.closed_loop_spectral_radius,
        fmt_poles(&s.closed_loop_poles),
        fmt_poles(&s.filter_poles)
    );
    let _ = writeln!(
        r,
        "| \"the loop works correctly even with heavily noisy signals\" (Figs. 3–6, no numbers) | RMS position error of the estimate {:.4} m vs of the measurement {:.4} m (ratio {:.3}); the position settles at {:.3} m for a {} m step | quantified: the filter removes {:.0} % of the measurement noise power |",
        s.rms_estimation_error,
        s.rms_measurement_error,
        mc.rms_ratio,
        s.tracking_mean_last_quarter,
        p.step_amplitude,
        100.0 * (1.0 - mc.rms_ratio.powi(2))
    );
    if let Some(w) = s.psd_nodes.first() {
        let _ = writeln!(
            r,
            "| Fig. 4: noise generator output W is white | mean PSD of W's position component {:.3e} vs 2Q₁₁/fs = {:.3e}; upper half band {:.3e} | flat at the theoretical level (ratio {:.3}) |",
            w.mean_level,
            w.white_level.unwrap_or(f64::NAN),
            w.high_band_level,
            w.mean_level / w.white_level.unwrap_or(f64::NAN)
        );
    }
    if let Some(z) = s.psd_nodes.get(1) {
        let _ = writeln!(
            r,
            "| Fig. 5: sensor output z is the signal buried in noise | z's spectrum: the loop's low-frequency power over the noise floor 2R/fs = {:.3} m²/Hz (upper half band {:.3}) | same picture |",
            2.0 * p.measurement_variance * p.dt_s,
            z.high_band_level
        );
    }
    if let (Some(z), Some(x)) = (s.psd_nodes.get(1), s.psd_nodes.get(2)) {
        let _ = writeln!(
            r,
            "| Fig. 3: control signal at the filter input (node 2) and output (node 3) | upper half band (f > fs/4): x̂ {:.3e} m²/Hz vs z {:.3e} m²/Hz ({:.0}× less) | the filter is a low-pass in the loop, as the paper's figure shows |",
            x.high_band_level,
            z.high_band_level,
            z.high_band_level / x.high_band_level
        );
    }
    if let Some(e) = s.psd_nodes.get(3) {
        let _ = writeln!(
            r,
            "| Fig. 6: the error signal | innovation white: pooled Ljung–Box Q = {:.1} < χ²₀.₉₉({}) = {:.1}: {}; {:.0} % of runs pass at α = {}; mean NIS {:.3}; PSD mean {:.3e} vs 2Σ/fs = {:.3e} | the paper shows the signal only; we test it |",
            mc.pooled_ljung_box_q,
            mc.pooled_dof,
            mc.pooled_bound,
            yes(s.innovation_whiteness_pass),
            100.0 * mc.runs_passing_fraction,
            p.whiteness_alpha,
            mc.mean_nis,
            e.mean_level,
            e.white_level.unwrap_or(f64::NAN)
        );
    }
    let _ = writeln!(
        r,
        "| Riccati equation (5) (Kalman–Bucy) and the discrete gain (12) | K_c = ({:.4}, {:.4}) (CARE, R_c = RΔt = {}); ODE limit agrees to {:.1e}; K_d/Δt → K_c: gap {} | consistent: {} (gap shrinks with Δt, {:.2e} ≤ {} at the smallest Δt) |",
        kb.care_gain[0],
        kb.care_gain[1],
        kb.measurement_intensity,
        kb.ode_vs_care,
        kb.table
            .iter()
            .map(|g| format!("{:.3e} at Δt = {}", g.relative_gap, g.dt_s))
            .collect::<Vec<_>>()
            .join(", "),
        yes(kb.consistent),
        kb.table.last().map_or(f64::NAN, |g| g.relative_gap),
        p.gain_tolerance
    );
    let _ = writeln!(
        r,
        "| gain (12) prints P⁺ inside the bracket | we use P⁻ (H P⁻ Hᵀ + R) | the printed P⁺ is a typo (SPEC U) |\n"
    );
    let _ = writeln!(
        r,
        "## Stability and the filter\n\n- closed loop ρ = {:.6}, controller ρ(F − BL) = {:.6}, filter ρ = {:.6}\n\
         - the running filter gain after {} steps matches the DARE gain to {:.1e} (relative)\n\
         - the innovation whiteness test passes: {} (pooled Ljung–Box over {} runs, h = {} \
         lags, α = {}); in run 0, {:.0} % of the autocorrelations at lags 1–{} fall outside \
         ±1.96/√N (≈ 5 % expected for white innovations)\n\n\
         ![innovation autocorrelation](innovation_acf.svg)\n",
        s.closed_loop_spectral_radius,
        s.controller_spectral_radius,
        s.filter_spectral_radius,
        p.steps,
        s.running_gain_vs_dare,
        yes(s.innovation_whiteness_pass),
        s.runs,
        p.whiteness_lags,
        p.whiteness_alpha,
        100.0 * s.innovation_acf_outside_fraction,
        ACF_LAGS
    );
    let _ = writeln!(
        r,
        "## Kalman–Bucy against the discrete gain\n\nWith the measurement noise of \
         variance R at interval Δt read as a continuous intensity R_c = R·Δt, the discrete \
         steady gain at interval Δt (R_d = R_c/Δt, Q_d by Van Loan) satisfies K_d/Δt → K_c.\n\n\
         | Δt, s | K_d/Δt | ‖K_d/Δt − K_c‖/‖K_c‖ |\n|---|---|---|"
    );
    for g in &kb.table {
        let _ = writeln!(
            r,
            "| {} | ({:.5}, {:.5}) | {:.3e} |",
            g.dt_s, g.discrete_gain_over_dt[0], g.discrete_gain_over_dt[1], g.relative_gap
        );
    }
    let _ = writeln!(
        r,
        "| CARE | ({:.5}, {:.5}) | — |\n\n![gain transient](gain_transient.svg)\n",
        kb.care_gain[0], kb.care_gain[1]
    );
    let _ = writeln!(
        r,
        "## Signals and spectra at the nodes (paper Figs. 3–6)\n\n\
         ![node 1](signal_node1_W.svg)\n\n![node 2](signal_node2_z.svg)\n\n\
         ![nodes 2 and 3](signal_node3_filter.svg)\n\n![node 4](signal_node4_error.svg)\n"
    );
    for n in &s.psd_nodes {
        let _ = writeln!(
            r,
            "{} — data: [{}]({})\n\n![{}]({})\n",
            n.description, n.csv, n.csv, n.name, n.svg
        );
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_values_are_named() {
        let p = UavParams {
            welch_segment: 100,
            ..UavParams::default()
        };
        let msg = p
            .validate(Path::new("u.toml"))
            .expect_err("not a power of two")
            .to_string();
        assert!(
            msg.contains("welch_segment") && msg.contains("u.toml"),
            "{msg}"
        );
        let err = crate::config::parse_toml::<UavParams>(Path::new("u.toml"), "dt = 0.1\n")
            .expect_err("unknown key");
        assert!(err.to_string().contains("dt"), "{err}");
    }

    #[test]
    fn design_matches_the_paper_plant() {
        let d = design(&UavParams::default()).expect("design");
        // ZOH of the double integrator is exact: F = [[1, Δt], [0, 1]], B = (Δt²/2, Δt).
        assert!((d.f[(0, 1)] - 0.25).abs() < 1e-12 && (d.f[(1, 1)] - 1.0).abs() < 1e-12);
        assert!((d.b[(0, 0)] - 0.03125).abs() < 1e-12 && (d.b[(1, 0)] - 0.25).abs() < 1e-12);
        // Van Loan for white acceleration: Q_d = q[[Δt³/3, Δt²/2], [Δt²/2, Δt]].
        let q = 0.1;
        assert!((d.q[(0, 0)] - q * 0.25f64.powi(3) / 3.0).abs() < 1e-14);
        assert!((d.q[(0, 1)] - q * 0.25f64.powi(2) / 2.0).abs() < 1e-14);
        // The double integrator holds a constant position with zero input.
        assert!((d.nx[0] - 1.0).abs() < 1e-12 && d.nx[1].abs() < 1e-12 && d.nu.abs() < 1e-12);
    }

    #[test]
    fn merge_aggregates_like_a_single_run() {
        let p = UavParams {
            steps: 400,
            runs: 6,
            ..UavParams::default()
        };
        let whole = compute(&p, 5, 6, 0..6, Some(1)).expect("whole");
        let a = compute(&p, 5, 6, 0..2, Some(1)).expect("a");
        let b = compute(&p, 5, 6, 2..6, Some(2)).expect("b");
        let mut rec = a.summary.run_records.clone();
        rec.extend(b.summary.run_records.clone());
        assert_eq!(rec, whole.summary.run_records);
        assert_eq!(aggregate(&p, &rec), whole.summary.monte_carlo);
    }
}
