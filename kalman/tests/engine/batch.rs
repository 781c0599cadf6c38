//! The batch filter against the scalar filter, series by series, and its refusals.

use kalman::batch::{BatchFilter, LANES};
use kalman::strategies::{FilterProblem, ProblemOptions};
use kalman::{CovarianceForm, DynDims, Error, Filter, Model};

/// |a − b| relative to max(1, |b|).
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1.0)
}

/// Series of one problem's model: the problem's own record first, then the records of
/// problems with other seeds (other data of the same shape, with their own random gaps).
fn series(n: usize, m: usize, count: usize, seed: u64, opts: ProblemOptions) -> Vec<Vec<f64>> {
    (0..count as u64)
        .map(|s| {
            let p = FilterProblem::generate(n, m, opts, seed + 1000 * s);
            p.z.iter().flatten().copied().collect()
        })
        .collect()
}

/// Worst relative deviation of the batch run from the scalar filter over every series,
/// step, state and covariance entry, and the log-likelihood.
fn deviation(n: usize, m: usize, count: usize, seed: u64, form: CovarianceForm) -> f64 {
    let opts = ProblemOptions {
        steps: 30,
        missing: 0.3,
        ..ProblemOptions::default()
    };
    let p = FilterProblem::generate(n, m, opts, seed);
    let model = p
        .model(DynDims::new(n, m, 0).expect("dims"))
        .expect("model");
    let records = series(n, m, count, seed, opts);
    let zs: Vec<f64> = records.iter().flatten().copied().collect();
    let batch = BatchFilter::new(&model, form)
        .expect("batch")
        .with_covariances(true);
    let out = batch
        .run(&p.system.x0, &p.system.p0, &zs, count)
        .expect("batch run");
    assert_eq!((out.series, out.steps, out.n), (count, opts.steps, n));
    let mut worst = 0.0_f64;
    for (s, record) in records.iter().enumerate() {
        let mut kf = Filter::new(model.clone(), &p.system.x0, &p.system.p0, form).expect("filter");
        let mut loglik = 0.0;
        for k in 0..opts.steps {
            let info = kf.step(&record[k * m..(k + 1) * m], None).expect("step");
            loglik += info.log_likelihood;
            for i in 0..n {
                worst = worst.max(rel(out.mean(s, k)[i], kf.state()[i]));
                for j in 0..n {
                    let at = ((s * opts.steps + k) * n + i) * n + j;
                    worst = worst.max(rel(out.covariances[at], kf.covariance()[(i, j)]));
                }
            }
        }
        for i in 0..n {
            for j in 0..n {
                let last = out.last_covariances[(s * n + i) * n + j];
                worst = worst.max(rel(last, kf.covariance()[(i, j)]));
            }
        }
        worst = worst.max(rel(out.log_likelihood[s], loglik));
    }
    worst
}

#[test]
fn equals_the_scalar_filter_on_every_series_with_random_gaps_in_both_forms() {
    // Random stable models (spectral norm ≤ 0.98, well-conditioned noise) over 30 steps:
    // the two filters do the same arithmetic in different orders (the batch step masks a
    // missing entry, the scalar one drops its row), so they agree to round-off, a few
    // hundred ulps; 1e-12 leaves room for that and catches any real difference.
    // Eleven series: one full group of LANES and a partial one. The sizes include ones the
    // batch step compiles for (n = 1, 2, 3, 4, 6) and ones it does not ((2, 4), (5, 2)).
    const { assert!(LANES < 11) };
    for form in [CovarianceForm::Joseph, CovarianceForm::Standard] {
        for (n, m) in [(1, 1), (2, 1), (4, 1), (3, 2), (6, 3), (2, 4), (5, 2)] {
            for seed in 0..4 {
                let d = deviation(n, m, 11, seed, form);
                assert!(
                    d < 1e-12,
                    "{form:?} n={n} m={m} seed={seed}: deviation {d:e}"
                );
            }
        }
    }
}

