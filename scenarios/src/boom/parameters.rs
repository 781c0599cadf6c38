//! Parameters of the boom scenario: SPEC B's defaults (sensor, limits, rotation profile, WLS
//! options, γ sweep, beyond-the-paper cases), overridable by a `--config` TOML file, their
//! validation, and the `wls` configurations they define.

use std::path::Path;

use kalman::nonlinear::SigmaPoints;
use serde::{Deserialize, Serialize};
use wls::boom::{
    AngleRecovery, AngleUnit, AxWeightLaw, BoomConfig, BoomMethod, Deceleration, ErrorVariant,
    Level, Limits, RateWeight, RotationProfile,
};

use crate::campaign::ScenarioParams;
use crate::error::{Error, Result};

/// The estimators, serialised by the names the summary uses: the paper's three and the
/// nonlinear filters of the tracking formulation (beyond the paper).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Direct inversion, eqs. (2)–(3).
    Direct,
    /// The linearised 3×3 solve, eq. (7).
    Linear3,
    /// Weighted least squares, eqs. (9)–(10).
    Wls,
    /// Extended Kalman filter on the white-jerk model (module `tracking`).
    Ekf,
    /// Unscented Kalman filter on the white-jerk model.
    Ukf,
    /// Unscented Rauch–Tung–Striebel smoother over the UKF's forward pass.
    Urts,
}

impl Method {
    /// The `wls` crate's method; `None` for the Kalman filters and the smoother.
    pub fn to_wls(self) -> Option<BoomMethod> {
        match self {
            Method::Direct => Some(BoomMethod::Direct),
            Method::Linear3 => Some(BoomMethod::Linear3),
            Method::Wls => Some(BoomMethod::Wls),
            Method::Ekf | Method::Ukf | Method::Urts => None,
        }
    }

    /// The name in file names and tables (the serialised name).
    pub fn name(self) -> &'static str {
        match self {
            Method::Direct => "direct",
            Method::Linear3 => "linear3",
            Method::Wls => "wls",
            Method::Ekf => "ekf",
            Method::Ukf => "ukf",
            Method::Urts => "urts",
        }
    }
}

/// Allowed errors (SPEC B: Δα = 1°, Δε = 0.5 °/s²).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LimitParams {
    /// Δα, degrees (> 0).
    pub alpha_deg: f64,
    /// Δε, °/s² (> 0).
    pub eps_deg_s2: f64,
}

impl Default for LimitParams {
    fn default() -> Self {
        Self {
            alpha_deg: 1.0,
            eps_deg_s2: 0.5,
        }
    }
}

/// The γ sweep: `from_deg` to `to_deg` in steps of `step_deg`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SweepParams {
    /// First γ, degrees (≥ 0).
    pub from_deg: f64,
    /// Last γ, degrees (> `from_deg`, ≤ 45).
    pub to_deg: f64,
    /// Step, degrees (> 0, at most 1000 points).
    pub step_deg: f64,
}

impl Default for SweepParams {
    fn default() -> Self {
        Self {
            from_deg: 0.0,
            to_deg: 20.0,
            step_deg: 0.5,
        }
    }
}

/// One breakpoint of the ε(α) table of SPEC B eq. (6).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BreakpointParams {
    /// α, degrees (strictly increasing along the table).
    pub alpha_deg: f64,
    /// ε, °/s²; omitted means −ε_d, the final deceleration.
    #[serde(default)]
    pub epsilon_deg_s2: Option<f64>,
}

/// The rotation profile (SPEC B eq. 6) as a configurable table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProfileParams {
    /// Breakpoints; ε is linear between them.
    pub breakpoints: Vec<BreakpointParams>,
    /// The turn ends at this angle, degrees.
    pub final_angle_deg: f64,
    /// ε_d in °/s²; omitted = solved so that ω reaches 0 at the final angle (≈ 0.419).
    pub deceleration_deg_s2: Option<f64>,
}

