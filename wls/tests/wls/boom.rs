//! Tests of `wls::boom`: exactness on exact readings, the definedness of direct inversion,
//! the 1/cos α growth of the 3×3 condition number, the WLS reduced path against the general
//! solver, the paper's full turn with ±Δa and the γ sweep.

use nalgebra::{DMatrix, DVector};
use wls::Error;
use wls::boom::{
    AngleUnit, BoomConfig, BoomEstimator, BoomMethod, BoomSolver, ErrorVariant, Estimate, Limits,
    RateWeight, RotationProfile, TrajectoryPoint, WlsWeights, ideal_accelerometer, run_turn,
    sweep_gamma,
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

/// One cycle of a fresh estimator seeded at (α, ε₀) on exact readings at (α, ε).
fn seeded_cycle(cfg: &BoomConfig, alpha: f64, eps0: f64, eps: f64) -> Estimate {
    let mut est = BoomEstimator::new(cfg.clone()).expect("valid");
    est.set_state(alpha, eps0).expect("finite");
    let (ax, ay) = exact(cfg, alpha, eps);
    est.update(ax, ay, 0.0).expect("finite")
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
    let past = est.update(g * (1.0 + 1e-9), 0.0, 0.0).expect("finite");
    assert!(!past.defined);
    // The solved s = a_x/g is still reported, just outside [−1, 1] (two roundings).
    assert!(
        (past.sin_sensor - (1.0 + 1e-9)).abs() < 1e-15,
        "{}",
        past.sin_sensor
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
        let e = seeded_cycle(&config(BoomMethod::Linear3), alpha, 0.0, 0.0);
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
/// κ₂(V^{1/2}H) by SVD. Also on noisy readings (seeded, uniform within ±0.02 m/s² on a_x and
/// a_y), where ε̇
/// is large and the self-consistent v₆ is far from the one-solve start, so the search must
/// really converge rather than stop where it began.
#[test]
fn wls_cycle_matches_the_general_solver_with_self_consistent_weights() {
    use rand::{RngExt, SeedableRng};
    for (eu, ru, noisy) in [
        (AngleUnit::Degree, AngleUnit::Degree, false),
        (AngleUnit::Radian, AngleUnit::Radian, false),
        (AngleUnit::Degree, AngleUnit::Degree, true),
    ] {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let half_width = if noisy { 0.02 } else { 0.0 };
        let mut noise = move || rng.random_range(-1.0..1.0) * half_width;
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
            let (ax, ay) = (ax + noise(), ay + noise());
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
    let sweep = |gammas: &[f64]| {
        sweep_gamma(
            &tr,
            &cfg,
            &meas,
            &[ErrorVariant::plus(0.02)],
            gammas,
            Limits::paper(),
        )
    };
    assert!(matches!(
        sweep(&[]),
        Err(Error::Shape { name: "gammas", .. })
    ));
    assert!(matches!(
        sweep(&[0.1, 0.05]),
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

/// Max errors over the defined cycles after start-up (°, °/s²).
fn defined_maxima(run: &wls::boom::TurnRun) -> (f64, f64) {
    run.cycles
        .iter()
        .skip(1)
        .filter(|c| c.defined)
        .fold((0.0_f64, 0.0_f64), |(a, e), c| {
            (
                a.max(c.angle_error.to_degrees()),
                e.max(c.epsilon_error.to_degrees()),
            )
        })
}

/// The paper's full turn with constant errors ±Δa = 0.02 m/s² on a_x and a_y, Δα = 1°,
/// Δε = 0.5 °/s². Records what this implementation reproduces (see the crate docs and the
/// report): direct inversion and the 3×3 solve fail near the end; WLS at γ = 0 (default
/// units: ε in °/s² in the state, ε̇ in °/s³, v₆ at a fixed point) stays within limits for
/// "−" and exceeds Δε only slightly for "+" from α ≈ 79°; WLS at γ = 10° is within both
/// limits over the whole turn for both variants.
#[test]
fn full_turn_with_constant_errors_behaves_as_the_paper_describes() {
    let tr = RotationProfile::default().trajectory().expect("valid");
    let limits = Limits::paper();
    let base = BoomConfig::default();
    let meas = ideal_accelerometer(base.g, base.sensor_radius);
    let run = |cfg: &BoomConfig, v: &ErrorVariant| {
        run_turn(&tr.points, cfg, &meas, v, limits).expect("valid")
    };
    let (plus, minus) = (ErrorVariant::plus(0.02), ErrorVariant::minus(0.02));
    let deg = |o: Option<(f64, f64)>| o.map(|(_, a)| a.to_degrees());

    // Exact readings. The priors only penalise change from the previous cycle, so when ε
    // ramps (77–80°) the WLS lets c absorb the a_y change instead of ε: at γ = 0 even exact
    // readings leave a lag of ≈ 0.84° / 0.35 °/s², and s drifts past 1 (arcsin undefined)
    // from α ≈ 89.3°. At γ = 10° the lag is ≈ 0.19° / 0.09 °/s².
    let nominal = run(&base, &ErrorVariant::nominal());
    let (da, de) = defined_maxima(&nominal);
    assert!(da > 0.7 && da < 0.9 && de > 0.3 && de < 0.4, "{da} {de}");
    assert!(deg(nominal.first_undefined).is_some_and(|a| a > 89.0));
    let g10 = BoomConfig {
        sensor_offset_angle: 10f64.to_radians(),
        ..base.clone()
    };
    let nominal = run(&g10, &ErrorVariant::nominal());
    assert!(nominal.first_undefined.is_none());
    assert!(
        nominal.max_angle_error.to_degrees() < 0.2 && nominal.max_epsilon_error.to_degrees() < 0.1
    );

    // Direct inversion has no memory: exact along the moving trajectory too (up to the
    // 1/cos α amplification of rounding, < 1e-9 up to the last sample at ≈ 89.99°).
    let exact_run = run(&config(BoomMethod::Direct), &ErrorVariant::nominal());
    assert!(
        exact_run.max_angle_error < 1e-9 && exact_run.max_epsilon_error < 1e-9,
        "{} {}",
        exact_run.max_angle_error,
        exact_run.max_epsilon_error
    );

    for method in [BoomMethod::Direct, BoomMethod::Linear3] {
        let cfg = config(method);
        let p = run(&cfg, &plus);
        let m = run(&cfg, &minus);
        // Within limits for most of the turn, violated near the end (paper: from α ≈ 86°).
        let (vp, vm) = (
            deg(p.first_violation).expect("+ violates"),
            deg(m.first_violation).expect("− violates"),
        );
        assert!(
            (82.0..87.0).contains(&vp) && (82.0..87.0).contains(&vm),
            "{method:?}: {vp} {vm}"
        );
        // "+" pushes a_x past g: undefined from sin α = 1 − Δa/g, α ≈ 86.3° (paper: ≈ 88°).
        let up = deg(p.first_undefined).expect("+ becomes undefined");
        assert!((86.0..87.0).contains(&up), "{method:?}: {up}");
        assert!(m.first_undefined.is_none() && m.max_angle_error.to_degrees() > 3.0);
    }

    // WLS, γ = 0: "−" within limits; "+" exceeds Δε slightly from α ≈ 79°.
    let m = run(&base, &minus);
    assert!(m.first_violation.is_none(), "{:?}", m.first_violation);
    let p = run(&base, &plus);
    let vp = deg(p.first_violation).expect("+ exceeds");
    assert!((78.0..82.0).contains(&vp), "{vp}");
    let (da, de) = defined_maxima(&p);
    assert!(de > 0.5 && de < 0.6, "δε⁺ max {de} °/s²");
    // Not reproduced: the paper reports δα⁺ within 1°; here it reaches ≈ 1.4° (a stuck ε of
    // 0.57 °/s² must be absorbed by c in the a_y row: Δc·g = Δε·r ⇒ Δα ≈ 1.4° at 80°), and
    // arcsin of s > 1 leaves "+" undefined in the last 1.5° of the turn.
    assert!(da > 1.0 && da < 1.5, "δα⁺ max {da}°");
    assert!(deg(p.first_undefined).is_some_and(|a| a > 88.0));

    // WLS, γ = 10°: both variants within Δα = 1°, Δε = 0.5 °/s² over the whole turn.
    for v in [&plus, &minus] {
        let r = run(&g10, v);
        assert!(
            r.first_violation.is_none() && r.first_undefined.is_none(),
            "{}: {:?}",
            v.label(),
            r.first_violation
        );
        assert!(r.max_angle_error.to_degrees() < 0.6 && r.max_epsilon_error.to_degrees() < 0.3);
    }

    // Units matter: with ε in rad/s² in the state the ε₀ prior is 3283× weaker, WLS behaves
    // like direct inversion for "−" (δα ≈ 3.7° near the end) — not the paper's result.
    let rad = BoomConfig {
        epsilon_unit: AngleUnit::Radian,
        epsilon_rate_unit: AngleUnit::Radian,
        ..base.clone()
    };
    assert!(run(&rad, &minus).max_angle_error.to_degrees() > 3.0);
    // The evaluation time of v₆ hardly matters on this profile: previous-cycle ε̇ gives the
    // same maxima to 1e-3 °/s².
    let prev = BoomConfig {
        rate_weight: RateWeight::PreviousCycle,
        ..g10.clone()
    };
    let (a, b) = (run(&prev, &plus), run(&g10, &plus));
    assert!(
        (a.max_epsilon_error - b.max_epsilon_error)
            .to_degrees()
            .abs()
            < 1e-3
    );
}

/// The γ sweep over 0–20° (1° steps): with Δε = 0.5 °/s² the smallest feasible γ is 5° and
/// 10° (the paper's choice) is inside the window; with Δε = 0.25 °/s² it is 11°.
#[test]
fn gamma_sweep_finds_the_smallest_feasible_offset() {
    let tr = RotationProfile::default().trajectory().expect("valid");
    let base = BoomConfig::default();
    let meas = ideal_accelerometer(base.g, base.sensor_radius);
    let variants = [ErrorVariant::plus(0.02), ErrorVariant::minus(0.02)];
    let gammas: Vec<f64> = (0..=20).map(|k| f64::from(k).to_radians()).collect();
    let rep = sweep_gamma(
        &tr.points,
        &base,
        &meas,
        &variants,
        &gammas,
        Limits::paper(),
    )
    .expect("valid");
    let smallest = rep
        .smallest_feasible
        .expect("feasible γ exists")
        .to_degrees();
    assert!((smallest - 5.0).abs() < 1e-9, "{smallest}");
    let (lo, hi) = rep.window.expect("window");
    assert!(lo.to_degrees() <= 10.0 && hi.to_degrees() >= 10.0);
    // Errors fall monotonically with γ once defined (the bad direction moves out of reach).
    for w in rep.rows.windows(2).skip(2) {
        assert!(w[1].max_epsilon_error <= w[0].max_epsilon_error + 1e-12);
    }
    let strict = Limits {
        angular_acceleration: 0.25f64.to_radians(),
        ..Limits::paper()
    };
    let rep = sweep_gamma(&tr.points, &base, &meas, &variants, &gammas, strict).expect("valid");
    assert!((rep.smallest_feasible.expect("feasible").to_degrees() - 11.0).abs() < 1e-9);
}

/// A state seeded with a mounting offset γ = 10°: the Linear3 row s₀·s + c₀·c = 1 holds at
/// the truth only if the seed is the sensor angle β = α − γ, so one cycle on exact readings
/// from the seeded true state returns α (1e-10: the rounding bound of the test above). The
/// estimator keeps its configuration, and a reset makes the next cycle a start-up again.
#[test]
fn a_seeded_state_is_the_sensor_angle_and_a_reset_forgets_it() {
    let gamma = 10f64.to_radians();
    let cfg = BoomConfig {
        sensor_offset_angle: gamma,
        ..config(BoomMethod::Linear3)
    };
    let mut est = BoomEstimator::new(cfg.clone()).expect("valid");
    assert_eq!(est.config(), &cfg);
    for a in [5.0, 40.0, 75.0_f64] {
        let alpha = a.to_radians();
        let (ax, ay) = exact(&cfg, alpha, 0.004);
        est.set_state(alpha, 0.004).expect("finite");
        let e = est.update(ax, ay, 0.0).expect("finite");
        assert!(!e.startup && e.defined, "{a}°");
        assert!(
            (e.angle - alpha).abs() < 1e-10,
            "{a}°: {}",
            e.angle.to_degrees()
        );
        assert!((e.angular_acceleration - 0.004).abs() < 1e-10, "{a}°");
    }
    est.reset();
    let (ax, ay) = exact(&cfg, 0.3, 0.0);
    assert!(est.update(ax, ay, 0.0).expect("finite").startup);
}

/// With a zero weight on a_y (allowed: weights are ≥ 0) no row but the prior mentions ε, so
/// the self-consistent WLS cycle must return the previous cycle's ε unchanged, whatever the
/// new reading says, and still the angle from the other rows (1e-10: the exactness bound of
/// the first test; the a_x row and the priors agree at the truth).
#[test]
fn a_zero_weight_on_a_y_keeps_the_previous_acceleration() {
    let cfg = BoomConfig {
        weights: WlsWeights {
            ay: 0.0,
            ..WlsWeights::default()
        },
        ..config(BoomMethod::Wls)
    };
    assert!(matches!(cfg.rate_weight, RateWeight::FixedPoint { .. }));
    let alpha = 30f64.to_radians();
    let e = seeded_cycle(&cfg, alpha, 0.004, 0.009);
    assert!(e.defined, "{e:?}");
    assert!((e.angular_acceleration - 0.004).abs() < 1e-12, "{e:?}");
    assert!((e.angle - alpha).abs() < 1e-10, "{e:?}");
}

/// At α = 90° the solved s is 1 up to a few ulps, which the arcsin recovery must accept
/// (its slack is 4ε) rather than call the estimate undefined: Linear3 and WLS seeded at the
/// vertical on exact readings. asin is flat at 1, so an s error of a few ε moves α by up to
/// √(2·4ε) ≈ 3e-8 rad: 1e-7.
#[test]
fn the_vertical_boom_is_recovered_by_the_arcsin() {
    for method in [BoomMethod::Linear3, BoomMethod::Wls] {
        let alpha = 90f64.to_radians();
        let e = seeded_cycle(&config(method), alpha, 0.0, 0.0);
        assert!(e.defined, "{method:?}: {e:?}");
        assert!((e.angle - alpha).abs() < 1e-7, "{method:?}: {e:?}");
    }
}

/// The self-consistent search reports the v₆ evaluations it made: at least one on a cycle
/// where it runs (noisy readings make ε̇ and so v₆ move), never more than its cap, also when
/// the cap is 1 and the tolerance is out of reach.
#[test]
fn the_v6_search_counts_its_evaluations_up_to_its_cap() {
    use rand::{RngExt, SeedableRng};
    for (max_iterations, tolerance) in [(1, 1e-300), (50, 1e-10)] {
        let cfg = BoomConfig {
            rate_weight: RateWeight::FixedPoint {
                max_iterations,
                tolerance,
            },
            ..BoomConfig::default()
        };
        let tr = RotationProfile::default().trajectory().expect("valid");
        let meas = ideal_accelerometer(cfg.g, cfg.sensor_radius);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut est = BoomEstimator::new(cfg.clone()).expect("valid");
        let mut most = 0;
        for p in tr.points.iter().step_by(7).take(200) {
            let [ax, ay, az] = meas(p, 0.0, &ErrorVariant::nominal());
            let ay = ay + rng.random_range(-0.02..0.02);
            let e = est.update(ax, ay, az).expect("finite");
            assert!(e.iterations <= max_iterations, "{e:?}");
            if !e.startup {
                assert!(e.iterations >= 1, "{e:?}");
            }
            most = most.max(e.iterations);
        }
        assert!(most >= 1);
    }
}

/// The mounting tolerance may be zero (demand a_z = 0 exactly) but not negative or
/// non-finite; a bad one is refused by name.
#[test]
fn the_mounting_tolerance_is_checked_by_name() {
    for (value, valid) in [
        (0.0, true),
        (0.5, true),
        (-1e-9, false),
        (f64::NAN, false),
        (f64::INFINITY, false),
    ] {
        let cfg = BoomConfig {
            mounting_tolerance: value,
            ..BoomConfig::default()
        };
        match BoomEstimator::new(cfg) {
            Ok(_) => assert!(valid, "{value} accepted"),
            Err(Error::InvalidParameter { name, .. }) => {
                assert!(!valid, "{value} refused");
                assert_eq!(name, "mounting_tolerance");
            }
            Err(e) => panic!("{value}: {e:?}"),
        }
    }
}
