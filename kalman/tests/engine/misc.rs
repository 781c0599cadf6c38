//! Adoption paths: nalgebra inputs (feature `nalgebra`), time-varying models through
//! `ModelSource`, and `reset`.

use crate::FORMS;
use kalman::strategies::{FilterProblem, ProblemOptions};
use kalman::{CovarianceForm, DynDims, Filter, FixedDims, Model};

#[test]
fn nalgebra_matrices_build_the_same_model() {
    let p = FilterProblem::generate(4, 2, ProblemOptions::default(), 21);
    let to_na =
        |a: &faer::Mat<f64>| nalgebra::DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)]);
    let F: nalgebra::SMatrix<f64, 4, 4> = nalgebra::SMatrix::from_fn(|i, j| p.system.f[(i, j)]);
    let model = Model::new(
        FixedDims::<4, 2, 0>::new(),
        &F,
        &to_na(&p.system.h),
        &to_na(&p.system.q),
        &to_na(&p.system.r),
    )
    .expect("model");
    let mut a = Filter::new(
        model,
        &p.system.x0,
        &to_na(&p.system.p0),
        CovarianceForm::Joseph,
    )
    .expect("filter");
    let mut b = Filter::new(
        p.model(FixedDims::<4, 2, 0>::new()).expect("model"),
        &p.system.x0,
        &p.system.p0,
        CovarianceForm::Joseph,
    )
    .expect("filter");
    for z in &p.z {
        a.step(z, None).expect("step");
        b.step(z, None).expect("step");
        // Same numbers in, same kernels: bit-identical.
        assert!(
            a.state()
                .iter()
                .zip(b.state())
                .all(|(x, y)| (x - y).abs() <= 0.0)
        );
    }
    // A wrongly shaped nalgebra matrix is a typed error naming it.
    let bad = nalgebra::DMatrix::<f64>::zeros(3, 4);
    let e = Model::new(
        DynDims::new(4, 2, 0).expect("dims"),
        &F,
        &bad,
        &to_na(&p.system.q),
        &to_na(&p.system.r),
    )
    .err();
    assert!(
        matches!(e, Some(kalman::Error::Shape { name: "H", .. })),
        "{e:?}"
    );
}

#[test]
fn time_varying_models_step_by_step() {
    let p = FilterProblem::generate(3, 2, ProblemOptions::default(), 22);
    let q = FilterProblem::generate(3, 2, ProblemOptions::default(), 23);
    let dims = DynDims::new(3, 2, 0).expect("dims");
    let m0 = p.model(dims).expect("model");
    let m1 = q.model(dims).expect("model");
    // Alternating models: step k uses models[k] for its update (H) and prediction (F, Q).
    let models: Vec<Model<DynDims>> = (0..p.z.len())
        .map(|k| if k % 2 == 0 { m0.clone() } else { m1.clone() })
        .collect();
    let mut by_source = Filter::new(
        m0.clone(),
        &p.system.x0,
        &p.system.p0,
        CovarianceForm::Joseph,
    )
    .expect("filter");
    let mut by_hand = by_source.clone();
    let mut constant = by_source.clone();
    for (k, z) in p.z.iter().enumerate() {
        by_source.step_source(&models, z, None).expect("step");
        by_hand
            .step_with(if k % 2 == 0 { &m0 } else { &m1 }, z, None)
            .expect("step");
        constant.step(z, None).expect("step");
        assert!(
            by_source
                .state()
                .iter()
                .zip(by_hand.state())
                .all(|(x, y)| (x - y).abs() <= 0.0)
        );
    }
    let diff = by_source
        .state()
        .iter()
        .zip(constant.state())
        .fold(0.0_f64, |s, (x, y)| s.max((x - y).abs()));
    assert!(
        diff > 1e-6,
        "the time-varying run must differ from the constant one"
    );
    // Past the end of the list the last model is reused.
    assert!(by_source.step_source(&models, &p.z[0], None).is_ok());
}

#[test]
fn reset_restarts_from_a_new_prior() {
    let p = FilterProblem::generate(3, 1, ProblemOptions::default(), 24);
    let mut f = Filter::new(
        p.model(DynDims::new(3, 1, 0).expect("dims"))
            .expect("model"),
        &p.system.x0,
        &p.system.p0,
        CovarianceForm::SquareRoot,
    )
    .expect("filter");
    let first: Vec<f64> = {
        f.step(&p.z[0], None).expect("step");
        f.state().to_vec()
    };
    let info = f.step(&p.z[1], None).expect("step");
    assert_eq!(f.steps(), 2);
    // The last step's record is the one the step returned (step 1, one measured channel).
    assert_eq!(f.last_step(), info);
    assert_eq!((info.step, info.observed), (1, 1));
    f.reset(&p.system.x0, &p.system.p0).expect("reset");
    assert_eq!(f.steps(), 0);
    // A reset keeps the covariance form the filter was built with.
    assert_eq!(f.form(), CovarianceForm::SquareRoot);
    f.step(&p.z[0], None).expect("step");
    assert!(
        f.state()
            .iter()
            .zip(&first)
            .all(|(x, y)| (x - y).abs() <= 0.0)
    );
}

