//! Criterion benches of the bootstrap particle filter on the classic 1-D nonlinear model
//! (Kitagawa; Gordon, Salmond and Smith):
//! `x_{k+1} = x_k/2 + 25 x_k/(1 + x_k²) + 8 cos(1.2 k) + w_k`, `w ~ N(0, 10)`,
//! `z_k = x_k²/20 + v_k`, `v ~ N(0, 1)`, `x_0 ~ N(0, 5)`; 100 measurements simulated once,
//! N = 1000 and 10 000 particles, systematic resampling when the ESS falls below N/2.
//! - `baseline_bare_loop`: the same draws and arithmetic written as one loop over a vector
//!   (a ChaCha8 stream, a normal draw, the transition and the log-likelihood per particle; no
//!   weights normalised, no resampling): what a step cannot cost less than;
//! - `bootstrap_1_thread`, `bootstrap_2_threads`: `ParticleFilter::step` over the record in
//!   a rayon pool of that many threads (the same results bit for bit).
//!
//! Criterion reports the throughput in particles propagated and weighted per second (N × 100
//! per iteration); the ratio to the baseline is the filter's overhead, the ratio of the two
//! pools the thread scaling. The thread scaling needs the feature `parallel` (on in
//! `cargo xtask bench`, which builds with all features).
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use kalman::particle::rand::RngExt;
use kalman::particle::{ParticleFilter, ParticleModel, ParticleOptions, ParticleRng};
use rand::SeedableRng;
use rand_distr::StandardNormal;

const STEPS: usize = 100;

/// The classic model.
struct Classic;

impl Classic {
    fn f(k: usize, x: f64) -> f64 {
        0.5 * x + 25.0 * x / (1.0 + x * x) + 8.0 * (1.2 * k as f64).cos()
    }
    fn log_g(x: f64, z: f64) -> f64 {
        let e = z - x * x / 20.0;
        -0.5 * e * e
    }
}

impl ParticleModel for Classic {
    fn state_dim(&self) -> usize {
        1
    }
    fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]) {
        x[0] = 5f64.sqrt() * rng.sample::<f64, _>(StandardNormal);
    }
    fn sample_transition(&self, k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]) {
        next[0] = Self::f(k, x[0]) + 10f64.sqrt() * rng.sample::<f64, _>(StandardNormal);
    }
    fn log_likelihood(&self, _k: usize, x: &[f64], z: &[f64]) -> f64 {
        Self::log_g(x[0], z[0])
    }
}

fn record() -> Vec<f64> {
    let mut rng = ParticleRng::seed_from_u64(2026);
    let mut x = 5f64.sqrt() * rng.sample::<f64, _>(StandardNormal);
    (0..STEPS)
        .map(|k| {
            let z = x * x / 20.0 + rng.sample::<f64, _>(StandardNormal);
            x = Classic::f(k, x) + 10f64.sqrt() * rng.sample::<f64, _>(StandardNormal);
            z
        })
        .collect()
}

fn run(options: ParticleOptions, zs: &[f64]) -> f64 {
    let mut pf = ParticleFilter::new(Classic, options).unwrap();
    for z in zs {
        pf.step(&[*z]).unwrap();
    }
    pf.mean()[0]
}

fn bare(n: usize, zs: &[f64]) -> f64 {
    let mut rng = ParticleRng::seed_from_u64(1);
    let mut x: Vec<f64> = (0..n)
        .map(|_| 5f64.sqrt() * rng.sample::<f64, _>(StandardNormal))
        .collect();
    let mut lw = vec![0.0; n];
    for (k, z) in zs.iter().enumerate() {
        for (xi, l) in x.iter_mut().zip(lw.iter_mut()) {
            *xi = Classic::f(k, *xi) + 10f64.sqrt() * rng.sample::<f64, _>(StandardNormal);
            *l = Classic::log_g(*xi, *z);
        }
    }
    x[0] + lw[0]
}

fn bench(c: &mut Criterion) {
    let zs = record();
    let mut g = c.benchmark_group("particle_1d");
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(3));
    g.sample_size(20);
    let pools: Vec<_> = [1, 2]
        .into_iter()
        .map(|t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
        })
        .collect();
    for n in [1000, 10_000] {
        g.throughput(Throughput::Elements((n * STEPS) as u64));
        let options = ParticleOptions {
            particles: n,
            seed: 5,
            ..ParticleOptions::default()
        };
        g.bench_with_input(BenchmarkId::new("baseline_bare_loop", n), &n, |b, &n| {
            b.iter(|| bare(black_box(n), &zs))
        });
        g.bench_with_input(BenchmarkId::new("bootstrap_1_thread", n), &n, |b, _| {
            b.iter(|| pools[0].install(|| run(black_box(options), &zs)))
        });
        g.bench_with_input(BenchmarkId::new("bootstrap_2_threads", n), &n, |b, _| {
            b.iter(|| pools[1].install(|| run(black_box(options), &zs)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
