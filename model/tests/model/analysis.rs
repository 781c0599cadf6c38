//! Analysis helpers: controllability/observability with the rank tolerance, stability,
//! Lyapunov residuals, PSD factors, and the SPD strategy's condition number.

use model::{discrete_lyapunov, is_controllable, is_observable, rank, spectral_radius};
use nalgebra::{DMatrix, DVector};

#[test]
fn controllability_and_observability_of_double_integrator() {
    let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
    assert!(is_controllable(&a, &DMatrix::from_row_slice(2, 1, &[0.0, 1.0]), None).expect("ok"));
    assert!(!is_controllable(&a, &DMatrix::from_row_slice(2, 1, &[1.0, 0.0]), None).expect("ok"));
    assert!(is_observable(&a, &DMatrix::from_row_slice(1, 2, &[1.0, 0.0]), None).expect("ok"));
    assert!(!is_observable(&a, &DMatrix::from_row_slice(1, 2, &[0.0, 1.0]), None).expect("ok"));
}

#[test]
fn rank_uses_the_stated_tolerance() {
    // Singular values 1 and 1e-13: rank 2 by the default tolerance 2·ε·1 ≈ 4.4e-16,
    // rank 1 with an explicit tolerance of 1e-12.
    let m = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1e-13]);
    assert_eq!(rank(&m, None).expect("ok"), 2);
    assert_eq!(rank(&m, Some(1e-12)).expect("ok"), 1);
    let m = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1e-17]);
    assert_eq!(rank(&m, None).expect("ok"), 1);
}

#[test]
fn fuel_model_is_observable_with_two_channels() {
    let m = model::FuelParams::default()
        .build(model::Channels::LevelAndTilt, model::Realisation::Paper)
        .expect("builds");
    // The seven states are observable from (z1, z2) at the defaults: tolerance default.
    assert!(is_observable(&m.a, &m.c, None).expect("ok"));
    // The integrator makes A marginally stable: spectral radius 1 (up to rounding).
    let rho = spectral_radius(&m.a).expect("ok");
    assert!((rho - 1.0).abs() < 1e-9, "{rho}");
}

#[test]
fn scalar_lyapunov_closed_form() {
    let (f, q) = (0.9, 2.0);
    let p = discrete_lyapunov(
        &DMatrix::from_element(1, 1, f),
        &DMatrix::from_element(1, 1, q),
    )
    .expect("stable");
    assert!((p[(0, 0)] - q / (1.0 - f * f)).abs() < 1e-12);
    // Rotation scaled by 0.5: spectral radius 0.5.
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    let r = DMatrix::from_row_slice(2, 2, &[c, -s, s, c]) * 0.5;
    assert!((spectral_radius(&r).expect("ok") - 0.5).abs() < 1e-14);
}

#[cfg(feature = "proptest")]
mod props {
    use super::*;
    use model::psd_factor;
    use model::strategies::{spd_matrix, stable_discrete};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(super::super::support::config())]

        /// P − F P Fᵀ − GQGᵀ ≈ 0, P symmetric PSD.
        #[test]
        fn lyapunov_residual(sys in stable_discrete(8, 3, 3)) {
            let q = sys.process_covariance();
            let p = sys.stationary_covariance().expect("stable by construction");
            let res = &p - sys.f() * &p * sys.f().transpose() - &q;
            // ‖P‖ ≤ ‖Q‖/(1 − 0.95²) ≈ 10‖Q‖; rounding of the doubling sums is a few ε‖P‖ per step.
            prop_assert!(res.amax() <= 1e-12 * p.amax().max(1.0), "residual {:e}", res.amax());
            prop_assert!((&p - p.transpose()).amax() <= 0.0);
            prop_assert!(p.symmetric_eigenvalues().min() >= -1e-12 * p.amax().max(1.0));
        }

        /// The SPD strategy delivers the requested condition number; psd_factor reconstructs.
        #[test]
        fn spd_condition_and_factor(
            (n, cond, m) in (1usize..=8, 1.0..1e6f64)
                .prop_flat_map(|(n, c)| (Just(n), Just(c), spd_matrix(n, c)))
        ) {
            let ev = m.symmetric_eigenvalues();
            let got = ev.max() / ev.min();
            if n > 1 {
                // Eigenvalues of U·diag·Uᵀ are recovered to ~ε·cond relative.
                prop_assert!((got - cond).abs() <= 1e-8 * cond, "cond {got} vs {cond}");
            }
            let l = psd_factor(&m).expect("SPD");
            let err = (&l * l.transpose() - &m).amax();
            prop_assert!(err <= 1e-10 * m.amax(), "L Lᵀ − M = {err:e}");
        }

        /// Random stable discrete systems really are stable and observable systems report
        /// consistently with the rank of the observability matrix.
        #[test]
        fn stable_discrete_is_stable(sys in stable_discrete(8, 3, 3)) {
            prop_assert!(sys.spectral_radius().expect("ok") < 0.95 + 1e-12);
            let o = model::analysis::observability_matrix(sys.f(), sys.h()).expect("ok");
            prop_assert_eq!(
                sys.is_observable(None).expect("ok"),
                rank(&o, None).expect("ok") == sys.n_states()
            );
        }
    }
}

