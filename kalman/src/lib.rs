//! A generic linear Kalman filter engine: Joseph, standard and square-root covariance
//! forms, exact cross-covariance of process and measurement noise, singular measurement
//! noise, missing measurements, consistency statistics, and a step that never allocates.
//!
//! # Notation
//! n states, m measurements, p control inputs:
//!
//! ```text
//! x_{k+1} = F x_k + B u_k + w_k,     z_k = H x_k + v_k,
//! cov(w_k) = Q,   cov(v_k) = R,   E[w_k v_kᵀ] = S,
//! ```
//!
//! `(x0, P0)` is the prior of the first measurement. Step `k` updates with `z_k` (innovation
//! `e_k = z_k − H x_{k|k−1}`, its covariance `Σ_k = H P_{k|k−1} Hᵀ + R`, gain
//! `K_k = P_{k|k−1} Hᵀ Σ_k⁺`) and then predicts to `k + 1` with `u_k`; with `S ≠ 0` the
//! prediction uses the correlated-noise recursion
//! `x_{k+1|k} = F x_{k|k} + B u_k + S Σ_k⁺ e_k`,
//! `P_{k+1|k} = F P_{k|k} Fᵀ + Q − F K_k Sᵀ − S K_kᵀ Fᵀ − S Σ_k⁺ Sᵀ`.
//! After step `k` the filter holds both `x_{k|k}` ("current" form) and `x_{k+1|k}`
//! ("delayed" form).
//!
//! # Storage paths
//! [`Filter<DynDims>`](Filter) (the default) keeps heap buffers sized at construction and hands
//! large products to faer's GEMM (`Par::Seq`; Rayon above a threshold with the `parallel`
//! feature). [`Filter<FixedDims<N, M, P>>`](Filter) keeps its buffers inline, each sized by N, M
//! and P (n, m ≤ 16).
//! Both run the same kernels on slices, so they share validation, semantics and tests.
//!
//! # Beyond the step
//! - [`riccati`]: steady state — DARE by structured doubling (with the cross term S), the
//!   discrete LQR gain as its dual, CARE; undetectable or unstabilisable pairs are typed errors.
//! - [`continuous`]: the Kalman–Bucy Riccati ODE, matrix exponential and Van Loan sampling.
//! - [`smoother`]: the Rauch–Tung–Striebel smoother over a recorded forward pass.
//! - [`nonlinear`]: the extended (also iterated) and unscented Kalman filters and their
//!   Rauch–Tung–Striebel smoothers, with Jacobians by hand, by automatic differentiation
//!   (feature `autodiff`) or by central differences.
//! - [`diagnostics`]: is the model right? NIS with its χ² bands, innovation
//!   autocorrelation and the Ljung–Box test, Welch's power spectral density.
//! - [`fit`]: learning the model from data — exact log-likelihood and its gradient,
//!   maximum likelihood, EM, standard errors.
//! - [`schedule`]: the Monte Carlo mode — the data-independent gain sequence computed once
//!   ([`schedule::GainSchedule`]) and many measurement streams run at the cost of the state
//!   update alone; also the fixed-gain filter.
//! - `particle` (feature `particle`): bootstrap and auxiliary particle filters over any
//!   transition and likelihood, four resampling schemes, the FFBSi particle smoother.
//! - [`prelude`]: `use kalman::prelude::*;` gives a program the model, the filter, the
//!   Riccati solvers and, with the feature `nalgebra`, `ToNalgebra` and the nalgebra types and
//!   macros of the version this crate is built against.
//!
//! # Robustness
//! Σ is factored by Cholesky with a relative pivot tolerance ([`RANK_TOL`]), falling back to
//! a Jacobi eigen-decomposition and the pseudo-inverse when it is (numerically) singular —
//! e.g. an exact measurement channel with `R_ii = 0`. A NaN entry of `z` drops that row; an
//! all-NaN `z` is a predict-only step (its [`StepInfo::nis`] is `None`). A step whose state
//! or covariance is no longer finite returns [`Error::Diverged`] naming the step (every covariance form, both storage paths, the gain
//! schedule and the smoother).
//!
//! # Example
//! ```
//! use kalman::{CovarianceForm, DynDims, Filter, Model};
//! # fn main() -> Result<(), kalman::Error> {
//! // Constant-velocity model with position measurements.
//! let dt = 0.1;
//! let model = Model::new(
//!     DynDims::new(2, 1, 0)?,
//!     &[[1.0, dt], [0.0, 1.0]],
//!     &[[1.0, 0.0]],
//!     &[[1e-4, 0.0], [0.0, 1e-3]],
//!     &[[0.01]],
//! )?;
//! let mut filter = Filter::new(model, &[0.0, 1.0], &[[1.0, 0.0], [0.0, 1.0]], CovarianceForm::Joseph)?;
//! for z in [0.11, 0.19, f64::NAN, 0.42] {
//!     let info = filter.step(&[z], None)?;
//!     // No NIS on the step whose measurement is missing.
//!     assert_eq!(info.nis.is_some(), !z.is_nan());
//! }
//! assert!((filter.state()[1] - 1.0).abs() < 0.5);
//! # Ok(())
//! # }
//! ```
//!
//! # References
//! - R. E. Kalman, *A new approach to linear filtering and prediction problems*, 1960; the
//!   Joseph form and the correlated-noise recursion as in D. Simon, *Optimal State
//!   Estimation*, 2006.
//! - H. E. Rauch, F. Tung, C. T. Striebel, *Maximum likelihood estimates of linear dynamic
//!   systems*, 1965 — [`smoother`].
//! - Structured doubling for the DARE: E. K.-W. Chu, H.-Y. Fan, W.-W. Lin, C.-S. Wang,
//!   *Structure-preserving algorithms for periodic discrete-time algebraic Riccati
//!   equations*, 2004 — [`riccati`].
//! - Yu. V. Gridnev, A. Yu. Rusetsky, S. A. Rak, *Stochastic simulation of the automatic
//!   control systems of an unmanned aerial vehicle with an optimal Kalman filter* (in
//!   Russian, 2013): the UAV loop in the example of [`riccati::Dlqr`].
//!
//! # nalgebra in, nalgebra out
//! Every matrix argument of the public API — [`Model::new`], [`Filter::new`], the Riccati
//! solvers ([`riccati::Dare`], [`riccati::Dlqr`], [`riccati::Care`], …),
//! [`continuous::expm`], the nonlinear filters — takes anything that implements
//! [`MatrixInput`]: row-major arrays `[[f64; C]; R]`, faer matrices and, with the feature
//! `nalgebra`, nalgebra matrices (`&DMatrix<f64>`, fixed-size `Matrix2<f64>`, views). Vectors
//! are `&[f64]` (`dvector.as_slice()`). Results are faer matrices and slices; with the feature
//! `nalgebra` one idiom brings any of them back: `.to_nalgebra()` from [`ToNalgebra`]
//! (`filter.covariance().to_nalgebra()`, `filter.state().to_nalgebra()`), and on the result
//! structs it converts every matrix at once (`Dare::new(…)?.solve()?.to_nalgebra().gain`,
//! `model.smooth(…)?.to_nalgebra().means`). [`Model::from_matrices`] reads the dimensions off
//! the matrices, [`Model::smooth`] filters a whole series with gaps and smooths it in one call.
//!
#![cfg_attr(
    feature = "nalgebra",
    doc = r##"
