//! Every invalid input gives a typed error naming the matrix.

use kalman::{CovarianceForm, DynDims, Error, Filter, FixedDims, Model};

const F: [[f64; 2]; 2] = [[1.0, 0.1], [0.0, 1.0]];
const H: [[f64; 2]; 1] = [[1.0, 0.0]];
const Q: [[f64; 2]; 2] = [[0.01, 0.0], [0.0, 0.02]];
const R: [[f64; 1]; 1] = [[0.5]];
const P0: [[f64; 2]; 2] = [[1.0, 0.2], [0.2, 2.0]];

fn dims() -> DynDims {
    DynDims::new(2, 1, 1).expect("dims")
}

fn model() -> Model<DynDims> {
    Model::new(dims(), &F, &H, &Q, &R).expect("valid model")
}

fn name_of(e: &Error) -> &'static str {
    match e {
        Error::Shape { name, .. }
        | Error::NonFinite { name, .. }
        | Error::NotSymmetric { name, .. }
        | Error::NotPositiveSemidefinite { name, .. }
        | Error::Dimension { name, .. }
        | Error::Factorisation { name, .. } => name,
        _ => "other",
    }
}

#[test]
fn shape_errors_name_the_matrix() {
    let bad3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let bad12 = [[1.0, 0.0]];
    let cases: Vec<(&str, Result<Model<DynDims>, Error>)> = vec![
        ("F", Model::new(dims(), &bad3, &H, &Q, &R)),
        ("H", Model::new(dims(), &F, &bad3, &Q, &R)),
        ("Q", Model::new(dims(), &F, &H, &bad12, &R)),
        ("R", Model::new(dims(), &F, &H, &Q, &bad3)),
        ("S", model().with_cross_covariance(&bad3)),
        ("B", model().with_control(&bad3)),
    ];
    for (name, r) in cases {
        match r {
            Err(e @ Error::Shape { .. }) => {
                assert_eq!(name_of(&e), name);
                assert!(e.to_string().starts_with(name), "{e}");
            }
            other => panic!("{name}: expected a shape error, got {other:?}"),
        }
    }
    let e = Filter::new(model(), &[0.0; 3], &P0, CovarianceForm::Joseph).err();
    assert!(matches!(e, Some(Error::Shape { name: "x0", .. })), "{e:?}");
    let e = Filter::new(model(), &[0.0; 2], &bad3, CovarianceForm::Joseph).err();
    assert!(matches!(e, Some(Error::Shape { name: "P0", .. })), "{e:?}");
}

#[test]
fn nan_entries_name_the_matrix() {
    let nan2 = [[1.0, f64::NAN], [f64::NAN, 1.0]];
    let nan21 = [[f64::NAN], [0.0]];
    let nan12 = [[f64::NAN, 0.0]];
    let nan11 = [[f64::INFINITY]];
    let cases: Vec<(&str, Result<Model<DynDims>, Error>)> = vec![
        ("F", Model::new(dims(), &nan2, &H, &Q, &R)),
        ("H", Model::new(dims(), &F, &nan12, &Q, &R)),
        ("Q", Model::new(dims(), &F, &H, &nan2, &R)),
        ("R", Model::new(dims(), &F, &H, &Q, &nan11)),
        ("S", model().with_cross_covariance(&nan21)),
        ("B", model().with_control(&nan21)),
    ];
    for (name, r) in cases {
        assert!(
            matches!(&r, Err(Error::NonFinite { name: n, .. }) if *n == name),
            "{name}: {r:?}"
        );
    }
    let e = Filter::new(model(), &[0.0, f64::NAN], &P0, CovarianceForm::Joseph).err();
    assert!(
        matches!(e, Some(Error::NonFinite { name: "x0", .. })),
        "{e:?}"
    );
    let e = Filter::new(model(), &[0.0; 2], &nan2, CovarianceForm::Joseph).err();
    assert!(
        matches!(e, Some(Error::NonFinite { name: "P0", .. })),
        "{e:?}"
    );
}

