//! The Joseph and standard covariance forms: the measurement update with `z_k` (innovation,
//! its covariance Σ, a robust factorisation of Σ, the gain, the updated state and
//! covariance) followed by the prediction to `k + 1` (with the exact cross-covariance terms).
#![allow(non_snake_case)]

use faer::Accum::{Add, Replace};

use super::{LN_2PI, State, StepInfo, add_mat_vec, innovation, propagate_mean};
use crate::CovarianceForm;
use crate::kernels::Op::{N, T};
use crate::kernels::Part::{Full, Lower};
use crate::kernels::{RANK_TOL, cholesky, jacobi_eigen, mirror_lower, mm};
use crate::model::Model;
use crate::storage::{Buf, Dims};

/// One step: the update stage (skipped when nothing is observed), then the prediction.
#[inline(always)]
pub(super) fn step<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    z: &[f64],
    u: Option<&[f64]>,
    observed: usize,
) -> StepInfo {
    let info = if observed == 0 {
        no_update(model.dims, st);
        StepInfo::default()
    } else {
        update(model, st, z, observed)
    };
    predict(model, st, u, observed > 0);
    info
}

/// A predict-only step: `x_{k|k} = x_{k|k−1}`, `P_{k|k} = P_{k|k−1}`, no innovation.
#[inline(always)]
pub(super) fn no_update<D: Dims>(d: D, st: &mut State<D>) {
    let (n, m) = (d.n(), d.m());
    st.xf.as_mut_slice()[..n].copy_from_slice(&st.xp.as_slice()[..n]);
    st.pf.as_mut_slice()[..n * n].copy_from_slice(&st.pp.as_slice()[..n * n]);
    st.e.as_mut_slice()[..m].fill(0.0);
    st.sig.as_mut_slice()[..m * m].fill(0.0);
    st.gain.as_mut_slice()[..n * m].fill(0.0);
    st.chol = true;
}

/// The measurement update with `observed ≥ 1` entries of `z`:
/// `e = z − H x⁻`, `Σ = H P⁻ Hᵀ + R`, `K = P⁻ Hᵀ Σ⁺`, `x⁺ = x⁻ + K e`, and `P⁺` in the
/// Joseph or standard form.
#[inline(always)]
pub(super) fn update<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    z: &[f64],
    observed: usize,
) -> StepInfo {
    let d = model.dims;
    let (n, m) = (d.n(), d.m());
    let H = model.H.as_slice();
    innovation(
        m,
        n,
        H,
        st.xp.as_slice(),
        z,
        st.mask.as_slice(),
        st.e.as_mut_slice(),
    );
    let maxdiag = innovation_covariance(model, st);
    let (rank, logdet) = gain(model, st, observed, maxdiag);
    // The unit diagonal of the missing entries served the factorisation only: Σ as
    // reported (`Filter::innovation_covariance`) is zero in their rows and columns.
    let (sig, mask) = (st.sig.as_mut_slice(), st.mask.as_slice());
    for i in (0..m).filter(|&i| !mask[i]) {
        sig[i + i * m] = 0.0;
    }
    let y = &st.y.as_slice()[..m];
    let nis: f64 = y.iter().map(|v| v * v).sum();
    // x⁺ = x⁻ + K e.
    let xf = st.xf.as_mut_slice();
    xf[..n].copy_from_slice(&st.xp.as_slice()[..n]);
    add_mat_vec(n, st.gain.as_slice(), &st.e.as_slice()[..m], xf);
    match st.form {
        CovarianceForm::Standard => standard_update(d, st),
        _ => joseph_update(model, st),
    }
    StepInfo {
        rank,
        nis: Some(nis),
        log_likelihood: -0.5 * (nis + logdet + rank as f64 * LN_2PI),
        iterations: 1,
        ..StepInfo::default()
    }
}

