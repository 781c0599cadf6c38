//! The discrete fuel-level sensor of Mazurenko's paper: tilt at the mounting point, hydro-damper
//! lag, point-sensor quantization, optional threshold noise, mid-step compensation and dead time.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, finite, non_negative, positive};
use crate::lag::{DelayLine, FirstOrderLag, LagInput, Quantizer, Rounding, samples_in};
use crate::platform::Attitude;
use crate::process::normal;

/// Level-sensor configuration. Defaults are assumed values for the fuel-level paper
/// (δ = 10 mm, T_y = 2 s, R = 1.5 m, φ = 30°), with no compensation, noise or dead time.
///
/// # Example
/// ```
/// use sensors::{LevelSensor, LevelSensorConfig};
///
/// // A 5 mm sensor with mid-step compensation and no hydro-damper.
/// let cfg = LevelSensorConfig {
///     step_m: 0.005,
///     damper_time_constant_s: 0.0,
///     mid_step_compensation: true,
///     ..LevelSensorConfig::default()
/// };
/// let sensor = LevelSensor::new(&cfg, 0.1)?;
/// assert!((sensor.step_size() - 0.005).abs() < 1e-15);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LevelSensorConfig {
    /// Quantization step δ of the point sensor, m (> 0; default 0.01).
    pub step_m: f64,
    /// Hydro-damper time constant T_y, s (≥ 0, 0 = no damper; default 2).
    pub damper_time_constant_s: f64,
    /// How the damper's input is integrated between samples (default piecewise-linear).
    pub damper_input: LagInput,
    /// Distance R of the sensor from the tank axis, m (≥ 0; default 1.5).
    pub sensor_radius_m: f64,
    /// Angle φ from the stern direction to the sensor, degrees (default 30).
    pub sensor_angle_deg: f64,
    /// Add δ/2 to every reading so the quantization error is centred (default false).
    pub mid_step_compensation: bool,
    /// Standard deviation of the switching-threshold noise added to the damped level before
    /// quantization, m (≥ 0; default 0).
    pub noise_std_m: f64,
    /// Transport delay of the reading, s (≥ 0; rounded to whole samples; default 0).
    pub dead_time_s: f64,
}

impl Default for LevelSensorConfig {
    fn default() -> Self {
        Self {
            step_m: 0.01,
            damper_time_constant_s: 2.0,
            damper_input: LagInput::PiecewiseLinear,
            sensor_radius_m: 1.5,
            sensor_angle_deg: 30.0,
            mid_step_compensation: false,
            noise_std_m: 0.0,
            dead_time_s: 0.0,
        }
    }
}

/// The signals of one level-sensor step, m.
///
/// # Example
/// ```
/// use sensors::{Attitude, LevelSensor, LevelSensorConfig, seeded_rng};
///
/// let mut sensor = LevelSensor::new(&LevelSensorConfig::default(), 0.1)?;
/// let out = sensor.step(1.234, Attitude::default(), &mut seeded_rng(0));
/// // Level platform: the sensor sees the level itself; the damper starts in equilibrium.
/// assert!((out.at_sensor - 1.234).abs() < 1e-15 && (out.damped - 1.234).abs() < 1e-15);
/// assert!((out.reading - 1.23).abs() < 1e-12); // floor to the 10 mm step
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelReading {
    /// Liquid level at the sensor's position, h + R·tan α.
    pub at_sensor: f64,
    /// Level inside the hydro-damper sleeve (the lag's output).
    pub damped: f64,
    /// The sensor output: δ·⌊(damped + noise)/δ⌋ (+ δ/2 if compensated), delayed.
    pub reading: f64,
}

/// Point level sensor in a hydro-damper sleeve on a tilting tank (Mazurenko's fuel-level paper).
///
/// Each step: level at the sensor h + R·tan α with α = ψ·cos φ + θ·sin φ; damper
/// 1/(T_y s + 1) integrated exactly ([`FirstOrderLag`]; it starts in equilibrium with the first
/// input); threshold noise; floor quantization (mean error −δ/2, or 0 with mid-step
/// compensation); dead time. One normal is drawn per step whether or not noise is enabled.
///
/// # Example
/// ```
/// use sensors::{Attitude, LevelSensor, LevelSensorConfig, seeded_rng};
///
/// let mut sensor = LevelSensor::new(&LevelSensorConfig::default(), 0.1)?;
/// let tilt = Attitude { roll: 0.0, pitch: 0.01 };
/// // h + R·tan α with α = ψ cos φ (R = 1.5 m, φ = 30°).
/// let expected = 2.0 + 1.5 * (0.01 * 30f64.to_radians().cos()).tan();
/// assert!((sensor.level_at_sensor(2.0, tilt) - expected).abs() < 1e-15);
/// let out = sensor.step(2.0, tilt, &mut seeded_rng(0));
/// assert!(out.reading <= out.damped);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct LevelSensor {
    radius: f64,
    phi: f64,
    /// (sin φ, cos φ), precomputed.
    sin_cos_phi: (f64, f64),
    noise_std: f64,
    step: f64,
    damper: FirstOrderLag,
    quantizer: Quantizer,
    delay: DelayLine,
}

