//! The continuous equations' numerics: the filter-form CARE (the [`Care`](super::Care),
//! and the [`Clqr`](super::Clqr) as its dual) by the structured doubling algorithm after a
//! Cayley transform, its residual, and the read-outs of the steady state and the
//! continuous LQR.
#![allow(non_snake_case)]

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, Side};

use super::checks::{Modes, marginal_modes, pbh, psd_sqrt};
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
    let relative_residual = continuous_residual(form, X.as_ref());
    let Kt = llt.solve(H * &X);
    let cl = A.to_owned() - Kt.transpose() * H;
    let abscissa = spectral(cl.as_ref(), true);
    Solved {
        x: X,
        iterations,
        relative_residual,
    }
    .checked(abscissa, Time::Continuous, opts, names.equation)
}
