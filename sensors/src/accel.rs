//! Three-axis accelerometer on a turning erector boom (Zavyalov and Shatov's boom paper): gravity
//! projection at the sensor's position on the arc, tangential ε·r, optional centripetal ω²·r,
//! misalignment, constant ±Δa bias, noise, range saturation and the a_z mounting check.

use std::f64::consts::FRAC_PI_2;

use nalgebra::{Rotation3, Vector3};
use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, finite, in_range, non_negative, positive};
use crate::process::normal;

/// The constant-error variants of the boom paper (a bias of +Δa or −Δa on every axis).
///
/// # Example
/// ```
/// use sensors::{Accelerometer, AccelerometerConfig, BiasVariant, BoomMotion};
///
/// let cfg = AccelerometerConfig { bias: BiasVariant::Plus, ..AccelerometerConfig::default() };
/// let reading = Accelerometer::new(&cfg)?.clean(BoomMotion::default());
/// // Level boom at rest: a_x = 0 and a_y = g, each shifted by +Δa = 0.02 m/s².
/// assert!((reading.x - 0.02).abs() < 1e-12 && (reading.y - 9.82).abs() < 1e-12);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum BiasVariant {
    /// No bias.
    #[default]
    None,
    /// Variant "+": +Δa on a_x and a_y.
    Plus,
    /// Variant "−": −Δa on a_x and a_y.
    Minus,
}

/// Accelerometer configuration (the offset angle in radians, as the estimator takes it; the
/// misalignment in degrees). Defaults: the boom paper's
/// sensor (r = 25 m, range 10 m/s², Δa = 0.02 m/s², g = 9.8 m/s²), ideally mounted at γ = 0,
/// no bias, no noise, centripetal term off (as in the paper).
///
/// # Example
/// ```
/// use sensors::{Accelerometer, AccelerometerConfig};
///
/// // Mounted 10° lower along the arc, with 0.005 m/s² noise on every axis.
/// let cfg = AccelerometerConfig {
///     sensor_offset_angle: 10f64.to_radians(),
///     noise_std_mps2: 0.005,
///     ..AccelerometerConfig::default()
/// };
/// let sensor = Accelerometer::new(&cfg)?;
/// assert_eq!(sensor.sensor_offset_angle(), 10f64.to_radians());
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AccelerometerConfig {
    /// Distance r from the boom pivot, m (> 0; default 25).
    pub sensor_radius_m: f64,
    /// Offset angle γ along the arc (sensor mounted lower by γ), rad, in [−π/2, π/2]
    /// (default 0).
    pub sensor_offset_angle: f64,
    /// Misalignment of the sensor axes, degrees: rotations about the ideal x (radial), y
    /// (tangential) and z (pivot axis) axes, applied as R = R_z·R_y·R_x (default zeros).
    pub misalignment_deg: [f64; 3],
    /// Gravity g, m/s² (> 0; default 9.8 as in the boom paper).
    pub gravity_mps2: f64,
    /// Include the centripetal term −ω²·r on the radial axis (default false, as the paper).
    pub centripetal: bool,
    /// Constant-error variant (default none).
    pub bias: BiasVariant,
    /// Limiting error Δa used by the bias variants, m/s² (≥ 0; default 0.02).
    pub limiting_error_mps2: f64,
    /// White-noise standard deviation on each axis, m/s² (≥ 0; default 0).
    pub noise_std_mps2: f64,
    /// Measurement range: each axis saturates at ±range, m/s² (> 0; default 10).
    pub range_mps2: f64,
    /// Mounting check tolerance on |a_z|, m/s² (> 0; default 0.1 ≈ g·sin 0.6°, 5σ of a
    /// 0.02 m/s² noise).
    pub mounting_tolerance_mps2: f64,
}

impl Default for AccelerometerConfig {
    fn default() -> Self {
        Self {
            sensor_radius_m: 25.0,
            sensor_offset_angle: 0.0,
            misalignment_deg: [0.0; 3],
            gravity_mps2: 9.8,
            centripetal: false,
            bias: BiasVariant::None,
            limiting_error_mps2: 0.02,
            noise_std_mps2: 0.0,
            range_mps2: 10.0,
            mounting_tolerance_mps2: 0.1,
        }
    }
}

