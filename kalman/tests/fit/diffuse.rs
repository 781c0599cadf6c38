//! The exact diffuse initialisation (`kalman::fit::diffuse`): its log-likelihood against
//! statsmodels' (`use_exact_diffuse=True`, stored by `golden/make_nile.py`) on the Nile
//! local level and on a local linear trend with gaps inside the diffuse period, its exact
//! gradient against central differences, and the diffuse MLE reaching Durbin & Koopman's
//! table from a start four orders off.

use kalman::fit::{
    FitError, Free, MleOptions, Series, StandardMap, Structure, System, diffuse_log_likelihood,
    diffuse_log_likelihood_gradient, mle_diffuse,
};

fn golden() -> serde_json::Value {
    serde_json::from_str(include_str!("../golden/nile.json")).expect("nile JSON")
}

fn nile(g: &serde_json::Value) -> Vec<f64> {
    g["y"]
        .as_array()
        .expect("y")
        .iter()
        .map(|v| v.as_f64().expect("number"))
        .collect()
}

fn level(q: f64, r: f64) -> System {
    // P0 = 0: the level's prior is given by the diffuse part alone.
    System::new(&[[1.0]], &[[1.0]], &[[q]], &[[r]], &[0.0], &[[0.0]]).expect("system")
}

/// statsmodels' diffuse log-likelihood at Durbin & Koopman's variances, and at its own
/// optimum: 1e-10 relative (two exact recursions over 100 terms of order 6, differing only
/// by the order of their floating-point operations).
#[test]
fn the_local_level_diffuse_likelihood_is_statsmodels() {
    let g = golden();
    let y = nile(&g);
    let data = Series::new(&y, 1).expect("series");
    let want = g["exact_diffuse_level"]["loglike_at_durbin_koopman"]
        .as_f64()
        .expect("loglike");
    let got = diffuse_log_likelihood(&level(1469.1, 15099.0), &[0], &data).expect("ll");
    assert!((got - want).abs() <= 1e-10 * want.abs(), "{got} vs {want}");
    let opt = &g["exact_diffuse_level"]["statsmodels_optimum"];
    let (eps, eta) = (
        opt["params"][0].as_f64().expect("eps"),
        opt["params"][1].as_f64().expect("eta"),
    );
    let want = opt["llf"].as_f64().expect("llf");
    let got = diffuse_log_likelihood(&level(eta, eps), &[0], &data).expect("ll");
    assert!((got - want).abs() <= 1e-10 * want.abs(), "{got} vs {want}");
}