impl Default for ProfileParams {
    fn default() -> Self {
        let p = RotationProfile::default();
        Self {
            breakpoints: p
                .breakpoints
                .iter()
                .map(|b| BreakpointParams {
                    alpha_deg: b.alpha_deg,
                    epsilon_deg_s2: match b.epsilon {
                        Level::Value(e) => Some(e),
                        Level::MinusDeceleration => None,
                    },
                })
                .collect(),
            final_angle_deg: p.final_angle_deg,
            deceleration_deg_s2: None,
        }
    }
}

/// The WLS options the paper leaves open (SPEC B (8)–(10)); the scenario runs every
/// combination of units, v₆ timing and v₁ law as the "alternatives" table, and these for the
/// main cases.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EstimatorParams {
    /// Unit of ε inside the WLS state: "Radian" or "Degree".
    pub epsilon_unit: AngleUnit,
    /// Unit of ε̇ inside v₆: "Radian" or "Degree".
    pub epsilon_rate_unit: AngleUnit,
    /// Re-evaluate v₆ to a fixed point within the cycle (true) or take ε̇ from the previous
    /// two cycles (false).
    pub fixed_point: bool,
    /// v₁ = cos α₀ (true, the paper) or v₁ = 1 (false).
    pub ax_weight_cos: bool,
    /// α from the solved (s, c): "Arcsin" (the paper's; undefined when |s| > 1) or "Atan2"
    /// (always defined).
    pub angle_recovery: AngleRecovery,
}

impl Default for EstimatorParams {
    /// ε in °/s² in the state, ε̇ in °/s³ in v₆, v₆ to a fixed point, v₁ = cos α₀ (the `wls`
    /// crate's defaults, SPEC B's prototype choice) with α = atan2(s, c): of the option sets
    /// that keep WLS at γ = 0 defined and within the limits at γ = 10°, the one closest to
    /// the paper's Fig. 5 (only the "+" variant departs, from t ≈ 29 s, δε⁺ ≈ 0.58 °/s²) and
    /// to the prototype's smallest feasible γ ≈ 5° (see the alternatives table of the report).
    fn default() -> Self {
        Self {
            epsilon_unit: AngleUnit::Degree,
            epsilon_rate_unit: AngleUnit::Degree,
            fixed_point: true,
            ax_weight_cos: true,
            angle_recovery: AngleRecovery::Atan2,
        }
    }
}

/// Beyond the paper: the centripetal term and noise on top of the constant errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BeyondParams {
    /// Run the beyond-the-paper cases at all.
    pub enabled: bool,
    /// White-noise standard deviation per axis added on top of ±Δa, m/s² (≥ 0).
    pub noise_std_mps2: f64,
}

impl Default for BeyondParams {
    fn default() -> Self {
        Self {
            enabled: true,
            noise_std_mps2: 0.01,
        }
    }
}

/// The tracking formulation (beyond the paper): the white-jerk model, the sigma points and
/// the noise Monte Carlo that compares it with the WLS.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackingParams {
    /// White-jerk intensity q, (°/s³)²·s = (°/s²)²/s (> 0); omitted = derived from the
    /// nominal turn (the largest change of ε over 1 s, squared, per second: ≈ 0.21).
    pub jerk_psd_deg2_s5: Option<f64>,
    /// The UKF's sigma points (default the cubature set: positive weights, P stays PSD).
    pub sigma_points: SigmaPoints,
    /// White-noise σ per axis of the Monte Carlo, on top of ±Δa, m/s² (≥ 0; 0.01).
    pub noise_std_mps2: f64,
    /// Monte Carlo turns per γ (≥ 1; `--runs`); each turn is run under "+" and "−".
    pub runs: usize,
}

impl Default for TrackingParams {
    fn default() -> Self {
        Self {
            jerk_psd_deg2_s5: None,
            sigma_points: SigmaPoints::Cubature,
            noise_std_mps2: 0.01,
            runs: 40,
        }
    }
}

