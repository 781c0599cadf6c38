//! Unit tests of the Riccati solvers against closed forms.
#![allow(non_snake_case)]

use super::*;
use faer::mat;

#[test]
fn scalar_dare_closed_form() {
    // p = f²p r/(p + r) + q with f = 0.9, q = 0.5, r = 2: quadratic p² + (r(1 − f²) − q)p − qr = 0.
    let (f, q, r) = (0.9_f64, 0.5, 2.0);
    let b = r * (1.0 - f * f) - q;
    let p = (-b + (b * b + 4.0 * q * r).sqrt()) / 2.0;
    let ss = Dare::new(mat![[f]], mat![[1.0]], mat![[q]], mat![[r]])
        .and_then(|p| p.solve())
        .expect("must succeed");
    // Tolerance: a few ulps of p ≈ 1 after ~10 doubling steps.
    assert!(
        (ss.prior[(0, 0)] - p).abs() < 1e-13,
        "{} vs {p}",
        ss.prior[(0, 0)]
    );
    assert!((ss.gain[(0, 0)] - p / (p + r)).abs() < 1e-13);
    assert!((ss.posterior[(0, 0)] - p * r / (p + r)).abs() < 1e-13);
}

#[test]
fn zero_noise_stable_gives_zero() {
    let ss = Dare::new(mat![[0.5]], mat![[1.0]], mat![[0.0]], mat![[1.0]])
        .and_then(|p| p.solve())
        .expect("must succeed");
    assert!(ss.prior[(0, 0)].abs() < 1e-300);
}

#[test]
fn undetectable_and_unstabilisable_are_typed() {
    let F = mat![[1.2, 0.0], [0.0, 0.5]];
    let H = mat![[0.0, 1.0]];
    let Q = mat![[1.0, 0.0], [0.0, 1.0]];
    let R = mat![[1.0]];
    let e = Dare::new(&F, &H, &Q, &R)
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(
        matches!(e, Error::NotDetectable { pair: "(F, H)", .. }),
        "{e}"
    );
    // A mode on the unit circle that the noise does not reach has no stabilising
    // solution: refused.
    let F1 = mat![[1.0, 0.0], [0.0, 0.5]];
    let H = mat![[1.0, 1.0]];
    let Q = mat![[0.0, 0.0], [0.0, 1.0]];
    let e = Dare::new(&F1, &H, &Q, &R)
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(
        matches!(e, Error::NotStabilisable { re, im, .. } if (re - 1.0).abs() < 1e-12 && im == 0.0),
        "{e}"
    );
    // The same on the circle at an angle: a rotation without noise.
    let (c, s) = (0.6_f64.cos(), 0.6_f64.sin());
    let e = Dare::new(
        mat![[c, -s], [s, c]],
        mat![[1.0, 0.0]],
        Mat::<f64>::zeros(2, 2).as_ref(),
        &R,
    )
    .and_then(|p| p.solve())
    .expect_err("must be an error");
    assert!(
        matches!(e, Error::NotStabilisable { im, .. } if im > 0.5),
        "{e}"
    );
    // Complex unstable pair, unobservable.
    let c = 1.1 * 0.6_f64.cos();
    let s = 1.1 * 0.6_f64.sin();
    let F = mat![[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 0.3]];
    let H = mat![[0.0, 0.0, 1.0]];
    let Q = Mat::<f64>::identity(3, 3);
    let e = Dare::new(&F, &H, &Q, &R)
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(
        matches!(e, Error::NotDetectable { im, .. } if im > 0.5),
        "{e}"
    );
}

