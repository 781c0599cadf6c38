//! Parameters of the fueling scenario: the TOML-overridable [`FuelingParams`] with SPEC F's
//! assumed defaults, their validation, and the sweeps they define (each point a [`World`] in
//! SI units).

use std::path::Path;

use model::{FuelParams, FuelParamsStated, Realisation};
use serde::{Deserialize, Serialize};

use crate::campaign::ScenarioParams;
use crate::error::{Error, Result};

/// How the filters' model is discretised (`model::Realisation`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RealisationName {
    /// The paper's Tustin variant (SPEC F's A–D).
    Paper,
    /// Exact Tustin per block.
    ExactTustin,
    /// Zero-order hold of the continuous cascade.
    Zoh,
}

impl RealisationName {
    /// The `model` crate's realisation.
    pub fn to_model(self) -> model::Realisation {
        match self {
            RealisationName::Paper => model::Realisation::Paper,
            RealisationName::ExactTustin => model::Realisation::ExactTustin,
            RealisationName::Zoh => model::Realisation::Zoh,
        }
    }
}

/// Parameters of the scenario (TOML keys = field names). Defaults: SPEC F's assumed values
/// (the paper's own data set is unavailable) and the campaign sizes that fit
/// `cargo xtask reproduce` in its time budget.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FuelingParams {
    /// Monte Carlo runs per point of the amplitude sweep (the paper's Fig. 1). `--runs`
    /// overrides this and `sweep_runs_per_point` alike.
    pub runs_per_point: usize,
    /// Runs per point of the period, fill-rate and damper sweeps and the invariance table.
    pub sweep_runs_per_point: usize,
    /// Sampling interval Δt, s.
    pub dt_s: f64,
    /// Correlation time T_a of the fill-velocity fluctuation, s.
    pub velocity_time_s: f64,
    /// Standard deviation √D_c of the fill-velocity fluctuation, mm/s.
    pub velocity_std_mm_s: f64,
    /// Mean fill rate V_c, mm/s.
    pub fill_rate_mm_s: f64,
    /// Quantization step δ of the level sensor, mm.
    pub step_mm: f64,
    /// Hydro-damper time constant T_y, s.
    pub damper_time_s: f64,
    /// Distance R of the sensor from the tank axis, m.
    pub sensor_radius_m: f64,
    /// Angle φ from the stern direction to the sensor, degrees.
    pub sensor_angle_deg: f64,
    /// Dominant rolling period 2π/β, s.
    pub rolling_period_s: f64,
    /// Irregularity μ of rolling, 1/s.
    pub irregularity_per_s: f64,
    /// Maximum tilt amplitude A_max of the sweeps other than the amplitude sweep, degrees
    /// (σ = A_max/3 per axis).
    pub max_amplitude_deg: f64,
    /// Gyro noise per axis, degrees (0 = the paper's noise-free tilt channel).
    pub gyro_noise_deg: f64,
    /// Valve-closing delay: the error is the level this long after the stop command, s.
    pub valve_delay_s: f64,
    /// Target level H*, m (put on a sensor mark so relay logic is not penalised by δ).
    pub target_level_m: f64,
    /// Put H* at a uniformly random height within the quantization step above
    /// `target_level_m` in each run (true: the dose sets H*, so relay logic also pays the
    /// sensor's discreteness, as in the paper's error budget) or on the mark itself (false).
    pub random_target_phase: bool,
    /// Filling time before the nominal crossing of H*, s (start level = H* − V_c·warm-up):
    /// how long the filters have to converge.
    pub warmup_s: f64,
    /// Prior standard deviation of the level given to the filters, mm.
    pub initial_level_std_mm: f64,
    /// Discretisation of the filters' model: "paper", "exact_tustin" or "zoh".
    pub realisation: RealisationName,
    /// Amplitude sweep (the paper's Fig. 1), degrees.
    pub amplitudes_deg: Vec<f64>,
    /// Rolling-period sweep, s.
    pub periods_s: Vec<f64>,
    /// Fill-rate sweep, mm/s.
    pub fill_rates_mm_s: Vec<f64>,
    /// Damper time-constant sweep, s.
    pub damper_times_s: Vec<f64>,
    /// Quantization-step sweep, mm (explains the gap to the paper: the two-channel gain over
    /// relay logic grows as δ shrinks against the tilt swing).
    pub steps_mm: Vec<f64>,
    /// Amplitudes of the invariance table, degrees.
    pub invariance_amplitudes_deg: Vec<f64>,
    /// Periods of the invariance table, s.
    pub invariance_periods_s: Vec<f64>,
    /// The search over the unstated parameters (`[calibration]`, see `calibration`).
    pub calibration: CalibrationConfig,
    /// The exact-likelihood particle filter in the amplitude sweep (`[particle]`, see
    /// `particle`).
    pub particle: ParticleConfig,
}

