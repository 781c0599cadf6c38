//! Criterion benches of one nonlinear step (update + predict) on the fixed-size path at
//! (n, m) = (4, 2): a constant-velocity target seen in range and bearing, 64 measurements of
//! a circular track cycled (no jump at the wrap, no RNG). The baseline in the same group is
//! the EKF with hand-written Jacobians; the others are the EKF with forward-mode AD
//! Jacobians (target: within 2× of the baseline), the iterated EKF, and the UKF with
//! Merwe's scaled and the cubature sigma points, each beside the square-root UKF on the same
//! set (target: within 1.5× of the plain step). `benches/kalman/filterpy_ukf_step.py` builds the
//! same problem and times FilterPy's UKF on it.
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kalman::FixedDims;
use kalman::nonlinear::{AutoDiff, Ekf, EkfUpdate, SigmaPoints, SqrtUkf, Ukf};

// The test models: the bench uses range and bearing only.
#[allow(dead_code)]
#[path = "../../kalman/tests/nonlinear/models.rs"]
mod models;

mod track;

use models::{Hand, RangeBearing};
use track::{P0, X0, measurements};

/// The FilterPy script's model: Δt = 1 s, white acceleration of intensity 0.5 m²/s³, range
/// σ 0.5 m, bearing σ 0.01 rad.
const MODEL: RangeBearing = RangeBearing {
    dt: 1.0,
    q: 0.5,
    sr: 0.5,
    sb: 0.01,
};

fn nonlinear(c: &mut Criterion) {
    let mut g = c.benchmark_group("nonlinear_step");
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(2));
    let zs = measurements();
    let d = FixedDims::<4, 2>::new();
    let label = "(4,2)";
    let mut k = 0;
    let mut hand = Ekf::new(d, Hand(MODEL), &X0, &P0, EkfUpdate::Extended).unwrap();
    g.bench_function(
        BenchmarkId::new("baseline_ekf_hand_jacobians", label),
        |b| {
            b.iter(|| {
                k = (k + 1) % zs.len();
                black_box(hand.step(black_box(&zs[k]), None).unwrap());
            })
        },
    );
    let mut ad = Ekf::new(d, AutoDiff::new(d, MODEL), &X0, &P0, EkfUpdate::Extended).unwrap();
    g.bench_function(BenchmarkId::new("ekf_autodiff_jacobians", label), |b| {
        b.iter(|| {
            k = (k + 1) % zs.len();
            black_box(ad.step(black_box(&zs[k]), None).unwrap());
        })
    });
    let it = EkfUpdate::Iterated {
        max_iterations: 5,
        tolerance: 1e-9,
    };
    let mut iekf = Ekf::new(d, Hand(MODEL), &X0, &P0, it).unwrap();
    g.bench_function(BenchmarkId::new("iterated_ekf", label), |b| {
        b.iter(|| {
            k = (k + 1) % zs.len();
            black_box(iekf.step(black_box(&zs[k]), None).unwrap());
        })
    });
    for (name, set) in [
        ("ukf_merwe", SigmaPoints::merwe(0.5, 2.0, -1.0)),
        ("ukf_cubature", SigmaPoints::Cubature),
    ] {
        let mut ukf = Ukf::new(d, Hand(MODEL), &X0, &P0, set).unwrap();
        g.bench_function(BenchmarkId::new(name, label), |b| {
            b.iter(|| {
                k = (k + 1) % zs.len();
                black_box(ukf.step(black_box(&zs[k]), None).unwrap());
            })
        });
        // The square-root UKF on the same problem (target: within 1.5× the plain step).
        let mut sq = SqrtUkf::new(d, Hand(MODEL), &X0, &P0, set).unwrap();
        g.bench_function(BenchmarkId::new(format!("sqrt_{name}"), label), |b| {
            b.iter(|| {
                k = (k + 1) % zs.len();
                black_box(sq.step(black_box(&zs[k]), None).unwrap());
            })
        });
    }
    g.finish();
}

criterion_group!(benches, nonlinear);
criterion_main!(benches);
