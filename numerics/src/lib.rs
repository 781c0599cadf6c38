//! The numerical rules and kernels that the workspace's independent crates share, on
//! column-major slices and without a matrix library: the covariance tolerance policy
//! ([`SYMMETRY_TOL`], [`PSD_TOL`]), the symmetrisation (A + Aᵀ)/2 ([`symmetrise`]), and the
//! matrix exponential ([`Expm`], [`van_loan`]).
//!
//! `stochest-model` (nalgebra), `stochest-kalman` (faer) and `stochest-wls` (nalgebra) each
//! build and publish on their own, so a rule that all of them apply has its home here, below
//! them, rather than in one of them; each crate re-exports the constants and wraps the
//! kernels in its own matrix types.
//!
//! # Notation
//! A square n×n matrix is stored column-major: entry (i, j) at `a[i + j·n]`. `max|A|` is the
//! largest absolute entry, λ the eigenvalues of the symmetric part.
//!
//! # Example
//! ```
//! // Van Loan's sampling of a random walk of intensity 3 over 0.5 s: F = 1, Q_d = 1.5.
//! let (mut f, mut qd) = ([0.0], [0.0]);
//! assert!(numerics::van_loan(&[0.0], &[3.0], 1, 0.5, &mut f, &mut qd));
//! assert!((f[0] - 1.0).abs() < 1e-15 && (qd[0] - 1.5).abs() < 1e-12);
//! ```

mod expm;

#[cfg(feature = "autodiff")]
pub use expm::expm_of;
pub use expm::{Expm, van_loan};

/// Symmetry tolerance of covariance inputs: a matrix is accepted as symmetric when
/// `max|A_ij − A_ji| ≤ SYMMETRY_TOL·max|A|` (loose enough for matrices computed as products
/// such as `D Q Dᵀ`, tight enough to catch a transposed or mistyped entry), and is then
/// stored symmetrised. Relative to the matrix's own scale, so a change of units never
/// changes a verdict.
pub const SYMMETRY_TOL: f64 = 1e-10;

/// PSD tolerance of covariance inputs: the smallest eigenvalue of the symmetric part must be
/// at least `−PSD_TOL·max|λ|` (round-off of an exactly singular covariance such as the fuel
/// model's `R = D Q Dᵀ` stays far inside it).
pub const PSD_TOL: f64 = 1e-10;

/// The largest asymmetry `max|A_ij − A_ji|` accepted for a matrix whose largest absolute
/// entry is `scale`: `SYMMETRY_TOL·scale`.
///
/// # Example
/// ```
/// let a = [2.0_f64, 1.0 + 1e-12, 1.0, 2.0]; // column-major, asymmetry 1e-12
/// assert!((a[1] - a[2]).abs() <= numerics::symmetry_tolerance(2.0));
/// ```
#[inline]
pub fn symmetry_tolerance(scale: f64) -> f64 {
    SYMMETRY_TOL * scale
}

/// The most negative eigenvalue accepted, as a magnitude, for a symmetric matrix whose
/// largest absolute eigenvalue is `lmax`: `PSD_TOL·lmax` (λ_min ≥ −`psd_tolerance(lmax)`).
///
/// # Example
/// ```
/// // λ = (4, −1e-12): PSD within the tolerance; λ = (4, −1e-6): not.
/// assert!(-1e-12 >= -numerics::psd_tolerance(4.0));
/// assert!(-1e-6 < -numerics::psd_tolerance(4.0));
/// ```
#[inline]
pub fn psd_tolerance(lmax: f64) -> f64 {
    PSD_TOL * lmax
}

/// The scalars of the kernels: `f64`, and with the feature `autodiff` every `num-dual` dual
/// number over it, so code differentiating through a filter pass or an exponential runs the
/// same kernels as the plain one.
pub trait Real:
    Copy
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::SubAssign
    + std::ops::AddAssign
    + std::ops::Mul<f64, Output = Self>
{
    /// The square root.
    fn sqrt(self) -> Self;
    /// The value (the real part of a dual number).
    fn value(self) -> f64;
    /// The constant `v` (no derivative part).
    fn constant(v: f64) -> Self;
}

#[cfg(not(feature = "autodiff"))]
impl Real for f64 {
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn value(self) -> f64 {
        self
    }
    #[inline(always)]
    fn constant(v: f64) -> Self {
        v
    }
}

#[cfg(feature = "autodiff")]
impl<T: num_dual::DualNum<Primitive = f64> + Copy> Real for T {
    #[inline(always)]
    fn sqrt(self) -> Self {
        num_dual::DualNum::sqrt(&self)
    }
    #[inline(always)]
    fn value(self) -> f64 {
        num_dual::DualStruct::re(&self)
    }
    #[inline(always)]
    fn constant(v: f64) -> Self {
        T::from(v)
    }
}

/// Replaces the square `n`×`n` column-major `a` by `(a + aᵀ)/2` (each pair of entries by
/// their mean, the diagonal unchanged).
///
/// # Panics
/// If `a` holds fewer than n² entries.
///
/// # Example
/// ```
/// let mut a = [1.0, 2.0, 4.0, 3.0]; // [[1, 4], [2, 3]]
/// numerics::symmetrise(&mut a, 2);
/// assert_eq!(a, [1.0, 3.0, 3.0, 3.0]);
/// ```
#[inline(always)]
pub fn symmetrise<T: Real>(a: &mut [T], n: usize) {
    for j in 0..n {
        for i in 0..j {
            let s = (a[i + j * n] + a[j + i * n]) * 0.5;
            a[i + j * n] = s;
            a[j + i * n] = s;
        }
    }
}

/// The README's examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
