//! Fitting benches: MLE (Q diag, R diag) of a 3000-sample local linear trend (compare with
//! `benches/kalman/statsmodels_fit.py` on the same data), and one EM iteration against its
//! baseline, one filter pass plus one RTS smoother pass.
#![allow(non_snake_case)]

use criterion::{Criterion, criterion_group, criterion_main};
use kalman::fit::{Free, MleOptions, Series, StandardMap, Structure, System, em_step, mle};
use kalman::smoother::RtsSmoother;
use kalman::{CovarianceForm, Filter};
use std::hint::black_box;

/// The series both benches use (and `statsmodels_fit.py` rebuilds bit for bit): a local
/// linear trend with σ² 0.5 (level), 0.01 (slope), 4 (measurement), driven by a 64-bit LCG
/// through Box–Muller.
fn llt_series(len: usize) -> Vec<f64> {
    let mut s: u64 = 20_261_127;
    let mut uniform = move || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((s >> 11) as f64 + 0.5) * (1.0 / 9_007_199_254_740_992.0)
    };
    let mut normal = move || {
        let (a, b) = (uniform(), uniform());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    };
    let (mut level, mut slope) = (0.0, 0.1);
    let mut z = Vec::with_capacity(len);
    for _ in 0..len {
        z.push(level + 2.0 * normal());
        level += slope + 0.5f64.sqrt() * normal();
        slope += 0.1 * normal();
    }
    z
}

fn base(z0: f64) -> System {
    System::new(
        &[[1.0, 1.0], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[1.0]],
        &[z0, 0.0],
        &[[10.0, 0.0], [0.0, 1.0]],
    )
    .expect("LLT")
}

fn bench(c: &mut Criterion) {
    let z = llt_series(3000);
    let data = Series::new(&z, 1).expect("series");
    let sys = base(z[0]);
    let map = StandardMap::new(
        sys.clone(),
        Free {
            q: Structure::Diag,
            r: Structure::Diag,
            ..Free::default()
        },
    )
    .expect("map");
    let theta0 = map.theta_of(&sys, Some(&data));
    let fit = mle(&map, theta0.clone(), &data, &MleOptions::default()).expect("fit");
    eprintln!(
        "LLT 3000: ln L = {:.6}, R = {:.6}, Q = diag({:.6}, {:.6}), {} iterations, converged {}",
        fit.loglik,
        fit.system.r[(0, 0)],
        fit.system.q[(0, 0)],
        fit.system.q[(1, 1)],
        fit.iterations,
        fit.converged
    );
    let mut g = c.benchmark_group("fit_llt3000");
    g.sample_size(10);
    g.bench_function("mle_q_diag_r_diag", |b| {
        b.iter(|| {
            mle(
                &map,
                black_box(theta0.clone()),
                &data,
                &MleOptions::default(),
            )
            .expect("fit")
        })
    });
    g.finish();

    let theta = fit.theta.clone();
    let model = fit.system.model().expect("model");
    let mut g = c.benchmark_group("em_iteration_llt3000");
    g.sample_size(20);
    g.bench_function("baseline_filter_plus_smoother", |b| {
        b.iter(|| {
            let mut f = Filter::new(
                model.clone(),
                &fit.system.x0,
                &fit.system.p0,
                CovarianceForm::Standard,
            )
            .expect("filter");
            let mut s = RtsSmoother::new();
            for k in 0..z.len() {
                f.step(&z[k..k + 1], None).expect("step");
                s.record(&f).expect("record");
            }
            black_box(s.smooth().expect("smooth"))
        })
    });
    g.bench_function("em_step", |b| {
        b.iter(|| em_step(&map, black_box(&theta), &data).expect("em step"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