#[test]
fn unreached_unstable_modes_off_the_circle_have_a_stabilising_solution() {
    // F = 2, Q = 0, H = R = 1: p = 4p − 4p²/(p + 1) ⇔ p² − 3p = 0. The root p = 0 leaves
    // the closed loop at 2; p = 3 gives K_p = F p/(p + 1) = 1.5, closed loop
    // 2 − 1.5 = 0.5: the stabilising solution, posterior p − p²/(p + 1) = 0.75.
    let ss = Dare::new(mat![[2.0]], mat![[1.0]], mat![[0.0]], mat![[1.0]])
        .and_then(|p| p.solve())
        .expect("stabilising solution exists");
    // 1e-12: a few Newton steps from a 1e-8 perturbation, quadratic convergence.
    assert!(
        (ss.prior[(0, 0)] - 3.0).abs() < 1e-12,
        "{}",
        ss.prior[(0, 0)]
    );
    assert!((ss.posterior[(0, 0)] - 0.75).abs() < 1e-12);
    assert!((ss.predictor_gain[(0, 0)] - 1.5).abs() < 1e-12);
    // Two states: the unreached mode 1.2 is seen through H and stabilised by the gain.
    let F = mat![[1.2, 0.0], [0.0, 0.5]];
    let H = mat![[1.0, 1.0]];
    let Q = mat![[0.0, 0.0], [0.0, 1.0]];
    let R = mat![[1.0]];
    let ss = Dare::new(&F, &H, &Q, &R)
        .and_then(|p| p.solve())
        .expect("stabilising solution exists");
    let cl = &F - &ss.predictor_gain * &H;
    assert!(spectral(cl.as_ref(), false) < 1.0);
    // Independent check: the residual of the DARE itself.
    let res = Dare::new(&F, &H, &Q, &R).and_then(|d| d.residual(&ss.prior));
    assert!(res.expect("valid shapes") < 1e-12);
}

