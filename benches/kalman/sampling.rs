//! Criterion benches of continuous–discrete filtering (`kalman::sampling`): a 1000-row record
//! of a 2-D constant-velocity target (n = 4) with three channels (m = 3), filtered through a
//! `Sampler` with `step_with`, in three clocks:
//! - `baseline_constant_dt`: one interval (every step a cache hit);
//! - `quantised_100`: 100 distinct intervals, repeating (one discretisation each);
//! - `every_interval_distinct`: 1000 distinct intervals (every step discretises).
//!
//! Each iteration filters the whole record from the same prior, so the ratios are the cost
//! of the time stamps per record.
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kalman::sampling::{ContinuousModel, Sampler};
use kalman::{CovarianceForm, Filter};

const ROWS: usize = 1000;

fn cv() -> ContinuousModel {
    ContinuousModel::new(
        &[
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
        ],
        &[
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ],
        &[
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.5, 0.0],
            [0.0, 0.0, 0.0, 0.5],
        ],
        &[[4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, 0.04]],
    )
    .unwrap()
}

/// The intervals of a clock with `distinct` values around 0.1 s (0 = every interval its own).
fn intervals(distinct: usize) -> Vec<f64> {
    (0..ROWS)
        .map(|k| {
            let i = if distinct == 0 { k } else { k % distinct };
            0.05 + 0.1 * (i as f64 + 0.5) / (if distinct == 0 { ROWS } else { distinct }) as f64
        })
        .collect()
}

fn record() -> Vec<[f64; 3]> {
    (0..ROWS)
        .map(|k| {
            let t = k as f64 * 0.1;
            [300.0 * t, 20.0 * t, 300.0]
        })
        .collect()
}

fn irregular(c: &mut Criterion) {
    let z = record();
    let mut g = c.benchmark_group("irregular_record");
    g.measurement_time(Duration::from_secs(5));
    let P0 = [
        [100.0, 0.0, 0.0, 0.0],
        [0.0, 100.0, 0.0, 0.0],
        [0.0, 0.0, 400.0, 0.0],
        [0.0, 0.0, 0.0, 400.0],
    ];
    let id = "(4,3)";
    for (name, dts) in [
        ("baseline_constant_dt", vec![0.1; ROWS]),
        ("quantised_100", intervals(100)),
        ("every_interval_distinct", intervals(0)),
    ] {
        let mut sampler = Sampler::new(cv(), 256).unwrap();
        let mut kf = Filter::new(
            sampler.at(0.1).unwrap().clone(),
            &[0.0, 0.0, 300.0, 20.0],
            &P0,
            CovarianceForm::Joseph,
        )
        .unwrap();
        g.bench_function(BenchmarkId::new(name, id), |b| {
            b.iter(|| {
                kf.reset(&[0.0, 0.0, 300.0, 20.0], &P0).unwrap();
                for k in 0..ROWS {
                    let model = sampler.at(dts[k]).unwrap();
                    black_box(kf.step_with(model, black_box(&z[k]), None).unwrap());
                }
                black_box(kf.state()[0]);
            })
        });
    }
    g.finish();
}

criterion_group!(benches, irregular);
criterion_main!(benches);
