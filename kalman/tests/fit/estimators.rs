//! MLE and EM: the same optimum on a local linear trend; Wald coverage over simulated
//! series for Q, R and for a shaping filter's parameters; bad input.

use faer::Mat;
use kalman::fit::{
    Derivative, EmOptions, FitError, FnMap, Free, Interrupt, MleOptions, ParamMap, Series,
    StandardMap, Structure, System, em, mle,
};

use super::common::{binomial_band, llt, mle_from, mle_qr, rng, simulate_diag};

#[test]
fn mle_and_em_reach_the_same_optimum_on_a_local_linear_trend() {
    let truth = llt(0.5, 0.01, 4.0, [0.0, 0.1], [1.0, 0.01]);
    let z = simulate_diag(&truth, 400, &mut rng(21));
    let data = Series::new(&z, 1).expect("series");
    let base = llt(1.0, 1.0, 1.0, [z[0], 0.0], [10.0, 1.0]);
    let map = StandardMap::new(
        base.clone(),
        Free {
            q: Structure::Diag,
            r: Structure::Diag,
            ..Free::default()
        },
    )
    .expect("map");
    let fm = mle_from(&map, &base, &data);
    let fe = em(&map, &data, &EmOptions::default()).expect("em");
    assert!(fm.converged, "{}", fm.message);
    assert!(fe.converged, "{}", fe.message);
    assert!(
        (fm.loglik - fe.loglik).abs() < 1e-3,
        "MLE {} vs EM {} ({} EM iterations)",
        fm.loglik,
        fe.loglik,
        fe.iterations
    );
    // Information criteria follow from the log-likelihood and the 3 parameters.
    assert!((fm.aic - (6.0 - 2.0 * fm.loglik)).abs() < 1e-9);
    assert!((fm.bic - (3.0 * 400f64.ln() - 2.0 * fm.loglik)).abs() < 1e-9);
}

/// A fit whose interruption check fires stops with `FitError::Interrupted` (after the
/// calls the check counts: EM before its fourth iteration, the MLE before its fourth
/// likelihood evaluation, well short of convergence on this record), and a check that
/// never fires changes nothing.
#[test]
fn an_interrupted_fit_stops_with_a_typed_error() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static EM_CALLS: AtomicUsize = AtomicUsize::new(0);
    static MLE_CALLS: AtomicUsize = AtomicUsize::new(0);
    fn em_stop() -> bool {
        EM_CALLS.fetch_add(1, Ordering::SeqCst) >= 3
    }
    fn mle_stop() -> bool {
        MLE_CALLS.fetch_add(1, Ordering::SeqCst) >= 3
    }
    fn never() -> bool {
        false
    }
    let truth = llt(0.5, 0.01, 4.0, [0.0, 0.1], [1.0, 0.01]);
    let z = simulate_diag(&truth, 400, &mut rng(21));
    let data = Series::new(&z, 1).expect("series");
    let base = llt(1.0, 1.0, 1.0, [z[0], 0.0], [10.0, 1.0]);
    let free = Free {
        q: Structure::Diag,
        r: Structure::Diag,
        ..Free::default()
    };
    let map = StandardMap::new(base, free).expect("map");
    let em_opts = |f| EmOptions {
        interrupt: Some(Interrupt(f)),
        ..EmOptions::default()
    };
    assert_eq!(
        em(&map, &data, &em_opts(em_stop)).map(|f| f.loglik),
        Err(FitError::Interrupted)
    );
    assert_eq!(EM_CALLS.load(Ordering::SeqCst), 4);
    let mle_opts = |f| MleOptions {
        interrupt: Some(Interrupt(f)),
        ..MleOptions::default()
    };
    let theta0 = vec![0.0; 3];
    let err = mle(&map, theta0.clone(), &data, &mle_opts(mle_stop)).map(|f| f.loglik);
    assert_eq!(err, Err(FitError::Interrupted));
    assert_eq!(MLE_CALLS.load(Ordering::SeqCst), 4);
    let plain = mle(&map, theta0.clone(), &data, &MleOptions::default()).expect("fit");
    let checked = mle(&map, theta0, &data, &mle_opts(never)).expect("fit");
    assert_eq!(plain.theta, checked.theta);
    let em_plain = em(&map, &data, &EmOptions::default()).expect("em");
    assert_eq!(
        em(&map, &data, &em_opts(never)).expect("em").theta,
        em_plain.theta
    );
}

