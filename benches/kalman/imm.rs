//! Criterion bench of one IMM step with three UKF modes on the fixed-size path at
//! (n, m) = (4, 2): the range-and-bearing target of the nonlinear bench, the modes differing
//! in their acceleration intensity (0.05, 0.5 and 5 m²/s³). The baseline in the same group
//! is three plain UKF steps of the same three filters; the target is the IMM step within
//! 4× the baseline (the IMM adds an update–mix–predict split, the mode probabilities, the
//! mixing and the combined estimate over three 4-state modes).
#![allow(non_snake_case, missing_docs, clippy::unwrap_used)]

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kalman::FixedDims;
use kalman::imm::{Embedding, Imm, Mode};
use kalman::nonlinear::{SigmaPoints, Ukf};

#[allow(dead_code)]
#[path = "../../kalman/tests/nonlinear/models.rs"]
mod models;

mod track;

use models::{Hand, RangeBearing};
use track::{P0, X0, measurements};

const QS: [f64; 3] = [0.05, 0.5, 5.0];

fn model(q: f64) -> RangeBearing {
    RangeBearing {
        dt: 1.0,
        q,
        sr: 0.5,
        sb: 0.01,
    }
}

fn ukf(q: f64) -> Ukf<FixedDims<4, 2>, Hand<RangeBearing>> {
    let d = FixedDims::<4, 2>::new();
    Ukf::new(
        d,
        Hand(model(q)),
        &X0,
        &P0,
        SigmaPoints::merwe(0.5, 2.0, -1.0),
    )
    .unwrap()
}

fn imm(c: &mut Criterion) {
    let mut g = c.benchmark_group("imm_step");
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(2));
    let zs = measurements();
    let label = "3 UKF (4,2)";
    let mut k = 0;
    let mut three = QS.map(ukf);
    g.bench_function(BenchmarkId::new("baseline_three_ukf_steps", label), |b| {
        b.iter(|| {
            k = (k + 1) % zs.len();
            for f in &mut three {
                black_box(f.step(black_box(&zs[k]), None).unwrap());
            }
        })
    });
    let modes: Vec<(Box<dyn Mode>, Embedding)> = QS
        .iter()
        .map(|&q| (Box::new(ukf(q)) as Box<dyn Mode>, Embedding::identity(4)))
        .collect();
    let t = [[0.9, 0.05, 0.05], [0.05, 0.9, 0.05], [0.05, 0.05, 0.9]];
    let mut f = Imm::new(modes, &t, &[1.0 / 3.0, 1.0 / 3.0, 1.0 - 2.0 / 3.0]).unwrap();
    g.bench_function(BenchmarkId::new("imm_three_ukf_modes", label), |b| {
        b.iter(|| {
            k = (k + 1) % zs.len();
            black_box(f.step(black_box(&zs[k]), None).unwrap());
        })
    });
    g.finish();
}

criterion_group!(benches, imm);
criterion_main!(benches);
