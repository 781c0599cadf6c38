//! Output-error bench: a 2000-step pendulum with a biased displacement sensor and a gyro
//! with a scale-factor error, four initial-state entries free. The baseline is one plain
//! `f64` integration of the record (what any simulation of the model costs); against it,
//! one cost-gradient-information evaluation (`output_error_cost`: the four seeded dual
//! passes) and the whole fit from a far start.

use criterion::{Criterion, criterion_group, criterion_main};
use kalman::DynDims;
use kalman::faer::Mat;
use kalman::fit::{OutputErrorOptions, output_error, output_error_cost};
use kalman::nonlinear::{GenericModel, Scalar};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::hint::black_box;

/// x = (φ, ω, b, s): a damped pendulum under a known torque (symplectic Euler, Δt = 0.05 s);
/// the displacement sensor reads `sin φ + b`, the gyro `(1 + s) ω`.
struct Pendulum;
const DT: f64 = 0.05;

impl GenericModel for Pendulum {
    fn f<T: Scalar>(&self, x: &[T], u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        let torque = u.map_or(0.0, |u| u[0]);
        let w = x[1] + (x[0].sin() * -9.81 - x[1] * 0.1 + torque) * DT;
        out[0] = x[0] + w * DT;
        out[1] = w;
        out[2] = x[2];
        out[3] = x[3];
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0].sin() + x[2];
        out[1] = x[1] * (x[3] + 1.0);
    }
    fn q(&self, _k: usize, out: &mut [f64]) {
        out.fill(0.0);
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&[4e-4, 0.0, 0.0, 2.5e-3]);
    }
}

/// One `f64` integration of the record: the outputs, N×2.
fn integrate(x0: &[f64], u: &Mat<f64>) -> Mat<f64> {
    let mut x = x0.to_vec();
    let mut next = x.clone();
    let mut y = [0.0; 2];
    let mut out = Mat::zeros(u.nrows(), 2);
    for k in 0..u.nrows() {
        Pendulum.h::<f64>(&x, k, &mut y);
        out[(k, 0)] = y[0];
        out[(k, 1)] = y[1];
        Pendulum.f::<f64>(&x, Some(&[u[(k, 0)]]), k, &mut next);
        std::mem::swap(&mut x, &mut next);
    }
    out
}

fn bench(c: &mut Criterion) {
    let steps = 2000;
    let truth = [0.5, 0.0, 0.05, 0.02];
    let start = [0.3, 0.2, 0.0, 0.0];
    let free = [0, 1, 2, 3];
    let dims = DynDims::new(4, 2, 1).expect("dims");
    let u = Mat::from_fn(steps, 1, |k, _| 0.3 * (0.5 * k as f64 * DT).sin());
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let mut z = integrate(&truth, &u);
    for k in 0..steps {
        z[(k, 0)] += 0.02 * rng.sample::<f64, _>(StandardNormal);
        z[(k, 1)] += 0.05 * rng.sample::<f64, _>(StandardNormal);
    }
    let options = OutputErrorOptions::default();
    let fit = output_error(
        &Pendulum,
        dims,
        &start,
        &free,
        z.as_ref(),
        Some(u.as_ref()),
        &options,
    )
    .expect("fit");
    eprintln!(
        "pendulum 2000: θ̂ = {:?}, σ = {:?}, {} iterations, converged {}",
        fit.estimate, fit.std, fit.iterations, fit.converged
    );
    let mut g = c.benchmark_group("output_error_pendulum2000");
    g.sample_size(20);
    g.bench_function("baseline_integration", |b| {
        b.iter(|| integrate(black_box(&start), &u))
    });
    g.bench_function("cost_gradient_information", |b| {
        b.iter(|| {
            output_error_cost(
                &Pendulum,
                dims,
                black_box(&start),
                &free,
                z.as_ref(),
                Some(u.as_ref()),
            )
            .expect("cost")
        })
    });
    g.bench_function("fit_from_far_start", |b| {
        b.iter(|| {
            output_error(
                &Pendulum,
                dims,
                black_box(&start),
                &free,
                z.as_ref(),
                Some(u.as_ref()),
                &options,
            )
            .expect("fit")
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