fn cv() -> Model<DynDims> {
    Model::new(
        DynDims::new(2, 1, 0).expect("dims"),
        &[[1.0, 0.1], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &[[1e-4, 0.0], [0.0, 1e-3]],
        &[[0.01]],
    )
    .expect("model")
}

const P0: [[f64; 2]; 2] = [[1.0, 0.0], [0.0, 1.0]];

#[test]
fn refuses_what_it_does_not_do_by_name() {
    let e = BatchFilter::new(&cv(), CovarianceForm::SquareRoot).expect_err("refused");
    assert!(
        matches!(e, Error::InvalidOption { name: "form", .. }),
        "{e}"
    );
    let with_s = cv()
        .with_cross_covariance(&[[1e-3], [0.0]])
        .expect("valid S");
    let e = BatchFilter::new(&with_s, CovarianceForm::Joseph).expect_err("refused");
    assert!(matches!(e, Error::InvalidOption { name: "S", .. }), "{e}");
}

#[test]
fn bad_data_is_an_error_naming_the_series() {
    let batch = BatchFilter::new(&cv(), CovarianceForm::Joseph).expect("batch");
    // Seven values are not three series of whole steps.
    let e = batch
        .run(&[0.0, 0.0], &P0, &[0.0; 7], 3)
        .expect_err("refused");
    assert!(matches!(e, Error::Shape { name: "z", .. }), "{e}");
    // An infinite measurement in series 3, step 1.
    let mut zs = vec![0.5; 5 * 4];
    zs[3 * 4 + 1] = f64::INFINITY;
    match batch.run(&[0.0, 0.0], &P0, &zs, 5).expect_err("refused") {
        Error::InSeries { series: 3, error } => {
            assert!(
                matches!(
                    *error,
                    Error::NonFinite {
                        name: "z",
                        row: 1,
                        ..
                    }
                ),
                "{error}"
            );
        }
        other => panic!("{other}"),
    }
    // A prior that is not a covariance.
    let e = batch
        .run(&[0.0, 0.0], &[[1.0, 2.0], [2.0, 1.0]], &zs, 5)
        .expect_err("refused");
    assert!(
        matches!(e, Error::NotPositiveSemidefinite { name: "P0", .. }),
        "{e}"
    );
}

#[test]
fn a_singular_innovation_covariance_is_an_error_at_its_series_and_step() {
    // Two exact readings of one state: Σ = [[1, 1], [1, 1]] is singular.
    let model = Model::new(
        DynDims::new(1, 2, 0).expect("dims"),
        &[[0.9]],
        &[[1.0], [1.0]],
        &[[1.0]],
        &[[0.0, 0.0], [0.0, 0.0]],
    )
    .expect("model");
    let batch = BatchFilter::new(&model, CovarianceForm::Joseph).expect("batch");
    // Series 0 and 1 see one reading a step (fine); series 2 both at step 2.
    let nan = f64::NAN;
    let mut zs = vec![nan; 3 * 4 * 2];
    for s in 0..3 {
        for k in 0..4 {
            zs[(s * 4 + k) * 2] = 1.0;
        }
    }
    zs[(2 * 4 + 2) * 2 + 1] = 1.0;
    match batch.run(&[0.0], &[[1.0]], &zs, 3).expect_err("refused") {
        Error::InSeries { series: 2, error } => {
            assert!(
                matches!(*error, Error::SingularInnovation { step: 2, .. }),
                "{error}"
            );
        }
        other => panic!("{other}"),
    }
}

#[test]
fn a_diverging_series_is_an_error_at_the_step_where_it_diverges() {
    // An unstable mode the measurement does not see: its variance grows by 1e100 a step
    // and overflows in the prediction of step 3 (P_{4|3} = 1e400).
    let model = Model::new(
        DynDims::new(2, 1, 0).expect("dims"),
        &[[1e50, 0.0], [0.0, 0.5]],
        &[[0.0, 1.0]],
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[1.0]],
    )
    .expect("model");
    let batch = BatchFilter::new(&model, CovarianceForm::Standard).expect("batch");
    let zs = vec![0.0; 10];
    match batch.run(&[0.0, 0.0], &P0, &zs, 1).expect_err("refused") {
        Error::InSeries { series: 0, error } => {
            assert!(
                matches!(
                    *error,
                    Error::Diverged {
                        step: 3,
                        what: "P_{k+1|k}",
                        ..
                    }
                ),
                "{error}"
            );
        }
        other => panic!("{other}"),
    }
}

#[test]
fn no_series_or_no_steps_is_an_empty_result() {
    let batch = BatchFilter::new(&cv(), CovarianceForm::Joseph).expect("batch");
    let out = batch.run(&[0.0, 0.0], &P0, &[], 0).expect("empty");
    assert!(out.means.is_empty() && out.log_likelihood.is_empty());
    let out = batch.run(&[0.0, 0.0], &P0, &[], 4).expect("no steps");
    assert_eq!(out.log_likelihood, vec![0.0; 4]);
}

#[test]
fn the_log_likelihood_holds_at_extreme_noise_scales() {
    // The batch filter multiplies the steps' det Σ and takes the logarithm when the product
    // leaves 2^±500, and a step whose own det Σ is beyond that pivot by pivot. Scaled by
    // 1e160 (every step beyond), 1e-100 (every step inside, the product out after two) and
    // 1e-160 (every step beyond, below): the scalar filter's ln L to 1e-12 relative.
    for scale in [1e160, 1e-100, 1e-160] {
        let model = Model::new(
            DynDims::new(2, 1, 0).expect("dims"),
            &[[1.0, 0.1], [0.0, 1.0]],
            &[[1.0, 0.0]],
            &[[1e-4 * scale, 0.0], [0.0, 1e-3 * scale]],
            &[[0.01 * scale]],
        )
        .expect("model");
        let p0 = [[scale, 0.0], [0.0, scale]];
        let steps = 40;
        let root = scale.sqrt();
        let zs: Vec<f64> = (0..3 * steps)
            .map(|i| {
                if i % 9 == 4 {
                    f64::NAN
                } else {
                    root * (0.3 * i as f64).sin()
                }
            })
            .collect();
        let out = BatchFilter::new(&model, CovarianceForm::Joseph)
            .expect("batch")
            .run(&[0.0, 0.0], &p0, &zs, 3)
            .expect("batch run");
        for s in 0..3 {
            let mut kf =
                Filter::new(model.clone(), &[0.0, 0.0], &p0, CovarianceForm::Joseph).expect("kf");
            let mut loglik = 0.0;
            for k in 0..steps {
                loglik += kf
                    .step(&[zs[s * steps + k]], None)
                    .expect("step")
                    .log_likelihood;
            }
            let d = rel(out.log_likelihood[s], loglik);
            assert!(
                d < 1e-12,
                "scale {scale:e}, series {s}: {} vs {loglik}",
                out.log_likelihood[s]
            );
        }
    }
}
