//! Flight-path bench: the filter–smoother over a 3-minute simulated flight (IMU at 100 Hz,
//! air data and AHRS at 25 Hz, GNSS at 5 Hz: the union grid has about 28 000 steps, 21
//! states). The baseline is one `f64` integration of the kinematic model over the grid
//! (what any simulation of the record costs); against it, one gated EKF and extended RTS
//! pass, and the iterated smoother as the scenario runs it.

use criterion::{Criterion, criterion_group, criterion_main};
use kalman::nonlinear::GenericModel;
use scenarios::flightpath::data::Grid;
use scenarios::flightpath::estimate::{self, SMOOTHER_ITERATIONS};
use scenarios::flightpath::model::FlightModel;
use scenarios::flightpath::parameters::FlightPathParams;
use scenarios::flightpath::simulation::{flight_data, noise_model};
use scenarios::flightpath::smoother;
use std::hint::black_box;

/// One `f64` integration of the augmented model over the grid from `x0`.
fn integrate(model: &FlightModel, x0: &[f64]) -> Vec<f64> {
    let mut x = x0.to_vec();
    let mut next = x.clone();
    for k in 0..model.steps() {
        model.f::<f64>(&x, None, k, &mut next);
        std::mem::swap(&mut x, &mut next);
    }
    x
}

fn bench(c: &mut Criterion) {
    let mut p = FlightPathParams::default();
    p.flight.duration_s = 180.0;
    let rec = sensors::flight::simulate(&p.flight, &mut sensors::seeded_rng(2026)).expect("flight");
    let data = flight_data(&rec);
    let full = data.grid();
    let noise = noise_model(&p.flight.noise_si(), p.flight.imu.rate_hz);
    let s = estimate::settings(&data, &full, &noise, &p);
    let grid: Grid = estimate::consumed(&data, &full);
    let model = FlightModel::new(&grid, &noise, true);
    eprintln!("flightpath 180 s: {} grid steps", grid.t.len());
    let mut g = c.benchmark_group("flightpath_180s");
    g.sample_size(10);
    g.bench_function("baseline_integration", |b| {
        b.iter(|| integrate(&model, black_box(&s.x0)))
    });
    g.bench_function("ekf_rts_pass", |b| {
        b.iter(|| smoother::run(black_box(&grid), &s, &[]).expect("pass"))
    });
    g.bench_function("iterated_smoother", |b| {
        b.iter(|| {
            estimate::filter_smoother(black_box(&grid), &s, SMOOTHER_ITERATIONS, &[])
                .expect("iterated")
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
