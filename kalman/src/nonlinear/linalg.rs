//! Small dense kernels of the nonlinear filters on column-major slices: products, the
//! (semi)definite Cholesky factor and triangular solves. Plain loops (the nonlinear filters
//! are for small n, where loops beat a GEMM call); nothing here allocates.
#![allow(non_snake_case)]

/// `C = A·B (+ C if acc)`: `A` is `r`×`k`, `B` is `k`×`c`, `C` is `r`×`c` (leading
/// dimensions equal to the row counts).
#[inline(always)]
pub(crate) fn mul(C: &mut [f64], A: &[f64], B: &[f64], r: usize, k: usize, c: usize, acc: bool) {
    for j in 0..c {
        let col = &mut C[j * r..(j + 1) * r];
        if !acc {
            col.fill(0.0);
        }
        for p in 0..k {
            let s = B[p + j * k];
            let a = &A[p * r..(p + 1) * r];
            for (ci, ai) in col.iter_mut().zip(a) {
                *ci += s * ai;
            }
        }
    }
}

/// `C = A·Bᵀ (+ C if acc)`: `A` is `r`×`k`, `B` is `c`×`k`, `C` is `r`×`c`.
#[inline(always)]
pub(crate) fn mul_nt(C: &mut [f64], A: &[f64], B: &[f64], r: usize, k: usize, c: usize, acc: bool) {
    for j in 0..c {
        let col = &mut C[j * r..(j + 1) * r];
        if !acc {
            col.fill(0.0);
        }
        for p in 0..k {
            let s = B[j + p * c];
            let a = &A[p * r..(p + 1) * r];
            for (ci, ai) in col.iter_mut().zip(a) {
                *ci += s * ai;
            }
        }
    }
}

/// `C = Aᵀ·B (+ C if acc)`: `A` is `k`×`r`, `B` is `k`×`c`, `C` is `r`×`c`.
#[inline(always)]
pub(crate) fn mul_tn(C: &mut [f64], A: &[f64], B: &[f64], r: usize, k: usize, c: usize, acc: bool) {
    for j in 0..c {
        let b = &B[j * k..(j + 1) * k];
        for i in 0..r {
            let a = &A[i * k..(i + 1) * k];
            let s: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
            if acc {
                C[i + j * r] += s;
            } else {
                C[i + j * r] = s;
            }
        }
    }
}

/// `C += w·a·bᵀ` (`a` an `r`-vector, `b` a `c`-vector, `C` `r`×`c`).
#[inline(always)]
pub(crate) fn rank1(C: &mut [f64], w: f64, a: &[f64], b: &[f64], r: usize, c: usize) {
    for j in 0..c {
        let s = w * b[j];
        for (ci, ai) in C[j * r..(j + 1) * r].iter_mut().zip(a) {
            *ci += s * ai;
        }
    }
}

pub(crate) use crate::kernels::symmetrise;

/// Largest absolute diagonal entry of the `n`×`n` `a`.
#[inline(always)]
pub(crate) fn max_diag(a: &[f64], n: usize) -> f64 {
    (0..n).fold(0.0_f64, |s, i| s.max(a[i + i * n].abs()))
}

/// Lower Cholesky factor `L` (`L Lᵀ = a`) of the symmetric PSD `n`×`n` `a`, written to `L`
/// (upper triangle zeroed), with the reciprocals of its diagonal in `inv` (the solves below
/// multiply by them: no division in their dependency chains). A pivot `d_j` at or below
/// `zero_tol·a_jj` (entry j is, to that share of its own variance, a combination of the
/// earlier ones, whatever its units; and any pivot of a zero diagonal entry) or below zero
/// but above `−neg_tol·max_diag` (round-off) is a zero pivot: its column of `L` is zero and
/// its `inv` entry 0 (the semidefinite case). A pivot below `−neg_tol·max_diag` is
/// returned as `Err(pivot)`.
///
/// Computed as `a = U D Uᵀ` first (see [`ldl_pass`]): the chain from one pivot to the next
/// holds one division and no square root; the square roots come after, all independent.
#[inline(always)]
pub(crate) fn psd_cholesky(
    a: &[f64],
    n: usize,
    L: &mut [f64],
    inv: &mut [f64],
    zero_tol: f64,
    neg_tol: f64,
) -> Result<(), f64> {
    let (a, L, inv) = (&a[..n * n], &mut L[..n * n], &mut inv[..n]);
    let scale = max_diag(a, n);
    for j in 0..n {
        L[j + j * n] = a[j + j * n];
        for i in 0..j {
            L[i + j * n] = 0.0;
        }
        for i in j + 1..n {
            L[i + j * n] = a[i + j * n];
        }
    }
    ldl_pass(L, n, inv, |d, ajj| {
        if d.is_nan() || d < -neg_tol * scale {
            Err(d)
        } else {
            Ok(d > zero_tol * ajj)
        }
    })?;
    scale_columns(L, n, inv);
    Ok(())
}

