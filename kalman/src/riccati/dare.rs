//! The discrete equations' numerics: the decorrelate–test–double driver of the filter-form
//! DARE (the [`Dare`](super::Dare), and the [`Dlqr`](super::Dlqr) as its dual), its
//! residual, Newton's polish, and the read-outs of the steady state and the discrete LQR.
#![allow(non_snake_case)]

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, Side};

use super::checks::{Modes, marginal_modes, pbh, psd_sqrt};
use super::problem::{FilterForm, Finish, Inputs, Names, Solved, Time};
use super::sda::sda;
use super::{
    Lqr, RiccatiOptions, SteadyState, all_finite, factor_pd, relative, spectral, symmetrise,
    symmetrised, weighted_gram,
};
use crate::Error;

impl Finish for SteadyState {
    fn finish(inputs: &Inputs, _: Time, solved: Solved) -> Result<Self, Error> {
        let ([F, H, _, R], S) = inputs.views();
        let P = solved.x;
        // Σ = H P Hᵀ + R; K = P Hᵀ Σ⁻¹; K_p = (F P Hᵀ + S) Σ⁻¹; all by Cholesky solves.
        let HP = H * &P;
        let mut Sigma = &HP * H.transpose() + R;
        symmetrise(&mut Sigma);
        let llt = factor_pd(
            "H P H^T + R",
            Sigma.as_ref(),
            "the steady-state innovation covariance must be invertible",
        )?;
        let gain = llt.solve(&HP).transpose().to_owned();
        let mut FPHt_S = F * (&P * H.transpose());
        if let Some(S) = S {
            FPHt_S += S;
        }
        let predictor_gain = llt.solve(FPHt_S.transpose()).transpose().to_owned();
        let mut posterior = &P - &gain * &HP;
        symmetrise(&mut posterior);
        Ok(SteadyState {
            prior: P,
            posterior,
            gain,
            predictor_gain,
            innovation_cov: Sigma,
            iterations: solved.iterations,
            relative_residual: solved.relative_residual,
        })
    }
}

/// [`Finish`] of the [`Lqr`] in discrete time.
pub(super) fn discrete_lqr(inputs: &Inputs, solved: Solved) -> Result<Lqr, Error> {
    let ([A, B, _, R], N) = inputs.views();
    let X = solved.x;
    let BtX = B.transpose() * &X;
    let mut Sigma = &BtX * B + R;
    symmetrise(&mut Sigma);
    let llt = factor_pd(
        "R + B^T X B",
        Sigma.as_ref(),
        "the LQR gain needs its inverse",
    )?;
    let mut rhs = &BtX * A;
    if let Some(N) = N {
        rhs += N.transpose();
    }
    let gain = llt.solve(&rhs);
    Ok(Lqr {
        gain,
        cost: X,
        iterations: solved.iterations,
        relative_residual: solved.relative_residual,
    })
}

/// The filter-form DARE's relative residual
/// ([`Riccati::residual`](super::Riccati::residual)) on faer views (the solvers' own check).
pub(super) fn discrete_residual(form: &FilterForm<'_>, P: MatRef<'_, f64>) -> f64 {
    discrete_parts(form, P).0
}

/// The relative residual and its round-off floor
/// ε·(‖F‖²‖P‖ + ‖P‖ + ‖Q‖ + 2(‖F‖‖P‖‖H‖ + ‖S‖)‖K_p‖ + ‖K_p‖²‖Σ‖)/‖P‖ with
/// K_p = (F P Hᵀ + S) Σ⁻¹ (see
/// [`RiccatiOptions::residual_floor_factor`]); (+∞, 0) when Σ is not positive definite.
fn discrete_parts(form: &FilterForm<'_>, P: MatRef<'_, f64>) -> (f64, f64) {
    match dare_residual_matrix(form, P) {
        Some((res, corr)) => {
            let p = P.norm_l2();
            let f = form.F.norm_l2();
            let floor = f64::EPSILON * (f * f * p + p + form.Q.norm_l2() + corr)
                / if p > 0.0 { p } else { 1.0 };
            (relative(res.norm_l2(), p), floor)
        }
        None => (f64::INFINITY, 0.0),
    }
}

