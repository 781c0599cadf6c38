//! The rotation profile of the boom paper's eq. (6): α̇ = ω, ω̇ = ε(α) with ε(α) a configurable
//! piecewise-linear table, integrated at a fixed step into a trajectory (t, α, ω, ε).
//!
//! The table is written in degrees (°, °/s²) as in the paper; the trajectory is in SI
//! (rad, rad/s, rad/s²). The final deceleration ε_d is either fixed or found by bisection so
//! that ω reaches 0 exactly when α reaches the final angle.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The angular acceleration at one breakpoint of the table.
///
/// # Example
/// ```
/// use wls::boom::{Breakpoint, Deceleration, Level, RotationProfile};
///
/// // Accelerate at 0.5 °/s² to 10°, then brake at ε_d, solved to stop at 20°.
/// let profile = RotationProfile {
///     breakpoints: vec![
///         Breakpoint { alpha_deg: 0.0, epsilon: Level::Value(0.5) },
///         Breakpoint { alpha_deg: 10.0, epsilon: Level::Value(0.5) },
///         Breakpoint { alpha_deg: 10.5, epsilon: Level::MinusDeceleration },
///     ],
///     final_angle_deg: 20.0,
///     dt: 0.01,
///     deceleration: Deceleration::Auto,
/// };
/// let tr = profile.trajectory()?;
/// assert!((tr.deceleration_deg_s2 - 0.5).abs() < 0.05); // symmetric turn: ε_d ≈ 0.5 °/s²
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Level {
    /// A fixed value in °/s².
    Value(f64),
    /// −ε_d, the final deceleration (fixed or solved for, see [`Deceleration`]).
    MinusDeceleration,
}

/// One breakpoint: ε(α) is linear between consecutive breakpoints, constant outside.
///
/// # Example
/// ```
/// use wls::boom::{Breakpoint, Level, RotationProfile};
///
/// let p = RotationProfile::default();
/// let Breakpoint { alpha_deg, epsilon } = p.breakpoints[0];
/// assert!(alpha_deg.abs() < 1e-15);
/// assert!(matches!(epsilon, Level::Value(e) if (e - 0.4584).abs() < 1e-15));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Breakpoint {
    /// α at the breakpoint, degrees.
    pub alpha_deg: f64,
    /// ε at the breakpoint.
    pub epsilon: Level,
}

/// How ε_d is chosen.
///
/// # Example
/// ```
/// use wls::boom::{Deceleration, RotationProfile};
///
/// // A fixed ε_d of 0.3 °/s² (the turn then stops wherever ω returns to 0).
/// let p = RotationProfile {
///     deceleration: Deceleration::Fixed(0.3),
///     ..RotationProfile::default()
/// };
/// assert!((p.trajectory()?.deceleration_deg_s2 - 0.3).abs() < 1e-15);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Deceleration {
    /// Solve for ε_d so that ω = 0 when α = `final_angle_deg` (bisection on the discrete
    /// integration, so the trajectory stops at the final angle to within one step).
    Auto,
    /// A fixed ε_d in °/s² (> 0).
    Fixed(f64),
}

/// The configurable rotation profile.
///
/// # Example
/// ```
/// use wls::boom::RotationProfile;
///
/// let p = RotationProfile::default(); // the paper's turn
/// // ε(α) in °/s²: 0.4584 below 9°, 0 between 12° and 77°.
/// assert!((p.epsilon_deg(5.0, 0.4) - 0.4584).abs() < 1e-12);
/// assert!(p.epsilon_deg(40.0, 0.4).abs() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RotationProfile {
    /// Breakpoints with strictly increasing α.
    pub breakpoints: Vec<Breakpoint>,
    /// The turn ends when α reaches this angle (degrees) or ω returns to 0.
    pub final_angle_deg: f64,
    /// Integration and sampling step, seconds.
    pub dt: f64,
    /// How ε_d is chosen.
    pub deceleration: Deceleration,
}

impl Default for RotationProfile {
    /// The paper's profile: 0.4584 °/s² to 9°, ramp to 0 over 9–12°, 0 over 12–77°, ramp to
    /// −ε_d over 77–80°, −ε_d to 90°; ε_d solved for; 0.01 s steps.
    fn default() -> Self {
        let v = |alpha_deg, e| Breakpoint {
            alpha_deg,
            epsilon: Level::Value(e),
        };
        let d = |alpha_deg| Breakpoint {
            alpha_deg,
            epsilon: Level::MinusDeceleration,
        };
        Self {
            breakpoints: vec![
                v(0.0, 0.4584),
                v(9.0, 0.4584),
                v(12.0, 0.0),
                v(77.0, 0.0),
                d(80.0),
                d(90.0),
            ],
            final_angle_deg: 90.0,
            dt: 0.01,
            deceleration: Deceleration::Auto,
        }
    }
}