/// Lower Cholesky factor of a positive definite `n`×`n` `a` in place (lower triangle), with
/// the reciprocals of its diagonal in `inv`. Returns `Err(pivot)` for the first pivot `d_j`
/// at or below `tol·a_jj` (see [`psd_cholesky`]). Computed as [`psd_cholesky`].
#[inline(always)]
pub(crate) fn pd_cholesky(a: &mut [f64], n: usize, inv: &mut [f64], tol: f64) -> Result<(), f64> {
    let (a, inv) = (&mut a[..n * n], &mut inv[..n]);
    ldl_pass(a, n, inv, |d, ajj| {
        if d.is_nan() || d <= tol * ajj {
            Err(d)
        } else {
            Ok(true)
        }
    })?;
    scale_columns(a, n, inv);
    Ok(())
}

/// The first pass of the Cholesky factorisations, in place on the lower triangle of `a`:
/// `a = U D Uᵀ` (U unit lower) held as `s_ij = U_ij d_j` below the diagonal (the pivot
/// column before its division), `d_j` on it and `1/d_j` in `inv`. With `w_k = s_jk / d_k`,
/// `d_j = a_jj − Σ_{k<j} s_jk w_k` and `s_ij = a_ij − Σ_{k<j} s_ik w_k` (i > j). `pivot`
/// judges each `d_j`: `Err` stops, `Ok(false)` makes it a zero pivot (its column and its
/// `inv` entry zero, so later columns ignore it); it sees `d_j` and `a_jj`, so that it can
/// judge `d_j / a_jj = 1 − R²_j`, the share of entry j's variance that the earlier entries
/// do not explain, whatever the units of each entry.
#[inline(always)]
fn ldl_pass(
    a: &mut [f64],
    n: usize,
    inv: &mut [f64],
    pivot: impl Fn(f64, f64) -> Result<bool, f64>,
) -> Result<(), f64> {
    for j in 0..n {
        let ajj = a[j + j * n];
        let mut d = ajj;
        for k in 0..j {
            let s = a[j + k * n];
            d -= s * (s * inv[k]);
        }
        if !pivot(d, ajj)? {
            for i in j..n {
                a[i + j * n] = 0.0;
            }
            inv[j] = 0.0;
            continue;
        }
        a[j + j * n] = d;
        inv[j] = 1.0 / d;
        for i in j + 1..n {
            let mut s = a[i + j * n];
            for k in 0..j {
                s -= a[i + k * n] * (a[j + k * n] * inv[k]);
            }
            a[i + j * n] = s;
        }
    }
    Ok(())
}

/// The second pass: `L_jj = √d_j`, `L_ij = s_ij / √d_j` and `inv_j = 1/√d_j` from
/// [`ldl_pass`]'s output (a zero pivot stays a zero column with `inv_j` 0). The columns are
/// independent: their square roots and divisions overlap.
#[inline(always)]
fn scale_columns(a: &mut [f64], n: usize, inv: &mut [f64]) {
    for j in 0..n {
        // A zero pivot was stored as exactly 0; any other is positive (+∞ included, which
        // gives `inv_j` 0 as the direct factorisation did).
        if a[j + j * n] <= 0.0 {
            continue;
        }
        let root = a[j + j * n].sqrt();
        let r = 1.0 / root;
        a[j + j * n] = root;
        inv[j] = r;
        for i in j + 1..n {
            a[i + j * n] *= r;
        }
    }
}

