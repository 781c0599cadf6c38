//! The ship's gyro instrument (Mazurenko's fuel-level paper): reports pitch ψ and roll θ with
//! noise, constant bias and resolution, sampled at its own rate and held between samples.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, finite, non_negative, positive};
use crate::lag::{Quantizer, Rounding};
use crate::platform::Attitude;
use crate::process::normal;

/// Gyro configuration (angles in degrees here, radians inside). Defaults: an ideal instrument
/// sampling every 0.1 s (the paper's tilt channel is noise-free).
///
/// # Example
/// ```
/// use sensors::{Gyro, GyroConfig};
///
/// // A gyro sampling at 1 Hz with 0.05° noise and a 0.1° roll bias.
/// let cfg = GyroConfig {
///     sample_period_s: 1.0,
///     noise_std_deg: 0.05,
///     roll_bias_deg: 0.1,
///     ..GyroConfig::default()
/// };
/// let _gyro = Gyro::new(&cfg, 0.1)?;
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GyroConfig {
    /// Interval between the instrument's samples, s (> 0; default 0.1). A period shorter than
    /// the simulation step samples at every step.
    pub sample_period_s: f64,
    /// Standard deviation of the white noise on each sample, degrees (≥ 0; default 0).
    pub noise_std_deg: f64,
    /// Constant bias on roll θ, degrees (default 0).
    pub roll_bias_deg: f64,
    /// Constant bias on pitch ψ, degrees (default 0).
    pub pitch_bias_deg: f64,
    /// Output resolution, degrees (≥ 0, 0 = continuous; rounds to nearest; default 0).
    pub resolution_deg: f64,
}

impl Default for GyroConfig {
    fn default() -> Self {
        Self {
            sample_period_s: 0.1,
            noise_std_deg: 0.0,
            roll_bias_deg: 0.0,
            pitch_bias_deg: 0.0,
            resolution_deg: 0.0,
        }
    }
}

/// Gyro instrument stepped on the simulation grid Δt. At simulation time t_k = k·Δt (k counted
/// from the first call) it takes a new sample when t_k has reached the next multiple of its
/// sample period, and otherwise holds the last one (sample-and-hold). Sample = truth + bias +
/// noise, then rounded to the resolution. Two normals are drawn every step (held or not), so
/// the random stream does not depend on the sample period.
///
/// # Example
/// ```
/// use sensors::{Attitude, Gyro, GyroConfig, seeded_rng};
///
/// let cfg = GyroConfig { pitch_bias_deg: 0.5, ..GyroConfig::default() };
/// let mut gyro = Gyro::new(&cfg, 0.1)?;
/// let mut rng = seeded_rng(3);
/// let seen = gyro.step(Attitude { roll: 0.01, pitch: 0.0 }, &mut rng);
/// assert!((seen.roll - 0.01).abs() < 1e-15);
/// assert!((seen.pitch - 0.5f64.to_radians()).abs() < 1e-15);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Gyro {
    dt: f64,
    period: f64,
    noise_std: f64,
    bias: Attitude,
    quantizer: Quantizer,
    step_index: u64,
    next_sample: f64,
    held: Attitude,
}

impl Gyro {
    /// Builds the instrument for simulation step `dt` s.
    ///
    /// # Errors
    /// [`Error`] naming the field for a non-positive period or Δt, a negative noise or
    /// resolution, or a non-finite value.
    pub fn new(config: &GyroConfig, dt: f64) -> Result<Self, Error> {
        Ok(Self {
            dt: positive("dt_s", dt)?,
            period: positive("sample_period_s", config.sample_period_s)?,
            noise_std: non_negative("noise_std_deg", config.noise_std_deg)?.to_radians(),
            bias: Attitude {
                roll: finite("roll_bias_deg", config.roll_bias_deg)?.to_radians(),
                pitch: finite("pitch_bias_deg", config.pitch_bias_deg)?.to_radians(),
            },
            quantizer: Quantizer::new(
                "resolution_deg",
                non_negative("resolution_deg", config.resolution_deg)?.to_radians(),
                Rounding::Nearest,
                0.0,
            )?,
            step_index: 0,
            next_sample: 0.0,
            held: Attitude::default(),
        })
    }
    /// Advances one simulation step with the true attitude; returns the instrument output, rad.
    #[inline]
    pub fn step<R: Rng + ?Sized>(&mut self, truth: Attitude, rng: &mut R) -> Attitude {
        let n_roll = normal(rng);
        let n_pitch = normal(rng);
        // Exact for up to 2^53 steps.
        #[allow(clippy::cast_precision_loss)]
        let t = self.step_index as f64 * self.dt;
        self.step_index += 1;
        // A relative slack of 1e-9 step absorbs rounding in k·Δt vs n·T.
        if t + 1e-9 * self.dt >= self.next_sample {
            self.held = Attitude {
                roll: self
                    .quantizer
                    .quantize(truth.roll + self.bias.roll + self.noise_std * n_roll),
                pitch: self
                    .quantizer
                    .quantize(truth.pitch + self.bias.pitch + self.noise_std * n_pitch),
            };
            let n = ((t + 1e-9 * self.dt) / self.period).floor() + 1.0;
            self.next_sample = n * self.period;
        }
        self.held
    }
    /// Restarts the clock: the next step samples.
    pub fn reset(&mut self) {
        self.step_index = 0;
        self.next_sample = 0.0;
        self.held = Attitude::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::process::seeded_rng;
    use approx::assert_relative_eq;

    #[test]
    fn samples_and_holds_at_its_own_rate() {
        let cfg = GyroConfig {
            sample_period_s: 0.3,
            ..GyroConfig::default()
        };
        let mut g = Gyro::new(&cfg, 0.1).expect("valid");
        let mut rng = seeded_rng(0);
        let out: Vec<f64> = (0..7)
            .map(|k| {
                let truth = Attitude {
                    roll: f64::from(k),
                    pitch: 0.0,
                };
                g.step(truth, &mut rng).roll
            })
            .collect();
        let want = [0.0, 0.0, 0.0, 3.0, 3.0, 3.0, 6.0];
        for (o, w) in out.iter().zip(want) {
            assert_relative_eq!(*o, w);
        }
    }

    #[test]
    fn bias_and_resolution_apply() {
        let cfg = GyroConfig {
            roll_bias_deg: 0.5,
            resolution_deg: 0.2,
            ..GyroConfig::default()
        };
        let mut g = Gyro::new(&cfg, 0.1).expect("valid");
        let mut rng = seeded_rng(0);
        let out = g.step(
            Attitude {
                roll: 0.33f64.to_radians(),
                pitch: 0.0,
            },
            &mut rng,
        );
        // 0.33° + 0.5° = 0.83° rounds to 0.8°.
        assert_relative_eq!(out.roll, 0.8f64.to_radians(), epsilon = 1e-12);
        assert_relative_eq!(out.pitch, 0.0);
    }
}
