//! "Paper F learned back": one simulated 10-minute record of the gyro and the level sensor
//! from the scenario's truth world, and the paper's model parameters fitted to it by maximum
//! likelihood — the rolling (σ, μ, period) from the gyro's tilt, the fill-rate fluctuation
//! (σ, T_a) from the quantized, damped level reading — next to the values that simulated it.
//!
//! The rolling fit is `crate::fit::shaping`'s irregular-rolling map (the tilt toward the
//! sensor, ψ cos φ + θ sin φ of two independent axes of σ = A_max/3 each, is itself an
//! irregular rolling of variance σ²), with the classical autocorrelation least-squares
//! estimate for comparison. The fill fit is a three-state model written here for
//! `kalman::fit` (states: tank level h_k, fluctuation ΔV_k, the damper output y_{k−1}):
//! `h_{k+1} = h_k + Δt (V_c + ΔV_k)`, ΔV an exact AR(1) of the exponential correlation
//! σ² e^{−|τ|/T_a}, `y_k = a y_{k−1} + (1 − a)(h_k + R α_k)` with `a = e^{−Δt/T_y}` and the
//! gyro's tilt α_k as a known input, and the reading `z_k = y_k + v_k` with the quantization
//! error taken as white of variance δ²/12 (the floor's mean −δ/2 is added back). That last
//! step is the question: the quantizer's error is not white, and whether the fit survives it
//! is what the section reports.
#![allow(non_snake_case)]

use kalman::fit::{FitError, FnMap, Series, System, mle};
use sensors::{
    ExpCorrelated, ExpCorrelatedConfig, Gyro, GyroConfig, LevelSensor, LevelSensorConfig,
    PlatformMotion, PlatformMotionConfig, Process, RollingAxisConfig,
};
use serde::{Deserialize, Serialize};

use super::parameters::{FuelingParams, Swept};
use crate::error::{Error, Result};
use crate::fit::shaping::{Kind, Noise, ShapingMap, fit_acf, fit_mle};
use crate::montecarlo::{run_rng, run_seed};

/// The record's length, s.
pub const RECORD_S: f64 = 600.0;
/// The random stream of the record (apart from the Monte Carlo runs' and the calibration's).
const LEARN_STREAM: u64 = (1 << 62) + 16;
/// The normal quantile of a two-sided 95 % interval.
pub const Z95: f64 = 1.959_963_984_540_054;

/// One learned parameter. Every fit is on a log scale (`ln p`), so the 95 % Wald interval
/// is `p̂·e^{±1.96·se(ln p̂)}` — the interval of the scale the information is computed on,
/// mapped back, and positive as the parameter is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Learned {
    /// Name with its unit.
    pub name: String,
    /// The value used to simulate.
    pub truth: f64,
    /// The maximum-likelihood estimate.
    pub estimate: f64,
    /// Its standard error on this scale (delta method: `p̂·se(ln p̂)`); NaN when the
    /// observed information is not positive definite.
    pub std_error: f64,
    /// The 95 % Wald interval `[p̂·e^{−1.96·se(ln p̂)}, p̂·e^{1.96·se(ln p̂)}]` (NaN as above).
    pub interval95: [f64; 2],
    /// The classical estimate (autocorrelation least squares), where there is one.
    pub classical: Option<f64>,
}

impl Learned {
    /// A parameter estimated as `estimate` with `log_se`, the standard error of its
    /// logarithm.
    fn new(
        name: &'static str,
        truth: f64,
        estimate: f64,
        log_se: f64,
        classical: Option<f64>,
    ) -> Self {
        Self {
            name: name.to_string(),
            truth,
            estimate,
            std_error: estimate * log_se,
            interval95: [
                estimate * (-Z95 * log_se).exp(),
                estimate * (Z95 * log_se).exp(),
            ],
            classical,
        }
    }
    /// `ln(p̂/p)/se(ln p̂)`: how many standard errors of the fitted scale the truth lies
    /// from the estimate.
    pub fn z(&self) -> f64 {
        let log_se = (self.interval95[1] / self.estimate).ln() / Z95;
        (self.estimate / self.truth).ln() / log_se
    }
    /// Whether the 95 % interval covers the truth (false without a standard error).
    pub fn covered(&self) -> bool {
        self.interval95[0] <= self.truth && self.truth <= self.interval95[1]
    }
}

