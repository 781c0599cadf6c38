//! A diverging filter is stopped at the step where it diverges, with a typed error naming
//! the step, in every covariance form, on both storage paths and in the gain schedule; and
//! a step without a measurement says so in its NIS.

use crate::FORMS;
use kalman::schedule::{GainSchedule, ScheduleOptions};
use kalman::{CovarianceForm, Dims, DynDims, Error, Filter, FixedDims, Model};

/// F = diag(1e10, 0.5) with the unstable state first (`unstable` = 0) or second (1), only
/// the stable state measured, Q = I, R = 1. Both orders, so the check must read the whole
/// diagonal of P, not only its first entry or column.
fn exploding<D: Dims>(dims: D, unstable: usize) -> Model<D> {
    let f = |i: usize| if i == unstable { 1e10 } else { 0.5 };
    let stable = 1 - unstable;
    Model::new(
        dims,
        &[[f(0), 0.0], [0.0, f(1)]],
        &[[(stable == 0).into(), (stable == 1).into()]],
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[1.0]],
    )
    .expect("valid model")
}

/// The step at which the prior variance of the unmeasured state first overflows. P stays
/// diagonal (F, Q, P0 diagonal; H sees only state 2), so that variance obeys
/// p_{k+1} = 1e20 p_k + 1 from p_0 = 1: after step k (update, then prediction to k + 1) it
/// is p_{k+1} ≈ 1e20^(k+1), with log10 = 20 (k + 1) up to a relative 1e-20, against
/// log10(f64::MAX) ≈ 308.25.
fn expected_step() -> usize {
    (0..)
        .find(|k| 20.0 * (k + 1) as f64 > f64::MAX.log10())
        .expect("finite")
}

fn run<D: Dims>(dims: D, form: CovarianceForm, unstable: usize) {
    let mut f = Filter::new(
        exploding(dims, unstable),
        &[0.0, 0.0],
        &[[1.0, 0.0], [0.0, 1.0]],
        form,
    )
    .expect("valid prior");
    let k_div = expected_step();
    for k in 0..40 {
        let z = [(0.3 * k as f64).sin()];
        match f.step(&z, None) {
            Ok(info) => {
                assert!(
                    k < k_div,
                    "{form:?} (unstable state {unstable}): step {k} passed, expected an error at {k_div}"
                );
                // Every output of an accepted step is a finite number, the measured state
                // included.
                assert!(
                    info.nis.is_some_and(f64::is_finite),
                    "{form:?} (unstable state {unstable}) step {k}"
                );
                let P = f.predicted_covariance();
                assert!(
                    f.state()
                        .iter()
                        .chain(f.predicted_state())
                        .all(|v| v.is_finite())
                        && (0..2).all(|i| P[(i, i)].is_finite()),
                    "{form:?} (unstable state {unstable}) step {k}"
                );
            }
            Err(e) => {
                assert!(
                    matches!(
                        e,
                        Error::Diverged { step, what: "P_{k+1|k}" | "x_{k+1|k}", value }
                            if step == k_div && !value.is_finite()
                    ),
                    "{form:?} (unstable state {unstable}): {e}"
                );
                assert_eq!(k, k_div, "{form:?} (unstable state {unstable})");
                return;
            }
        }
    }
    panic!("{form:?} (unstable state {unstable}): 40 steps without an error");
}

#[test]
fn a_diverging_filter_is_an_error_at_the_step_it_diverges() {
    // 1e300 is finite, 1e320 is not: step 15 (the sixteenth data row).
    assert_eq!(expected_step(), 15);
    for (form, unstable) in FORMS.into_iter().flat_map(|f| [(f, 0), (f, 1)]) {
        run(FixedDims::<2, 1>::new(), form, unstable);
        run(DynDims::new(2, 1, 0).expect("dims"), form, unstable);
    }
}

#[test]
fn the_gain_schedule_reports_the_diverging_step() {
    for (form, unstable) in FORMS.into_iter().flat_map(|f| [(f, 0), (f, 1)]) {
        let opts = ScheduleOptions {
            form,
            ..ScheduleOptions::default()
        };
        let e = GainSchedule::new(
            exploding(DynDims::new(2, 1, 0).expect("dims"), unstable),
            &[[1.0, 0.0], [0.0, 1.0]],
            opts,
        )
        .expect_err("the covariance recursion diverges");
        assert!(
            matches!(e, Error::Diverged { step, .. } if step == expected_step()),
            "{form:?}, unstable state {unstable}: {e}"
        );
    }
}

#[test]
fn a_predict_only_step_has_no_nis() {
    let model = Model::new(
        FixedDims::<1, 1>::new(),
        &[[0.9]],
        &[[1.0]],
        &[[1.0]],
        &[[1.0]],
    )
    .expect("valid model");
    for form in FORMS {
        let mut f = Filter::new(model.clone(), &[0.0], &[[1.0]], form).expect("valid prior");
        // Measured: P⁻ = 1, Σ = 2, NIS = e²/Σ = 0.5 for z = 1.
        let info = f.step(&[1.0], None).expect("step");
        let nis = info.nis.expect("a measured step has a NIS");
        // 1e-15: three roundings of numbers near 1.
        assert!((nis - 0.5).abs() < 1e-15, "{form:?}: {nis}");
        let info = f.step(&[f64::NAN], None).expect("step");
        assert_eq!(info.nis, None, "{form:?}");
        assert_eq!((info.observed, info.rank), (0, 0), "{form:?}");
    }
}

/// A variance can overflow in the last addition of the prediction, P⁻ = F P Fᵀ + Q with
/// P₂₂ = Q₂₂ = 1e308 and F = I, while every other entry stays small: no product of the step
/// meets an infinity, so nothing but the diagonal itself shows it (no NaN spreads to the
/// other entries). It is an error at step 0 all the same.
#[test]
fn a_variance_that_overflows_in_the_last_addition_is_an_error_at_once() {
    let model = Model::new(
        DynDims::new(2, 1, 0).expect("dims"),
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &[[1.0, 0.0], [0.0, 1e308]],
        &[[1.0]],
    )
    .expect("valid model");
    for form in FORMS {
        let mut f = Filter::new(
            model.clone(),
            &[0.0, 0.0],
            &[[1.0, 0.0], [0.0, 1e308]],
            form,
        )
        .expect("valid prior");
        let e = f.step(&[0.5], None).expect_err("P₂₂ overflows");
        // The square-root form carries √1e308 in its factor and meets the overflow earlier,
        // in the update's triangularisation: still step 0.
        let named = form == CovarianceForm::SquareRoot
            || matches!(e, Error::Diverged { what: "P_{k+1|k}", value, .. } if value == f64::INFINITY);
        assert!(
            matches!(e, Error::Diverged { step: 0, .. }) && named,
            "{form:?}: {e}"
        );
    }
}
