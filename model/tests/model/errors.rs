//! Bad input of every class returns a typed error naming the matrix or parameter.

use model::{
    ContinuousSs, ContinuousTf, DampedCosineShaping, DiscreteSs, DiscreteTf, Discretization, Error,
    ExponentialShaping, FuelParams, IrregularRollingShaping, NoiseConvention, discrete_lyapunov,
    discretize, zoh,
};
use nalgebra::DMatrix;

fn z(r: usize, c: usize) -> DMatrix<f64> {
    DMatrix::zeros(r, c)
}

fn lag() -> ContinuousSs {
    ContinuousSs::new(
        DMatrix::from_element(1, 1, -1.0),
        z(1, 1),
        DMatrix::from_element(1, 1, 1.0),
        z(1, 1),
    )
    .expect("valid")
}

#[test]
fn non_square_state_matrix() {
    let e = ContinuousSs::new(z(2, 3), z(2, 1), z(1, 3), z(1, 1))
        .expect_err("bad input must be rejected");
    assert_eq!(
        e,
        Error::NotSquare {
            name: "A",
            rows: 2,
            cols: 3
        }
    );
    assert!(e.to_string().contains("A") && e.to_string().contains("2×3"));
    let e = DiscreteSs::new(z(3, 2), z(3, 1), z(1, 2), z(1, 1), 0.1)
        .expect_err("bad input must be rejected");
    assert!(matches!(e, Error::NotSquare { name: "F", .. }));
}

#[test]
fn mismatched_matrices() {
    let e = ContinuousSs::new(z(2, 2), z(3, 1), z(1, 2), z(1, 1))
        .expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::DimensionMismatch {
                name: "B",
                rows: 3,
                expected_rows: 2,
                ..
            }
        ),
        "{e}"
    );
    let e = ContinuousSs::new(z(2, 2), z(2, 1), z(1, 3), z(1, 1))
        .expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::DimensionMismatch { name: "C", .. }),
        "{e}"
    );
    let e = ContinuousSs::new(z(2, 2), z(2, 1), z(1, 2), z(2, 1))
        .expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::DimensionMismatch { name: "D", .. }),
        "{e}"
    );
    let e = lag()
        .with_noise(z(2, 1), z(1, 1))
        .expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::DimensionMismatch { name: "G", .. }),
        "{e}"
    );
    let d = DiscreteSs::new(z(2, 2), z(2, 1), z(1, 2), z(1, 1), 0.1).expect("valid");
    let e = d
        .clone()
        .with_noise(z(2, 1), z(1, 1), z(2, 2))
        .expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::DimensionMismatch { name: "Q", .. }),
        "{e}"
    );
    let e = d
        .with_noise(z(2, 1), z(3, 1), z(1, 1))
        .expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::DimensionMismatch { name: "J", .. }),
        "{e}"
    );
    // Composition: series needs outputs of the first = inputs of the second.
    let s1 = DiscreteSs::new(z(1, 1), z(1, 1), z(2, 1), z(2, 1), 0.1).expect("valid");
    let e = model::series(&s1, &s1).expect_err("bad input must be rejected");
    assert!(matches!(e, Error::DimensionMismatch { .. }), "{e}");
    let s2 = DiscreteSs::new(z(1, 1), z(1, 1), z(1, 1), z(1, 1), 0.2).expect("valid");
    let s3 = DiscreteSs::new(z(1, 1), z(1, 1), z(1, 1), z(1, 1), 0.1).expect("valid");
    assert!(matches!(
        model::series(&s2, &s3),
        Err(Error::SampleTimeMismatch { .. })
    ));
    assert!(matches!(
        model::select_outputs(&s3, &[1]),
        Err(Error::IndexOutOfRange {
            name: "output",
            index: 1,
            len: 1
        })
    ));
}

#[test]
fn non_finite_entries() {
    let mut a = z(2, 2);
    a[(1, 0)] = f64::NAN;
    let e =
        ContinuousSs::new(a, z(2, 1), z(1, 2), z(1, 1)).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::NonFiniteMatrix {
                name: "A",
                row: 1,
                col: 0,
                ..
            }
        ),
        "{e}"
    );
    let mut q = z(1, 1);
    q[(0, 0)] = f64::INFINITY;
    let d = DiscreteSs::new(z(1, 1), z(1, 1), z(1, 1), z(1, 1), 0.1).expect("valid");
    let e = d
        .with_noise(z(1, 1), z(1, 1), q)
        .expect_err("bad input must be rejected");
    assert!(matches!(e, Error::NonFiniteMatrix { name: "Q", .. }), "{e}");
    let e =
        ContinuousTf::new(vec![1.0], vec![1.0, f64::NAN]).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidParameter {
                name: "denominator",
                ..
            }
        ),
        "{e}"
    );
    let e = FuelParams {
        phi: f64::NAN,
        ..FuelParams::default()
    }
    .validate()
    .expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::InvalidParameter { name: "phi", .. }),
        "{e}"
    );
}

