//! Output-error bench: a 2000-step pendulum with a biased displacement sensor and a gyro
//! with a scale-factor error, four initial-state entries free. The baseline is one plain
//! `f64` integration of the record (what any simulation of the model costs); against it,
//! one cost-gradient-information evaluation (`output_error_cost`: the four seeded dual
//! passes) and the whole fit from a far start.

use criterion::{Criterion, criterion_group, criterion_main};
use kalman::DynDims;
use kalman::faer::Mat;
use kalman::fit::{OutputErrorOptions, output_error, output_error_cost};
use kalman::nonlinear::GenericModel;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::hint::black_box;

// The output-error tests' pendulum, its truth, start and torque.
#[path = "../../kalman/tests/fit/pendulum.rs"]
mod pendulum;

use pendulum::{Pendulum, START, TRUTH, torque};

/// The step, s.
const DT: f64 = 0.05;
/// The tests' pendulum (symplectic Euler) at Δt = 0.05 s with the sensors' noise variances.
const PENDULUM: Pendulum = Pendulum {
    dt: DT,
    r: [4e-4, 2.5e-3],
};

/// One `f64` integration of the record: the outputs, N×2.
fn integrate(x0: &[f64], u: &Mat<f64>) -> Mat<f64> {
    let mut x = x0.to_vec();
    let mut next = x.clone();
    let mut y = [0.0; 2];
    let mut out = Mat::zeros(u.nrows(), 2);
    for k in 0..u.nrows() {
        PENDULUM.h::<f64>(&x, k, &mut y);
        out[(k, 0)] = y[0];
        out[(k, 1)] = y[1];
        PENDULUM.f::<f64>(&x, Some(&[u[(k, 0)]]), k, &mut next);
        std::mem::swap(&mut x, &mut next);
    }
    out
}

fn bench(c: &mut Criterion) {
    let steps = 2000;
    let free = [0, 1, 2, 3];
    let dims = DynDims::new(4, 2, 1).expect("dims");
    let u = torque(steps, DT);
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let mut z = integrate(&TRUTH, &u);
    for k in 0..steps {
        z[(k, 0)] += 0.02 * rng.sample::<f64, _>(StandardNormal);
        z[(k, 1)] += 0.05 * rng.sample::<f64, _>(StandardNormal);
    }
    let options = OutputErrorOptions::default();
    let cost = |x0: &[f64]| {
        output_error_cost(&PENDULUM, dims, x0, &free, z.as_ref(), Some(u.as_ref())).expect("cost")
    };
    let fit = |x0: &[f64]| {
        output_error(
            &PENDULUM,
            dims,
            x0,
            &free,
            z.as_ref(),
            Some(u.as_ref()),
            &options,
        )
        .expect("fit")
    };
    let first = fit(&START);
    eprintln!(
        "pendulum 2000: θ̂ = {:?}, σ = {:?}, {} iterations, converged {}",
        first.estimate, first.std, first.iterations, first.converged
    );
    let mut g = c.benchmark_group("output_error_pendulum2000");
    g.sample_size(20);
    g.bench_function("baseline_integration", |b| {
        b.iter(|| integrate(black_box(&START), &u))
    });
    g.bench_function("cost_gradient_information", |b| {
        b.iter(|| cost(black_box(&START)))
    });
    g.bench_function("fit_from_far_start", |b| b.iter(|| fit(black_box(&START))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
