//! Slice kernels shared by both storage paths: GEMM loops (and the faer hand-off), the
//! robust factorisation of the innovation covariance, and the row-wise LQ triangularisation
//! of the square-root form. Column-major unless stated; nothing here allocates.
#![allow(non_snake_case)]

use faer::linalg::matmul::triangular::BlockStructure;
use faer::{Accum, MatMut, MatRef, Par};

/// One product `C = beta·C + alpha·op(A)·op(B)` (`C` is `rows`×`cols` with leading dimension
/// `ldc`, `op(A)` is `rows`×`inner`).
#[doc(hidden)]
#[derive(Clone, Copy, Debug)]
pub struct Gemm<'a> {
    pub rows: usize,
    pub cols: usize,
    pub inner: usize,
    pub alpha: f64,
    /// Accumulate into `C` (`beta = 1`) instead of overwriting it (`beta = 0`).
    pub acc: bool,
    pub a: &'a [f64],
    pub lda: usize,
    pub ta: bool,
    pub b: &'a [f64],
    pub ldb: usize,
    pub tb: bool,
    pub ldc: usize,
    /// Compute only the lower triangle of `C` (square `C`).
    pub lower: bool,
}

/// `C = alpha·op(A)·op(B) (+ C)` with plain loops (unrolled for fixed sizes).
#[inline(always)]
pub fn gemm(g: Gemm<'_>, c: &mut [f64]) {
    let Gemm {
        rows,
        cols,
        inner,
        alpha,
        acc,
        a,
        lda,
        ta,
        b,
        ldb,
        tb,
        ldc,
        lower,
    } = g;
    // Small outputs: full columns vectorise better than the shrinking lower-triangle ones
    // (every `lower` product is mirrored by its caller, so the extra upper part is harmless).
    let lower = lower && rows > 16;
    for j in 0..cols {
        let i0 = if lower { j } else { 0 };
        let ccol = &mut c[j * ldc + i0..j * ldc + rows];
        if !acc {
            ccol.fill(0.0);
        }
        if !ta {
            for p in 0..inner {
                let s = alpha * if tb { b[j + p * ldb] } else { b[p + j * ldb] };
                let acol = &a[p * lda + i0..p * lda + rows];
                for (ci, ai) in ccol.iter_mut().zip(acol) {
                    *ci += s * ai;
                }
            }
        } else {
            for (ci, i) in ccol.iter_mut().zip(i0..rows) {
                let arow = &a[i * lda..i * lda + inner];
                let mut s = 0.0;
                if tb {
                    for (p, ap) in arow.iter().enumerate() {
                        s += ap * b[j + p * ldb];
                    }
                } else {
                    let bcol = &b[j * ldb..j * ldb + inner];
                    for (ap, bp) in arow.iter().zip(bcol) {
                        s += ap * bp;
                    }
                }
                *ci += alpha * s;
            }
        }
    }
}

/// The same product through faer's GEMM (`Par::Seq`, or Rayon above
/// [`crate::storage::PARALLEL_THRESHOLD`] with the `parallel` feature).
pub fn gemm_faer(g: Gemm<'_>, c: &mut [f64]) {
    let (ar, ac) = if g.ta {
        (g.inner, g.rows)
    } else {
        (g.rows, g.inner)
    };
    let (br, bc) = if g.tb {
        (g.cols, g.inner)
    } else {
        (g.inner, g.cols)
    };
    let mut A = MatRef::from_column_major_slice_with_stride(g.a, ar, ac, g.lda);
    if g.ta {
        A = A.transpose();
    }
    let mut B = MatRef::from_column_major_slice_with_stride(g.b, br, bc, g.ldb);
    if g.tb {
        B = B.transpose();
    }
    let C = MatMut::from_column_major_slice_with_stride_mut(c, g.rows, g.cols, g.ldc);
    let par = par_for(g.rows * g.cols * g.inner);
    let beta = if g.acc { Accum::Add } else { Accum::Replace };
    if g.lower && g.rows >= TRIANGULAR_MIN {
        faer::linalg::matmul::triangular::matmul(
            C,
            BlockStructure::TriangularLower,
            beta,
            A,
            BlockStructure::Rectangular,
            B,
            BlockStructure::Rectangular,
            g.alpha,
            par,
        );
    } else {
        faer::linalg::matmul::matmul(C, beta, A, B, g.alpha, par);
    }
}

/// Below this size faer's triangular-output product is slower than its full GEMM (the
/// upper triangle is then computed too and overwritten when the caller mirrors the lower
/// one); measured with `benches/step.rs`.
pub const TRIANGULAR_MIN: usize = 128;

#[cfg(feature = "parallel")]
fn par_for(work: usize) -> Par {
    if work >= crate::storage::PARALLEL_THRESHOLD {
        Par::rayon(0)
    } else {
        Par::Seq
    }
}

#[cfg(not(feature = "parallel"))]
fn par_for(_work: usize) -> Par {
    Par::Seq
}