```
use kalman::nalgebra::{DMatrix, dmatrix, dvector};
use kalman::{CovarianceForm, Filter, Model, ToNalgebra};
# fn main() -> Result<(), kalman::Error> {
let dt = 0.1;
let f = dmatrix![1.0, dt; 0.0, 1.0];
let h = dmatrix![1.0, 0.0];
let q = dmatrix![1e-4, 0.0; 0.0, 1e-3];
let r = dmatrix![0.01];
// The dimensions are read off the matrices (n = 2 from F, m = 1 from H).
let model = Model::from_matrices(&f, &h, &q, &r)?;
// The offline path in one call: filter with gaps (NaN), RTS-smooth, nalgebra out.
let zs = dvector![0.11, 0.19, f64::NAN, 0.42];
let s = model.smooth(&[0.0, 1.0], &DMatrix::identity(2, 2), &zs)?.to_nalgebra();
assert_eq!((s.means.ncols(), s.covariances.len()), (4, 4));
// Or step by step, keeping the filter.
let mut filter = Filter::new(model, &[0.0, 1.0], &DMatrix::identity(2, 2), CovarianceForm::Joseph)?;
let smoothed = filter.run_smoothed([[0.11], [0.19], [f64::NAN], [0.42]])?;
let p: DMatrix<f64> = filter.covariance().to_nalgebra();
let means: DMatrix<f64> = smoothed.means.to_nalgebra(); // column k is x_{k|N-1}
// The RTS smoother ends where the filter ends.
assert!((means.column(3) - filter.state().to_nalgebra()).norm() < 1e-12);
assert!((&smoothed.covariances.to_nalgebra()[3] - &p).norm() < 1e-12);
// The steady state of the same model, nalgebra in and out.
let steady = kalman::riccati::Dare::new(&f, &h, &q, &r)?.solve()?.to_nalgebra();
let k: &DMatrix<f64> = &steady.gain;
assert_eq!(k.shape(), (2, 1));
# Ok(())
# }
```
"##
)]
//!
//! # Versions of the types in this API and features
//! Matrices are stored and returned as [`faer`] 0.24 types. faer is re-exported
//! (`kalman::faer`) and, with the feature, nalgebra 0.35 too (`kalman::nalgebra`), so a user
//! does not need to add either dependency — or pick a matching version — to name their types.
//! A nalgebra user enables one feature: `stochest-kalman = { version = "0.1", features =
//! ["nalgebra"] }`.
//!
//! | feature | what it adds |
//! |---|---|
//! | `nalgebra` | nalgebra 0.35 matrices as inputs, [`ToNalgebra`] for results; `kalman::nalgebra` |
//! | `autodiff` | exact Jacobians for the nonlinear filters by forward-mode automatic differentiation |
//! | `argmin` | maximum-likelihood fitting by L-BFGS and Nelder–Mead ([`fit`]) |
//! | `proptest` | `kalman::strategies`: random consistent filter problems for property tests |
//! | `parallel` | Rayon in faer's products above [`PARALLEL_THRESHOLD`] |
//! | `particle` | bootstrap and auxiliary particle filters, resampling, the FFBSi smoother (`kalman::particle`) |
#![deny(missing_docs)]
// Links to the items of feature `nalgebra` resolve in the all-features build (docs.rs, CI),
// which checks every link; without the feature they have no target.
#![cfg_attr(not(feature = "nalgebra"), allow(rustdoc::broken_intra_doc_links))]

