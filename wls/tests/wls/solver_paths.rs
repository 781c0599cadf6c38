//! Tests of `wls::solver` paths the main solver tests do not reach: the sensitivity under a
//! full (non-diagonal) weight, the conditioning of an underdetermined or all-zero design
//! that only regularisation makes solvable, and the IRLS stopping rule.

use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wls::Error;
use wls::solver::{
    IrlsOptions, PriorRows, SolveOptions, Tikhonov, Weights, sensitivity, solve, solve_irls,
    worst_case_bounds,
};

fn uniform(rng: &mut ChaCha8Rng, m: usize, n: usize) -> DMatrix<f64> {
    DMatrix::from_fn(m, n, |_, _| rng.random_range(-1.0..1.0))
}

fn tikhonov(lambda: f64) -> SolveOptions {
    SolveOptions {
        tikhonov: Some(Tikhonov {
            lambda,
            prior_mean: None,
            operator: None,
        }),
        ..SolveOptions::default()
    }
}

/// With a full SPD weight V the sensitivity is (HᵀVH + λI)⁻¹HᵀV. The reference solves the
/// normal equations by Cholesky (a route that never forms the whitener W = Lᵀ nor a QR), and
/// the sensitivity must also be the linear map z ↦ x̂ that `solve` applies. With m ≠ n and
/// m = n, with and without regularisation: the square unregularised case has S = H⁻¹ for any
/// V, so it checks the map without V; the others check V's off-diagonal coupling.
/// Tolerance: κ(HᵀVH) ≤ a few hundred for these seeded designs (diagonal boost of 3, V =
/// BBᵀ + I), so both routes agree to ≈ κ·ε·‖S‖; 1e-10 relative leaves a margin of > 100.
#[test]
fn sensitivity_under_a_full_weight_is_the_weighted_pseudo_inverse() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for (m, n, lambda) in [
        (6, 3, None),
        (4, 4, None),
        (5, 2, Some(0.4)),
        (3, 3, Some(2.0)),
    ] {
        let mut h = uniform(&mut rng, m, n);
        for i in 0..n {
            h[(i, i)] += 3.0;
        }
        let b = uniform(&mut rng, m, m);
        let v = &b * b.transpose() + DMatrix::identity(m, m);
        let weights = Weights::Full(v.clone());
        let options = lambda.map_or_else(SolveOptions::default, tikhonov);
        let s = sensitivity(&h, &weights, &options).expect("SPD weight, full rank");
        assert_eq!(s.shape(), (n, m));
        let normal = h.transpose() * &v * &h + DMatrix::identity(n, n) * lambda.unwrap_or(0.0);
        let reference = normal
            .cholesky()
            .expect("SPD normal matrix")
            .solve(&(h.transpose() * &v));
        let tol = 1e-10 * reference.norm();
        assert!(
            (&s - &reference).norm() <= tol,
            "m={m} n={n} λ={lambda:?}: {s} vs {reference}"
        );
        // S·z is the estimate itself (zero prior mean makes the map linear, not affine).
        let z = DVector::from_fn(m, |_, _| rng.random_range(-2.0..2.0));
        let x = solve(&h, &z, &weights, &options).expect("ok").x;
        assert!((&x - &s * &z).norm() <= 1e-10 * (1.0 + x.norm()));
        // Worst-case bounds are |S|·Δ through the same map.
        let delta = DVector::from_fn(m, |_, _| rng.random_range(0.0..1.0));
        let bound = worst_case_bounds(&h, &weights, &delta, &options).expect("ok");
        let expected = reference.abs() * &delta;
        assert!((&bound - &expected).norm() <= 1e-10 * (1.0 + expected.norm()));
    }
}

/// An underdetermined design (m < n) has fewer singular values than columns, so W·H has
/// rank ≤ m < n and κ₂(W·H) = ∞; only the Tikhonov rows make the solve possible, and the
/// solved system's κ is finite. The solution is the ridge estimate Hᵀ(HHᵀ + λI)⁻¹z (the
/// push-through identity, an independent route from the (HᵀH + λI)⁻¹Hᵀz the solver uses).
#[test]
fn underdetermined_designs_report_infinite_weighted_conditioning() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for (m, n) in [(1, 2), (2, 4), (3, 5)] {
        let h = uniform(&mut rng, m, n);
        let z = DVector::from_fn(m, |_, _| rng.random_range(-2.0..2.0));
        let lambda = 0.5;
        let s = solve(&h, &z, &Weights::Identity, &tikhonov(lambda)).expect("regularised");
        assert_eq!(s.singular_values.len(), m);
        assert_eq!(s.rank, m, "a random {m}×{n} design has full row rank");
        assert!(
            s.condition_weighted.is_infinite(),
            "{}",
            s.condition_weighted
        );
        assert!(s.condition_solved.is_finite());
        let gram = &h * h.transpose() + DMatrix::identity(m, m) * lambda;
        let x_ref = h.transpose() * gram.cholesky().expect("SPD").solve(&z);
        assert!((&s.x - &x_ref).norm() <= 1e-12 * (1.0 + x_ref.norm()));
    }
}

