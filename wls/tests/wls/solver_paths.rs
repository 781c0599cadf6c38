//! Tests of `wls::solver` paths the main solver tests do not reach: the sensitivity under a
//! full (non-diagonal) weight, the conditioning of an underdetermined or all-zero design
//! that only regularisation makes solvable, and the units-free IRLS stopping rule.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use wls::Error;
use wls::solver::{
    IrlsOptions, SolveOptions, Tikhonov, Weights, sensitivity, solve, solve_irls, worst_case_bounds,
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

/// The IRLS stopping rule ‖x_{k+1} − x_k‖ ≤ tol·(1 + ‖x_{k+1}‖) is relative once ‖x‖ ≫ 1, so
/// the verdict cannot depend on the units. The same robust line fit in two units 2²⁰ apart
/// (a power of two: every iterate scales exactly, Huber threshold included) must converge
/// after the same number of iterations.
#[test]
fn irls_convergence_does_not_depend_on_the_units() {
    let t: Vec<f64> = (0..10).map(f64::from).collect();
    let h = DMatrix::from_fn(10, 2, |i, j| if j == 0 { 1.0 } else { t[i] });
    let run = |scale: f64| {
        let mut z = DVector::from_fn(10, |i, _| (1.0 + 0.5 * t[i]) * scale);
        z[7] += 20.0 * scale;
        let (hc, zc) = (h.clone(), z.clone());
        let huber = move |x: &DVector<f64>| {
            let r = &zc - &hc * x;
            Weights::Diagonal(r.map(|ri| 1.0 / (ri.abs() / (0.1 * scale)).max(1.0)))
        };
        let irls = IrlsOptions {
            tolerance: 1e-10,
            max_iterations: 500,
        };
        let start = DVector::zeros(2);
        solve_irls(&h, &z, &start, huber, &SolveOptions::default(), &irls).expect("ok")
    };
    let (small, large) = (run(2f64.powi(20)), run(2f64.powi(40)));
    assert!(small.converged && large.converged, "{small:?}\n{large:?}");
    assert_eq!(small.iterations, large.iterations);
    assert!(
        (&large.solution.x / 2f64.powi(20) - &small.solution.x).norm()
            <= 1e-9 * small.solution.x.norm()
    );
}
