//! Small dense kernels of the nonlinear filters on column-major slices: products, the
//! (semi)definite Cholesky factor and triangular solves. Plain loops (the nonlinear filters
//! are for small n, where loops beat a GEMM call); nothing here allocates.
#![allow(non_snake_case)]

/// `C = A·B (+ C if acc)`: `A` is `r`×`k`, `B` is `k`×`c`, `C` is `r`×`c` (leading
/// dimensions equal to the row counts).
#[inline]
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
#[inline]
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
#[inline]
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
#[inline]
pub(crate) fn rank1(C: &mut [f64], w: f64, a: &[f64], b: &[f64], r: usize, c: usize) {
    for j in 0..c {
        let s = w * b[j];
        for (ci, ai) in C[j * r..(j + 1) * r].iter_mut().zip(a) {
            *ci += s * ai;
        }
    }
}

/// Replaces the square `n`×`n` `a` by `(a + aᵀ)/2`.
#[inline]
pub(crate) fn symmetrise(a: &mut [f64], n: usize) {
    for j in 0..n {
        for i in j + 1..n {
            let s = 0.5 * (a[i + j * n] + a[j + i * n]);
            a[i + j * n] = s;
            a[j + i * n] = s;
        }
    }
}

/// Largest absolute diagonal entry of the `n`×`n` `a`.
#[inline]
pub(crate) fn max_diag(a: &[f64], n: usize) -> f64 {
    (0..n).fold(0.0_f64, |s, i| s.max(a[i + i * n].abs()))
}

/// Lower Cholesky factor `L` (`L Lᵀ = a`) of the symmetric PSD `n`×`n` `a`, written to `L`
/// (upper triangle zeroed). A pivot within `zero_tol·max_diag` of zero (or below it but
/// above `−neg_tol·max_diag`) is a zero pivot: its column of `L` is zero (the semidefinite
/// case). A pivot below `−neg_tol·max_diag` is returned as `Err(pivot)`.
#[inline]
pub(crate) fn psd_cholesky(
    a: &[f64],
    n: usize,
    L: &mut [f64],
    zero_tol: f64,
    neg_tol: f64,
) -> Result<(), f64> {
    let scale = max_diag(a, n);
    for j in 0..n {
        let mut d = a[j + j * n];
        for k in 0..j {
            d -= L[j + k * n] * L[j + k * n];
        }
        for i in 0..j {
            L[i + j * n] = 0.0;
        }
        if d.is_nan() || d < -neg_tol * scale {
            return Err(d);
        }
        if d <= zero_tol * scale {
            for i in j..n {
                L[i + j * n] = 0.0;
            }
            continue;
        }
        let d = d.sqrt();
        L[j + j * n] = d;
        for i in j + 1..n {
            let mut s = a[i + j * n];
            for k in 0..j {
                s -= L[i + k * n] * L[j + k * n];
            }
            L[i + j * n] = s / d;
        }
    }
    Ok(())
}

/// Lower Cholesky factor of a positive definite `n`×`n` `a` in place (lower triangle).
/// Returns `Err(pivot)` for the first pivot at or below `tol·max_diag`.
#[inline]
pub(crate) fn pd_cholesky(a: &mut [f64], n: usize, tol: f64) -> Result<(), f64> {
    let scale = max_diag(a, n);
    for j in 0..n {
        let mut d = a[j + j * n];
        for k in 0..j {
            d -= a[j + k * n] * a[j + k * n];
        }
        if d.is_nan() || d <= tol * scale {
            return Err(d);
        }
        let d = d.sqrt();
        a[j + j * n] = d;
        for i in j + 1..n {
            let mut s = a[i + j * n];
            for k in 0..j {
                s -= a[i + k * n] * a[j + k * n];
            }
            a[i + j * n] = s / d;
        }
    }
    Ok(())
}

/// Solves `L y = b` in place (`L` lower `n`×`n`, leading dimension `n`); a zero pivot
/// gives a zero component (the minimum-norm choice for a semidefinite factor).
#[inline]
pub(crate) fn forward(L: &[f64], n: usize, b: &mut [f64]) {
    for j in 0..n {
        let d = L[j + j * n];
        if d == 0.0 {
            b[j] = 0.0;
            continue;
        }
        let y = b[j] / d;
        b[j] = y;
        for i in j + 1..n {
            b[i] -= L[i + j * n] * y;
        }
    }
}

