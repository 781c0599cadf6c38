//! Slice kernels shared by both storage paths: the matrix product (plain loops or faer's
//! GEMM), the robust factorisation of the innovation covariance, and the row-wise LQ
//! triangularisation of the square-root form. Column-major unless stated; nothing here
//! allocates.
#![allow(non_snake_case)]

use faer::linalg::matmul::triangular::BlockStructure;
use faer::{Accum, MatMut, MatRef, Par};

use crate::storage::Dims;

/// How a stored column-major matrix enters a product: `N(a, rows, cols)` as it is,
/// `T(a, rows, cols)` transposed. `rows`×`cols` is always the *stored* shape, so the
/// leading dimension is `rows`.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Op<'a> {
    /// `A` as stored.
    N(&'a [f64], usize, usize),
    /// `Aᵀ`.
    T(&'a [f64], usize, usize),
}

impl<'a> Op<'a> {
    /// Rows and columns of `op(A)`.
    #[inline(always)]
    fn shape(self) -> (usize, usize) {
        match self {
            Op::N(_, r, c) => (r, c),
            Op::T(_, r, c) => (c, r),
        }
    }
    /// The stored entries, their leading dimension, and whether they enter transposed.
    #[inline(always)]
    fn parts(self) -> (&'a [f64], usize, bool) {
        match self {
            Op::N(a, r, _) => (a, r, false),
            Op::T(a, r, _) => (a, r, true),
        }
    }
}

/// Which part of a product's output is needed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Part {
    /// Every entry.
    Full,
    /// The lower triangle of a square output: a symmetric result that the caller mirrors
    /// (the upper triangle may be written too).
    Lower,
}

/// Products with `rows·cols·inner` below this many multiply-adds use the crate's own loops
/// on the dynamic path (the fixed path always does). Chosen from faer's per-call overhead
/// (20–75 ns a call), about the cost of this many multiply-adds in plain loops; not tuned
/// further.
pub const FAER_THRESHOLD: usize = 512; // 8³

/// With the `parallel` feature, products of at least this many multiply-adds run on Rayon
/// (faer's own default of 32 768 was 3.6× slower at n = 50 on a 2-core machine; Rayon paid
/// off only near n = 1000). On a loaded machine Rayon can lose even there: the feature is
/// off by default.
pub const PARALLEL_THRESHOLD: usize = 64_000_000; // 400³

/// Below this size faer's triangular-output product is slower than its full GEMM (the
/// upper triangle is then computed too and overwritten when the caller mirrors the lower
/// one); measured with the criterion benchmark of the filter step.
const TRIANGULAR_MIN: usize = 128;

/// `C = alpha·op(A)·op(B)`, replacing `C` or added to it (`accum`); `C` is contiguous
/// (leading dimension = its rows). The fixed path and small products run plain loops;
/// large products on the dynamic path go to faer's GEMM.
#[inline(always)]
pub(crate) fn mm<D: Dims>(
    d: &D,
    c: &mut [f64],
    part: Part,
    accum: Accum,
    alpha: f64,
    a: Op<'_>,
    b: Op<'_>,
) {
    let (rows, inner) = a.shape();
    let (inner_b, cols) = b.shape();
    debug_assert_eq!(inner, inner_b, "inner dimensions of a product");
    // Both paths form the same product to round-off (a `Lower` one is mirrored by its
    // caller): the test chooses speed only, and any other test gives the same results.
    if d.is_fixed() || rows * cols * inner < FAER_THRESHOLD {
        gemm_loops(c, part, accum, alpha, a, b);
    } else {
        gemm_faer(c, part, accum, alpha, a, b);
    }
}

