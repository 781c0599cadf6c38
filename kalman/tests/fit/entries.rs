//! Free matrix entries ([`Param`]): statsmodels' SARIMAX(2,0,0) with measurement error on a
//! record with gaps (stored by `tests/golden/make_statsmodels_ar2.py`), the exact gradient
//! through ∂F, ∂B, ∂H, ∂x0 and shared parameters against differences of the likelihood, the
//! refusals, and a named non-identified direction.

use kalman::CovarianceForm;

use super::common::{mle_from, rng, simulate_diag};
use kalman::fit::{
    EmOptions, FitError, Free, Matrix, MleOptions, Param, ParamMap, Series, StandardMap, Structure,
    System, Transform, em, log_likelihood, log_likelihood_gradient, mle,
};

fn golden() -> serde_json::Value {
    serde_json::from_str(include_str!("../golden/statsmodels_ar2.json")).expect("golden JSON")
}

fn num(v: &serde_json::Value) -> f64 {
    v.as_f64().expect("number")
}

/// SARIMAX's AR(2)-plus-noise state space at (φ1, φ2, σ²_ε, σ²) with the stored prior.
fn ar2(g: &serde_json::Value, phi1: f64, phi2: f64, meas: f64, sigma2: f64) -> System {
    System::new(
        &[[phi1, 1.0], [phi2, 0.0]],
        &[[1.0, 0.0]],
        &[[sigma2, 0.0], [0.0, 0.0]],
        &[[meas]],
        &[num(&g["x0"][0]), num(&g["x0"][1])],
        &[[num(&g["P0_diag"][0]), 0.0], [0.0, num(&g["P0_diag"][1])]],
    )
    .expect("valid AR(2)")
}

fn ar2_params() -> Vec<Param> {
    vec![
        Param::entry(Matrix::F, 0, 0),
        Param::entry(Matrix::F, 1, 0),
        Param::entry(Matrix::Q, 0, 0),
        Param::entry(Matrix::R, 0, 0),
    ]
}

/// The SARIMAX name of each of our parameters.
const NAMES: [(&str, &str); 4] = [
    ("F[0,0]", "ar.L1"),
    ("F[1,0]", "ar.L2"),
    ("Q[0,0]", "sigma2"),
    ("R[0,0]", "var.measurement_error"),
];

#[test]
fn ar2_with_measurement_error_matches_statsmodels_sarimax() {
    let g = golden();
    let y: Vec<f64> = g["y"]
        .as_array()
        .expect("y")
        .iter()
        .map(|v| v.as_f64().unwrap_or(f64::NAN))
        .collect();
    assert!(
        y.iter().filter(|v| v.is_nan()).count() > 25,
        "the record has gaps"
    );
    let data = Series::new(&y, 1).expect("series");
    let p = |key: &str, name: &str| num(&g[key][name]);
    // The likelihood itself at fixed parameters: two exact evaluations of one number, 800
    // steps of round-off apart (|ln L| ≈ 1.3e3, so 1e-9 relative is ~1e-6 absolute).
    // The AR(2) at one of the stored parameter sets.
    let ar2_at = |set: &str| {
        ar2(
            &g,
            p(set, "ar.L1"),
            p(set, "ar.L2"),
            p(set, "var.measurement_error"),
            p(set, "sigma2"),
        )
    };
    let sys = ar2_at("check_params");
    let ll = log_likelihood(&sys, &data, CovarianceForm::Joseph).expect("ll");
    let want = num(&g["check_llf"]);
    assert!(
        (ll - want).abs() <= 1e-9 * want.abs(),
        "ln L {ll} vs {want}"
    );
    // The MLE from statsmodels' start.
    let base = ar2_at("start");
    let map = StandardMap::with_params(base.clone(), Free::default(), ar2_params()).expect("map");
    let fit = mle_from(&map, &base, &data);
    assert!(fit.converged, "{}", fit.message);
    // Both optimisers stop on a gradient tolerance, where ln L is flat to second order:
    // the two optima agree far inside 1e-3.
    let llf = num(&g["llf"]);
    assert!(
        (fit.loglik - llf).abs() <= 1e-3,
        "ln L {} vs {llf}",
        fit.loglik
    );
    let values = map.param_values(&fit.theta).expect("values");
    let cov = fit.uncertainty.covariance.as_ref().expect("covariance");
    let se = map.matrix_std_errors(&fit.theta, cov).expect("se").params;
    for (i, (ours, theirs)) in NAMES.iter().enumerate() {
        assert_eq!(values[i].0, *ours);
        assert_eq!(se[i].0, *ours);
        let (est, sd) = (values[i].1, se[i].1);
        let (sm, oim, approx) = (
            p("params", theirs),
            p("bse_oim", theirs),
            p("bse_approx", theirs),
        );
        // Same optimum: within 2 % of a standard error.
        assert!(
            (est - sm).abs() <= 0.02 * oim,
            "{ours}: {est} vs statsmodels {sm} (se {oim})"
        );
        // Harvey's OIM drops the terms of zero expectation (6 % apart from the Hessian
        // here): 10 %. The numerical Hessian of ln L is our information itself, up to
        // both finite-difference steps: 2 %.
        assert!(
            (sd - oim).abs() <= 0.10 * oim,
            "{ours}: se {sd} vs OIM {oim}"
        );
        assert!(
            (sd - approx).abs() <= 0.02 * approx,
            "{ours}: se {sd} vs statsmodels' Hessian {approx}"
        );
    }
    // Every entry not freed is kept exactly.
    assert!((fit.system.f[(0, 1)] - 1.0).abs() == 0.0 && fit.system.f[(1, 1)].abs() == 0.0);
    assert!(fit.system.q[(1, 1)].abs() == 0.0 && fit.system.h[(0, 1)].abs() == 0.0);
    // And the correlation matrix: symmetric, unit diagonal, φ1 and φ2 negatively correlated.
    let r = fit.uncertainty.correlation.as_ref().expect("correlation");
    for i in 0..4 {
        assert!((r[(i, i)] - 1.0).abs() < 1e-15);
        for j in 0..4 {
            assert!((r[(i, j)] - r[(j, i)]).abs() < 1e-15 && r[(i, j)].abs() <= 1.0);
        }
    }
    assert!(r[(0, 1)] < -0.3, "corr(φ1, φ2) = {}", r[(0, 1)]);
}

