//! Criterion benches of one nonlinear step (update + predict) on the fixed-size path at
//! (n, m) = (4, 2): a constant-velocity target seen in range and bearing, 64 measurements of
//! a circular track cycled (no jump at the wrap, no RNG). The baseline in the same group is
//! the EKF with hand-written Jacobians; the others are the EKF with forward-mode AD
//! Jacobians (target: within 2× of the baseline), the iterated EKF, and the UKF with
//! Merwe's scaled and the cubature sigma points. `benches/filterpy_ukf_step.py` builds the
//! same problem and times FilterPy's UKF on it.
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kalman::FixedDims;
use kalman::nonlinear::{
    AutoDiff, Ekf, EkfUpdate, GenericModel, Jacobians, NonlinearModel, Scalar, SigmaPoints, Ukf,
};

const DT: f64 = 1.0;

fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
}

/// x = (px, vx, py, vy), constant velocity; z = (range, bearing) from the origin.
#[derive(Clone, Debug)]
struct RangeBearing;

impl GenericModel for RangeBearing {
    fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        out[0] = x[0] + x[1] * DT;
        out[1] = x[1];
        out[2] = x[2] + x[3] * DT;
        out[3] = x[3];
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = (x[0] * x[0] + x[2] * x[2]).sqrt();
        out[1] = x[2].atan2(x[0]);
    }
    fn q(&self, _k: usize, out: &mut [f64]) {
        let q = 0.5;
        out.fill(0.0);
        for b in [0, 2] {
            out[b + b * 4] = q * DT.powi(3) / 3.0;
            out[b + 1 + b * 4] = q * DT * DT / 2.0;
            out[b + (b + 1) * 4] = q * DT * DT / 2.0;
            out[b + 1 + (b + 1) * 4] = q * DT;
        }
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&[0.25, 0.0, 0.0, 1e-4]);
    }
    fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        out[0] = a[0] - b[0];
        out[1] = wrap(a[1] - b[1]);
    }
}

/// The same model with hand-written Jacobians.
#[derive(Clone, Debug)]
struct Hand;

impl NonlinearModel for Hand {
    fn f(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]) {
        RangeBearing.f(x, u, k, out);
    }
    fn h(&mut self, x: &[f64], k: usize, out: &mut [f64]) {
        RangeBearing.h(x, k, out);
    }
    fn q(&mut self, k: usize, out: &mut [f64]) {
        GenericModel::q(&RangeBearing, k, out);
    }
    fn r(&mut self, k: usize, out: &mut [f64]) {
        GenericModel::r(&RangeBearing, k, out);
    }
    fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        GenericModel::residual(&RangeBearing, a, b, out);
    }
}

impl Jacobians for Hand {
    fn f_jacobian(&mut self, _x: &[f64], _u: Option<&[f64]>, _k: usize, jac: &mut [f64]) {
        jac.fill(0.0);
        for i in 0..4 {
            jac[i + i * 4] = 1.0;
        }
        jac[4] = DT;
        jac[2 + 3 * 4] = DT;
    }
    fn h_jacobian(&mut self, x: &[f64], _k: usize, jac: &mut [f64]) {
        let (px, py) = (x[0], x[2]);
        let r2 = px * px + py * py;
        let r = r2.sqrt();
        jac.fill(0.0);
        jac[0] = px / r;
        jac[1] = -py / r2;
        jac[4] = py / r;
        jac[5] = px / r2;
    }
}

/// 64 measurements of a circle of radius 50 m centred 200 m out, one turn per 64 steps,
/// with a deterministic ripple standing in for noise (the FilterPy script's data).
fn measurements() -> Vec<[f64; 2]> {
    (0..64)
        .map(|k| {
            let t = 2.0 * std::f64::consts::PI * k as f64 / 64.0;
            let (px, py) = (200.0 + 50.0 * t.cos(), 50.0 * t.sin());
            [
                px.hypot(py) + 0.3 * (1.7 * k as f64).sin(),
                py.atan2(px) + 0.005 * (2.3 * k as f64).cos(),
            ]
        })
        .collect()
}

const X0: [f64; 4] = [250.0, 0.0, 0.0, 4.9];
const P0: [[f64; 4]; 4] = [
    [10.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 10.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

fn nonlinear(c: &mut Criterion) {
    let mut g = c.benchmark_group("nonlinear_step");
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(2));
    let zs = measurements();
    let d = FixedDims::<4, 2>::new();
    let label = "(4,2)";
    let mut k = 0;
    let mut hand = Ekf::new(d, Hand, &X0, &P0, EkfUpdate::Extended).unwrap();
    g.bench_function(
        BenchmarkId::new("baseline_ekf_hand_jacobians", label),
        |b| {
            b.iter(|| {
                k = (k + 1) % zs.len();
                black_box(hand.step(black_box(&zs[k]), None).unwrap());
            })
        },
    );
    let mut ad = Ekf::new(
        d,
        AutoDiff::new(RangeBearing, d),
        &X0,
        &P0,
        EkfUpdate::Extended,
    )
    .unwrap();
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
    let mut iekf = Ekf::new(d, Hand, &X0, &P0, it).unwrap();
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
        let mut ukf = Ukf::new(d, Hand, &X0, &P0, set).unwrap();
        g.bench_function(BenchmarkId::new(name, label), |b| {
            b.iter(|| {
                k = (k + 1) % zs.len();
                black_box(ukf.step(black_box(&zs[k]), None).unwrap());
            })
        });
    }
    g.finish();
}

criterion_group!(benches, nonlinear);
criterion_main!(benches);
