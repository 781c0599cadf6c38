//! The continuous equations' numerics: the filter-form CARE (the [`Care`](super::Care),
//! and the [`Clqr`](super::Clqr) as its dual) by the structured doubling algorithm after a
//! Cayley transform, its residual, and the read-outs of the steady state and the
//! continuous LQR.
#![allow(non_snake_case)]

use faer::linalg::solvers::{Llt, Solve};
use faer::{Mat, MatRef, Side};

use super::checks::{Modes, eigenvalues, marginal_modes, pbh, psd_sqrt};
use super::problem::{FilterForm, Finish, Inputs, Names, Solved, Time};
use super::sda::sda;
use super::{
    ContinuousSteadyState, Lqr, RiccatiOptions, all_finite, factor_pd, relative, spectral,
    symmetrise, symmetrised, weighted_gram,
};
use crate::Error;

impl Finish for ContinuousSteadyState {
    fn finish(inputs: &Inputs, _: Time, solved: Solved) -> Result<Self, Error> {
        let ([_, H, _, R], _) = inputs.views();
        let P = solved.x;
        let llt = factor_pd("R", R, "the Riccati solvers need R^-1")?;
        let gain = llt.solve(H * &P).transpose().to_owned();
        Ok(ContinuousSteadyState {
            covariance: P,
            gain,
            iterations: solved.iterations,
            relative_residual: solved.relative_residual,
        })
    }
}

/// [`Finish`] of the [`Lqr`] in continuous time.
pub(super) fn continuous_lqr(inputs: &Inputs, solved: Solved) -> Result<Lqr, Error> {
    let ([_, B, _, R], _) = inputs.views();
    let llt = factor_pd("R", R, "the Riccati solvers need R^-1")?;
    let gain = llt.solve(B.transpose() * &solved.x);
    Ok(Lqr {
        gain,
        cost: solved.x,
        iterations: solved.iterations,
        relative_residual: solved.relative_residual,
    })
}

/// The filter-form CARE's relative residual
/// ([`Riccati::residual`](super::Riccati::residual)) on faer views (the solver's own check).
pub(super) fn continuous_residual(form: &FilterForm<'_>, P: MatRef<'_, f64>) -> f64 {
    let FilterForm { F: A, H, Q, R, .. } = *form;
    let HP = H * P;
    let corr = match R.llt(Side::Lower) {
        Ok(llt) => HP.transpose() * llt.solve(&HP),
        Err(_) => return f64::INFINITY,
    };
    let res = A * P + P * A.transpose() - corr + Q;
    relative(res.norm_l2(), P.norm_l2())
}

