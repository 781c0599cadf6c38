//! Tests of `wls::boom`: exactness on exact readings, the definedness of direct inversion,
//! the 1/cos α growth of the 3×3 condition number, the WLS reduced path against the general
//! solver, the paper's full turn with ±Δa and the γ sweep.

use nalgebra::{DMatrix, DVector};
use wls::Error;
use wls::boom::{
    AngleUnit, BoomConfig, BoomEstimator, BoomMethod, BoomSolver, ErrorVariant, Limits, RateWeight,
    RotationProfile, TrajectoryPoint, ideal_accelerometer, run_turn, sweep_gamma,
};
use wls::solver::{SolveOptions, Weights, solve};

fn config(method: BoomMethod) -> BoomConfig {
    BoomConfig {
        method,
        ..BoomConfig::default()
    }
}

fn exact(cfg: &BoomConfig, alpha: f64, eps: f64) -> (f64, f64) {
    let beta = alpha - cfg.sensor_offset_angle;
    (
        cfg.g * beta.sin(),
        cfg.g * beta.cos() + eps * cfg.sensor_radius,
    )
}

/// γ = 0 (and γ = 10°), exact static readings over 0–89°: every method returns α and ε.
/// Tolerance 1e-10: rounding in a_x is amplified by 1/(g·cos α) ≤ 6 at 89° for α, and by
/// tan α/r ≤ 2.3 for ε; WLS is consistent (all rows agree at the truth) with κ ≤ 30.
#[test]
fn exact_readings_give_exact_angle_and_acceleration_over_0_to_89_degrees() {
    for method in [BoomMethod::Direct, BoomMethod::Linear3, BoomMethod::Wls] {
        for gamma_deg in [0.0, 10.0_f64] {
            for solver in [BoomSolver::Qr, BoomSolver::NormalEquations] {
                for k in 0..=178 {
                    let alpha = (0.5 * f64::from(k)).to_radians();
                    for eps in [-0.008, 0.0, 0.005] {
                        let cfg = BoomConfig {
                            sensor_offset_angle: gamma_deg.to_radians(),
                            solver,
                            ..config(method)
                        };
                        let (ax, ay) = exact(&cfg, alpha, eps);
                        let mut est = BoomEstimator::new(cfg).expect("valid");
                        // Start-up cycle, then steady cycles from the carried state.
                        for cycle in 0..3 {
                            let e = est.update(ax, ay, 0.0).expect("finite");
                            assert!(e.defined, "{method:?} α={alpha} cycle {cycle}");
                            assert!(
                                (e.angle - alpha).abs() < 1e-10,
                                "{method:?} γ={gamma_deg} α={}: {}",
                                alpha.to_degrees(),
                                e.angle.to_degrees()
                            );
                            assert!(
                                (e.angular_acceleration - eps).abs() < 1e-10,
                                "{method:?} α={}: ε {}",
                                alpha.to_degrees(),
                                e.angular_acceleration
                            );
                            assert_eq!(e.startup, cycle == 0 && method != BoomMethod::Direct);
                        }
                    }
                }
            }
        }
    }
}

/// Direct inversion is defined exactly where g² ≥ a_x²; the estimate is NaN otherwise and the
/// flag says so.
#[test]
fn direct_method_flags_undefined_where_g2_below_ax2() {
    let cfg = config(BoomMethod::Direct);
    let g = cfg.g;
    let mut est = BoomEstimator::new(cfg).expect("valid");
    for k in 0..=400 {
        let alpha = (80.0 + 0.025 * f64::from(k)).to_radians();
        for bias in [-0.02, 0.0, 0.02] {
            let ax = g * alpha.sin() + bias;
            let e = est.update(ax, g * alpha.cos(), 0.0).expect("finite");
            assert_eq!(
                e.defined,
                g * g >= ax * ax,
                "α = {}, bias {bias}",
                alpha.to_degrees()
            );
            assert_eq!(
                e.defined,
                e.angle.is_finite() && e.angular_acceleration.is_finite()
            );
            if !e.defined {
                assert!(e.condition_number.is_infinite());
            }
        }
    }
    // Right at the boundary: defined with α = 90°; just past it: undefined.
    let e = est.update(g, 0.0, 0.0).expect("finite");
    assert!(e.defined && (e.angle - 90f64.to_radians()).abs() < 1e-12);
    assert!(
        !est.update(g * (1.0 + 1e-9), 0.0, 0.0)
            .expect("finite")
            .defined
    );
}

