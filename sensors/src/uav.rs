//! UAV control-channel sensors (Gridnev, Rusetsky and Rak's UAV paper): angular-rate sensor, linear
//! accelerometer and control-surface potentiometer, each with bandwidth, bias, white noise,
//! quantization and range.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, finite, non_negative, positive};
use crate::lag::{FirstOrderLag, LagInput, Quantizer, Rounding};
use crate::process::normal;

/// What a channel sensor measures; fixes the units of its configuration.
///
/// # Example
/// ```
/// use sensors::{ChannelSensor, ChannelSensorConfig, Quantity};
///
/// let s = ChannelSensor::new(&ChannelSensorConfig::potentiometer(), 0.01)?;
/// assert_eq!(s.quantity(), Quantity::SurfaceDeflection); // configured in degrees, reads rad
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Quantity {
    /// Angular rate: configured in deg/s, output in rad/s.
    #[default]
    AngularRate,
    /// Linear acceleration: configured and output in m/s².
    LinearAcceleration,
    /// Control-surface deflection (potentiometer): configured in degrees, output in rad.
    SurfaceDeflection,
}

impl Quantity {
    /// Factor from configuration units to SI.
    fn to_si(self) -> f64 {
        match self {
            Self::AngularRate | Self::SurfaceDeflection => std::f64::consts::PI / 180.0,
            Self::LinearAcceleration => 1.0,
        }
    }
}

/// Channel-sensor configuration, in the units of its [`Quantity`] (deg/s, m/s² or deg).
/// Defaults ([`ChannelSensorConfig::default`] = an angular-rate sensor) are assumed typical
/// values, not the paper's (it gives none); see also the per-kind constructors.
///
/// # Example
/// ```
/// use sensors::{ChannelSensor, ChannelSensorConfig, seeded_rng};
///
/// // An ideal accelerometer with a 0.1 m/s² bias and no noise, bandwidth or range limit.
/// let cfg = ChannelSensorConfig {
///     bandwidth_hz: None,
///     bias: 0.1,
///     noise_std: 0.0,
///     quantization_step: 0.0,
///     range: None,
///     ..ChannelSensorConfig::linear_accelerometer()
/// };
/// let mut s = ChannelSensor::new(&cfg, 0.01)?;
/// assert!((s.step(2.0, &mut seeded_rng(0)) - 2.1).abs() < 1e-12);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChannelSensorConfig {
    /// What is measured.
    pub quantity: Quantity,
    /// −3 dB bandwidth f_c of the first-order response, Hz (> 0), or `None` for an ideal
    /// response.
    pub bandwidth_hz: Option<f64>,
    /// Constant bias, configuration units.
    pub bias: f64,
    /// White-noise standard deviation, configuration units (≥ 0).
    pub noise_std: f64,
    /// Quantization step (rounds to nearest), configuration units (≥ 0, 0 = none).
    pub quantization_step: f64,
    /// Output range ±range, configuration units (> 0), or `None` for no saturation.
    pub range: Option<f64>,
}

impl Default for ChannelSensorConfig {
    fn default() -> Self {
        Self::angular_rate()
    }
}

impl ChannelSensorConfig {
    /// A MEMS-class rate sensor: 50 Hz, noise 0.1 °/s, bias 0, step 0.01 °/s, ±300 °/s.
    #[must_use]
    pub fn angular_rate() -> Self {
        Self {
            quantity: Quantity::AngularRate,
            bandwidth_hz: Some(50.0),
            bias: 0.0,
            noise_std: 0.1,
            quantization_step: 0.01,
            range: Some(300.0),
        }
    }
    /// A linear accelerometer: 100 Hz, noise 0.02 m/s², bias 0, step 0.001 m/s², ±50 m/s².
    #[must_use]
    pub fn linear_accelerometer() -> Self {
        Self {
            quantity: Quantity::LinearAcceleration,
            bandwidth_hz: Some(100.0),
            bias: 0.0,
            noise_std: 0.02,
            quantization_step: 0.001,
            range: Some(50.0),
        }
    }
    /// A control-surface potentiometer: 20 Hz, noise 0.05°, bias 0, step 0.1°, ±30°.
    #[must_use]
    pub fn potentiometer() -> Self {
        Self {
            quantity: Quantity::SurfaceDeflection,
            bandwidth_hz: Some(20.0),
            bias: 0.0,
            noise_std: 0.05,
            quantization_step: 0.1,
            range: Some(30.0),
        }
    }
}