/// [`mm`] in plain loops (unrolled by the compiler for fixed sizes).
#[inline(always)]
fn gemm_loops(c: &mut [f64], part: Part, accum: Accum, alpha: f64, a: Op<'_>, b: Op<'_>) {
    let (rows, inner) = a.shape();
    let cols = b.shape().1;
    let (a, lda, ta) = a.parts();
    let (b, ldb, tb) = b.parts();
    let ldc = rows;
    // Small outputs: full columns vectorise better than the shrinking lower-triangle ones
    // (every `Lower` product is mirrored by its caller, so the extra upper part is harmless;
    // any other size threshold, or none, gives the same results).
    let lower = part == Part::Lower && rows > 16;
    for j in 0..cols {
        let i0 = if lower { j } else { 0 };
        let ccol = &mut c[j * ldc + i0..j * ldc + rows];
        if matches!(accum, Accum::Replace) {
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

/// [`mm`] through faer's GEMM (`Par::Seq`, or Rayon above [`PARALLEL_THRESHOLD`] with the
/// `parallel` feature).
fn gemm_faer(c: &mut [f64], part: Part, accum: Accum, alpha: f64, a: Op<'_>, b: Op<'_>) {
    fn view(op: Op<'_>) -> MatRef<'_, f64> {
        match op {
            Op::N(x, r, c) => MatRef::from_column_major_slice_with_stride(x, r, c, r),
            Op::T(x, r, c) => MatRef::from_column_major_slice_with_stride(x, r, c, r).transpose(),
        }
    }
    let (rows, inner) = a.shape();
    let cols = b.shape().1;
    let C = MatMut::from_column_major_slice_with_stride_mut(c, rows, cols, rows);
    // The work estimate only chooses the threads (see `par_for`).
    let par = par_for(rows * cols * inner);
    // Speed only: the full product is the triangular one plus an upper part the caller
    // overwrites.
    if part == Part::Lower && rows >= TRIANGULAR_MIN {
        faer::linalg::matmul::triangular::matmul(
            C,
            BlockStructure::TriangularLower,
            accum,
            view(a),
            BlockStructure::Rectangular,
            view(b),
            BlockStructure::Rectangular,
            alpha,
            par,
        );
    } else {
        faer::linalg::matmul::matmul(C, accum, view(a), view(b), alpha, par);
    }
}

/// Threads for a product of `work` multiply-adds. The threshold is a matter of speed alone:
/// a parallel product at most sums in another order, the same results to round-off.
#[cfg(feature = "parallel")]
fn par_for(work: usize) -> Par {
    if work >= PARALLEL_THRESHOLD {
        Par::rayon(0)
    } else {
        Par::Seq
    }
}

#[cfg(not(feature = "parallel"))]
fn par_for(_work: usize) -> Par {
    Par::Seq
}

/// The scalar trait and the symmetrisation have their home in `numerics`, below the
/// independent crates that share them.
pub(crate) use numerics::{Real, symmetrise};

/// Copies the lower triangle of the square `n`×`n` matrix to the upper one.
#[inline(always)]
pub(crate) fn mirror_lower(a: &mut [f64], n: usize) {
    for j in 0..n {
        for i in 0..j {
            // Row i < j, column j (upper) from row j, column i (lower).
            a[i + j * n] = a[j + i * n];
        }
    }
}

/// ln 2π, the constant of every Gaussian log-likelihood in the crate.
pub(crate) const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// Relative pivot tolerance of the covariance factorisations: a Cholesky pivot
/// `d_j ≤ RANK_TOL·max_i Σ_ii` (a channel predicted to within 1e-6 of its scale; the linear
/// engine and the gate), `d_j ≤ RANK_TOL·Σ_jj` (entry j within 1e-6 of a combination of
/// the earlier ones, whatever its units; the nonlinear filters, whose states and channels
/// mix units by many orders) or an eigenvalue `λ ≤ RANK_TOL·λ_max` is treated as an exact
/// linear dependence.
pub const RANK_TOL: f64 = 1e-12;

/// In-place lower Cholesky of the `n`×`n` matrix `a` (only the lower triangle is read and
/// written). Returns `false` if a pivot is at or below `tol` (the caller falls back).
#[inline(always)]
pub(crate) fn cholesky<T: Real>(a: &mut [T], n: usize, tol: f64) -> bool {
    for j in 0..n {
        let mut d = a[j + j * n];
        for k in 0..j {
            d -= a[j + k * n] * a[j + k * n];
        }
        if d.value().is_nan() || d.value() <= tol {
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

/// Solves `L Lᵀ y = b` in place for one right-hand side `b` (length `n`), with `L` the lower
/// factor [`cholesky`] leaves in the lower triangle of an `n`×`n` column-major matrix (the
/// upper triangle is not read).
#[inline(always)]
pub(crate) fn cholesky_solve<T: Real>(l: &[T], n: usize, b: &mut [T]) {
    cholesky_solve_strided(l, n, b, 1);
}

/// [`cholesky_solve`] for a right-hand side whose entry i is `b[i·stride]` (a column of a
/// row-major matrix).
#[inline(always)]
pub(crate) fn cholesky_solve_strided<T: Real>(l: &[T], n: usize, b: &mut [T], stride: usize) {
    for i in 0..n {
        let mut v = b[i * stride];
        for c in 0..i {
            v -= l[i + c * n] * b[c * stride];
        }
        b[i * stride] = v / l[i + i * n];
    }
    for i in (0..n).rev() {
        let mut v = b[i * stride];
        for r in i + 1..n {
            v -= l[r + i * n] * b[r * stride];
        }
        b[i * stride] = v / l[i + i * n];
    }
}

/// Cyclic Jacobi eigen-decomposition of the symmetric `n`×`n` matrix `a` (destroyed; its
/// diagonal ends up holding the eigenvalues, copied to `w`); `v` receives the eigenvectors
/// as columns. Converges quadratically; stops when the off-diagonal mass is below
/// 1e-30 of the total or after 60 sweeps.
pub(crate) fn jacobi_eigen(a: &mut [f64], n: usize, v: &mut [f64], w: &mut [f64]) {
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
        // (Also when off = 0: total ≥ off ≥ 0. A stop that never fired — a total summed
        // wrongly, the diagonal counted as off it, x = a/a — would only run the 60 sweeps
        // out, rotating a converged matrix by angles below ε.)
        if off <= 1e-30 * total {
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
                // The smaller root of t² + 2θt = 1. (Its approximation 1/(2θ) would still
                // converge on the symmetric PSD matrices this receives: near θ = 0 such a
                // rotation about triples |θ|, far from 0 it is exact to O(θ⁻³); ~40 sweeps
                // from θ ~ ε.)
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                // A ← Jᵀ A J (columns, then rows p and q), V ← V J.
                rotate(a, n, |k| (k + p * n, k + q * n), c, s);
                rotate(a, n, |k| (p + k * n, q + k * n), c, s);
                rotate(v, n, |k| (k + p * n, k + q * n), c, s);
            }
        }
    }
    for i in 0..n {
        w[i] = a[i + i * n];
    }
}

/// The plane rotation (c, s) applied to the pairs `(x[i], x[j])` with `(i, j) = at(k)`,
/// `k < n`: `x_i ← c x_i − s x_j`, `x_j ← s x_i + c x_j`.
#[inline(always)]
fn rotate(x: &mut [f64], n: usize, at: impl Fn(usize) -> (usize, usize), c: f64, s: f64) {
    for k in 0..n {
        let (i, j) = at(k);
        let (xi, xj) = (x[i], x[j]);
        x[i] = c * xi - s * xj;
        x[j] = s * xi + c * xj;
    }
}

/// `Σ aᵢ bᵢ` over the shorter of the two, in two interleaved partial sums: the short
/// rows of the triangularisations are latency-bound in one running sum.
#[inline(always)]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let len = a.len().min(b.len());
    let (a, b) = (&a[..len], &b[..len]);
    let (mut s0, mut s1) = (0.0, 0.0);
    let mut t = 1;
    while t < len {
        s0 += a[t - 1] * b[t - 1];
        s1 += a[t] * b[t];
        t += 2;
    }
    if t == len {
        s0 += a[t - 1] * b[t - 1];
    }
    s0 + s1
}

/// Row-wise Householder LQ on a row-major array (`ld` entries per row): triangularises rows
/// `rows` over columns `col0..ncols`, applying each reflection to rows `rows.start..apply_end`.
/// A row whose remaining squared norm is at most `tol2` or at most `f64::MIN_POSITIVE` (where
/// the reflection's vᵀv could lose all precision to underflow) is rank-deficient:
/// its remainder is zeroed, `piv[row] = None`, and the pivot column does not advance.
/// Otherwise `piv[row]` is its pivot column. Returns the number of pivots.
pub(crate) fn lq_rows(
    a: &mut [f64],
    ld: usize,
    rows: core::ops::Range<usize>,
    apply_end: usize,
    col0: usize,
    ncols: usize,
    tol2: f64,
    piv: &mut [Option<usize>],
) -> usize {
    let mut c = col0;
    let first = rows.start;
    for i in rows {
        if c >= ncols {
            piv[i - first] = None;
            continue;
        }
        let row = &a[i * ld + c..i * ld + ncols];
        let rem = dot(row, row);
        if rem <= tol2 || rem <= f64::MIN_POSITIVE {
            a[i * ld + c..i * ld + ncols].fill(0.0);
            piv[i - first] = None;
            continue;
        }
        let norm = rem.sqrt();
        let x0 = a[i * ld + c];
        let alpha = if x0 >= 0.0 { -norm } else { norm };
        // v = x - alpha·e1, stored in place in row i (columns c..); vᵀv = 2(norm² - alpha·x0).
        a[i * ld + c] = x0 - alpha;
        // 2 / vᵀv with vᵀv = 2(norm² - alpha·x0).
        let scale = 1.0 / (rem - alpha * x0);
        let (head, tail) = a.split_at_mut((i + 1) * ld);
        let v = &head[i * ld + c..i * ld + ncols];
        let below = apply_end.saturating_sub(i + 1) * ld;
        for row in tail[..below].chunks_exact_mut(ld) {
            let rr = &mut row[c..ncols];
            let f = dot(v, rr) * scale;
            for (q, p) in rr.iter_mut().zip(v) {
                *q -= f * p;
            }
        }
        a[i * ld + c] = alpha;
        a[i * ld + c + 1..i * ld + ncols].fill(0.0);
        piv[i - first] = Some(c);
        c += 1;
    }
    c - col0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DynDims, FixedDims};

    /// Entry (i, j) of op(A), read from the stored column-major matrix by the definition.
    fn at(op: Op<'_>, i: usize, j: usize) -> f64 {
        match op {
            Op::N(a, r, _) => a[i + j * r],
            Op::T(a, r, _) => a[j + i * r],
        }
    }

    /// `mm` against the sum Σ_p op(A)_ip op(B)_pj written out, for the four transpose
    /// combinations (the engine itself only passes a transposed B), both accumulations and
    /// both parts, in the plain loops (fixed path, and small products) and in faer's GEMM
    /// (large products on the dynamic path).
    #[test]
    fn products_match_the_definition_in_every_layout() {
        let (fixed, dynamic) = (
            FixedDims::<1, 1>::new(),
            DynDims::new(1, 1, 0).expect("dims"),
        );
        // 20×20 outputs take the loops' lower-triangle branch (above 16 rows), 130×130 ones
        // faer's triangular product (from `TRIANGULAR_MIN`).
        for (rows, inner, cols) in [(3, 4, 2), (20, 9, 20), (130, 3, 130)] {
            // Small integers and halves: every product and partial sum is a multiple of 1/8
            // well inside f64's exact range, so any summation order gives the same number.
            let a: Vec<f64> = (0..rows * inner)
                .map(|k| (k * 7 % 11) as f64 - 5.0)
                .collect();
            let b: Vec<f64> = (0..inner * cols)
                .map(|k| (k * 5 % 13) as f64 * 0.5 - 3.0)
                .collect();
            let c0: Vec<f64> = (0..rows * cols).map(|k| k as f64 * 0.25).collect();
            for (ta, tb) in [(false, false), (false, true), (true, false), (true, true)] {
                let opa = if ta {
                    Op::T(&a, inner, rows)
                } else {
                    Op::N(&a, rows, inner)
                };
                let opb = if tb {
                    Op::T(&b, cols, inner)
                } else {
                    Op::N(&b, inner, cols)
                };
                let parts: &[Part] = if rows == cols {
                    &[Part::Full, Part::Lower]
                } else {
                    &[Part::Full]
                };
                for (&part, add, on_fixed) in parts
                    .iter()
                    .flat_map(|p| [(p, false), (p, true)])
                    .flat_map(|(p, add)| [(p, add, false), (p, add, true)])
                {
                    let mut c = c0.clone();
                    let accum = if add { Accum::Add } else { Accum::Replace };
                    if on_fixed {
                        mm(&fixed, &mut c, part, accum, -1.5, opa, opb);
                    } else {
                        mm(&dynamic, &mut c, part, accum, -1.5, opa, opb);
                    }
                    for j in 0..cols {
                        // `Lower` promises the lower triangle only.
                        let i0 = if part == Part::Lower { j } else { 0 };
                        for i in i0..rows {
                            let dot: f64 = (0..inner).map(|p| at(opa, i, p) * at(opb, p, j)).sum();
                            let want = if add { c0[i + j * rows] } else { 0.0 } - 1.5 * dot;
                            assert!(
                                (c[i + j * rows] - want).abs() <= 1e-12 * want.abs().max(1.0),
                                "{rows}x{inner}x{cols} ta {ta} tb {tb} {part:?} add {add} \
                                 fixed {on_fixed} ({i}, {j}): {} vs {want}",
                                c[i + j * rows]
                            );
                        }
                    }
                }
            }
        }
    }

    /// The Cholesky pivot test is `d ≤ tol` (a pivot exactly at the tolerance is a
    /// dependence) and refuses a NaN pivot; above it, the factor reproduces the matrix.
    #[test]
    fn cholesky_refuses_a_pivot_at_the_tolerance_and_a_nan() {
        // [[4, 2], [2, 1 + t]]: second pivot (1 + t) − 1 = t exactly for t = 0.25.
        let t = 0.25;
        let fresh = || vec![4.0, 2.0, 2.0, 1.0 + t];
        assert!(!cholesky(&mut fresh(), 2, t), "pivot at the tolerance");
        let mut a = fresh();
        assert!(cholesky(&mut a, 2, t / 2.0));
        // L = [[2, 0], [1, √t]]: every entry exact in binary.
        assert_eq!((a[0], a[1], a[3]), (2.0, 1.0, t.sqrt()));
        assert!(!cholesky(&mut [f64::NAN], 1, 0.0), "NaN pivot");
        assert!(
            !cholesky(&mut [4.0, f64::NAN, 0.0, 1.0], 2, 0.0),
            "NaN below the diagonal"
        );
    }

    /// Jacobi on a symmetric 3×3 with known spectrum: AV = VΛ and VᵀV = I to round-off.
    #[test]
    fn jacobi_reconstructs_a_symmetric_matrix() {
        // Eigenvalues of [[2, 1, 0], [1, 2, 1], [0, 1, 2]]: 2 − √2, 2, 2 + √2.
        let a0 = [2.0, 1.0, 0.0, 1.0, 2.0, 1.0, 0.0, 1.0, 2.0];
        let (mut a, mut v, mut w) = (a0, [0.0; 9], [0.0; 3]);
        jacobi_eigen(&mut a, 3, &mut v, &mut w);
        let mut sorted = w;
        sorted.sort_by(f64::total_cmp);
        let r = 2f64.sqrt();
        for (got, want) in sorted.iter().zip([2.0 - r, 2.0, 2.0 + r]) {
            // Tolerance: a few ulps of the largest eigenvalue (quadratic convergence to 1e-15).
            assert!((got - want).abs() < 1e-14, "{got} vs {want}");
        }
        for k in 0..3 {
            for i in 0..3 {
                let av: f64 = (0..3).map(|j| a0[i + 3 * j] * v[j + 3 * k]).sum();
                assert!((av - w[k] * v[i + 3 * k]).abs() < 1e-14, "A v_{k} row {i}");
                let vv: f64 = (0..3).map(|j| v[j + 3 * i] * v[j + 3 * k]).sum();
                let want = if i == k { 1.0 } else { 0.0 };
                assert!((vv - want).abs() < 1e-14, "v_{i}·v_{k}");
            }
        }
    }

    /// `lq_rows`: a row whose remainder is `f64::MIN_POSITIVE` (2⁻¹⁰²², the square of an
    /// exact 2⁻⁵¹¹) is dependent even with a zero tolerance, one just above it is not; the
    /// pivot count and the pivot columns follow.
    #[test]
    fn lq_rows_treats_a_remainder_at_the_smallest_normal_as_dependent() {
        let tiny = 2f64.powi(-511);
        assert!((tiny * tiny - f64::MIN_POSITIVE).abs() <= 0.0);
        for (x, dependent) in [(tiny, true), (2.0 * tiny, false)] {
            // Rows (row-major, ld 2): [2, 0] then [0, x]; the first row's reflection
            // (v = [4, 0]) leaves the second row as it is, so its remainder is x² exactly.
            let mut a = [2.0, 0.0, 0.0, x];
            let mut piv = [None; 2];
            let k = lq_rows(&mut a, 2, 0..2, 2, 0, 2, 0.0, &mut piv);
            assert_eq!(piv[0], Some(0));
            assert!((a[0].abs() - 2.0).abs() <= 0.0 && a[1].abs() <= 0.0);
            if dependent {
                assert_eq!((k, piv[1]), (1, None), "x = {x:e}");
                assert!(a[3].abs() <= 0.0);
            } else {
                assert_eq!((k, piv[1]), (2, Some(1)), "x = {x:e}");
                assert!(a[3].abs() > 0.0);
            }
        }
    }

    /// `lq_rows` on rows `1..5` and columns `1..3` of a 5×3 array (more rows than columns,
    /// the block starting below row 0 and right of column 0): `piv` is indexed from the
    /// block's first row and holds absolute columns, the count is of the pivots taken, the
    /// two independent rows take the two pivot columns, and the rows left once the columns
    /// run out get `None`. Row 0 and column 0 are outside the block and must not change; the
    /// reflections act on the columns, so each block row keeps its length.
    #[test]
    fn lq_rows_indexes_pivots_from_the_first_row_of_the_block() {
        // Row-major, ld 3: [7, 7, 7] (outside), then [c₀, 3, 4], [c₀, 1, 2], [c₀, 5, 6],
        // [c₀, 8, 9] with c₀ outside the block's columns.
        let c0 = [0.5, 0.25, 0.125, 1.0];
        let mut a = [7.0; 15];
        for (r, row) in [[3.0, 4.0], [1.0, 2.0], [5.0, 6.0], [8.0, 9.0]]
            .iter()
            .enumerate()
        {
            a[3 * (r + 1)..3 * (r + 2)].copy_from_slice(&[c0[r], row[0], row[1]]);
        }
        let mut piv = [Some(9); 4];
        let k = lq_rows(&mut a, 3, 1..5, 5, 1, 3, 0.0, &mut piv);
        assert_eq!(k, 2);
        assert_eq!(piv, [Some(1), Some(2), None, None]);
        assert_eq!(a[..3], [7.0; 3]);
        for r in 0..4 {
            assert!(
                (a[3 * (r + 1)] - c0[r]).abs() <= 0.0,
                "column 0 of row {}",
                r + 1
            );
        }
        // Row 1 becomes (∓5, 0) on the block's columns: its norm on the pivot column.
        assert!((a[4].abs() - 5.0).abs() < 1e-15 && a[5].abs() <= 0.0);
        for (row, len2) in [(2, 5.0), (3, 61.0), (4, 145.0)] {
            let got = a[3 * row + 1] * a[3 * row + 1] + a[3 * row + 2] * a[3 * row + 2];
            // A few roundings of O(100) numbers.
            assert!((got - len2).abs() < 1e-12, "row {row}: {got} vs {len2}");
        }
    }
}