/// `HP = H P⁻` (masked rows zero) and `Σ = (HP) Hᵀ + R` over the observed entries; a
/// missing entry gets a unit diagonal (its gain column is zero, so it drops out exactly).
/// Returns `max_i Σ_ii`.
#[inline(always)]
fn innovation_covariance<D: Dims>(model: &Model<D>, st: &mut State<D>) -> f64 {
    let d = model.dims;
    let (n, m) = (d.n(), d.m());
    let (H, R) = (model.H.as_slice(), model.R.as_slice());
    let mask = st.mask.as_slice();
    let hp = st.hp.as_mut_slice();
    let pp = st.pp.as_slice();
    mm(&d, hp, Full, Replace, 1.0, N(H, m, n), N(pp, n, n));
    for i in 0..m {
        if !mask[i] {
            for j in 0..n {
                hp[i + j * m] = 0.0;
            }
        }
    }
    let sig = st.sig.as_mut_slice();
    mm(&d, sig, Lower, Replace, 1.0, N(hp, m, n), T(H, m, n));
    let mut maxdiag = 0.0_f64;
    for j in 0..m {
        for i in j..m {
            sig[i + j * m] = if mask[i] && mask[j] {
                sig[i + j * m] + R[i + j * m]
            } else if i == j {
                1.0
            } else {
                0.0
            };
        }
        maxdiag = maxdiag.max(sig[j + j * m]);
    }
    mirror_lower(sig, m);
    maxdiag
}

/// Factors Σ and forms the gain: with `Σ⁺ = Z Zᵀ` (`Z = L⁻ᵀ` from a Cholesky factor, or
/// `V Λ₊^{-1/2}` from the eigen-decomposition when Σ is numerically singular), writes
/// `kbar = P Hᵀ Z`, `K = kbar Zᵀ` and the whitened innovation `y = Zᵀ e`. Returns the rank
/// of Σ over the observed entries and the log of its pseudo-determinant.
#[inline(always)]
fn gain<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    observed: usize,
    maxdiag: f64,
) -> (usize, f64) {
    let d = model.dims;
    let (n, m) = (d.n(), d.m());
    let (hp, sig, e) = (st.hp.as_slice(), st.sig.as_slice(), st.e.as_slice());
    // U = P Hᵀ = (HP)ᵀ.
    let uu = st.u.as_mut_slice();
    for j in 0..m {
        for i in 0..n {
            uu[i + j * n] = hp[j + i * m];
        }
    }
    let fact = st.fact.as_mut_slice();
    fact[..m * m].copy_from_slice(&sig[..m * m]);
    let kbar = st.kbar.as_mut_slice();
    let K = st.gain.as_mut_slice();
    let y = st.y.as_mut_slice();
    // Any acceptance that sends more Σ to the eigen-decomposition below gives the same
    // results to round-off (it handles every Σ; the Cholesky is the fast path).
    st.chol = cholesky(fact, m, RANK_TOL * maxdiag);
    if st.chol {
        // kbar = U L⁻ᵀ, K = kbar L⁻¹, y = L⁻¹ e.
        whiten_chol(n, m, fact, uu, kbar);
        unwhiten_chol(n, m, fact, kbar, K);
        for i in 0..m {
            let mut s = e[i];
            for l in 0..i {
                s -= fact[i + l * m] * y[l];
            }
            y[i] = s / fact[i + i * m];
        }
        // log det Σ = 2 ln Π L_ii: one logarithm unless the product leaves the normal range
        // (then one per pivot).
        let prod: f64 = (0..m).map(|i| fact[i + i * m]).product();
        let logdet = if prod.is_normal() {
            2.0 * prod.ln()
        } else {
            (0..m).map(|i| 2.0 * fact[i + i * m].ln()).sum()
        };
        return (observed, logdet);
    }
    // Rank-revealing fallback: Σ = V Λ Vᵀ, Z = V Λ₊^{-1/2} (dropped columns zero).
    let w = st.eigw.as_mut_slice();
    let eigv = st.eigv.as_mut_slice();
    // The failed Cholesky overwrote part of `fact`: start again from Σ.
    fact[..m * m].copy_from_slice(&sig[..m * m]);
    jacobi_eigen(fact, m, eigv, w);
    let lmax = w[..m].iter().fold(0.0_f64, |a, b| a.max(*b));
    let mut r = 0usize;
    let mut logdet = 0.0;
    for j in 0..m {
        if w[j] > RANK_TOL * lmax {
            r += 1;
            logdet += w[j].ln();
            let s = 1.0 / w[j].sqrt();
            for i in 0..m {
                eigv[i + j * m] *= s;
            }
        } else {
            eigv[j * m..j * m + m].fill(0.0);
        }
    }
    mm(&d, kbar, Full, Replace, 1.0, N(uu, n, m), N(eigv, m, m));
    mm(&d, K, Full, Replace, 1.0, N(kbar, n, m), T(eigv, m, m));
    for j in 0..m {
        let mut s = 0.0;
        for i in 0..m {
            s += eigv[i + j * m] * e[i];
        }
        y[j] = s;
    }
    // Missing entries contributed unit eigenvalues (ln 1 = 0) to the count.
    (r.saturating_sub(m - observed), logdet)
}

