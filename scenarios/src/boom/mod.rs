//! The `boom` scenario (SPEC B): erector-boom angle and angular acceleration from one
//! three-axis accelerometer — direct inversion, the linearised 3×3 solve and WLS at γ = 0° and
//! γ = 10° under the constant "+"/"−" errors ±Δa, the γ sweep, the unit/weight alternatives of
//! the WLS, and (beyond the paper) the centripetal term and noise on top of the constant errors.
//!
//! The world is `sensors::Accelerometer` (gravity projection at α − γ, ε·r, optional ω²·r,
//! ±Δa bias, noise, ±range saturation) driven by `wls::boom::RotationProfile`'s nominal turn;
//! the estimators and the per-turn error bookkeeping are `wls::boom`'s (`run_turn`,
//! `sweep_gamma`).
//!
//! Beyond the paper, [`tracking`] solves the same problem as a tracking problem: (α, ω, ε)
//! carried through time by a white-jerk model, the `sensors` accelerometer as the
//! measurement function, and `kalman::nonlinear`'s EKF, UKF and unscented RTS smoother over
//! the same turns; a noise Monte Carlo compares them with the WLS.
//!
//! Layout (the same as every scenario's): [`parameters`], [`simulation`] (the accelerometer
//! as the measurement model, per-turn statistics, the Monte Carlo runs), [`tracking`],
//! [`records`] (`runs_noise.csv`, the Monte Carlo's ground truth), [`summary`] (every number)
//! and [`report`] with [`tracking_report`] (formatting only). The paper's cases are deterministic (the
//! beyond-the-paper noise draws from streams of the campaign seed) and are recomputed by
//! every shard; the noise Monte Carlo's runs are split between shards, and `merge`
//! recomputes everything from their records.

mod findings;
pub mod parameters;
pub mod records;
pub mod report;
pub mod simulation;
pub mod summary;
pub mod tracking;
pub mod tracking_report;

use std::path::Path;

use crate::campaign::Scenario;
use crate::error::Result;
use crate::montecarlo::Shard;
use parameters::BoomParams;
use records::NoiseRecord;
use summary::{BoomSummary, Computed};

/// The boom scenario, as the campaign runs it.
#[derive(Debug, Clone, Copy)]
pub struct Boom;

impl Scenario for Boom {
    const NAME: &'static str = "boom";
    type Params = BoomParams;
    type Records = Vec<NoiseRecord>;
    type Summary = Computed;
    type Json = BoomSummary;
    type Finish = ();

    fn simulate(
        params: &BoomParams,
        seed: u64,
        shard: Shard,
        threads: Option<usize>,
    ) -> Result<Vec<NoiseRecord>> {
        simulation::simulate_noise_runs(params, seed, shard, threads)
    }

    fn summarise(
        params: &BoomParams,
        seed: u64,
        _shard: Shard,
        records: &Vec<NoiseRecord>,
        _finish: Option<&()>,
        threads: Option<usize>,
    ) -> Result<Computed> {
        summary::summarise(params, seed, records, threads, Path::new("<parameters>"))
    }

    fn json(summary: &Computed) -> &BoomSummary {
        &summary.summary
    }

    fn write_outputs(summary: &Computed, dir: &Path) -> Result<()> {
        let section = tracking_report::write_outputs(summary, dir)?;
        report::write_outputs(summary, dir, &section)
    }
}

#[cfg(test)]
mod tests {
    use super::parameters::BoomParams;
    use super::simulation::Meter;
    use crate::campaign::ScenarioParams;
    use crate::montecarlo::run_rng;
    use std::path::Path;
    use wls::boom::{AngleUnit, ErrorVariant, TrajectoryPoint};

    #[test]
    fn bad_values_are_named() {
        let p = BoomParams {
            cycle_s: -1.0,
            ..BoomParams::default()
        };
        let msg = p
            .validate(Path::new("b.toml"))
            .expect_err("negative cycle")
            .to_string();
        assert!(msg.contains("cycle_s") && msg.contains("b.toml"), "{msg}");
        let p = BoomParams {
            case_gammas_deg: vec![60.0],
            ..BoomParams::default()
        };
        let msg = p
            .validate(Path::new("b.toml"))
            .expect_err("γ out of range")
            .to_string();
        assert!(msg.contains("case_gammas_deg"), "{msg}");
        let err = crate::config::parse_toml::<BoomParams>(
            Path::new("b.toml"),
            "[estimator]\nepsilon_unit = \"Degree\"\nfoo = 1\n",
        )
        .expect_err("unknown key");
        assert!(err.to_string().contains("foo"), "{err}");
        let ok = crate::config::parse_toml::<BoomParams>(
            Path::new("b.toml"),
            "[estimator]\nepsilon_unit = \"Degree\"\n[sweep]\nstep_deg = 2.0\n",
        )
        .expect("valid");
        assert_eq!(ok.estimator.epsilon_unit, AngleUnit::Degree);
        assert_eq!(ok.sweep_gammas_deg().len(), 11);
    }

    #[test]
    fn meter_matches_equation_1() {
        let p = BoomParams::default();
        let mut m = Meter::new(&p, false, 0.0, run_rng(1, 0));
        let pt = TrajectoryPoint {
            t: 0.0,
            alpha: 40f64.to_radians(),
            omega: 0.05,
            epsilon: 0.004,
        };
        let gamma = 10f64.to_radians();
        let [ax, ay, az] = m.read(&pt, gamma, &ErrorVariant::plus(0.02));
        let beta = pt.alpha - gamma;
        // Exact arithmetic up to the sensor's rotation by an identity misalignment.
        assert!((ax - (9.8 * beta.sin() + 0.02)).abs() < 1e-12);
        assert!((ay - (9.8 * beta.cos() + 0.004 * 25.0 + 0.02)).abs() < 1e-12);
        assert!(az.abs() < 1e-12);
        let [ax2, ..] = m.read(&pt, gamma, &ErrorVariant::minus(0.02));
        assert!((ax - ax2 - 0.04).abs() < 1e-12);
        // The variant's own size reaches the sensor, not the scenario's Δa.
        let bigger = ErrorVariant {
            sign: wls::boom::Sign::Plus,
            size: 0.05,
        };
        let [ax3, ay3, _] = m.read(&pt, gamma, &bigger);
        assert!((ax3 - (9.8 * beta.sin() + 0.05)).abs() < 1e-12);
        assert!((ay3 - (9.8 * beta.cos() + 0.004 * 25.0 + 0.05)).abs() < 1e-12);
    }
}
