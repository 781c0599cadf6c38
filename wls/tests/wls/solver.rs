//! Tests of `wls::solver`: agreement of QR and normal equations, accuracy at κ ≈ 1e8,
//! worst-case bounds against brute force, Tikhonov limits, priors, IRLS and typed errors.

use nalgebra::{DMatrix, DVector, dmatrix, dvector};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wls::Error;
use wls::solver::{
    IrlsOptions, PriorRows, SolveMethod, SolveOptions, Tikhonov, Weights, sensitivity, solve,
    solve_irls, worst_case_bounds,
};

fn uniform(rng: &mut ChaCha8Rng, m: usize, n: usize, lo: f64, hi: f64) -> DMatrix<f64> {
    DMatrix::from_fn(m, n, |_, _| rng.random_range(lo..hi))
}

/// A random m×n design with a dominant diagonal: κ stays small (checked where it matters).
fn well_conditioned(rng: &mut ChaCha8Rng, m: usize, n: usize) -> DMatrix<f64> {
    let mut h = uniform(rng, m, n, -1.0, 1.0);
    for i in 0..n {
        h[(i, i)] += 3.0;
    }
    h
}

fn qr() -> SolveOptions {
    SolveOptions::default()
}

fn normal() -> SolveOptions {
    SolveOptions {
        method: SolveMethod::NormalEquations,
        ..SolveOptions::default()
    }
}

/// A matrix with prescribed singular values: U·diag(σ)·Vᵀ with random orthonormal U, V.
fn with_singular_values(rng: &mut ChaCha8Rng, m: usize, sigma: &[f64]) -> DMatrix<f64> {
    let n = sigma.len();
    let U = uniform(rng, m, n, -1.0, 1.0).qr().q();
    let V = uniform(rng, n, n, -1.0, 1.0).qr().q();
    U * DMatrix::from_diagonal(&DVector::from_column_slice(sigma)) * V.transpose()
}

proptest! {
    /// Well-conditioned problems: κ(V^{1/2}H) ≤ 20, so even the normal equations (error
    /// ∝ κ²·ε ≈ 1e-13) agree with QR (∝ κ·ε) to 1e-12 relative.
    #[test]
    fn qr_and_normal_equations_agree_when_well_conditioned(
        seed in any::<u64>(), m in 1usize..=12, n_raw in 1usize..=6,
    ) {
        let n = n_raw.min(m);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let h = well_conditioned(&mut rng, m, n);
        let z = DVector::from_fn(m, |_, _| rng.random_range(-5.0..5.0));
        let w = Weights::Diagonal(DVector::from_fn(m, |_, _| rng.random_range(0.5..2.0)));
        let a = solve(&h, &z, &w, &qr()).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assume!(a.condition_weighted <= 20.0);
        let b = solve(&h, &z, &w, &normal()).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let scale = 1.0 + a.x.norm();
        prop_assert!((&a.x - &b.x).norm() <= 1e-12 * scale, "{} vs {}", a.x, b.x);
        let cscale = 1.0 + a.covariance.norm();
        prop_assert!((&a.covariance - &b.covariance).norm() <= 1e-12 * cscale);
        prop_assert_eq!(a.rank, n);
        // κ(HᵀVH) = κ(V^{1/2}H)² up to rounding.
        prop_assert!((a.condition_normal / a.condition_weighted.powi(2) - 1.0).abs() < 1e-8);
    }

    /// The worst-case bound of each unknown equals the maximum over all 2^m corners
    /// δz ∈ {±Δ} of |x̂(z + δz) − x̂(z)| (the map is linear, so a corner attains it).
    /// Tolerance: both sides are sums of m ≤ 6 terms of size ≤ ‖S‖·Δ, computed by different
    /// routes (one factorisation vs 2^m solves) with κ ≤ 50: 1e-9 relative is generous.
    #[test]
    fn worst_case_bounds_equal_brute_force_corners(
        seed in any::<u64>(), m in 1usize..=6, n_raw in 1usize..=3, regularise in any::<bool>(),
    ) {
        let n = n_raw.min(m);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let h = well_conditioned(&mut rng, m, n);
        let z = DVector::from_fn(m, |_, _| rng.random_range(-5.0..5.0));
        let w = Weights::Diagonal(DVector::from_fn(m, |_, _| rng.random_range(0.1..10.0)));
        let delta = DVector::from_fn(m, |_, _| rng.random_range(0.0..1.0));
        let options = SolveOptions {
            tikhonov: regularise.then(|| Tikhonov {
                lambda: 0.7,
                prior_mean: Some(DVector::from_element(n, 0.3)),
                operator: None,
            }),
            ..SolveOptions::default()
        };
        let base = solve(&h, &z, &w, &options).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assume!(base.condition_solved <= 50.0);
        let bound = worst_case_bounds(&h, &w, &delta, &options)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        let mut brute = DVector::<f64>::zeros(n);
        for corner in 0u32..(1 << m) {
            let dz = DVector::from_fn(m, |i, _| if corner >> i & 1 == 1 { delta[i] } else { -delta[i] });
            let x = solve(&h, &(&z + dz), &w, &options)
                .map_err(|e| TestCaseError::fail(e.to_string()))?.x;
            brute = brute.zip_map(&(x - &base.x), |b, d| b.max(d.abs()));
        }
        for j in 0..n {
            prop_assert!((bound[j] - brute[j]).abs() <= 1e-9 * (1.0 + bound[j]), "{} vs {}", bound, brute);
        }
    }
}

