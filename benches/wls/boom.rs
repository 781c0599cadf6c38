//! Criterion benches of one boom-estimator cycle: the direct inversion (2)–(3) is the in-run
//! baseline; the WLS (9)–(10) cycle on fixed-size 6×3 matrices is compared with it.
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wls::boom::{BoomConfig, BoomEstimator, BoomMethod, BoomSolver, RateWeight};

/// Seeded readings of a slow turn through 40–80° with ±0.02 m/s² uniform noise.
fn readings() -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let (g, r) = (9.8, 25.0);
    (0..4096)
        .map(|k| {
            let a = (40.0 + 40.0 * f64::from(k) / 4096.0).to_radians();
            let e = 0.003;
            [
                g * a.sin() + rng.random_range(-0.02..0.02),
                g * a.cos() + e * r + rng.random_range(-0.02..0.02),
                rng.random_range(-0.02..0.02),
            ]
        })
        .collect()
}

fn bench_cycle(c: &mut Criterion, name: &str, config: BoomConfig, data: &[[f64; 3]]) {
    c.benchmark_group("boom_cycle").bench_function(name, |b| {
        let Ok(mut est) = BoomEstimator::new(config.clone()) else {
            return;
        };
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % data.len();
            let [ax, ay, az] = data[i];
            black_box(est.update(black_box(ax), black_box(ay), black_box(az)))
        });
    });
}

fn boom(c: &mut Criterion) {
    let data = readings();
    let base = BoomConfig::default();
    let variants = [
        (
            "baseline_direct_inversion",
            BoomConfig {
                method: BoomMethod::Direct,
                ..base.clone()
            },
        ),
        ("wls_cycle", base.clone()),
        (
            "wls_cycle_single_solve",
            BoomConfig {
                rate_weight: RateWeight::PreviousCycle,
                ..base.clone()
            },
        ),
        (
            "wls_cycle_no_condition",
            BoomConfig {
                compute_condition: false,
                ..base.clone()
            },
        ),
        (
            "wls_cycle_normal_equations",
            BoomConfig {
                solver: BoomSolver::NormalEquations,
                ..base.clone()
            },
        ),
        (
            "linear3_cycle",
            BoomConfig {
                method: BoomMethod::Linear3,
                ..base
            },
        ),
    ];
    for (name, config) in variants {
        bench_cycle(c, name, config, &data);
    }
}

criterion_group!(benches, boom);
criterion_main!(benches);