#[test]
fn scalar_care_and_clqr() {
    let ss = Care::new(mat![[-1.0]], mat![[1.0]], mat![[1.0]], mat![[1.0]])
        .and_then(|p| p.solve())
        .expect("must succeed");
    assert!((ss.covariance[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-13);
    // Unstable a = 2, b = 1, q = r = 1: 4X − X² + 1 = 0, X = 2 + √5, L = X.
    let l = Clqr::new(mat![[2.0]], mat![[1.0]], mat![[1.0]], mat![[1.0]])
        .and_then(|p| p.solve())
        .expect("must succeed");
    assert!((l.gain[(0, 0)] - (2.0 + 5f64.sqrt())).abs() < 1e-12);
}

#[test]
fn shape_and_pd_errors_name_the_matrix() {
    let e = Dare::new(mat![[1.0]], mat![[1.0, 0.0]], mat![[1.0]], mat![[1.0]])
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(matches!(e, Error::Shape { name: "H", .. }), "{e}");
    // R = 0 is an exact channel: z = x, so the posterior is exact and the prior is Q = 1.
    let ss = Dare::new(mat![[1.0]], mat![[1.0]], mat![[1.0]], mat![[0.0]])
        .and_then(|p| p.solve())
        .expect("H P Hᵀ + R = P > 0 at the solution");
    assert!((ss.prior[(0, 0)] - 1.0).abs() < 1e-15 && ss.posterior[(0, 0)].abs() < 1e-15);
    // With Q = 0 too no noise reaches the channel: H P Hᵀ + R is singular at every P the
    // equation can reach, and the error names it.
    let e = Dare::new(mat![[0.5]], mat![[1.0]], mat![[0.0]], mat![[0.0]])
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(
        matches!(
            e,
            Error::NotPositiveDefinite {
                name: "H P H^T + R",
                ..
            }
        ),
        "{e}"
    );
    // The CARE needs R⁻¹ itself.
    let e = Care::new(mat![[-1.0]], mat![[1.0]], mat![[1.0]], mat![[0.0]])
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(
        matches!(e, Error::NotPositiveDefinite { name: "R", .. }),
        "{e}"
    );
    let e = Dare::new(mat![[f64::NAN]], mat![[1.0]], mat![[1.0]], mat![[1.0]])
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(matches!(e, Error::NonFinite { name: "F", .. }), "{e}");
}

#[test]
fn lqr_residual_measures_a_candidate() {
    // A = B = Q = R = 1: the control DARE is X = 1 + X − X²/(1 + X), so X² = X + 1 and
    // X = (1 + √5)/2; the candidate X = 1 leaves |1 + 1 − 1/2 − 1| / 1 = 1/2 exactly.
    let lqr = Dlqr::new([[1.0]], [[1.0]], [[1.0]], [[1.0]]).expect("inputs");
    let golden = (1.0 + 5f64.sqrt()) / 2.0;
    assert!(lqr.residual([[golden]]).expect("residual") < 1e-15);
    let off = lqr.residual([[1.0]]).expect("residual");
    assert!((off - 0.5).abs() < 1e-15, "{off}");
}

#[test]
fn lqr_cross_weight_enters_the_equation() {
    // A = B = Q = R = 1 and N = 1/2: X = X + 1 − (X + 1/2)²/(1 + X), so X² = 3/4 (against
    // the golden ratio without N).
    let x = Dlqr::new([[1.0]], [[1.0]], [[1.0]], [[1.0]])
        .and_then(|d| d.cross_weight([[0.5]]))
        .and_then(|d| d.solve())
        .expect("solve")
        .cost[(0, 0)];
    assert!((x - 0.75f64.sqrt()).abs() < 1e-12, "{x}");
}

#[test]
fn hamiltonian_norm_is_the_norm_of_the_assembled_matrix() {
    // γ must exceed ρ(ℋ) for the Cayley transform to send the stable eigenvalues inside the
    // unit circle; the solver takes γ from ‖ℋ‖_F computed blockwise, so the blockwise sum
    // must equal the norm of ℋ = [[A_c, −G], [−Q, −A_cᵀ]] built out in full.
    let Ac = mat![[0.3, -1.2], [2.5, -0.7]];
    let G = mat![[2.0, 0.4], [0.4, 0.9]];
    let Q = mat![[0.5, -0.1], [-0.1, 3.0]];
    let Hm = Mat::<f64>::from_fn(4, 4, |i, j| match (i < 2, j < 2) {
        (true, true) => Ac[(i, j)],
        (true, false) => -G[(i, j - 2)],
        (false, true) => -Q[(i - 2, j)],
        (false, false) => -Ac[(j - 2, i - 2)],
    });
    let blockwise = care::hamiltonian_norm(&Ac, &G, &Q);
    assert!(
        (blockwise - Hm.norm_l2()).abs() < 1e-14 * Hm.norm_l2(),
        "{blockwise}"
    );
}

#[test]
fn care_and_clqr_residuals_measure_a_candidate() {
    // ẋ = −x + w, z = x + v, q = r = 1: the residual of P is |−2P − P² + 1| / P; zero at
    // P = √2 − 1, exactly 2 at P = 1 (|−2 − 1 + 1| / 1).
    let care = Care::new([[-1.0]], [[1.0]], [[1.0]], [[1.0]]).expect("inputs");
    assert!(care.residual([[2f64.sqrt() - 1.0]]).expect("residual") < 1e-15);
    let off = care.residual([[1.0]]).expect("residual");
    assert!((off - 2.0).abs() < 1e-15, "{off}");
    // Its dual, the LQR with A = −1, B = Q = R = 1, has the same equation in X.
    let clqr = Clqr::new([[-1.0]], [[1.0]], [[1.0]], [[1.0]]).expect("inputs");
    let off = clqr.residual([[1.0]]).expect("residual");
    assert!((off - 2.0).abs() < 1e-15, "{off}");
}

#[test]
fn symmetrise_averages_the_off_diagonal_pairs_and_leaves_the_diagonal() {
    // Diagonal entries near f64::MAX must stay as they are (adding one to itself would
    // overflow); each off-diagonal pair becomes its mean, exactly for these binary fractions.
    let mut M = mat![[1e308, 1.0, 0.25], [3.0, -1e308, 0.5], [0.75, 1.5, 2.0]];
    symmetrise(&mut M);
    let expected = mat![[1e308, 2.0, 0.5], [2.0, -1e308, 1.0], [0.5, 1.0, 2.0]];
    assert_eq!(M, expected);
    // The relative residual of a zero residual is 0 even over a zero solution, and a
    // non-zero residual over a zero solution is infinitely large.
    assert!(relative(0.0, 0.0).abs() <= 0.0);
    assert!(relative(1e-3, 0.0).is_infinite() && relative(1e-3, 0.0) > 0.0);
    assert!((relative(1.0, 4.0) - 0.25).abs() <= 0.0);
}

#[test]
fn a_care_scaled_towards_underflow_keeps_its_solution() {
    // Scaling A, HᵀR⁻¹H and Q by s scales the whole equation, not its solution: the scalar
    // case a = −s, g = s, q = s keeps p = √2 − 1 down to s = 1e-155, where ‖ℋ‖_F ≈ 2s is
    // below the Cayley shift's floor √(f64::MIN_POSITIVE) ≈ 1.5e-154, so that floor decides
    // the shift's sign. (Products of order s² are subnormal there: 1e-10 relative.)
    for s in [1.0, 1e-100, 1e-155] {
        let ss = Care::new(mat![[-s]], mat![[1.0]], mat![[s]], mat![[1.0 / s]])
            .and_then(|p| p.solve())
            .expect("must succeed");
        assert!(
            (ss.covariance[(0, 0)] - (2f64.sqrt() - 1.0)).abs() < 1e-10,
            "s = {s}: {:?}",
            ss.covariance
        );
    }
}

#[test]
fn pbh_embeds_a_complex_mode_and_scales_its_tolerance_with_f() {
    let opts = RiccatiOptions::default();
    // A rotation by θ has the unit-circle pair cos θ ± i sin θ: unobservable from C = 0,
    // observable from either coordinate. The complex mode's real embedding must put Im M in
    // its own block for both columns (n = 2).
    let (c, s) = (0.6_f64, 0.8_f64);
    let F = mat![[c, -s], [s, c]];
    let unseen = checks::pbh(F.as_ref(), mat![[0.0, 0.0]].as_ref(), &[(c, s)], &opts).expect("svd");
    assert_eq!(unseen, Some((c, s)));
    for C in [mat![[1.0, 0.0]], mat![[0.0, 1.0]]] {
        let seen = checks::pbh(F.as_ref(), C.as_ref(), &[(c, s)], &opts).expect("svd");
        assert_eq!(seen, None, "{C:?}");
    }
    // With a third, stable state the embedding has more than one column per block to place
    // Im M in: the pair is unobservable from that state alone and seen from either of its own.
    let F3 = mat![[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 0.5]];
    for (C, flagged) in [
        (mat![[0.0, 0.0, 1.0]], true),
        (mat![[1.0, 0.0, 0.0]], false),
        (mat![[0.0, 1.0, 1.0]], false),
    ] {
        let verdict = checks::pbh(F3.as_ref(), C.as_ref(), &[(c, s)], &opts).expect("svd");
        assert_eq!(verdict.is_some(), flagged, "{C:?}");
    }
    // The pair in the last two states: no complex multiple of its eigenvector (0, 1, ∓i) has
    // a real part confined to the first state, so every column of the embedding's Im M block
    // takes part in the null vector.
    let F3 = mat![[0.5, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]];
    for (C, flagged) in [
        (mat![[1.0, 0.0, 0.0]], true),
        (mat![[0.0, 0.0, 1.0]], false),
    ] {
        let verdict = checks::pbh(F3.as_ref(), C.as_ref(), &[(c, s)], &opts).expect("svd");
        assert_eq!(verdict.is_some(), flagged, "{C:?}");
    }
    // The tolerance is relative to max(1, ‖F‖): with ‖F‖_F ≈ 100 the mode λ = 1 of
    // [[1, 100], [0, 0.5]] (eigenvector e₁) seen from C at an angle φ to its null direction
    // has σ_min ≈ 0.7·100·φ (C is scaled to ‖F‖), so φ = 1e-9 is below 1e-7·‖F‖ (flagged)
    // but would not be below 1e-7/‖F‖, and φ = 1e-4 is clearly seen.
    let F = mat![[1.0, 100.0], [0.0, 0.5]];
    for (phi, flagged) in [(1e-9_f64, true), (1e-4, false)] {
        let C = mat![[phi.sin(), phi.cos()]];
        let verdict = checks::pbh(F.as_ref(), C.as_ref(), &[(1.0, 0.0)], &opts).expect("svd");
        assert_eq!(verdict.is_some(), flagged, "φ = {phi}");
    }
}

#[test]
fn the_last_check_wants_a_closed_loop_strictly_inside() {
    // Stable means ρ < 1 (discrete) and max Re λ < 0 (continuous): a closed loop on the
    // boundary is refused, one just inside accepted, a NaN refused.
    let opts = RiccatiOptions::default();
    let solved = || problem::Solved {
        x: Mat::<f64>::identity(1, 1),
        iterations: 1,
        relative_residual: 0.0,
        floor: f64::EPSILON,
    };
    for (time, boundary, inside) in [
        (problem::Time::Discrete, 1.0, 1.0 - 1e-12),
        (problem::Time::Continuous, 0.0, -1e-12),
    ] {
        assert!(
            solved().checked(boundary, time, &opts, "test").is_err(),
            "{time:?}"
        );
        assert!(
            solved().checked(f64::NAN, time, &opts, "test").is_err(),
            "{time:?}"
        );
        assert!(
            solved().checked(inside, time, &opts, "test").is_ok(),
            "{time:?}"
        );
    }
}

/// The filter-form DARE of scalar or small (F, H, Q, R, S) as the solvers take it.
fn form<'a>(
    F: &'a Mat<f64>,
    H: &'a Mat<f64>,
    Q: &'a Mat<f64>,
    R: &'a Mat<f64>,
    S: Option<&'a Mat<f64>>,
) -> problem::FilterForm<'a> {
    problem::FilterForm {
        F: F.as_ref(),
        H: H.as_ref(),
        Q: Q.as_ref(),
        R: R.as_ref(),
        S: S.map(Mat::as_ref),
    }
}