/// The section's numbers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LearnedBack {
    /// Samples in the record.
    pub samples: usize,
    /// Sampling interval, s.
    pub dt_s: f64,
    /// σ (°), μ (1/s), period (s) of the rolling, from the gyro.
    pub rolling: Vec<Learned>,
    /// σ (mm/s), T_a (s) of the fill-rate fluctuation, from the level sensor.
    pub fill: Vec<Learned>,
    /// Whether both maximum-likelihood fits converged.
    pub converged: bool,
    /// The two fits' accounts of their stop (rolling, fill).
    pub messages: [String; 2],
}

/// The gyro's tilt toward the sensor and the level sensor's readings over one record.
fn record(p: &FuelingParams, seed: u64) -> Result<(Vec<f64>, Vec<f64>)> {
    crate::montecarlo::count_simulation();
    let w = p.world(p.max_amplitude_deg, Swept::Nothing).fuel;
    let sensor_err = |context| move |source| Error::Sensors { context, source };
    let axis = RollingAxisConfig {
        max_amplitude_deg: w.max_tilt_amplitude.to_degrees(),
        period_s: w.rolling_period,
        irregularity_per_s: w.mu,
    };
    let mut platform = PlatformMotion::new(
        &PlatformMotionConfig {
            roll: axis,
            pitch: axis,
        },
        w.dt,
    )
    .map_err(sensor_err("platform motion"))?;
    let mut velocity = ExpCorrelated::new(
        &ExpCorrelatedConfig {
            std_dev: w.d_c.sqrt(),
            correlation_time_s: w.t_a,
        },
        w.dt,
    )
    .map_err(sensor_err("fill-velocity fluctuation"))?;
    let mut sensor = LevelSensor::new(
        &LevelSensorConfig {
            step_m: w.delta,
            damper_time_constant_s: w.t_y,
            sensor_radius_m: w.sensor_radius,
            sensor_angle_deg: w.phi.to_degrees(),
            ..LevelSensorConfig::default()
        },
        w.dt,
    )
    .map_err(sensor_err("level sensor"))?;
    let mut gyro = Gyro::new(
        &GyroConfig {
            sample_period_s: w.dt,
            noise_std_deg: w.gyro_noise_var.sqrt().to_degrees(),
            ..GyroConfig::default()
        },
        w.dt,
    )
    .map_err(sensor_err("gyro"))?;
    let mut rng = run_rng(run_seed(seed, LEARN_STREAM), 0);
    let n = (RECORD_S / w.dt).round() as usize;
    let (mut tilt, mut level) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut h = p.target_level_m - w.v_c * RECORD_S;
    let mut v_prev = 0.0;
    for k in 0..n {
        let attitude = platform.next(&mut rng);
        let v = velocity.next(&mut rng);
        if k > 0 {
            h += (w.v_c + 0.5 * (v + v_prev)) * w.dt;
        }
        v_prev = v;
        level.push(sensor.step(h, attitude, &mut rng).reading);
        tilt.push(gyro.step(attitude, &mut rng).tilt_toward(w.phi));
    }
    Ok((tilt, level))
}

fn compute(source: FitError) -> Error {
    Error::Fit {
        context: "learning the model back",
        source,
    }
}

/// The fill model for θ = (ln σ², ln T_a); inputs u_k = (Δt·V_c, (1 − a)·R·α_k).
fn fill_map(dt: f64, t_y: f64, delta: f64, h0: f64) -> impl kalman::fit::ParamMap {
    let a = (-dt / t_y).exp();
    FnMap::new(2, move |t: &[f64]| {
        let (var, t_a) = (t[0].exp(), t[1].exp());
        let phi = (-dt / t_a).exp();
        let F = [[1.0, dt, 0.0], [0.0, phi, 0.0], [1.0 - a, 0.0, a]];
        let H = [[1.0 - a, 0.0, a]];
        let q = var * -(-2.0 * dt / t_a).exp_m1();
        let Q = [[0.0, 0.0, 0.0], [0.0, q, 0.0], [0.0, 0.0, 0.0]];
        let R = [[delta * delta / 12.0]];
        // The level from the first reading to within a few steps; ΔV stationary.
        let P0 = [
            [(4.0 * delta).powi(2), 0.0, 0.0],
            [0.0, var, 0.0],
            [0.0, 0.0, (4.0 * delta).powi(2)],
        ];
        System::new(&F, &H, &Q, &R, &[h0, 0.0, h0], &P0)?.with_control(&[
            [1.0, 0.0],
            [0.0, 0.0],
            [0.0, 1.0],
        ])
    })
    .with_log_variances(vec![0])
}