/// A two-state model with an input, every kind of entry free: F, B, H, x0, a shared Q
/// intensity over three cells, a tanh-bounded entry and an off-diagonal R.
fn rich() -> (StandardMap, Vec<f64>, Vec<f64>, Vec<f64>) {
    let base = System::new(
        &[[0.9, 0.1], [-0.2, 0.7]],
        &[[1.0, 0.0], [0.3, 1.0]],
        &[[0.02, 0.01], [0.01, 0.5]],
        &[[0.4, 0.1], [0.1, 0.3]],
        &[0.5, -0.2],
        &[[2.0, 0.0], [0.0, 1.0]],
    )
    .and_then(|s| s.with_control(&[[0.5], [1.0]]))
    .expect("system");
    let dt: f64 = 0.5;
    let params = vec![
        Param::entry(Matrix::F, 0, 1),
        Param::entry(Matrix::F, 1, 1).transformed(Transform::Tanh),
        Param::entry(Matrix::B, 1, 0),
        Param::entry(Matrix::H, 1, 0),
        Param::entry(Matrix::X0, 1, 0),
        Param::entry(Matrix::R, 1, 0),
        Param::shared("q", Transform::Log)
            .with(Matrix::Q, 0, 0, dt.powi(3) / 3.0)
            .with(Matrix::Q, 1, 0, dt.powi(2) / 2.0)
            .with(Matrix::Q, 1, 1, dt),
        Param::entry(Matrix::P0, 0, 0),
    ];
    let map = StandardMap::with_params(
        base.clone(),
        Free {
            r: Structure::Fixed,
            ..Free::default()
        },
        params,
    )
    .expect("map");
    let z: Vec<f64> = (0..120)
        .flat_map(|k| {
            let t = k as f64;
            let a = if k % 17 == 5 {
                f64::NAN
            } else {
                (0.3 * t).sin()
            };
            [a, 0.5 * (0.11 * t).cos() + 0.1 * (1.7 * t).sin()]
        })
        .collect();
    let u: Vec<f64> = (0..120).map(|k| (0.05 * k as f64).cos()).collect();
    let theta = vec![0.05, 0.8, 0.9, 0.25, -0.1, 0.05, 0.2_f64.ln(), 1.5_f64.ln()];
    (map, theta, z, u)
}

#[test]
fn the_score_recursion_is_exact_for_every_kind_of_entry() {
    // The recursion's gradient against central differences of the filter's ln L with step
    // 1e-5: truncation h²·|∂³ln L| ≈ 1e-10·10², round-off ε·|ln L|/h ≈ 1e-16·300/1e-5 ≈ 3e-9;
    // asserted at 1e-5 relative to max(1, |g_i|).
    let (map, theta, z, u) = rich();
    let data = Series::new(&z, 2)
        .and_then(|s| s.with_inputs(&u, 1))
        .expect("series");
    let (ll, g) = log_likelihood_gradient(&map, &theta, &data).expect("gradient");
    let ll_filter = log_likelihood(
        &map.system(&theta).expect("sys"),
        &data,
        CovarianceForm::Joseph,
    )
    .expect("ll");
    assert!(
        (ll - ll_filter).abs() <= 1e-10 * ll.abs(),
        "{ll} vs {ll_filter}"
    );
    let h = 1e-5;
    for i in 0..theta.len() {
        let at = |d: f64| {
            let mut t = theta.clone();
            t[i] += d;
            log_likelihood(&map.system(&t).expect("sys"), &data, CovarianceForm::Joseph)
                .expect("ll")
        };
        let fd = (at(h) - at(-h)) / (2.0 * h);
        assert!(
            (g[i] - fd).abs() <= 1e-5 * g[i].abs().max(1.0),
            "{}: score {} vs differences {fd}",
            map.names()[i],
            g[i]
        );
        assert!(
            g[i].abs() > 1e-6,
            "{}: a zero gradient tests nothing",
            map.names()[i]
        );
    }
    // The map wrote what it was asked to: the mirror of R[1,0], the shared Q, tanh F[1,1].
    let sys = map.system(&theta).expect("sys");
    assert!((sys.r[(0, 1)] - 0.05).abs() < 1e-15 && (sys.r[(1, 0)] - 0.05).abs() < 1e-15);
    assert!(
        (sys.q[(1, 1)] - 0.2 * 0.5).abs() < 1e-15 && (sys.q[(0, 1)] - 0.2 * 0.125).abs() < 1e-15
    );
    assert!((sys.f[(1, 1)] - 0.8_f64.tanh()).abs() < 1e-15);
    assert!((sys.f[(0, 0)] - 0.9).abs() == 0.0 && (sys.b[(0, 0)] - 0.5).abs() == 0.0);
}

