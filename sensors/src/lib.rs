//! Truth-side random processes and sensor models for launch and flight-test simulation.
//!
//! These are the models a scenario's *world* is made of, written from the physics, not from
//! any filter's model (the three papers listed under [References](#references)). SI units inside;
//! angles are given in degrees only in configuration structs and converted once, at construction.
//!
//! # Notation
//! - Δt: fixed sampling interval of every stepped object, s, given at construction.
//! - σ, D = σ²: standard deviation and variance of a process; R(τ): its correlation
//!   (auto-covariance) function at lag τ, s.
//! - Platform (fuel-level paper): roll θ, pitch ψ, sensor angle φ, tilt α = ψ·cos φ + θ·sin φ;
//!   rolling irregularity μ and dominant frequency β (period 2π/β).
//! - Level sensor: step δ, damper time constant T_y, sensor radius R, tank level h.
//! - Boom (boom paper): angle α, rate ω, angular acceleration ε, radius r, offset angle γ, g.
//!
//! # Randomness
//! Every stochastic object takes `&mut R: rand::Rng`; the crate uses
//! [`rand_chacha::ChaCha8Rng`] seeded from a `u64` ([`seeded_rng`]) so a seed reproduces a run
//! bit for bit. Each step draws a fixed number of normals, independent of which noise options
//! are on. No step allocates.
//!
//! # Example
//! ```
//! use sensors::{
//!     Attitude, IrregularRollingProcess, IrregularRollingConfig, LevelSensor, LevelSensorConfig,
//!     PlatformMotion, PlatformMotionConfig, Process, seeded_rng,
//! };
//!
//! let dt = 0.1;
//! let mut rng = seeded_rng(42);
//! let mut platform = PlatformMotion::new(&PlatformMotionConfig::default(), dt)?;
//! let mut sensor = LevelSensor::new(&LevelSensorConfig::default(), dt)?;
//! let mut level = 1.0; // m
//! for _ in 0..100 {
//!     level += 0.010 * dt; // filling at 10 mm/s
//!     let attitude: Attitude = platform.next(&mut rng);
//!     let out = sensor.step(level, attitude, &mut rng);
//!     // A floor quantizer never reads above the damped level (no noise configured).
//!     assert!(out.reading <= out.damped + 1e-12);
//! }
//!
//! let rolling = IrregularRollingProcess::new(&IrregularRollingConfig::default(), dt)?;
//! assert!((rolling.variance() - 1.0).abs() < 1e-12);
//!
//! // nalgebra out and in: the boom accelerometer's reading is a `Vector3<f64>`, and the
//! // mounting check takes one (a_z must stay near 0).
//! use sensors::nalgebra::Vector3;
//! use sensors::{Accelerometer, AccelerometerConfig, BoomMotion};
//! let accel = Accelerometer::new(&AccelerometerConfig::default())?;
//! let reading: Vector3<f64> = accel.measure(BoomMotion::default(), &mut rng);
//! accel.check_mounting(&reading)?;
//! assert!(accel.check_mounting(&Vector3::new(0.0, 9.8, 5.0)).is_err());
//! # Ok::<(), sensors::Error>(())
//! ```
//!
//! # References
//! - V. B. Mazurenko, *Using information on the platform tilt angles when processing
//!   liquid-fuel level measurements with a discrete Kalman filter* (in Russian): platform
//!   rolling, the level sensor, the fill-velocity and quantization-noise processes.
//! - Yu. V. Gridnev, A. Yu. Rusetsky, S. A. Rak, *Stochastic simulation of the automatic
//!   control systems of an unmanned aerial vehicle with an optimal Kalman filter* (in
//!   Russian, 2013): the UAV channel sensors.
//! - P. P. Zavyalov, A. A. Shatov, *Determination of the angular acceleration of rotary
//!   elements of rocket complexes in ground tests* (in Russian): the boom accelerometer.
//!
//! # Versions of the types in this API
//! Generators and the `Rng` bound come from [`rand`] 0.10 and [`rand_chacha`] 0.10
//! ([`ChaCha8Rng`]); vectors are [`nalgebra`] 0.35 types. All three are re-exported
//! ([`sensors::rand`](rand), [`sensors::rand_chacha`](rand_chacha),
//! [`sensors::nalgebra`](nalgebra)), so `use sensors::rand::SeedableRng` always matches the
//! generator this crate accepts, whatever version of `rand` the rest of a project uses.
#![deny(missing_docs)]

mod accel;
mod error;
pub mod flight;
mod gyro;
mod lag;
mod level;
mod platform;
mod process;
mod uav;

pub use accel::{Accelerometer, AccelerometerConfig, BiasVariant, BoomMotion, validate_motion};
pub use error::Error;
pub use gyro::{Gyro, GyroConfig};
pub use lag::{FirstOrderLag, LagInput, Quantizer, Rounding};
pub use level::{LevelReading, LevelSensor, LevelSensorConfig};
pub use platform::{Attitude, PlatformMotion, PlatformMotionConfig, RollingAxisConfig};
pub use process::{
    DampedCosineConfig, DampedCosineProcess, ExpCorrelated, ExpCorrelatedConfig,
    IrregularRollingConfig, IrregularRollingProcess, Process, Seeded, WhiteNoise, seeded_rng,
};
pub use uav::{ChannelSensor, ChannelSensorConfig, Quantity};

/// The generator type the crate uses everywhere.
pub use rand_chacha::ChaCha8Rng;

/// Re-export of the linear-algebra crate whose vector types appear in this API.
pub use nalgebra;
/// Re-export of the `rand` version whose `Rng` trait this crate's `step`/`next` methods accept.
pub use rand;
/// Re-export of the `rand_chacha` version of [`ChaCha8Rng`].
pub use rand_chacha;

/// The README's examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
