//! DARE / LQR / PBH: random detectable models converge to the DARE solution, residuals,
//! the LQR gain against its own Riccati equation, typed errors for undetectable and
//! unstabilisable pairs.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side, mat};
use kalman::riccati::{Dare, Dlqr};
use kalman::{CovarianceForm, DynDims, Error, Filter, Model};
use proptest::prelude::*;

use super::common::{joint_noise, randn, rel, rho, rng, spd, with_radius};

/// Runs the engine's filter (no data needed: P does not depend on z) until P_{k+1|k} settles.
fn iterate_filter(
    F: &Mat<f64>,
    H: &Mat<f64>,
    Q: &Mat<f64>,
    R: &Mat<f64>,
    S: Option<&Mat<f64>>,
) -> (Mat<f64>, usize) {
    let (n, m) = (F.nrows(), H.nrows());
    let mut model = Model::new(DynDims::new(n, m, 0).expect("dims"), F, H, Q, R).expect("model");
    if let Some(S) = S {
        model = model.with_cross_covariance(S).expect("S");
    }
    let P0 = Mat::<f64>::identity(n, n);
    let mut f = Filter::new(model, &vec![0.0; n], &P0, CovarianceForm::Joseph).expect("filter");
    let z = vec![0.0; m];
    let mut prev = P0;
    for k in 0..20_000 {
        f.step(&z, None).expect("step");
        let P = f.predicted_covariance().to_owned();
        if rel(&P, &prev) < 1e-14 {
            return (P, k);
        }
        prev = P;
    }
    (prev, 20_000)
}

/// The DARE's acceptance bound on the relative residual, recomputed from its definition
/// (see `RiccatiOptions::residual_floor_factor`): 100 ε (‖F‖²‖P‖ + ‖P‖ + ‖Q‖ +
/// 2(‖F‖‖P‖‖H‖ + ‖S‖)‖K_p‖ + ‖K_p‖²‖Σ‖)/‖P‖ with Σ = H P Hᵀ + R and K_p the predictor gain:
/// the normwise backward error allowed. Well-conditioned draws sit far below 1e-10; an
/// ill-conditioned one (an unstable mode the noise does not reach, a closed loop near the
/// unit circle) may be returned above it, within this bound.
fn dare_bound(
    F: &Mat<f64>,
    H: &Mat<f64>,
    Q: &Mat<f64>,
    R: &Mat<f64>,
    S: Option<&Mat<f64>>,
    P: &Mat<f64>,
    Kp: &Mat<f64>,
) -> f64 {
    let p = P.norm_l2();
    let f = F.norm_l2();
    let sigma = (H * P * H.transpose() + R).norm_l2();
    let k = Kp.norm_l2();
    let c = f * p * H.norm_l2() + S.map_or(0.0, |S| S.norm_l2());
    100.0 * f64::EPSILON * (f * f * p + p + Q.norm_l2() + 2.0 * c * k + k * k * sigma) / p
}