/// The DARE residual matrix F P Fᵀ + Q − (F P Hᵀ + S) Σ⁻¹ (⋯)ᵀ − P and the size of its
/// correction term for the floor (`None` if Σ is not positive definite).
fn dare_residual_matrix(form: &FilterForm<'_>, P: MatRef<'_, f64>) -> Option<(Mat<f64>, f64)> {
    let FilterForm { F, H, Q, R, S } = *form;
    let mut Sigma = H * P * H.transpose() + R;
    symmetrise(&mut Sigma);
    let mut C = F * P * H.transpose();
    if let Some(S) = S {
        C += S;
    }
    let llt = Sigma.llt(Side::Lower).ok()?;
    let KpT = llt.solve(C.transpose());
    let corr = &C * &KpT;
    let mut res = F * P * F.transpose() + Q - &corr - P;
    symmetrise(&mut res);
    // The correction's sensitivity to roundings of C = F P Hᵀ + S and of Σ, as norm
    // products (like the other terms): 2(‖F‖‖P‖‖H‖ + ‖S‖)‖K_p‖ + ‖K_p‖²‖Σ‖ with
    // K_p = C Σ⁻¹; large beside ‖C Σ⁻¹ Cᵀ‖ when Σ is ill-conditioned.
    let k = KpT.norm_l2();
    let c = F.norm_l2() * P.norm_l2() * H.norm_l2() + S.map_or(0.0, |S| S.norm_l2());
    Some((res, 2.0 * c * k + k * k * Sigma.norm_l2()))
}

/// One Newton (Hewer) correction of a DARE solution: with the closed loop
/// A_cl = F − K_p H, the correction E solves the Stein equation E − A_cl E A_clᵀ = Res(P),
/// here by Smith's doubling E = Σ_k A_cl^k Res (A_clᵀ)^k (squaring A_cl each step). Returns
/// `None` if the closed loop is not contractive enough for the doubling to converge.
pub(super) fn newton_polish(form: &FilterForm<'_>, P: &Mat<f64>) -> Option<Mat<f64>> {
    let (res, _) = dare_residual_matrix(form, P.as_ref())?;
    let FilterForm { F, H, R, S, .. } = *form;
    let mut Sigma = H * P * H.transpose() + R;
    symmetrise(&mut Sigma);
    let llt = Sigma.llt(Side::Lower).ok()?;
    let mut C = F * (P * H.transpose());
    if let Some(S) = S {
        C += S;
    }
    let Kp = llt.solve(C.transpose()).transpose().to_owned();
    let mut T = F - &Kp * H;
    let mut E = res;
    for _ in 0..64 {
        let mut E_next = &E + &T * &E * T.transpose();
        symmetrise(&mut E_next);
        let change = (&E_next - &E).norm_l2();
        E = E_next;
        T = &T * &T;
        if !all_finite(T.as_ref()) || !all_finite(E.as_ref()) {
            return None;
        }
        if change <= f64::EPSILON * E.norm_l2() || T.norm_l2() <= f64::EPSILON {
            let mut Pn = P + &E;
            symmetrise(&mut Pn);
            return Some(Pn);
        }
    }
    None
}

/// The doubling's answer for the filter-form DARE before Newton's polish, with the steps it
/// took and the decorrelated F̃ = F − S R⁻¹ H.
pub(super) struct DoublingStart {
    pub(super) X: Mat<f64>,
    pub(super) iterations: usize,
    #[cfg_attr(not(test), allow(dead_code))] // read by the unit tests
    pub(super) Ft: Mat<f64>,
}

