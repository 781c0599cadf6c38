//! Parameters of the uav scenario: SPEC U's defaults, overridable by a `--config` TOML file,
//! and their validation.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::campaign::ScenarioParams;
use crate::error::{Error, Result};

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

impl ScenarioParams for UavParams {
    fn set_runs(&mut self, runs: usize) {
        self.runs = runs;
    }

    /// Checks every value, naming the key of the first bad one.
    ///
    /// # Errors
    /// [`Error::Invalid`] for `path`, naming the key and the rule.
    fn validate(&self, path: &Path) -> Result<()> {
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
}
