//! Sea-platform motion (Mazurenko's fuel-level paper): roll θ and pitch ψ as independent
//! irregular-rolling processes, and the tilt α = ψ·cos φ + θ·sin φ toward a sensor at angle φ.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::error::{Error, non_negative, positive};
use crate::process::{IrregularRollingConfig, IrregularRollingProcess, Process};

/// Platform attitude, rad.
///
/// # Example
/// ```
/// use sensors::Attitude;
///
/// let a = Attitude { roll: 0.02, pitch: 0.01 };
/// // Toward a sensor at φ = 90° only the roll is seen.
/// assert!((a.tilt_toward(std::f64::consts::FRAC_PI_2) - 0.02).abs() < 1e-15);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Attitude {
    /// Roll θ, rad.
    pub roll: f64,
    /// Pitch (trim) ψ, rad.
    pub pitch: f64,
}

impl Attitude {
    /// Tilt toward a sensor at angle `phi` (rad, from the stern direction in the tank
    /// cross-section): α = ψ·cos φ + θ·sin φ (the fuel-level paper's eq. 7), rad.
    #[inline]
    #[must_use]
    pub fn tilt_toward(&self, phi: f64) -> f64 {
        let (s, c) = phi.sin_cos();
        self.pitch * c + self.roll * s
    }
}

/// One rolling axis. Defaults: assumed values for the fuel-level paper (A_max = 1°, period 10 s,
/// μ = 0.08 s⁻¹).
///
/// # Example
/// ```
/// use sensors::RollingAxisConfig;
///
/// let axis = RollingAxisConfig { max_amplitude_deg: 3.0, ..RollingAxisConfig::default() };
/// let process = axis.to_process()?;
/// assert!((process.std_dev - 1f64.to_radians()).abs() < 1e-15); // σ = A_max/3
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RollingAxisConfig {
    /// Maximum amplitude A_max, degrees (≥ 0; default 1). The axis has σ = A_max/3 (the fuel-level
    /// paper's rule).
    pub max_amplitude_deg: f64,
    /// Dominant period 2π/β, s (default 10).
    pub period_s: f64,
    /// Irregularity μ, s⁻¹ (default 0.08).
    pub irregularity_per_s: f64,
}

impl Default for RollingAxisConfig {
    fn default() -> Self {
        Self {
            max_amplitude_deg: 1.0,
            period_s: 10.0,
            irregularity_per_s: 0.08,
        }
    }
}

impl RollingAxisConfig {
    /// The axis as an irregular-rolling process configuration in radians (σ = A_max/3).
    ///
    /// # Errors
    /// [`Error`] if the amplitude is negative or not finite.
    pub fn to_process(&self) -> Result<IrregularRollingConfig, Error> {
        let a = non_negative("max_amplitude_deg", self.max_amplitude_deg)?;
        Ok(IrregularRollingConfig {
            std_dev: a.to_radians() / 3.0,
            period_s: positive("period_s", self.period_s)?,
            irregularity_per_s: positive("irregularity_per_s", self.irregularity_per_s)?,
        })
    }
}

/// Configuration of the platform motion: one irregular-rolling process per axis.
///
/// # Example
/// ```
/// use sensors::{PlatformMotion, PlatformMotionConfig, RollingAxisConfig};
///
/// // Pitch twice as strong as roll.
/// let cfg = PlatformMotionConfig {
///     pitch: RollingAxisConfig { max_amplitude_deg: 2.0, ..RollingAxisConfig::default() },
///     ..PlatformMotionConfig::default()
/// };
/// let motion = PlatformMotion::new(&cfg, 0.1)?;
/// // Tilt variance toward φ = 0 is the pitch variance (2°/3)².
/// let sigma = 2f64.to_radians() / 3.0;
/// assert!((motion.tilt_correlation(0.0, 0.0) - sigma * sigma).abs() < 1e-15);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlatformMotionConfig {
    /// Roll θ.
    pub roll: RollingAxisConfig,
    /// Pitch ψ.
    pub pitch: RollingAxisConfig,
}

/// Roll and pitch of the platform, stepped every Δt. Each step draws roll then pitch (two
/// normals each) from the same generator; the two processes are independent.
///
/// # Example
/// ```
/// use sensors::{PlatformMotion, PlatformMotionConfig, seeded_rng};
///
/// let mut motion = PlatformMotion::new(&PlatformMotionConfig::default(), 0.1)?;
/// let mut rng = seeded_rng(5);
/// let tilts: Vec<f64> = (0..100).map(|_| motion.next(&mut rng).tilt_toward(0.5)).collect();
/// assert!(tilts.iter().all(|t| t.abs() < 5f64.to_radians()));
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct PlatformMotion {
    roll: IrregularRollingProcess,
    pitch: IrregularRollingProcess,
}

impl PlatformMotion {
    /// Builds the motion sampled every `dt` s.
    ///
    /// # Errors
    /// [`Error`] for an invalid axis configuration or Δt.
    pub fn new(config: &PlatformMotionConfig, dt: f64) -> Result<Self, Error> {
        Ok(Self {
            roll: IrregularRollingProcess::new(&config.roll.to_process()?, dt)?,
            pitch: IrregularRollingProcess::new(&config.pitch.to_process()?, dt)?,
        })
    }
    /// The attitude at the next sample.
    #[inline]
    pub fn next<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Attitude {
        let roll = self.roll.next(rng);
        let pitch = self.pitch.next(rng);
        Attitude { roll, pitch }
    }
    /// Angular rates (θ̇, ψ̇) at the last sample, rad/s.
    pub fn rates(&self) -> Attitude {
        Attitude {
            roll: self.roll.rate(),
            pitch: self.pitch.rate(),
        }
    }
    /// The roll process θ.
    pub fn roll(&self) -> &IrregularRollingProcess {
        &self.roll
    }
    /// The pitch process ψ.
    pub fn pitch(&self) -> &IrregularRollingProcess {
        &self.pitch
    }
    /// Theoretical correlation of the tilt toward angle `phi` (rad) at lag `tau` (s):
    /// cos²φ·R_ψ(τ) + sin²φ·R_θ(τ) (the axes are independent), rad².
    pub fn tilt_correlation(&self, phi: f64, tau: f64) -> f64 {
        let (s, c) = phi.sin_cos();
        c * c * self.pitch.correlation(tau) + s * s * self.roll.correlation(tau)
    }
    /// Forgets the state: the next sample is a fresh stationary draw.
    pub fn reset(&mut self) {
        self.roll.reset();
        self.pitch.reset();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn tilt_projects_pitch_and_roll() {
        let a = Attitude {
            roll: 0.2,
            pitch: 0.1,
        };
        assert_relative_eq!(a.tilt_toward(0.0), 0.1);
        assert_relative_eq!(
            a.tilt_toward(std::f64::consts::FRAC_PI_2),
            0.2,
            epsilon = 1e-15
        );
        let phi = 30f64.to_radians();
        assert_relative_eq!(a.tilt_toward(phi), 0.1 * phi.cos() + 0.2 * phi.sin());
    }

    #[test]
    fn sigma_is_a_third_of_the_amplitude_in_radians() {
        let m = PlatformMotion::new(&PlatformMotionConfig::default(), 0.1).expect("valid");
        assert_relative_eq!(m.roll().std_dev(), 1f64.to_radians() / 3.0);
        assert_relative_eq!(m.pitch().beta(), 2.0 * std::f64::consts::PI / 10.0);
    }
}