/// κ(H) = 1e8 with a known solution of a consistent system: QR's error ≈ κ·ε ≈ 1e-8 (≈ 8
/// digits), the normal equations' ≈ κ²·ε ≈ 1 (≈ 0 digits). Requires ≥ 6 more digits, for
/// several seeded problems.
#[test]
fn qr_keeps_six_more_digits_than_normal_equations_at_kappa_1e8() {
    for seed in 0..6 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let sigma: Vec<f64> = (0..5).map(|i| 10f64.powf(-2.0 * f64::from(i))).collect();
        let h = with_singular_values(&mut rng, 8, &sigma);
        let x_true = DVector::from_fn(5, |_, _| rng.random_range(-1.0..1.0));
        let z = &h * &x_true;
        let digits = |x: &DVector<f64>| -((x - &x_true).norm() / x_true.norm()).log10();
        let a =
            solve(&h, &z, &Weights::Identity, &qr()).expect("full rank at the default tolerance");
        let b = solve(&h, &z, &Weights::Identity, &normal()).expect("normal equations still solve");
        assert!(
            (a.condition_weighted / 1e8 - 1.0).abs() < 1e-3,
            "{}",
            a.condition_weighted
        );
        // κ(HᵀH) is 1e16; its SVD in double can only say it is enormous.
        assert!(a.condition_normal > 1e13, "{}", a.condition_normal);
        assert_eq!(a.rank, 5);
        let (dq, dn) = (digits(&a.x), digits(&b.x));
        assert!(
            dq >= dn + 6.0,
            "seed {seed}: QR {dq:.1} digits, normal equations {dn:.1}"
        );
        assert!(dq >= 6.5, "seed {seed}: QR only {dq:.1} digits");
    }
}

#[test]
fn covariance_is_the_inverse_normal_matrix_and_scales_by_residual_variance() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let h = well_conditioned(&mut rng, 7, 3);
    let z = DVector::from_fn(7, |_, _| rng.random_range(-1.0..1.0));
    let v = DVector::from_fn(7, |_, _| rng.random_range(0.5..3.0));
    let w = Weights::Diagonal(v.clone());
    let s = solve(&h, &z, &w, &qr()).expect("well posed");
    // The test may invert: it is the independent reference.
    let n = h.transpose() * DMatrix::from_diagonal(&v) * &h;
    let reference = n.clone().try_inverse().expect("SPD");
    assert!((&s.covariance - &reference).norm() <= 1e-12 * reference.norm());
    assert!((&s.covariance - s.covariance.transpose()).norm() <= 0.0 + 1e-15 * reference.norm());
    // Residuals and the residual variance.
    assert!((&s.residuals - (&z - &h * &s.x)).norm() < 1e-14);
    let chi2: f64 = s
        .residuals
        .iter()
        .zip(v.iter())
        .map(|(r, w)| w * r * r)
        .sum();
    let s2 = s.residual_variance.expect("7 rows, 3 unknowns");
    assert!((s2 - chi2 / 4.0).abs() <= 1e-12 * s2);
    let scaled = solve(
        &h,
        &z,
        &w,
        &SolveOptions {
            scale_covariance: true,
            ..qr()
        },
    )
    .expect("ok");
    assert!(scaled.covariance_scaled);
    assert!((&scaled.covariance - &s.covariance * s2).norm() <= 1e-12 * reference.norm() * s2);
    // No degrees of freedom: a typed error.
    let square = well_conditioned(&mut rng, 3, 3);
    let err = solve(
        &square,
        &dvector![1.0, 2.0, 3.0],
        &Weights::Identity,
        &SolveOptions {
            scale_covariance: true,
            ..qr()
        },
    );
    assert_eq!(err, Err(Error::NoDegreesOfFreedom { rows: 3, cols: 3 }));
}

