//! Small dense column-major kernels for the fitting recursions (plain loops: the fitted
//! models are small, and per-call dispatch would dominate a 2×2 product).
#![allow(non_snake_case)]

/// `C = beta·C + alpha·op(A)·op(B)`, all column-major. `op(A)` is `r×k`, `op(B)` is `k×c`;
/// `lda`/`ldb` are the row counts of the stored `A` and `B`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn gemm(
    c: &mut [f64],
    r: usize,
    cc: usize,
    k: usize,
    alpha: f64,
    a: &[f64],
    lda: usize,
    ta: bool,
    b: &[f64],
    ldb: usize,
    tb: bool,
    beta: f64,
) {
    for j in 0..cc {
        for i in 0..r {
            let mut s = 0.0;
            for l in 0..k {
                let av = if ta { a[l + i * lda] } else { a[i + l * lda] };
                let bv = if tb { b[j + l * ldb] } else { b[l + j * ldb] };
                s += av * bv;
            }
            let dst = &mut c[i + j * r];
            *dst = if beta == 0.0 {
                alpha * s
            } else {
                beta * *dst + alpha * s
            };
        }
    }
}

/// The whole lower Cholesky factor of the `n×n` matrix `a`, in place: the crate's kernel
/// ([`crate::kernels::cholesky`], zero pivot tolerance), then the strict upper triangle
/// zeroed so that `a` holds `L` as a matrix. `false` if a pivot is not positive.
pub(crate) fn lower_factor(a: &mut [f64], n: usize) -> bool {
    if !crate::kernels::cholesky(a, n, 0.0) {
        return false;
    }
    for j in 1..n {
        a[j * n..j * n + j].fill(0.0);
    }
    true
}

/// Solves `L Lᵀ X = B` in place for `B` (`n×c`, column-major) with the Cholesky factor `L`,
/// one column at a time by the crate's kernel ([`crate::kernels::cholesky_solve`]).
#[inline(always)]
pub(crate) fn solve_each_column(l: &[f64], n: usize, b: &mut [f64], c: usize) {
    for x in b[..n * c].chunks_exact_mut(n) {
        crate::kernels::cholesky_solve(l, n, x);
    }
}

pub(crate) use crate::kernels::symmetrise;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solve_reconstructs() {
        // A = M Mᵀ + I is SPD; A·X = B solved and multiplied back.
        let m = [1.0, 2.0, -1.0, 0.5, 3.0, 1.0, 0.0, -2.0, 1.5];
        let mut a = [0.0; 9];
        gemm(&mut a, 3, 3, 3, 1.0, &m, 3, false, &m, 3, true, 0.0);
        for i in 0..3 {
            a[i + 3 * i] += 1.0;
        }
        let mut l = a;
        assert!(lower_factor(&mut l, 3));
        let b = [1.0, -2.0, 0.5, 4.0, 0.0, 1.0];
        let mut x = b;
        solve_each_column(&l, 3, &mut x, 2);
        let mut back = [0.0; 6];
        gemm(&mut back, 3, 2, 3, 1.0, &a, 3, false, &x, 3, false, 0.0);
        for (u, v) in back.iter().zip(b) {
            assert!((u - v).abs() < 1e-12 * 10.0, "{u} vs {v}");
        }
    }
}
