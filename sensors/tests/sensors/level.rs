//! Level sensor: quantization error uniform over one step (centred with compensation), the
//! damper's exact step and ramp responses, and reproducibility with noise.

use approx::assert_relative_eq;
use rand::RngExt;
use sensors::{
    Attitude, FirstOrderLag, LagInput, LevelSensor, LevelSensorConfig, PlatformMotion,
    PlatformMotionConfig, Quantizer, Rounding, seeded_rng,
};

use crate::stats::{Z, ks_uniform, len, mean};

/// 1% critical value of the one-sample KS statistic times √N is 1.63; we use 1.95 (0.1%).
const KS_CRIT: f64 = 1.95;

#[test]
fn floor_quantizer_error_is_uniform_over_one_step() {
    let delta = 0.01;
    let q = Quantizer::new("step_m", delta, Rounding::Floor, 0.0).expect("valid");
    let mut rng = seeded_rng(21);
    let n = 100_000;
    // Independent levels spread over 1000 steps: the error e = q(h) − h is i.i.d.
    let mut e: Vec<f64> = (0..n)
        .map(|_| {
            let h = rng.random_range(0.0..10.0);
            q.quantize(h) - h
        })
        .collect();
    assert!(e.iter().all(|&v| (-delta..=1e-15).contains(&v)));
    // Moments of U(−δ, 0): mean −δ/2 (SE δ/√(12N)), variance δ²/12 (SE δ²/√(180N)).
    let m = mean(&e);
    let se_m = delta / (12.0 * len(&e)).sqrt();
    assert!((m + delta / 2.0).abs() <= Z * se_m, "mean {m}");
    let v = e.iter().map(|x| (x - m).powi(2)).sum::<f64>() / len(&e);
    let se_v = delta * delta / (180.0 * len(&e)).sqrt();
    assert!((v - delta * delta / 12.0).abs() <= Z * se_v, "variance {v}");
    let d = ks_uniform(&mut e, -delta, 0.0);
    assert!(d <= KS_CRIT / len(&e).sqrt(), "KS {d}");
}

/// Runs the full sensor on a level filling at 10 mm/s on a rolling platform (SPEC F defaults)
/// and returns the quantization errors reading − damped level.
fn sensor_errors(compensated: bool, n: usize) -> Vec<f64> {
    let dt = 0.1;
    let cfg = LevelSensorConfig {
        mid_step_compensation: compensated,
        ..LevelSensorConfig::default()
    };
    let mut s = LevelSensor::new(&cfg, dt).expect("valid");
    let mut platform = PlatformMotion::new(&PlatformMotionConfig::default(), dt).expect("valid");
    let mut rng = seeded_rng(22);
    (0..n)
        .map(|k| {
            let att = platform.next(&mut rng);
            #[allow(clippy::cast_precision_loss)]
            let h = 1.0 + 0.010 * dt * k as f64;
            let out = s.step(h, att, &mut rng);
            out.reading - out.damped
        })
        .collect()
}

/// Samples are correlated through the rolling (correlation time 1/μ = 12.5 s), so the
/// tolerances use N_eff = T/(2·12.5 s) independent samples instead of N.
fn n_eff(n: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let t = n as f64 * 0.1;
    t / 25.0
}

#[test]
fn sensor_quantization_error_is_uniform_and_biased_by_half_a_step() {
    let delta = 0.01;
    let n = 200_000;
    let mut e = sensor_errors(false, n);
    assert!(e.iter().all(|&v| (-delta - 1e-12..=1e-12).contains(&v)));
    let m = mean(&e);
    let tol = Z * delta / (12.0 * n_eff(n)).sqrt();
    assert!((m + delta / 2.0).abs() <= tol, "mean {m}, tolerance {tol}");
    let d = ks_uniform(&mut e, -delta, 0.0);
    assert!(d <= KS_CRIT / n_eff(n).sqrt(), "KS {d}");
}