#[test]
fn non_positive_sampling_interval() {
    for dt in [0.0, -0.1, f64::NAN] {
        let e = DiscreteSs::new(z(1, 1), z(1, 1), z(1, 1), z(1, 1), dt)
            .expect_err("bad input must be rejected");
        assert!(
            matches!(e, Error::InvalidParameter { name: "dt", .. }),
            "{e}"
        );
        let e = discretize(&lag(), dt, Discretization::Zoh, NoiseConvention::VanLoan)
            .expect_err("bad input must be rejected");
        assert!(
            matches!(e, Error::InvalidParameter { name: "dt", .. }),
            "{e}"
        );
        let e = zoh(&z(1, 1), &z(1, 1), dt).expect_err("bad input must be rejected");
        assert!(
            matches!(e, Error::InvalidParameter { name: "dt", .. }),
            "{e}"
        );
        let e = DiscreteTf::new(vec![1.0], vec![1.0], dt).expect_err("bad input must be rejected");
        assert!(
            matches!(e, Error::InvalidParameter { name: "dt", .. }),
            "{e}"
        );
        let e = FuelParams {
            dt,
            ..FuelParams::default()
        }
        .validate()
        .expect_err("bad input must be rejected");
        assert!(
            matches!(e, Error::InvalidParameter { name: "dt", .. }),
            "{e}"
        );
    }
    // Pre-warp frequency at or above Nyquist.
    let e = discretize(
        &lag(),
        0.1,
        Discretization::TustinPrewarp { omega: 40.0 },
        NoiseConvention::VanLoan,
    )
    .expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidParameter {
                name: "prewarp_frequency",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn non_positive_time_constants_and_variances() {
    let e = ExponentialShaping::new(1.0, 0.0).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidParameter {
                name: "time_constant",
                ..
            }
        ),
        "{e}"
    );
    let e = ExponentialShaping::new(-1.0, 1.0).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidParameter {
                name: "variance",
                ..
            }
        ),
        "{e}"
    );
    let e = IrregularRollingShaping::new(1.0, -0.1, 1.0).expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::InvalidParameter { name: "mu", .. }),
        "{e}"
    );
    let e = IrregularRollingShaping::new(1.0, 0.1, 0.0).expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::InvalidParameter { name: "beta", .. }),
        "{e}"
    );
    let e = DampedCosineShaping::new(0.0, 0.1, 1.0).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidParameter {
                name: "variance",
                ..
            }
        ),
        "{e}"
    );
    let e = DampedCosineShaping::new(1.0, 0.0, 1.0).expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::InvalidParameter { name: "xi", .. }),
        "{e}"
    );
    for (name, p) in [
        (
            "t_a",
            FuelParams {
                t_a: 0.0,
                ..FuelParams::default()
            },
        ),
        (
            "t_y",
            FuelParams {
                t_y: -2.0,
                ..FuelParams::default()
            },
        ),
        (
            "d_c",
            FuelParams {
                d_c: 0.0,
                ..FuelParams::default()
            },
        ),
        (
            "delta",
            FuelParams {
                delta: 0.0,
                ..FuelParams::default()
            },
        ),
        (
            "sensor_radius",
            FuelParams {
                sensor_radius: 0.0,
                ..FuelParams::default()
            },
        ),
        (
            "rolling_period",
            FuelParams {
                rolling_period: 0.0,
                ..FuelParams::default()
            },
        ),
        (
            "max_tilt_amplitude",
            FuelParams {
                max_tilt_amplitude: -0.01,
                ..FuelParams::default()
            },
        ),
        (
            "gyro_noise_var",
            FuelParams {
                gyro_noise_var: -1.0,
                ..FuelParams::default()
            },
        ),
    ] {
        let e = p
            .build(model::Channels::LevelAndTilt, model::Realisation::Paper)
            .expect_err("bad input must be rejected");
        assert!(
            matches!(e, Error::InvalidParameter { name: n, .. } if n == name),
            "{name}: {e}"
        );
        assert!(e.to_string().contains(name));
    }
    // Covariances and intensities: negative variance or asymmetry.
    let e = lag()
        .with_noise(
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, -1.0),
        )
        .expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::NotPositiveSemiDefinite { name: "W", .. }),
        "{e}"
    );
    let w = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.4, 1.0]);
    let e = ContinuousSs::new(z(2, 2), z(2, 0), z(1, 2), z(1, 0))
        .expect("valid")
        .with_noise(DMatrix::identity(2, 2), w)
        .expect_err("bad input must be rejected");
    assert!(matches!(e, Error::NotSymmetric { name: "W", .. }), "{e}");
}