/// The doubling's start for any R with H P Hᵀ + R positive definite at the solution. A
/// positive definite R goes straight to [`doubling_pd`]. A singular R (an exact channel) is
/// handled by shifting the unknown: for any symmetric Z, P = Y + Z turns the DARE into one
/// in Y of the same form with Q̂ = F Z Fᵀ + Q − Z, R̂ = R + H Z Hᵀ, Ŝ = S + F Z Hᵀ (and
/// the same closed loop, so the stabilising Y gives the stabilising P). With the k-step
/// noise Gramian Z = Σ_{i<k} Fⁱ Q (Fⁱ)ᵀ the new noise is Q̂ = Fᵏ Q (Fᵏ)ᵀ ⪰ 0, and k is the
/// first (k ≤ n) with R̂ positive definite: the noise reaching the exact channels within k
/// steps. No k ≤ n works exactly when H P Hᵀ + R is singular for every reachable P; then
/// [`Error::NotPositiveDefinite`] names it.
pub(super) fn doubling_start(
    form: &FilterForm<'_>,
    opts: &RiccatiOptions,
    names: &Names,
) -> Result<DoublingStart, Error> {
    let FilterForm { F, H, Q, R, S } = *form;
    if let Ok(llt) = R.llt(Side::Lower) {
        return doubling_pd(form, llt, opts, names);
    }
    // A singular R is a covariance (or weight) with an exact channel; an indefinite one is
    // neither, and is refused by the workspace's one PSD rule.
    let m = R.nrows();
    let r: Vec<f64> = (0..m * m).map(|e| R[(e % m, e / m)]).collect();
    crate::model::psd_factor("R", &r, m, &mut vec![0.0; m * m])?;
    let n = F.nrows();
    let mut Z = Mat::<f64>::zeros(n, n);
    let mut term = symmetrised(Q);
    for _ in 0..n.max(1) {
        Z += &term;
        let Rh = symmetrised((R + H * &Z * H.transpose()).as_ref());
        if let Ok(llt) = Rh.llt(Side::Lower) {
            let mut Sh = F * &Z * H.transpose();
            if let Some(S) = S {
                Sh += S;
            }
            let Qh = symmetrised((F * &term * F.transpose()).as_ref());
            let shifted = FilterForm {
                F,
                H,
                Q: Qh.as_ref(),
                R: Rh.as_ref(),
                S: Some(Sh.as_ref()),
            };
            let mut start = doubling_pd(&shifted, llt, opts, names)?;
            start.X += &Z;
            symmetrise(&mut start.X);
            return Ok(start);
        }
        term = symmetrised((F * &term * F.transpose()).as_ref());
    }
    Err(Error::NotPositiveDefinite {
        name: "H P H^T + R",
        n: R.nrows(),
        rule: "R is singular and the noise reaches no exact channel within n steps, so the steady-state innovation covariance is singular",
    })
}

/// Decorrelates (F̃ = F − S R⁻¹ H, Q̃ = Q − S R⁻¹ Sᵀ, with `llt` the factor of R), runs the
/// PBH tests, and doubles from Q̃, or from Q̃ + δI when the answer from Q̃ would not
/// stabilise (see inside): a stabilising start for Newton's polish, accurate to the
/// doubling's tolerance on a well-conditioned problem and within O(δ) of the solution on
/// the δ path.
fn doubling_pd(
    form: &FilterForm<'_>,
    llt: faer::linalg::solvers::Llt<f64>,
    opts: &RiccatiOptions,
    names: &Names,
) -> Result<DoublingStart, Error> {
    let FilterForm { F, H, Q, R: _, S } = *form;
    // F̃ = F − S R⁻¹ H, Q̃ = Q − S R⁻¹ Sᵀ.
    let (Ft, Qt) = match S {
        Some(S) => {
            let RinvSt = llt.solve(S.transpose());
            let RinvH = llt.solve(H);
            let mut Qt = Q - S * &RinvSt;
            symmetrise(&mut Qt);
            (F - S * &RinvH, Qt)
        }
        None => (F.to_owned(), Q.to_owned()),
    };
    // F̃ = F − S R⁻¹ H has F's eigenvalues when S = 0: one eigen-decomposition then.
    let modes = marginal_modes(F, false, Modes::OnOrOutside, opts)?;
    if let Some((re, im)) = pbh(F, H, &modes, opts)? {
        return Err(names.detect.error(re, im));
    }
    // A stabilising solution exists when (F̃, Q̃^{1/2}) has no unreachable mode *on* the
    // unit circle; an unreachable mode outside it is stabilised through the gain (F = 2,
    // Q = 0, H = R = 1: P = 3).
    let modes_t = marginal_modes(Ft.as_ref(), false, Modes::On, opts)?;
    if !modes_t.is_empty() {
        let Qh = psd_sqrt(Qt.as_ref())?;
        if let Some((re, im)) = pbh(Ft.transpose(), Qh.as_ref(), &modes_t, opts)? {
            return Err(names.stab.error(re, im));
        }
    }
    let G = weighted_gram(H, &llt);
    let Qs = symmetrised(Qt.as_ref());
    let (mut X, mut iterations) = sda(
        Ft.transpose().to_owned(),
        G.clone(),
        Qs.clone(),
        opts,
        names.equation,
    )?;
    let rho0 = closed_loop_radius(form, &X);
    if rho0.is_nan() || rho0 >= 1.0 {
        // Q̃ leaves an unstable mode unexcited: the doubling from Q̃ then converges to a
        // solution that does not stabilise it (X = 0 for Q̃ = 0). The doubling from
        // Q̃ + δI does (every mode is then reachable), and lies within O(δ) of the
        // stabilising solution; Newton's method from a stabilising start stays stabilising
        // and removes the O(δ) in a few quadratic steps. δ is relative to the scale of X
        // (that of Q̃, or of (Hᵀ R⁻¹ H)⁻¹ when Q̃ vanishes). G = Hᵀ R⁻¹ H ≠ 0 here: with H = 0
        // the closed loop is F itself, stable after the PBH test passed, so this path is not
        // taken.
        let scale = Qs.norm_l2().max(1.0 / G.norm_l2());
        let n = Qs.nrows();
        let Qd = &Qs + (1e-8 * scale) * Mat::<f64>::identity(n, n);
        let (Xd, it) = sda(Ft.transpose().to_owned(), G, Qd, opts, names.equation)?;
        X = Xd;
        iterations += it;
    }
    Ok(DoublingStart { X, iterations, Ft })
}

