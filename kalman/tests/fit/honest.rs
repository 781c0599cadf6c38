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
        },
    )
    .expect("em");
    let cov = loose.covariance.as_ref().expect("covariance");
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
    let d = decrement(&tight.theta, tight.covariance.as_ref().expect("covariance"));
    assert!(d <= EM_DECREMENT, "decrement {d}");
    assert!(tight.loglik > loose.loglik);
}