/// A random walk of variance q per step seen by two channels of variance r each, from
/// x0 = 0 with variance p0.
fn walk_two_channels(q: f64, r: f64, p0: f64) -> System {
    System::new(
        &[[1.0]],
        &[[1.0], [1.0]],
        &[[q]],
        &[[r, 0.0], [0.0, r]],
        &[0.0],
        &[[p0]],
    )
    .expect("two-channel walk")
}

#[test]
fn em_honours_constraints_and_agrees_with_mle_with_missing_data() {
    // Two measurement channels of one random walk with scalar R, some entries missing.
    let truth = walk_two_channels(0.3, 1.0, 1.0);
    let mut z = simulate_diag(&truth, 300, &mut rng(5));
    for k in (0..300).step_by(7) {
        z[2 * k + (k % 2)] = f64::NAN;
    }
    let data = Series::new(&z, 2).expect("series");
    let base = walk_two_channels(1.0, 2.0, 10.0);
    let map = StandardMap::new(
        base,
        Free {
            q: Structure::Scalar,
            r: Structure::Scalar,
            ..Free::default()
        },
    )
    .expect("map");
    let fe = em(&map, &data, &EmOptions::default()).expect("em");
    let fm = mle_from(&map, map.base(), &data);
    assert!(
        (fm.loglik - fe.loglik).abs() < 1e-3,
        "{} vs {}",
        fm.loglik,
        fe.loglik
    );
    // Scalar R stays σ²·I.
    let R = &fe.system.r;
    assert!(R[(0, 1)].abs() < 1e-300 && (R[(0, 0)] - R[(1, 1)]).abs() < 1e-15 * R[(0, 0)]);
}

fn wald_covers(est: f64, se: f64, truth: f64) -> bool {
    (est - truth).abs() <= 1.959_963_984_540_054 * se
}

#[test]
fn wald_intervals_of_q_and_r_cover_at_the_nominal_rate() {
    // Local level, q = 1, r = 2, 300 steps, 200 series; intervals on θ = ln σ².
    let (q, r) = (1.0, 2.0);
    let truth = System::new(&[[1.0]], &[[1.0]], &[[q]], &[[r]], &[0.0], &[[1.0]]).expect("sys");
    let mut g = rng(99);
    let mut cover = [0usize; 2];
    let runs = 200;
    for _ in 0..runs {
        let z = simulate_diag(&truth, 300, &mut g);
        let data = Series::new(&z, 1).expect("series");
        let base =
            System::new(&[[1.0]], &[[1.0]], &[[0.5]], &[[0.5]], &[0.0], &[[1.0]]).expect("base");
        let (_, fit) = mle_qr(&base, Structure::Scalar, Structure::Scalar, &data);
        let se = fit.uncertainty.std_errors.expect("standard errors");
        cover[0] += usize::from(wald_covers(fit.theta[0], se[0], q.ln()));
        cover[1] += usize::from(wald_covers(fit.theta[1], se[1], r.ln()));
    }
    let (lo, hi) = binomial_band(runs, 0.95);
    for (name, c) in ["Q", "R"].iter().zip(cover) {
        assert!(
            (lo..=hi).contains(&c),
            "{name}: {c}/{runs} intervals cover, band [{lo}, {hi}]"
        );
    }
}