#[test]
fn bad_entries_are_refused_with_their_names() {
    let (map, ..) = rich();
    let base = map.base().clone();
    let refused =
        |free: Free, params: Vec<Param>| match StandardMap::with_params(base.clone(), free, params)
        {
            Err(FitError::Parameters(m)) => m,
            other => panic!("expected a parameter error, got {other:?}"),
        };
    let m = refused(Free::default(), vec![Param::entry(Matrix::F, 2, 0)]);
    assert!(m.contains("F[2,0] is outside the 2×2 matrix F"), "{m}");
    let m = refused(Free::default(), vec![Param::entry(Matrix::B, 0, 1)]);
    assert!(m.contains("outside the 2×1 matrix B"), "{m}");
    let m = refused(
        Free {
            q: Structure::Diag,
            ..Free::default()
        },
        vec![Param::entry(Matrix::Q, 0, 0)],
    );
    assert!(m.contains("Q is already free as a whole"), "{m}");
    let m = refused(
        Free::default(),
        vec![Param::entry(Matrix::Q, 0, 1), Param::entry(Matrix::Q, 1, 0)],
    );
    assert!(m.contains("Q[1,0] is set by both Q[0,1] and Q[1,0]"), "{m}");
    let m = refused(
        Free::default(),
        vec![Param::shared("k", Transform::Identity).with(Matrix::H, 0, 0, 0.0)],
    );
    assert!(m.contains("coefficient of H[0,0] is 0"), "{m}");
    let m = refused(Free::default(), vec![Param::shared("k", Transform::Log)]);
    assert!(m.contains("k sets no matrix entry"), "{m}");
    // EM has no closed-form M-step for an entry: refused, not silently left at its start.
    let em_map =
        StandardMap::with_params(base, Free::default(), vec![Param::entry(Matrix::F, 0, 0)])
            .expect("map");
    let z = [0.1, 0.2, 0.3, -0.1, 0.0, 0.4, 0.2, 0.1];
    match em(
        &em_map,
        &Series::new(&z, 2).expect("series"),
        &EmOptions::default(),
    ) {
        Err(FitError::Unsupported(m)) => assert!(m.contains("F[0,0]"), "{m}"),
        other => panic!("expected Unsupported, got {other:?}"),
    }
}

#[test]
fn a_direction_the_data_do_not_identify_is_named() {
    // B enters only through u, and u is zero throughout: B[0,0] is free of the data, its
    // row of the information exactly zero, while F[0,0] and R[0,0] are identified.
    let base = System::new(&[[0.8]], &[[1.0]], &[[1.0]], &[[0.5]], &[0.0], &[[1.0]])
        .and_then(|s| s.with_control(&[[1.0]]))
        .expect("system");
    let params = vec![
        Param::entry(Matrix::F, 0, 0),
        Param::entry(Matrix::B, 0, 0),
        Param::entry(Matrix::R, 0, 0),
    ];
    let map = StandardMap::with_params(base.clone(), Free::default(), params).expect("map");
    let truth =
        System::new(&[[0.8]], &[[1.0]], &[[1.0]], &[[0.5]], &[0.0], &[[1.0]]).expect("truth");
    let z = simulate_diag(&truth, 300, &mut rng(41));
    let u = vec![0.0; 300];
    let data = Series::new(&z, 1)
        .and_then(|s| s.with_inputs(&u, 1))
        .expect("series");
    let opts = MleOptions::default();
    let fit = mle(&map, map.theta_of(&base, Some(&data)), &data, &opts).expect("mle");
    assert!(fit.uncertainty.covariance.is_none() && fit.uncertainty.std_errors.is_none());
    assert_eq!(
        fit.uncertainty.unidentified.len(),
        1,
        "{:?}",
        fit.uncertainty.unidentified
    );
    let dir = &fit.uncertainty.unidentified[0];
    assert_eq!(dir.len(), 1, "{dir:?}");
    assert_eq!(dir[0].0, "B[0,0]");
    assert!((dir[0].1 - 1.0).abs() < 1e-12, "{dir:?}");
    assert!(fit.message.contains("+1.00·B[0,0]"), "{}", fit.message);
}
