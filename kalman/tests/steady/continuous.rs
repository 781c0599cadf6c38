//! Kalman–Bucy: the Riccati ODE's limit is the CARE solution; the discrete steady-state
//! gain of the sampled model divided by Δt tends to the continuous gain at first order.

use faer::{Mat, mat};
use kalman::continuous::{KalmanBucy, OdeOptions, van_loan};
use kalman::riccati::{Care, Clqr, Dare};
use proptest::prelude::*;

use super::common::{randn, rel, rng, spd, with_radius};

/// A lightly damped oscillator driven by white acceleration, position measured.
fn oscillator() -> (Mat<f64>, Mat<f64>, Mat<f64>, Mat<f64>) {
    let A = mat![[0.0, 1.0], [-1.0, -0.4]];
    let H = mat![[1.0, 0.0]];
    let Q = mat![[0.0, 0.0], [0.0, 0.5]];
    let R = mat![[0.2]];
    (A, H, Q, R)
}

#[test]
fn ode_limit_is_care() {
    let (A, H, Q, R) = oscillator();
    let ss = Care::new(&A, &H, &Q, &R)
        .and_then(|p| p.solve())
        .expect("CARE");
    assert!(ss.relative_residual < 1e-12);
    let kb = KalmanBucy::new(A.as_ref(), H.as_ref(), Q.as_ref(), R.as_ref()).expect("KB");
    let P0 = Mat::<f64>::identity(2, 2) * 10.0;
    // Rate 1e-10: an explicit scheme near a stable fixed point hovers at ~rtol·‖P‖·|λ|, so
    // rates much below 100·rtol are not reachable (see `KalmanBucy::until_steady`).
    let sol = kb
        .until_steady(P0.as_ref(), 1e-10, 1e4, &OdeOptions::default())
        .expect("ODE settles");
    // Tolerance: ‖Ṗ‖ ≤ 1e-10‖P‖ at the stop; the distance to the fixed point is that over the
    // closed-loop decay rate (~0.5 here), plus the integrator's rtol 1e-10: ~1e-10 ≪ 1e-8.
    let d = rel(&sol.covariance, &ss.covariance);
    assert!(d < 1e-8, "ODE limit vs CARE: {d:e}");
    let K = kb.gain(sol.covariance.as_ref()).expect("gain");
    assert!(rel(&K, &ss.gain) < 1e-8);
    // Symmetric along the way.
    let mid = kb
        .integrate(P0.as_ref(), 0.7, &OdeOptions::default())
        .expect("ODE");
    // P is symmetrised after every step, so the two triangles agree exactly.
    assert!((mid.covariance[(0, 1)] - mid.covariance[(1, 0)]).abs() <= 0.0);
}

#[test]
fn discrete_gain_over_dt_tends_to_continuous_gain_at_first_order() {
    let (A, H, Q, R) = oscillator();
    let Kc = Care::new(&A, &H, &Q, &R)
        .and_then(|p| p.solve())
        .expect("CARE")
        .gain;
    let mut errs = Vec::new();
    for dt in [0.04, 0.02, 0.01] {
        let (F, Qd) = van_loan(A.as_ref(), Q.as_ref(), dt).expect("Van Loan");
        // Measurement noise of intensity R averaged over Δt has covariance R/Δt.
        let Rd = &R * (1.0 / dt);
        let ss = Dare::new(&F, &H, &Qd, &Rd)
            .and_then(|p| p.solve())
            .expect("DARE");
        let Kd = &ss.gain * (1.0 / dt);
        errs.push((&Kd - &Kc).norm_l2());
    }
    // Expected order 1: K_d/Δt = P Hᵀ(H P Hᵀ Δt + R)⁻¹ = K_c + O(Δt) (and P_d = P_c + O(Δt)).
    // Tolerance on the observed order: ±0.1 (the next term is O(Δt²)/O(Δt) ≈ Δt·const).
    let p1 = (errs[0] / errs[1]).log2();
    let p2 = (errs[1] / errs[2]).log2();
    assert!(
        (p1 - 1.0).abs() < 0.1 && (p2 - 1.0).abs() < 0.1,
        "observed orders {p1}, {p2}; errors {errs:?}"
    );
    assert!(errs[2] < 0.05 * Kc.norm_l2());
}