proptest! {

    /// Random detectable, stabilisable models (Q > 0, generic H, spectral radius up to 1.3,
    /// with or without cross-covariance): the filter's P converges to the DARE prior, the
    /// DARE residual is below 1e-10·‖P‖, and the gains match the converged filter.
    #[test]
    fn filter_converges_to_dare(seed in any::<u64>(), n in 1usize..=6, m in 1usize..=3, r in 0.2f64..1.3, cross in any::<bool>()) {
        let mut g = rng(seed);
        let F = with_radius(&mut g, n, r);
        let H = randn(&mut g, m, n);
        let (Q, R, S) = joint_noise(&mut g, n, m);
        let S = cross.then_some(S);
        let mut dare = Dare::new(&F, &H, &Q, &R).expect("valid shapes");
        if let Some(S) = &S {
            dare = dare.cross_covariance(S).expect("valid shape");
        }
        let ss = match dare.solve() {
            Ok(ss) => ss,
            // A random H can make a mode nearly unobservable; then the typed PBH error is the
            // right answer and no NaN may appear.
            Err(Error::NotDetectable { .. }) => return Ok(()),
            Err(e) => return Err(TestCaseError::fail(format!("{e}"))),
        };
        let res = dare.residual(&ss.prior).expect("n×n");
        let bound = dare_bound(&F, &H, &Q, &R, S.as_ref(), &ss.prior, &ss.predictor_gain);
        prop_assert!(res < 1e-10 || res <= bound, "residual {res:e}, bound {bound:e}");
        prop_assert!(ss.relative_residual < 1e-10 || ss.relative_residual <= bound);
        let (P, _) = iterate_filter(&F, &H, &Q, &R, S.as_ref());
        // Tolerance: the iterated filter stops at a relative change of 1e-14; its distance to
        // the fixed point is that times 1/(1 − ρ_cl), and ρ_cl can be ~0.999 here.
        let d = rel(&P, &ss.prior);
        prop_assert!(d < 1e-8, "filter vs DARE {d:e}");
        // Closed loop of the predictor is stable.
        let cl = &F - &ss.predictor_gain * &H;
        prop_assert!(rho(&cl) < 1.0);
    }

    /// LQR: the returned X satisfies X = AᵀXA + Q − (AᵀXB + N)(R + BᵀXB)⁻¹(BᵀXA + Nᵀ)
    /// (written out here independently of the solver; N = 0 without a cross weight) and
    /// L = (R + BᵀXB)⁻¹(BᵀXA + Nᵀ) stabilises A − BL.
    #[test]
    fn lqr_satisfies_its_riccati_equation(seed in any::<u64>(), n in 1usize..=6, p in 1usize..=3, r in 0.2f64..1.5, cross in any::<bool>()) {
        let mut g = rng(seed);
        let A = with_radius(&mut g, n, r);
        let B = randn(&mut g, n, p);
        // [Q N; Nᵀ R] ≥ 0 jointly, as the cost needs.
        let (Q, R, N) = joint_noise(&mut g, n, p);
        let N = if cross { N } else { Mat::zeros(n, p) };
        let mut dlqr = Dlqr::new(&A, &B, &Q, &R).expect("valid shapes");
        if cross {
            dlqr = dlqr.cross_weight(&N).expect("valid shape");
        }
        let lqr = match dlqr.solve() {
            Ok(l) => l,
            Err(Error::NotStabilisable { .. } | Error::NotDetectable { .. }) => return Ok(()),
            Err(e) => return Err(TestCaseError::fail(format!("{e}"))),
        };
        let X = &lqr.cost;
        let Sig = &R + B.transpose() * X * &B;
        let llt = Sig.llt(Side::Lower).expect("R + BᵀXB > 0");
        let BtXA_N = B.transpose() * X * &A + N.transpose();
        let rhs = A.transpose() * X * &A + &Q - BtXA_N.transpose() * llt.solve(&BtXA_N);
        let res = rel(X, &rhs);
        prop_assert!(res < 1e-10, "LQR residual {res:e}");
        let L = llt.solve(&BtXA_N);
        prop_assert!(rel(&lqr.gain, &L) < 1e-10);
        prop_assert!(rho(&(&A - &B * &lqr.gain)) < 1.0);
    }

    /// An unstable mode that H cannot see is a typed `NotDetectable`, not a NaN.
    #[test]
    fn undetectable_is_typed(seed in any::<u64>(), n in 2usize..=6, m in 1usize..=3, lam in 1.05f64..2.0, neg in any::<bool>()) {
        let mut g = rng(seed);
        let lam = if neg { -lam } else { lam };
        // D = [[F1, 0], [d, λ]]: e_n is an eigenvector with eigenvalue λ; H_D = [H1, 0] misses it.
        let mut D = randn(&mut g, n, n) * 0.3;
        for i in 0..n - 1 {
            D[(i, n - 1)] = 0.0;
        }
        D[(n - 1, n - 1)] = lam;
        let mut HD = randn(&mut g, m, n);
        for i in 0..m {
            HD[(i, n - 1)] = 0.0;
        }
        let T = Mat::<f64>::identity(n, n) + randn(&mut g, n, n) * 0.2;
        let lu = T.partial_piv_lu();
        // F = T D T⁻¹ and H = H_D T⁻¹ by solves: Tᵀ Fᵀ = (T D)ᵀ.
        let F = lu.solve_transpose((&T * &D).transpose()).transpose().to_owned();
        let H = lu.solve_transpose(HD.transpose()).transpose().to_owned();
        let Q = spd(&mut g, n, 0.1);
        let R = spd(&mut g, m, 0.1);
        let e = Dare::new(&F, &H, &Q, &R).and_then(|p| p.solve());
        prop_assert!(matches!(e, Err(Error::NotDetectable { pair: "(F, H)", .. })), "{:?}", e.map(|s| s.prior));
    }

    /// A mode the process noise cannot excite: on the unit circle there is no stabilising
    /// solution (a typed `NotStabilisable`); outside it the gain stabilises it and the
    /// solution is returned, checked by its own residual and closed loop.
    #[test]
    fn unreached_modes(seed in any::<u64>(), n in 2usize..=6, m in 1usize..=3, lam in 1.05f64..2.0, on_circle in any::<bool>(), negative in any::<bool>()) {
        let mut g = rng(seed);
        let lam = if on_circle { 1.0 } else { lam } * if negative { -1.0 } else { 1.0 };
        // D = [[F1, d], [0, λ]]: e_nᵀ is a left eigenvector; Q_D = diag(Q1, 0) misses it.
        let mut D = randn(&mut g, n, n) * 0.3;
        for j in 0..n - 1 {
            D[(n - 1, j)] = 0.0;
        }
        D[(n - 1, n - 1)] = lam;
        let mut QD = Mat::<f64>::zeros(n, n);
        let Q1 = spd(&mut g, n - 1, 0.1);
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                QD[(i, j)] = Q1[(i, j)];
            }
        }
        let T = Mat::<f64>::identity(n, n) + randn(&mut g, n, n) * 0.2;
        let lu = T.partial_piv_lu();
        let F = lu.solve_transpose((&T * &D).transpose()).transpose().to_owned();
        let Q = &T * &QD * T.transpose();
        let H = randn(&mut g, m, n);
        let R = spd(&mut g, m, 0.1);
        let dare = Dare::new(&F, &H, &Q, &R).expect("valid shapes");
        let e = dare.solve();
        if on_circle {
            // With a generic H the failing pair is the noise pair.
            prop_assert!(matches!(e, Err(Error::NotStabilisable { .. })), "{:?}", e.map(|s| s.prior));
        } else {
            let ss = e.map_err(|e| TestCaseError::fail(format!("{e}")))?;
            let res = dare.residual(&ss.prior).expect("n×n");
            let bound = dare_bound(&F, &H, &Q, &R, None, &ss.prior, &ss.predictor_gain);
            prop_assert!(res < 1e-10 || res <= bound, "DARE residual {res:e}, bound {bound:e}");
            let cl = &F - &ss.predictor_gain * &H;
            prop_assert!(rho(&cl) < 1.0);
        }
    }
}