/// Solves `L y = b` in place (`L` lower `n`×`n`, leading dimension `n`, `inv` the
/// reciprocals of its diagonal); a zero pivot (`inv` 0) gives a zero component (the
/// minimum-norm choice for a semidefinite factor).
#[inline(always)]
pub(crate) fn forward(L: &[f64], inv: &[f64], n: usize, b: &mut [f64]) {
    let (L, inv, b) = (&L[..n * n], &inv[..n], &mut b[..n]);
    for j in 0..n {
        let y = b[j] * inv[j];
        b[j] = y;
        for i in j + 1..n {
            b[i] -= L[i + j * n] * y;
        }
    }
}

/// `B ← B (L Lᵀ)⁻¹` for the `rows`×`n` `B`, a column at a time (`Y Lᵀ = B`, then
/// `X L = Y`): each column operation runs down all rows at once; zero pivots as in
/// [`forward`].
#[inline(always)]
pub(crate) fn right_solve(L: &[f64], inv: &[f64], n: usize, B: &mut [f64], rows: usize) {
    let (L, inv, B) = (&L[..n * n], &inv[..n], &mut B[..rows * n]);
    // Y Lᵀ = B: Y_j = (B_j − Σ_{k<j} L_jk Y_k) / L_jj.
    for j in 0..n {
        let (done, rest) = B.split_at_mut(j * rows);
        let bj = &mut rest[..rows];
        for k in 0..j {
            let l = L[j + k * n];
            for (b, y) in bj.iter_mut().zip(&done[k * rows..(k + 1) * rows]) {
                *b -= l * y;
            }
        }
        for b in bj.iter_mut() {
            *b *= inv[j];
        }
    }
    // X L = Y: X_j = (Y_j − Σ_{k>j} L_kj X_k) / L_jj.
    for j in (0..n).rev() {
        let (head, done) = B.split_at_mut((j + 1) * rows);
        let bj = &mut head[j * rows..];
        for k in j + 1..n {
            let l = L[k + j * n];
            for (b, x) in bj.iter_mut().zip(&done[(k - j - 1) * rows..(k - j) * rows]) {
                *b -= l * x;
            }
        }
        for b in bj.iter_mut() {
            *b *= inv[j];
        }
    }
}

/// `eᵀ (L Lᵀ)⁻¹ e` and `log det (L Lᵀ)`; `tmp` is an `n`-vector workspace.
#[inline(always)]
pub(crate) fn nis_logdet(
    L: &[f64],
    inv: &[f64],
    n: usize,
    e: &[f64],
    tmp: &mut [f64],
) -> (f64, f64) {
    tmp[..n].copy_from_slice(&e[..n]);
    forward(L, inv, n, &mut tmp[..n]);
    let nis = tmp[..n].iter().map(|v| v * v).sum();
    // One logarithm of the product of the pivots, unless that product under- or overflows.
    let prod = (0..n).map(|j| L[j + j * n]).product::<f64>();
    let logdet = if prod.is_normal() {
        2.0 * prod.ln()
    } else {
        2.0 * (0..n).map(|j| L[j + j * n].ln()).sum::<f64>()
    };
    (nis, logdet)
}

/// Joseph form `P⁺ = A P Aᵀ + K R Kᵀ` with `A = I − K H` (`K` `n`×`mo`, `H` `mo`×`n`,
/// `R` `mo`×`mo`): the lower triangle is computed and mirrored, so the result is exactly
/// symmetric. `A`, `T` are `n`×`n` and `KR` `n`×`mo` workspaces.
#[inline(always)]
pub(crate) fn joseph(
    P: &[f64],
    K: &[f64],
    H: &[f64],
    R: &[f64],
    n: usize,
    mo: usize,
    out: &mut [f64],
    A: &mut [f64],
    T: &mut [f64],
    KR: &mut [f64],
) {
    let (K, H, R) = (&K[..n * mo], &H[..mo * n], &R[..mo * mo]);
    let (A, T, KR, out) = (
        &mut A[..n * n],
        &mut T[..n * n],
        &mut KR[..n * mo],
        &mut out[..n * n],
    );
    mul(A, K, H, n, mo, n, false);
    for v in A.iter_mut() {
        *v = -*v;
    }
    for i in 0..n {
        A[i + i * n] += 1.0;
    }
    mul(T, A, P, n, n, n, false);
    mul(KR, K, R, n, mo, mo, false);
    symmetric_sum(out, T, A, KR, K, n, mo);
}