/// An all-zero design has only zero singular values: its κ₂ is ∞ (not 0/0 = NaN), and the
/// solve is the prior mean, the only information there is. κ(HᵀH) is ∞ for the same reason.
#[test]
fn an_all_zero_design_has_infinite_conditioning() {
    let h = DMatrix::zeros(3, 2);
    let z = DVector::from_vec(vec![1.0, -2.0, 0.5]);
    let xp = DVector::from_vec(vec![0.25, -4.0]);
    let options = SolveOptions {
        tikhonov: Some(Tikhonov {
            lambda: 3.0,
            prior_mean: Some(xp.clone()),
            operator: None,
        }),
        ..SolveOptions::default()
    };
    let s = solve(&h, &z, &Weights::Identity, &options).expect("regularised");
    assert_eq!(s.rank, 0);
    assert!(
        s.condition_weighted.is_infinite(),
        "{}",
        s.condition_weighted
    );
    assert!(s.condition_normal.is_infinite(), "{}", s.condition_normal);
    // The solved system is √λ·I stacked under zeros: κ = 1, up to the SVD's rounding.
    assert!((s.condition_solved - 1.0).abs() <= 1e-12);
    assert!((&s.x - &xp).norm() <= 1e-12 * xp.norm());
    // Without regularisation, or with λ = 0 (rows of zeros), nothing pins x down: rank 0.
    // The default tolerance is 0 here (σ_max = 0), so "rank" must count σ > tol, not ≥.
    let rank_deficient = |options: &SolveOptions| match solve(&h, &z, &Weights::Identity, options) {
        Err(Error::RankDeficient {
            name, rank, cols, ..
        }) => (name, rank, cols),
        other => panic!("expected RankDeficient, got {other:?}"),
    };
    assert_eq!(
        rank_deficient(&SolveOptions::default()),
        ("V^(1/2) H", 0, 2)
    );
    assert_eq!(rank_deficient(&tikhonov(0.0)), ("regularised system", 0, 2));
}

/// The IRLS stopping rule is ‖x_{k+1} − x_k‖ ≤ tol·(1 + ‖x_{k+1}‖). A weight law that makes
/// the iteration an exact contraction, x_{k+1} = a + ρ(x_k − a), gives steps ρᵏ·|a| (from
/// x₀ = 0), so the iteration count is known in closed form: the first k with
/// ρᵏ·|a| ≤ tol·(1 + |a|(1 − ρᵏ)). H = [1; 1], z = [0; 2] and weights (1, t/(2 − t)) make
/// the weighted mean exactly t. With tol = 1e-6 the steps stay ten orders above rounding, and
/// the rule holds with a margin of ≥ 4 % at the boundary k (checked below), so an iteration
/// count off by one means a different rule (absolute, or relative to 1/(1 + ‖x‖)).
#[test]
fn irls_stops_where_the_relative_step_rule_says() {
    let h = DMatrix::from_element(2, 1, 1.0);
    let z = DVector::from_vec(vec![0.0, 2.0]);
    let (a, rho, tol) = (1.0_f64, 0.5_f64, 1e-6);
    let contraction = |x: &DVector<f64>| {
        let t = a + rho * (x[0] - a);
        Weights::Diagonal(DVector::from_vec(vec![1.0, t / (2.0 - t)]))
    };
    let irls = IrlsOptions {
        tolerance: tol,
        max_iterations: 200,
    };
    let start = DVector::zeros(1);
    let out = solve_irls(&h, &z, &start, contraction, &SolveOptions::default(), &irls)
        .expect("positive weights");
    let rule = |k: i32| {
        let step = rho.powi(k) * a.abs();
        step / (tol * (1.0 + a.abs() * (1.0 - rho.powi(k))))
    };
    let expected = (1..200).find(|&k| rule(k) <= 1.0).expect("contracts");
    assert!(rule(expected) <= 0.96 && rule(expected - 1) >= 1.04);
    assert!(out.converged, "{out:?}");
    assert_eq!(out.iterations, expected as usize);
    assert!((out.solution.x[0] - a).abs() <= 2.0 * tol);
}