impl Default for FuelingParams {
    /// The physical values are the fuel model's ([`FuelParamsStated::DEFAULT`]).
    fn default() -> Self {
        let fuel = FuelParamsStated::DEFAULT;
        Self {
            runs_per_point: 1000,
            sweep_runs_per_point: 1000,
            dt_s: fuel.dt_s,
            velocity_time_s: fuel.t_a_s,
            velocity_std_mm_s: fuel.sigma_c_mm_s,
            fill_rate_mm_s: fuel.v_c_mm_s,
            step_mm: fuel.delta_mm,
            damper_time_s: fuel.t_y_s,
            sensor_radius_m: fuel.sensor_radius_m,
            sensor_angle_deg: fuel.phi_deg,
            rolling_period_s: fuel.rolling_period_s,
            irregularity_per_s: fuel.mu_per_s,
            max_amplitude_deg: fuel.max_tilt_amplitude_deg,
            gyro_noise_deg: fuel.gyro_sigma_deg,
            valve_delay_s: 0.0,
            target_level_m: 10.0,
            random_target_phase: true,
            warmup_s: 60.0,
            initial_level_std_mm: 50.0,
            realisation: RealisationName::Paper,
            amplitudes_deg: (0..=10).map(|i| f64::from(i) / 10.0).collect(),
            periods_s: vec![6.0, 8.0, 10.0, 12.0, 14.0],
            fill_rates_mm_s: vec![5.0, 10.0, 15.0, 20.0],
            damper_times_s: vec![0.5, 1.0, 2.0, 4.0],
            steps_mm: vec![1.0, 2.5, 5.0, 10.0, 20.0],
            invariance_amplitudes_deg: vec![0.25, 0.5, 0.75, 1.0],
            invariance_periods_s: vec![6.0, 10.0, 14.0],
            calibration: CalibrationConfig::default(),
            particle: ParticleConfig::default(),
        }
    }
}

impl ScenarioParams for FuelingParams {
    fn set_runs(&mut self, runs: usize) {
        self.runs_per_point = runs;
        self.sweep_runs_per_point = runs;
    }

