//! Typed errors of the nonlinear filters, each naming the step: non-finite f or h, a
//! sigma-point covariance that is not PSD, a singular innovation covariance, bad options
//! and bad shapes — never a panic or NaN output.

use kalman::nonlinear::{CentralDiff, Ekf, EkfUpdate, FnModel, SigmaPoints, Ukf};
use kalman::{DynDims, Error, FixedDims};

use super::common::assert_f_non_finite_at;

/// The transition and measurement closures of the scalar test model.
type Transition = Box<dyn FnMut(&[f64], Option<&[f64]>, usize, &mut [f64])>;
type Measurement = Box<dyn FnMut(&[f64], usize, &mut [f64])>;
type Scalar = FnModel<Transition, Measurement, FixedDims<1, 1>>;

fn scalar_model(h_nan_at: usize, f_nan_at: usize) -> Scalar {
    let f: Transition = Box::new(move |x, _u, k, out| {
        out[0] = if k == f_nan_at { f64::NAN } else { 0.9 * x[0] };
    });
    let h: Measurement = Box::new(move |x, k, out| {
        out[0] = if k == h_nan_at { f64::INFINITY } else { x[0] };
    });
    FnModel::new(FixedDims::<1, 1>::new(), f, h, &[[0.1]], &[[0.1]]).expect("model")
}

#[test]
fn non_finite_model_values_name_function_and_step() {
    let d = FixedDims::<1, 1>::new();
    let mut ukf = Ukf::new(
        d,
        scalar_model(2, 99),
        &[0.0],
        &[[1.0]],
        SigmaPoints::Cubature,
    )
    .expect("ukf");
    for _ in 0..2 {
        ukf.step(&[0.1], None).expect("finite steps");
    }
    let err = ukf.step(&[0.1], None).expect_err("h is infinite at step 2");
    assert_eq!(
        err,
        Error::ModelNonFinite {
            function: "h",
            step: 2,
            index: 0
        }
    );
    assert!(err.to_string().contains("step 2"));
    let cd = CentralDiff::new(d, scalar_model(99, 1));
    let mut ekf = Ekf::new(d, cd, &[0.0], &[[1.0]], EkfUpdate::Extended).expect("ekf");
    ekf.step(&[0.1], None).expect("step 0");
    let err = ekf.step(&[0.1], None).expect_err("f is NaN at step 1");
    assert_f_non_finite_at(&err, 1);
}

#[test]
fn indefinite_sigma_covariance_is_an_error() {
    // Q_k indefinite from step 1: P_{2|1} is indefinite and the UKF refuses to draw
    // sigma points from it at step 2.
    let d = DynDims::new(2, 1, 0).expect("dims");
    struct M;
    impl kalman::nonlinear::NonlinearModel for M {
        fn f(&mut self, x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]) {
            out.copy_from_slice(x);
        }
        fn h(&mut self, x: &[f64], _k: usize, out: &mut [f64]) {
            out[0] = x[0];
        }
        fn q(&mut self, k: usize, out: &mut [f64]) {
            let v = if k >= 1 { -10.0 } else { 0.1 };
            out.copy_from_slice(&[0.1, 0.0, 0.0, v]);
        }
        fn r(&mut self, _k: usize, out: &mut [f64]) {
            out[0] = 0.1;
        }
    }
    let mut ukf = Ukf::new(
        d,
        M,
        &[0.0, 0.0],
        &[[1.0, 0.0], [0.0, 1.0]],
        SigmaPoints::Cubature,
    )
    .expect("ukf");
    ukf.step(&[0.0], None).expect("step 0");
    ukf.step(&[0.0], None)
        .expect("step 1 (its prediction makes P indefinite)");
    let err = ukf.step(&[0.0], None).expect_err("indefinite P_{2|1}");
    assert!(
        matches!(
            err,
            Error::SigmaCovariance {
                name: "P_{k|k-1}",
                step: 2,
                n: 2,
                ..
            }
        ),
        "{err:?}"
    );
}

#[test]
fn singular_innovation_covariance_is_an_error() {
    // h constant and R = 0: Σ = 0.
    let d = FixedDims::<1, 1>::new();
    let model = FnModel::new(
        d,
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
        |_x: &[f64], _k: usize, out: &mut [f64]| out[0] = 1.0,
        &[[0.1]],
        &[[0.0]],
    )
    .expect("model");
    let mut ukf = Ukf::new(
        d,
        model.clone(),
        &[0.0],
        &[[1.0]],
        SigmaPoints::merwe(1.0, 2.0, 0.0),
    )
    .expect("ukf");
    let err = ukf.step(&[1.0], None).expect_err("Σ = 0");
    assert!(
        matches!(
            err,
            Error::SingularInnovation {
                filter: "UKF",
                step: 0,
                m: 1,
                ..
            }
        ),
        "{err:?}"
    );
    let mut ekf = Ekf::new(
        d,
        CentralDiff::new(d, model),
        &[0.0],
        &[[1.0]],
        EkfUpdate::Extended,
    )
    .expect("ekf");
    let err = ekf.step(&[1.0], None).expect_err("Σ = 0");
    assert!(
        matches!(err, Error::SingularInnovation { filter: "EKF", .. }),
        "{err:?}"
    );
}

#[test]
fn bad_options_and_shapes_are_errors() {
    let d = FixedDims::<1, 1>::new();
    for (set, name) in [
        (SigmaPoints::merwe(0.0, 2.0, 0.0), "alpha"),
        (SigmaPoints::merwe(1.0, 2.0, -1.0), "kappa"),
        (SigmaPoints::merwe(1.0, f64::NAN, 0.0), "beta"),
    ] {
        let err = Ukf::new(d, scalar_model(99, 99), &[0.0], &[[1.0]], set).expect_err("bad option");
        assert!(
            matches!(err, Error::InvalidOption { name: n, .. } if n == name),
            "{err:?}"
        );
    }
    let cd = || CentralDiff::new(d, scalar_model(99, 99));
    let bad = EkfUpdate::Iterated {
        max_iterations: 0,
        tolerance: 1e-9,
    };
    let err = Ekf::new(d, cd(), &[0.0], &[[1.0]], bad).expect_err("cap 0");
    assert!(matches!(
        err,
        Error::InvalidOption {
            name: "max_iterations",
            ..
        }
    ));
    let err = Ekf::new(d, cd(), &[0.0], &[[-1.0]], EkfUpdate::Extended).expect_err("P0 < 0");
    assert!(matches!(
        err,
        Error::NotPositiveSemidefinite { name: "P0", .. }
    ));
    let mut ekf = Ekf::new(d, cd(), &[0.0], &[[1.0]], EkfUpdate::Extended).expect("ekf");
    let err = ekf.step(&[1.0, 2.0], None).expect_err("z too long");
    assert!(matches!(
        err,
        Error::Shape {
            name: "z",
            rows: 2,
            ..
        }
    ));
    assert!(cd().with_step(0.0).is_err());
}