/// Boom kinematics at one instant.
///
/// # Example
/// ```
/// use sensors::{Accelerometer, AccelerometerConfig, BoomMotion};
///
/// let sensor = Accelerometer::new(&AccelerometerConfig::default())?;
/// let motion = BoomMotion { angle: 30f64.to_radians(), rate: 0.0, acceleration: 0.01 };
/// let f = sensor.clean(motion);
/// // a_x = g sin α, a_y = g cos α + ε r (r = 25 m).
/// assert!((f.x - 9.8 * 0.5).abs() < 1e-12);
/// assert!((f.y - (9.8 * 30f64.to_radians().cos() + 0.25)).abs() < 1e-12);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct BoomMotion {
    /// Boom angle α from the horizontal, rad.
    pub angle: f64,
    /// Angular rate ω = α̇, rad/s.
    pub rate: f64,
    /// Angular acceleration ε = ω̇, rad/s².
    pub acceleration: f64,
}

/// Three-axis accelerometer on the boom.
///
/// Geometry (vertical plane of the turn, pivot at the origin, X horizontal, Z up): the sensor
/// sits at radius r and angular position α − γ (mounted lower along the arc by γ). Its ideal
/// axes are x = radial, pointing away from the pivot, y = tangential, in the direction of
/// increasing α, z = x × y, along the pivot axis. An accelerometer measures the specific
/// force f = a − g⃗ with g⃗ = (0, −g) and a = ε·r·e_t − ω²·r·e_r (rigid rotation), hence
///
///   a_x = g·sin(α − γ) − ω²·r   (the centripetal term, optional, lowers the radial reading)
///   a_y = g·cos(α − γ) + ε·r
///   a_z = 0
///
/// which is the boom paper's equation (1) with the offset angle. The reading is R_misᵀ·f (the
/// sensor axes are the ideal ones rotated by R_mis), plus the bias, plus noise, each axis clipped
/// to ±range. Three normals are drawn per measurement whether or not noise is enabled.
///
/// # Example
/// ```
/// use sensors::{Accelerometer, AccelerometerConfig, BoomMotion, seeded_rng};
///
/// let cfg = AccelerometerConfig { noise_std_mps2: 0.01, ..AccelerometerConfig::default() };
/// let sensor = Accelerometer::new(&cfg)?;
/// let mut rng = seeded_rng(1);
/// let reading = sensor.measure(BoomMotion::default(), &mut rng);
/// assert!((reading.y - 9.8).abs() < 0.1); // within 10σ of g
/// sensor.check_mounting(&reading)?; // a_z stays near 0
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Accelerometer {
    radius: f64,
    gamma: f64,
    g: f64,
    centripetal: bool,
    /// R_misᵀ: maps the ideal frame to the sensor frame.
    to_sensor: Rotation3<f64>,
    bias: Vector3<f64>,
    noise_std: f64,
    range: f64,
    tolerance: f64,
}