fn filter_names() -> problem::Names {
    problem::Names {
        equation: "filter DARE",
        detect: Pair::Detect("(F, H)"),
        stab: Pair::Stab("(F, Q^{1/2})"),
    }
}

/// The root p > 0 of the scalar DARE p = f²p r/(p + r) + q (h = 1).
fn scalar_dare(f: f64, q: f64, r: f64) -> f64 {
    let b = r * (1.0 - f * f) - q;
    (-b + (b * b + 4.0 * q * r).sqrt()) / 2.0
}

#[test]
fn the_doubling_alone_solves_a_well_conditioned_dare_with_cross_covariance() {
    // f = 0.8, q = 1, r = 1, s = 0.6: w − (s/r)v is uncorrelated with v, so the DARE is that
    // of f̃ = f − s h/r = 0.2 and q̃ = q − s²/r = 0.64 without a cross term.
    let (F, H, Q, R, S) = (
        mat![[0.8]],
        mat![[1.0]],
        mat![[1.0]],
        mat![[1.0]],
        mat![[0.6]],
    );
    let p = scalar_dare(0.2, 0.64, 1.0);
    let start = dare::doubling_start(
        &form(&F, &H, &Q, &R, Some(&S)),
        &RiccatiOptions::default(),
        &filter_names(),
    )
    .expect("well posed");
    // The doubling converges quadratically to its stopping tolerance of 1e-14 relative:
    // no Newton step is needed here, so its answer alone must be that accurate.
    assert!(
        (start.X[(0, 0)] - p).abs() < 1e-13 * p,
        "{} vs {p}",
        start.X[(0, 0)]
    );
    assert!((start.Ft[(0, 0)] - 0.2).abs() < 1e-15);
    let ss = Dare::new(&F, &H, &Q, &R)
        .and_then(|d| d.cross_covariance(&S))
        .and_then(|d| d.solve())
        .expect("well posed");
    assert!((ss.prior[(0, 0)] - p).abs() < 1e-13 * p);
}

