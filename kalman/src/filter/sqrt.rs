//! The square-root covariance form. One pre-array, row-major, `m + 2n` rows by `m + 2n`
//! columns:
//!
//! ```text
//!   [ Gv  H L ]   z rows (m)       Gv, Gw: rows of G with G Gᵀ = [[R, Sᵀ], [S, Q]]
//!   [ 0     L ]   current rows (n)  L: factor of P_{k|k-1}
//!   [ Gw  F L ]   next rows (n)
//! ```
//!
//! Householder LQ of the z rows gives `Σ^{1/2}` and, in the rows below, the whitened gains
//! `K̄ = P Hᵀ Σ^{-T/2}` and `K̄ₚ = (F P Hᵀ + S) Σ^{-T/2}`; triangularising the remaining
//! columns of each block separately gives the factors of `P_{k|k}` and `P_{k+1|k}`. Rows of
//! missing entries are zero and drop out as rank-deficient rows.
#![allow(non_snake_case)]

use faer::Accum::Replace;

use super::{LN_2PI, State, StepInfo, innovation, propagate_mean};
use crate::kernels::Op::{N, T};
use crate::kernels::Part::{Full, Lower};
use crate::kernels::{RANK_TOL, cholesky, lq_rows, mirror_lower, mm};
use crate::model::Model;
use crate::storage::{Buf, Dims};

/// One step: build the pre-array, triangularise it, read the estimates out of it.
#[inline(always)]
pub(super) fn step<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    z: &[f64],
    u: Option<&[f64]>,
) -> StepInfo {
    let d = model.dims;
    let (n, m) = (d.n(), d.m());
    let ld = m + 2 * n;
    let maxdiag = pre_array(model, st);
    let arr = &mut st.arr[..ld * ld];
    let piv = st.piv.as_mut_slice();
    let r = lq_rows(arr, ld, 0..m, ld, 0, ld, RANK_TOL * maxdiag, piv);
    let pivx = st.pivx.as_mut_slice();
    lq_rows(arr, ld, m..m + n, m + n, r, ld, 0.0, pivx);
    lq_rows(arr, ld, m + n..m + 2 * n, m + 2 * n, r, ld, 0.0, pivx);
    let info = estimates(model, st, z, u, r);
    covariances(model, st, r);
    info
}

/// Fills the pre-array from the joint noise factor, `H L` and `F L`; returns the largest
/// squared norm of an observed z row (the scale of the rank tolerance).
#[inline(always)]
fn pre_array<D: Dims>(model: &Model<D>, st: &mut State<D>) -> f64 {
    let d = model.dims;
    let (n, m) = (d.n(), d.m());
    let ld = m + 2 * n;
    let (F, H) = (model.F.as_slice(), model.H.as_slice());
    let G = &model.joint;
    let (gvv, gvw) = (G.vv.as_slice(), G.vw.as_slice());
    let (gwv, gww) = (G.wv.as_slice(), G.ww.as_slice());
    let mask = st.mask.as_slice();
    let lp = st.lp.as_slice();
    // HL (m×n) into hp, FL (n×n) into t.
    let hl = st.hp.as_mut_slice();
    mm(&d, hl, Full, Replace, 1.0, N(H, m, n), N(lp, n, n));
    let fl = st.t.as_mut_slice();
    mm(&d, fl, Full, Replace, 1.0, N(F, n, n), N(lp, n, n));
    let arr = &mut st.arr[..ld * ld];
    let mut maxdiag = 0.0_f64;
    for i in 0..m {
        let row = &mut arr[i * ld..(i + 1) * ld];
        if mask[i] {
            for j in 0..m {
                row[j] = gvv[i + j * m];
            }
            for j in 0..n {
                row[m + j] = gvw[i + j * m];
                row[n + m + j] = hl[i + j * m];
            }
            maxdiag = maxdiag.max(row.iter().map(|v| v * v).sum());
        } else {
            row.fill(0.0);
        }
    }
    for i in 0..n {
        let row = &mut arr[(m + i) * ld..(m + i + 1) * ld];
        row[..n + m].fill(0.0);
        for j in 0..n {
            row[n + m + j] = lp[i + j * n];
        }
        let row = &mut arr[(m + n + i) * ld..(m + n + i + 1) * ld];
        for j in 0..m {
            row[j] = gwv[i + j * n];
        }
        for j in 0..n {
            row[m + j] = gww[i + j * n];
            row[n + m + j] = fl[i + j * n];
        }
    }
    maxdiag
}

