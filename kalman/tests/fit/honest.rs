//! EM is honest about what it cannot do and about where it stopped: x0 under a zero P0 is
//! refused, and a stop the gradient says is short of the optimum is flagged unconverged.

use kalman::fit::{
    EM_DECREMENT, EmOptions, FitError, Free, Series, StandardMap, Structure, System, em,
    log_likelihood_gradient,
};

use super::common::{llt, rng, simulate_diag};

#[test]
fn em_refuses_an_x0_that_a_zero_p0_pins() {
    // A local level with P0 = 0: the smoothed x_{0|N} equals x0, so EM's update of x0
    // is the identity; it must be refused, not reported as an estimate.
    let base =
        System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[0.0]]).expect("system");
    let z: Vec<f64> = (0..50).map(|k| 100.0 + (0.3 * k as f64).sin()).collect();
    let data = Series::new(&z, 1).expect("series");
    let free = Free {
        q: Structure::Diag,
        r: Structure::Diag,
        x0: true,
        ..Free::default()
    };
    let map = StandardMap::new(base, free).expect("map");
    match em(&map, &data, &EmOptions::default()) {
        Err(FitError::NotIdentifiable { what, why }) => {
            assert_eq!(what, "x0[0] by EM");
            assert!(why.contains("P0[0,0] = 0") && why.contains("MLE"), "{why}");
        }
        other => panic!("expected NotIdentifiable, got {other:?}"),
    }
}

#[test]
fn an_em_stop_short_of_the_optimum_is_not_called_converged() {
    // A local linear trend, Q (level, slope) and R free: EM crawls along the slope
    // variance's flat ridge. A loose tolerance stops it where the Newton decrement still
    // exceeds the bound: flagged unconverged with the remaining gain; the default
    // tolerance goes on to a point the gradient accepts.
    let truth = llt(0.5, 0.02, 4.0, [0.0, 0.1], [10.0, 1.0]);
    let z = simulate_diag(&truth, 400, &mut rng(8));
    let data = Series::new(&z, 1).expect("series");
    let base = llt(1.0, 1.0, 1.0, [0.0, 0.1], [10.0, 1.0]);
    let free = Free {
        q: Structure::Diag,
        r: Structure::Diag,
        ..Free::default()
    };
    let map = StandardMap::new(base, free).expect("map");
    let decrement = |theta: &[f64], cov: &faer::Mat<f64>| {
        let (_, g) = log_likelihood_gradient(&map, theta, &data).expect("gradient");
        let k = g.len();
        (0..k)
            .map(|i| (0..k).map(|j| g[i] * cov[(i, j)] * g[j]).sum::<f64>())
            .sum::<f64>()
    };
    let loose = em(
        &map,
        &data,
        &EmOptions {
            tol: 1e-5,
            max_iter: 10_000,
            ..EmOptions::default()
        },
    )
    .expect("em");
    let cov = loose.uncertainty.covariance.as_ref().expect("covariance");
    let d = decrement(&loose.theta, cov);
    assert!(
        d > EM_DECREMENT,
        "the loose stop is already optimal (decrement {d})"
    );
    assert!(!loose.converged, "{}", loose.message);
    assert!(
        loose.message.contains("EM not converged"),
        "{}",
        loose.message
    );
    let tight = em(&map, &data, &EmOptions::default()).expect("em");
    assert!(tight.converged, "{}", tight.message);
    let d = decrement(
        &tight.theta,
        tight.uncertainty.covariance.as_ref().expect("covariance"),
    );
    assert!(d <= EM_DECREMENT, "decrement {d}");
    assert!(tight.loglik > loose.loglik);
}

#[test]
fn the_mle_reaches_the_nile_optimum_from_a_start_four_orders_off() {
    // Durbin & Koopman's local level on the Nile (σ²_ε = 15099, σ²_η = 1469.1 under the
    // exact diffuse prior; P0 = 1e10 is diffuse to far below their four digits). From
    // Q = R = 1 the gradient is 2.6e5; the fit must get there as from a good start.
    let g: serde_json::Value =
        serde_json::from_str(include_str!("../golden/nile.json")).expect("nile JSON");
    let y: Vec<f64> = g["y"]
        .as_array()
        .expect("y")
        .iter()
        .map(|v| v.as_f64().expect("number"))
        .collect();
    let data = Series::new(&y, 1).expect("series");
    let dk = &g["durbin_koopman"];
    let (eps, eta) = (
        dk["sigma2_eps"].as_f64().expect("eps"),
        dk["sigma2_eta"].as_f64().expect("eta"),
    );
    let mut ll = Vec::new();
    for (q0, r0) in [(1.0, 1.0), (1500.0, 15000.0)] {
        let base =
            System::new(&[[1.0]], &[[1.0]], &[[q0]], &[[r0]], &[0.0], &[[1e10]]).expect("system");
        let free = Free {
            q: Structure::Diag,
            r: Structure::Diag,
            ..Free::default()
        };
        let map = StandardMap::new(base.clone(), free).expect("map");
        let fit = kalman::fit::mle(
            &map,
            map.theta_of(&base, Some(&data)),
            &data,
            &kalman::fit::MleOptions::default(),
        )
        .expect("mle");
        assert!(fit.converged, "from Q = {q0}, R = {r0}: {}", fit.message);
        // D&K's table has five significant digits: 5e-5 relative, asserted at 1e-4.
        let (r, q) = (fit.system.r[(0, 0)], fit.system.q[(0, 0)]);
        assert!((r - eps).abs() <= 1e-4 * eps, "σ²_ε {r} vs {eps}");
        assert!((q - eta).abs() <= 1e-4 * eta, "σ²_η {q} vs {eta}");
        ll.push(fit.loglik);
    }
    assert!((ll[0] - ll[1]).abs() <= 1e-6, "{ll:?}");
}