#[test]
fn the_doubling_start_of_an_unreached_unstable_mode_is_close_in_any_unit() {
    // F = 2, Q = 0, H = 1, R = r: P = 3r (see the test above with r = 1). The doubling from
    // Q̃ = 0 would give the non-stabilising P = 0, so it starts from Q̃ + δI with δ = 1e-8 r
    // (relative to (Hᵀ R⁻¹ H)⁻¹ = r), which lies within O(δ) of 3r in any unit.
    for r in [1e-20, 1.0, 1e20] {
        let (F, H, Q, R) = (mat![[2.0]], mat![[1.0]], mat![[0.0]], mat![[r]]);
        let start = dare::doubling_start(
            &form(&F, &H, &Q, &R, None),
            &RiccatiOptions::default(),
            &filter_names(),
        )
        .expect("a stabilising solution exists");
        let rel = (start.X[(0, 0)] - 3.0 * r).abs() / (3.0 * r);
        // δ/P = 1e-8/3 moves P by about that much (∂P/∂q = 1/(1 − a_cl²) = 4/3 here), and
        // upwards: the DARE's solution grows with Q, so the start lies above the solution, the
        // side from which Newton's iterates decrease onto it.
        assert!(
            start.X[(0, 0)] > 3.0 * r,
            "r = {r:e}: start below the solution"
        );
        assert!(
            rel < 1e-7,
            "r = {r:e}: start {:e}, relative error {rel:e}",
            start.X[(0, 0)]
        );
        let ss = Dare::new(&F, &H, &Q, &R)
            .and_then(|d| d.solve())
            .expect("solve");
        assert!(
            (ss.prior[(0, 0)] - 3.0 * r).abs() < 1e-12 * 3.0 * r,
            "r = {r:e}"
        );
        // The doubling steps count both doublings: more than the second alone, which is the
        // plain doubling of the DARE with Q = δ.
        let perturbed = Dare::new(&F, &H, mat![[1e-8 * r]], &R)
            .and_then(|d| d.solve())
            .expect("solve");
        assert!(ss.iterations > perturbed.iterations, "r = {r:e}");
    }
}

