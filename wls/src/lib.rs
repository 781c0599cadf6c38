//! Ill-conditioning-aware weighted least squares with prior information, and the erector-boom
//! angular-acceleration estimator with the sensor-offset-angle (γ) method of Zavyalov and
//! Shatov (see [References](#references)).
//!
//! # Notation
//! n unknowns x, m measurements z, design matrix H (m×n), weight matrix V (m×m, diagonal or
//! symmetric positive definite): the solver minimises ‖V^{1/2}(H x − z)‖². The covariance is
//! (HᵀVH)⁻¹; κ is the 2-norm condition number (σ_max/σ_min). In the boom estimator
//! α is the boom angle, ε its angular acceleration, g gravity, r the sensor radius, γ the
//! sensor offset angle, β = α − γ the angle the sensor sees, and the state is
//! x = (s, c, ε) = (sin β, cos β, ε).
//!
//! # Modules
//! - [`solver`]: QR (default) or normal-equation solves, covariance from the R factor,
//!   condition numbers and numerical rank, Tikhonov and prior rows, iteratively re-weighted
//!   solves, sensitivity ∂x/∂z and worst-case bounds.
//! - [`boom`]: the per-cycle estimator (direct, linearised 3×3, WLS), the rotation profile,
//!   and the γ sweep.
//! - [`prelude`]: `use wls::prelude::*;` gives a program the solver, its options and weights,
//!   and the nalgebra types and macros (`DMatrix`, `DVector`, `dmatrix!`, `dvector!`) of the
//!   version this crate is built against.
//!
//! # The boom paper's choices
//! The WLS (9)–(10) of Zavyalov and Shatov (see [`boom`] for the equations) does not say in
//! which units ε sits in the state, nor when the ε₀ weight v₆ = 0.5/(1 + 2|ε̇|)² is
//! evaluated. Both are configuration fields ([`boom::AngleUnit`] for ε and ε̇,
//! [`boom::RateWeight`]). The defaults of [`boom::BoomConfig`] — ε in °/s² inside the state
//! (H₂₃ = r·π/180), ε̇ in °/s³ in v₆, v₆ made self-consistent within each cycle — are the
//! ones under which the paper's full turn behaves as the paper reports: direct inversion and
//! the 3×3 solve exceed the limits near the end of the turn, WLS at γ = 0 stays within them
//! except δε for the "+" error variant, and WLS at γ = 10° is within both over the whole turn.
//! With ε in rad/s² the ε₀ prior is (180/π)² ≈ 3283 times weaker and WLS behaves like direct
//! inversion. [`boom::AngleRecovery::Atan2`] keeps the angle defined where `arcsin` of the
//! solved s would not be (|s| > 1 near the end of the turn).
//!
//! # Example
//! ```
//! use nalgebra::{dmatrix, dvector};
//! use wls::solver::{solve, SolveOptions, Weights};
//!
//! let h = dmatrix![1.0, 0.0; 0.0, 1.0; 1.0, 1.0];
//! let z = dvector![1.0, 2.0, 3.0];
//! let sol = solve(&h, &z, &Weights::Diagonal(dvector![1.0, 1.0, 4.0]), &SolveOptions::default())?;
//! assert!((sol.x[0] - 1.0).abs() < 1e-12 && (sol.x[1] - 2.0).abs() < 1e-12);
//! assert_eq!(sol.rank, 2);
//!
//! // The boom estimator: exact readings at α = 30°, ε = 0.01 rad/s², γ = 0.
//! use wls::boom::{BoomConfig, BoomEstimator};
//! let cfg = BoomConfig::default();
//! let (g, r, a, e) = (cfg.g, cfg.sensor_radius, 30f64.to_radians(), 0.01);
//! let mut est = BoomEstimator::new(cfg)?;
//! for _ in 0..3 {
//!     let out = est.update(g * a.sin(), g * a.cos() + e * r, 0.0)?;
//!     assert!(out.defined && (out.angle - a).abs() < 1e-9);
//! }
//! # Ok::<(), wls::Error>(())
//! ```
//!
//! # References
//! - P. P. Zavyalov, A. A. Shatov, *Determination of the angular acceleration of rotary
//!   elements of rocket complexes in ground tests* (in Russian): the boom estimator, its
//!   equations (1)–(10) and the sensor offset angle.
//! - G. H. Golub, C. F. Van Loan, *Matrix Computations*: QR least squares, condition numbers
//!   and numerical rank; A. N. Tikhonov, V. Y. Arsenin, *Solutions of Ill-Posed Problems*:
//!   the regularisation.
//!
//! # Versions of the types in this API
//! Matrices and vectors are [`nalgebra`] 0.35 types (`DMatrix<f64>`, `DVector<f64>`),
//! re-exported as [`wls::nalgebra`](nalgebra) so a user can name exactly the version this
//! crate is built against.
#![deny(missing_docs)]

pub mod boom;
mod error;
pub mod prelude;
pub mod solver;

pub use error::{Error, Result};

/// Symmetry tolerance of a full weight matrix `V`, relative to its own scale: accepted when
/// `max|Vᵢⱼ − Vⱼᵢ| ≤ SYMMETRY_TOL · max|V|`, then symmetrised. The same value and rule as
/// `model::SYMMETRY_TOL` and `kalman::SYMMETRY_TOL`: the workspace's one tolerance policy,
/// whose home is `numerics`. Scaling `V` by any positive factor — a change of units — never
/// changes the verdict. `V` must moreover be positive definite (its Cholesky factor whitens
/// the rows).
pub use numerics::SYMMETRY_TOL;

/// Re-export of the linear-algebra crate whose types appear in this API.
pub use nalgebra;

/// The README's examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