/// The UAV loop of SPEC U: discrete LQR with state weight diag(1, 0.1), input weight 1.
#[test]
fn uav_lqr() {
    let dt = 0.25;
    let A = mat![[1.0, dt], [0.0, 1.0]];
    let B = mat![[dt * dt / 2.0], [dt]];
    let Q = mat![[1.0, 0.0], [0.0, 0.1]];
    let R = mat![[1.0]];
    let lqr = Dlqr::new(&A, &B, &Q, &R)
        .and_then(|p| p.solve())
        .expect("UAV LQR");
    assert!(lqr.relative_residual < 1e-12);
    let cl = &A - &B * &lqr.gain;
    assert!(rho(&cl) < 1.0);
    // The value iteration X_{k+1} = AᵀX_kA + Q − AᵀX_kB(R + BᵀX_kB)⁻¹BᵀX_kA from X_0 = Q
    // reaches the same X (tolerance: 5000 iterations reach the fixed point to rounding).
    let mut X = Q.clone();
    for _ in 0..5000 {
        let S = &R + B.transpose() * &X * &B;
        let BtXA = B.transpose() * &X * &A;
        let l = S.llt(Side::Lower).expect("pd");
        X = A.transpose() * &X * &A + &Q - BtXA.transpose() * l.solve(&BtXA);
    }
    assert!(rel(&lqr.cost, &X) < 1e-10);
    // Double integrator without damping: (A, B) stabilisable, but B = 0 is not.
    let e = Dlqr::new(&A, Mat::<f64>::zeros(2, 1).as_ref(), &Q, &R)
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(
        matches!(e, Error::NotStabilisable { pair: "(A, B)", .. }),
        "{e}"
    );
    // Q that does not see the position mode: (Q^{1/2}, A) not detectable.
    let e = Dlqr::new(&A, &B, mat![[0.0, 0.0], [0.0, 1.0]], &R)
        .and_then(|p| p.solve())
        .expect_err("must be an error");
    assert!(
        matches!(
            e,
            Error::NotDetectable {
                pair: "(Q^{1/2}, A)",
                ..
            }
        ),
        "{e}"
    );
}

