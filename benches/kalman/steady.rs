//! Criterion benches of the steady-state machinery (issue 5):
//! - `gain_schedule/(7,2)`: one step of [`ScheduledFilter`] on the fixed-size path against
//!   one step of the full fixed-size filter (`baseline_full_filter`), same data;
//! - `dare/n`: the DARE solver at (n, m) = (7, 2), (50, 10), (200, 20) against the engine's
//!   filter iterated from P0 = I until P_{k+1|k} settles (`baseline_iterated_filter`; the
//!   number of steps it needs is printed once per size).
//!
//! Deterministic problem: `benches/kalman/common/mod.rs`, shared with `benches/kalman/step.rs`.
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

mod common;

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::Mat;
use kalman::riccati::Dare;
use kalman::schedule::{GainSchedule, ScheduleOptions};
use kalman::{CovarianceForm, DynDims, Filter, FixedDims};

use common::{Problem, model, problem};

fn gain_schedule(c: &mut Criterion) {
    let p = problem(7, 2);
    let mut g = c.benchmark_group("gain_schedule");
    let id = "(7,2)";
    let P0 = Mat::<f64>::identity(7, 7);
    let mut full = Filter::new(
        model(&p, FixedDims::<7, 2>::new()),
        &[0.0; 7],
        &P0,
        CovarianceForm::Joseph,
    )
    .unwrap();
    let mut k = 0usize;
    g.bench_function(BenchmarkId::new("baseline_full_filter", id), |b| {
        b.iter(|| {
            k = (k + 1) % p.z.len();
            black_box(full.step(black_box(&p.z[k]), None).unwrap());
        })
    });
    let sched = GainSchedule::new(
        model(&p, FixedDims::<7, 2>::new()),
        &P0,
        ScheduleOptions::default(),
    )
    .unwrap();
    let mut run = sched.runner(&[0.0; 7]).unwrap();
    let mut k = 0usize;
    g.bench_function(BenchmarkId::new("gain_schedule", id), |b| {
        b.iter(|| {
            k = (k + 1) % p.z.len();
            run.step(black_box(&p.z[k]), None).unwrap();
            black_box(run.state()[0]);
        })
    });
    g.finish();
}

/// Iterates the filter from P0 = I until max|P_{k+1|k} − P_{k|k−1}| ≤ 1e-12·max|P|.
fn iterate(p: &Problem) -> (Mat<f64>, usize) {
    let (n, m) = (p.F.nrows(), p.H.nrows());
    let P0 = Mat::<f64>::identity(n, n);
    let mut f = Filter::new(
        model(p, DynDims::new(n, m, 0).unwrap()),
        &vec![0.0; n],
        &P0,
        CovarianceForm::Joseph,
    )
    .unwrap();
    let z = vec![0.0; m];
    let mut prev = P0;
    for k in 1..100_000 {
        f.step(&z, None).unwrap();
        let P = f.predicted_covariance();
        let (mut d, mut big) = (0.0_f64, 0.0_f64);
        for j in 0..n {
            for i in 0..n {
                d = d.max((P[(i, j)] - prev[(i, j)]).abs());
                big = big.max(P[(i, j)].abs());
            }
        }
        prev.copy_from(P);
        if d <= 1e-12 * big {
            return (prev, k);
        }
    }
    (prev, 100_000)
}

fn dare_vs_iteration(c: &mut Criterion) {
    let mut g = c.benchmark_group("dare");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for (n, m) in [(7, 2), (50, 10), (200, 20)] {
        let p = problem(n, m);
        let (P, steps) = iterate(&p);
        let ss = Dare::new(&p.F, &p.H, &p.Q, &p.R)
            .and_then(|p| p.solve())
            .unwrap();
        let d = (&P - &ss.prior).norm_l2() / ss.prior.norm_l2();
        eprintln!(
            "dare n={n}: iterated filter converged in {steps} steps, {} doubling steps, relative difference {d:.1e}",
            ss.iterations
        );
        g.bench_with_input(
            BenchmarkId::new("baseline_iterated_filter", n),
            &p,
            |b, p| b.iter(|| black_box(iterate(p).1)),
        );
        g.bench_with_input(BenchmarkId::new("dare", n), &p, |b, p| {
            b.iter(|| {
                black_box(
                    Dare::new(&p.F, &p.H, &p.Q, &p.R)
                        .and_then(|p| p.solve())
                        .unwrap()
                        .iterations,
                )
            })
        });
    }
    g.finish();
}

criterion_group!(benches, gain_schedule, dare_vs_iteration);
criterion_main!(benches);