/// Solves `Lᵀ x = b` in place (`L` lower `n`×`n`); zero pivots as in [`forward`].
#[inline]
pub(crate) fn backward(L: &[f64], n: usize, b: &mut [f64]) {
    for j in (0..n).rev() {
        let d = L[j + j * n];
        if d == 0.0 {
            b[j] = 0.0;
            continue;
        }
        let mut s = b[j];
        for i in j + 1..n {
            s -= L[i + j * n] * b[i];
        }
        b[j] = s / d;
    }
}

/// `B ← B (L Lᵀ)⁻¹` for the `rows`×`n` `B` (row by row: `L Lᵀ bᵢᵀ = bᵢᵀ`). `row` is an
/// `n`-vector workspace.
#[inline]
pub(crate) fn right_solve(L: &[f64], n: usize, B: &mut [f64], rows: usize, row: &mut [f64]) {
    for i in 0..rows {
        for j in 0..n {
            row[j] = B[i + j * rows];
        }
        forward(L, n, &mut row[..n]);
        backward(L, n, &mut row[..n]);
        for j in 0..n {
            B[i + j * rows] = row[j];
        }
    }
}

/// `B ← (L Lᵀ)⁻¹ B` for the `n`×`cols` `B`, column by column.
#[inline]
pub(crate) fn left_solve(L: &[f64], n: usize, B: &mut [f64], cols: usize) {
    for j in 0..cols {
        let b = &mut B[j * n..(j + 1) * n];
        forward(L, n, b);
        backward(L, n, b);
    }
}

/// `eᵀ (L Lᵀ)⁻¹ e` and `log det (L Lᵀ)`; `tmp` is an `n`-vector workspace.
#[inline]
pub(crate) fn nis_logdet(L: &[f64], n: usize, e: &[f64], tmp: &mut [f64]) -> (f64, f64) {
    tmp[..n].copy_from_slice(&e[..n]);
    forward(L, n, &mut tmp[..n]);
    let nis = tmp[..n].iter().map(|v| v * v).sum();
    let logdet = 2.0 * (0..n).map(|j| L[j + j * n].ln()).sum::<f64>();
    (nis, logdet)
}

/// Joseph form `P⁺ = A P Aᵀ + K R Kᵀ` with `A = I − K H` (`K` `n`×`mo`, `H` `mo`×`n`,
/// `R` `mo`×`mo`), symmetrised. `A`, `T` are `n`×`n` and `KR` `n`×`mo` workspaces.
#[inline]
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
    mul(A, K, H, n, mo, n, false);
    for v in A[..n * n].iter_mut() {
        *v = -*v;
    }
    for i in 0..n {
        A[i + i * n] += 1.0;
    }
    mul(T, A, P, n, n, n, false);
    mul_nt(out, T, A, n, n, n, false);
    mul(KR, K, R, n, mo, mo, false);
    mul_nt(out, KR, K, n, mo, n, true);
    symmetrise(out, n);
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let mut L = [0.0; 9];
        psd_cholesky(&a, 3, &mut L, 1e-12, 1e-10).expect("PSD");
        let mut r = [0.0; 9];
        mul_nt(&mut r, &L, &L, 3, 3, 3, false);
        for (x, y) in r.iter().zip(&a) {
            assert!((x - y).abs() < 1e-13 * 14.0);
        }
        a[8] -= 1e-3;
        assert!(psd_cholesky(&a, 3, &mut L, 1e-12, 1e-10).is_err());
    }

    #[test]
    fn solves_invert_the_factor() {
        let a = [4.0, 2.0, 2.0, 3.0];
        let mut L = a;
        pd_cholesky(&mut L, 2, 1e-12).expect("PD");
        let mut B = [1.0, 0.0, 0.0, 1.0];
        right_solve(&L, 2, &mut B, 2, &mut [0.0; 2]);
        // (a)⁻¹ = [[3, −2], [−2, 4]] / 8
        let inv = [3.0 / 8.0, -0.25, -0.25, 0.5];
        for (x, y) in B.iter().zip(&inv) {
            assert!((x - y).abs() < 1e-15);
        }
        let (nis, logdet) = nis_logdet(&L, 2, &[1.0, 1.0], &mut [0.0; 2]);
        assert!((nis - (3.0 - 4.0 + 4.0) / 8.0).abs() < 1e-15);
        assert!((logdet - 8.0_f64.ln()).abs() < 1e-15);
    }
}
