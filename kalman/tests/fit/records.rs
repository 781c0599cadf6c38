//! One fit over several records sharing θ: the pooled likelihood is the sum of the records',
//! its optimum is where the summed gradient vanishes, and pooling sharpens the bounds.

use kalman::CovarianceForm;
use kalman::fit::{
    Free, MleOptions, Series, StandardMap, System, log_likelihood, log_likelihood_gradient, mle,
    mle_records,
};

use super::common::{ar1, ar1_far_start, rng, simulate_diag};

#[test]
fn a_pooled_fit_sums_the_records_and_beats_each_alone() {
    let truth = ar1(0.8, 0.5, 1.0);
    let (start, map) = ar1_far_start();
    let mut g = rng(12);
    let zs: Vec<Vec<f64>> = [150, 220, 180]
        .iter()
        .map(|&n| simulate_diag(&truth, n, &mut g))
        .collect();
    let records: Vec<Series> = zs
        .iter()
        .map(|z| Series::new(z, 1).expect("series"))
        .collect();
    let opts = MleOptions::default();
    let pooled = mle_records(&map, map.theta_of(&start, None), &records, &opts).expect("mle");
    assert!(pooled.converged, "{}", pooled.message);
    assert_eq!(pooled.n_obs, 550);
    // ln L is the sum of each record's filter likelihood (from the same prior), to the
    // round-off of 550 terms.
    let sys = &pooled.system;
    let sum: f64 = records
        .iter()
        .map(|d| log_likelihood(sys, d, CovarianceForm::Joseph).expect("ll"))
        .sum();
    assert!(
        (pooled.loglik - sum).abs() <= 1e-9 * sum.abs(),
        "{} vs {sum}",
        pooled.loglik
    );
    // At the optimum the summed gradient vanishes while each record's does not.
    let mut total = [0.0; 3];
    let mut largest_single: f64 = 0.0;
    for d in &records {
        let (_, gi) = log_likelihood_gradient(&map, &pooled.theta, d).expect("gradient");
        for (t, v) in total.iter_mut().zip(&gi) {
            *t += v;
        }
        largest_single = largest_single.max(gi.iter().fold(0.0, |a, v| a.max(v.abs())));
    }
    assert!(total.iter().all(|v| v.abs() <= opts.grad_tol), "{total:?}");
    assert!(largest_single > 100.0 * opts.grad_tol, "{largest_single}");
    // Pooling 550 samples sharpens each bound below every single record's.
    let se = pooled.uncertainty.std_errors.as_ref().expect("se");
    for d in &records {
        let alone = mle(&map, map.theta_of(&start, None), d, &opts).expect("mle");
        let se1 = alone.uncertainty.std_errors.as_ref().expect("se");
        for i in 0..3 {
            assert!(se[i] < se1[i], "θ{i}: pooled {} vs alone {}", se[i], se1[i]);
        }
    }
    // The truth within three standard errors (seeded: deterministic).
    let values = map.param_values(&pooled.theta).expect("values");
    let ses = map
        .matrix_std_errors(
            &pooled.theta,
            pooled.uncertainty.covariance.as_ref().expect("cov"),
        )
        .expect("se")
        .params;
    for (i, want) in [0.8, 0.5, 1.0].iter().enumerate() {
        assert!(
            (values[i].1 - want).abs() <= 3.0 * ses[i].1,
            "{}: {} ± {} vs {want}",
            values[i].0,
            values[i].1,
            ses[i].1
        );
    }
}

/// Two runs of a local level started 1000 apart, each fitted from its own prior
/// (`mle_records_with_priors`): ln L at the optimum is the sum of each record's filter
/// likelihood from its own prior (the round-off of 400 terms: 1e-9 relative), the variances
/// come back within three standard errors (a fixed seed), and a shared prior (x0 = 0, the
/// second run's start 1000 away) fits worse.
#[test]
fn each_record_can_start_from_its_own_prior() {
    use kalman::fit::{Prior, Structure, mle_records_with_priors};
    let (q, r) = (0.5, 2.0);
    let mut g = rng(21);
    let zs: Vec<Vec<f64>> = [0.0, 1000.0]
        .iter()
        .map(|&start| {
            let truth = System::new(&[[1.0]], &[[1.0]], &[[q]], &[[r]], &[start], &[[0.01]])
                .expect("truth");
            simulate_diag(&truth, 200, &mut g)
        })
        .collect();
    let records: Vec<Series> = zs
        .iter()
        .map(|z| Series::new(z, 1).expect("series"))
        .collect();
    let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[1.0]]).expect("base");
    let free = Free {
        q: Structure::Diag,
        r: Structure::Diag,
        ..Free::default()
    };
    let map = StandardMap::new(base.clone(), free).expect("map");
    let priors = [
        Prior::new(&[0.0], &[[1.0]]).expect("prior"),
        Prior::new(&[1000.0], &[[1.0]]).expect("prior"),
    ];
    let opts = MleOptions::default();
    let own = mle_records_with_priors(&map, map.theta_of(&base, None), &records, &priors, &opts)
        .expect("mle");
    assert!(own.converged, "{}", own.message);
    let sum: f64 = records
        .iter()
        .zip(&priors)
        .map(|(data, prior)| {
            let mut sys = own.system.clone();
            sys.x0 = prior.x0().to_vec();
            sys.p0 = prior.p0().clone();
            log_likelihood(&sys, data, CovarianceForm::Joseph).expect("ll")
        })
        .sum();
    assert!(
        (own.loglik - sum).abs() <= 1e-9 * sum.abs(),
        "{} vs {sum}",
        own.loglik
    );
    let se = own.uncertainty.std_errors.as_ref().expect("bounds");
    for (j, truth) in [(0, q), (1, r)] {
        assert!(
            (own.theta[j] - f64::ln(truth)).abs() < 3.0 * se[j],
            "θ{j} = {} vs ln {truth}, σ {}",
            own.theta[j],
            se[j]
        );
    }
    let shared = mle_records(&map, map.theta_of(&base, None), &records, &opts).expect("mle");
    assert!(
        shared.loglik < own.loglik - 10.0,
        "{} vs {}",
        shared.loglik,
        own.loglik
    );
    let e = mle_records_with_priors(
        &map,
        map.theta_of(&base, None),
        &records,
        &priors[..1],
        &opts,
    )
    .expect_err("one prior for two records");
    assert!(e.to_string().contains("2 records and 1 priors"), "{e}");
}