/// The CARE residual matrix A P + P Aᵀ − P G P + Q (symmetrised; `llt` is R's factor and
/// G = Hᵀ R⁻¹ H, whose norm enters the floor), its relative size and the
/// relative residual's round-off floor ε·(2‖A‖‖P‖ + ‖G‖‖P‖² + ‖Q‖)/‖P‖: what rounding the
/// exact P to double precision alone can leave (see
/// [`RiccatiOptions::residual_floor_factor`]).
fn care_parts(
    A: MatRef<'_, f64>,
    (H, llt, G): (MatRef<'_, f64>, &Llt<f64>, &Mat<f64>),
    Q: MatRef<'_, f64>,
    P: &Mat<f64>,
) -> (Mat<f64>, f64, f64) {
    // P G P as (H P)ᵀ R⁻¹ (H P): an ill-conditioned R (CAREX #8) costs G = Hᵀ R⁻¹ H digits
    // that the solve on H P keeps.
    let HP = H * P;
    let mut res = A * P + P * A.transpose() - HP.transpose() * llt.solve(&HP) + Q;
    symmetrise(&mut res);
    let p = P.norm_l2();
    let floor = f64::EPSILON * (2.0 * A.norm_l2() * p + G.norm_l2() * p * p + Q.norm_l2())
        / if p > 0.0 { p } else { 1.0 };
    (res.clone(), relative(res.norm_l2(), p), floor)
}

/// Newton–Kleinman steps after the doubling at most (each a Lyapunov solve; they converge
/// quadratically from a stabilising start, so the cap is reached only when rounding stalls
/// the residual, which the loop detects before).
const NEWTON_STEPS: usize = 12;

/// Squarings of Smith's iteration at most: with the Cayley factor's spectral radius
/// ρ = 1 − δ, 2^k terms reach round-off when 2^k·δ ≈ 37, so 64 covers δ down to 10⁻¹⁷.
const SMITH_SQUARINGS: usize = 64;

/// Solves the Lyapunov equation A E + E Aᵀ + W = 0 (A stable with eigenvalues `eig`, W
/// symmetric) by Smith's doubling after the Cayley transform: with M = (A − γI)⁻¹ and
/// C = M (A + γI), E = C E Cᵀ + 2γ M W Mᵀ, so E = Σ_k C^k (2γ M W Mᵀ) (Cᵀ)^k, summed by
/// squaring C. The shift γ = √(min|λ|·max|λ|) minimises the largest |(λ + γ)/(λ − γ)| on a
/// real spectrum. `None` if the sum does not settle within [`SMITH_SQUARINGS`] squarings.
fn lyapunov(A: &Mat<f64>, eig: &[(f64, f64)], W: &Mat<f64>) -> Option<Mat<f64>> {
    let n = A.nrows();
    let moduli = eig.iter().map(|&(re, im)| re.hypot(im));
    let (lo, hi) = moduli.fold((f64::INFINITY, 0.0f64), |(lo, hi), m| {
        (lo.min(m), hi.max(m))
    });
    let gamma = (lo * hi).sqrt();
    let I = Mat::<f64>::identity(n, n);
    let lu = (A - gamma * &I).partial_piv_lu();
    let mut C = lu.solve(A + gamma * &I);
    let MW = lu.solve(W);
    let mut E = (2.0 * gamma) * lu.solve(MW.transpose());
    symmetrise(&mut E);
    for _ in 0..SMITH_SQUARINGS {
        let mut next = &E + &C * &E * C.transpose();
        symmetrise(&mut next);
        let change = (&next - &E).norm_l2();
        E = next;
        C = &C * &C;
        if !all_finite(E.as_ref()) || !all_finite(C.as_ref()) {
            return None;
        }
        if change <= f64::EPSILON * E.norm_l2() || C.norm_l2() <= f64::EPSILON {
            return Some(E);
        }
    }
    None
}

/// Newton–Kleinman refinement of a CARE solution P (filter form A P + P Aᵀ − P G P + Q = 0):
/// each step solves A_k E + E A_kᵀ + Res(P_k) = 0 with A_k = A − P_k G and takes
/// P_{k+1} = P_k + E (then Res(P_{k+1}) = −E G E). Follows the iterates while they stay
/// stabilising (A_k's eigenvalues, which also give the Lyapunov shift, in the open left
/// half-plane), keeps the stabilising one of least residual, and stops when the residual is
/// at a few ε or has twice failed to halve (rounding has stalled it: the answer is then the
/// best this arithmetic gives, which is what the acceptance gate is measured against).
/// Returns (P, relative residual, floor); the doubling's own P when it is not stabilising
/// (the final check then refuses it).
fn newton_kleinman(
    A: MatRef<'_, f64>,
    gain: (MatRef<'_, f64>, &Llt<f64>, &Mat<f64>),
    Q: MatRef<'_, f64>,
    P: Mat<f64>,
) -> (Mat<f64>, f64, f64) {
    let (H, llt, _) = gain;
    let (mut res, mut rel, mut floor) = care_parts(A, gain, Q, &P);
    let start = (P.clone(), rel, floor);
    let mut best: Option<(Mat<f64>, f64, f64)> = None;
    let mut current = P;
    let mut stalls = 0;
    for step in 0..=NEWTON_STEPS {
        let Ak = A - llt.solve(H * &current).transpose() * H;
        let Ok(eig) = eigenvalues(Ak.as_ref(), "Newton-Kleinman closed loop") else {
            break;
        };
        if eig.iter().any(|&(re, _)| re.is_nan() || re >= 0.0) {
            break;
        }
        match &best {
            Some(b) if rel > 0.5 * b.1 => stalls += 1,
            _ => stalls = 0,
        }
        if best.as_ref().is_none_or(|b| rel < b.1) {
            best = Some((current.clone(), rel, floor));
        }
        if stalls >= 2 || rel.is_nan() || rel <= 4.0 * f64::EPSILON || step == NEWTON_STEPS {
            break;
        }
        let Some(E) = lyapunov(&Ak, &eig, &res) else {
            break;
        };
        current += &E;
        symmetrise(&mut current);
        (res, rel, floor) = care_parts(A, gain, Q, &current);
        if !rel.is_finite() {
            break;
        }
    }
    best.unwrap_or(start)
}

/// ‖ℋ‖_F of the Hamiltonian ℋ = [[A_c, −G], [−Q, −A_cᵀ]], from its blocks (ℋ is never formed).
pub(super) fn hamiltonian_norm(Ac: &Mat<f64>, G: &Mat<f64>, Q: &Mat<f64>) -> f64 {
    (2.0 * Ac.squared_norm_l2() + G.squared_norm_l2() + Q.squared_norm_l2()).sqrt()
}

/// PBH tests and SDA-after-Cayley for the filter-form CARE A P + P Aᵀ − P Hᵀ R⁻¹ H P + Q = 0.
pub(super) fn continuous_dual(
    form: &FilterForm<'_>,
    opts: &RiccatiOptions,
    names: &Names,
) -> Result<Solved, Error> {
    let FilterForm { F: A, H, Q, R, .. } = *form;
    let n = A.nrows();
    let llt = factor_pd("R", R, "the Riccati solvers need R^-1")?;
    // The CARE keeps the stricter test (no unreachable mode on or right of the imaginary
    // axis): its doubling has no restart for a Q that leaves an unstable mode unexcited.
    let modes = marginal_modes(A, true, Modes::OnOrOutside, opts)?;
    if let Some((re, im)) = pbh(A, H, &modes, opts)? {
        return Err(names.detect.error(re, im));
    }
    if !modes.is_empty() {
        let Qh = psd_sqrt(Q)?;
        if let Some((re, im)) = pbh(A.transpose(), Qh.as_ref(), &modes, opts)? {
            return Err(names.stab.error(re, im));
        }
    }
    let G = weighted_gram(H, &llt);
    let Hc = symmetrised(Q);
    let Ac = A.transpose().to_owned();
    // γ ≥ ‖ℋ‖_F > ρ(ℋ): ℋ − γI is non-singular, so the Cayley transform exists.
    let gamma = 1.01 * hamiltonian_norm(&Ac, &G, &Hc) + f64::MIN_POSITIVE.sqrt();
    let I = Mat::<f64>::identity(n, n);
    let Ag = &Ac - gamma * &I;
    let Ag_lu = Ag.partial_piv_lu();
    let Y = Ag_lu.solve_transpose(&Hc); // A_γ⁻ᵀ Q
    let V = &Ag + &G * &Y;
    let V_lu = V.partial_piv_lu();
    // V⁻¹ itself is the SDA's initial matrix here (A₀ = I + 2γV⁻¹): obtained as the solve V X = I.
    let A0 = &I + (2.0 * gamma) * V_lu.solve(&I);
    let Z = Ag_lu.solve(&G); // A_γ⁻¹ G, so G A_γ⁻ᵀ = Zᵀ
    let mut G0 = (2.0 * gamma) * V_lu.solve(Z.transpose());
    let mut H0 = (2.0 * gamma) * V_lu.solve_transpose(Y.transpose()); // V⁻ᵀ Q A_γ⁻¹
    symmetrise(&mut G0);
    symmetrise(&mut H0);
    // All three come from the factorisations of A_γ and V: a non-finite value in either
    // reaches all three (inf·0 is NaN).
    if !all_finite(A0.as_ref()) || !all_finite(G0.as_ref()) || !all_finite(H0.as_ref()) {
        return Err(Error::RiccatiNoConvergence {
            equation: names.equation,
            iterations: 0,
            reason: "Cayley transform singular",
        });
    }
    let (X, iterations) = sda(A0, G0, H0, opts, names.equation)?;
    // The doubling after a Cayley transform loses digits on a badly scaled or nearly
    // unstabilisable problem (CAREX #6, #17): Newton–Kleinman steps from its answer bring the
    // residual down to what the conditioning allows.
    let (X, relative_residual, floor) = newton_kleinman(A, (H, &llt, &G), Q, X);
    let cl = A - llt.solve(H * &X).transpose() * H;
    let abscissa = spectral(cl.as_ref(), true);
    Solved {
        x: X,
        iterations,
        relative_residual,
        floor,
    }
    .checked(abscissa, Time::Continuous, opts, names.equation)
}