/// One sample of the nominal turn (SI units).
///
/// # Example
/// ```
/// use wls::boom::RotationProfile;
///
/// let tr = RotationProfile::default().trajectory()?;
/// let last = tr.points.last().expect("a turn has samples");
/// assert!((last.alpha.to_degrees() - 90.0).abs() < 0.1); // stops at the vertical
/// assert!(last.omega.abs() < 1e-3);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrajectoryPoint {
    /// Time since the start of the turn, s.
    pub t: f64,
    /// Boom angle α, rad.
    pub alpha: f64,
    /// Angular rate ω, rad/s.
    pub omega: f64,
    /// Angular acceleration ε = ε(α), rad/s².
    pub epsilon: f64,
}

/// A generated trajectory and the deceleration used.
///
/// # Example
/// ```
/// use wls::boom::RotationProfile;
///
/// let tr = RotationProfile::default().trajectory()?;
/// // Sampled every dt = 0.01 s.
/// assert!((tr.points[1].t - tr.points[0].t - 0.01).abs() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// Samples at t = k·dt.
    pub points: Vec<TrajectoryPoint>,
    /// ε_d used, °/s².
    pub deceleration_deg_s2: f64,
}

/// Hard cap on integration steps (10⁷ steps of the default 0.01 s is over a day of turning).
const MAX_STEPS: usize = 10_000_000;

impl RotationProfile {
    fn validate(&self) -> Result<()> {
        if self.breakpoints.is_empty() {
            return Err(Error::Shape {
                name: "profile.breakpoints",
                rows: 0,
                cols: 1,
                expected: "at least one breakpoint".into(),
            });
        }
        for (i, b) in self.breakpoints.iter().enumerate() {
            let e = match b.epsilon {
                Level::Value(e) => e,
                Level::MinusDeceleration => 0.0,
            };
            for (value, col) in [(b.alpha_deg, 0), (e, 1)] {
                if !value.is_finite() {
                    return Err(Error::NonFinite {
                        name: "profile.breakpoints",
                        row: i,
                        col,
                        value,
                    });
                }
            }
            if i > 0 && b.alpha_deg <= self.breakpoints[i - 1].alpha_deg {
                return Err(Error::InvalidParameter {
                    name: "profile.breakpoints.alpha_deg",
                    value: b.alpha_deg,
                    rule: "breakpoint angles must increase strictly",
                });
            }
        }
        if !self.dt.is_finite() || self.dt <= 0.0 {
            return Err(Error::InvalidParameter {
                name: "profile.dt",
                value: self.dt,
                rule: "must be finite and > 0",
            });
        }
        if !self.final_angle_deg.is_finite() || self.final_angle_deg <= 0.0 {
            return Err(Error::InvalidParameter {
                name: "profile.final_angle_deg",
                value: self.final_angle_deg,
                rule: "must be finite and > 0",
            });
        }
        if let Deceleration::Fixed(d) = self.deceleration
            && (!d.is_finite() || d <= 0.0)
        {
            return Err(Error::InvalidParameter {
                name: "profile.deceleration",
                value: d,
                rule: "a fixed ε_d must be finite and > 0 (°/s²)",
            });
        }
        Ok(())
    }

    /// ε(α) in °/s² for a given ε_d (°/s²), α in degrees.
    #[must_use]
    pub fn epsilon_deg(&self, alpha_deg: f64, decel: f64) -> f64 {
        let level = |b: &Breakpoint| match b.epsilon {
            Level::Value(e) => e,
            Level::MinusDeceleration => -decel,
        };
        let bp = &self.breakpoints;
        let Some(first) = bp.first() else { return 0.0 };
        if alpha_deg <= first.alpha_deg {
            return level(first);
        }
        for w in bp.windows(2) {
            if alpha_deg <= w[1].alpha_deg {
                let f = (alpha_deg - w[0].alpha_deg) / (w[1].alpha_deg - w[0].alpha_deg);
                return level(&w[0]) + f * (level(&w[1]) - level(&w[0]));
            }
        }
        bp.last().map_or(0.0, level)
    }

    /// One RK4 step of (α, ω) in degrees.
    fn step(&self, alpha: f64, omega: f64, decel: f64) -> (f64, f64) {
        let h = self.dt;
        let f = |a: f64| self.epsilon_deg(a, decel);
        let (k1a, k1w) = (omega, f(alpha));
        let (k2a, k2w) = (omega + 0.5 * h * k1w, f(alpha + 0.5 * h * k1a));
        let (k3a, k3w) = (omega + 0.5 * h * k2w, f(alpha + 0.5 * h * k2a));
        let (k4a, k4w) = (omega + h * k3w, f(alpha + h * k3a));
        (
            alpha + h / 6.0 * (k1a + 2.0 * k2a + 2.0 * k3a + k4a),
            omega + h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
        )
    }

    /// Integrates from rest at α = first breakpoint; calls `visit(t, α, ω)` (degrees) for each
    /// sample, and returns whether α reached the final angle (`true`) or ω returned to 0 first
    /// (`false`).
    fn integrate(&self, decel: f64, mut visit: impl FnMut(f64, f64, f64)) -> Result<bool> {
        let mut alpha = self.breakpoints.first().map_or(0.0, |b| b.alpha_deg);
        let mut omega = 0.0;
        visit(0.0, alpha, omega);
        for k in 1..=MAX_STEPS {
            let (a, w) = self.step(alpha, omega, decel);
            if w <= 0.0 {
                return Ok(false);
            }
            if a >= self.final_angle_deg {
                return Ok(true);
            }
            alpha = a;
            omega = w;
            visit(k as f64 * self.dt, alpha, omega);
        }
        Err(Error::InvalidParameter {
            name: "profile",
            value: MAX_STEPS as f64,
            rule: "the turn did not end within the step cap (does ε(α) ever move the boom?)",
        })
    }