impl Accelerometer {
    /// Builds the sensor.
    ///
    /// # Errors
    /// [`Error`] naming the field: r, g, range or tolerance not positive; γ outside
    /// [−π/2, π/2]; Δa or noise negative; misalignment outside [−180°, 180°]; any NaN.
    pub fn new(config: &AccelerometerConfig) -> Result<Self, Error> {
        let [mx, my, mz] = config.misalignment_deg;
        let mx = in_range("misalignment_deg[0]", mx, -180.0, 180.0)?.to_radians();
        let my = in_range("misalignment_deg[1]", my, -180.0, 180.0)?.to_radians();
        let mz = in_range("misalignment_deg[2]", mz, -180.0, 180.0)?.to_radians();
        let da = non_negative("limiting_error_mps2", config.limiting_error_mps2)?;
        let b = match config.bias {
            BiasVariant::None => 0.0,
            BiasVariant::Plus => da,
            BiasVariant::Minus => -da,
        };
        Ok(Self {
            radius: positive("sensor_radius_m", config.sensor_radius_m)?,
            gamma: in_range(
                "sensor_offset_angle",
                config.sensor_offset_angle,
                -FRAC_PI_2,
                FRAC_PI_2,
            )?,
            g: positive("gravity_mps2", config.gravity_mps2)?,
            centripetal: config.centripetal,
            to_sensor: Rotation3::from_euler_angles(mx, my, mz).inverse(),
            bias: Vector3::new(b, b, 0.0),
            noise_std: non_negative("noise_std_mps2", config.noise_std_mps2)?,
            range: positive("range_mps2", config.range_mps2)?,
            tolerance: positive("mounting_tolerance_mps2", config.mounting_tolerance_mps2)?,
        })
    }
    /// Offset angle γ, rad.
    pub fn sensor_offset_angle(&self) -> f64 {
        self.gamma
    }
    /// Radius r, m.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// Gravity g, m/s².
    pub fn gravity(&self) -> f64 {
        self.g
    }
    /// Specific force in the ideal sensor frame (x radial, y tangential, z pivot axis), m/s².
    #[inline]
    pub fn specific_force(&self, motion: BoomMotion) -> Vector3<f64> {
        let (s, c) = (motion.angle - self.gamma).sin_cos();
        let centripetal = if self.centripetal {
            motion.rate * motion.rate * self.radius
        } else {
            0.0
        };
        Vector3::new(
            self.g * s - centripetal,
            self.g * c + motion.acceleration * self.radius,
            0.0,
        )
    }
    /// Noise-free output before saturation: R_misᵀ·f + bias, m/s².
    #[inline]
    pub fn clean(&self, motion: BoomMotion) -> Vector3<f64> {
        self.to_sensor * self.specific_force(motion) + self.bias
    }
    /// One measurement: clean output + noise, each axis clipped to ±range, m/s².
    #[inline]
    pub fn measure<R: Rng + ?Sized>(&self, motion: BoomMotion, rng: &mut R) -> Vector3<f64> {
        let n = Vector3::new(normal(rng), normal(rng), normal(rng));
        let r = self.range;
        (self.clean(motion) + self.noise_std * n).map(|v| v.clamp(-r, r))
    }
    /// The boom paper's mounting check: |a_z| must stay within the tolerance. Run it at rest
    /// (or average several readings first when noise is on).
    ///
    /// # Errors
    /// [`Error::MountingCheck`] with the offending a_z; also when a_z is NaN.
    pub fn check_mounting(&self, reading: &Vector3<f64>) -> Result<(), Error> {
        let a_z = reading.z;
        if a_z.abs() <= self.tolerance {
            Ok(())
        } else {
            Err(Error::MountingCheck {
                a_z,
                tolerance: self.tolerance,
            })
        }
    }
}

/// Checks a motion sample supplied by a caller: all fields finite.
///
/// # Errors
/// [`Error::NotFinite`] naming the field.
///
/// # Example
/// ```
/// use sensors::{BoomMotion, Error, validate_motion};
///
/// assert!(validate_motion(&BoomMotion::default()).is_ok());
/// let bad = BoomMotion { angle: f64::NAN, ..BoomMotion::default() };
/// assert!(matches!(validate_motion(&bad), Err(Error::NotFinite { name: "angle", .. })));
/// ```
pub fn validate_motion(motion: &BoomMotion) -> Result<(), Error> {
    finite("angle", motion.angle)?;
    finite("rate", motion.rate)?;
    finite("acceleration", motion.acceleration)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn level_boom_at_rest_reads_g_on_y() {
        let a = Accelerometer::new(&AccelerometerConfig::default()).expect("valid");
        let f = a.clean(BoomMotion::default());
        assert_relative_eq!(f.x, 0.0);
        assert_relative_eq!(f.y, 9.8);
        assert_relative_eq!(f.z, 0.0);
        assert!(a.check_mounting(&f).is_ok());
    }

    #[test]
    fn yaw_misalignment_mixes_x_and_y_only() {
        let cfg = AccelerometerConfig {
            misalignment_deg: [0.0, 0.0, 90.0],
            ..AccelerometerConfig::default()
        };
        let a = Accelerometer::new(&cfg).expect("valid");
        // Sensor x is the ideal y: at rest, level, it reads g on x.
        let f = a.clean(BoomMotion::default());
        assert_relative_eq!(f.x, 9.8, epsilon = 1e-12);
        assert_relative_eq!(f.y, 0.0, epsilon = 1e-12);
    }
}