/// A local linear trend (two diffuse states, so the diffuse period spans two observations)
/// on the Nile with four gaps, one of them (row 1) inside the diffuse period: statsmodels'
/// number to 1e-10 relative.
#[test]
fn a_two_state_diffuse_period_with_a_gap_inside_it_is_statsmodels() {
    let g = golden();
    let case = &g["exact_diffuse_trend_gaps"];
    let mut y = nile(&g);
    for k in case["missing"].as_array().expect("missing") {
        y[k.as_u64().expect("index") as usize] = f64::NAN;
    }
    let p: Vec<f64> = case["params"]
        .as_array()
        .expect("params")
        .iter()
        .map(|v| v.as_f64().expect("number"))
        .collect();
    assert_eq!(
        case["param_names"][0], "sigma2.irregular",
        "the stored order: irregular, level, trend"
    );
    let sys = System::new(
        &[[1.0, 1.0], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &[[p[1], 0.0], [0.0, p[2]]],
        &[[p[0]]],
        &[0.0, 0.0],
        &[[0.0, 0.0], [0.0, 0.0]],
    )
    .expect("system");
    let data = Series::new(&y, 1).expect("series");
    let want = case["loglike"].as_f64().expect("loglike");
    let got = diffuse_log_likelihood(&sys, &[0, 1], &data).expect("ll");
    assert!((got - want).abs() <= 1e-10 * want.abs(), "{got} vs {want}");
}

fn map(q0: f64, r0: f64) -> (StandardMap, System) {
    let base = level(q0, r0);
    let free = Free {
        q: Structure::Diag,
        r: Structure::Diag,
        ..Free::default()
    };
    (StandardMap::new(base.clone(), free).expect("map"), base)
}

/// The dual-number gradient against central differences of the likelihood (step 1e-5 in
/// the log-variances: truncation ~1e-10, rounding ~1e-16·630/1e-5 ≈ 1e-8; 1e-6 holds both).
#[test]
fn the_diffuse_gradient_is_the_likelihoods_slope() {
    let y = nile(&golden());
    let data = Series::new(&y, 1).expect("series");
    let (map, _) = map(1.0, 1.0);
    let theta = [7.0, 9.5];
    let (ll, grad) = diffuse_log_likelihood_gradient(&map, &theta, &[0], &data).expect("grad");
    assert!(ll.is_finite());
    for j in 0..2 {
        let h = 1e-5;
        let (mut a, mut b) = (theta, theta);
        a[j] += h;
        b[j] -= h;
        let f = |t: &[f64]| {
            diffuse_log_likelihood_gradient(&map, t, &[0], &data)
                .expect("ll")
                .0
        };
        let fd = (f(&a) - f(&b)) / (2.0 * h);
        assert!(
            (grad[j] - fd).abs() <= 1e-6 * grad[j].abs().max(1.0),
            "θ{j}: {} vs {fd}",
            grad[j]
        );
    }
}

/// The exact-diffuse MLE gives D&K's σ²_ε = 15099 and σ²_η = 1469.1 (five significant
/// digits: asserted at 1e-4 relative) from Q = R = 1 as from a good start, with a diffuse
/// log-likelihood at least statsmodels' at D&K's values (the optimum can only be higher;
/// 1e-6 for the optimiser's last digits).
#[test]
fn the_diffuse_mle_reaches_durbin_and_koopmans_table_from_far_off() {
    let g = golden();
    let y = nile(&g);
    let data = Series::new(&y, 1).expect("series");
    let (eps, eta) = (
        g["durbin_koopman"]["sigma2_eps"].as_f64().expect("eps"),
        g["durbin_koopman"]["sigma2_eta"].as_f64().expect("eta"),
    );
    let best = g["exact_diffuse_level"]["loglike_at_durbin_koopman"]
        .as_f64()
        .expect("loglike");
    for (q0, r0) in [(1.0, 1.0), (1500.0, 15000.0)] {
        let (map, base) = map(q0, r0);
        let fit = mle_diffuse(
            &map,
            map.theta_of(&base, Some(&data)),
            &[0],
            &data,
            &MleOptions::default(),
        )
        .expect("mle");
        assert!(fit.converged, "from Q = {q0}, R = {r0}: {}", fit.message);
        let (r, q) = (fit.system.r[(0, 0)], fit.system.q[(0, 0)]);
        assert!((r - eps).abs() <= 1e-4 * eps, "σ²_ε {r} vs {eps}");
        assert!((q - eta).abs() <= 1e-4 * eta, "σ²_η {q} vs {eta}");
        assert!(fit.loglik >= best - 1e-6, "{} vs {best}", fit.loglik);
        assert!(fit.uncertainty.std_errors.is_some() && fit.uncertainty.correlation.is_some());
    }
}

/// A diffuse state that does not exist, or is listed twice, is named.
#[test]
fn bad_diffuse_lists_are_named() {
    let y = [1.0, 2.0, 3.0];
    let data = Series::new(&y, 1).expect("series");
    let sys = level(1.0, 1.0);
    for (list, what) in [(&[1][..], "does not exist"), (&[0, 0][..], "twice")] {
        let e = diffuse_log_likelihood(&sys, list, &data).expect_err("refused");
        assert!(
            matches!(&e, FitError::Parameters(m) if m.contains(what)),
            "{e}"
        );
    }
}

/// A prior so wide that the first update keeps fewer than 7 of its 16 digits (Nile's
/// variance is 2.9e4, so P0 = 1e15 is 3.5e10 times it) is refused by the MLE and by EM with
/// a pointer to the diffuse initialisation; P0 = 1e10 (3.5e5 times) is taken.
#[test]
fn a_prior_that_swamps_the_first_update_is_refused() {
    let y = nile(&golden());
    let data = Series::new(&y, 1).expect("series");
    let free = Free {
        q: Structure::Diag,
        r: Structure::Diag,
        ..Free::default()
    };
    for (p0, refused) in [(1e15, true), (1e10, false)] {
        let base = System::new(
            &[[1.0]],
            &[[1.0]],
            &[[1500.0]],
            &[[15000.0]],
            &[0.0],
            &[[p0]],
        )
        .expect("system");
        let map = StandardMap::new(base.clone(), free).expect("map");
        let mle = kalman::fit::mle(
            &map,
            map.theta_of(&base, Some(&data)),
            &data,
            &MleOptions::default(),
        );
        let em = kalman::fit::em(&map, &data, &kalman::fit::EmOptions::default());
        for (name, r) in [("mle", mle.map(|_| ())), ("em", em.map(|_| ()))] {
            match (refused, r) {
                (true, Err(e)) => assert!(e.to_string().contains("diffuse"), "{name}: {e}"),
                (false, Ok(())) => {}
                (want, got) => panic!("{name} at P0 = {p0}: refused {want}, got {got:?}"),
            }
        }
    }
}