#[test]
fn mid_step_compensation_centres_the_error() {
    let delta = 0.01;
    let n = 200_000;
    let mut e = sensor_errors(true, n);
    assert!(
        e.iter()
            .all(|&v| (-delta / 2.0 - 1e-12..=delta / 2.0 + 1e-12).contains(&v))
    );
    let m = mean(&e);
    let tol = Z * delta / (12.0 * n_eff(n)).sqrt();
    assert!(m.abs() <= tol, "mean {m}, tolerance {tol}");
    let d = ks_uniform(&mut e, -delta / 2.0, delta / 2.0);
    assert!(d <= KS_CRIT / n_eff(n).sqrt(), "KS {d}");
}

#[test]
fn damper_step_response_is_one_minus_exp_at_the_samples() {
    let (ty, dt) = (2.0, 0.1);
    for mode in [LagInput::PiecewiseLinear, LagInput::ZeroOrderHold] {
        let mut lag = FirstOrderLag::new(ty, dt, mode).expect("valid");
        // Output 0 at t = 0 with the input already at 1 (a unit step at t = 0).
        lag.reset_to(0.0, 1.0);
        for k in 1..=100 {
            let y = lag.step(1.0);
            let t = f64::from(k) * dt;
            // Exact integration: only rounding (a few ulps per step) separates them.
            assert_relative_eq!(y, 1.0 - (-t / ty).exp(), epsilon = 1e-13);
        }
    }
    // Through the whole sensor (no tilt, fine δ so the damped level is visible): with a
    // zero-order-hold damper a level step applied at sample 1 gives 1 − e^{−(t − t₁)/T_y}.
    let cfg = LevelSensorConfig {
        damper_input: LagInput::ZeroOrderHold,
        ..LevelSensorConfig::default()
    };
    let mut s = LevelSensor::new(&cfg, dt).expect("valid");
    let mut rng = seeded_rng(0);
    let first = s.step(0.0, Attitude::default(), &mut rng);
    assert_relative_eq!(first.damped, 0.0);
    for j in 0..50 {
        let out = s.step(1.0, Attitude::default(), &mut rng);
        let t = f64::from(j) * dt;
        assert_relative_eq!(out.damped, 1.0 - (-t / ty).exp(), epsilon = 1e-13);
        assert_relative_eq!(
            out.reading,
            (out.damped / 0.01).floor() * 0.01,
            epsilon = 1e-15
        );
    }
}

#[test]
fn piecewise_linear_damper_is_exact_for_a_ramp() {
    // u = c·t from rest: y = c·(t − T(1 − e^{−t/T})).
    let (ty, dt, c) = (2.0, 0.1, 0.01);
    let mut lag = FirstOrderLag::new(ty, dt, LagInput::PiecewiseLinear).expect("valid");
    lag.reset_to(0.0, 0.0);
    for k in 1..=200 {
        let t = f64::from(k) * dt;
        let y = lag.step(c * t);
        assert_relative_eq!(y, c * (t - ty * (1.0 - (-t / ty).exp())), epsilon = 1e-14);
    }
}

#[test]
fn level_sensor_with_noise_is_reproducible() {
    let cfg = LevelSensorConfig {
        noise_std_m: 0.003,
        ..LevelSensorConfig::default()
    };
    let run = |seed: u64| -> Vec<u64> {
        let mut s = LevelSensor::new(&cfg, 0.1).expect("valid");
        let mut rng = seeded_rng(seed);
        (0..2000)
            .map(|k| {
                let h = f64::from(k) * 0.001;
                s.step(h, Attitude::default(), &mut rng).reading.to_bits()
            })
            .collect()
    };
    assert_eq!(run(1), run(1));
    assert_ne!(run(1), run(2));
}

#[test]
fn noise_options_do_not_shift_the_random_stream() {
    // Each step draws a fixed number of normals whether noise is on or off, so a Monte Carlo
    // comparison of configurations sees the same platform motion for the same seed.
    let run = |noise: f64| -> u64 {
        let cfg = LevelSensorConfig {
            noise_std_m: noise,
            ..LevelSensorConfig::default()
        };
        let mut s = LevelSensor::new(&cfg, 0.1).expect("valid");
        let mut rng = seeded_rng(9);
        for k in 0..100 {
            s.step(f64::from(k) * 1e-3, Attitude::default(), &mut rng);
        }
        rng.random::<u64>()
    };
    assert_eq!(run(0.0), run(0.005));
}
