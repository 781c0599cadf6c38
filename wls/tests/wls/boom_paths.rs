//! Tests of `wls::boom` paths the main boom tests do not reach: every invalid scalar of the
//! rotation profile is rejected by name, a turn no deceleration can end is reported so, and
//! a turn's first violation is decided by either error alone.

use wls::Error;
use wls::boom::{
    BoomConfig, Breakpoint, CycleError, Deceleration, ErrorVariant, Level, Limits, RotationProfile,
    TurnRun, ideal_accelerometer, run_turn,
};

/// The field an `InvalidParameter` error names, or a panic showing what came instead.
fn invalid_name<T: std::fmt::Debug>(result: Result<T, Error>) -> &'static str {
    match result {
        Err(Error::InvalidParameter { name, .. }) => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

/// A final angle, step or fixed deceleration that is not finite and positive is a typed error
/// naming the field, from both entry points. Each rule has two halves (finite, and > 0), so
/// each is probed with a non-finite value and with a finite value ≤ 0.
#[test]
fn invalid_profile_scalars_are_named() {
    for bad in [f64::NAN, f64::INFINITY, 0.0, -10.0] {
        let cases = [
            (
                RotationProfile {
                    final_angle_deg: bad,
                    ..RotationProfile::default()
                },
                "profile.final_angle_deg",
            ),
            (
                RotationProfile {
                    dt: bad,
                    ..RotationProfile::default()
                },
                "profile.dt",
            ),
            (
                RotationProfile {
                    deceleration: Deceleration::Fixed(bad),
                    ..RotationProfile::default()
                },
                "profile.deceleration",
            ),
        ];
        for (profile, name) in cases {
            assert_eq!(invalid_name(profile.trajectory()), name, "value {bad}");
            assert_eq!(
                invalid_name(profile.solve_deceleration()),
                name,
                "value {bad}"
            );
        }
    }
}

/// A final angle the boom passes within its first step from rest is passed still moving
/// whatever the deceleration (ε_d only acts from the 77° ramp on), so no ε_d solves the turn:
/// the error must say that no deceleration stops it, not that it stops short. (The rate at
/// the crossing, interpolated between ω = 0 and the first step's ω > 0, is positive.)
#[test]
fn a_final_angle_passed_in_the_first_step_cannot_be_stopped_at() {
    let profile = RotationProfile {
        // One step of 0.01 s at 0.4584 °/s² from rest covers ≈ 2.3e-5°.
        final_angle_deg: 1e-5,
        ..RotationProfile::default()
    };
    match profile.solve_deceleration() {
        Err(Error::InvalidParameter { name, rule, .. }) => {
            assert_eq!(name, "profile");
            assert_eq!(rule, "no deceleration stops the boom at the final angle");
        }
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

/// The first 300 samples (3 s) of the paper's turn with the "+" variant of 0.02 m/s², run
/// under `limits`.
fn short_turn(limits: Limits) -> TurnRun {
    let profile = RotationProfile::default().trajectory().expect("valid");
    let config = BoomConfig::default();
    let measure = ideal_accelerometer(config.g, config.sensor_radius);
    run_turn(
        &profile.points[..300],
        &config,
        &measure,
        &ErrorVariant::plus(0.02),
        limits,
    )
    .expect("valid")
}

/// A turn's first violation is the first cycle after start-up where *either* error exceeds
/// its own limit: rebuilt here from the per-cycle records, with one limit out of reach
/// (1 rad, 1 rad/s²) so that the other error alone decides.
#[test]
fn first_violation_is_decided_by_either_error_alone() {
    let tight = 1e-4;
    for (limits, error_of) in [
        (
            Limits {
                angle: 1.0,
                angular_acceleration: tight,
            },
            (|c: &CycleError| c.epsilon_error) as fn(&CycleError) -> f64,
        ),
        (
            Limits {
                angle: tight,
                angular_acceleration: 1.0,
            },
            |c: &CycleError| c.angle_error,
        ),
    ] {
        let run = short_turn(limits);
        let expected = run.cycles[1..]
            .iter()
            .find(|c| error_of(c) > tight)
            .map(|c| (c.t, c.alpha));
        assert!(
            expected.is_some(),
            "a 0.02 m/s² bias must cost more than {tight}"
        );
        assert!(
            run.cycles
                .iter()
                .all(|c| c.angle_error < 1.0 && c.epsilon_error < 1.0)
        );
        assert_eq!(run.first_violation, expected);
    }
}

/// The label reports use is the name the variant is stored under (its serde name), so a
/// report and a stored record name a variant alike.
#[test]
fn a_variant_is_labelled_by_its_stored_name() {
    use wls::boom::Sign;
    for (sign, variant) in [
        (Sign::Plus, ErrorVariant::plus(0.1)),
        (Sign::Minus, ErrorVariant::minus(0.1)),
        (Sign::Nominal, ErrorVariant::nominal()),
    ] {
        let stored = serde_json::to_string(&sign).expect("a unit variant serialises");
        assert_eq!(stored, format!("\"{}\"", sign.label()));
        assert_eq!(variant.sign, sign);
        assert_eq!(variant.label(), sign.label());
    }
}

/// A violation is an error that *exceeds* its limit: a limit equal to the largest error after
/// start-up is met, one a step of round-off below it is violated, first at the cycle that
/// reaches that largest error (or earlier, if an earlier cycle is above the lowered limit).
/// Each error alone, the other limit out of reach.
#[test]
fn an_error_equal_to_its_limit_is_not_a_violation() {
    let loose = Limits {
        angle: 1.0,
        angular_acceleration: 1.0,
    };
    let reference = short_turn(loose);
    assert_eq!(reference.first_violation, None);
    let errors: [fn(&CycleError) -> f64; 2] = [|c| c.angle_error, |c| c.epsilon_error];
    for (which, error_of) in errors.into_iter().enumerate() {
        let largest = reference.cycles[1..]
            .iter()
            .map(error_of)
            .fold(0.0, f64::max);
        assert!(largest > 0.0 && largest < 1.0, "{which}: {largest}");
        let limits_at = |limit: f64| {
            let mut l = loose;
            if which == 0 {
                l.angle = limit;
            } else {
                l.angular_acceleration = limit;
            }
            l
        };
        let met = short_turn(limits_at(largest));
        assert_eq!(met.first_violation, None, "{which}: limit = largest error");
        let below = largest - largest * f64::EPSILON;
        let broken = short_turn(limits_at(below));
        let expected = reference.cycles[1..]
            .iter()
            .find(|c| error_of(c) > below)
            .map(|c| (c.t, c.alpha));
        assert!(expected.is_some());
        assert_eq!(broken.first_violation, expected, "{which}");
    }
}

/// Over the paper profile's first segment (0–9°) the acceleration is a constant ε₀ =
/// 0.4584 °/s², so from rest α = ε₀t²/2 and ω = ε₀t exactly; RK4 is exact on a quadratic,
/// so every sample there must match to round-off (≈ 630 steps of a few ε each: 1e-12
/// relative is a margin of > 10).
#[test]
fn the_constant_acceleration_segment_follows_its_closed_form() {
    let profile = RotationProfile::default().trajectory().expect("valid");
    let eps0 = 0.4584_f64;
    let mut checked = 0;
    for p in profile
        .points
        .iter()
        .take_while(|p| p.alpha.to_degrees() < 8.9)
    {
        let alpha = eps0 * p.t * p.t / 2.0;
        let omega = eps0 * p.t;
        assert!(
            (p.alpha.to_degrees() - alpha).abs() <= 1e-12 * alpha.max(1e-3),
            "t = {}: α = {}° against {alpha}°",
            p.t,
            p.alpha.to_degrees()
        );
        assert!(
            (p.omega.to_degrees() - omega).abs() <= 1e-12 * omega.max(1e-3),
            "t = {}",
            p.t
        );
        assert!(
            (p.epsilon.to_degrees() - eps0).abs() <= 1e-14,
            "t = {}",
            p.t
        );
        checked += 1;
    }
    // t = √(2·8.9/ε₀) ≈ 6.2 s at 0.01 s steps.
    assert!(checked > 600, "{checked}");
}

/// A linear ramp ε = ε₀(1 − α/10°) from rest at 0° is a harmonic oscillation about 10°:
/// α = 10°·(1 − cos kt), ω = 10°·k·sin kt with k = √(ε₀/10°). RK4 at kh ≈ 0.002 has a
/// local error of order (kh)⁵ ≈ 1e-14 of the amplitude, so ≈ 980 steps to 15° stay within
/// 1e-10 of it (a margin of > 10); a step that evaluates ε at the wrong angle is off by far
/// more, which the constant segment of the paper profile cannot show.
#[test]
fn a_linear_ramp_from_rest_follows_the_harmonic_closed_form() {
    let eps0 = 0.4584_f64;
    let profile = RotationProfile {
        breakpoints: vec![
            Breakpoint {
                alpha_deg: 0.0,
                epsilon: Level::Value(eps0),
            },
            Breakpoint {
                alpha_deg: 20.0,
                epsilon: Level::Value(-eps0),
            },
        ],
        final_angle_deg: 15.0,
        dt: 0.01,
        deceleration: Deceleration::Fixed(1.0),
    };
    let tr = profile.trajectory().expect("valid");
    let k = (eps0 / 10.0).sqrt();
    for p in &tr.points {
        let (alpha, omega) = (10.0 * (1.0 - (k * p.t).cos()), 10.0 * k * (k * p.t).sin());
        assert!(
            (p.alpha.to_degrees() - alpha).abs() <= 1e-10 * 10.0,
            "t = {}",
            p.t
        );
        assert!(
            (p.omega.to_degrees() - omega).abs() <= 1e-10 * 10.0 * k,
            "t = {}",
            p.t
        );
    }
    let last = tr.points.last().expect("non-empty");
    assert!(
        last.alpha.to_degrees() > 14.9,
        "{}",
        last.alpha.to_degrees()
    );
}

/// Scaling every acceleration of the table by s and the step by 1/√s leaves the discrete
/// path in α unchanged (each RK4 stage scales exactly: ω by √s, ε by s), so the solved ε_d
/// scales by s. With s a power of 4, √s is a power of 2 and the scaling is exact in binary;
/// only the bisection's own stopping (1e-15 relative) separates the two answers. s = 4 and
/// 1024 need ε_d ≈ 1.7 and 430 °/s², beyond the search's initial bracket [0, 1].
#[test]
fn the_solved_deceleration_scales_with_the_table() {
    let base = RotationProfile::default();
    let d1 = base.solve_deceleration().expect("valid");
    let scaled = |s: f64| {
        let mut p = base.clone();
        for b in &mut p.breakpoints {
            if let Level::Value(e) = &mut b.epsilon {
                *e *= s;
            }
        }
        p.dt = base.dt / s.sqrt();
        p.solve_deceleration()
    };
    for s in [4.0_f64, 1024.0] {
        let ds = scaled(s).expect("valid");
        assert!(
            (ds / s - d1).abs() <= 1e-14 * d1,
            "s = {s}: {ds} against {}",
            s * d1
        );
    }
    // The search doubles its bracket up to 60 times, so ε_d up to 2^60 °/s² is found: here
    // ≈ 8.4e17 > 2^59. (s is not a power of 4, so the scaled path differs by rounding: 1e-9.)
    let s = 2e18;
    let ds = scaled(s).expect("within the search's range");
    assert!(ds > 2f64.powi(59));
    assert!((ds / s - d1).abs() <= 1e-9 * d1, "{ds} against {}", s * d1);
}