/// det H = −g·r·c₀, so κ(H) of the 3×3 solve grows like 1/cos α: κ·cos α tends to a constant
/// as α → 90° (and κ itself grows monotonically).
#[test]
fn linear3_condition_number_grows_like_inverse_cosine() {
    let angles = [
        60.0, 70.0, 80.0, 85.0, 88.0, 89.0, 89.5, 89.9, 89.99, 89.999_f64,
    ];
    let mut kc = Vec::new();
    let mut last = 0.0;
    for a in angles {
        let alpha = a.to_radians();
        let cfg = config(BoomMethod::Linear3);
        let (ax, ay) = exact(&cfg, alpha, 0.0);
        let mut est = BoomEstimator::new(cfg).expect("valid");
        est.set_state(alpha, 0.0).expect("finite");
        let e = est.update(ax, ay, 0.0).expect("finite");
        assert!(
            e.condition_number > last,
            "κ must grow: {a}° {}",
            e.condition_number
        );
        last = e.condition_number;
        kc.push(e.condition_number * alpha.cos());
    }
    // κ·cos α is bounded over the whole range…
    let (lo, hi) = kc
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(l, h), &v| (l.min(v), h.max(v)));
    assert!(hi / lo < 2.0, "{kc:?}");
    // …and settles: from 89° on it changes by < 0.1 % (the next-order term is O(cos α)).
    let tail = &kc[5..];
    for v in tail {
        assert!((v / tail[tail.len() - 1] - 1.0).abs() < 1e-3, "{kc:?}");
    }
    // The closed-form κ agrees with an SVD of the same matrix.
    let cfg = config(BoomMethod::Linear3);
    let (g, r) = (cfg.g, cfg.sensor_radius);
    let a = 89.9_f64.to_radians();
    let h = DMatrix::from_row_slice(3, 3, &[g, 0.0, 0.0, 0.0, g, r, a.sin(), a.cos(), 0.0]);
    let sv = h.singular_values();
    let reference = sv[0] / sv[2];
    assert!((kc[7] / a.cos() / reference - 1.0).abs() < 1e-9);
}

/// The WLS hot path (reduced QR + Givens update, fixed-point v₆) equals the general dynamic
/// solver on the paper's 6×3 system with the v₆ implied by the returned ε, and its κ equals
/// κ₂(V^{1/2}H) by SVD.
#[test]
fn wls_cycle_matches_the_general_solver_with_self_consistent_weights() {
    for (eu, ru) in [
        (AngleUnit::Degree, AngleUnit::Degree),
        (AngleUnit::Radian, AngleUnit::Radian),
    ] {
        let cfg = BoomConfig {
            epsilon_unit: eu,
            epsilon_rate_unit: ru,
            ..BoomConfig::default()
        };
        let tr = RotationProfile::default().trajectory().expect("valid");
        let meas = ideal_accelerometer(cfg.g, cfg.sensor_radius);
        let mut est = BoomEstimator::new(cfg.clone()).expect("valid");
        let mut prev = None;
        for p in tr.points.iter().step_by(7).take(400) {
            let [ax, ay, az] = meas(p, 0.0, &ErrorVariant::plus(0.02));
            let e = est.update(ax, ay, az).expect("finite");
            if let Some((s0, c0, e0)) = prev {
                let k = eu.per_radian();
                let rate = (e.angular_acceleration - e0) / cfg.dt * ru.per_radian();
                let v6 = 0.5 / (1.0 + 2.0 * f64::abs(rate)).powi(2);
                let (g, r) = (cfg.g, cfg.sensor_radius);
                let h = DMatrix::from_row_slice(
                    6,
                    3,
                    &[
                        g,
                        0.0,
                        0.0,
                        0.0,
                        g,
                        r / k,
                        s0,
                        c0,
                        0.0,
                        1.0,
                        0.0,
                        0.0,
                        0.0,
                        1.0,
                        0.0,
                        0.0,
                        0.0,
                        1.0,
                    ],
                );
                let z = DVector::from_column_slice(&[ax, ay, 1.0, s0, c0, e0 * k]);
                let v = DVector::from_column_slice(&[f64::abs(c0), 1.0, 100.0, 1.0, 1.0, v6]);
                let s = solve(&h, &z, &Weights::Diagonal(v), &SolveOptions::default())
                    .expect("full rank");
                // The fixed point is met to 1e-10 rad/s² in ε; x depends on v₆ smoothly, so
                // the other unknowns agree to a similar level.
                assert!(
                    (s.x[0] - e.sin_sensor).abs() < 1e-9,
                    "{} vs {}",
                    s.x[0],
                    e.sin_sensor
                );
                assert!((s.x[1] - e.cos_sensor).abs() < 1e-9);
                assert!((s.x[2] / k - e.angular_acceleration).abs() < 1e-9);
                // v₆ is re-derived here from an ε that is only 1e-10 rad/s² from the fixed point,
                // i.e. ε̇ within ≈ 6e-7 °/s³: v₆ and κ agree to ≈ 1e-8 relative.
                assert!(
                    (s.condition_weighted / e.condition_number - 1.0).abs() < 1e-6,
                    "{} vs {}",
                    s.condition_weighted,
                    e.condition_number
                );
            }
            prev = Some((e.sin_sensor, e.cos_sensor, e.angular_acceleration));
        }
    }
}