#[test]
fn full_weights_match_the_weighted_normal_equations() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let h = well_conditioned(&mut rng, 6, 3);
    let z = DVector::from_fn(6, |_, _| rng.random_range(-1.0..1.0));
    let b = uniform(&mut rng, 6, 6, -1.0, 1.0);
    let v = &b * b.transpose() + DMatrix::identity(6, 6);
    let s = solve(&h, &z, &Weights::Full(v.clone()), &qr()).expect("SPD V");
    let n = h.transpose() * &v * &h;
    let x_ref = n.cholesky().expect("SPD").solve(&(h.transpose() * &v * &z));
    assert!((&s.x - &x_ref).norm() <= 1e-11 * (1.0 + x_ref.norm()));
    // A diagonal V given as Full equals the Diagonal form.
    let d = DVector::from_fn(6, |_, _| rng.random_range(0.5..2.0));
    let a1 = solve(&h, &z, &Weights::Diagonal(d.clone()), &qr()).expect("ok");
    let a2 = solve(&h, &z, &Weights::Full(DMatrix::from_diagonal(&d)), &qr()).expect("ok");
    assert!((&a1.x - &a2.x).norm() <= 1e-13 * (1.0 + a1.x.norm()));
}

#[test]
fn sensitivity_is_the_weighted_pseudo_inverse() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let h = well_conditioned(&mut rng, 5, 2);
    let v = DVector::from_fn(5, |_, _| rng.random_range(0.2..5.0));
    let s = sensitivity(&h, &Weights::Diagonal(v.clone()), &qr()).expect("ok");
    let V = DMatrix::from_diagonal(&v);
    let reference = (h.transpose() * &V * &h).try_inverse().expect("SPD") * h.transpose() * V;
    assert!((&s - &reference).norm() <= 1e-12 * reference.norm());
    // It maps measurement perturbations to solution perturbations.
    let z = DVector::from_fn(5, |_, _| rng.random_range(-1.0..1.0));
    let x = solve(&h, &z, &Weights::Diagonal(v), &qr()).expect("ok").x;
    assert!((&x - &s * &z).norm() <= 1e-12 * (1.0 + x.norm()));
}

/// λ → 0 recovers the least-squares solution, λ → ∞ the prior; distance to the prior falls
/// monotonically as λ grows.
#[test]
fn tikhonov_tends_to_least_squares_and_to_the_prior() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let h = well_conditioned(&mut rng, 8, 3);
    let z = DVector::from_fn(8, |_, _| rng.random_range(-3.0..3.0));
    let w = Weights::Diagonal(DVector::from_fn(8, |_, _| rng.random_range(0.5..2.0)));
    let xp = dvector![10.0, -4.0, 2.5];
    let ls = solve(&h, &z, &w, &qr()).expect("full rank").x;
    let with = |lambda: f64, op: Option<DMatrix<f64>>| {
        solve(
            &h,
            &z,
            &w,
            &SolveOptions {
                tikhonov: Some(Tikhonov {
                    lambda,
                    prior_mean: Some(xp.clone()),
                    operator: op,
                }),
                ..qr()
            },
        )
        .expect("regularised")
    };
    // Perturbation theory: ‖x(λ) − x_ls‖ ≈ λ‖(HᵀVH)⁻¹‖‖x_p − x_ls‖ ≈ 1e-12·O(10).
    assert!((with(1e-12, None).x - &ls).norm() <= 1e-9);
    // ‖x(λ) − x_p‖ ≈ ‖HᵀV(z − H x_p)‖/λ ≈ O(100)/1e12.
    assert!((with(1e12, None).x - &xp).norm() <= 1e-8);
    let mut last = f64::INFINITY;
    for k in -6..=6 {
        let d = (with(10f64.powi(k), None).x - &xp).norm();
        assert!(d < last, "λ = 1e{k}: {d} ≥ {last}");
        last = d;
    }
    // A general operator L (here 2·I, equivalent to 4λ) and the prior-rows form agree.
    let a = with(0.3, Some(DMatrix::identity(3, 3) * 2.0)).x;
    let b = with(1.2, None).x;
    assert!((&a - &b).norm() <= 1e-12 * (1.0 + a.norm()));
    let prior = solve(
        &h,
        &z,
        &w,
        &SolveOptions {
            prior: Some(PriorRows {
                rows: DMatrix::identity(3, 3),
                values: xp.clone(),
                weights: Weights::Diagonal(DVector::from_element(3, 1.2)),
            }),
            ..qr()
        },
    )
    .expect("ok")
    .x;
    assert!((&prior - &b).norm() <= 1e-12 * (1.0 + b.norm()));
}