/// The Joseph form of [`joseph`] given the factor `L` of `P` (`P = L Lᵀ`, `L` lower `n`×`n`)
/// and `G` (`n`×`mo`) with `H L = Gᵀ`: `(I − K H) L = M = L − K Gᵀ`, so
/// `P⁺ = M Mᵀ + K R Kᵀ` — a Gram matrix plus `K R Kᵀ`, symmetric PSD by its form as the
/// Joseph form is, without forming H or `(I − K H) P`. Only the lower triangle is computed,
/// then mirrored. `M` (`n`×`n`) and `KR` (`n`×`mo`) are workspaces.
#[inline(always)]
pub(crate) fn factored_joseph(
    L: &[f64],
    K: &[f64],
    G: &[f64],
    R: &[f64],
    n: usize,
    mo: usize,
    out: &mut [f64],
    M: &mut [f64],
    KR: &mut [f64],
) {
    let (L, K, G, R) = (&L[..n * n], &K[..n * mo], &G[..n * mo], &R[..mo * mo]);
    let (M, KR, out) = (&mut M[..n * n], &mut KR[..n * mo], &mut out[..n * n]);
    M.copy_from_slice(L);
    for a in 0..mo {
        let k = &K[a * n..(a + 1) * n];
        for j in 0..n {
            let g = G[j + a * n];
            for (m, ki) in M[j * n..(j + 1) * n].iter_mut().zip(k) {
                *m -= ki * g;
            }
        }
    }
    mul(KR, K, R, n, mo, mo, false);
    symmetric_sum(out, M, M, KR, K, n, mo);
}

/// `out = X Yᵀ + KR Kᵀ` (`X`, `Y` `n`×`n`; `KR`, `K` `n`×`mo`) for a sum its caller knows
/// to be symmetric (the two Joseph forms): the lower triangle computed, then mirrored.
#[inline(always)]
fn symmetric_sum(
    out: &mut [f64],
    X: &[f64],
    Y: &[f64],
    KR: &[f64],
    K: &[f64],
    n: usize,
    mo: usize,
) {
    for j in 0..n {
        for i in j..n {
            let mut s = 0.0;
            for k in 0..n {
                s += X[i + k * n] * Y[j + k * n];
            }
            for a in 0..mo {
                s += KR[i + a * n] * K[j + a * n];
            }
            out[i + j * n] = s;
        }
    }
    mirror_lower(out, n);
}

/// The nonzero pattern of a square column-major matrix by rows, for Jacobians that are
/// mostly zero (a model augmented with constant states: their rows are unit rows). The
/// sparse products below sum the same nonzero terms in the same order as the dense loops
/// of [`mul`] and [`mul_nt`], so they give the same bits.
#[derive(Clone, Debug, Default)]
pub(crate) struct RowPattern {
    /// Row i's nonzero columns are `cols[ptr[i]..ptr[i + 1]]`, ascending.
    ptr: Vec<usize>,
    cols: Vec<usize>,
    /// The pattern describes the matrix last passed to [`RowPattern::find`], and it is
    /// sparse enough to pay.
    pub(crate) sparse: bool,
}

impl RowPattern {
    /// Workspaces for n×n matrices (allocated here, never in [`RowPattern::find`]).
    pub(crate) fn new(n: usize) -> Self {
        Self {
            ptr: vec![0; n + 1],
            cols: vec![0; n * n],
            sparse: false,
        }
    }

    /// Reads the pattern of `a` (n×n); sets `sparse` when n ≥ 8 and at most a third of the
    /// entries are nonzero (below that the dense loops, which vectorise, are as fast).
    pub(crate) fn find(&mut self, a: &[f64], n: usize) {
        let mut nnz = 0;
        for i in 0..n {
            self.ptr[i] = nnz;
            for j in 0..n {
                if a[i + j * n] != 0.0 {
                    self.cols[nnz] = j;
                    nnz += 1;
                }
            }
        }
        self.ptr[n] = nnz;
        self.sparse = n >= 8 && 3 * nnz <= n * n;
    }