/// From the triangularised pre-array with `r` pivots: the innovation, its whitened form
/// `y = Σ^{-1/2} e`, `x_{k|k} = x⁻ + K̄ y`, `x_{k+1|k} = F x⁻ + B u + K̄ₚ y`, and the
/// step's statistics.
#[inline(always)]
fn estimates<D: Dims>(
    model: &Model<D>,
    st: &mut State<D>,
    z: &[f64],
    u: Option<&[f64]>,
    r: usize,
) -> StepInfo {
    let d = model.dims;
    let (n, m, p) = (d.n(), d.m(), d.p());
    let ld = m + 2 * n;
    let arr = &st.arr[..ld * ld];
    let (F, H, B) = (model.F.as_slice(), model.H.as_slice(), model.B.as_slice());
    let piv = st.piv.as_slice();
    let xp = st.xp.as_mut_slice();
    let e = st.e.as_mut_slice();
    innovation(m, n, H, xp, z, st.mask.as_slice(), e);
    let y = st.y.as_mut_slice();
    let pivrow = st.pivrow.as_mut_slice();
    let mut logdet = 0.0;
    for i in 0..m {
        if let Some(c) = piv[i] {
            let mut s = e[i];
            for l in 0..c {
                s -= arr[i * ld + l] * y[l];
            }
            let dgl = arr[i * ld + c];
            y[c] = s / dgl;
            pivrow[c] = i;
            logdet += 2.0 * dgl.abs().ln();
        }
    }
    let mask = st.mask.as_slice();
    // Only to save the work: with no dependent observed row `ln_det_dependent` adds the
    // log-determinant of an empty matrix, 0.
    if (0..m).any(|i| mask[i] && piv[i].is_none()) {
        let (w, g) = (st.sig.as_mut_slice(), st.eigv.as_mut_slice());
        logdet += ln_det_dependent(&d, arr, ld, r, (piv, pivrow, mask), w, g);
    }
    let nis: f64 = y[..r].iter().map(|v| v * v).sum();
    let xf = st.xf.as_mut_slice();
    let xt = st.xtmp.as_mut_slice();
    propagate_mean(n, p, F, B, xp, u, xt);
    for i in 0..n {
        let mut a = xp[i];
        let mut b = xt[i];
        for l in 0..r {
            a += arr[(m + i) * ld + l] * y[l];
            b += arr[(m + n + i) * ld + l] * y[l];
        }
        xf[i] = a;
        xp[i] = b;
    }
    StepInfo {
        rank: r,
        nis: Some(nis),
        // With no pivot every term is 0: the branch only keeps the sign of 0.0 (`r ≥ 0`
        // would give −0.0, the same number).
        log_likelihood: if r > 0 {
            -0.5 * (nis + logdet + r as f64 * LN_2PI)
        } else {
            0.0
        },
        iterations: 1,
        ..StepInfo::default()
    }
}