/// QR and the paper's normal equations give the same boom estimates (κ(V^{1/2}H) ≈ 20).
#[test]
fn boom_qr_and_normal_equations_agree() {
    let tr = RotationProfile::default().trajectory().expect("valid");
    let base = BoomConfig::default();
    let meas = ideal_accelerometer(base.g, base.sensor_radius);
    let mut a = BoomEstimator::new(base.clone()).expect("valid");
    let mut b = BoomEstimator::new(BoomConfig {
        solver: BoomSolver::NormalEquations,
        ..base
    })
    .expect("valid");
    for p in &tr.points {
        let [ax, ay, az] = meas(p, 0.0, &ErrorVariant::minus(0.02));
        let (ea, eb) = (
            a.update(ax, ay, az).expect("ok"),
            b.update(ax, ay, az).expect("ok"),
        );
        assert!(
            (ea.angle - eb.angle).abs() < 1e-9
                && (ea.angular_acceleration - eb.angular_acceleration).abs() < 1e-9
        );
    }
}

#[test]
fn mounting_check_and_invalid_inputs() {
    let mut est = BoomEstimator::new(BoomConfig::default()).expect("valid");
    assert!(est.update(0.0, 9.8, 0.05).expect("ok").mounting_ok);
    assert!(!est.update(0.0, 9.8, -0.2).expect("ok").mounting_ok);
    assert!(matches!(
        est.update(f64::NAN, 9.8, 0.0),
        Err(Error::NonFinite { name: "a_x", .. })
    ));
    assert!(matches!(
        est.update(0.0, f64::INFINITY, 0.0),
        Err(Error::NonFinite { name: "a_y", .. })
    ));
    assert!(matches!(
        est.update(0.0, 9.8, f64::NAN),
        Err(Error::NonFinite { name: "a_z", .. })
    ));
    assert!(matches!(
        est.set_state(f64::NAN, 0.0),
        Err(Error::NonFinite { name: "angle", .. })
    ));
    let mut cfg = BoomConfig::default();
    cfg.weights.unit_circle = -1.0;
    assert!(matches!(
        BoomEstimator::new(cfg),
        Err(Error::NegativeWeight {
            name: "weights",
            index: 2,
            ..
        })
    ));
    let cfg = BoomConfig {
        sensor_radius: 0.0,
        ..BoomConfig::default()
    };
    assert!(matches!(
        BoomEstimator::new(cfg),
        Err(Error::InvalidParameter {
            name: "sensor_radius",
            ..
        })
    ));
    let cfg = BoomConfig {
        g: f64::NAN,
        ..BoomConfig::default()
    };
    assert!(matches!(
        BoomEstimator::new(cfg),
        Err(Error::InvalidParameter { name: "g", .. })
    ));
    let cfg = BoomConfig {
        rate_weight: RateWeight::FixedPoint {
            max_iterations: 0,
            tolerance: 1e-9,
        },
        ..BoomConfig::default()
    };
    assert!(matches!(
        BoomEstimator::new(cfg),
        Err(Error::InvalidParameter {
            name: "rate_weight.max_iterations",
            ..
        })
    ));
    let tr = [TrajectoryPoint {
        t: 0.0,
        alpha: 0.0,
        omega: 0.0,
        epsilon: 0.0,
    }];
    let meas = ideal_accelerometer(9.8, 25.0);
    let cfg = BoomConfig::default();
    assert!(matches!(
        sweep_gamma(
            &tr,
            &cfg,
            &meas,
            &[ErrorVariant::plus(0.02)],
            &[],
            Limits::paper()
        ),
        Err(Error::Shape { name: "gammas", .. })
    ));
    assert!(matches!(
        sweep_gamma(
            &tr,
            &cfg,
            &meas,
            &[ErrorVariant::plus(0.02)],
            &[0.1, 0.05],
            Limits::paper()
        ),
        Err(Error::InvalidParameter { name: "gammas", .. })
    ));
    let bad = Limits {
        angle: -1.0,
        ..Limits::paper()
    };
    assert!(matches!(
        run_turn(&tr, &cfg, &meas, &ErrorVariant::plus(0.02), bad),
        Err(Error::InvalidParameter {
            name: "limits.angle",
            ..
        })
    ));
}

#[test]
fn config_round_trips_through_serde() {
    let cfg = BoomConfig {
        sensor_offset_angle: 0.2,
        method: BoomMethod::Linear3,
        ..BoomConfig::default()
    };
    let text = serde_json::to_string(&cfg).expect("serialisable");
    let back: BoomConfig = serde_json::from_str(&text).expect("parsable");
    assert_eq!(back, cfg);
    let p = RotationProfile::default();
    let back: RotationProfile =
        serde_json::from_str(&serde_json::to_string(&p).expect("ok")).expect("ok");
    assert_eq!(back, p);
}