#[test]
fn asymmetric_covariances_are_rejected() {
    let asym = [[1.0, 0.5], [0.0, 1.0]];
    let asym_r = DynDims::new(2, 2, 0).expect("dims");
    let h2 = [[1.0, 0.0], [0.0, 1.0]];
    let e = Model::new(dims(), &F, &H, &asym, &R).err();
    assert!(
        matches!(e, Some(Error::NotSymmetric { name: "Q", .. })),
        "{e:?}"
    );
    let e = Model::new(asym_r, &F, &h2, &Q, &asym).err();
    assert!(
        matches!(e, Some(Error::NotSymmetric { name: "R", .. })),
        "{e:?}"
    );
    let e = Filter::new(model(), &[0.0; 2], &asym, CovarianceForm::Joseph).err();
    assert!(
        matches!(e, Some(Error::NotSymmetric { name: "P0", .. })),
        "{e:?}"
    );
}

#[test]
fn indefinite_covariances_are_rejected() {
    let indef = [[1.0, 2.0], [2.0, 1.0]];
    let e = Model::new(dims(), &F, &H, &indef, &R).err();
    assert!(
        matches!(e, Some(Error::NotPositiveSemidefinite { name: "Q", .. })),
        "{e:?}"
    );
    let e = Model::new(dims(), &F, &H, &Q, &[[-1.0]]).err();
    assert!(
        matches!(e, Some(Error::NotPositiveSemidefinite { name: "R", .. })),
        "{e:?}"
    );
    let e = Filter::new(model(), &[0.0; 2], &indef, CovarianceForm::SquareRoot).err();
    assert!(
        matches!(e, Some(Error::NotPositiveSemidefinite { name: "P0", .. })),
        "{e:?}"
    );
    // |S| too large for Q and R: the joint covariance [[R, Sᵀ], [S, Q]] is indefinite.
    let e = model().with_cross_covariance(&[[1.0], [0.0]]).err();
    assert!(
        matches!(
            e,
            Some(Error::NotPositiveSemidefinite {
                name: "[[R, S^T], [S, Q]]",
                ..
            })
        ),
        "{e:?}"
    );
}

#[test]
fn step_inputs_are_checked_and_leave_the_state_unchanged() {
    let mut f = Filter::new(model(), &[0.0; 2], &P0, CovarianceForm::Joseph).expect("filter");
    let e = f.step(&[1.0, 2.0], None).err();
    assert!(matches!(e, Some(Error::Shape { name: "z", .. })), "{e:?}");
    let e = f.step(&[f64::INFINITY], None).err();
    assert!(
        matches!(e, Some(Error::NonFinite { name: "z", .. })),
        "{e:?}"
    );
    let e = f.step(&[1.0], Some(&[1.0, 2.0])).err();
    assert!(matches!(e, Some(Error::Shape { name: "u", .. })), "{e:?}");
    let e = f.step(&[1.0], Some(&[f64::NAN])).err();
    assert!(
        matches!(e, Some(Error::NonFinite { name: "u", .. })),
        "{e:?}"
    );
    assert_eq!(f.steps(), 0);
    assert!(f.state().iter().all(|v| v.abs() < 1e-300));
}

#[test]
fn dimensions_are_checked() {
    assert!(matches!(
        DynDims::new(0, 1, 0),
        Err(Error::Dimension { name: "n", .. })
    ));
    assert!(matches!(
        DynDims::new(1, 0, 0),
        Err(Error::Dimension { name: "m", .. })
    ));
    // `FixedDims::new()` checks at compile time; `Default` bypasses that and is caught here.
    let eye17 = faer::Mat::<f64>::identity(17, 17);
    let h = faer::Mat::<f64>::identity(1, 17);
    let r = faer::Mat::<f64>::identity(1, 1);
    let e = Model::new(FixedDims::<17, 1, 0>::default(), &eye17, &h, &eye17, &r).err();
    assert!(
        matches!(e, Some(Error::Dimension { name: "n", .. })),
        "{e:?}"
    );
    // A time-varying model must keep the dimensions.
    let other = Model::new(DynDims::new(2, 1, 0).expect("dims"), &F, &H, &Q, &R).expect("model");
    let mut f = Filter::new(model(), &[0.0; 2], &P0, CovarianceForm::Joseph).expect("filter");
    assert!(matches!(
        f.step_with(&other, &[1.0], None),
        Err(Error::Dimension { .. })
    ));
    let empty: Vec<Model<DynDims>> = Vec::new();
    assert!(matches!(
        f.step_source(&empty, &[1.0], None),
        Err(Error::NoModel { step: 0 })
    ));
}

