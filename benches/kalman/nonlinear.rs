//! Criterion benches of one nonlinear step (update + predict) on the fixed-size path at
//! (n, m) = (4, 2): a constant-velocity target seen in range and bearing, 64 measurements of
//! a circular track cycled (no jump at the wrap, no RNG). The baseline in the same group is
//! the EKF with hand-written Jacobians; the others are the EKF with forward-mode AD
//! Jacobians (target: within 2× of the baseline), the iterated EKF, and the UKF with
//! Merwe's scaled and the cubature sigma points, each beside the square-root UKF on the same
//! set (target: within 1.5× of the plain step). `benches/kalman/filterpy_ukf_step.py` builds the
//! same problem and times FilterPy's UKF on it.
//!
//! The group `manifold_step` times the UKF on the attitude model of the tests (a unit
//! quaternion and a gyro bias: 7 stored, 6 tangent, six vector rows every fifth step) against
//! the baseline of a plain 6-state UKF on the same flight whose attitude is a rotation
//! vector θ (f and h map it through exp and log: the same arithmetic per sigma point, with
//! `+`/`−` in place of `⊞`/`⊟`). Target: the manifold step within 2× of the baseline.
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kalman::FixedDims;
use kalman::nonlinear::{AutoDiff, Ekf, EkfUpdate, FnModel, SigmaPoints, SqrtUkf, Ukf, quaternion};

// The test models: the bench uses range and bearing only.
#[allow(dead_code)]
#[path = "../../kalman/tests/nonlinear/models.rs"]
mod models;

// The attitude model and its simulated flights.
#[allow(dead_code)]
#[path = "../../kalman/tests/nonlinear/attitude.rs"]
mod attitude;

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

/// The rotation-vector chart of the attitude model: a 6-vector `(θ, b)`.
fn chart_f(x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]) {
    let q = quaternion::exp([x[0], x[1], x[2]]);
    let stored = [q[0], q[1], q[2], q[3], x[3], x[4], x[5]];
    let mut next = [0.0; 7];
    attitude::kinematics(&stored, u, k, &mut next);
    let theta = quaternion::log([next[0], next[1], next[2], next[3]]);
    out[..3].copy_from_slice(&theta);
    out[3..].copy_from_slice(&next[4..]);
}

fn chart_h(x: &[f64], k: usize, out: &mut [f64]) {
    let q = quaternion::exp([x[0], x[1], x[2]]);
    attitude::vectors(&[q[0], q[1], q[2], q[3], x[3], x[4], x[5]], k, out);
}

fn manifold(c: &mut Criterion) {
    let mut g = c.benchmark_group("manifold_step");
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(2));
    let f = attitude::flight(1);
    let set = SigmaPoints::merwe(0.5, 2.0, 0.0);
    let n = attitude::STEPS;
    let plain_d = FixedDims::<6, 6, 3>::new();
    let chart = FnModel::new(plain_d, chart_f, chart_h, &attitude::q(), &attitude::r()).unwrap();
    let log0 = quaternion::log([f.x0[0], f.x0[1], f.x0[2], f.x0[3]]);
    let x0 = [log0[0], log0[1], log0[2], f.x0[4], f.x0[5], f.x0[6]];
    let mut plain = Ukf::new(plain_d, chart, &x0, &attitude::p0(), set).unwrap();
    let d = FixedDims::<6, 6, 3, 7>::new();
    let mut on = Ukf::new(d, attitude::model(d), &f.x0, &attitude::p0(), set).unwrap();
    let label = "(6,6)";
    // Each filter restarts at the end of the flight, so every timed step is one of the
    // same 400 (80 with a vector fix).
    let mut k = 0;
    g.bench_function(
        BenchmarkId::new("baseline_ukf_rotation_vector", label),
        |b| {
            b.iter(|| {
                k = (k + 1) % n;
                if k == 0 {
                    plain.reset(&x0, &attitude::p0()).unwrap();
                }
                black_box(plain.step(black_box(&f.z[k]), Some(&f.gyro[k])).unwrap());
            })
        },
    );
    let mut k = 0;
    g.bench_function(BenchmarkId::new("ukf_quaternion_manifold", label), |b| {
        b.iter(|| {
            k = (k + 1) % n;
            if k == 0 {
                on.reset(&f.x0, &attitude::p0()).unwrap();
            }
            black_box(on.step(black_box(&f.z[k]), Some(&f.gyro[k])).unwrap());
        })
    });
    g.finish();
}

criterion_group!(benches, nonlinear, manifold);
criterion_main!(benches);