#[test]
fn newton_polish_converges_quadratically_in_any_unit() {
    // Two states with cross-covariance and a slow closed loop (ρ ≈ 0.9), so the Stein
    // equation of the Newton step needs several doublings. From P* + η‖P*‖·Z one step must
    // leave an error of order η², far below the η of a step with a wrong closed loop or a
    // truncated Stein sum.
    let F = mat![[0.97, 0.1], [0.0, 0.9]];
    let H = mat![[1.0, 0.0]];
    for unit in [1.0, 1e-6, 1e6] {
        let Q = mat![[0.02, 0.0], [0.0, 0.01]] * unit;
        let R = mat![[4.0]] * unit;
        let S = mat![[0.1], [0.05]] * unit;
        let f = form(&F, &H, &Q, &R, Some(&S));
        let ss = Dare::new(&F, &H, &Q, &R)
            .and_then(|d| d.cross_covariance(&S))
            .and_then(|d| d.solve())
            .expect("well posed");
        let P = &ss.prior;
        let cl = &F - &ss.predictor_gain * &H;
        assert!(spectral(cl.as_ref(), false) > 0.85, "a slow closed loop");
        let eta = 1e-4;
        let scale = P.norm_l2();
        let P0 = P + mat![[1.0, 0.3], [0.3, 0.5]] * (eta * scale);
        let P1 = dare::newton_polish(&f, &P0).expect("stabilising start");
        let e0 = (&P0 - P).norm_l2() / scale;
        let e1 = (&P1 - P).norm_l2() / scale;
        // Quadratic: e1 ≈ c·e0² with c of order ‖∂²Res‖/‖∂Res‖ ~ 1–100 here; 1e-6 = 100·η²
        // is the bound, and a linearly converging step would leave e1 ~ 0.1·e0 = 1e-5.
        assert!(e1 < 1e-6, "unit {unit:e}: e0 {e0:e} → e1 {e1:e}");
    }
}

#[test]
fn the_bounded_eigenvalue_routine_is_exact_on_a_companion_matrix_and_refuses_nan() {
    // Companion matrix of (λ − 1)(λ − 2)(λ − 3) = λ³ − 6λ² + 11λ − 6, and a rotation block
    // with eigenvalues ±2i: simple, well-separated roots come out to a few ε of 3.
    let C = mat![
        [6.0, -11.0, 6.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 2.0],
        [0.0, 0.0, 0.0, -2.0, 0.0],
    ];
    let mut eig = checks::eigenvalues(C.as_ref(), "test").expect("converges");
    eig.sort_by(|a, b| (a.0, a.1).partial_cmp(&(b.0, b.1)).expect("finite"));
    let want = [(0.0, -2.0), (0.0, 2.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0)];
    for (got, want) in eig.iter().zip(want) {
        // The companion matrix's roots have condition numbers of order 10: 1e-12 is ample.
        assert!(
            (got.0 - want.0).abs() < 1e-12 && (got.1 - want.1).abs() < 1e-12,
            "{got:?}"
        );
    }
    let mut bad = C.clone();
    bad[(2, 1)] = f64::NAN;
    let e = checks::eigenvalues(bad.as_ref(), "test").expect_err("not finite");
    assert!(
        matches!(
            e,
            Error::RiccatiNoConvergence {
                equation: "test",
                ..
            }
        ),
        "{e}"
    );
}