pub mod batch;
mod consistency;
pub mod continuous;
#[cfg(feature = "nalgebra")]
mod convert;
pub mod dense;
pub mod diagnostics;
mod error;
mod filter;
pub mod fit;
pub mod gate;
pub mod imm;
mod input;
mod kernels;
mod model;
pub mod nonlinear;
#[cfg(feature = "particle")]
pub mod particle;
pub mod prelude;
pub mod riccati;
pub mod sampling;
pub mod schedule;
pub mod smoother;
mod storage;
#[cfg(feature = "proptest")]
pub mod strategies;

pub use consistency::{Nees, chi2_cdf, chi2_quantile, chi2_sf, nees};
#[cfg(feature = "nalgebra")]
pub use convert::ToNalgebra;
pub use error::Error;
pub use filter::{CovarianceForm, Filter, StepInfo};
pub use kernels::{FAER_THRESHOLD, PARALLEL_THRESHOLD, RANK_TOL};
pub use model::{Diagonal, MatrixInput, Model, ModelSource, PSD_TOL, SYMMETRY_TOL};
pub use storage::{Dims, DynDims, FIXED_MAX, FixedDims};

/// Re-export of the faer version whose matrix types this API returns.
pub use faer;
/// Re-export of the nalgebra version whose matrices this API accepts (feature `nalgebra`).
#[cfg(feature = "nalgebra")]
pub use nalgebra;

/// The fixed-size filter: `FixedFilter<N, M, P>` = `Filter<FixedDims<N, M, P>>`.
pub type FixedFilter<const N: usize, const M: usize, const P: usize = 0> =
    Filter<FixedDims<N, M, P>>;
/// The fixed-size model.
pub type FixedModel<const N: usize, const M: usize, const P: usize = 0> = Model<FixedDims<N, M, P>>;

/// The README's examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