    /// Checks every value, naming the key (`source` names the file in the error).
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the key and the rule broken.
    fn validate(&self, source: &Path) -> Result<()> {
        let bad = |key: &str, rule: &str, value: String| {
            Err(Error::invalid(
                source,
                format!("key `{key}` = {value}: {rule}"),
            ))
        };
        for (key, v) in [
            ("runs_per_point", self.runs_per_point),
            ("sweep_runs_per_point", self.sweep_runs_per_point),
        ] {
            if v < 2 {
                return bad(
                    key,
                    "needs at least 2 runs (a standard deviation)",
                    v.to_string(),
                );
            }
        }
        let positive = [
            ("dt_s", self.dt_s),
            ("velocity_time_s", self.velocity_time_s),
            ("velocity_std_mm_s", self.velocity_std_mm_s),
            ("fill_rate_mm_s", self.fill_rate_mm_s),
            ("step_mm", self.step_mm),
            ("damper_time_s", self.damper_time_s),
            ("sensor_radius_m", self.sensor_radius_m),
            ("rolling_period_s", self.rolling_period_s),
            ("irregularity_per_s", self.irregularity_per_s),
            ("warmup_s", self.warmup_s),
            ("initial_level_std_mm", self.initial_level_std_mm),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return bad(key, "must be finite and > 0", v.to_string());
            }
        }
        let non_negative = [
            ("max_amplitude_deg", self.max_amplitude_deg),
            ("gyro_noise_deg", self.gyro_noise_deg),
            ("valve_delay_s", self.valve_delay_s),
        ];
        for (key, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return bad(key, "must be finite and ≥ 0", v.to_string());
            }
        }
        for (key, v) in [
            ("sensor_angle_deg", self.sensor_angle_deg),
            ("target_level_m", self.target_level_m),
        ] {
            if !v.is_finite() {
                return bad(key, "must be finite", v.to_string());
            }
        }
        if self.warmup_s < 10.0 * self.dt_s {
            return bad(
                "warmup_s",
                "must be at least 10 sampling intervals dt_s",
                self.warmup_s.to_string(),
            );
        }
        let lists: [(&str, &[f64], bool); 7] = [
            ("amplitudes_deg", &self.amplitudes_deg, true),
            ("periods_s", &self.periods_s, false),
            ("fill_rates_mm_s", &self.fill_rates_mm_s, false),
            ("damper_times_s", &self.damper_times_s, false),
            ("steps_mm", &self.steps_mm, false),
            (
                "invariance_amplitudes_deg",
                &self.invariance_amplitudes_deg,
                true,
            ),
            ("invariance_periods_s", &self.invariance_periods_s, false),
        ];
        for (key, list, zero_ok) in lists {
            if list.is_empty() {
                return bad(key, "must list at least one value", "[]".into());
            }
            for v in list {
                let ok = v.is_finite() && (*v > 0.0 || (zero_ok && *v >= 0.0));
                if !ok {
                    let rule = if zero_ok {
                        "every entry must be finite and ≥ 0"
                    } else {
                        "every entry must be finite and > 0"
                    };
                    return bad(key, rule, format!("{list:?}"));
                }
            }
        }
        if self.amplitudes_deg.len() < 2 {
            return bad(
                "amplitudes_deg",
                "needs at least two amplitudes for the straight-line fits",
                format!("{:?}", self.amplitudes_deg),
            );
        }
        self.calibration.check(source)?;
        let pf = self.particle;
        if pf.runs > 0 && !(16..=1 << 20).contains(&pf.particles) {
            return bad(
                "particle.particles",
                "must be in 16 ..= 1048576 (or set `particle.runs` = 0)",
                pf.particles.to_string(),
            );
        }
        if pf.runs == 1 {
            return bad(
                "particle.runs",
                "needs at least 2 runs (a standard deviation), or 0 for none",
                "1".into(),
            );
        }
        // Let the model check the combination (e.g. an overflowing discretisation).
        let world = self.world(self.max_amplitude_deg, Swept::Nothing);
        world
            .fuel
            .build(model::Channels::LevelAndTilt, world.realisation)
            .map_err(|e| {
                Error::invalid(
                    source,
                    format!("the fuel model rejects these parameters: {e}"),
                )
            })?;
        Ok(())
    }
}

impl FuelingParams {
    /// The world at amplitude `amplitude_deg`, with one swept value overriding its base.
    pub fn world(&self, amplitude_deg: f64, swept: Swept) -> World {
        let (mut period_s, mut fill_rate_mm_s, mut damper_time_s, mut step_mm) =
            (None, None, None, None);
        match swept {
            Swept::Nothing => {}
            Swept::Period(x) => period_s = Some(x),
            Swept::FillRate(x) => fill_rate_mm_s = Some(x),
            Swept::Damper(x) => damper_time_s = Some(x),
            Swept::Step(x) => step_mm = Some(x),
            Swept::RandomTargetPhase(_) => {}
        }
        let random_target_phase = match swept {
            Swept::RandomTargetPhase(on) => on,
            _ => self.random_target_phase,
        };
        let fuel = FuelParamsStated {
            dt_s: self.dt_s,
            t_a_s: self.velocity_time_s,
            sigma_c_mm_s: self.velocity_std_mm_s,
            v_c_mm_s: fill_rate_mm_s.unwrap_or(self.fill_rate_mm_s),
            delta_mm: step_mm.unwrap_or(self.step_mm),
            t_y_s: damper_time_s.unwrap_or(self.damper_time_s),
            sensor_radius_m: self.sensor_radius_m,
            phi_deg: self.sensor_angle_deg,
            rolling_period_s: period_s.unwrap_or(self.rolling_period_s),
            mu_per_s: self.irregularity_per_s,
            max_tilt_amplitude_deg: amplitude_deg,
            gyro_sigma_deg: self.gyro_noise_deg,
        }
        .to_si();
        World {
            fuel,
            target: self.target_level_m,
            random_target_phase,
            warmup: self.warmup_s,
            initial_level_std: self.initial_level_std_mm * 1e-3,
            valve_delay: self.valve_delay_s,
            realisation: self.realisation.to_model(),
        }
    }

