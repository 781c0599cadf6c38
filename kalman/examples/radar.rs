//! A range–bearing radar tracking a target on a constant-velocity course, with the unscented
//! filter and its Rauch–Tung–Striebel smoother:
//! `cargo run -p stochest-kalman --example radar`.
//!
//! The bearing's residual is wrapped to (−π, π], so a target crossing the radar's −x axis
//! (bearing ±180°) does not see a 360° innovation.

use std::f64::consts::PI;

use kalman::FixedDims;
use kalman::nonlinear::{FnModel, NonlinearRts, SigmaPoints, Ukf};
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

fn main() -> Result<(), kalman::Error> {
    let (dt, q, sr, sb): (f64, f64, f64, f64) = (1.0, 0.05, 5.0, 0.5f64.to_radians()); // s, m²/s³, m, rad
    let (qa, qb, qc) = (q * dt.powi(3) / 3.0, q * dt * dt / 2.0, q * dt);
    let model = FnModel::new(
        FixedDims::<4, 2>::new(), // state (x, vx, y, vy); z = (range, bearing)
        move |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
            out.copy_from_slice(&[x[0] + dt * x[1], x[1], x[2] + dt * x[3], x[3]]);
        },
        |x: &[f64], _k: usize, out: &mut [f64]| {
            out.copy_from_slice(&[x[0].hypot(x[2]), x[2].atan2(x[0])]);
        },
        &[
            [qa, qb, 0.0, 0.0],
            [qb, qc, 0.0, 0.0],
            [0.0, 0.0, qa, qb],
            [0.0, 0.0, qb, qc],
        ],
        &[[sr * sr, 0.0], [0.0, sb * sb]],
    )?
    .with_residual(|a, b, out| {
        out[0] = a[0] - b[0];
        out[1] = (a[1] - b[1] + PI).rem_euclid(2.0 * PI) - PI;
    });

    // A target passing west of the radar at (0, 0), from north-west to south-west.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut noise = |s: f64| s * rng.sample::<f64, _>(StandardNormal);
    let truth: Vec<[f64; 4]> = (0..120)
        .map(|k| [-300.0, 0.0, 600.0 - 10.0 * k as f64, -10.0])
        .collect();
    let zs: Vec<[f64; 2]> = truth
        .iter()
        .map(|t| [t[0].hypot(t[2]) + noise(sr), t[2].atan2(t[0]) + noise(sb)])
        .collect();

    let p0 = [
        [100.0, 0.0, 0.0, 0.0],
        [0.0, 100.0, 0.0, 0.0],
        [0.0, 0.0, 100.0, 0.0],
        [0.0, 0.0, 0.0, 100.0],
    ];
    let points = SigmaPoints::merwe(1e-3, 2.0, 0.0);
    let mut ukf = Ukf::new(
        FixedDims::<4, 2>::new(),
        model,
        &[-290.0, 0.0, 590.0, -9.0],
        &p0,
        points,
    )?;
    let mut rts = NonlinearRts::new();
    let mut filtered = Vec::new();
    for z in &zs {
        ukf.step(z, None)?;
        rts.record(&ukf)?;
        filtered.push(ukf.state().to_vec());
    }
    let smoothed = rts.smooth()?;

    let rms = |est: &dyn Fn(usize) -> [f64; 2]| {
        let s: f64 = truth
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let e = est(k);
                (e[0] - t[0]).powi(2) + (e[1] - t[2]).powi(2)
            })
            .sum();
        (s / truth.len() as f64).sqrt()
    };
    let raw = rms(&|k| [zs[k][0] * zs[k][1].cos(), zs[k][0] * zs[k][1].sin()]);
    let filt = rms(&|k| [filtered[k][0], filtered[k][2]]);
    let smooth = rms(&|k| [smoothed.means[(0, k)], smoothed.means[(2, k)]]);
    println!(
        "RMS position error: measurements {raw:.2} m, filter {filt:.2} m, smoother {smooth:.2} m"
    );
    assert!(smooth < filt && filt < raw);
    Ok(())
}
