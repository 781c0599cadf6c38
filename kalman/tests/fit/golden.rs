//! Against an independent implementation: statsmodels' `UnobservedComponents` (local linear
//! trend) on the same data, stored by `tests/golden/make_statsmodels_llt.py`.

use kalman::CovarianceForm;
use kalman::fit::{Series, Structure, log_likelihood};

use super::common::{llt, mle_qr};

fn golden() -> serde_json::Value {
    let text = include_str!("../golden/statsmodels_llt.json");
    serde_json::from_str(text).expect("golden JSON")
}

fn num(v: &serde_json::Value) -> f64 {
    v.as_f64().expect("number")
}

#[test]
fn likelihood_and_mle_match_statsmodels_unobserved_components() {
    let g = golden();
    let y: Vec<f64> = g["y"].as_array().expect("y").iter().map(num).collect();
    let x0 = [num(&g["x0"][0]), num(&g["x0"][1])];
    let p0 = [num(&g["P0_diag"][0]), num(&g["P0_diag"][1])];
    let data = Series::new(&y, 1).expect("series");
    // The likelihood itself at fixed parameters (σ²_irregular, σ²_level, σ²_trend): two
    // exact evaluations of one number, 500 steps of round-off apart.
    let c = &g["check_params"];
    let sys = llt(num(&c[1]), num(&c[2]), num(&c[0]), x0, p0);
    let ll = log_likelihood(&sys, &data, CovarianceForm::Joseph).expect("ll");
    let want = num(&g["check_llf"]);
    assert!(
        (ll - want).abs() <= 1e-9 * want.abs(),
        "ln L {ll} vs statsmodels {want}"
    );
    // The MLE.
    let base = llt(1.0, 1.0, 1.0, x0, p0);
    let (map, fit) = mle_qr(&base, Structure::Diag, Structure::Diag, &data);
    let cov = fit.uncertainty.covariance.as_ref().expect("covariance");
    let se = map.matrix_std_errors(&fit.theta, cov).expect("se");
    let (Some(seq), Some(ser)) = (se.q, se.r) else {
        panic!("Q and R are free")
    };
    let ours = [
        ("sigma2.irregular", fit.system.r[(0, 0)], ser[(0, 0)]),
        ("sigma2.level", fit.system.q[(0, 0)], seq[(0, 0)]),
        ("sigma2.trend", fit.system.q[(1, 1)], seq[(1, 1)]),
    ];
    for (name, est, se) in ours {
        let (sm, sm_se) = (num(&g["params"][name]), num(&g["bse_hessian"][name]));
        // Same optimum: within 2 % of a standard error (both optimisers stop at a gradient
        // tolerance; the log-likelihood is flat to second order there).
        assert!(
            (est - sm).abs() <= 0.02 * sm_se,
            "{name}: ours {est} vs statsmodels {sm} (se {sm_se})"
        );
        // Same curvature: both standard errors come from finite-difference Hessians.
        assert!(
            (se - sm_se).abs() <= 0.02 * sm_se,
            "{name}: se {se} vs statsmodels {sm_se}"
        );
    }
    let llf = num(&g["llf"]);
    assert!(
        fit.loglik >= llf - 1e-6,
        "ln L {} below statsmodels' {llf}",
        fit.loglik
    );
}
