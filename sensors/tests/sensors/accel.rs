//! Accelerometer: outputs equal SPEC B's formulas, ±Δa variants, saturation, the a_z
//! mounting check, and noise statistics.

use approx::assert_relative_eq;
use sensors::{Accelerometer, AccelerometerConfig, BiasVariant, BoomMotion, Error, seeded_rng};

const G: f64 = 9.8;
const R: f64 = 25.0;

#[test]
fn outputs_equal_spec_b_formulas() {
    for gamma_deg in [0.0f64, 10.0, 20.0, -15.0] {
        for centripetal in [false, true] {
            let cfg = AccelerometerConfig {
                sensor_offset_angle: gamma_deg.to_radians(),
                centripetal,
                ..AccelerometerConfig::default()
            };
            let acc = Accelerometer::new(&cfg).expect("valid");
            let gamma = f64::to_radians(gamma_deg);
            for alpha_deg in [0.0, 9.0, 45.0, 81.0, 88.0, 90.0] {
                let alpha = f64::to_radians(alpha_deg);
                for (omega, eps) in [(0.0, 0.0), (0.05, 0.008), (0.03, -0.0073)] {
                    let m = BoomMotion {
                        angle: alpha,
                        rate: omega,
                        acceleration: eps,
                    };
                    let out = acc.measure(m, &mut seeded_rng(0));
                    let cen = if centripetal { omega * omega * R } else { 0.0 };
                    // SPEC B: a_x = g sin(α − γ) [− ω²r], a_y = g cos(α − γ) + ε r, a_z = 0.
                    assert_relative_eq!(out.x, G * (alpha - gamma).sin() - cen, epsilon = 1e-12);
                    assert_relative_eq!(
                        out.y,
                        G * (alpha - gamma).cos() + eps * R,
                        epsilon = 1e-12
                    );
                    assert_relative_eq!(out.z, 0.0, epsilon = 1e-12);
                }
            }
        }
    }
}

#[test]
fn centripetal_term_is_0_06_at_0_05_rad_s() {
    // SPEC B: 0.06 m/s² at 0.05 rad/s on r = 25 m (three times Δa), on the radial axis.
    let on = Accelerometer::new(&AccelerometerConfig {
        centripetal: true,
        ..AccelerometerConfig::default()
    })
    .expect("valid");
    let off = Accelerometer::new(&AccelerometerConfig::default()).expect("valid");
    let m = BoomMotion {
        angle: 0.5,
        rate: 0.05,
        acceleration: 0.0,
    };
    let d = off.clean(m) - on.clean(m);
    assert_relative_eq!(d.x, 0.0625, epsilon = 1e-12);
    assert_relative_eq!(d.y, 0.0, epsilon = 1e-12);
}

#[test]
fn bias_variants_add_plus_or_minus_delta_a_to_x_and_y() {
    let m = BoomMotion {
        angle: 0.7,
        rate: 0.0,
        acceleration: 0.004,
    };
    let base = Accelerometer::new(&AccelerometerConfig::default())
        .expect("valid")
        .clean(m);
    for (variant, sign) in [(BiasVariant::Plus, 1.0), (BiasVariant::Minus, -1.0)] {
        let acc = Accelerometer::new(&AccelerometerConfig {
            bias: variant,
            ..AccelerometerConfig::default()
        })
        .expect("valid");
        let d = acc.clean(m) - base;
        assert_relative_eq!(d.x, sign * 0.02, epsilon = 1e-12);
        assert_relative_eq!(d.y, sign * 0.02, epsilon = 1e-12);
        assert_relative_eq!(d.z, 0.0, epsilon = 1e-12);
    }
}

