//! Parameters of the flightpath scenario: the simulated flight (`sensors::flight`), the
//! filter's priors and gate, and the Monte Carlo size; overridable by a `--config` TOML
//! file (`[flight]`, `[flight.errors]`, … tables).

use std::path::Path;

use sensors::flight::FlightConfig;
use serde::{Deserialize, Serialize};

use crate::campaign::ScenarioParams;
use crate::error::{Error, Result};

/// Every parameter of the scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlightPathParams {
    /// The simulated flight (truth, sensors, record defects).
    pub flight: FlightConfig,
    /// Monte Carlo runs when `--runs` is not given (30).
    pub runs: usize,
    /// Prior standard deviations of the instrument errors, in the units of
    /// `flight.errors` (accelerometer m/s², gyro deg/s, scale factors, V m/s, angles deg).
    pub error_prior: PriorErrors,
    /// Prior standard deviations of the kinematic states: velocity m/s, attitude deg,
    /// position m ((5, 2, 10)).
    pub kinematic_prior: [f64; 3],
    /// Probability of the χ²(1) gate on each measurement's innovation (0.9999).
    pub gate_probability: f64,
    /// Consecutive rejections of a channel after which its next sample is accepted (3).
    pub gate_reset: usize,
    /// Iteration cap of the output-error fit (30).
    pub output_error_iterations: usize,
}

/// Prior standard deviations of the instrument errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PriorErrors {
    /// Accelerometer biases, m/s² (0.2).
    pub accel_bias_mps2: f64,
    /// Gyro biases, deg/s (1).
    pub gyro_bias_dps: f64,
    /// Scale factors (0.2).
    pub scale: f64,
    /// Airspeed bias, m/s (2).
    pub airspeed_bias_mps: f64,
    /// Flow-angle biases, deg (2).
    pub angle_bias_deg: f64,
}

impl Default for PriorErrors {
    fn default() -> Self {
        Self {
            accel_bias_mps2: 0.2,
            gyro_bias_dps: 1.0,
            scale: 0.2,
            airspeed_bias_mps: 2.0,
            angle_bias_deg: 2.0,
        }
    }
}

impl Default for FlightPathParams {
    fn default() -> Self {
        Self {
            flight: FlightConfig::default(),
            runs: 30,
            error_prior: PriorErrors::default(),
            kinematic_prior: [5.0, 2.0, 10.0],
            gate_probability: 0.9999,
            gate_reset: 3,
            output_error_iterations: 30,
        }
    }
}

impl ScenarioParams for FlightPathParams {
    fn set_runs(&mut self, runs: usize) {
        self.runs = runs;
    }

    /// Checks every value, naming the key of the first bad one (the flight's own values are
    /// checked by the simulation, naming theirs).
    ///
    /// # Errors
    /// [`Error::Invalid`] for `path`, naming the key and the rule.
    fn validate(&self, path: &Path) -> Result<()> {
        let bad = |key: &str, value: f64, rule: &str| {
            Err(Error::invalid(path, format!("`{key}` = {value}: {rule}")))
        };
        let p = &self.error_prior;
        for (key, value) in [
            ("error_prior.accel_bias_mps2", p.accel_bias_mps2),
            ("error_prior.gyro_bias_dps", p.gyro_bias_dps),
            ("error_prior.scale", p.scale),
            ("error_prior.airspeed_bias_mps", p.airspeed_bias_mps),
            ("error_prior.angle_bias_deg", p.angle_bias_deg),
            ("kinematic_prior[0]", self.kinematic_prior[0]),
            ("kinematic_prior[1]", self.kinematic_prior[1]),
            ("kinematic_prior[2]", self.kinematic_prior[2]),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return bad(key, value, "must be finite and > 0");
            }
        }
        if !(self.gate_probability > 0.5 && self.gate_probability < 1.0) {
            return bad(
                "gate_probability",
                self.gate_probability,
                "must lie in (0.5, 1)",
            );
        }
        if self.runs == 0 || self.runs > 100_000 {
            return bad("runs", self.runs as f64, "must lie in [1, 100000]");
        }
        if self.gate_reset == 0 {
            return bad("gate_reset", 0.0, "must be ≥ 1");
        }
        if self.output_error_iterations == 0 {
            return bad("output_error_iterations", 0.0, "must be ≥ 1");
        }
        if !(self.flight.duration_s >= 10.0 && self.flight.duration_s <= 3600.0) {
            return bad(
                "flight.duration_s",
                self.flight.duration_s,
                "must lie in [10, 3600] s",
            );
        }
        Ok(())
    }
}

impl FlightPathParams {
    /// The prior standard deviations of the 12 instrument errors, SI, in state order.
    pub fn error_prior_si(&self) -> [f64; 12] {
        let d2r = std::f64::consts::PI / 180.0;
        let p = &self.error_prior;
        let (a, g, s) = (p.accel_bias_mps2, p.gyro_bias_dps * d2r, p.scale);
        let b = p.angle_bias_deg * d2r;
        [a, a, a, g, g, g, s, p.airspeed_bias_mps, s, b, s, b]
    }

    /// The prior standard deviations of the 9 kinematic states, SI.
    pub fn kinematic_prior_si(&self) -> [f64; 9] {
        let [v, e, p] = self.kinematic_prior;
        let e = e.to_radians();
        [v, v, v, e, e, e, p, p, p]
    }

    /// The gate's threshold: the χ²(1) quantile of `gate_probability`.
    pub fn gate_threshold(&self) -> f64 {
        kalman::chi2_quantile(self.gate_probability, 1)
    }
}