/// The default rank tolerance is max(rows, cols)·ε·σ_max, relative to the largest singular
/// value: diag(s, s·1e-17) has rank 1 whatever the unit s (1e-17 is far below 2ε), and a
/// given tolerance counts only the singular values strictly above it.
#[test]
fn rank_tolerance_is_relative_and_strict() {
    for s in [1e-10, 1.0, 1e10] {
        let m = DMatrix::from_diagonal(&DVector::from_vec(vec![s, s * 1e-17]));
        assert_eq!(rank(&m, None).expect("finite"), 1, "unit {s}");
        let tol = model::analysis::default_rank_tolerance(&m);
        // The SVD of a diagonal matrix returns its entries to round-off.
        assert!(
            (tol - 2.0 * f64::EPSILON * s).abs() <= 1e-12 * tol,
            "unit {s}: {tol}"
        );
    }
    let m = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 3.0]);
    let sv = m.clone().svd(false, false).singular_values;
    let (big, small) = (sv.max(), sv.min());
    assert_eq!(
        rank(&m, Some(small)).expect("finite"),
        1,
        "σ = tol is not above it"
    );
    assert_eq!(rank(&m, Some(small * (1.0 - 1e-12))).expect("finite"), 2);
    assert_eq!(rank(&m, Some(big)).expect("finite"), 0);
}

/// The spectral abscissa is the largest real part of the eigenvalues: the largest diagonal
/// entry of a triangular matrix, and a for the rotation-scaling block [[a, b], [−b, a]]
/// (eigenvalues a ± ib), positive or negative.
#[test]
fn spectral_abscissa_is_the_largest_real_part() {
    let tri = DMatrix::from_row_slice(3, 3, &[-1.0, 5.0, 2.0, 0.0, 0.25, 7.0, 0.0, 0.0, -3.0]);
    assert!((model::spectral_abscissa(&tri).expect("finite") - 0.25).abs() <= 1e-14);
    for a in [0.7, -1.5] {
        let rot = DMatrix::from_row_slice(2, 2, &[a, 2.0, -2.0, a]);
        // A 2×2 real Schur block: a few ε of the entries.
        assert!(
            (model::spectral_abscissa(&rot).expect("finite") - a).abs() <= 1e-14,
            "{a}"
        );
    }
}