#[test]
fn unstable_system_has_no_stationary_covariance() {
    let f = DMatrix::from_row_slice(2, 2, &[1.1, 0.0, 0.3, 0.5]);
    let e =
        discrete_lyapunov(&f, &DMatrix::identity(2, 2)).expect_err("bad input must be rejected");
    assert!(
        matches!(e, Error::Unstable { name: "F", value, .. } if (value - 1.1).abs() < 1e-12),
        "{e}"
    );
    // A marginally stable integrator is rejected too.
    let d = DiscreteSs::new(
        DMatrix::identity(1, 1),
        z(1, 0),
        DMatrix::identity(1, 1),
        z(1, 0),
        0.1,
    )
    .expect("valid")
    .with_noise(DMatrix::identity(1, 1), z(1, 1), DMatrix::identity(1, 1))
    .expect("valid");
    assert!(matches!(
        d.stationary_covariance(),
        Err(Error::Unstable { name: "F", .. })
    ));
}

#[test]
fn transfer_function_errors() {
    let e = ContinuousTf::new(vec![1.0, 2.0, 3.0], vec![1.0, 1.0])
        .expect_err("bad input must be rejected");
    assert_eq!(
        e,
        Error::Improper {
            num_degree: 2,
            den_degree: 1
        }
    );
    let e = ContinuousTf::new(vec![1.0], vec![0.0, 0.0]).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidPolynomial {
                name: "denominator",
                ..
            }
        ),
        "{e}"
    );
    let e = ContinuousTf::new(vec![], vec![1.0]).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidPolynomial {
                name: "numerator",
                ..
            }
        ),
        "{e}"
    );
    let e =
        DiscreteTf::new(vec![1.0], vec![0.0, 1.0], 0.1).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidPolynomial {
                name: "denominator",
                ..
            }
        ),
        "{e}"
    );
    // The paper's variant needs a strictly proper model.
    let bi = ContinuousTf::new(vec![1.0, 1.0], vec![1.0, 2.0]).expect("valid");
    let e = bi
        .paper_tustin(0.1, model::PaperVariant::Drop)
        .expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::InvalidPolynomial {
                name: "numerator",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn ill_posed_feedback_loop_and_singular_dc_gain() {
    // Unit feed-through both ways with positive feedback: I − D1·D2 = 0.
    let one = DMatrix::from_element(1, 1, 1.0);
    let s = DiscreteSs::new(z(0, 0), z(0, 1), z(1, 0), one, 0.1).expect("valid static gain");
    let e = model::feedback(&s, &s, 1.0).expect_err("bad input must be rejected");
    assert!(
        matches!(
            e,
            Error::Singular {
                name: "I − D·K",
                ..
            }
        ),
        "{e}"
    );
    // DC gain of an integrator.
    let int = ContinuousTf::new(vec![1.0], vec![0.0, 1.0])
        .expect("valid")
        .realize();
    assert!(matches!(
        int.dc_gain(),
        Err(Error::Singular { name: "A", .. })
    ));
}

/// `R(θ)·diag(l1, l2)·R(θ)ᵀ`, plus `skew` added to the (0, 1) entry only.
fn rotated(l1: f64, l2: f64, skew: f64) -> DMatrix<f64> {
    let (s, c) = 0.3_f64.sin_cos();
    let r = DMatrix::from_row_slice(2, 2, &[c, -s, s, c]);
    let mut m = &r * DMatrix::from_diagonal(&nalgebra::dvector![l1, l2]) * r.transpose();
    m[(0, 1)] += skew;
    m
}

/// The tolerance policy is relative to the matrix's own scale: one noise intensity written in
/// m² and in mm² (× 1e6) gets the same verdict. The matrices sit a factor of 50 either side
/// of the 1e-10 tolerances, far from round-off (1e-16) and from any real modelling error.
#[test]
fn covariance_checks_do_not_depend_on_units() {
    let verdict = |w: DMatrix<f64>| {
        ContinuousSs::new(z(2, 2), z(2, 0), z(1, 2), z(1, 0))
            .expect("valid")
            .with_noise(DMatrix::identity(2, 2), w)
    };
    // (1 cm)² variance with an eigenvalue of −5e-7 relative: not PSD in any unit.
    let cases = [
        (rotated(1e-4, -5e-11, 0.0), false),
        (rotated(1e-4, -5e-15, 0.0), true),
        (rotated(1e-4, 1e-5, 5e-13), false),
        (rotated(1e-4, 1e-5, 5e-16), true),
    ];
    for (m2, ok) in cases {
        for unit in [1.0, 1e6] {
            let w = &m2 * unit;
            let got = verdict(w.clone());
            assert_eq!(got.is_ok(), ok, "unit × {unit}: {w} gave {got:?}");
        }
    }
    assert!((model::SYMMETRY_TOL - 1e-10).abs() < 1e-25 && (model::PSD_TOL - 1e-10).abs() < 1e-25);
}