    fn row(&self, i: usize) -> &[usize] {
        &self.cols[self.ptr[i]..self.ptr[i + 1]]
    }

    /// `T = A·B` for this pattern's `A` (n×n) and an n×n `B`, as [`mul`] computes it.
    pub(crate) fn mul(&self, T: &mut [f64], A: &[f64], B: &[f64], n: usize) {
        for j in 0..n {
            let b = &B[j * n..(j + 1) * n];
            for i in 0..n {
                let mut s = 0.0;
                for &p in self.row(i) {
                    s += b[p] * A[i + p * n];
                }
                T[i + j * n] = s;
            }
        }
    }

    /// `C = B·Aᵀ` for this pattern's `A` and an n×n `B`, as [`mul_nt`] computes it.
    pub(crate) fn mul_nt(&self, C: &mut [f64], B: &[f64], A: &[f64], n: usize) {
        for j in 0..n {
            let cols = self.row(j);
            for i in 0..n {
                let mut s = 0.0;
                for &p in cols {
                    s += A[j + p * n] * B[i + p * n];
                }
                C[i + j * n] = s;
            }
        }
    }

    /// The lower triangle of `C += B·Aᵀ` for this pattern's `A`: C's entry first, then the
    /// nonzero terms in column order (the dense sum's bits, its zero terms left out). The
    /// pattern is read whatever `sparse` says, so a dense `A` takes this path too.
    pub(crate) fn add_mul_nt_lower(&self, C: &mut [f64], B: &[f64], A: &[f64], n: usize) {
        for j in 0..n {
            let cols = self.row(j);
            for i in j..n {
                let mut s = C[i + j * n];
                for &p in cols {
                    s += B[i + p * n] * A[j + p * n];
                }
                C[i + j * n] = s;
            }
        }
    }
}

/// Copies the lower triangle of the square `n`×`n` `a` to its upper triangle.
#[inline(always)]
pub(crate) fn mirror_lower(a: &mut [f64], n: usize) {
    for j in 0..n {
        for i in j + 1..n {
            a[j + i * n] = a[i + j * n];
        }
    }
}

/// `C += w·a·aᵀ` on the lower triangle of the `r`×`r` `C` (mirror it afterwards).
#[inline(always)]
pub(crate) fn rank1_lower(C: &mut [f64], w: f64, a: &[f64], r: usize) {
    let (C, a) = (&mut C[..r * r], &a[..r]);
    for j in 0..r {
        let s = w * a[j];
        for i in j..r {
            C[i + j * r] += s * a[i];
        }
    }
}

/// Makes the pivots of a triangularised row-major array positive: for each row
/// `rows.start + r` with pivot column `piv[r] = Some(c)` whose pivot is negative, negates
/// column c in rows `rows.start..end` (a column's sign does not change `A Aᵀ`). With every
/// pivot positive, a lower-triangular factor of a positive definite matrix is its Cholesky
/// factor.
#[inline(always)]
pub(crate) fn positive_pivots(
    a: &mut [f64],
    ld: usize,
    rows: core::ops::Range<usize>,
    end: usize,
    piv: &[Option<usize>],
) {
    let first = rows.start;
    for i in rows {
        if let Some(c) = piv[i - first]
            && a[i * ld + c] < 0.0
        {
            for r in i..end {
                a[r * ld + c] = -a[r * ld + c];
            }
        }
    }
}

/// Rank-one Cholesky downdate `L' L'ᵀ = L Lᵀ − v vᵀ` of the lower-triangular `N`×`N`
/// factor held row-major in `a` (row r, column c at `a[r·ld + c]`) with nonnegative
/// diagonal, by hyperbolic rotations (`v` is destroyed). A zero pivot with a zero `v`
/// entry is skipped (the semidefinite case). Returns `Err(d)`, d = L_kk² − v_k², at the
/// first pivot the downdate would make zero or negative: `L Lᵀ − v vᵀ` is not positive
/// (semi)definite there.
#[inline(always)]
pub(crate) fn downdate_rows(a: &mut [f64], ld: usize, N: usize, v: &mut [f64]) -> Result<(), f64> {
    for k in 0..N {
        let (l, vk) = (a[k * ld + k], v[k]);
        if vk.abs() <= 0.0 {
            continue;
        }
        let d = (l - vk) * (l + vk);
        if d.is_nan() || d <= 0.0 {
            return Err(d);
        }
        let r = d.sqrt();
        let (c, s) = (r / l, vk / l);
        a[k * ld + k] = r;
        for i in k + 1..N {
            let lik = (a[i * ld + k] - s * v[i]) / c;
            a[i * ld + k] = lik;
            v[i] = c * v[i] - s * lik;
        }
    }
    Ok(())
}