    /// The campaign's sweeps, in output order.
    pub fn sweeps(&self) -> Vec<Sweep> {
        let a = self.max_amplitude_deg;
        let one = |id, key, label, runs, xs: &[f64], f: &dyn Fn(f64) -> World| Sweep {
            id,
            keys: vec![key],
            label,
            runs,
            points: xs.iter().map(|&x| (vec![x], f(x))).collect(),
        };
        let mut invariance = Vec::new();
        for &amp in &self.invariance_amplitudes_deg {
            for &period in &self.invariance_periods_s {
                invariance.push((vec![amp, period], self.world(amp, Swept::Period(period))));
            }
        }
        vec![
            one(
                "amplitude",
                "amplitude_deg",
                "maximum tilt amplitude A_max [°]",
                self.runs_per_point,
                &self.amplitudes_deg,
                &|x| self.world(x, Swept::Nothing),
            ),
            one(
                "period",
                "rolling_period_s",
                "dominant rolling period 2π/β [s]",
                self.sweep_runs_per_point,
                &self.periods_s,
                &|x| self.world(a, Swept::Period(x)),
            ),
            one(
                "fill_rate",
                "fill_rate_mm_s",
                "mean fill rate V_c [mm/s]",
                self.sweep_runs_per_point,
                &self.fill_rates_mm_s,
                &|x| self.world(a, Swept::FillRate(x)),
            ),
            one(
                "damper",
                "damper_time_s",
                "hydro-damper time constant T_y [s]",
                self.sweep_runs_per_point,
                &self.damper_times_s,
                &|x| self.world(a, Swept::Damper(x)),
            ),
            one(
                "step",
                "step_mm",
                "quantization step δ [mm]",
                self.sweep_runs_per_point,
                &self.steps_mm,
                &|x| self.world(a, Swept::Step(x)),
            ),
            one(
                "target",
                "random_target_phase",
                "H* within a step (1) or on a mark (0)",
                self.sweep_runs_per_point,
                &[0.0, 1.0],
                &|x| self.world(a, Swept::RandomTargetPhase(x > 0.5)),
            ),
            Sweep {
                id: "invariance",
                keys: vec!["amplitude_deg", "rolling_period_s"],
                label: "amplitude × period",
                runs: self.sweep_runs_per_point,
                points: invariance,
            },
        ]
    }
}

/// Which parameter a sweep point moves away from its base value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Swept {
    /// None (the amplitude sweep moves only the amplitude).
    Nothing,
    /// Rolling period, s.
    Period(f64),
    /// Fill rate, mm/s.
    FillRate(f64),
    /// Damper time constant, s.
    Damper(f64),
    /// Quantization step, mm.
    Step(f64),
    /// Whether H* is drawn within a step (true) or put on a mark (false).
    RandomTargetPhase(bool),
}

/// One sweep: its points (coordinates and world) and runs per point.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// Identifier (file names, JSON keys).
    pub id: &'static str,
    /// JSON keys of the point coordinates.
    pub keys: Vec<&'static str>,
    /// Axis label.
    pub label: &'static str,
    /// Monte Carlo runs per point.
    pub runs: usize,
    /// Coordinates and world of each point.
    pub points: Vec<(Vec<f64>, World)>,
}

/// Everything that defines one sweep point's world, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct World {
    /// The model parameters (also the truth's: the filter knows the world's statistics).
    pub fuel: FuelParams,
    /// Target level H*, m.
    pub target: f64,
    /// Draw H* uniformly within the quantization step above `target` for each run (the dose
    /// sets the target, not the sensor's marks); `false` puts H* on a mark.
    pub random_target_phase: bool,
    /// Simulated time before the nominal crossing of H*, s (start level H* − V_c·warm-up).
    pub warmup: f64,
    /// Prior standard deviation of the tank level given to the filters, m.
    pub initial_level_std: f64,
    /// Valve-closing delay after the stop command, s.
    pub valve_delay: f64,
    /// How the filters' model is discretised.
    pub realisation: Realisation,
}