/// Every parameter of the scenario; SPEC B defaults, overridable by `--config`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoomParams {
    /// g, m/s² (SPEC B: 9.8).
    pub gravity_mps2: f64,
    /// Sensor radius r, m (25).
    pub sensor_radius_m: f64,
    /// Cycle and integration step, s (0.01).
    pub cycle_s: f64,
    /// The sensor's limiting error Δa, m/s² (0.02): the "+"/"−" variants add ±Δa.
    pub limiting_error_mps2: f64,
    /// Sensor range ±range, m/s² (10, the paper's sensor).
    pub range_mps2: f64,
    /// Allowed errors.
    pub limits: LimitParams,
    /// γ values of the main cases, degrees (0 and 10).
    pub case_gammas_deg: Vec<f64>,
    /// The γ sweep.
    pub sweep: SweepParams,
    /// The rotation profile.
    pub profile: ProfileParams,
    /// WLS options of the main cases.
    pub estimator: EstimatorParams,
    /// Beyond-the-paper cases.
    pub beyond: BeyondParams,
    /// The tracking formulation and its noise Monte Carlo.
    pub tracking: TrackingParams,
}

impl Default for BoomParams {
    fn default() -> Self {
        Self {
            gravity_mps2: 9.8,
            sensor_radius_m: 25.0,
            cycle_s: 0.01,
            limiting_error_mps2: 0.02,
            range_mps2: 10.0,
            limits: LimitParams::default(),
            case_gammas_deg: vec![0.0, 10.0],
            sweep: SweepParams::default(),
            profile: ProfileParams::default(),
            estimator: EstimatorParams::default(),
            beyond: BeyondParams::default(),
            tracking: TrackingParams::default(),
        }
    }
}

impl ScenarioParams for BoomParams {
    fn set_runs(&mut self, runs: usize) {
        self.tracking.runs = runs;
    }

    /// Checks every value, naming the key of the first bad one.
    ///
    /// # Errors
    /// [`Error::Invalid`] for `path` naming the key and the rule broken.
    fn validate(&self, path: &Path) -> Result<()> {
        let bad = |key: &str, value: f64, rule: &str| {
            Err(Error::invalid(path, format!("`{key}` = {value}: {rule}")))
        };
        for (key, value) in [
            ("gravity_mps2", self.gravity_mps2),
            ("sensor_radius_m", self.sensor_radius_m),
            ("cycle_s", self.cycle_s),
            ("range_mps2", self.range_mps2),
            ("limits.alpha_deg", self.limits.alpha_deg),
            ("limits.eps_deg_s2", self.limits.eps_deg_s2),
            ("sweep.step_deg", self.sweep.step_deg),
            ("profile.final_angle_deg", self.profile.final_angle_deg),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return bad(key, value, "must be finite and > 0");
            }
        }
        for (key, value) in [
            ("limiting_error_mps2", self.limiting_error_mps2),
            ("beyond.noise_std_mps2", self.beyond.noise_std_mps2),
            ("tracking.noise_std_mps2", self.tracking.noise_std_mps2),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return bad(key, value, "must be finite and ≥ 0");
            }
        }
        if let Some(q) = self.tracking.jerk_psd_deg2_s5
            && !(q.is_finite() && q > 0.0)
        {
            return bad("tracking.jerk_psd_deg2_s5", q, "must be finite and > 0");
        }
        if self.tracking.runs == 0 {
            return bad("tracking.runs", 0.0, "must be ≥ 1");
        }
        if let SigmaPoints::Merwe { alpha, beta, kappa } = self.tracking.sigma_points
            && !(alpha.is_finite()
                && alpha > 0.0
                && beta.is_finite()
                && kappa.is_finite()
                && 3.0 + kappa > 0.0)
        {
            return bad(
                "tracking.sigma_points",
                alpha,
                "Merwe needs finite alpha > 0, beta, kappa with 3 + kappa > 0",
            );
        }
        if self.cycle_s > 1.0 {
            return bad("cycle_s", self.cycle_s, "must be ≤ 1 s");
        }
        if self.case_gammas_deg.is_empty() {
            return Err(Error::invalid(path, "`case_gammas_deg` must not be empty"));
        }
        for &g in &self.case_gammas_deg {
            if !(g.is_finite() && (0.0..=45.0).contains(&g)) {
                return bad("case_gammas_deg", g, "each γ must lie in [0, 45] degrees");
            }
        }
        let s = &self.sweep;
        if !(s.from_deg.is_finite() && s.from_deg >= 0.0) {
            return bad("sweep.from_deg", s.from_deg, "must be finite and ≥ 0");
        }
        if !(s.to_deg.is_finite() && s.to_deg > s.from_deg && s.to_deg <= 45.0) {
            return bad(
                "sweep.to_deg",
                s.to_deg,
                "must be > sweep.from_deg and ≤ 45",
            );
        }
        if (s.to_deg - s.from_deg) / s.step_deg > 1000.0 {
            return bad("sweep.step_deg", s.step_deg, "at most 1000 sweep points");
        }
        if let Some(d) = self.profile.deceleration_deg_s2
            && !(d.is_finite() && d > 0.0)
        {
            return bad("profile.deceleration_deg_s2", d, "must be finite and > 0");
        }
        if self.profile.breakpoints.is_empty() {
            return Err(Error::invalid(
                path,
                "`profile.breakpoints` must not be empty",
            ));
        }
        for (i, b) in self.profile.breakpoints.iter().enumerate() {
            if !b.alpha_deg.is_finite()
                || (i > 0 && b.alpha_deg <= self.profile.breakpoints[i - 1].alpha_deg)
            {
                return bad(
                    "profile.breakpoints.alpha_deg",
                    b.alpha_deg,
                    "must be finite and strictly increasing",
                );
            }
            if let Some(e) = b.epsilon_deg_s2
                && !e.is_finite()
            {
                return bad("profile.breakpoints.epsilon_deg_s2", e, "must be finite");
            }
        }
        Ok(())
    }
}

