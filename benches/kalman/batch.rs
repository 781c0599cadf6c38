//! Criterion benches of the batch filter (`kalman::batch`): 2000 series of 500 steps of one
//! model, m = 1 with 10 % of the entries missing, at n = 2 (constant velocity) and n = 4 (two
//! such axes, one measured), on one thread:
//! - `baseline_scalar_fixed`: the scalar filter on the fixed-size path, series by series;
//! - `batch`: `BatchFilter::run` over all of them (Joseph form, as the baseline), on a rayon
//!   pool of one thread (the benches build kalman with `parallel`);
//! - `batch_2_threads`: the same on a pool of two.
//!
//! The ratio is the batch filter's cost per series step against the scalar filter's.
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kalman::batch::BatchFilter;
use kalman::{CovarianceForm, DynDims, Filter, FixedDims, MatrixInput, Model};

const SERIES: usize = 2000;
const STEPS: usize = 500;

/// F, H, Q, R of a constant-velocity model with `axes` axes (n = 2·axes), the first
/// position measured.
fn matrices(
    axes: usize,
) -> (
    faer::Mat<f64>,
    faer::Mat<f64>,
    faer::Mat<f64>,
    faer::Mat<f64>,
) {
    let n = 2 * axes;
    let dt = 0.1;
    let f = faer::Mat::from_fn(n, n, |i, j| {
        if i == j {
            1.0
        } else if j == i + 1 && i % 2 == 0 {
            dt
        } else {
            0.0
        }
    });
    let h = faer::Mat::from_fn(1, n, |_, j| if j == 0 { 1.0 } else { 0.0 });
    let q = faer::Mat::from_fn(n, n, |i, j| {
        let (a, b) = (i / 2, j / 2);
        if a != b {
            return 0.0;
        }
        match (i % 2, j % 2) {
            (0, 0) => dt * dt * dt / 3.0,
            (1, 1) => dt,
            _ => dt * dt / 2.0,
        }
    });
    let r = faer::Mat::from_fn(1, 1, |_, _| 0.25);
    (f, h, q, r)
}

/// The measurements, (series, steps) row-major: a sinusoid per series, every tenth missing.
fn data() -> Vec<f64> {
    (0..SERIES * STEPS)
        .map(|i| {
            if i % 10 == 3 {
                f64::NAN
            } else {
                (0.01 * i as f64).sin() + 0.1 * (i % 7) as f64
            }
        })
        .collect()
}

fn scalar<const N: usize>(
    model: &Model<FixedDims<N, 1, 0>>,
    p0: &impl MatrixInput,
    zs: &[f64],
) -> f64 {
    let mut acc = 0.0;
    for s in 0..SERIES {
        let mut kf = Filter::new(model.clone(), &[0.0; N], p0, CovarianceForm::Joseph).unwrap();
        for k in 0..STEPS {
            kf.step(&[zs[s * STEPS + k]], None).unwrap();
        }
        acc += kf.state()[0];
    }
    acc
}

fn bench_batch(c: &mut Criterion) {
    let zs = data();
    let mut group = c.benchmark_group("batch_2000x500");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(6))
        .warm_up_time(Duration::from_secs(1));
    for axes in [1, 2] {
        let n = 2 * axes;
        let (f, h, q, r) = matrices(axes);
        let p0 = faer::Mat::<f64>::identity(n, n);
        let dynamic = Model::new(DynDims::new(n, 1, 0).unwrap(), &f, &h, &q, &r).unwrap();
        let batch = BatchFilter::new(&dynamic, CovarianceForm::Joseph).unwrap();
        let x0 = vec![0.0; n];
        group.bench_with_input(BenchmarkId::new("baseline_scalar_fixed", n), &n, |b, _| {
            b.iter(|| match axes {
                1 => {
                    let m = Model::new(FixedDims::<2, 1, 0>::new(), &f, &h, &q, &r).unwrap();
                    black_box(scalar(&m, &p0, black_box(&zs)))
                }
                _ => {
                    let m = Model::new(FixedDims::<4, 1, 0>::new(), &f, &h, &q, &r).unwrap();
                    black_box(scalar(&m, &p0, black_box(&zs)))
                }
            })
        });
        for (name, threads) in [("batch", 1), ("batch_2_threads", 2)] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            group.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| {
                    pool.install(|| black_box(batch.run(&x0, &p0, black_box(&zs), SERIES).unwrap()))
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench_batch);
criterion_main!(benches);