/// `R(θ)·diag(l1, l2)·R(θ)ᵀ`, plus `skew` added to the (0, 1) entry only.
fn rotated(l1: f64, l2: f64, skew: f64, unit: f64) -> [[f64; 2]; 2] {
    let (s, c) = 0.3_f64.sin_cos();
    let a = c * c * l1 + s * s * l2;
    let b = s * c * (l1 - l2);
    let d = s * s * l1 + c * c * l2;
    [[a * unit, (b + skew) * unit], [b * unit, d * unit]]
}

/// The tolerance policy is relative to the matrix's own scale: one process noise covariance
/// written in m² and in mm² (× 1e6) gets the same verdict; the cases sit a factor of 50
/// either side of the 1e-10 tolerances, far from round-off and from real modelling errors.
#[test]
fn covariance_checks_do_not_depend_on_units() {
    let cases = [
        ((1e-4, -5e-11, 0.0), false),
        ((1e-4, -5e-15, 0.0), true),
        ((1e-4, 1e-5, 5e-13), false),
        ((1e-4, 1e-5, 5e-16), true),
    ];
    for ((l1, l2, skew), ok) in cases {
        for unit in [1.0, 1e6] {
            let q = rotated(l1, l2, skew, unit);
            let got = Model::new(dims(), &F, &H, &q, &R);
            assert_eq!(got.is_ok(), ok, "unit × {unit}: {q:?} gave {:?}", got.err());
        }
    }
    assert!(
        (kalman::SYMMETRY_TOL - 1e-10).abs() < 1e-25 && (kalman::PSD_TOL - 1e-10).abs() < 1e-25
    );
}

/// `kalman::dense::check_covariance` (the rule the Python module applies to an assigned
/// covariance) gives `Model::new`'s verdict on Q on both sides of each tolerance: an
/// asymmetry of 2·SYMMETRY_TOL and 0.5·SYMMETRY_TOL of the largest entry, an eigenvalue of
/// −2·PSD_TOL and −0.5·PSD_TOL of the largest (the factor 2 leaves room for the round-off of
/// the eigen-decomposition, ~1e-16 of the largest eigenvalue).
#[test]
fn the_slice_rule_is_the_models_rule() {
    use kalman::{PSD_TOL, SYMMETRY_TOL, dense::check_covariance};
    let scale = 3.0;
    let mut cases: Vec<([[f64; 2]; 2], bool)> = Vec::new();
    for (factor, ok) in [(2.0, false), (0.5, true)] {
        let d = factor * SYMMETRY_TOL * scale;
        cases.push(([[scale, 1.0 + d], [1.0, 2.0]], ok));
        // diag(scale, −factor·PSD_TOL·scale): its smallest eigenvalue is exactly that.
        cases.push(([[scale, 0.0], [0.0, -factor * PSD_TOL * scale]], ok));
    }
    for (q, ok) in cases {
        let model = Model::new(dims(), &F, &H, &q, &R);
        // Column-major, as `dense` takes it.
        let slice = [q[0][0], q[1][0], q[0][1], q[1][1]];
        let rule = check_covariance("Q", &slice, 2);
        assert_eq!(model.is_ok(), ok, "{q:?}: {model:?}");
        assert_eq!(rule.is_ok(), ok, "{q:?}: {rule:?}");
        if let (Err(a), Err(b)) = (&model, &rule) {
            assert_eq!(std::mem::discriminant(a), std::mem::discriminant(b));
        }
    }
    assert!(matches!(
        check_covariance("Q", &[1.0, 0.0, 0.0], 2),
        Err(Error::Dimension { name: "Q", .. })
    ));
}