/// Rank deficiency is an error without regularisation and solvable with it; rank and
/// tolerance are reported.
#[test]
fn rank_deficiency_needs_regularisation() {
    let h = dmatrix![1.0, 2.0, 3.0; 2.0, 4.0, 6.0; 1.0, 0.0, 1.0; 0.0, 0.0, 0.0];
    let z = dvector![1.0, 2.0, 0.5, 0.0];
    match solve(&h, &z, &Weights::Identity, &qr()) {
        Err(Error::RankDeficient {
            rank,
            cols,
            tolerance,
            ..
        }) => {
            assert_eq!((rank, cols), (2, 3));
            assert!(tolerance > 0.0 && tolerance < 1e-12);
        }
        other => panic!("expected RankDeficient, got {other:?}"),
    }
    let reg = SolveOptions {
        tikhonov: Some(Tikhonov {
            lambda: 1e-3,
            prior_mean: None,
            operator: None,
        }),
        ..qr()
    };
    let s = solve(&h, &z, &Weights::Identity, &reg).expect("regularised");
    assert_eq!(s.rank, 2);
    assert!(s.condition_weighted.is_infinite() || s.condition_weighted > 1e14);
    assert!(s.condition_solved.is_finite());
    // A regulariser that does not fill the null space is still an error.
    let useless = SolveOptions {
        tikhonov: Some(Tikhonov {
            lambda: 1.0,
            prior_mean: None,
            operator: Some(dmatrix![1.0, 2.0, 3.0]),
        }),
        ..qr()
    };
    assert!(matches!(
        solve(&h, &z, &Weights::Identity, &useless),
        Err(Error::RankDeficient {
            name: "regularised system",
            ..
        })
    ));
}

#[test]
fn irls_reaches_a_fixed_point_and_reports_convergence() {
    // Line fit with one gross outlier; Huber-like weights 1/max(1, |r|/k).
    let t: Vec<f64> = (0..10).map(f64::from).collect();
    let h = DMatrix::from_fn(10, 2, |i, j| if j == 0 { 1.0 } else { t[i] });
    let mut z = DVector::from_fn(10, |i, _| 1.0 + 0.5 * t[i]);
    z[7] += 20.0;
    let hc = h.clone();
    let zc = z.clone();
    let huber = move |x: &DVector<f64>| {
        let r = &zc - &hc * x;
        Weights::Diagonal(r.map(|ri| 1.0 / (ri.abs() / 0.1).max(1.0)))
    };
    let ols = solve(&h, &z, &Weights::Identity, &qr()).expect("ok").x;
    let out = solve_irls(
        &h,
        &z,
        &ols,
        huber.clone(),
        &qr(),
        &IrlsOptions {
            tolerance: 1e-10,
            max_iterations: 500,
        },
    )
    .expect("ok");
    assert!(out.converged && out.iterations > 2, "{out:?}");
    let truth = dvector![1.0, 0.5];
    assert!((&out.solution.x - &truth).norm() < 0.1 * (&ols - &truth).norm());
    // Constant weights: the second solve repeats the first.
    let fixed = solve_irls(
        &h,
        &z,
        &DVector::zeros(2),
        |_| Weights::Identity,
        &qr(),
        &IrlsOptions::default(),
    )
    .expect("ok");
    assert!(fixed.converged && fixed.iterations == 2);
    assert!((&fixed.solution.x - &ols).norm() < 1e-12);
    // An iteration cap that is too small is reported, not hidden.
    let capped = solve_irls(
        &h,
        &z,
        &ols,
        huber,
        &qr(),
        &IrlsOptions {
            tolerance: 1e-10,
            max_iterations: 1,
        },
    )
    .expect("ok");
    assert!(!capped.converged && capped.iterations == 1);
}

