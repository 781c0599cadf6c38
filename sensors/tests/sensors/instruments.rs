//! Gyro instrument and UAV channel sensors: bias, noise, resolution, sample rate, bandwidth,
//! reproducibility.

use approx::assert_relative_eq;
use sensors::{
    Attitude, ChannelSensor, ChannelSensorConfig, Gyro, GyroConfig, Quantity, seeded_rng,
};

use crate::stats::Z;

#[test]
fn gyro_error_has_the_configured_bias_and_noise() {
    let cfg = GyroConfig {
        sample_period_s: 0.1,
        noise_std_deg: 0.05,
        roll_bias_deg: 0.1,
        pitch_bias_deg: -0.2,
        resolution_deg: 0.0,
    };
    let mut g = Gyro::new(&cfg, 0.1).expect("valid");
    let mut rng = seeded_rng(51);
    let n = 20_000;
    let (mut sr, mut sp, mut sr2) = (0.0, 0.0, 0.0);
    for k in 0..n {
        let truth = Attitude {
            roll: (f64::from(k) * 0.01).sin() * 0.01,
            pitch: 0.003,
        };
        let out = g.step(truth, &mut rng);
        let (er, ep) = (out.roll - truth.roll, out.pitch - truth.pitch);
        sr += er;
        sp += ep;
        sr2 += (er - 0.1f64.to_radians()).powi(2);
    }
    let nf = f64::from(n);
    let sigma = 0.05f64.to_radians();
    // Samples are independent (one fresh sample per step): SE σ/√N and σ²·√(2/N).
    assert!((sr / nf - 0.1f64.to_radians()).abs() <= Z * sigma / nf.sqrt());
    assert!((sp / nf + 0.2f64.to_radians()).abs() <= Z * sigma / nf.sqrt());
    assert!((sr2 / nf - sigma * sigma).abs() <= Z * sigma * sigma * (2.0 / nf).sqrt());
}

#[test]
fn gyro_sample_period_holds_noise_too() {
    let cfg = GyroConfig {
        sample_period_s: 0.5,
        noise_std_deg: 0.1,
        ..GyroConfig::default()
    };
    let mut g = Gyro::new(&cfg, 0.1).expect("valid");
    let mut rng = seeded_rng(52);
    let out: Vec<u64> = (0..20)
        .map(|_| g.step(Attitude::default(), &mut rng).roll.to_bits())
        .collect();
    // New value every 5 steps, held in between.
    for (k, w) in out.windows(2).enumerate() {
        if (k + 1) % 5 == 0 {
            assert_ne!(w[0], w[1], "step {k}");
        } else {
            assert_eq!(w[0], w[1], "step {k}");
        }
    }
    let run = |seed| -> Vec<u64> {
        let mut g = Gyro::new(&cfg, 0.1).expect("valid");
        let mut rng = seeded_rng(seed);
        (0..100)
            .map(|_| g.step(Attitude::default(), &mut rng).pitch.to_bits())
            .collect()
    };
    assert_eq!(run(1), run(1));
    assert_ne!(run(1), run(2));
}

#[test]
fn channel_sensor_bandwidth_gives_the_first_order_step_response() {
    let fc = 5.0;
    let cfg = ChannelSensorConfig {
        quantity: Quantity::LinearAcceleration,
        bandwidth_hz: Some(fc),
        bias: 0.0,
        noise_std: 0.0,
        quantization_step: 0.0,
        range: None,
    };
    let dt = 0.001;
    let mut s = ChannelSensor::new(&cfg, dt).expect("valid");
    let mut rng = seeded_rng(0);
    assert_relative_eq!(s.step(0.0, &mut rng), 0.0);
    // The step happens between sample 0 and 1 (a linear ramp over the first interval under
    // the piecewise-linear input model); from then on the response is
    // 1 − e^{−t/T} delayed by half a step to first order; check the exact FOH solution.
    let tau = 1.0 / (2.0 * std::f64::consts::PI * fc);
    let a = (-dt / tau).exp();
    let y1 = 1.0 - tau * (1.0 - a) / dt;
    let mut want = y1;
    assert_relative_eq!(s.step(1.0, &mut rng), y1, epsilon = 1e-12);
    for _ in 0..500 {
        want = a * want + (1.0 - a);
        assert_relative_eq!(s.step(1.0, &mut rng), want, epsilon = 1e-12);
    }
    // At one time constant after the ramp, about 63 % of the step.
    assert!(want > 0.99);
}

#[test]
fn channel_sensor_bias_noise_quantization_in_si() {
    let cfg = ChannelSensorConfig {
        bandwidth_hz: None,
        bias: 0.5,
        noise_std: 0.2,
        quantization_step: 0.0,
        range: None,
        ..ChannelSensorConfig::angular_rate()
    };
    let mut s = ChannelSensor::new(&cfg, 0.01).expect("valid");
    let mut rng = seeded_rng(53);
    let n = 20_000;
    let (mut m, mut m2) = (0.0, 0.0);
    for _ in 0..n {
        let e = s.step(1.0, &mut rng) - 1.0;
        m += e;
        m2 += e * e;
    }
    let nf = f64::from(n);
    let (bias, sigma) = (0.5f64.to_radians(), 0.2f64.to_radians());
    let var = m2 / nf - (m / nf).powi(2);
    assert!((m / nf - bias).abs() <= Z * sigma / nf.sqrt());
    assert!((var - sigma * sigma).abs() <= Z * sigma * sigma * (2.0 / nf).sqrt());
    // Quantization to 0.01 m/s² (nearest) on the accelerometer.
    let cfg = ChannelSensorConfig {
        bandwidth_hz: None,
        noise_std: 0.0,
        quantization_step: 0.01,
        ..ChannelSensorConfig::linear_accelerometer()
    };
    let mut s = ChannelSensor::new(&cfg, 0.01).expect("valid");
    assert_relative_eq!(s.step(1.234, &mut rng), 1.23, epsilon = 1e-12);
    assert_relative_eq!(s.step(-1.236, &mut rng), -1.24, epsilon = 1e-12);
    // Reproducible.
    let run = |seed| -> Vec<u64> {
        let mut s = ChannelSensor::new(&ChannelSensorConfig::potentiometer(), 0.01).expect("ok");
        let mut rng = seeded_rng(seed);
        (0..200)
            .map(|k| s.step(f64::from(k) * 1e-3, &mut rng).to_bits())
            .collect()
    };
    assert_eq!(run(1), run(1));
    assert_ne!(run(1), run(2));
}