/// The CARE's acceptance bound on the relative residual, recomputed from its definition
/// (see `RiccatiOptions::residual_floor_factor`): 100 ε (2‖A‖‖P‖ + ‖Hᵀ R⁻¹ H‖‖P‖² + ‖Q‖)/‖P‖,
/// the normwise backward error allowed. Well-conditioned draws sit far below 1e-10; an
/// ill-conditioned one may be returned above it, within this bound.
fn care_bound(A: &Mat<f64>, H: &Mat<f64>, Q: &Mat<f64>, R: &Mat<f64>, P: &Mat<f64>) -> f64 {
    use faer::Side;
    use faer::linalg::solvers::Solve;
    let G = H.transpose() * R.llt(Side::Lower).expect("R > 0").solve(H);
    let p = P.norm_l2();
    100.0 * f64::EPSILON * (2.0 * A.norm_l2() * p + G.norm_l2() * p * p + Q.norm_l2()) / p
}

proptest! {

    /// Random continuous models: CARE residual small, and the continuous LQR gain solves its
    /// own CARE X A + AᵀX − X B R⁻¹ Bᵀ X + Q = 0 (the filter form with A → Aᵀ, H → Bᵀ).
    #[test]
    fn care_and_clqr_residuals(seed in any::<u64>(), n in 1usize..=5, m in 1usize..=3, r in 0.1f64..2.0) {
        let mut g = rng(seed);
        // Spectrum of A shifted so some eigenvalues are unstable.
        let mut A = with_radius(&mut g, n, r);
        for i in 0..n {
            A[(i, i)] -= 0.5;
        }
        let H = randn(&mut g, m, n);
        let Q = spd(&mut g, n, 0.1);
        let R = spd(&mut g, m, 0.1);
        let care = Care::new(&A, &H, &Q, &R).expect("valid shapes");
        if let Ok(ss) = care.solve() {
            let res = care.residual(&ss.covariance).expect("n×n");
            let bound = care_bound(&A, &H, &Q, &R, &ss.covariance);
            prop_assert!(res < 1e-10 || res <= bound, "CARE residual {res:e}, bound {bound:e}");
        }
        let B = H.transpose().to_owned();
        let clqr = Clqr::new(&A, &B, &Q, &R).expect("valid shapes");
        if let Ok(l) = clqr.solve() {
            let res = clqr.residual(&l.cost).expect("n×n");
            let At = A.transpose().to_owned();
            let bound = care_bound(&At, &H, &Q, &R, &l.cost);
            prop_assert!(res < 1e-10 || res <= bound, "CLQR residual {res:e}, bound {bound:e}");
        }
    }
}

/// SPEC U's continuous model: position/velocity driven by white acceleration of intensity
/// q = 0.1, position measured with intensity r = 1. Closed form of the CARE:
/// P = [[√2 q^¼ r^¾, √(qr)], [√(qr), √2 q^¾ r^¼]], K = [√2 (q/r)^¼, √(q/r)]ᵀ. The double
/// eigenvalue 0 of A lies on the stability boundary, so this also exercises the PBH test
/// of marginal modes.
#[test]
fn uav_kalman_bucy_closed_form() {
    let (q, r) = (0.1_f64, 1.0_f64);
    let A = mat![[0.0, 1.0], [0.0, 0.0]];
    let H = mat![[1.0, 0.0]];
    let Q = mat![[0.0, 0.0], [0.0, q]];
    let R = mat![[r]];
    let ss = Care::new(&A, &H, &Q, &R)
        .and_then(|p| p.solve())
        .expect("UAV CARE");
    let want = [
        [2f64.sqrt() * q.powf(0.25) * r.powf(0.75), (q * r).sqrt()],
        [(q * r).sqrt(), 2f64.sqrt() * q.powf(0.75) * r.powf(0.25)],
    ];
    // Tolerance: a few ulps of O(1) entries after ~20 doubling steps.
    for i in 0..2 {
        for j in 0..2 {
            assert!(
                (ss.covariance[(i, j)] - want[i][j]).abs() < 1e-12,
                "P[{i},{j}]"
            );
        }
    }
    assert!((ss.gain[(0, 0)] - 2f64.sqrt() * (q / r).powf(0.25)).abs() < 1e-12);
    assert!((ss.gain[(1, 0)] - (q / r).sqrt()).abs() < 1e-12);
    // The Kalman–Bucy ODE from P0 = 0 reaches the same limit.
    let kb = KalmanBucy::new(A.as_ref(), H.as_ref(), Q.as_ref(), R.as_ref()).expect("KB");
    let sol = kb
        .until_steady(
            Mat::<f64>::zeros(2, 2).as_ref(),
            1e-9,
            1e4,
            &OdeOptions::default(),
        )
        .expect("settles");
    assert!(rel(&sol.covariance, &ss.covariance) < 1e-7);
}

