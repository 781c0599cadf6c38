//! Criterion bench of the per-sample cost of every process and sensor, 1000 samples per
//! iteration, against `baseline_standard_normal` (1000 standard normals from ChaCha8: the
//! irreducible cost of one random input per sample). `spectral_synthesis_256` is the
//! alternative the issue mentions for irregular rolling — a sum of 256 harmonics with random
//! phases, advanced by the cheapest recurrence (rotating phasors) — kept here only to show
//! why the crate uses the exact shaping filter instead.
#![allow(missing_docs, clippy::unwrap_used)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use sensors::{
    Accelerometer, AccelerometerConfig, Attitude, BoomMotion, ChaCha8Rng, DampedCosineConfig,
    DampedCosineProcess, ExpCorrelated, ExpCorrelatedConfig, Gyro, GyroConfig,
    IrregularRollingConfig, IrregularRollingProcess, LevelSensor, LevelSensorConfig,
    PlatformMotion, PlatformMotionConfig, Process, WhiteNoise, seeded_rng,
};

const SAMPLES: usize = 1000;
const DT: f64 = 0.1;

/// Irregular rolling by spectral synthesis: x_k = Σ A_i cos(ω_i k Δt + φ_i), ω_i on a uniform
/// grid up to 4β, A_i² = 2 S(ω_i) Δω with S the one-sided spectral density of
/// R(τ) = e^{−μ|τ|}(cos βτ + (μ/β) sin β|τ|).
struct Spectral {
    amp: Vec<f64>,
    rot: Vec<(f64, f64)>,
    z: Vec<(f64, f64)>,
}

impl Spectral {
    fn new(harmonics: usize, mu: f64, beta: f64, rng: &mut ChaCha8Rng) -> Self {
        let w0 = mu * mu + beta * beta;
        let dw = 4.0 * beta / harmonics as f64;
        let mut amp = Vec::with_capacity(harmonics);
        let mut rot = Vec::with_capacity(harmonics);
        let mut z = Vec::with_capacity(harmonics);
        for i in 0..harmonics {
            let w = (i as f64 + 0.5) * dw;
            // S(ω) = (2/π)·2μ·w0 / ((w0 − ω²)² + 4μ²ω²) for unit variance (one-sided).
            let s = 2.0 / std::f64::consts::PI * 2.0 * mu * w0
                / ((w0 - w * w).powi(2) + 4.0 * mu * mu * w * w);
            amp.push((s * dw).sqrt());
            rot.push(((w * DT).cos(), (w * DT).sin()));
            let ph: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            z.push((ph.cos(), ph.sin()));
        }
        Self { amp, rot, z }
    }
    fn next(&mut self) -> f64 {
        let mut x = 0.0;
        for ((a, (c, s)), z) in self.amp.iter().zip(&self.rot).zip(&mut self.z) {
            x += a * z.0;
            *z = (z.0 * c - z.1 * s, z.0 * s + z.1 * c);
        }
        x
    }
}

fn per_sample(c: &mut Criterion) {
    let mut g = c.benchmark_group("per_sample_x1000");
    let c = &mut g;
    {
        let mut rng = seeded_rng(1);
        c.bench_function("baseline_standard_normal", |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for _ in 0..SAMPLES {
                    let w: f64 = StandardNormal.sample(&mut rng);
                    acc += w;
                }
                black_box(acc)
            });
        });
    }
    let mut rng = seeded_rng(1);
    {
        let mut p = WhiteNoise::new(1.0, DT).unwrap();
        c.bench_function("white_noise", |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for _ in 0..SAMPLES {
                    acc += p.next(&mut rng);
                }
                black_box(acc)
            });
        });
    }
    let mut bench = |name: &str, f: &mut dyn FnMut(&mut ChaCha8Rng) -> f64| {
        c.bench_function(name, |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for _ in 0..SAMPLES {
                    acc += f(&mut rng);
                }
                black_box(acc)
            });
        });
    };
    let mut ar = ExpCorrelated::new(&ExpCorrelatedConfig::default(), DT).unwrap();
    bench("exp_correlated", &mut |r| ar.next(r));
    let cfg = IrregularRollingConfig::default();
    let mut roll = IrregularRollingProcess::new(&cfg, DT).unwrap();
    bench("irregular_rolling_exact", &mut |r| roll.next(r));
    let mut spectral = Spectral::new(
        256,
        cfg.irregularity_per_s,
        std::f64::consts::TAU / cfg.period_s,
        &mut seeded_rng(2),
    );
    bench("spectral_synthesis_256", &mut |_| spectral.next());
    let mut dc = DampedCosineProcess::new(&DampedCosineConfig::default(), DT).unwrap();
    bench("damped_cosine", &mut |r| dc.next(r));
    let mut platform = PlatformMotion::new(&PlatformMotionConfig::default(), DT).unwrap();
    bench("platform_motion", &mut |r| platform.next(r).roll);
    let mut pm = PlatformMotion::new(&PlatformMotionConfig::default(), DT).unwrap();
    let mut level = LevelSensor::new(&LevelSensorConfig::default(), DT).unwrap();
    let mut h = 1.0;
    bench("platform_and_level_sensor", &mut |r| {
        h += 1e-3;
        let att = pm.next(r);
        level.step(h, att, r).reading
    });
    let mut gyro = Gyro::new(
        &GyroConfig {
            noise_std_deg: 0.01,
            ..GyroConfig::default()
        },
        DT,
    )
    .unwrap();
    bench("gyro", &mut |r| gyro.step(Attitude::default(), r).roll);
    let acc = Accelerometer::new(&AccelerometerConfig {
        noise_std_mps2: 0.02,
        misalignment_deg: [0.1, 0.2, 0.3],
        centripetal: true,
        ..AccelerometerConfig::default()
    })
    .unwrap();
    let m = BoomMotion {
        angle: 0.7,
        rate: 0.05,
        acceleration: 0.001,
    };
    bench("accelerometer", &mut |r| acc.measure(m, r).y);
    g.finish();
}

criterion_group!(benches, per_sample);
criterion_main!(benches);