/// A continuous model's own checks: stable exactly when every eigenvalue of A has a negative
/// real part (an integrator, eigenvalue 0, is not), and the double integrator is controllable
/// from the acceleration input and observable from the position, not the other way round.
#[test]
fn continuous_model_stability_controllability_and_observability() {
    let ss = |a: &[f64], b: &[f64], c: &[f64]| {
        model::ContinuousSs::new(
            DMatrix::from_row_slice(2, 2, a),
            DMatrix::from_row_slice(2, 1, b),
            DMatrix::from_row_slice(1, 2, c),
            DMatrix::zeros(1, 1),
        )
        .expect("valid")
    };
    let stable = ss(&[-1.0, 2.0, 0.0, -0.5], &[0.0, 1.0], &[1.0, 0.0]);
    let integrator = ss(&[0.0, 0.0, 0.0, -1.0], &[0.0, 1.0], &[1.0, 0.0]);
    let unstable = ss(&[0.3, 0.0, 0.0, -1.0], &[0.0, 1.0], &[1.0, 0.0]);
    assert!(stable.is_stable().expect("ok"));
    assert!(!integrator.is_stable().expect("ok"));
    assert!(!unstable.is_stable().expect("ok"));

    let double = [0.0, 1.0, 0.0, 0.0];
    let from_acceleration = ss(&double, &[0.0, 1.0], &[1.0, 0.0]);
    let from_position = ss(&double, &[1.0, 0.0], &[0.0, 1.0]);
    assert!(from_acceleration.is_controllable(None).expect("ok"));
    assert!(from_acceleration.is_observable(None).expect("ok"));
    assert!(!from_position.is_controllable(None).expect("ok"));
    assert!(!from_position.is_observable(None).expect("ok"));
}

/// The Lyapunov doubling stops on a criterion relative to P, so a scaled Q gives the scaled
/// P to round-off whatever the unit (an absolute stopping rule would stop early for small Q
/// and truncate the series).
#[test]
fn discrete_lyapunov_is_scale_free() {
    let f = DMatrix::from_row_slice(2, 2, &[0.9, 0.2, -0.1, 0.7]);
    let q = DMatrix::from_row_slice(2, 2, &[1.0, 0.3, 0.3, 2.0]);
    let p1 = discrete_lyapunov(&f, &q).expect("stable");
    for s in [1e-12, 1e12] {
        let ps = discrete_lyapunov(&f, &(&q * s)).expect("stable");
        // Doublings of a contraction with ρ ≈ 0.8: a few dozen roundings, 1e-13 relative.
        assert!((&ps / s - &p1).amax() <= 1e-13 * p1.amax(), "unit {s}");
    }
}

/// The discrete twin: stable exactly when every eigenvalue of F lies inside the unit circle
/// (a unit eigenvalue is not), the spectral radius is the largest modulus (0.9 for a
/// triangular F with diagonal 0.5, −0.9), and the discrete double integrator is controllable
/// from the acceleration input and observable from the position, not the other way round.
#[test]
fn discrete_model_stability_controllability_and_observability() {
    let ss = |f: &[f64], b: &[f64], h: &[f64]| {
        model::DiscreteSs::new(
            DMatrix::from_row_slice(2, 2, f),
            DMatrix::from_row_slice(2, 1, b),
            DMatrix::from_row_slice(1, 2, h),
            DMatrix::zeros(1, 1),
            0.1,
        )
        .expect("valid")
    };
    let stable = ss(&[0.5, 1.0, 0.0, -0.9], &[0.0, 1.0], &[1.0, 0.0]);
    let marginal = ss(&[1.0, 0.0, 0.0, 0.5], &[0.0, 1.0], &[1.0, 0.0]);
    let unstable = ss(&[1.2, 0.0, 0.0, 0.1], &[0.0, 1.0], &[1.0, 0.0]);
    assert!(stable.is_stable().expect("ok"));
    assert!(!marginal.is_stable().expect("ok"));
    assert!(!unstable.is_stable().expect("ok"));
    // Eigenvalues of a triangular matrix: its diagonal, to a few ε.
    assert!((stable.spectral_radius().expect("ok") - 0.9).abs() <= 1e-14);
    assert!((unstable.spectral_radius().expect("ok") - 1.2).abs() <= 1e-14);

    let double = [1.0, 1.0, 0.0, 1.0];
    let from_acceleration = ss(&double, &[0.5, 1.0], &[1.0, 0.0]);
    let from_position = ss(&double, &[1.0, 0.0], &[0.0, 1.0]);
    assert!(from_acceleration.is_controllable(None).expect("ok"));
    assert!(from_acceleration.is_observable(None).expect("ok"));
    assert!(!from_position.is_controllable(None).expect("ok"));
    assert!(!from_position.is_observable(None).expect("ok"));
}