#[test]
fn saturation_clips_at_the_range() {
    let acc = Accelerometer::new(&AccelerometerConfig::default()).expect("valid");
    // α = 0: a_y = g + ε r = 9.8 + 0.02·25 = 10.3 > 10; with ε < 0, 9.8 − 12.5 = −2.7 (in range).
    let m = BoomMotion {
        angle: 0.0,
        rate: 0.0,
        acceleration: 0.02,
    };
    assert!(acc.clean(m).y > 10.0);
    let out = acc.measure(m, &mut seeded_rng(1));
    assert_relative_eq!(out.y, 10.0);
    let m = BoomMotion {
        angle: std::f64::consts::FRAC_PI_2,
        rate: 0.0,
        acceleration: -0.6,
    };
    let out = acc.measure(m, &mut seeded_rng(1));
    assert_relative_eq!(out.y, -10.0);
    assert_relative_eq!(out.x, 9.8, epsilon = 1e-12);
}

#[test]
fn misaligned_mount_fails_the_a_z_check() {
    let at_rest = BoomMotion::default();
    let good = Accelerometer::new(&AccelerometerConfig::default()).expect("valid");
    assert!(good.check_mounting(&good.clean(at_rest)).is_ok());
    // A 0.3° tilt about the radial axis leaks g·sin 0.3° = 0.051 m/s² into z: within 0.1.
    let small = Accelerometer::new(&AccelerometerConfig {
        misalignment_deg: [0.3, 0.0, 0.0],
        ..AccelerometerConfig::default()
    })
    .expect("valid");
    let z = small.clean(at_rest).z;
    assert_relative_eq!(z.abs(), G * 0.3f64.to_radians().sin(), epsilon = 1e-12);
    assert!(small.check_mounting(&small.clean(at_rest)).is_ok());
    // 2° leaks 0.342 m/s²: the check fails and reports a_z.
    let bad = Accelerometer::new(&AccelerometerConfig {
        misalignment_deg: [2.0, 0.0, 0.0],
        ..AccelerometerConfig::default()
    })
    .expect("valid");
    let reading = bad.clean(at_rest);
    match bad.check_mounting(&reading) {
        Err(Error::MountingCheck { a_z, tolerance }) => {
            assert_relative_eq!(a_z.abs(), G * 2f64.to_radians().sin(), epsilon = 1e-12);
            assert_relative_eq!(tolerance, 0.1);
        }
        other => panic!("expected a mounting-check failure, got {other:?}"),
    }
    // A tilt about the tangential axis shows once the boom is raised (gravity on x).
    let pitched = Accelerometer::new(&AccelerometerConfig {
        misalignment_deg: [0.0, 2.0, 0.0],
        ..AccelerometerConfig::default()
    })
    .expect("valid");
    let up = BoomMotion {
        angle: std::f64::consts::FRAC_PI_2,
        ..BoomMotion::default()
    };
    assert!(pitched.check_mounting(&pitched.clean(up)).is_err());
}

#[test]
fn noise_has_the_configured_spread_and_is_reproducible() {
    let acc = Accelerometer::new(&AccelerometerConfig {
        noise_std_mps2: 0.02,
        ..AccelerometerConfig::default()
    })
    .expect("valid");
    let m = BoomMotion {
        angle: 0.3,
        rate: 0.0,
        acceleration: 0.0,
    };
    let clean = acc.clean(m);
    let mut rng = seeded_rng(31);
    let n = 20_000;
    let mut s2 = 0.0;
    for _ in 0..n {
        let d = acc.measure(m, &mut rng) - clean;
        s2 += d.norm_squared();
    }
    // Var of the mean square of 3n i.i.d. N(0, σ²): 2σ⁴/(3n).
    let var = s2 / (3.0 * f64::from(n));
    let se = 0.02f64.powi(2) * (2.0 / (3.0 * f64::from(n))).sqrt();
    assert!(
        (var - 0.0004).abs() <= crate::stats::Z * se,
        "variance {var}"
    );
    let a = acc.measure(m, &mut seeded_rng(4));
    let b = acc.measure(m, &mut seeded_rng(4));
    let c = acc.measure(m, &mut seeded_rng(5));
    assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
    assert_ne!(a.map(f64::to_bits), c.map(f64::to_bits));
}