/// What exactly dependent observed z rows add to `ln pdet Σ` beyond the kept pivots'
/// `ln det(L₁)²`: `ln det(I + W Wᵀ)`. With `A` the first `r` columns of the z rows
/// (`Σ = A Aᵀ`, full column rank), `L₁` its pivot rows (lower triangular in pivot order) and
/// `C` its dependent rows, `pdet Σ = det(AᵀA) = det(L₁ᵀL₁ + CᵀC) = det(L₁)² det(I + WᵀW)`
/// with `W = C L₁⁻¹`, and `det(I + WᵀW) = det(I + WWᵀ)`. Every eigenvalue of `I + WWᵀ` is
/// at least 1, so its Cholesky fails only on non-finite numbers (a diverged step, which the
/// caller reports). `w` (q×r) and `g` (q×q) are scratch of at least m² entries.
fn ln_det_dependent<D: Dims>(
    d: &D,
    arr: &[f64],
    ld: usize,
    r: usize,
    (piv, pivrow, mask): (&[Option<usize>], &[usize], &[bool]),
    w: &mut [f64],
    g: &mut [f64],
) -> f64 {
    // Row q of W (row-major, r per row) solves wᵀ L₁ = c, by back substitution.
    let mut q = 0;
    for i in 0..d.m() {
        if !mask[i] || piv[i].is_some() {
            continue;
        }
        let wq = &mut w[q * r..(q + 1) * r];
        for l in (0..r).rev() {
            let mut s = arr[i * ld + l];
            for k in l + 1..r {
                s -= wq[k] * arr[pivrow[k] * ld + l];
            }
            wq[l] = s / arr[pivrow[l] * ld + l];
        }
        q += 1;
    }
    // Stored column-major, w is Wᵀ (r×q): G = W Wᵀ + I, lower triangle.
    mm(d, g, Lower, Replace, 1.0, T(w, r, q), N(w, r, q));
    for i in 0..q {
        g[i + i * q] += 1.0;
    }
    if cholesky(g, q, 0.0) {
        (0..q).map(|i| 2.0 * g[i + i * q].ln()).sum()
    } else {
        f64::NAN
    }
}

/// From the triangularised pre-array with `r` pivots: the factors and covariances
/// `P_{k|k} = L_f L_fᵀ`, `P_{k+1|k} = L L ᵀ`, `Σ = Σ^{1/2} Σ^{T/2}` over the observed
/// entries, and the gain `K` from `K Σ^{1/2} = K̄`.
#[inline(always)]
fn covariances<D: Dims>(model: &Model<D>, st: &mut State<D>, r: usize) {
    let d = model.dims;
    let (n, m) = (d.n(), d.m());
    let ld = m + 2 * n;
    let arr = &st.arr[..ld * ld];
    let lf = st.a.as_mut_slice();
    let lpm = st.lp.as_mut_slice();
    for j in 0..n {
        for i in 0..n {
            lf[i + j * n] = arr[(m + i) * ld + r + j];
            lpm[i + j * n] = arr[(m + n + i) * ld + r + j];
        }
    }
    let pf = st.pf.as_mut_slice();
    mm(&d, pf, Lower, Replace, 1.0, N(lf, n, n), T(lf, n, n));
    mirror_lower(pf, n);
    let pp = st.pp.as_mut_slice();
    mm(&d, pp, Lower, Replace, 1.0, N(lpm, n, n), T(lpm, n, n));
    mirror_lower(pp, n);
    let sig = st.sig.as_mut_slice();
    for j in 0..m {
        for i in 0..m {
            let mut s = 0.0;
            for l in 0..r {
                s += arr[i * ld + l] * arr[j * ld + l];
            }
            sig[i + j * m] = s;
        }
    }
    let (piv, pivrow) = (st.piv.as_slice(), st.pivrow.as_slice());
    let K = st.gain.as_mut_slice();
    K[..n * m].fill(0.0);
    for l in (0..r).rev() {
        let il = pivrow[l];
        let dgl = arr[il * ld + l];
        for row in 0..n {
            let mut s = arr[(m + row) * ld + l];
            for i2 in 0..m {
                // (`c ≥ l` would add the row pivoted at l, whose gain is still the zero it
                // was filled with.)
                if piv[i2].is_some_and(|c| c > l) {
                    s -= K[row + i2 * n] * arr[i2 * ld + l];
                }
            }
            K[row + il * n] = s / dgl;
        }
    }
}