/// The exponential shaping filter (first-order Gauss–Markov, correlation `σ² e^{−μ|τ|}`)
/// sampled at Δt, measured with noise variance `r`; θ = (ln σ², ln μ). Exact
/// discretisation `φ = e^{−μΔt}`, `q = σ²(1 − φ²)`, stationary prior `P0 = σ²`.
fn exponential_map(dt: f64, r: f64) -> impl ParamMap {
    let sys = move |t: &[f64]| {
        let (v, mu) = (t[0].exp(), t[1].exp());
        let phi = (-mu * dt).exp();
        System::new(
            &[[phi]],
            &[[1.0]],
            &[[v * (1.0 - phi * phi)]],
            &[[r]],
            &[0.0],
            &[[v]],
        )
    };
    let der = move |t: &[f64]| {
        let (v, mu) = (t[0].exp(), t[1].exp());
        let phi = (-mu * dt).exp();
        let dphi = -mu * dt * phi; // ∂φ/∂ln μ
        let s = |a: f64| Some(Mat::from_fn(1, 1, |_, _| a));
        Ok(vec![
            Derivative {
                q: s(v * (1.0 - phi * phi)),
                p0: s(v),
                ..Derivative::default()
            },
            Derivative {
                f: s(dphi),
                q: s(-2.0 * v * phi * dphi),
                ..Derivative::default()
            },
        ])
    };
    FnMap::with_derivatives(2, sys, der).with_log_variances(vec![0])
}

#[test]
fn wald_intervals_of_a_shaping_filter_cover_at_the_nominal_rate() {
    // σ² = 1, μ = 0.2 at Δt = 1 (φ ≈ 0.82), 500 samples (100 correlation times), 200 series.
    let (v, mu, dt, r): (f64, f64, f64, f64) = (1.0, 0.2, 1.0, 0.05);
    let map = exponential_map(dt, r);
    let truth_theta = [v.ln(), f64::ln(mu)];
    let truth = map.system(&truth_theta).expect("truth");
    let mut g = rng(7);
    let mut cover = [0usize; 2];
    let runs = 200;
    for _ in 0..runs {
        let z = simulate_diag(&truth, 500, &mut g);
        let data = Series::new(&z, 1).expect("series");
        let fit = mle(
            &map,
            vec![0.5f64.ln(), 0.5f64.ln()],
            &data,
            &MleOptions::default(),
        )
        .expect("mle");
        assert!(fit.converged, "{}", fit.message);
        let se = fit.uncertainty.std_errors.expect("standard errors");
        for i in 0..2 {
            cover[i] += usize::from(wald_covers(fit.theta[i], se[i], truth_theta[i]));
        }
    }
    let (lo, hi) = binomial_band(runs, 0.95);
    for (name, c) in ["σ²", "μ"].iter().zip(cover) {
        assert!(
            (lo..=hi).contains(&c),
            "{name}: {c}/{runs} intervals cover, band [{lo}, {hi}]"
        );
    }
}

#[test]
fn bad_input_is_a_typed_error() {
    let base = walk_two_channels(1.0, 1.0, 1.0);
    assert_eq!(
        StandardMap::new(base.clone(), Free::default()).err(),
        Some(FitError::NothingFree)
    );
    assert_eq!(
        Series::new(&[f64::NAN, f64::NAN], 2).err(),
        Some(FitError::NoMeasurements)
    );
    // Channel 1 never observed: its R entry cannot be learned.
    let z = [1.0, f64::NAN, 2.0, f64::NAN, 1.5, f64::NAN];
    let data = Series::new(&z, 2).expect("series");
    let map = StandardMap::new(
        base,
        Free {
            r: Structure::Diag,
            ..Free::default()
        },
    )
    .expect("map");
    assert!(matches!(
        em(&map, &data, &EmOptions::default()),
        Err(FitError::NotIdentifiable { .. })
    ));
    // Wrong θ length.
    assert!(matches!(
        mle(&map, vec![0.0], &data, &MleOptions::default()),
        Err(FitError::Parameters(_))
    ));
    // An iteration cap that stops EM early is flagged, not silent.
    let z: Vec<f64> = (0..50)
        .flat_map(|k| [k as f64 * 0.1, k as f64 * 0.1 + 0.3])
        .collect();
    let data = Series::new(&z, 2).expect("series");
    let fit = em(
        &map,
        &data,
        &EmOptions {
            tol: 1e-12,
            max_iter: 2,
            ..EmOptions::default()
        },
    )
    .expect("em");
    assert!(
        !fit.converged && fit.message.contains("cap"),
        "{}",
        fit.message
    );
}
