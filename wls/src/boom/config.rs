//! The boom estimator's options: the inversion method, the weights of the least-squares
//! rows, the angle recovery and the solver, gathered in [`BoomConfig`], and the per-cycle
//! [`Estimate`] it returns.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::solver::check_finite_scalars;

/// Which inversion the estimator uses.
///
/// # Example
/// ```
/// use wls::boom::{BoomConfig, BoomEstimator, BoomMethod};
///
/// // Direct inversion has no answer once a_x exceeds g (here by a +0.02 m/s² error at 90°).
/// let cfg = BoomConfig { method: BoomMethod::Direct, ..BoomConfig::default() };
/// let mut est = BoomEstimator::new(cfg)?;
/// let out = est.update(9.8 + 0.02, 0.0, 0.0)?;
/// assert!(!out.defined && out.angle.is_nan());
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum BoomMethod {
    /// Eqs. (2)–(3): α = arcsin(a_x/g), ε = (a_y − √(g² − a_x²))/r; undefined when g² < a_x².
    Direct,
    /// Eq. (7): the square system in (s, c, ε) with the row s₀·s + c₀·c = 1.
    Linear3,
    /// Eqs. (9)–(10): (7) plus the previous cycle's (s₀, c₀, ε₀) as weighted measurements.
    #[default]
    Wls,
}

/// The unit an angular quantity is carried in inside the WLS state or weight law.
///
/// # Example
/// ```
/// use wls::boom::AngleUnit;
///
/// assert!((AngleUnit::Degree.per_radian() - 180.0 / std::f64::consts::PI).abs() < 1e-12);
/// assert!((AngleUnit::Radian.per_radian() - 1.0).abs() < 1e-15);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AngleUnit {
    /// Radians.
    Radian,
    /// Degrees (factor 180/π).
    Degree,
}

impl AngleUnit {
    /// Multiplier from radians to this unit.
    #[must_use]
    pub fn per_radian(self) -> f64 {
        match self {
            Self::Radian => 1.0,
            Self::Degree => 180.0 / core::f64::consts::PI,
        }
    }
}

/// How the a_x weight v₁ depends on the previous angle.
///
/// # Example
/// ```
/// use wls::boom::{AxWeightLaw, BoomConfig, BoomEstimator, WlsWeights};
///
/// // A constant a_x weight instead of the paper's cos α₀ law.
/// let weights = WlsWeights { ax_law: AxWeightLaw::Constant, ..WlsWeights::default() };
/// let _est = BoomEstimator::new(BoomConfig { weights, ..BoomConfig::default() })?;
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AxWeightLaw {
    /// v₁ = scale·|cos β₀| (the paper: a_x is the bad row near 90°).
    CosPrevious,
    /// v₁ = scale.
    Constant,
}

/// When the ε₀ weight v₆ = numerator/(1 + gain·|ε̇|)² is evaluated.
///
/// # Example
/// ```
/// use wls::boom::{BoomConfig, BoomEstimator, RateWeight};
///
/// // One solve per cycle, v₆ from the two previous cycles.
/// let cfg = BoomConfig { rate_weight: RateWeight::PreviousCycle, ..BoomConfig::default() };
/// let mut est = BoomEstimator::new(cfg)?;
/// est.update(0.0, 9.8, 0.0)?; // start-up cycle
/// assert_eq!(est.update(0.0, 9.8, 0.0)?.iterations, 1);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum RateWeight {
    /// ε̇ from the two previous cycles, (ε₀ − ε₋₁)/dt: one solve per cycle.
    PreviousCycle,
    /// ε̇ = (ε − ε₀)/dt with ε from this cycle's own solution: v₆ is made self-consistent
    /// (a stable fixed point of v₆ ↦ ε ↦ ε̇ ↦ v₆). Found by Newton safeguarded by bisection,
    /// started from the one-solve answer with the previous cycle's ε̇, until the ε step is at
    /// most `tolerance` (rad/s²) or `max_iterations` evaluations were made. Where the weight
    /// law admits several fixed points (rare; seen on noisy data) the one this search reaches
    /// is taken; plain iteration v₆ ← v₆(ε(v₆)) may settle on a neighbouring one.
    FixedPoint {
        /// Maximum fixed-point iterations per cycle (≥ 1).
        max_iterations: u32,
        /// Convergence tolerance on ε, rad/s² (> 0).
        tolerance: f64,
    },
}