impl LevelSensor {
    /// Builds the sensor stepped every `dt` s.
    ///
    /// # Errors
    /// [`Error`] naming the field: δ or Δt not positive; T_y, R, noise or dead time negative;
    /// any value not finite.
    pub fn new(config: &LevelSensorConfig, dt: f64) -> Result<Self, Error> {
        let step = positive("step_m", config.step_m)?;
        let dt = positive("dt_s", dt)?;
        let offset = if config.mid_step_compensation {
            0.5 * step
        } else {
            0.0
        };
        let phi = finite("sensor_angle_deg", config.sensor_angle_deg)?.to_radians();
        Ok(Self {
            radius: non_negative("sensor_radius_m", config.sensor_radius_m)?,
            phi,
            sin_cos_phi: phi.sin_cos(),
            noise_std: non_negative("noise_std_m", config.noise_std_m)?,
            step,
            damper: FirstOrderLag::new(
                non_negative("damper_time_constant_s", config.damper_time_constant_s)?,
                dt,
                config.damper_input,
            )?,
            quantizer: Quantizer::new("step_m", step, Rounding::Floor, offset)?,
            delay: DelayLine::new(samples_in("dead_time_s", config.dead_time_s, dt)?),
        })
    }
    /// Sensor angle φ, rad.
    pub fn sensor_angle(&self) -> f64 {
        self.phi
    }
    /// Sensor radius R, m.
    pub fn sensor_radius(&self) -> f64 {
        self.radius
    }
    /// Quantization step δ, m.
    pub fn step_size(&self) -> f64 {
        self.step
    }
    /// Level at the sensor for tank level `level_m` and platform `attitude`: h + R·tan α, m.
    #[inline]
    pub fn level_at_sensor(&self, level_m: f64, attitude: Attitude) -> f64 {
        let (s, c) = self.sin_cos_phi;
        level_m + self.radius * (attitude.pitch * c + attitude.roll * s).tan()
    }
    /// Advances one step with the true tank level `level_m` (on the axis) and the platform
    /// attitude at this sample.
    #[inline]
    pub fn step<R: Rng + ?Sized>(
        &mut self,
        level_m: f64,
        attitude: Attitude,
        rng: &mut R,
    ) -> LevelReading {
        let at_sensor = self.level_at_sensor(level_m, attitude);
        let damped = self.damper.step(at_sensor);
        let noisy = damped + self.noise_std * normal(rng);
        let reading = self.delay.push(self.quantizer.quantize(noisy));
        LevelReading {
            at_sensor,
            damped,
            reading,
        }
    }
    /// Forgets the state (damper, dead-time line).
    pub fn reset(&mut self) {
        self.damper.reset();
        self.delay.reset();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::process::seeded_rng;
    use approx::assert_relative_eq;

    #[test]
    fn level_at_sensor_uses_tan_of_tilt() {
        let s = LevelSensor::new(&LevelSensorConfig::default(), 0.1).expect("valid");
        let att = Attitude {
            roll: 0.01,
            pitch: 0.02,
        };
        let phi = 30f64.to_radians();
        let alpha = 0.02 * phi.cos() + 0.01 * phi.sin();
        assert_relative_eq!(s.level_at_sensor(3.0, att), 3.0 + 1.5 * alpha.tan());
    }

    #[test]
    fn dead_time_delays_the_reading() {
        let cfg = LevelSensorConfig {
            damper_time_constant_s: 0.0,
            dead_time_s: 0.3,
            ..LevelSensorConfig::default()
        };
        let mut s = LevelSensor::new(&cfg, 0.1).expect("valid");
        let mut rng = seeded_rng(0);
        let levels = [0.105, 0.215, 0.325, 0.435, 0.545, 0.655];
        let out: Vec<f64> = levels
            .iter()
            .map(|&h| s.step(h, Attitude::default(), &mut rng).reading)
            .collect();
        // Three samples of delay; before that the first reading is held.
        let want = [0.10, 0.10, 0.10, 0.10, 0.21, 0.32];
        for (o, w) in out.iter().zip(want) {
            assert_relative_eq!(*o, w, epsilon = 1e-12);
        }
    }
}
