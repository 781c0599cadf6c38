//! Attitude and gyro bias from a gyro and two body-frame reference vectors (an
//! accelerometer's vertical and a magnetometer's field), with the unit quaternion held on
//! its manifold: `cargo run -p stochest-kalman --example attitude`.
//!
//! The flight pitches up through 90° (where Euler angles are singular) and rolls past 180°;
//! the unscented filter and its smoother on the manifold track it, every estimate a unit
//! quaternion.

use kalman::FixedDims;
use kalman::nonlinear::{
    FnModel, Manifold, NonlinearRts, Part, Product, SigmaPoints, Ukf, quaternion,
};
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

fn main() -> Result<(), kalman::Error> {
    let dt = 0.02; // s: a 50 Hz gyro, vector fixes at 10 Hz
    let (sg, sb, sv) = (0.02, 1e-4, 0.02); // gyro noise, bias walk (rad/s), vector noise
    let (g, m) = ([0.0, 0.0, 1.0], [0.5, 0.0, 0.75f64.sqrt()]);
    let space = Product::new([Part::Quaternion, Part::Vector(3)]);
    let d = FixedDims::<6, 6, 3, 7>::new(); // 6 tangent, 6 measured, 3 inputs, 7 stored
    let diag = |v: [f64; 6]| -> Vec<Vec<f64>> {
        let row = |i: usize| (0..6).map(|j| if i == j { v[i] } else { 0.0 }).collect();
        (0..6).map(row).collect()
    };
    let a = (sg * dt) * (sg * dt);
    let model = FnModel::new(
        d,
        move |x: &[f64], u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
            let w = u.unwrap_or(&[0.0; 3]);
            let turn =
                quaternion::exp([(w[0] - x[4]) * dt, (w[1] - x[5]) * dt, (w[2] - x[6]) * dt]);
            out[..4].copy_from_slice(&quaternion::mul([x[0], x[1], x[2], x[3]], turn));
            out[4..].copy_from_slice(&x[4..]);
        },
        move |x: &[f64], _k: usize, out: &mut [f64]| {
            let q = [x[0], x[1], x[2], x[3]];
            out[..3].copy_from_slice(&quaternion::rotate_inverse(q, g));
            out[3..].copy_from_slice(&quaternion::rotate_inverse(q, m));
        },
        &diag([a, a, a, sb * sb, sb * sb, sb * sb]),
        &diag([sv * sv; 6]),
    )?
    .with_manifold(space.clone())?;

    // The truth: a pitch-up at 45°/s for 3 s, then a roll at 1.6 rad/s; a gyro bias.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut noise = |s: f64| s * rng.sample::<f64, _>(StandardNormal);
    let bias = [0.01, -0.02, 0.015];
    let (mut q, mut truth, mut gyro, mut zs) = ([1.0, 0.0, 0.0, 0.0], vec![], vec![], vec![]);
    for k in 0..400 {
        let t = k as f64 * dt;
        let w = if t < 3.0 {
            [0.0, std::f64::consts::FRAC_PI_4, 0.0]
        } else {
            [1.6, 0.0, 0.2]
        };
        truth.push(q);
        let (vg, vm) = (
            quaternion::rotate_inverse(q, g),
            quaternion::rotate_inverse(q, m),
        );
        zs.push(if k % 5 == 0 {
            [
                vg[0] + noise(sv),
                vg[1] + noise(sv),
                vg[2] + noise(sv),
                vm[0] + noise(sv),
                vm[1] + noise(sv),
                vm[2] + noise(sv),
            ]
        } else {
            [f64::NAN; 6]
        });
        gyro.push([
            w[0] + bias[0] + noise(sg),
            w[1] + bias[1] + noise(sg),
            w[2] + bias[2] + noise(sg),
        ]);
        q = quaternion::normalise(quaternion::mul(
            q,
            quaternion::exp([w[0] * dt, w[1] * dt, w[2] * dt]),
        ));
    }

    let x0 = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]; // level, no bias known
    let p0 = diag([0.01, 0.01, 0.01, 1e-3, 1e-3, 1e-3]);
    let mut ukf = Ukf::new(d, model, &x0, &p0, SigmaPoints::merwe(0.5, 2.0, 0.0))?;
    let mut rts = NonlinearRts::new();
    let mut filtered = Vec::new();
    for (z, w) in zs.iter().zip(&gyro) {
        ukf.step(z, Some(w))?;
        rts.record(&ukf)?;
        filtered.push(ukf.state().to_vec());
    }
    let smoothed = rts.smooth_on(&space)?;

    // RMS attitude error (the angle of q_true* ⊗ q̂) after the first second.
    let angle = |est: &[f64], k: usize| {
        let mut e = [0.0; 6];
        let t = truth[k];
        space.boxminus(&[t[0], t[1], t[2], t[3], 0.0, 0.0, 0.0], est, &mut e);
        e[..3].iter().map(|v| v * v).sum::<f64>()
    };
    let rms =
        |f: &dyn Fn(usize) -> f64| ((50..400).map(f).sum::<f64>() / 350.0).sqrt().to_degrees();
    let column = |k: usize| (0..7).map(|i| smoothed.means[(i, k)]).collect::<Vec<_>>();
    println!(
        "RMS attitude error: filtered {:.3}°, smoothed {:.3}°",
        rms(&|k| angle(&filtered[k], k)),
        rms(&|k| angle(&column(k), k))
    );
    let b = &ukf.state()[4..];
    println!(
        "gyro bias (rad/s): true {bias:?}, estimated [{:.4}, {:.4}, {:.4}]",
        b[0], b[1], b[2]
    );
    let worst = filtered
        .iter()
        .map(|x| (x[..4].iter().map(|v| v * v).sum::<f64>().sqrt() - 1.0).abs())
        .fold(0.0, f64::max);
    println!("largest | |q| − 1 | over the flight: {worst:.1e}");
    Ok(())
}