impl BoomParams {
    /// The wls rotation profile.
    pub(super) fn rotation_profile(&self) -> RotationProfile {
        RotationProfile {
            breakpoints: self
                .profile
                .breakpoints
                .iter()
                .map(|b| wls::boom::Breakpoint {
                    alpha_deg: b.alpha_deg,
                    epsilon: b
                        .epsilon_deg_s2
                        .map_or(Level::MinusDeceleration, Level::Value),
                })
                .collect(),
            final_angle_deg: self.profile.final_angle_deg,
            dt: self.cycle_s,
            deceleration: self
                .profile
                .deceleration_deg_s2
                .map_or(Deceleration::Auto, Deceleration::Fixed),
        }
    }

    /// The estimator configuration for `method` at γ with the WLS options `opt`.
    pub(super) fn config(
        &self,
        method: BoomMethod,
        gamma_deg: f64,
        opt: &EstimatorParams,
    ) -> BoomConfig {
        let base = BoomConfig::default();
        BoomConfig {
            g: self.gravity_mps2,
            sensor_radius: self.sensor_radius_m,
            dt: self.cycle_s,
            sensor_offset_angle: gamma_deg.to_radians(),
            method,
            weights: wls::boom::WlsWeights {
                ax_law: if opt.ax_weight_cos {
                    AxWeightLaw::CosPrevious
                } else {
                    AxWeightLaw::Constant
                },
                ..base.weights
            },
            epsilon_unit: opt.epsilon_unit,
            epsilon_rate_unit: opt.epsilon_rate_unit,
            angle_recovery: opt.angle_recovery,
            rate_weight: if opt.fixed_point {
                RateWeight::FixedPoint {
                    max_iterations: 20,
                    tolerance: 1e-12,
                }
            } else {
                RateWeight::PreviousCycle
            },
            ..base
        }
    }

    pub(super) fn limits(&self) -> Limits {
        Limits {
            angle: self.limits.alpha_deg.to_radians(),
            angular_acceleration: self.limits.eps_deg_s2.to_radians(),
        }
    }

    pub(super) fn variants(&self) -> [ErrorVariant; 2] {
        [
            ErrorVariant::plus(self.limiting_error_mps2),
            ErrorVariant::minus(self.limiting_error_mps2),
        ]
    }

    pub(super) fn sweep_gammas_deg(&self) -> Vec<f64> {
        let s = &self.sweep;
        let n = ((s.to_deg - s.from_deg) / s.step_deg + 1e-9).floor() as usize;
        (0..=n)
            .map(|i| s.from_deg + i as f64 * s.step_deg)
            .collect()
    }
}
