//! General weighted least squares: min ‖V^{1/2}(H x − z)‖² by QR of the weighted system (or
//! the paper's normal equations), with conditioning diagnostics, Tikhonov regularisation,
//! prior rows, iteratively re-weighted solves and worst-case error propagation.
//!
//! Every entry point first *whitens* the problem: with W such that WᵀW = V (W = diag(√vᵢ) for
//! diagonal weights, W = Lᵀ from the Cholesky factor V = L·Lᵀ for full weights) the weighted
//! problem is the ordinary least-squares problem min ‖A x − b‖² with A = W H, b = W z.
//! Regularisation and prior information are appended to A and b as extra rows, so one
//! factorisation serves the solve, the covariance and the sensitivity.
#![allow(non_snake_case)]

use nalgebra::{DMatrix, DVector, Dim, Matrix, Storage};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

mod irls;
pub use irls::{IrlsOptions, IrlsSolution, solve_irls};

/// The weight matrix V of the measurement rows.
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{SolveOptions, Weights, solve};
/// // A zero weight drops the third (outlying) row.
/// let h = dmatrix![1.0; 1.0; 1.0];
/// let z = dvector![1.0, 1.0, 100.0];
/// let sol = solve(&h, &z, &Weights::Diagonal(dvector![1.0, 1.0, 0.0]), &SolveOptions::default())?;
/// assert!((sol.x[0] - 1.0).abs() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Weights {
    /// V = I.
    Identity,
    /// V = diag(v), every vᵢ ≥ 0 (a zero weight drops its row).
    Diagonal(DVector<f64>),
    /// A full symmetric positive definite V (m×m), factorised by Cholesky.
    Full(DMatrix<f64>),
}

/// How the whitened system is solved.
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{SolveMethod, SolveOptions, Weights, solve};
/// let h = dmatrix![1.0, 1.0; 1.0, 2.0; 1.0, 3.0];
/// let z = dvector![1.0, 2.0, 2.9];
/// let qr = solve(&h, &z, &Weights::Identity, &SolveOptions::default())?;
/// let ne = SolveOptions { method: SolveMethod::NormalEquations, ..SolveOptions::default() };
/// let ne = solve(&h, &z, &Weights::Identity, &ne)?;
/// assert!((qr.x - ne.x).norm() < 1e-10); // well conditioned: both agree
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum SolveMethod {
    /// Householder QR of A = V^{1/2}H: x = R⁻¹Qᵀb, covariance R⁻¹R⁻ᵀ. Accuracy ∝ κ(A).
    #[default]
    Qr,
    /// The paper's form x = (HᵀVH)⁻¹HᵀVz, solved by Cholesky of the normal matrix (LU if the
    /// Cholesky factorisation breaks down in rounding). Accuracy ∝ κ(A)²; kept for comparison.
    NormalEquations,
}

/// Tikhonov regularisation: adds λ‖L(x − x_p)‖² to the objective.
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{SolveOptions, Tikhonov, Weights, solve};
/// // One equation, two unknowns: underdetermined without regularisation.
/// let h = dmatrix![1.0, 1.0];
/// let z = dvector![2.0];
/// assert!(solve(&h, &z, &Weights::Identity, &SolveOptions::default()).is_err());
/// let tik = Tikhonov { lambda: 1e-8, prior_mean: None, operator: None };
/// let options = SolveOptions { tikhonov: Some(tik), ..SolveOptions::default() };
/// let sol = solve(&h, &z, &Weights::Identity, &options)?;
/// // The minimum-norm solution (1, 1).
/// assert!((sol.x - dvector![1.0, 1.0]).norm() < 1e-6);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tikhonov {
    /// λ ≥ 0.
    pub lambda: f64,
    /// The prior mean x_p (n); `None` means 0.
    pub prior_mean: Option<DVector<f64>>,
    /// The operator L (k×n); `None` means the identity.
    pub operator: Option<DMatrix<f64>>,
}