/// The continuous boundary band is relative to the mode's size: λ = −ε ± 10i with
/// ε = 5·10⁻⁶ lies within margin·|λ| = 10⁻⁶·10 of the imaginary axis, so the CARE treats it
/// as a mode on the axis; with no process noise it is unreached, and the solve refuses it
/// as not stabilisable. Moved out of the band (ε = 2·10⁻⁵) the mode is plainly stable, needs
/// no noise, and the solution is P = 0 (A stable, Q = 0).
#[test]
fn continuous_marginal_band_scales_with_the_mode() {
    let solve = |eps: f64| {
        let A = mat![[-eps, 10.0], [-10.0, -eps]];
        let I = Mat::<f64>::identity(2, 2);
        Care::new(&A, &I, Mat::<f64>::zeros(2, 2), &I).and_then(|c| c.solve())
    };
    let inside = solve(5e-6);
    assert!(
        matches!(inside, Err(kalman::Error::NotStabilisable { re, .. }) if (re + 5e-6).abs() < 1e-9),
        "{inside:?}"
    );
    let outside = solve(2e-5).expect("a stable mode needs no noise");
    assert!(
        outside.covariance.norm_l2() <= 0.0,
        "{:?}",
        outside.covariance
    );
}

/// Ṗ = q − P² (A = 0, H = R = 1) from P(0) = 0 has P(t) = √q·tanh(√q·t). The first step's
/// guess, 0.01/(‖A‖ + ‖G‖·max(‖P‖, 1)) = 0.01, does not see q: at q = 1e10 (√q·h = 1000)
/// the Dormand–Prince stages grow as squares until the derivative at the step's end
/// overflows, and the step must be retried shorter rather than taken for divergence.
#[test]
fn a_first_step_that_overflows_is_retried_shorter() {
    let q = 1e10_f64;
    let (zero, one) = (mat![[0.0]], mat![[1.0]]);
    let Q = mat![[q]];
    let kb = KalmanBucy::new(zero.as_ref(), one.as_ref(), Q.as_ref(), one.as_ref()).expect("KB");
    let t1 = 0.01;
    let sol = kb
        .integrate(zero.as_ref(), t1, &OdeOptions::default())
        .expect("a stiff but finite problem integrates");
    assert!((sol.time - t1).abs() <= 1e-15 * t1);
    // √q·t1 = 1000: tanh is 1 to the last bit. Tolerance: the integrator's rtol 1e-10 per
    // step, at a stable fixed point where errors do not accumulate: 1e-8 relative.
    let exact = q.sqrt() * (q.sqrt() * t1).tanh();
    let got = sol.covariance[(0, 0)];
    assert!(
        ((got - exact) / exact).abs() < 1e-8,
        "P(t1) = {got:e}, exact {exact:e}"
    );
}

/// The step control's tolerance is relative to P: the same problem in units where every
/// covariance (Q, R, P0) and `atol` is 2⁴⁰ times larger takes exactly the same steps and
/// ends at exactly 2⁴⁰·P. A power of two scales every product, sum, square root and
/// quotient of the integration without rounding, and with ‖P0‖ ≥ 1 the first-step guess
/// `0.01/(‖A‖ + ‖G‖·max(‖P‖, 1))` sees ‖G‖·‖P‖, which does not change (G = HᵀR⁻¹H scales by
/// 2⁻⁴⁰), so any departure from bit-for-bit equality is a tolerance that is not relative.
#[test]
fn a_change_of_units_scales_the_solution_exactly() {
    let (A, H, Q, R) = oscillator();
    let P0 = mat![[2.0, 0.5], [0.5, 1.0]];
    let c = 2.0_f64.powi(40);
    let opts = OdeOptions::default();
    let solve = |s: f64, atol: f64| {
        KalmanBucy::new(A.as_ref(), H.as_ref(), (s * &Q).as_ref(), (s * &R).as_ref())
            .expect("KB")
            .integrate((s * &P0).as_ref(), 10.0, &OdeOptions { atol, ..opts })
            .expect("integrates")
    };
    let (one, big) = (solve(1.0, opts.atol), solve(c, c * opts.atol));
    assert_eq!(one.steps, big.steps, "accepted steps");
    assert!(one.steps > 10, "a run of {} steps tests little", one.steps);
    for j in 0..2 {
        for i in 0..2 {
            let (p, pc) = (one.covariance[(i, j)], big.covariance[(i, j)]);
            assert!(
                (pc - c * p).abs() <= 0.0,
                "P[{i},{j}]: {pc:e} in the large units against 2^40·{p:e}"
            );
        }
    }
}