/// `P = S Sᵀ` for the lower-triangular `n`×`n` `S` (column-major), lower triangle summed
/// and mirrored: exactly symmetric.
#[inline(always)]
pub(crate) fn gram_lower(S: &[f64], n: usize, P: &mut [f64]) {
    for j in 0..n {
        for i in j..n {
            let mut s = 0.0;
            for k in 0..=j {
                s += S[i + k * n] * S[j + k * n];
            }
            P[i + j * n] = s;
        }
    }
    mirror_lower(P, n);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sparse products equal the dense loops bit for bit on a Jacobian shaped like an
    /// augmented model's (dense kinematic rows with zeros, unit rows for constant states),
    /// and the pattern declines a dense matrix.
    #[test]
    fn row_pattern_products_equal_the_dense_loops_bit_for_bit() {
        let n = 12;
        // Irrational-looking entries so that every summation order would round differently.
        let val = |k: usize| ((k * 37 % 101) as f64 - 50.0).sin() * 1.7;
        let mut F = vec![0.0; n * n];
        for j in 0..n {
            F[j + j * n] = 1.0;
            for i in 0..4 {
                if (i + 2 * j) % 3 != 0 {
                    F[i + j * n] = val(i + j * n);
                }
            }
        }
        let P: Vec<f64> = (0..n * n).map(|k| val(k + 7)).collect();
        let mut pat = RowPattern::new(n);
        pat.find(&F, n);
        assert!(pat.sparse);
        let (mut dense, mut sparse) = (vec![0.0; n * n], vec![0.0; n * n]);
        mul(&mut dense, &F, &P, n, n, n, false);
        pat.mul(&mut sparse, &F, &P, n);
        assert_eq!(dense, sparse, "F·P");
        mul_nt(&mut dense, &P, &F, n, n, n, false);
        pat.mul_nt(&mut sparse, &P, &F, n);
        assert_eq!(dense, sparse, "P·Fᵀ");
        let Q: Vec<f64> = (0..n * n).map(|k| val(k + 3)).collect();
        let (mut dense, mut sparse) = (Q.clone(), Q.clone());
        for j in 0..n {
            for i in j..n {
                let mut s = dense[i + j * n];
                for k in 0..n {
                    s += P[i + k * n] * F[j + k * n];
                }
                dense[i + j * n] = s;
            }
        }
        pat.add_mul_nt_lower(&mut sparse, &P, &F, n);
        assert_eq!(dense, sparse, "Q + P·Fᵀ, lower triangle");
        pat.find(&P, n);
        assert!(!pat.sparse, "a dense matrix keeps the dense loops");
    }

    /// States of very different units are not a dependence: diag(100, 1e-14) with a
    /// correlation of 0.5 factors in full (both pivots kept, L Lᵀ = a to round-off), where a
    /// tolerance on the largest diagonal entry would zero the second column (its pivot
    /// 7.5e-15 is below 1e-12·100). A true dependence at that small scale, the same
    /// matrix with correlation 1, still gives a zero pivot.
    #[test]
    fn pivots_are_judged_against_their_own_diagonal() {
        let (s1, s2) = (10.0, 1e-7);
        for (rho, full) in [(0.5, true), (1.0, false)] {
            let a = [s1 * s1, rho * s1 * s2, rho * s1 * s2, s2 * s2];
            let (mut L, mut inv) = ([0.0; 4], [0.0; 2]);
            psd_cholesky(&a, 2, &mut L, &mut inv, 1e-12, 1e-10).expect("PSD");
            assert_eq!(inv[1] != 0.0, full, "ρ = {rho}: {L:?}");
            let mut r = [0.0; 4];
            mul_nt(&mut r, &L, &L, 2, 2, 2, false);
            assert!((r[3] - a[3]).abs() <= 1e-12 * a[3], "ρ = {rho}: {r:?}");
            let mut b = a;
            let mut binv = [0.0; 2];
            assert_eq!(pd_cholesky(&mut b, 2, &mut binv, 1e-12).is_ok(), full);
        }
    }

    #[test]
    fn semidefinite_cholesky_reconstructs_and_rejects_indefinite() {
        // a = v vᵀ + diag(0, 1, 0) with v = (1, 2, 3): rank 2, PSD.
        let v = [1.0, 2.0, 3.0];
        let mut a = [0.0; 9];
        for j in 0..3 {
            for i in 0..3 {
                a[i + 3 * j] = v[i] * v[j];
            }
        }
        a[4] += 1.0;
        let (mut L, mut inv) = ([0.0; 9], [0.0; 3]);
        psd_cholesky(&a, 3, &mut L, &mut inv, 1e-12, 1e-10).expect("PSD");
        let mut r = [0.0; 9];
        mul_nt(&mut r, &L, &L, 3, 3, 3, false);
        for (x, y) in r.iter().zip(&a) {
            assert!((x - y).abs() < 1e-13 * 14.0);
        }
        a[8] -= 1e-3;
        assert!(psd_cholesky(&a, 3, &mut L, &mut inv, 1e-12, 1e-10).is_err());
    }

    /// The downdate against the Cholesky factor of `L Lᵀ − v vᵀ` computed directly, and its
    /// refusal when the difference is indefinite.
    #[test]
    fn downdate_equals_the_factor_of_the_difference() {
        // A = M Mᵀ + 4 I (3×3), v small enough that A − v vᵀ stays PD. Entries O(1–10):
        // 1e-13 is rounding.
        let m = [1.0, 0.5, -0.3, 0.2, 2.0, 0.7, -1.0, 0.1, 1.5];
        let mut a = [0.0; 9];
        mul_nt(&mut a, &m, &m, 3, 3, 3, false);
        for i in 0..3 {
            a[i + 3 * i] += 4.0;
        }
        let v = [0.9, -0.4, 1.1];
        let (mut L, mut inv) = ([0.0; 9], [0.0; 3]);
        psd_cholesky(&a, 3, &mut L, &mut inv, 1e-12, 1e-10).expect("PD");
        let mut diff = a;
        for j in 0..3 {
            for i in 0..3 {
                diff[i + 3 * j] -= v[i] * v[j];
            }
        }
        let mut want = [0.0; 9];
        psd_cholesky(&diff, 3, &mut want, &mut inv, 1e-12, 1e-10).expect("PD");
        // Row-major copy of L (the lower triangle, row r column c at r·3 + c).
        let mut rows = [0.0; 9];
        for r in 0..3 {
            for c in 0..3 {
                rows[r * 3 + c] = L[r + 3 * c];
            }
        }
        let mut w = v;
        downdate_rows(&mut rows, 3, 3, &mut w).expect("PD difference");
        for r in 0..3 {
            for c in 0..3 {
                assert!(
                    (rows[r * 3 + c] - want[r + 3 * c]).abs() < 1e-13,
                    "({r}, {c})"
                );
            }
        }
        let mut w = [10.0, 0.0, 0.0];
        let d = downdate_rows(&mut rows, 3, 3, &mut w).expect_err("indefinite");
        assert!(d < 0.0);
    }

    #[test]
    fn solves_invert_the_factor() {
        let a = [4.0, 2.0, 2.0, 3.0];
        let (mut L, mut inv) = (a, [0.0; 2]);
        pd_cholesky(&mut L, 2, &mut inv, 1e-12).expect("PD");
        let mut B = [1.0, 0.0, 0.0, 1.0];
        right_solve(&L, &inv, 2, &mut B, 2);
        // (a)⁻¹ = [[3, −2], [−2, 4]] / 8
        let expect = [3.0 / 8.0, -0.25, -0.25, 0.5];
        for (x, y) in B.iter().zip(&expect) {
            assert!((x - y).abs() < 1e-15);
        }
        let (nis, logdet) = nis_logdet(&L, &inv, 2, &[1.0, 1.0], &mut [0.0; 2]);
        assert!((nis - (3.0 - 4.0 + 4.0) / 8.0).abs() < 1e-15);
        assert!((logdet - 8.0_f64.ln()).abs() < 1e-15);
    }

    #[test]
    fn right_and_forward_solves_reconstruct() {
        // a = M Mᵀ + I (3×3, PD) = L Lᵀ; X = B a⁻¹ must satisfy X a = B, Y = L⁻¹ Bᵀ must
        // satisfy L Y = Bᵀ, to rounding (entries O(1), condition number < 30: 1e-13 is
        // ample).
        let m = [1.0, 0.5, -0.3, 0.2, 2.0, 0.7, -1.0, 0.1, 1.5];
        let mut a = [0.0; 9];
        mul_nt(&mut a, &m, &m, 3, 3, 3, false);
        for i in 0..3 {
            a[i + 3 * i] += 1.0;
        }
        let (mut L, mut inv) = (a, [0.0; 3]);
        pd_cholesky(&mut L, 3, &mut inv, 1e-12).expect("PD");
        for j in 0..3 {
            for i in 0..j {
                L[i + 3 * j] = 0.0; // the factor is the lower triangle
            }
        }
        let b = [1.0, -2.0, 0.5, 3.0, -1.0, 0.25]; // 2×3
        let mut x = b;
        right_solve(&L, &inv, 3, &mut x, 2);
        let mut xa = [0.0; 6];
        mul(&mut xa, &x, &a, 2, 3, 3, false);
        let mut bt = [0.0; 6]; // 3×2
        for i in 0..2 {
            for j in 0..3 {
                bt[j + 3 * i] = b[i + 2 * j];
            }
        }
        let mut y = bt;
        for c in 0..2 {
            forward(&L, &inv, 3, &mut y[3 * c..3 * c + 3]);
        }
        let mut ly = [0.0; 6];
        mul(&mut ly, &L, &y, 3, 3, 2, false);
        for (p, q) in xa.iter().zip(&b).chain(ly.iter().zip(&bt)) {
            assert!((p - q).abs() < 1e-13, "{p} vs {q}");
        }
    }

    #[test]
    fn factored_joseph_equals_the_joseph_form() {
        // P = L Lᵀ (4×4), K (4×2), H (2×4), R (2×2 PD); G = (H L)ᵀ. Both forms are O(10)
        // sums of O(1–10) products: agreement to 1e-12 is rounding.
        let n = 4;
        let L = [
            2.0, 0.5, -0.3, 0.1, 0.0, 1.5, 0.2, -0.4, 0.0, 0.0, 1.0, 0.3, 0.0, 0.0, 0.0, 0.7,
        ];
        let mut P = [0.0; 16];
        mul_nt(&mut P, &L, &L, n, n, n, false);
        let K = [0.3, -0.1, 0.2, 0.05, 0.1, 0.4, -0.2, 0.3];
        let H = [1.0, 0.2, 0.0, -0.5, 0.3, 1.0, 0.1, 0.0];
        let R = [0.5, 0.1, 0.1, 0.2];
        let mut HL = [0.0; 8];
        mul(&mut HL, &H, &L, 2, n, n, false);
        let mut G = [0.0; 8];
        for i in 0..2 {
            for j in 0..n {
                G[j + i * n] = HL[i + j * 2];
            }
        }
        let (mut want, mut got) = ([0.0; 16], [0.0; 16]);
        let (mut A, mut T, mut KR) = ([0.0; 16], [0.0; 16], [0.0; 8]);
        joseph(&P, &K, &H, &R, n, 2, &mut want, &mut A, &mut T, &mut KR);
        factored_joseph(&L, &K, &G, &R, n, 2, &mut got, &mut A, &mut KR);
        for (p, q) in got.iter().zip(&want) {
            assert!((p - q).abs() < 1e-12, "{p} vs {q}");
        }
        for j in 0..n {
            for i in 0..n {
                assert!(got[i + j * n].to_bits() == got[j + i * n].to_bits());
            }
        }
    }
}