/// Copies the lower triangle of the square `n`×`n` matrix to the upper one.
#[inline(always)]
pub fn mirror_lower(a: &mut [f64], n: usize) {
    for j in 0..n {
        for i in j + 1..n {
            a[j + i * n] = a[i + j * n];
        }
    }
}

/// Relative pivot tolerance of the innovation-covariance factorisation: a Cholesky pivot
/// `d_j ≤ RANK_TOL·max_i Σ_ii` (a channel predicted to within 1e-6 of its scale) or an
/// eigenvalue `λ ≤ RANK_TOL·λ_max` is treated as an exact linear dependence.
pub const RANK_TOL: f64 = 1e-12;

/// In-place lower Cholesky of the `n`×`n` matrix `a` (only the lower triangle is read and
/// written). Returns `false` if a pivot is at or below `tol` (the caller falls back).
#[inline(always)]
pub fn cholesky(a: &mut [f64], n: usize, tol: f64) -> bool {
    for j in 0..n {
        let mut d = a[j + j * n];
        for k in 0..j {
            d -= a[j + k * n] * a[j + k * n];
        }
        if d.is_nan() || d <= tol {
            return false;
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
    true
}

/// Cyclic Jacobi eigen-decomposition of the symmetric `n`×`n` matrix `a` (destroyed; its
/// diagonal ends up holding the eigenvalues, copied to `w`); `v` receives the eigenvectors
/// as columns. Converges quadratically; stops when the off-diagonal mass is below
/// 1e-30 of the total or after 60 sweeps.
pub fn jacobi_eigen(a: &mut [f64], n: usize, v: &mut [f64], w: &mut [f64]) {
    v[..n * n].fill(0.0);
    for i in 0..n {
        v[i + i * n] = 1.0;
    }
    for _sweep in 0..60 {
        let mut off = 0.0;
        let mut total = 0.0;
        for j in 0..n {
            for i in 0..n {
                let x = a[i + j * n] * a[i + j * n];
                total += x;
                if i != j {
                    off += x;
                }
            }
        }
        if off <= 1e-30 * total || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p + q * n];
                if apq == 0.0 {
                    continue;
                }
                let app = a[p + p * n];
                let aqq = a[q + q * n];
                let theta = (aqq - app) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let akp = a[k + p * n];
                    let akq = a[k + q * n];
                    a[k + p * n] = c * akp - s * akq;
                    a[k + q * n] = s * akp + c * akq;
                }
                for k in 0..n {
                    let apk = a[p + k * n];
                    let aqk = a[q + k * n];
                    a[p + k * n] = c * apk - s * aqk;
                    a[q + k * n] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let vkp = v[k + p * n];
                    let vkq = v[k + q * n];
                    v[k + p * n] = c * vkp - s * vkq;
                    v[k + q * n] = s * vkp + c * vkq;
                }
            }
        }
    }
    for i in 0..n {
        w[i] = a[i + i * n];
    }
}

/// Row-wise Householder LQ on a row-major array (`ld` entries per row): triangularises rows
/// `rows` over columns `col0..ncols`, applying each reflection to rows `rows.start..apply_end`.
/// A row whose remaining squared norm is at most `tol2` (or exactly zero) is rank-deficient:
/// its remainder is zeroed, `piv[row] = -1`, and the pivot column does not advance.
/// Otherwise `piv[row]` is its pivot column. Returns the number of pivots.
pub fn lq_rows(
    a: &mut [f64],
    ld: usize,
    rows: core::ops::Range<usize>,
    apply_end: usize,
    col0: usize,
    ncols: usize,
    tol2: f64,
    piv: &mut [f64],
) -> usize {
    let mut c = col0;
    let first = rows.start;
    for i in rows {
        if c >= ncols {
            piv[i - first] = -1.0;
            continue;
        }
        let row = &a[i * ld..i * ld + ncols];
        let rem: f64 = row[c..].iter().map(|x| x * x).sum();
        if rem <= tol2 || rem <= f64::MIN_POSITIVE {
            a[i * ld + c..i * ld + ncols].fill(0.0);
            piv[i - first] = -1.0;
            continue;
        }
        let norm = rem.sqrt();
        let x0 = a[i * ld + c];
        let alpha = if x0 >= 0.0 { -norm } else { norm };
        // v = x - alpha·e1, stored in place in row i (columns c..); vᵀv = 2(norm² - alpha·x0).
        a[i * ld + c] = x0 - alpha;
        let vtv = 2.0 * (rem - alpha * x0);
        for r in i + 1..apply_end {
            let (head, tail) = a.split_at_mut(r * ld);
            let v = &head[i * ld + c..i * ld + ncols];
            let rr = &mut tail[c..ncols];
            let s: f64 = v.iter().zip(rr.iter()).map(|(p, q)| p * q).sum();
            let f = 2.0 * s / vtv;
            for (q, p) in rr.iter_mut().zip(v) {
                *q -= f * p;
            }
        }
        a[i * ld + c] = alpha;
        a[i * ld + c + 1..i * ld + ncols].fill(0.0);
        piv[i - first] = c as f64;
        c += 1;
    }
    c - col0
}
