//! The manoeuvring-target Monte Carlo: a target flies straight, turns at a constant rate,
//! and flies straight again, seen in position. An IMM of a constant-velocity linear filter
//! (4 states) and a coordinated-turn UKF with the turn rate as a fifth state, mixed through
//! the embedding of the first into the second, against each model alone; and the IMM
//! smoother against the IMM filter.

use kalman::imm::{Embedding, Imm, ImmRecord, Mode};
use kalman::nonlinear::{FnModel, SigmaPoints, Ukf};
use kalman::{CovarianceForm, DynDims, Filter, FixedDims, Model};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

pub const DT: f64 = 1.0;
/// Measurement noise (m) in x and y.
pub const SIGMA: f64 = 10.0;
const STEPS: usize = 100;

/// The coordinated turn over `DT` of `x = (px, vx, py, vy, ω)` (ω in rad/s; the
/// straight-line limit below |ω| = 1e-9).
pub fn turn(x: &[f64], out: &mut [f64]) {
    let (w, t) = (x[4], DT);
    let (s, c) = if w.abs() < 1e-9 {
        (t, 0.0)
    } else {
        ((w * t).sin() / w, (1.0 - (w * t).cos()) / w)
    };
    let (cw, sw) = ((w * t).cos(), (w * t).sin());
    out[0] = x[0] + s * x[1] - c * x[3];
    out[1] = cw * x[1] - sw * x[3];
    out[2] = x[2] + c * x[1] + s * x[3];
    out[3] = sw * x[1] + cw * x[3];
    out[4] = w;
}

/// White-acceleration noise of one axis with intensity q, ordered (p, v).
fn wa(q: f64) -> [[f64; 2]; 2] {
    let t = DT;
    [
        [q * t.powi(3) / 3.0, q * t * t / 2.0],
        [q * t * t / 2.0, q * t],
    ]
}

/// The constant-velocity filter (px, vx, py, vy) with acceleration intensity `q`.
pub fn cv(q: f64, x0: &[f64], P0: &[[f64; 4]; 4]) -> Filter<FixedDims<4, 2>> {
    let a = wa(q);
    let t = DT;
    let F = [
        [1.0, t, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, t],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let Q = [
        [a[0][0], a[0][1], 0.0, 0.0],
        [a[1][0], a[1][1], 0.0, 0.0],
        [0.0, 0.0, a[0][0], a[0][1]],
        [0.0, 0.0, a[1][0], a[1][1]],
    ];
    let H = [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];
    let R = [[SIGMA * SIGMA, 0.0], [0.0, SIGMA * SIGMA]];
    let model = Model::new(FixedDims::<4, 2>::new(), &F, &H, &Q, &R).expect("CV model");
    Filter::new(model, x0, P0, CovarianceForm::Joseph).expect("CV filter")
}

/// The coordinated-turn UKF (px, vx, py, vy, ω): acceleration intensity `q`, turn-rate
/// random walk of variance `qw` per step.
pub fn ct(
    q: f64,
    qw: f64,
    x0: &[f64],
    P0: &[[f64; 5]; 5],
) -> Ukf<FixedDims<5, 2>, impl kalman::nonlinear::NonlinearModel + Clone + 'static> {
    let a = wa(q);
    let Q = [
        [a[0][0], a[0][1], 0.0, 0.0, 0.0],
        [a[1][0], a[1][1], 0.0, 0.0, 0.0],
        [0.0, 0.0, a[0][0], a[0][1], 0.0],
        [0.0, 0.0, a[1][0], a[1][1], 0.0],
        [0.0, 0.0, 0.0, 0.0, qw],
    ];
    let R = [[SIGMA * SIGMA, 0.0], [0.0, SIGMA * SIGMA]];
    let model = FnModel::new(
        FixedDims::<5, 2>::new(),
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| turn(x, out),
        |x: &[f64], _k: usize, out: &mut [f64]| {
            out[0] = x[0];
            out[1] = x[2];
        },
        &Q,
        &R,
    )
    .expect("CT model");
    Ukf::new(
        FixedDims::<5, 2>::new(),
        model,
        x0,
        P0,
        SigmaPoints::merwe(1.0, 2.0, 0.0),
    )
    .expect("CT UKF")
}

/// The truth: straight for 30 s, a 30 s turn at `W` rad/s, straight again; and its
/// measurements.
const W: f64 = 0.07;