/// Fits the record of `seed` and sets the fits beside the truth.
///
/// # Errors
/// [`Error::Fit`] (or the shaping fit's errors) if a fit fails outright (not for an unconverged one, which the
/// section reports).
pub fn learn_back(p: &FuelingParams, seed: u64) -> Result<LearnedBack> {
    let w = p.world(p.max_amplitude_deg, Swept::Nothing).fuel;
    let (tilt, level) = record(p, seed)?;
    let dt = w.dt;

    // Rolling from the gyro: truth D = (A_max/3)², μ, β = 2π/period.
    let sigma = w.max_tilt_amplitude / 3.0;
    let beta = 2.0 * std::f64::consts::PI / w.rolling_period;
    let map = ShapingMap {
        kind: Kind::IrregularRolling,
        dt,
        noise: Noise::Known(w.gyro_noise_var),
    };
    let var = tilt.iter().map(|v| v * v).sum::<f64>() / tilt.len() as f64;
    let max_lag = ((3.0 / w.mu) / dt).round() as usize;
    let classical = fit_acf(map.kind, &tilt, dt, max_lag, &[var, 0.1, 0.5])?;
    let fit = fit_mle(&map, &tilt, &classical, 0.0)?;
    // Standard errors of ln D, ln μ, ln β (fit_mle reports p·se(ln p): divide back).
    let log_se: Vec<f64> = match &fit.std_errors {
        Some(se) => se.iter().zip(&fit.values).map(|(s, v)| s / v).collect(),
        None => vec![f64::NAN; 3],
    };
    let (d, mu, b) = (fit.values[0], fit.values[1], fit.values[2]);
    let period = |b: f64| 2.0 * std::f64::consts::PI / b;
    // σ = √D: ln σ = ½ ln D; period = 2π/β: ln period = ln 2π − ln β, the same se.
    let rolling = vec![
        Learned::new(
            "σ of the tilt, °",
            sigma.to_degrees(),
            d.sqrt().to_degrees(),
            0.5 * log_se[0],
            Some(classical[0].sqrt().to_degrees()),
        ),
        Learned::new(
            "irregularity μ, 1/s",
            w.mu,
            mu,
            log_se[1],
            Some(classical[1]),
        ),
        Learned::new(
            "period 2π/β, s",
            period(beta),
            period(b),
            log_se[2],
            Some(period(classical[2])),
        ),
    ];

    // Fill-rate fluctuation from the level reading.
    let a = (-dt / w.t_y).exp();
    let z: Vec<f64> = level
        .iter()
        .zip(&tilt)
        .map(|(z, t)| z + 0.5 * w.delta - (1.0 - a) * w.sensor_radius * t)
        .collect();
    let u: Vec<f64> = tilt
        .iter()
        .flat_map(|t| [dt * w.v_c, (1.0 - a) * w.sensor_radius * t])
        .collect();
    let data = Series::new(&z, 1)
        .and_then(|s| s.with_inputs(&u, 2))
        .map_err(compute)?;
    let map = fill_map(dt, w.t_y, w.delta, z[0]);
    let start = vec![(0.5 * w.d_c).ln(), (0.5 * w.t_a).ln()];
    let ffit = mle(&map, start, &data, &crate::fit::shaping::MLE_OPTIONS).map_err(compute)?;
    let fse = ffit
        .uncertainty
        .std_errors
        .clone()
        .unwrap_or_else(|| vec![f64::NAN; 2]);
    let (fv, ft) = (ffit.theta[0].exp(), ffit.theta[1].exp());
    let fill = vec![
        Learned::new(
            "σ of the fill-rate fluctuation, mm/s",
            w.d_c.sqrt() * 1e3,
            fv.sqrt() * 1e3,
            0.5 * fse[0],
            None,
        ),
        Learned::new("correlation time T_a, s", w.t_a, ft, fse[1], None),
    ];
    Ok(LearnedBack {
        samples: tilt.len(),
        dt_s: dt,
        rolling,
        fill,
        converged: fit.converged && ffit.converged,
        messages: [fit.message, ffit.message],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;
    use rand_distr::StandardNormal;

    #[test]
    fn the_fill_map_recovers_its_own_parameters() {
        // Data from the map's own model (white reading noise δ²/12): the fit must find the
        // truth within 4 standard errors — checks the map, apart from the quantizer.
        let (dt, t_y, delta, v_c, radius): (f64, f64, f64, f64, f64) = (0.1, 2.0, 0.01, 0.01, 1.5);
        let (var, t_a): (f64, f64) = (1e-6, 20.0);
        let a = (-dt / t_y).exp();
        let mut g = run_rng(5, 0);
        let mut n = || -> f64 { g.sample(StandardNormal) };
        let phi = (-dt / t_a).exp();
        let (mut h, mut dv, mut y) = (10.0, var.sqrt() * n(), 10.0);
        let (mut z, mut u) = (Vec::new(), Vec::new());
        for k in 0..6000 {
            let alpha = 0.005 * (0.6 * k as f64 * dt).sin();
            let yk = a * y + (1.0 - a) * (h + radius * alpha);
            z.push(yk + delta / 12f64.sqrt() * n() - (1.0 - a) * radius * alpha);
            u.extend([dt * v_c, (1.0 - a) * radius * alpha]);
            y = yk;
            h += dt * (v_c + dv);
            dv = phi * dv + (var * (1.0 - phi * phi)).sqrt() * n();
        }
        let data = Series::new(&z, 1)
            .and_then(|s| s.with_inputs(&u, 2))
            .expect("series");
        let map = fill_map(dt, t_y, delta, z[0]);
        let fit = mle(
            &map,
            vec![(0.5 * var).ln(), (0.5 * t_a).ln()],
            &data,
            &crate::fit::shaping::MLE_OPTIONS,
        )
        .expect("fit");
        assert!(fit.converged, "{}", fit.message);
        let se = fit.uncertainty.std_errors.expect("standard errors");
        for (i, truth) in [var.ln(), t_a.ln()].iter().enumerate() {
            // 4 s.e.: a 6e-5 event for a Gaussian estimate.
            assert!(
                (fit.theta[i] - truth).abs() < 4.0 * se[i],
                "θ{i} = {} ± {} vs {truth}",
                fit.theta[i],
                se[i]
            );
        }
    }

    #[test]
    fn the_rolling_is_learned_from_the_gyro() {
        let p = FuelingParams::default();
        let l = learn_back(&p, 1).expect("learned");
        assert_eq!(l.samples, (RECORD_S / p.dt_s).round() as usize);
        assert!(l.converged, "{l:#?}");
        // The rolling fit is correctly specified (the tilt is an irregular rolling sampled
        // exactly): its truth within 4 standard errors.
        for r in &l.rolling {
            assert!(r.z().abs() < 4.0, "{r:?}");
            assert!(r.std_error > 0.0 && r.std_error < r.truth, "{r:?}");
            // The interval is the log-scale one: it holds the estimate and its half-widths
            // in logs are 1.96 s.e. of ln p (= std_error/estimate) each.
            let [lo, hi] = r.interval95;
            assert!(lo < r.estimate && r.estimate < hi, "{r:?}");
            let log_se = r.std_error / r.estimate;
            assert!(((hi / lo).ln() - 2.0 * Z95 * log_se).abs() < 1e-12, "{r:?}");
            assert_eq!(r.covered(), r.z().abs() <= Z95, "{r:?}");
        }
        for f in &l.fill {
            assert!(
                f.estimate > 0.0 && f.std_error.is_finite() && f.std_error > 0.0,
                "{f:?}"
            );
        }
        // The same seed gives the same record and numbers.
        assert_eq!(learn_back(&p, 1).expect("learned"), l);
    }

    #[test]
    fn the_section_verdict_follows_the_intervals() {
        // Truth 1 with se(ln p) = 0.1: an estimate e^{0.15} is covered (1.5 s.e.), e^{0.25}
        // is not (2.5 s.e.); the verdict names the parameter whose interval misses.
        let p = |name, est: f64| Learned::new(name, 1.0, est, 0.1, None);
        let mut l = LearnedBack {
            samples: 6000,
            dt_s: 0.1,
            rolling: vec![p("a", 0.15f64.exp()), p("b", (-0.15f64).exp())],
            fill: vec![p("c", 0.15f64.exp())],
            converged: true,
            messages: [String::new(), String::new()],
        };
        assert!(l.rolling.iter().chain(&l.fill).all(Learned::covered));
        assert!((l.rolling[0].z() - 1.5).abs() < 1e-12);
        let s = super::super::calibration_report::learned_section(&l);
        assert!(s.contains("**Yes:**"), "{s}");
        l.fill[0] = p("c", 0.25f64.exp());
        assert!(!l.fill[0].covered());
        let s = super::super::calibration_report::learned_section(&l);
        assert!(
            s.contains("**The rolling, yes;") && s.contains("c (+2.5 s.e.)"),
            "{s}"
        );
        l.rolling[1] = Learned::new("b", 1.0, 1.0, f64::NAN, None);
        let s = super::super::calibration_report::learned_section(&l);
        assert!(
            s.contains("**No:**") && s.contains("b (no standard error)"),
            "{s}"
        );
    }
}
