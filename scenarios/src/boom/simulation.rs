//! The boom scenario's world and turns: the accelerometer of eq. (1) from `sensors`
//! (cached per γ and error variant, one random stream for the noise) as the measurement
//! model `wls::boom::run_turn` and `sweep_gamma` call, the per-turn statistics, and the noise
//! Monte Carlo's runs (WLS and the tracking filters on the same readings).

use rand_chacha::ChaCha8Rng;
use wls::boom::{
    BoomConfig, BoomMethod, ErrorVariant, Limits, Sign, TrajectoryPoint, TurnRun, run_turn,
};

use super::parameters::BoomParams;
use super::records::NoiseRecord;
use super::tracking::{Tracked, TrackingModel, jerk_intensity, turn_run};
use crate::error::{Error, Result};
use crate::montecarlo::{Shard, par_runs, run_rng, run_seed};

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
                sensor_offset_angle: g.to_radians(),
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
                sensor_offset_angle: gamma,
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

/// The readings of one turn, one per trajectory point, from `meter`.
pub(super) fn readings(
    points: &[TrajectoryPoint],
    meter: &mut Meter,
    gamma: f64,
    v: &ErrorVariant,
) -> Vec<[f64; 3]> {
    points.iter().map(|p| meter.read(p, gamma, v)).collect()
}

/// `wls::boom::run_turn` fed with recorded `readings` (so that it sees exactly what the
/// filters see).
pub(super) fn replay(
    points: &[TrajectoryPoint],
    cfg: &BoomConfig,
    readings: &[[f64; 3]],
    v: &ErrorVariant,
    limits: Limits,
) -> Result<TurnRun> {
    let mut next = readings.iter();
    let read = |_: &TrajectoryPoint, _: f64, _: &ErrorVariant| {
        next.next().copied().unwrap_or([f64::NAN; 3])
    };
    run_turn(points, cfg, read, v, limits).map_err(wls_err("run_turn"))
}

/// The filters' turns (EKF, UKF, unscented RTS) against the nominal turn.
pub(super) fn tracked_runs(
    points: &[TrajectoryPoint],
    t: &Tracked,
    sign: Sign,
    limits: Limits,
) -> [TurnRun; 3] {
    [
        turn_run(points, &t.ekf, sign, limits),
        turn_run(points, &t.ukf, sign, limits),
        turn_run(points, &t.urts, sign, limits),
    ]
}

/// Root mean square of the errors over the defined cycles after the start-up cycle of
/// every turn of `runs`, (degrees, °/s²).
pub(super) fn pooled_rms_deg(runs: &[&TurnRun]) -> (f64, f64) {
    let (mut sa, mut se, mut n) = (0.0, 0.0, 0usize);
    for run in runs {
        for c in run.cycles.iter().skip(1).filter(|c| c.defined) {
            sa += c.angle_error.powi(2);
            se += c.epsilon_error.powi(2);
            n += 1;
        }
    }
    let n = n.max(1) as f64;
    ((sa / n).sqrt().to_degrees(), (se / n).sqrt().to_degrees())
}

/// The noise Monte Carlo's stream tag: run i draws from `run_rng(run_seed(seed, TAG), i)`,
/// apart from the paper's and beyond-the-paper streams `run_rng(seed, 0..)`.
const NOISE_STREAM: u64 = u64::MAX;

/// The noise Monte Carlo runs of `shard`: run i reads white noise σ from its own stream
/// (the same draws at every γ, so the γ comparison is paired) on top of "+" then "−", and
/// the WLS (main options), EKF, UKF and unscented RTS all process the same readings.
/// Records come back in key order (γ index, then run).
///
/// # Errors
/// A library error on valid parameters, or the worker pool failing to start.
pub(super) fn simulate_noise_runs(
    p: &BoomParams,
    seed: u64,
    shard: Shard,
    threads: Option<usize>,
) -> Result<Vec<NoiseRecord>> {
    let points = p
        .rotation_profile()
        .trajectory()
        .map_err(|e| Error::invalid("<parameters>", format!("profile: {e}")))?
        .points;
    let q = jerk_intensity(p, &points);
    let sigma = p.tracking.noise_std_mps2;
    let limits = p.limits();
    let variants = p.variants();
    let models = p
        .case_gammas_deg
        .iter()
        .map(|&g| TrackingModel::new(p, g, false, sigma, q))
        .collect::<Result<Vec<_>>>()?;
    let stream = run_seed(seed, NOISE_STREAM);
    let per_run = par_runs(shard.runs(p.tracking.runs), threads, "boom", |i| {
        let mut rows = Vec::with_capacity(models.len());
        for (gi, (&gamma_deg, model)) in p.case_gammas_deg.iter().zip(&models).enumerate() {
            let mut meter = Meter::new(p, false, sigma, run_rng(stream, i as u64));
            let cfg = p.config(BoomMethod::Wls, gamma_deg, &p.estimator);
            let gamma = cfg.sensor_offset_angle;
            let mut turns: [Vec<TurnRun>; 4] = Default::default();
            for v in &variants {
                let z = readings(&points, &mut meter, gamma, v);
                turns[0].push(replay(&points, &cfg, &z, v, limits)?);
                let [e, u, s] = tracked_runs(&points, &model.track(&z)?, v.sign, limits);
                turns[1].push(e);
                turns[2].push(u);
                turns[3].push(s);
            }
            let rms = turns.map(|t| pooled_rms_deg(&t.iter().collect::<Vec<_>>()));
            rows.push(NoiseRecord {
                gamma_index: gi,
                run: i,
                rms,
            });
        }
        Ok::<_, Error>(rows)
    })?;
    let mut records = Vec::new();
    for rows in per_run {
        records.extend(rows?);
    }
    records.sort_by_key(|r| (r.gamma_index, r.run));
    Ok(records)
}