/// How the angle is recovered from the solved (s, c) in Linear3 and WLS.
///
/// # Example
/// ```
/// use wls::boom::{AngleRecovery, BoomConfig, BoomEstimator};
///
/// let cfg = BoomConfig { angle_recovery: AngleRecovery::Atan2, ..BoomConfig::default() };
/// let mut est = BoomEstimator::new(cfg)?;
/// let a = 60f64.to_radians();
/// for _ in 0..3 {
///     let out = est.update(9.8 * a.sin(), 9.8 * a.cos(), 0.0)?;
///     assert!(out.defined && (out.angle - a).abs() < 1e-9);
/// }
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum AngleRecovery {
    /// β = arcsin s, the paper's; undefined when |s| > 1.
    #[default]
    Arcsin,
    /// β = atan2(s, c): always defined, and insensitive to errors in s near 90°.
    Atan2,
}

/// Which factorisation solves the 6×3 WLS system.
///
/// # Example
/// ```
/// use wls::boom::{BoomConfig, BoomEstimator, BoomSolver};
///
/// // The paper's normal equations (10) instead of QR: the same answer on a well-posed cycle.
/// let a = 45f64.to_radians();
/// let mut answers = Vec::new();
/// for solver in [BoomSolver::Qr, BoomSolver::NormalEquations] {
///     let mut est = BoomEstimator::new(BoomConfig { solver, ..BoomConfig::default() })?;
///     est.update(9.8 * a.sin(), 9.8 * a.cos(), 0.0)?;
///     answers.push(est.update(9.8 * a.sin(), 9.8 * a.cos(), 0.0)?.angle);
/// }
/// assert!((answers[0] - answers[1]).abs() < 1e-9);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum BoomSolver {
    /// Householder QR of V^{1/2}H.
    #[default]
    Qr,
    /// Cholesky of HᵀVH, the paper's (10).
    NormalEquations,
}

/// The WLS weights of eq. (8); defaults are the paper's.
///
/// # Example
/// ```
/// use wls::boom::{BoomConfig, BoomEstimator, WlsWeights};
///
/// // Trust the unit-circle row ten times more than the paper does.
/// let weights = WlsWeights { unit_circle: 1000.0, ..WlsWeights::default() };
/// let _est = BoomEstimator::new(BoomConfig { weights, ..BoomConfig::default() })?;
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WlsWeights {
    /// Scale of v₁ (a_x); default 1.
    pub ax_scale: f64,
    /// Law of v₁; default [`AxWeightLaw::CosPrevious`].
    pub ax_law: AxWeightLaw,
    /// v₂ (a_y); default 1.
    pub ay: f64,
    /// v₃ (the row s₀·s + c₀·c = 1); default 100.
    pub unit_circle: f64,
    /// v₄ (prior s₀); default 1.
    pub sin_prior: f64,
    /// v₅ (prior c₀); default 1.
    pub cos_prior: f64,
    /// Numerator of v₆; default 0.5.
    pub eps_prior: f64,
    /// Gain on |ε̇| in v₆; default 2.
    pub eps_rate_gain: f64,
}

impl Default for WlsWeights {
    fn default() -> Self {
        Self {
            ax_scale: 1.0,
            ax_law: AxWeightLaw::CosPrevious,
            ay: 1.0,
            unit_circle: 100.0,
            sin_prior: 1.0,
            cos_prior: 1.0,
            eps_prior: 0.5,
            eps_rate_gain: 2.0,
        }
    }
}

/// The estimator's configuration. Angles in radians, accelerations in m/s², SI throughout
/// except where a field says otherwise.
///
/// # Example
/// ```
/// use wls::boom::{BoomConfig, BoomEstimator};
///
/// // The sensor mounted 10° lower along the arc.
/// let cfg = BoomConfig { sensor_offset_angle: 10f64.to_radians(), ..BoomConfig::default() };
/// cfg.validate()?;
/// let bad = BoomConfig { dt: -0.01, ..BoomConfig::default() };
/// assert!(BoomEstimator::new(bad).is_err());
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoomConfig {
    /// Gravity g, m/s²; default 9.8 (the paper's).
    pub g: f64,
    /// Sensor distance r from the pivot, m; default 25.
    pub sensor_radius: f64,
    /// Cycle length dt, s; default 0.01.
    pub dt: f64,
    /// Sensor offset angle γ, rad (sensor mounted γ lower along the arc); default 0.
    pub sensor_offset_angle: f64,
    /// Inversion method; default WLS.
    pub method: BoomMethod,
    /// WLS weights; default the paper's (8).
    pub weights: WlsWeights,
    /// Unit of ε inside the WLS state (so H₂₃ = r / per_radian and the ε₀ row is in this
    /// unit); default degrees, which reproduces the paper (see the crate docs).
    pub epsilon_unit: AngleUnit,
    /// Unit of ε̇ inside v₆; default degrees (°/s³), which reproduces the paper.
    pub epsilon_rate_unit: AngleUnit,
    /// When v₆ is evaluated; default a fixed point within the cycle (≤ 100 iterations, 1e-10 rad/s² ≈ 6e-9 °/s²).
    pub rate_weight: RateWeight,
    /// Factorisation of the WLS system; default QR.
    pub solver: BoomSolver,
    /// Angle recovery from (s, c) for Linear3 and WLS; default arcsin (the paper's).
    pub angle_recovery: AngleRecovery,
    /// The mounting check passes while |a_z| ≤ this, m/s²; default 0.1 (5·Δa).
    pub mounting_tolerance: f64,
    /// Compute the condition number each cycle (a 3×3 SVD); default true.
    pub compute_condition: bool,
}