impl Tikhonov {
    /// Ridge regression: λ‖x‖² (prior mean 0, operator the identity). λ is checked by
    /// [`solve`] (finite, ≥ 0).
    ///
    /// ```
    /// use wls::solver::Tikhonov;
    /// let t = Tikhonov::ridge(1e-6);
    /// assert_eq!(t, Tikhonov { lambda: 1e-6, prior_mean: None, operator: None });
    /// ```
    #[must_use]
    pub fn ridge(lambda: f64) -> Self {
        Self {
            lambda,
            prior_mean: None,
            operator: None,
        }
    }
}

/// Prior information as extra weighted measurement rows: P x ≈ p with weight V_p.
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{PriorRows, SolveOptions, Weights, solve};
/// // x₂ is unobserved by H but known a priori to be 5 ± 1.
/// let h = dmatrix![1.0, 0.0];
/// let z = dvector![3.0];
/// let (rows, values) = (dmatrix![0.0, 1.0], dvector![5.0]);
/// let prior = PriorRows { rows, values, weights: Weights::Identity };
/// let options = SolveOptions { prior: Some(prior), ..SolveOptions::default() };
/// let sol = solve(&h, &z, &Weights::Identity, &options)?;
/// assert!((sol.x - dvector![3.0, 5.0]).norm() < 1e-12);
/// assert!((sol.covariance[(1, 1)] - 1.0).abs() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PriorRows {
    /// P (k×n).
    pub rows: DMatrix<f64>,
    /// p (k).
    pub values: DVector<f64>,
    /// V_p (k×k), same rules as the measurement weights.
    pub weights: Weights,
}

/// Options of [`solve`].
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{SolveOptions, Weights, solve};
/// // Scale the covariance by the residual variance σ̂² (3 rows, 1 unknown: 2 dof).
/// let h = dmatrix![1.0; 1.0; 1.0];
/// let z = dvector![0.9, 1.0, 1.1];
/// let options = SolveOptions { scale_covariance: true, ..SolveOptions::default() };
/// let sol = solve(&h, &z, &Weights::Identity, &options)?;
/// // σ̂² = 0.02/2 and cov = σ̂²/3.
/// assert!((sol.covariance[(0, 0)] - 0.01 / 3.0).abs() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SolveOptions {
    /// QR (default) or normal equations.
    pub method: SolveMethod,
    /// Scale the covariance by the residual variance σ̂² = ‖Ax − b‖²/(rows − n).
    pub scale_covariance: bool,
    /// Singular values of V^{1/2}H at or below this count as zero; default
    /// max(m, n)·ε·σ_max (the LAPACK/NumPy convention).
    pub rank_tolerance: Option<f64>,
    /// Tikhonov regularisation.
    pub tikhonov: Option<Tikhonov>,
    /// Prior information as extra rows.
    pub prior: Option<PriorRows>,
}

impl SolveOptions {
    /// The default options with ridge regularisation λ‖x‖² ([`Tikhonov::ridge`]): the one
    /// value a regularised fit needs.
    ///
    /// ```
    /// use wls::nalgebra::{DMatrix, dvector};
    /// use wls::solver::{SolveOptions, Weights, solve};
    /// // Ridge on H = I: x = z/(1 + λ).
    /// let sol = solve(&DMatrix::identity(2, 2), &dvector![2.0, 4.0], &Weights::Identity, &SolveOptions::ridge(1.0))?;
    /// assert!((sol.x - dvector![1.0, 2.0]).norm() < 1e-12);
    /// # Ok::<(), wls::Error>(())
    /// ```
    #[must_use]
    pub fn ridge(lambda: f64) -> Self {
        Self {
            tikhonov: Some(Tikhonov::ridge(lambda)),
            ..Self::default()
        }
    }
}

