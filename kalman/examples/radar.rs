//! A range–bearing radar tracking a target on a constant-velocity course, with the unscented
//! filter and its Rauch–Tung–Striebel smoother:
//! `cargo run -p stochest-kalman --example radar`.
//!
//! The bearing's residual is wrapped to (−π, π], so a target crossing the radar's −x axis
//! (bearing ±180°) does not see a 360° innovation. `track` is the whole tracker; the same
//! function written with FilterPy is `python/examples/radar_filterpy.py`.

use std::f64::consts::PI;

use kalman::faer::Mat;
use kalman::nonlinear::{FnModel, NonlinearRts, SigmaPoints};
use kalman::{Diagonal, FixedDims};
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

const DT: f64 = 1.0; // s
const Q: f64 = 0.05; // white-acceleration intensity, m²/s³
const SR: f64 = 5.0; // range noise, m
const SB: f64 = 0.5 * PI / 180.0; // bearing noise, rad

/// The filtered and smoothed positions (x, y) of the target from the radar's (range,
/// bearing) measurements.
type Track = (Vec<[f64; 2]>, Vec<[f64; 2]>);

fn track(zs: &[[f64; 2]]) -> Result<Track, kalman::Error> {
    let (qa, qb, qc) = (Q * DT.powi(3) / 3.0, Q * DT * DT / 2.0, Q * DT);
    #[rustfmt::skip]
    let q = [[qa, qb, 0., 0.], [qb, qc, 0., 0.], [0., 0., qa, qb], [0., 0., qb, qc]];
    // The state is (x, vx, y, vy); z = (range, bearing), the bearing's residual wrapped.
    let f = |x: &[f64], _: Option<&[f64]>, _: usize, y: &mut [f64]| {
        y.copy_from_slice(&[x[0] + DT * x[1], x[1], x[2] + DT * x[3], x[3]])
    };
    let h = |x: &[f64], _: usize, y: &mut [f64]| {
        y.copy_from_slice(&[x[0].hypot(x[2]), x[2].atan2(x[0])])
    };
    let r = Diagonal([SR * SR, SB * SB]);
    let model = FnModel::new(FixedDims::<4, 2>::new(), f, h, &q, &r)?.with_residual(|a, b, d| {
        d[0] = a[0] - b[0];
        d[1] = (a[1] - b[1] + PI).rem_euclid(2.0 * PI) - PI;
    });
    let (x0, p0) = ([-290.0, 0.0, 590.0, -9.0], Diagonal([100.0; 4]));
    let mut ukf = model.ukf(&x0, &p0, SigmaPoints::merwe(1e-3, 2.0, 0.0))?;
    let (filtered, rts) = NonlinearRts::run(&mut ukf, zs)?;
    let positions = |m: Mat<f64>| (0..zs.len()).map(|k| [m[(0, k)], m[(2, k)]]).collect();
    Ok((positions(filtered), positions(rts.smooth()?.means)))
}

fn main() -> Result<(), kalman::Error> {
    // A target passing west of the radar at (0, 0), from north-west to south-west.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut noise = |s: f64| s * rng.sample::<f64, _>(StandardNormal);
    let truth: Vec<[f64; 2]> = (0..120)
        .map(|k| [-300.0, 600.0 - 10.0 * k as f64])
        .collect();
    let zs: Vec<[f64; 2]> = truth
        .iter()
        .map(|t| [t[0].hypot(t[1]) + noise(SR), t[1].atan2(t[0]) + noise(SB)])
        .collect();
    let raw: Vec<[f64; 2]> = zs
        .iter()
        .map(|z| [z[0] * z[1].cos(), z[0] * z[1].sin()])
        .collect();
    let (filtered, smoothed) = track(&zs)?;
    let rms = |est: &[[f64; 2]]| {
        let s: f64 = est
            .iter()
            .zip(&truth)
            .map(|(e, t)| (e[0] - t[0]).powi(2) + (e[1] - t[1]).powi(2))
            .sum();
        (s / truth.len() as f64).sqrt()
    };
    let (raw, filt, smooth) = (rms(&raw), rms(&filtered), rms(&smoothed));
    println!(
        "RMS position error: measurements {raw:.2} m, filter {filt:.2} m, smoother {smooth:.2} m"
    );
    assert!(smooth < filt && filt < raw);
    Ok(())
}