/// `P⁺ = P⁻ − K Σ Kᵀ = P⁻ − kbar kbarᵀ` (lower triangle, then mirrored).
#[inline(always)]
fn standard_update<D: Dims>(d: D, st: &mut State<D>) {
    let (n, m) = (d.n(), d.m());
    let pf = st.pf.as_mut_slice();
    pf[..n * n].copy_from_slice(&st.pp.as_slice()[..n * n]);
    let kbar = st.kbar.as_slice();
    mm(&d, pf, Lower, Add, -1.0, N(kbar, n, m), T(kbar, n, m));
    mirror_lower(pf, n);
}

/// Joseph form `P⁺ = A P⁻ Aᵀ + K R Kᵀ` with `A = I − K H`, applied as the identity minus a
/// rank-m term from each side (O(n²m) instead of O(n³), same expression):
/// `T = A P⁻ = P⁻ − K (HP)`, `A P⁻ Aᵀ = T − (T Hᵀ) Kᵀ`.
#[inline(always)]
fn joseph_update<D: Dims>(model: &Model<D>, st: &mut State<D>) {
    let d = model.dims;
    let (n, m) = (d.n(), d.m());
    let (H, R) = (model.H.as_slice(), model.R.as_slice());
    let K = st.gain.as_slice();
    let t = st.t.as_mut_slice();
    t[..n * n].copy_from_slice(&st.pp.as_slice()[..n * n]);
    let hp = st.hp.as_slice();
    mm(&d, t, Full, Add, -1.0, N(K, n, m), N(hp, m, n));
    let th = st.tnm.as_mut_slice();
    mm(&d, th, Full, Replace, 1.0, N(t, n, n), T(H, m, n));
    let pf = st.pf.as_mut_slice();
    pf[..n * n].copy_from_slice(&t[..n * n]);
    mm(&d, pf, Lower, Add, -1.0, N(th, n, m), T(K, n, m));
    // K R Kᵀ: gain columns of missing entries are zero, so R needs no masking.
    mm(&d, th, Full, Replace, 1.0, N(K, n, m), N(R, m, m));
    mm(&d, pf, Lower, Add, 1.0, N(th, n, m), T(K, n, m));
    mirror_lower(pf, n);
}

/// The prediction `x_{k+1|k} = F x_{k|k} + B u_k`, `P_{k+1|k} = F P_{k|k} Fᵀ + Q`, plus the
/// cross-covariance terms when the model has S and the step had a measurement.
#[inline(always)]
pub(super) fn predict<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    u: Option<&[f64]>,
    updated: bool,
) {
    let d = model.dims;
    let (n, p) = (d.n(), d.p());
    let (F, Q) = (model.F.as_slice(), model.Q.as_slice());
    let xp = st.xp.as_mut_slice();
    propagate_mean(n, p, F, model.B.as_slice(), st.xf.as_slice(), u, xp);
    let t = st.t.as_mut_slice();
    let pp = st.pp.as_mut_slice();
    let pf = st.pf.as_slice();
    mm(&d, t, Full, Replace, 1.0, N(F, n, n), N(pf, n, n));
    mm(&d, pp, Lower, Replace, 1.0, N(t, n, n), T(F, n, n));
    for j in 0..n {
        for i in j..n {
            pp[i + j * n] += Q[i + j * n];
        }
    }
    if let Some(S) = model.S.as_ref().filter(|_| updated) {
        cross_terms(model, S.as_slice(), st);
    }
    mirror_lower(st.pp.as_mut_slice(), n);
}