/// Every invalid input is a typed error naming what is wrong.
#[test]
fn invalid_inputs_are_typed_errors() {
    let h = dmatrix![1.0, 0.0; 0.0, 1.0; 1.0, 1.0];
    let z = dvector![1.0, 2.0, 3.0];
    let o = qr();
    let shape = |r: Result<wls::solver::Solution, Error>| match r {
        Err(Error::Shape { name, .. }) => name,
        other => panic!("expected Shape, got {other:?}"),
    };
    assert_eq!(
        shape(solve(&h, &dvector![1.0, 2.0], &Weights::Identity, &o)),
        "z"
    );
    assert_eq!(
        shape(solve(&h, &z, &Weights::Diagonal(dvector![1.0, 1.0]), &o)),
        "V"
    );
    assert_eq!(
        shape(solve(&h, &z, &Weights::Full(DMatrix::identity(2, 2)), &o)),
        "V"
    );
    assert_eq!(
        shape(solve(
            &DMatrix::zeros(0, 2),
            &DVector::zeros(0),
            &Weights::Identity,
            &o
        )),
        "H"
    );
    let t = |lambda, xp: Option<DVector<f64>>, op: Option<DMatrix<f64>>| SolveOptions {
        tikhonov: Some(Tikhonov {
            lambda,
            prior_mean: xp,
            operator: op,
        }),
        ..qr()
    };
    assert_eq!(
        shape(solve(
            &h,
            &z,
            &Weights::Identity,
            &t(1.0, Some(dvector![1.0]), None)
        )),
        "tikhonov.prior_mean"
    );
    assert_eq!(
        shape(solve(
            &h,
            &z,
            &Weights::Identity,
            &t(1.0, None, Some(DMatrix::identity(3, 3)))
        )),
        "tikhonov.operator"
    );
    assert_eq!(
        solve(&h, &z, &Weights::Diagonal(dvector![1.0, -0.5, 1.0]), &o),
        Err(Error::NegativeWeight {
            name: "V",
            index: 1,
            value: -0.5
        })
    );
    assert!(matches!(
        solve(
            &dmatrix![1.0, 0.0; f64::NAN, 1.0; 1.0, 1.0],
            &z,
            &Weights::Identity,
            &o
        ),
        Err(Error::NonFinite {
            name: "H",
            row: 1,
            col: 0,
            ..
        })
    ));
    assert!(matches!(
        solve(&h, &dvector![1.0, f64::NAN, 3.0], &Weights::Identity, &o),
        Err(Error::NonFinite {
            name: "z",
            row: 1,
            ..
        })
    ));
    assert!(matches!(
        solve(
            &h,
            &z,
            &Weights::Diagonal(dvector![1.0, f64::INFINITY, 1.0]),
            &o
        ),
        Err(Error::NonFinite { name: "V", .. })
    ));
    let asym = dmatrix![2.0, 0.5, 0.0; 0.0, 2.0, 0.0; 0.0, 0.0, 2.0];
    assert!(matches!(
        solve(&h, &z, &Weights::Full(asym), &o),
        Err(Error::NotSymmetric { row: 1, col: 0, .. })
    ));
    let indefinite = dmatrix![1.0, 2.0, 0.0; 2.0, 1.0, 0.0; 0.0, 0.0, 1.0];
    assert_eq!(
        solve(&h, &z, &Weights::Full(indefinite), &o),
        Err(Error::NotPositiveDefinite { name: "V", n: 3 })
    );
    assert!(matches!(
        solve(&h, &z, &Weights::Identity, &t(-1.0, None, None)),
        Err(Error::InvalidParameter {
            name: "tikhonov.lambda",
            ..
        })
    ));
    assert!(matches!(
        solve(
            &h,
            &z,
            &Weights::Identity,
            &SolveOptions {
                rank_tolerance: Some(f64::NAN),
                ..qr()
            }
        ),
        Err(Error::InvalidParameter {
            name: "rank_tolerance",
            ..
        })
    ));
    assert!(matches!(
        worst_case_bounds(&h, &Weights::Identity, &dvector![1.0, -1.0, 1.0], &o),
        Err(Error::InvalidParameter { name: "delta", .. })
    ));
    assert!(matches!(
        worst_case_bounds(&h, &Weights::Identity, &dvector![1.0], &o),
        Err(Error::Shape { name: "delta", .. })
    ));
    let bad_prior = SolveOptions {
        prior: Some(PriorRows {
            rows: DMatrix::identity(2, 2),
            values: dvector![1.0, 2.0],
            weights: Weights::Diagonal(dvector![1.0, -2.0]),
        }),
        ..qr()
    };
    assert!(matches!(
        solve(&h, &z, &Weights::Identity, &bad_prior),
        Err(Error::NegativeWeight {
            name: "prior.weights",
            index: 1,
            ..
        })
    ));
    assert!(matches!(
        solve_irls(
            &h,
            &z,
            &dvector![0.0, 0.0],
            |_| Weights::Identity,
            &o,
            &IrlsOptions {
                tolerance: 0.0,
                max_iterations: 5
            }
        ),
        Err(Error::InvalidParameter {
            name: "irls.tolerance",
            ..
        })
    ));
    // Messages name the offender and the rule.
    let msg = solve(&h, &z, &Weights::Diagonal(dvector![1.0, -0.5, 1.0]), &o)
        .expect_err("negative")
        .to_string();
    assert!(msg.contains("V[1]") && msg.contains("≥ 0"), "{msg}");
}