#[test]
fn fixed_filters_are_sized_by_their_dimensions() {
    use kalman::FixedFilter;
    let small = core::mem::size_of::<FixedFilter<2, 1>>();
    let medium = core::mem::size_of::<FixedFilter<7, 2>>();
    // A (2, 1) filter holds about 30 buffers of at most n² = 4 entries plus a few words of
    // bookkeeping: well under 2 kB (it was ~26 kB when every buffer was sized for n = 16).
    assert!(small < 2048, "FixedFilter<2, 1> is {small} bytes");
    // Bigger dimensions, bigger filter: the buffers follow N and M.
    assert!(medium > 4 * small, "{medium} vs {small} bytes");
    // And the largest fixed size is still bounded by its own dimensions: about 30 buffers of
    // at most 16² entries.
    let large = core::mem::size_of::<FixedFilter<16, 16>>();
    assert!(
        large <= 30 * 16 * 16 * 8 + 1024,
        "FixedFilter<16, 16> is {large} bytes"
    );
}

/// A filter of the 4-state, 3-channel problem `p` in `form`, after its first measured step.
fn after_first_step(p: &FilterProblem, form: CovarianceForm) -> Filter<DynDims> {
    let model = p
        .model(DynDims::new(4, 3, 0).expect("dims"))
        .expect("model");
    let mut f = Filter::new(model, &p.system.x0, &p.system.p0, form).expect("filter");
    f.step(&p.z[0], None).expect("step");
    f
}

#[test]
fn innovation_covariance_is_zero_in_the_rows_of_missing_entries() {
    // Every form reports Σ over the observed entries, with the rows and columns of a missing
    // entry zero (the dense forms factor a unit placeholder there, which must not leak), and
    // all forms agree on the observed block, to round-off of a well-conditioned 3×3 problem.
    let p = FilterProblem::generate(4, 3, ProblemOptions::default(), 31);
    let mut sigmas = Vec::new();
    for form in FORMS {
        let mut f = after_first_step(&p, form);
        let z = [p.z[1][0], f64::NAN, p.z[1][2]];
        f.step(&z, None).expect("step with a gap");
        let sig = f.innovation_covariance();
        for j in 0..3 {
            assert!(sig[(1, j)].abs() <= 0.0, "{form:?} row 1");
            assert!(sig[(j, 1)].abs() <= 0.0, "{form:?} column 1");
        }
        sigmas.push([sig[(0, 0)], sig[(0, 2)], sig[(2, 2)]]);
    }
    for s in &sigmas[1..] {
        for (a, b) in s.iter().zip(&sigmas[0]) {
            assert!((a - b).abs() <= 1e-10 * b.abs().max(1.0), "{a} vs {b}");
        }
    }
}

#[test]
fn a_step_with_every_entry_missing_is_a_pure_prediction() {
    // After a measured step has filled them, a step with nothing observed must report a zero
    // innovation, Σ and gain in full (the documented zero rows and columns of missing
    // entries), leave x_{k|k} = x_{k|k−1} and P_{k|k} = P_{k|k−1}, and predict as usual.
    let p = FilterProblem::generate(4, 3, ProblemOptions::default(), 32);
    for form in FORMS {
        let mut f = after_first_step(&p, form);
        assert!(
            f.gain().norm_l2() > 0.0,
            "{form:?}: a measured step has a gain"
        );
        let (x, P) = (
            f.predicted_state().to_vec(),
            f.predicted_covariance().to_owned(),
        );
        let info = f
            .step(&[f64::NAN; 3], None)
            .expect("step with nothing observed");
        assert_eq!(info.observed, 0, "{form:?}");
        assert!(f.innovation().iter().all(|e| e.abs() <= 0.0), "{form:?}");
        assert!(f.innovation_covariance().norm_l2() <= 0.0, "{form:?}");
        assert!(f.gain().norm_l2() <= 0.0, "{form:?}: {:?}", f.gain());
        assert_eq!(f.state(), &x[..], "{form:?}");
        // The square-root form holds P as a factor: equal to round-off.
        let d = (f.covariance() - &P).norm_l2();
        assert!(d <= 1e-12 * P.norm_l2(), "{form:?}: {d:e}");
        let pred = &p.system.f * &P * p.system.f.transpose() + &p.system.q;
        let d = (f.predicted_covariance() - &pred).norm_l2();
        assert!(d <= 1e-12 * pred.norm_l2(), "{form:?}: {d:e}");
    }
}

#[test]
fn the_forms_differ_where_the_standard_forms_subtraction_cancels() {
    // Scalar, P⁻ = 1, h = 1, r = 1e-20: the exact posterior is P⁻r/(P⁻ + r) ≈ 1e-20, but
    // Σ = 1 + r rounds to 1, so K = 1 and the standard form's P⁻ − KΣK cancels to 0, while
    // Joseph's (1 − K)²P⁻ + K²r = r keeps it to full relative precision, and the square-root
    // form, orthogonal throughout, keeps it too. This is the robustness the forms trade for
    // cost: each form must really be the computation it names.
    let r = 1e-20;
    let exact = r / (1.0 + r);
    for form in FORMS {
        let model = Model::new(
            DynDims::new(1, 1, 0).expect("dims"),
            &[[1.0]],
            &[[1.0]],
            &[[0.0]],
            &[[r]],
        )
        .expect("model");
        let mut f = Filter::new(model, &[0.0], &[[1.0]], form).expect("filter");
        f.step(&[0.5], None).expect("step");
        let posterior = f.covariance()[(0, 0)];
        let error = (posterior - exact).abs();
        if form == CovarianceForm::Standard {
            assert!(error > 0.5 * exact, "{form:?}: {posterior:e}");
        } else {
            assert!(error < 1e-6 * exact, "{form:?}: {posterior:e}");
        }
    }
}