/// The correlated-noise terms of the prediction: `x_{k+1|k} += S Σ⁺ e` and
/// `P_{k+1|k} −= F K Sᵀ + S Kᵀ Fᵀ + S Σ⁺ Sᵀ` (lower triangle), with S's columns of missing
/// entries zeroed.
#[inline(always)]
fn cross_terms<D: Dims>(model: &Model<D>, S: &[f64], st: &mut State<D>) {
    let d = model.dims;
    let (n, m) = (d.n(), d.m());
    let F = model.F.as_slice();
    let mask = st.mask.as_slice();
    let sm = st.sm.as_mut_slice();
    for j in 0..m {
        for i in 0..n {
            sm[i + j * n] = if mask[j] { S[i + j * n] } else { 0.0 };
        }
    }
    // gbar = S Z, so S Σ⁺ e = gbar y and S Σ⁺ Sᵀ = gbar gbarᵀ.
    let gbar = st.gbar.as_mut_slice();
    if st.chol {
        whiten_chol(n, m, st.fact.as_slice(), sm, gbar);
    } else {
        let eigv = st.eigv.as_slice();
        mm(&d, gbar, Full, Replace, 1.0, N(sm, n, m), N(eigv, m, m));
    }
    add_mat_vec(n, gbar, &st.y.as_slice()[..m], st.xp.as_mut_slice());
    let fk = st.tnm.as_mut_slice();
    let gain = st.gain.as_slice();
    mm(&d, fk, Full, Replace, 1.0, N(F, n, n), N(gain, n, m));
    let pp = st.pp.as_mut_slice();
    mm(&d, pp, Lower, Add, -1.0, N(fk, n, m), T(sm, n, m));
    mm(&d, pp, Lower, Add, -1.0, N(sm, n, m), T(fk, n, m));
    mm(&d, pp, Lower, Add, -1.0, N(gbar, n, m), T(gbar, n, m));
}

/// `out = U L⁻ᵀ` for lower-triangular `L` (m×m), `U` n×m (column forward substitution).
#[inline(always)]
fn whiten_chol(n: usize, m: usize, L: &[f64], U: &[f64], out: &mut [f64]) {
    for j in 0..m {
        let (done, rest) = out.split_at_mut(j * n);
        let oj = &mut rest[..n];
        oj.copy_from_slice(&U[j * n..j * n + n]);
        for k in 0..j {
            let l = L[j + k * m];
            for (o, dk) in oj.iter_mut().zip(&done[k * n..k * n + n]) {
                *o -= l * dk;
            }
        }
        let inv = 1.0 / L[j + j * m];
        for o in oj.iter_mut() {
            *o *= inv;
        }
    }
}

/// `out = W L⁻¹` for lower-triangular `L` (column back substitution).
#[inline(always)]
fn unwhiten_chol(n: usize, m: usize, L: &[f64], W: &[f64], out: &mut [f64]) {
    for j in (0..m).rev() {
        let (head, rest) = out.split_at_mut((j + 1) * n);
        let oj = &mut head[j * n..j * n + n];
        oj.copy_from_slice(&W[j * n..j * n + n]);
        for k in j + 1..m {
            let l = L[k + j * m];
            for (o, dk) in oj.iter_mut().zip(&rest[(k - j - 1) * n..(k - j) * n]) {
                *o -= l * dk;
            }
        }
        let inv = 1.0 / L[j + j * m];
        for o in oj.iter_mut() {
            *o *= inv;
        }
    }
}