/// A poorly controllable single-input case found by the LQR property test (relative
/// residual 7.7e-10 from the doubling alone): the Newton polish brings it below 1e-10.
#[test]
fn ill_conditioned_lqr_is_polished() {
    let mut g = rng(10793998847586351072);
    let (n, p, r) = (6, 1, 1.302292803561311);
    let A = with_radius(&mut g, n, r);
    let B = randn(&mut g, n, p);
    let Q = spd(&mut g, n, 0.1);
    let R = spd(&mut g, p, 0.1);
    let l = Dlqr::new(&A, &B, &Q, &R)
        .and_then(|p| p.solve())
        .expect("polished LQR");
    assert!(l.relative_residual < 1e-10, "{:e}", l.relative_residual);
}

/// Every Riccati builder passes its options on to the solver: one doubling step is too few
/// for the scalar random walk (the doubling needs about five to reach 1e-14), so each solve
/// must stop with `RiccatiNoConvergence` after that step, where the default options solve
/// the same problem.
#[test]
fn every_builder_applies_its_options() {
    use kalman::riccati::{Care, Clqr, Equation, Riccati, RiccatiOptions};
    let capped = RiccatiOptions {
        max_iterations: 1,
        ..RiccatiOptions::default()
    };
    // The solve with the default options and the one with `capped`, solutions dropped.
    fn both<E: Equation>(
        problem: Result<Riccati<E>, Error>,
        capped: RiccatiOptions,
    ) -> (Result<(), Error>, Result<(), Error>) {
        let problem = problem.expect("inputs");
        let default = problem.solve().map(drop);
        (default, problem.options(capped).solve().map(drop))
    }
    let one = [[1.0]];
    let verdicts = [
        both(Dare::new(one, one, one, one), capped),
        both(Dlqr::new(one, one, one, one), capped),
        both(Care::new([[-1.0]], one, one, one), capped),
        both(Clqr::new([[-1.0]], one, one, one), capped),
    ];
    for (k, (default, capped)) in verdicts.into_iter().enumerate() {
        assert!(default.is_ok(), "builder {k}: {default:?}");
        assert!(
            matches!(
                capped,
                Err(Error::RiccatiNoConvergence { iterations: 1, .. })
            ),
            "builder {k}: {capped:?}"
        );
    }
}

/// A doubling iterate that overflows is an error at that iteration, even when only one of
/// the three iterates does: for the scalar LQR with a = 0.9, b = 1, q = 0 and r = 1e-308, the
/// first doubling step multiplies G₀ = b²/r = 1e308 by 1 + a² = 1.81, past f64::MAX, while
/// A₁ = a² and H₁ = q = 0 stay finite (a solver that looked only at those would return the
/// zero solution without noticing).
#[test]
fn one_overflowing_doubling_iterate_is_an_error_at_once() {
    let result = Dlqr::new([[0.9]], [[1.0]], [[0.0]], [[1e-308]]).and_then(|p| p.solve());
    assert!(
        matches!(
            result,
            Err(Error::RiccatiNoConvergence { iterations: 1, reason, .. }) if reason.contains("non-finite")
        ),
        "{result:?}"
    );
}

#[test]
fn an_indefinite_r_is_refused_by_name_while_a_singular_one_solves() {
    // R is a covariance: a singular one (an exact channel) has a steady state, an indefinite
    // one is no covariance and is refused by the PSD rule, naming R.
    let (F, H, Q) = (
        mat![[0.5, 0.0], [0.0, 0.9]],
        mat![[1.0, 1.0]],
        mat![[1.0, 0.0], [0.0, 1.0]],
    );
    let e = Dare::new(&F, &H, &Q, &mat![[-1.0]])
        .expect("shapes are valid")
        .solve()
        .expect_err("an indefinite R");
    assert!(
        matches!(e, Error::NotPositiveSemidefinite { name: "R", .. }),
        "{e}"
    );
    Dare::new(&F, &H, &Q, &mat![[0.0]])
        .expect("shapes are valid")
        .solve()
        .expect("a singular R with noise reaching the channel");
}