fn trajectory(rng: &mut ChaCha8Rng) -> (Vec<[f64; 5]>, Vec<[f64; 2]>) {
    let mut x = [0.0, 40.0, 0.0, 0.0, 0.0];
    let (mut xs, mut zs) = (Vec::new(), Vec::new());
    for k in 0..STEPS {
        x[4] = if (30..60).contains(&k) { W } else { 0.0 };
        xs.push(x);
        let n1: f64 = StandardNormal.sample(rng);
        let n2: f64 = StandardNormal.sample(rng);
        zs.push([x[0] + SIGMA * n1, x[2] + SIGMA * n2]);
        let mut next = [0.0; 5];
        turn(&x, &mut next);
        x = next;
    }
    (xs, zs)
}

const Q_CV: f64 = 0.05;
const Q_CT: f64 = 0.5;
const QW: f64 = 1e-4;

fn p0_5() -> [[f64; 5]; 5] {
    let d = [100.0, 25.0, 100.0, 25.0, 1e-3];
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { d[i] } else { 0.0 }))
}

fn p0_4() -> [[f64; 4]; 4] {
    let p = p0_5();
    std::array::from_fn(|i| std::array::from_fn(|j| p[i][j]))
}

/// The IMM of the two models, CV embedded as (px, vx, py, vy) of the CT state.
pub fn imm(x0: &[f64; 5]) -> Imm {
    let cv: Box<dyn Mode> = Box::new(cv(Q_CV, &x0[..4], &p0_4()));
    let ct: Box<dyn Mode> = Box::new(ct(Q_CT, QW, x0, &p0_5()));
    Imm::new(
        vec![
            (cv, Embedding::new(5, &[0, 1, 2, 3]).expect("embedding")),
            (ct, Embedding::identity(5)),
        ],
        &[[0.95, 0.05], [0.05, 0.95]],
        &[0.5, 0.5],
    )
    .expect("IMM")
}

fn sq(x: &[f64], t: &[f64; 5]) -> f64 {
    (x[0] - t[0]).powi(2) + (x[2] - t[2]).powi(2)
}

/// Position RMS over every step of `runs` runs: (CV alone, CT alone, IMM, IMM smoother),
/// and the mean turn-mode probability inside and outside the turn.
pub fn monte_carlo(runs: u64) -> ([f64; 4], [f64; 2]) {
    let mut acc = [0.0; 4];
    let mut mode = [0.0; 2];
    let _ = DynDims::new(1, 1, 0);
    for run in 0..runs {
        let mut rng = ChaCha8Rng::seed_from_u64(20_261_202 + run);
        let (xs, zs) = trajectory(&mut rng);
        let p = p0_5();
        let x0: [f64; 5] = std::array::from_fn(|i| {
            let n: f64 = StandardNormal.sample(&mut rng);
            xs[0][i] + if i == 4 { 0.0 } else { p[i][i].sqrt() * n }
        });
        let mut a = cv(Q_CV, &x0[..4], &p0_4());
        let mut b = ct(Q_CT, QW, &x0, &p0_5());
        let mut f = imm(&x0);
        let mut rec = ImmRecord::new();
        for (k, z) in zs.iter().enumerate() {
            a.step(z, None).expect("CV");
            b.step(z, None).expect("CT");
            f.step_recorded(z, None, &mut rec).expect("IMM");
            acc[0] += sq(a.state(), &xs[k]);
            acc[1] += sq(b.state(), &xs[k]);
            acc[2] += sq(f.state(), &xs[k]);
            // Inside the turn after 5 s of it, outside after 10 s of straight flight.
            if (35..60).contains(&k) {
                mode[0] += f.mode_probabilities()[1];
            } else if (70..STEPS).contains(&k) {
                mode[1] += f.mode_probabilities()[1];
            }
        }
        let s = rec.smooth().expect("smoother");
        for (k, t) in xs.iter().enumerate() {
            let x: Vec<f64> = (0..5).map(|i| s.means[(i, k)]).collect();
            acc[3] += sq(&x, t);
        }
    }
    let n = (runs as usize * STEPS) as f64;
    (
        acc.map(|a| (a / n).sqrt()),
        [
            mode[0] / (25.0 * runs as f64),
            mode[1] / (30.0 * runs as f64),
        ],
    )
}

#[test]
fn imm_beats_each_model_and_the_smoother_beats_the_filter() {
    let ([cv, ct, imm, smooth], [in_turn, straight]) = monte_carlo(40);
    eprintln!(
        "position RMS (m): CV {cv:.3}, CT {ct:.3}, IMM {imm:.3}, IMM smoother {smooth:.3}; P(turn) in turn {in_turn:.3}, straight {straight:.3}"
    );
    assert!(imm < cv && imm < ct, "IMM {imm} vs CV {cv}, CT {ct}");
    assert!(smooth < imm, "smoother {smooth} vs filter {imm}");
    assert!(in_turn > straight);
}