/// A channel sensor stepped every Δt: truth → first-order lag 1/(T s + 1), T = 1/(2π f_c)
/// (exact, piecewise-linear input; starts in equilibrium) → + bias → + white noise →
/// quantization (nearest) → saturation. Output in SI (rad/s, m/s², rad). One normal is drawn
/// per step whether or not noise is enabled.
///
/// # Example
/// ```
/// use sensors::{ChannelSensor, ChannelSensorConfig, seeded_rng};
///
/// let mut gyro = ChannelSensor::new(&ChannelSensorConfig::angular_rate(), 0.01)?;
/// let mut rng = seeded_rng(2);
/// let readings: Vec<f64> = (0..100).map(|_| gyro.step(0.1, &mut rng)).collect();
/// assert!(readings.iter().all(|r| r.is_finite()));
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct ChannelSensor {
    quantity: Quantity,
    lag: FirstOrderLag,
    bias: f64,
    noise_std: f64,
    quantizer: Quantizer,
    range: f64,
}

impl ChannelSensor {
    /// Builds the sensor stepped every `dt` s.
    ///
    /// # Errors
    /// [`Error`] naming the field: bandwidth, range or Δt not positive; noise or step
    /// negative; any value not finite.
    pub fn new(config: &ChannelSensorConfig, dt: f64) -> Result<Self, Error> {
        let k = config.quantity.to_si();
        let time = match config.bandwidth_hz {
            Some(f) => 1.0 / (2.0 * std::f64::consts::PI * positive("bandwidth_hz", f)?),
            None => 0.0,
        };
        let range = match config.range {
            Some(r) => positive("range", r)? * k,
            None => f64::INFINITY,
        };
        Ok(Self {
            quantity: config.quantity,
            lag: FirstOrderLag::new(time, dt, LagInput::PiecewiseLinear)?,
            bias: finite("bias", config.bias)? * k,
            noise_std: non_negative("noise_std", config.noise_std)? * k,
            quantizer: Quantizer::new(
                "quantization_step",
                non_negative("quantization_step", config.quantization_step)? * k,
                Rounding::Nearest,
                0.0,
            )?,
            range,
        })
    }
    /// What the sensor measures.
    pub fn quantity(&self) -> Quantity {
        self.quantity
    }
    /// Advances one step with the true value (SI); returns the measurement (SI).
    #[inline]
    pub fn step<R: Rng + ?Sized>(&mut self, truth: f64, rng: &mut R) -> f64 {
        let w = normal(rng);
        let y = self.lag.step(truth) + self.bias + self.noise_std * w;
        self.quantizer.quantize(y).clamp(-self.range, self.range)
    }
    /// Forgets the lag's state.
    pub fn reset(&mut self) {
        self.lag.reset();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::process::seeded_rng;
    use approx::assert_relative_eq;

    #[test]
    fn potentiometer_converts_degrees_and_saturates() {
        let cfg = ChannelSensorConfig {
            bandwidth_hz: None,
            noise_std: 0.0,
            ..ChannelSensorConfig::potentiometer()
        };
        let mut s = ChannelSensor::new(&cfg, 0.01).expect("valid");
        let mut rng = seeded_rng(0);
        assert_relative_eq!(
            s.step(10.04f64.to_radians(), &mut rng),
            10.0f64.to_radians(),
            epsilon = 1e-12
        );
        assert_relative_eq!(s.step(1.0, &mut rng), 30f64.to_radians(), epsilon = 1e-12);
    }
}