/// The `[particle]` table of the fueling configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ParticleConfig {
    /// Runs per amplitude point (the first this many of the sweep's; 0 turns the strategy
    /// off; capped at `runs_per_point`).
    pub runs: usize,
    /// Particles N (≥ 16).
    pub particles: usize,
}

impl Default for ParticleConfig {
    /// 200 runs per amplitude point, 256 particles.
    fn default() -> Self {
        Self {
            runs: 200,
            particles: 256,
        }
    }
}

/// How thorough the search is; the sizes it sets can each be overridden.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Search {
    /// No calibration (the report has no calibration section).
    Off,
    /// The default, sized for `cargo xtask reproduce`: 256 sets × 200 runs, one refinement.
    Quick,
    /// 2048 sets × 400 runs, refinement from the best four (about 30× the quick search).
    Long,
}

/// The `[calibration]` table of the fueling configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CalibrationConfig {
    /// "off", "quick" (default) or "long".
    pub search: Search,
    /// Sets in the space-filling design (default from `search`).
    pub design_sets: Option<usize>,
    /// Monte Carlo runs per set during the search (default from `search`).
    pub runs_per_set: Option<usize>,
    /// Nelder–Mead refinements, each from one of the best design sets (default from `search`).
    pub refine_starts: Option<usize>,
    /// Iterations of each refinement (default from `search`).
    pub refine_iterations: Option<u64>,
    /// Weight w of the two-channel invariance spread in the objective.
    pub invariance_weight: f64,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        Self {
            search: Search::Quick,
            design_sets: None,
            runs_per_set: None,
            refine_starts: None,
            refine_iterations: None,
            invariance_weight: 0.1,
        }
    }
}

/// The sizes of one search.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plan {
    /// Sets in the Latin hypercube.
    pub design_sets: usize,
    /// Runs per set.
    pub runs_per_set: usize,
    /// Refinements.
    pub refine_starts: usize,
    /// Iterations per refinement.
    pub refine_iterations: u64,
}

impl CalibrationConfig {
    /// The search's sizes (`None` for `search = "off"`).
    pub fn plan(&self) -> Option<Plan> {
        let (d, r, s, i) = match self.search {
            Search::Off => return None,
            Search::Quick => (256, 200, 1, 60),
            Search::Long => (2048, 400, 4, 200),
        };
        Some(Plan {
            design_sets: self.design_sets.unwrap_or(d),
            runs_per_set: self.runs_per_set.unwrap_or(r),
            refine_starts: self.refine_starts.unwrap_or(s),
            refine_iterations: self.refine_iterations.unwrap_or(i),
        })
    }

    /// Checks the sizes and the weight (`source` names the file in the error).
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the key and the rule broken.
    pub fn check(&self, source: &Path) -> Result<()> {
        let bad = |rule: String| Err(Error::invalid(source, rule));
        if let Some(p) = self.plan() {
            if p.design_sets < 1 {
                return bad(format!(
                    "`calibration.design_sets` = {}: must be ≥ 1",
                    p.design_sets
                ));
            }
            if p.runs_per_set < 2 {
                return bad(format!(
                    "`calibration.runs_per_set` = {}: needs at least 2 runs (a standard deviation)",
                    p.runs_per_set
                ));
            }
            if p.refine_starts > p.design_sets {
                return bad(format!(
                    "`calibration.refine_starts` = {}: at most `design_sets` = {}",
                    p.refine_starts, p.design_sets
                ));
            }
        }
        let w = self.invariance_weight;
        if !(w.is_finite() && w >= 0.0) {
            return bad(format!(
                "`calibration.invariance_weight` = {w}: must be finite and ≥ 0"
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_world_is_the_fuel_models_default() {
        // The scenario's physical defaults are the fuel model's, stated in the units of its
        // TOML file (mm, degrees) and copied field by field; the base world converts them
        // by the model's own conversion, so it must be `model::FuelParams::default()`
        // exactly (a field copied from the wrong one, or a sweep's value leaking into the
        // base world, fails).
        let p = FuelingParams::default();
        let world = p.world(p.max_amplitude_deg, Swept::Nothing);
        assert_eq!(world.fuel, FuelParams::default());
    }
}
