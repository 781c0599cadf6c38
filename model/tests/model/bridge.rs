//! The model → kalman bridge: `filter_noise` and `to_kalman` against the hand conversion
//! (`G Q Gᵀ`, `R_c + J Q Jᵀ`, `G Q Jᵀ` formed here) and against closed forms of a scalar model.

use model::nalgebra::{DMatrix, dmatrix};
use model::{ContinuousSs, Discretization, Error, NoiseConvention};

/// Largest entry-wise difference between a faer view and a nalgebra matrix of the same shape.
fn diff(a: kalman::faer::MatRef<'_, f64>, b: &DMatrix<f64>) -> f64 {
    assert_eq!((a.nrows(), a.ncols()), b.shape());
    let mut d = 0.0_f64;
    for i in 0..b.nrows() {
        for j in 0..b.ncols() {
            d = d.max((a[(i, j)] - b[(i, j)]).abs());
        }
    }
    d
}

#[test]
fn scalar_van_loan_noise_matches_its_closed_form() {
    // ẋ = a x + w, E[w w] = W δ: F = e^{aΔt}, Q_d = W (e^{2aΔt} − 1) / (2a).
    let (a, w, dt, r) = (-0.7_f64, 2.5, 0.3, 0.04);
    let sys = ContinuousSs::autonomous(dmatrix![a], dmatrix![1.0])
        .and_then(|s| s.with_noise(dmatrix![1.0], dmatrix![w]))
        .expect("valid");
    let d = sys
        .discretize(dt, Discretization::Zoh, NoiseConvention::VanLoan)
        .expect("discretises");
    let m = d.to_kalman(Some(&dmatrix![r])).expect("bridges");
    let q = w * ((2.0 * a * dt).exp() - 1.0) / (2.0 * a);
    // Van Loan's exponential is accurate to a few ulps of its largest entry (order 1 here).
    assert!((m.f()[(0, 0)] - (a * dt).exp()).abs() < 1e-14);
    assert!((m.q()[(0, 0)] - q).abs() < 1e-14 * (1.0 + q));
    assert!((m.r()[(0, 0)] - r).abs() < f64::EPSILON * r);
    // ZOH with Van Loan noise has no noise feed-through, hence no cross-covariance.
    assert!(m.s().is_none());
}

#[test]
fn tustin_held_noise_gives_r_plus_jqj_and_a_cross_covariance() {
    // A damped oscillator driven by white force noise, position seen. (No control input:
    // Tustin gives a control input a feed-through D ≠ 0, which the filter form has no place
    // for; the next test checks that it is refused.)
    let sys = ContinuousSs::autonomous(dmatrix![0.0, 1.0; -4.0, -0.4], dmatrix![1.0, 0.0])
        .and_then(|s| s.with_noise(dmatrix![0.0; 1.0], dmatrix![0.3]))
        .expect("valid");
    let d = sys
        .discretize(
            0.05,
            Discretization::Tustin,
            NoiseConvention::IntensityOverDt,
        )
        .expect("discretises");
    let r_c = dmatrix![0.01];
    let (g, j, q) = (d.g(), d.j(), d.q());
    assert!(
        j.iter().any(|v| v.abs() > 0.0),
        "Tustin feeds the noise through"
    );
    // The hand conversion.
    let q_hand = g * q * g.transpose();
    let r_hand = &r_c + j * q * j.transpose();
    let s_hand = g * q * j.transpose();
    let m = d.to_kalman(Some(&r_c)).expect("bridges");
    // Same products in a different association order: a few ulps of their scale.
    let tol = 1e-15 * (1.0 + q_hand.amax() + r_hand.amax());
    assert!(diff(m.f(), d.f()) < f64::MIN_POSITIVE);
    assert!(diff(m.h(), d.h()) < f64::MIN_POSITIVE);
    assert!(diff(m.b(), d.b()) < f64::MIN_POSITIVE);
    assert!(diff(m.q(), &q_hand) < tol);
    assert!(diff(m.r(), &r_hand) < tol);
    assert!(diff(m.s().expect("J ≠ 0 gives S"), &s_hand) < tol);
    // The noise-only form agrees with the model the bridge built.
    let noise = d.filter_noise(Some(&r_c)).expect("valid");
    assert!(diff(m.q(), &noise.q) < f64::MIN_POSITIVE);
}

#[test]
fn feedthrough_and_bad_sensor_noise_are_refused_by_name() {
    let sys = ContinuousSs::autonomous(dmatrix![-1.0], dmatrix![1.0])
        .and_then(|s| s.with_input(dmatrix![1.0]))
        .and_then(|s| s.with_feedthrough(dmatrix![0.5]))
        .and_then(|s| s.with_noise(dmatrix![1.0], dmatrix![1.0]))
        .expect("valid");
    let d = sys
        .discretize(0.1, Discretization::Zoh, NoiseConvention::VanLoan)
        .expect("discretises");
    assert!(matches!(
        d.to_kalman(None),
        Err(Error::InvalidParameter { name: "D", .. })
    ));
    let plain = ContinuousSs::autonomous(dmatrix![-1.0], dmatrix![1.0])
        .and_then(|s| s.with_noise(dmatrix![1.0], dmatrix![1.0]))
        .and_then(|s| s.discretize(0.1, Discretization::Zoh, NoiseConvention::VanLoan))
        .expect("valid");
    assert!(matches!(
        plain.to_kalman(Some(&dmatrix![-1.0])),
        Err(Error::NotPositiveSemiDefinite { name: "R", .. })
    ));
    assert!(matches!(
        plain.to_kalman(Some(&dmatrix![1.0, 0.0; 0.0, 1.0])),
        Err(Error::DimensionMismatch { name: "R", .. })
    ));
}
