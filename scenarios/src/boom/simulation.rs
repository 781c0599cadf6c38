//! The boom scenario's world and turns: the accelerometer of eq. (1) from `sensors`
//! (cached per γ and error variant, one random stream for the noise) as the measurement
//! model `wls::boom::run_turn` and `sweep_gamma` call, and the per-turn statistics.

use rand_chacha::ChaCha8Rng;
use wls::boom::{ErrorVariant, Sign, TrajectoryPoint, TurnRun};

use super::parameters::BoomParams;
use crate::error::{Error, Result};

/// The accelerometer of the scenario's world: a `sensors::Accelerometer` per (γ, variant),
/// cached, with one random stream for the noise.
pub(super) struct Meter {
    base: sensors::AccelerometerConfig,
    rng: ChaCha8Rng,
    cache: Option<(u64, ErrorVariant, sensors::Accelerometer)>,
}

impl Meter {
    pub(super) fn new(
        p: &BoomParams,
        centripetal: bool,
        noise_std_mps2: f64,
        rng: ChaCha8Rng,
    ) -> Self {
        Self {
            base: sensors::AccelerometerConfig {
                sensor_radius_m: p.sensor_radius_m,
                gravity_mps2: p.gravity_mps2,
                centripetal,
                limiting_error_mps2: p.limiting_error_mps2,
                noise_std_mps2,
                range_mps2: p.range_mps2,
                ..sensors::AccelerometerConfig::default()
            },
            rng,
            cache: None,
        }
    }

    /// Checks that the sensor accepts the configuration at every γ used.
    pub(super) fn check(&self, gammas_deg: &[f64]) -> Result<()> {
        for &g in gammas_deg {
            sensors::Accelerometer::new(&sensors::AccelerometerConfig {
                sensor_offset_angle_deg: g,
                ..self.base
            })
            .map_err(|source| Error::Sensors {
                context: "boom accelerometer",
                source,
            })?;
        }
        Ok(())
    }

    /// The reading at a trajectory point for the sensor mounted γ (rad) lower, under the
    /// variant's constant error: its sign selects the sensor's bias variant and its size is
    /// the sensor's Δa. A configuration the sensor rejects reads NaN, which the estimator
    /// rejects by name (never reached after [`Meter::check`]).
    pub(super) fn read(&mut self, p: &TrajectoryPoint, gamma: f64, v: &ErrorVariant) -> [f64; 3] {
        let fresh = !matches!(&self.cache, Some((k, c, _)) if *k == gamma.to_bits() && c == v);
        if fresh {
            let cfg = sensors::AccelerometerConfig {
                sensor_offset_angle_deg: gamma.to_degrees(),
                bias: match v.sign {
                    Sign::Plus => sensors::BiasVariant::Plus,
                    Sign::Minus => sensors::BiasVariant::Minus,
                    Sign::Nominal => sensors::BiasVariant::None,
                },
                limiting_error_mps2: v.size,
                ..self.base
            };
            self.cache = sensors::Accelerometer::new(&cfg)
                .ok()
                .map(|a| (gamma.to_bits(), *v, a));
        }
        let Some((_, _, sensor)) = self.cache.as_ref() else {
            return [f64::NAN; 3];
        };
        let motion = sensors::BoomMotion {
            angle: p.alpha,
            rate: p.omega,
            acceleration: p.epsilon,
        };
        let m = sensor.measure(motion, &mut self.rng);
        [m.x, m.y, m.z]
    }
}

/// Maxima over the defined cycles after start-up, and the first undefined / violating α.
pub(super) struct TurnStats {
    pub(super) max_alpha_deg: f64,
    pub(super) max_eps_deg: f64,
    pub(super) undefined_from_deg: Option<f64>,
    pub(super) violation: Option<(f64, f64)>,
}

pub(super) fn stats(run: &TurnRun) -> TurnStats {
    let mut s = TurnStats {
        max_alpha_deg: 0.0,
        max_eps_deg: 0.0,
        undefined_from_deg: run.first_undefined.map(|(_, a)| a.to_degrees()),
        violation: run.first_violation.map(|(t, a)| (t, a.to_degrees())),
    };
    for c in run.cycles.iter().skip(1).filter(|c| c.defined) {
        s.max_alpha_deg = s.max_alpha_deg.max(c.angle_error.to_degrees());
        s.max_eps_deg = s.max_eps_deg.max(c.epsilon_error.to_degrees());
    }
    s
}

pub(super) fn wls_err(context: &'static str) -> impl Fn(wls::Error) -> Error {
    move |source| Error::Wls { context, source }
}