/// The result of [`solve`].
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{SolveOptions, Weights, solve};
/// let h = dmatrix![1.0, 0.0; 0.0, 1e-6];
/// let z = dvector![1.0, 1e-6];
/// let sol = solve(&h, &z, &Weights::Identity, &SolveOptions::default())?;
/// assert!((sol.condition_weighted - 1e6).abs() < 1e-3);
/// assert_eq!(sol.rank, 2);
/// assert!(sol.residuals.norm() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Solution {
    /// The estimate x̂ (n).
    pub x: DVector<f64>,
    /// (HᵀVH + regularisation)⁻¹ (n×n), symmetric; times σ̂² if `covariance_scaled`.
    pub covariance: DMatrix<f64>,
    /// Whether `covariance` was scaled by the residual variance.
    pub covariance_scaled: bool,
    /// Unweighted residuals z − H x̂ of the measurement rows (m).
    pub residuals: DVector<f64>,
    /// ‖A x̂ − b‖² over all solved rows (measurements, prior and regularisation rows).
    pub weighted_sum_of_squares: f64,
    /// σ̂² = `weighted_sum_of_squares` / (rows − n), `None` without degrees of freedom.
    pub residual_variance: Option<f64>,
    /// Singular values of V^{1/2}H, descending.
    pub singular_values: DVector<f64>,
    /// κ₂(V^{1/2}H) = σ_max/σ_min by SVD (∞ if rank-deficient).
    pub condition_weighted: f64,
    /// κ₂(HᵀVH) by SVD of the normal matrix (≈ `condition_weighted`², up to rounding).
    pub condition_normal: f64,
    /// κ₂ of the system actually solved (with regularisation and prior rows).
    pub condition_solved: f64,
    /// Numerical rank of V^{1/2}H.
    pub rank: usize,
    /// The tolerance that defined `rank`.
    pub rank_tolerance: f64,
    /// The method used.
    pub method: SolveMethod,
}

/// Checks that every entry of `m` is finite.
pub(crate) fn check_finite<R: Dim, C: Dim, S: Storage<f64, R, C>>(
    name: &'static str,
    m: &Matrix<f64, R, C, S>,
) -> Result<()> {
    for col in 0..m.ncols() {
        for row in 0..m.nrows() {
            let value = m[(row, col)];
            if !value.is_finite() {
                return Err(Error::NonFinite {
                    name,
                    row,
                    col,
                    value,
                });
            }
        }
    }
    Ok(())
}