/// The tolerance policy is relative to the matrix's own scale: one weight matrix written in
/// two units (× 1e6) gets the same symmetry verdict; the asymmetries sit a factor of 50 either
/// side of `SYMMETRY_TOL` (256 ulps, the old absolute-looking rule, would refuse the second).
#[test]
fn weight_checks_do_not_depend_on_units() {
    let h = dmatrix![1.0, 0.0; 0.0, 1.0; 1.0, 1.0];
    let z = dvector![1.0, 2.0, 3.0];
    let o = SolveOptions::default();
    for (skew, ok) in [(5e-9, false), (5e-12, true)] {
        for unit in [1e-4, 1e2] {
            let mut v = dmatrix![1.0, 0.2, 0.0; 0.2, 1.0, 0.0; 0.0, 0.0, 2.0];
            v[(0, 1)] += skew;
            let got = solve(&h, &z, &Weights::Full(v * unit), &o);
            assert_eq!(got.is_ok(), ok, "skew {skew}, unit {unit}: {got:?}");
        }
    }
    assert!((wls::SYMMETRY_TOL - 1e-10).abs() < 1e-25);
}

#[test]
fn ridge_options_solve_the_regularised_normal_equations() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let h = uniform(&mut rng, 12, 4, -1.0, 1.0);
    let z = DVector::from_fn(12, |i, _| (i as f64).sin());
    let lambda = 0.3;
    let sol = solve(&h, &z, &Weights::Identity, &SolveOptions::ridge(lambda)).expect("ridge");
    // Independent: (HᵀH + λI) x = Hᵀz by LU; κ of that matrix is small here (λ = 0.3 with
    // entries of H in [−1, 1]), so 1e-10 relative is far above round-off.
    let normal = h.transpose() * &h + DMatrix::identity(4, 4) * lambda;
    let x = normal
        .lu()
        .solve(&(h.transpose() * &z))
        .expect("nonsingular");
    assert!((&sol.x - &x).norm() < 1e-10 * x.norm());
    assert_eq!(
        SolveOptions::ridge(lambda).tikhonov,
        Some(Tikhonov::ridge(lambda))
    );
    assert!(matches!(
        solve(&h, &z, &Weights::Identity, &SolveOptions::ridge(-1.0)),
        Err(Error::InvalidParameter {
            name: "tikhonov.lambda",
            ..
        })
    ));
}