impl Default for BoomConfig {
    fn default() -> Self {
        Self {
            g: 9.8,
            sensor_radius: 25.0,
            dt: 0.01,
            sensor_offset_angle: 0.0,
            method: BoomMethod::Wls,
            weights: WlsWeights::default(),
            epsilon_unit: AngleUnit::Degree,
            epsilon_rate_unit: AngleUnit::Degree,
            rate_weight: RateWeight::FixedPoint {
                max_iterations: 100,
                tolerance: 1e-10,
            },
            solver: BoomSolver::Qr,
            angle_recovery: AngleRecovery::Arcsin,
            mounting_tolerance: 0.1,
            compute_condition: true,
        }
    }
}

impl BoomConfig {
    /// Checks every field.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] / [`Error::NegativeWeight`] / [`Error::NonFinite`] naming
    /// the field and the rule broken.
    pub fn validate(&self) -> Result<()> {
        let positive = |name, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(Error::InvalidParameter {
                    name,
                    value,
                    rule: "must be finite and > 0",
                })
            }
        };
        positive("g", self.g)?;
        positive("sensor_radius", self.sensor_radius)?;
        positive("dt", self.dt)?;
        check_finite_scalars(&[("sensor_offset_angle", self.sensor_offset_angle)])?;
        if !self.mounting_tolerance.is_finite() || self.mounting_tolerance < 0.0 {
            return Err(Error::InvalidParameter {
                name: "mounting_tolerance",
                value: self.mounting_tolerance,
                rule: "must be finite and ≥ 0",
            });
        }
        let w = &self.weights;
        let list = [
            w.ax_scale,
            w.ay,
            w.unit_circle,
            w.sin_prior,
            w.cos_prior,
            w.eps_prior,
            w.eps_rate_gain,
        ];
        for (index, &value) in list.iter().enumerate() {
            if !value.is_finite() {
                return Err(Error::NonFinite {
                    name: "weights",
                    row: index,
                    col: 0,
                    value,
                });
            }
            if value < 0.0 {
                return Err(Error::NegativeWeight {
                    name: "weights",
                    index,
                    value,
                });
            }
        }
        if let RateWeight::FixedPoint {
            max_iterations,
            tolerance,
        } = self.rate_weight
        {
            if max_iterations == 0 {
                return Err(Error::InvalidParameter {
                    name: "rate_weight.max_iterations",
                    value: 0.0,
                    rule: "must be ≥ 1",
                });
            }
            positive("rate_weight.tolerance", tolerance)?;
        }
        Ok(())
    }
}

/// One cycle's output. Angles in radians, ε in rad/s².
///
/// # Example
/// ```
/// use wls::boom::{BoomConfig, BoomEstimator};
///
/// let mut est = BoomEstimator::new(BoomConfig::default())?;
/// let first = est.update(0.0, 9.8, 0.0)?;
/// assert!(first.startup && first.mounting_ok);
/// let next = est.update(0.0, 9.8, 0.0)?;
/// assert!(!next.startup && next.condition_number.is_finite());
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Boom angle α = β + γ, rad (NaN when not `defined`).
    pub angle: f64,
    /// Angular acceleration ε, rad/s² (NaN when not `defined`).
    pub angular_acceleration: f64,
    /// κ₂ of the system solved this cycle: the 3×3 H of (7) for Direct (at the estimated
    /// angle) and Linear3, V^{1/2}H of (9) for WLS (from its triangular factor; equal to
    /// κ₂(V^{1/2}H) in exact arithmetic). ∞ if singular, NaN if not computed.
    pub condition_number: f64,
    /// False when the method has no answer: g² < a_x² (Direct), a singular 3×3 or |s| > 1
    /// (Linear3, WLS).
    pub defined: bool,
    /// |a_z| ≤ `mounting_tolerance`.
    pub mounting_ok: bool,
    /// s = sin β of the sensor frame as solved (may leave [−1, 1] when not `defined`).
    pub sin_sensor: f64,
    /// c = cos β as solved.
    pub cos_sensor: f64,
    /// v₆ evaluations (fixed-point iterations) made this cycle; 1 with
    /// [`RateWeight::PreviousCycle`], 0 for Direct, Linear3 and the start-up cycle.
    pub iterations: u32,
    /// True on the start-up cycle, which uses direct inversion whatever the method.
    pub startup: bool,
}