/// Checks that each named scalar is finite: [`Error::NonFinite`] naming the first that is
/// not (as the single entry at row 0, column 0).
pub(crate) fn check_finite_scalars(values: &[(&'static str, f64)]) -> Result<()> {
    match values.iter().find(|(_, v)| !v.is_finite()) {
        Some(&(name, value)) => Err(Error::NonFinite {
            name,
            row: 0,
            col: 0,
            value,
        }),
        None => Ok(()),
    }
}

/// Checks that a vector has `len` entries.
pub(super) fn check_len(
    name: &'static str,
    v: &DVector<f64>,
    len: usize,
    what: &str,
) -> Result<()> {
    if v.len() == len {
        Ok(())
    } else {
        Err(Error::Shape {
            name,
            rows: v.len(),
            cols: 1,
            expected: format!("{len}×1 ({what})"),
        })
    }
}

/// A validated whitening operator W with WᵀW = V.
#[derive(Debug, Clone)]
enum Whitener {
    Identity,
    /// √vᵢ.
    Diagonal(DVector<f64>),
    /// Lᵀ, upper triangular, from V = L·Lᵀ.
    Upper(DMatrix<f64>),
}

impl Whitener {
    /// Validates `weights` for `m` rows and builds W.
    fn new(name: &'static str, weights: &Weights, m: usize) -> Result<Self> {
        match weights {
            Weights::Identity => Ok(Self::Identity),
            Weights::Diagonal(v) => {
                check_len(name, v, m, "one weight per row")?;
                check_finite(name, v)?;
                if let Some((index, &value)) = v.iter().enumerate().find(|(_, w)| **w < 0.0) {
                    return Err(Error::NegativeWeight { name, index, value });
                }
                Ok(Self::Diagonal(v.map(f64::sqrt)))
            }
            Weights::Full(V) => {
                if V.nrows() != m || V.ncols() != m {
                    return Err(Error::Shape {
                        name,
                        rows: V.nrows(),
                        cols: V.ncols(),
                        expected: format!("{m}×{m} (one row and column per measurement)"),
                    });
                }
                check_finite(name, V)?;
                // The workspace's tolerance policy: asymmetry relative to V's own scale.
                let tol = numerics::symmetry_tolerance(V.amax());
                let mut worst = (0, 0, 0.0_f64);
                for i in 0..m {
                    for j in 0..i {
                        let d = (V[(i, j)] - V[(j, i)]).abs();
                        if d > worst.2 {
                            worst = (i, j, d);
                        }
                    }
                }
                if worst.2 > tol {
                    return Err(Error::NotSymmetric {
                        name,
                        n: m,
                        row: worst.0,
                        col: worst.1,
                        difference: worst.2,
                    });
                }
                let sym = symmetric_part(V.clone());
                let chol = sym
                    .cholesky()
                    .ok_or(Error::NotPositiveDefinite { name, n: m })?;
                Ok(Self::Upper(chol.l().transpose()))
            }
        }
    }

    /// W·M.
    fn apply(&self, M: &DMatrix<f64>) -> DMatrix<f64> {
        match self {
            Self::Identity => M.clone(),
            Self::Diagonal(w) => {
                let mut out = M.clone();
                for (i, mut row) in out.row_iter_mut().enumerate() {
                    row *= w[i];
                }
                out
            }
            Self::Upper(U) => U * M,
        }
    }

    /// W·v.
    fn apply_vec(&self, v: &DVector<f64>) -> DVector<f64> {
        match self {
            Self::Identity => v.clone(),
            Self::Diagonal(w) => v.component_mul(w),
            Self::Upper(U) => U * v,
        }
    }

    /// M·W (M has m columns).
    fn right_apply(&self, M: &DMatrix<f64>) -> DMatrix<f64> {
        match self {
            Self::Identity => M.clone(),
            Self::Diagonal(w) => {
                let mut out = M.clone();
                for (j, mut col) in out.column_iter_mut().enumerate() {
                    col *= w[j];
                }
                out
            }
            Self::Upper(U) => M * U,
        }
    }
}

/// κ₂ from descending singular values of a matrix with n columns (∞ if fewer than n or the
/// smallest is zero).
fn condition_from(sv: &DVector<f64>, n: usize) -> f64 {
    if sv.len() < n || n == 0 {
        return f64::INFINITY;
    }
    let smin = sv[n - 1];
    if smin > 0.0 {
        sv[0] / smin
    } else {
        f64::INFINITY
    }
}

/// The whitened (and possibly augmented) system, validated.
#[derive(Debug)]
struct System {
    /// Rows: W·H, then √λ·L, then W_p·P.
    A: DMatrix<f64>,
    /// W·z, √λ·L·x_p, W_p·p.
    b: DVector<f64>,
    /// The measurement rows' whitener.
    W: Whitener,
    /// Measurement rows m.
    m: usize,
    /// Singular values of W·H, descending.
    sv: DVector<f64>,
    rank: usize,
    tolerance: f64,
    condition_solved: f64,
}

/// Validates the inputs and assembles the whitened system; errors on rank deficiency unless
/// regularisation or prior rows make the augmented system full rank.
fn assemble(
    H: &DMatrix<f64>,
    z: &DVector<f64>,
    weights: &Weights,
    options: &SolveOptions,
) -> Result<System> {
    let (m, n) = H.shape();
    if m == 0 || n == 0 {
        return Err(Error::Shape {
            name: "H",
            rows: m,
            cols: n,
            expected: "m×n with m ≥ 1 and n ≥ 1".into(),
        });
    }
    check_finite("H", H)?;
    check_len("z", z, m, "rows(H)")?;
    check_finite("z", z)?;
    let W = Whitener::new("V", weights, m)?;
    let A0 = W.apply(H);
    let b0 = W.apply_vec(z);
    let sv = A0.singular_values();
    let smax = if sv.is_empty() { 0.0 } else { sv[0] };
    let tolerance = match options.rank_tolerance {
        Some(t) if !t.is_finite() || t < 0.0 => {
            return Err(Error::InvalidParameter {
                name: "rank_tolerance",
                value: t,
                rule: "must be finite and ≥ 0",
            });
        }
        Some(t) => t,
        None => m.max(n) as f64 * f64::EPSILON * smax,
    };
    let rank = sv.iter().filter(|&&s| s > tolerance).count();

    let mut blocks_A = vec![A0];
    let mut blocks_b = vec![b0];
    if let Some(t) = &options.tikhonov {
        if !t.lambda.is_finite() || t.lambda < 0.0 {
            return Err(Error::InvalidParameter {
                name: "tikhonov.lambda",
                value: t.lambda,
                rule: "must be finite and ≥ 0",
            });
        }
        let L = match &t.operator {
            Some(L) => {
                if L.ncols() != n || L.nrows() == 0 {
                    return Err(Error::Shape {
                        name: "tikhonov.operator",
                        rows: L.nrows(),
                        cols: L.ncols(),
                        expected: format!("k×{n} with k ≥ 1 (one column per unknown)"),
                    });
                }
                check_finite("tikhonov.operator", L)?;
                L.clone()
            }
            None => DMatrix::identity(n, n),
        };
        let xp = match &t.prior_mean {
            Some(xp) => {
                check_len("tikhonov.prior_mean", xp, n, "one entry per unknown")?;
                check_finite("tikhonov.prior_mean", xp)?;
                xp.clone()
            }
            None => DVector::zeros(n),
        };
        let s = t.lambda.sqrt();
        blocks_b.push(&L * &xp * s);
        blocks_A.push(L * s);
    }
    if let Some(p) = &options.prior {
        let k = p.rows.nrows();
        if p.rows.ncols() != n || k == 0 {
            return Err(Error::Shape {
                name: "prior.rows",
                rows: k,
                cols: p.rows.ncols(),
                expected: format!("k×{n} with k ≥ 1 (one column per unknown)"),
            });
        }
        check_finite("prior.rows", &p.rows)?;
        check_len("prior.values", &p.values, k, "rows(prior.rows)")?;
        check_finite("prior.values", &p.values)?;
        let Wp = Whitener::new("prior.weights", &p.weights, k)?;
        blocks_A.push(Wp.apply(&p.rows));
        blocks_b.push(Wp.apply_vec(&p.values));
    }
    let regularised = blocks_A.len() > 1;
    let total: usize = blocks_A.iter().map(DMatrix::nrows).sum();
    let mut A = DMatrix::zeros(total, n);
    let mut b = DVector::zeros(total);
    let mut at = 0;
    for (Ai, bi) in blocks_A.iter().zip(&blocks_b) {
        A.rows_mut(at, Ai.nrows()).copy_from(Ai);
        b.rows_mut(at, bi.nrows()).copy_from(bi);
        at += Ai.nrows();
    }
    let condition_solved = if regularised {
        let sv_aug = A.singular_values();
        let smax_aug = if sv_aug.is_empty() { 0.0 } else { sv_aug[0] };
        let tol_aug = options
            .rank_tolerance
            .unwrap_or(total.max(n) as f64 * f64::EPSILON * smax_aug);
        let rank_aug = sv_aug.iter().filter(|&&s| s > tol_aug).count();
        if rank_aug < n {
            return Err(Error::RankDeficient {
                name: "regularised system",
                rank: rank_aug,
                cols: n,
                tolerance: tol_aug,
            });
        }
        condition_from(&sv_aug, n)
    } else {
        if rank < n {
            return Err(Error::RankDeficient {
                name: "V^(1/2) H",
                rank,
                cols: n,
                tolerance,
            });
        }
        condition_from(&sv, n)
    };
    Ok(System {
        A,
        b,
        W,
        m,
        sv,
        rank,
        tolerance,
        condition_solved,
    })
}

/// R from the QR factorisation of a full-column-rank A (rows ≥ n), and the QR itself.
fn qr_of(
    A: &DMatrix<f64>,
) -> (
    nalgebra::linalg::QR<f64, nalgebra::Dyn, nalgebra::Dyn>,
    DMatrix<f64>,
) {
    let qr = A.clone().qr();
    let R = qr.r();
    (qr, R)
}

/// (RᵀR)⁻¹ = R⁻¹R⁻ᵀ by triangular solves, symmetrised.
fn covariance_from_r(R: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = R.ncols();
    let Rinv = R
        .solve_upper_triangular(&DMatrix::identity(n, n))
        .ok_or(Error::Singular {
            name: "R (QR factor)",
            detail: "zero on the diagonal",
        })?;
    let C = &Rinv * Rinv.transpose();
    Ok(symmetric_part(C))
}

/// Solves min ‖V^{1/2}(H x − z)‖² (+ regularisation and prior rows from `options`).
///
/// # Errors
/// Shape mismatch, non-finite entries, negative or non-SPD weights, invalid λ or tolerance,
/// rank deficiency without regularisation, and residual-variance scaling without degrees of
/// freedom are all typed [`Error`]s.
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{SolveOptions, Weights, solve};
/// // A straight line through three points, the last one measured four times as precisely.
/// let h = dmatrix![1.0, 0.0; 1.0, 1.0; 1.0, 2.0];
/// let z = dvector![0.1, 0.9, 2.0];
/// let sol = solve(&h, &z, &Weights::Diagonal(dvector![1.0, 1.0, 4.0]), &SolveOptions::default())?;
/// // The normal equations HᵀVH x = HᵀVz hold at the solution.
/// let v = dmatrix![1.0, 0.0, 0.0; 0.0, 1.0, 0.0; 0.0, 0.0, 4.0];
/// let grad = h.transpose() * &v * (&h * &sol.x - &z);
/// assert!(grad.norm() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
pub fn solve(
    H: &DMatrix<f64>,
    z: &DVector<f64>,
    weights: &Weights,
    options: &SolveOptions,
) -> Result<Solution> {
    let sys = assemble(H, z, weights, options)?;
    let n = H.ncols();
    let (x, mut covariance) = match options.method {
        SolveMethod::Qr => {
            let (qr, R) = qr_of(&sys.A);
            let mut qtb = sys.b.clone();
            qr.q_tr_mul(&mut qtb);
            let rhs = qtb.rows(0, n).into_owned();
            let x = R.solve_upper_triangular(&rhs).ok_or(Error::Singular {
                name: "R (QR factor)",
                detail: "zero on the diagonal",
            })?;
            (x, covariance_from_r(&R)?)
        }
        SolveMethod::NormalEquations => {
            let N = sys.A.transpose() * &sys.A;
            let rhs = sys.A.transpose() * &sys.b;
            let I = DMatrix::identity(n, n);
            let (x, C) = if let Some(chol) = N.clone().cholesky() {
                (chol.solve(&rhs), chol.solve(&I))
            } else {
                // Rounding can make HᵀVH indefinite when κ(A)² ≳ 1/ε; LU still returns the
                // (inaccurate) answer the paper's formula would give.
                let lu = N.lu();
                let singular = Error::Singular {
                    name: "HᵀVH",
                    detail: "LU met a zero pivot",
                };
                let x = lu.solve(&rhs).ok_or(singular.clone())?;
                let C = lu.solve(&I).ok_or(singular)?;
                (x, C)
            };
            (x, symmetric_part(C))
        }
    };
    let r_all = &sys.A * &x - &sys.b;
    let weighted_sum_of_squares = r_all.norm_squared();
    let rows = sys.A.nrows();
    let residual_variance = (rows > n).then(|| weighted_sum_of_squares / (rows - n) as f64);
    if options.scale_covariance {
        let s2 = residual_variance.ok_or(Error::NoDegreesOfFreedom { rows, cols: n })?;
        covariance *= s2;
    }
    let residuals = z - H * &x;
    let A_meas = sys.A.rows(0, sys.m);
    let normal = A_meas.transpose() * A_meas;
    let condition_normal = condition_from(&normal.singular_values(), n);
    Ok(Solution {
        x,
        covariance,
        covariance_scaled: options.scale_covariance,
        residuals,
        weighted_sum_of_squares,
        residual_variance,
        condition_weighted: condition_from(&sys.sv, n),
        singular_values: sys.sv,
        condition_normal,
        condition_solved: sys.condition_solved,
        rank: sys.rank,
        rank_tolerance: sys.tolerance,
        method: options.method,
    })
}

/// The sensitivity ∂x̂/∂z (n×m) of the solution to the measurements: (HᵀVH)⁻¹HᵀV without
/// regularisation, and the corresponding block of the regularised solution map with it.
///
/// Computed from the QR factors of the whitened system (R⁻¹Q₁ᵀW), never by inverting HᵀVH.
///
/// # Errors
/// As [`solve`] (the measurement vector is not needed).
///
/// ```
/// use wls::nalgebra::dmatrix;
/// use wls::solver::{SolveOptions, Weights, sensitivity};
/// // Mean of two readings: each moves the estimate by half its own change.
/// let s = sensitivity(&dmatrix![1.0; 1.0], &Weights::Identity, &SolveOptions::default())?;
/// assert!((s[(0, 0)] - 0.5).abs() < 1e-12 && (s[(0, 1)] - 0.5).abs() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
pub fn sensitivity(
    H: &DMatrix<f64>,
    weights: &Weights,
    options: &SolveOptions,
) -> Result<DMatrix<f64>> {
    let z = DVector::zeros(H.nrows());
    let sys = assemble(H, &z, weights, options)?;
    let n = H.ncols();
    let (qr, R) = qr_of(&sys.A);
    let Q = qr.q();
    let Q1t = Q.rows(0, sys.m).transpose();
    let M = sys.W.right_apply(&Q1t);
    let S = R.solve_upper_triangular(&M).ok_or(Error::Singular {
        name: "R (QR factor)",
        detail: "zero on the diagonal",
    })?;
    debug_assert_eq!(S.nrows(), n);
    Ok(S)
}

/// Worst-case error of each unknown when every measurement error is bounded, |δzᵢ| ≤ Δᵢ:
/// the row sums of |∂x̂/∂z|·Δ. Exact for the linear map (attained at a corner δz = ±Δ).
///
/// # Errors
/// As [`sensitivity`], plus `delta` of the wrong length, non-finite or negative.
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{SolveOptions, Weights, worst_case_bounds};
/// // x = z₁ − z₂ from two rows: errors of ±0.1 on each add up to ±0.2 in the worst case.
/// let h = dmatrix![1.0, 1.0; 0.0, 1.0];
/// let delta = dvector![0.1, 0.1];
/// let b = worst_case_bounds(&h, &Weights::Identity, &delta, &SolveOptions::default())?;
/// assert!((b[0] - 0.2).abs() < 1e-12 && (b[1] - 0.1).abs() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
pub fn worst_case_bounds(
    H: &DMatrix<f64>,
    weights: &Weights,
    delta: &DVector<f64>,
    options: &SolveOptions,
) -> Result<DVector<f64>> {
    check_len("delta", delta, H.nrows(), "one bound per measurement")?;
    check_finite("delta", delta)?;
    if let Some((_, &value)) = delta.iter().enumerate().find(|(_, d)| **d < 0.0) {
        return Err(Error::InvalidParameter {
            name: "delta",
            value,
            rule: "error bounds must be ≥ 0",
        });
    }
    let S = sensitivity(H, weights, options)?;
    Ok(S.abs() * delta)
}

/// `(M + Mᵀ)/2` of a square `M`, by the workspace's one symmetrisation
/// (`numerics::symmetrise`).
fn symmetric_part(mut m: DMatrix<f64>) -> DMatrix<f64> {
    let n = m.nrows();
    numerics::symmetrise(m.as_mut_slice(), n);
    m
}