/// Decorrelate, run the PBH tests, and solve the filter-form DARE for (F, H, Q, R, S) by
/// the doubling ([`doubling_start`]) polished by Newton's method; returns the prior P.
pub(super) fn discrete_dual(
    form: &FilterForm<'_>,
    opts: &RiccatiOptions,
    names: &Names,
) -> Result<Solved, Error> {
    let DoublingStart {
        mut X, iterations, ..
    } = doubling_start(form, opts, names)?;
    // Ill-conditioned problems leave the doubling short of full accuracy (an unstable mode
    // the noise does not reach, with the closed loop near the unit circle, costs several
    // digits): Newton corrections, each kept only if it lowers the residual, until the
    // residual is far inside the tolerance. From a stabilising start they converge
    // quadratically, so the cap is seldom reached.
    let newton_steps = 20;
    // Newton–Hewer iterates from a stabilising start stay stabilising and decrease
    // monotonically (in the PSD order) onto the stabilising solution, but the residual norm
    // need not fall at every step: follow the iteration while the closed loop stays stable
    // and keep the iterate with the smallest residual.
    let (mut relative_residual, mut floor) = discrete_parts(form, X.as_ref());
    let mut current = X.clone();
    for _ in 0..newton_steps {
        if relative_residual <= 4.0 * f64::EPSILON {
            break;
        }
        let Some(next) = newton_polish(form, &current) else {
            break;
        };
        let (r, next_floor) = discrete_parts(form, next.as_ref());
        // Written so that a NaN residual or radius stops the iteration. The radius test guards
        // against rounding carrying an iterate out of the stabilising set, which Newton's
        // iterates from a stabilising start never leave in exact arithmetic.
        if !(r.is_finite() && closed_loop_radius(form, &next) < 1.0) {
            break;
        }
        if r < relative_residual {
            X = next.clone();
            relative_residual = r;
            floor = next_floor;
        }
        current = next;
    }
    let rho = closed_loop_radius(form, &X);
    Solved {
        x: X,
        iterations,
        relative_residual,
        floor,
    }
    .checked(rho, Time::Discrete, opts, names.equation)
}

/// Spectral radius of the predictor's closed loop F − K_p H, K_p = (F X Hᵀ + S) Σ⁻¹, for a
/// candidate DARE solution X (+∞ if Σ = H X Hᵀ + R is not positive definite). Needs no R⁻¹.
fn closed_loop_radius(form: &FilterForm<'_>, X: &Mat<f64>) -> f64 {
    let FilterForm { F, H, R, S, .. } = *form;
    let mut Sigma = H * X * H.transpose() + R;
    symmetrise(&mut Sigma);
    match Sigma.llt(Side::Lower) {
        Ok(l) => {
            let mut C = F * (X * H.transpose());
            if let Some(S) = S {
                C += S;
            }
            let Kt = l.solve(C.transpose());
            let cl = F - Kt.transpose() * H;
            spectral(cl.as_ref(), false)
        }
        Err(_) => f64::INFINITY,
    }
}