    /// Solves for ε_d (°/s²) so that ω = 0 at the final angle.
    ///
    /// # Errors
    /// An invalid table, or a table whose final angle cannot be reached (the bracket fails).
    pub fn solve_deceleration(&self) -> Result<f64> {
        self.validate()?;
        // Whether the boom reaches the final angle still moving: true for d too small, false
        // for d too large, switching once as d grows.
        let reaches = |d: f64| self.integrate(d, |_, _, _| {});
        let (mut lo, mut hi) = (0.0, 1.0);
        let mut grow = 0;
        while reaches(hi)? {
            lo = hi;
            hi *= 2.0;
            grow += 1;
            if grow > 60 {
                return Err(Error::InvalidParameter {
                    name: "profile",
                    value: hi,
                    rule: "no deceleration stops the boom at the final angle",
                });
            }
        }
        if !reaches(lo.max(1e-12))? {
            return Err(Error::InvalidParameter {
                name: "profile",
                value: lo,
                rule: "the boom stops before the final angle even without deceleration",
            });
        }
        // Bisection to the last representable digits (≈ 60 halvings of [0, 1]).
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if reaches(mid)? {
                lo = mid;
            } else {
                hi = mid;
            }
            // Stopping later (or, below ε_d = 1, a few halvings earlier) moves ε_d by about
            // 1e-15 relative, under the rounding of the thousands of steps each halving runs.
            if hi - lo <= 1e-15 * hi {
                break;
            }
        }
        Ok(0.5 * (lo + hi))
    }

    /// The nominal trajectory at t = k·dt until α reaches the final angle or ω returns to 0.
    ///
    /// # Errors
    /// An invalid table, or [`Deceleration::Auto`] failing (see [`Self::solve_deceleration`]).
    pub fn trajectory(&self) -> Result<Trajectory> {
        self.validate()?;
        let decel = match self.deceleration {
            Deceleration::Auto => self.solve_deceleration()?,
            Deceleration::Fixed(d) => d,
        };
        let mut points = Vec::new();
        let rad = core::f64::consts::PI / 180.0;
        // A fixed ε_d may stop the boom short of the final angle; the trajectory ends there.
        let _reached = self.integrate(decel, |t, a, w| {
            points.push(TrajectoryPoint {
                t,
                alpha: a * rad,
                omega: w * rad,
                epsilon: self.epsilon_deg(a, decel) * rad,
            });
        })?;
        Ok(Trajectory {
            points,
            deceleration_deg_s2: decel,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_profile_decelerates_about_0_419_and_ends_near_90() {
        let p = RotationProfile::default();
        let tr = p.trajectory().expect("default profile is valid");
        // Continuous-time energy balance gives ε_d = 9.626/23 ≈ 0.4185 °/s² (the paper: ≈ 0.419).
        assert!(
            (tr.deceleration_deg_s2 - 0.4185).abs() < 2e-3,
            "{}",
            tr.deceleration_deg_s2
        );
        let last = tr.points.last().expect("non-empty");
        let deg = last.alpha.to_degrees();
        // Within one step of motion at ≤ 0.05 °/s of residual rate.
        assert!(deg > 89.9 && deg < 90.0, "{deg}");
        assert!(last.omega.to_degrees() < 0.05);
        // Cruise at ≈ 0.054 rad/s ("about 0.05 rad/s"). The turn lasts ≈ 36 s: 6.3 s to 9°,
        // ≈ 1 s of ramp, 65° at 3.1 °/s, ≈ 1 s of ramp, 6.9 s braking at ε_d from 3.0 °/s. (The
        // paper's plots put α = 88° at 31 s; its unreadable ramps were evidently steeper.)
        let max_w = tr.points.iter().map(|q| q.omega).fold(0.0, f64::max);
        assert!((max_w - 0.0541).abs() < 1e-3, "{max_w}");
        assert!(last.t > 35.5 && last.t < 36.5, "{}", last.t);
    }

    #[test]
    fn invalid_tables_are_typed_errors() {
        let mut p = RotationProfile::default();
        p.breakpoints[2].alpha_deg = 5.0;
        assert!(matches!(
            p.trajectory(),
            Err(Error::InvalidParameter { .. })
        ));
        let p = RotationProfile {
            dt: f64::NAN,
            ..RotationProfile::default()
        };
        assert!(matches!(
            p.trajectory(),
            Err(Error::InvalidParameter { .. })
        ));
        let mut p = RotationProfile::default();
        p.breakpoints[0].alpha_deg = f64::NAN;
        assert!(matches!(p.trajectory(), Err(Error::NonFinite { .. })));
    }
}