/// The rank tolerance. By default it is max(m, n)·ε·σ_max, relative to the largest singular
/// value, so the rank of diag(s, s·1e-17) is 1 whatever the unit s is (1e-17 is far below
/// 2ε ≈ 4.4e-16 and far above the rounding of the SVD of a diagonal matrix, which is exact).
/// A given tolerance is used as it is (0 counts every non-zero σ; 1 cuts σ = 0.5 here), and
/// a negative or non-finite one is refused by name. Ridge rows (λ = 4, so every augmented σ
/// is ≥ 2) keep the rank-deficient cases solvable, so the rank is reported, not refused.
#[test]
fn the_rank_tolerance_is_relative_by_default_and_absolute_when_given() {
    let ridge = |rank_tolerance| SolveOptions {
        rank_tolerance,
        ..SolveOptions::ridge(4.0)
    };
    let z = DVector::from_vec(vec![1.0, 1.0]);
    for s in [1e-10, 1.0, 1e10] {
        let h = DMatrix::from_diagonal(&DVector::from_vec(vec![s, s * 1e-17]));
        let sol = solve(&h, &z, &Weights::Identity, &ridge(None)).expect("ridge makes it solvable");
        assert_eq!(sol.rank, 1, "unit {s}");
        let expected = 2.0 * f64::EPSILON * s;
        assert!(
            (sol.rank_tolerance - expected).abs() <= 1e-12 * expected,
            "unit {s}"
        );
        let all =
            solve(&h, &z, &Weights::Identity, &ridge(Some(0.0))).expect("tolerance 0 is valid");
        assert_eq!(all.rank, 2, "unit {s}");
        assert!(all.rank_tolerance.abs() <= 0.0);
    }
    let h = DMatrix::from_diagonal(&DVector::from_vec(vec![3.0, 0.5]));
    let cut = solve(&h, &z, &Weights::Identity, &ridge(Some(1.0))).expect("tolerance 1 is valid");
    assert_eq!(cut.rank, 1);
    assert!((cut.rank_tolerance - 1.0).abs() <= 0.0);
    for bad in [-1.0, -f64::MIN_POSITIVE, f64::NAN, f64::INFINITY] {
        let err =
            solve(&h, &z, &Weights::Identity, &ridge(Some(bad))).expect_err("invalid tolerance");
        assert!(
            matches!(
                err,
                Error::InvalidParameter {
                    name: "rank_tolerance",
                    ..
                }
            ),
            "{bad}: {err:?}"
        );
    }
}

/// The regularised system's default rank tolerance is relative too: a ridge that penalises
/// only the first unknown leaves H = diag(s, s·1e-17) rank-deficient in the second whatever
/// the unit s, and that is refused by name (3 rows: tolerance 3·ε·σ_max ≫ 1e-17·σ_max).
#[test]
fn a_regularisation_that_misses_an_unknown_is_rank_deficient_in_any_unit() {
    let z = DVector::from_vec(vec![1.0, 1.0]);
    let options = SolveOptions {
        tikhonov: Some(Tikhonov {
            lambda: 1.0,
            prior_mean: None,
            operator: Some(DMatrix::from_row_slice(1, 2, &[1.0, 0.0])),
        }),
        ..SolveOptions::default()
    };
    for s in [1e-10, 1.0, 1e10] {
        let h = DMatrix::from_diagonal(&DVector::from_vec(vec![s, s * 1e-17]));
        let err = solve(&h, &z, &Weights::Identity, &options).expect_err("deficient");
        assert!(
            matches!(
                err,
                Error::RankDeficient {
                    name: "regularised system",
                    rank: 1,
                    cols: 2,
                    ..
                }
            ),
            "unit {s}: {err:?}"
        );
    }
}

/// Prior rows must have one column per unknown and at least one row; either mistake is a
/// shape error naming them.
#[test]
fn prior_rows_of_the_wrong_shape_are_named() {
    let h = DMatrix::identity(3, 2);
    let z = DVector::from_vec(vec![1.0, 2.0, 3.0]);
    for (k, cols) in [(1, 3), (2, 1), (0, 2)] {
        let options = SolveOptions {
            prior: Some(PriorRows {
                rows: DMatrix::from_element(k, cols, 1.0),
                values: DVector::zeros(k),
                weights: Weights::Identity,
            }),
            ..SolveOptions::default()
        };
        let err = solve(&h, &z, &Weights::Identity, &options).expect_err("bad prior shape");
        assert!(
            matches!(err, Error::Shape { name: "prior.rows", rows, cols: c, .. } if rows == k && c == cols),
            "{k}×{cols}: {err:?}"
        );
    }
}

/// A zero error bound is a valid bound (an exact measurement): it contributes nothing, so
/// the bounds equal those of the remaining measurements alone.
#[test]
fn a_zero_error_bound_is_valid_and_contributes_nothing() {
    let h = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 1.0, 1.0, 0.0, 2.0]);
    let options = SolveOptions::default();
    let with_zero = worst_case_bounds(
        &h,
        &Weights::Identity,
        &DVector::from_vec(vec![0.0, 0.1, 0.2]),
        &options,
    )
    .expect("zero is a valid bound");
    let s = sensitivity(&h, &Weights::Identity, &options).expect("full rank");
    for i in 0..2 {
        let expected = 0.1 * s[(i, 1)].abs() + 0.2 * s[(i, 2)].abs();
        // A sum of two products: rounding of a few ε.
        assert!(
            (with_zero[i] - expected).abs() <= 1e-15,
            "{i}: {} vs {expected}",
            with_zero[i]
        );
    }
    assert!(with_zero.iter().all(|b| *b > 0.0));
}
