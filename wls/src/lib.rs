//! Ill-conditioning-aware weighted least squares with prior information, and the erector-boom
//! angular-acceleration estimator with the sensor-offset-angle (γ) method (SPEC B).
//!
//! # Notation
//! n unknowns x, m measurements z, design matrix H (m×n), weight matrix V (m×m, diagonal or
//! symmetric positive definite): the solver minimises ‖V^{1/2}(H x − z)‖². The covariance is
//! (HᵀVH)⁻¹; κ is the 2-norm condition number (σ_max/σ_min). In the boom estimator (SPEC B)
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
//!
//! # Reproducing the paper
//! The paper's WLS (9)–(10) does not say in which units ε sits in the state, nor when the
//! ε₀ weight v₆ = 0.5/(1 + 2|ε̇|)² is evaluated. Both are configuration fields
//! ([`boom::AngleUnit`] for ε and ε̇, [`boom::RateWeight`]); the defaults of
//! [`boom::BoomConfig`] — ε in °/s² inside the state (H₂₃ = r·π/180), ε̇ in °/s³ in v₆, v₆
//! made self-consistent within each cycle — are the ones under which the full turn
//! (±Δa = 0.02 m/s², Δα = 1°, Δε = 0.5 °/s²) behaves as the paper reports:
//! - direct inversion and the 3×3 solve exceed the limits from α ≈ 83° and the "+" variant is
//!   undefined from α ≈ 86.3° (sin α > 1 − Δa/g; the paper says ≈ 88°);
//! - WLS at γ = 0 keeps "−" within limits and exceeds Δε slightly for "+" (max ≈ 0.58 °/s²,
//!   from α ≈ 79°, t ≈ 28.8 s; the paper: α > 81°, t > 29 s);
//! - WLS at γ = 10° is within both limits over the whole turn (max ≈ 0.56°, 0.26 °/s²);
//!   the smallest feasible γ is ≈ 4.5° (0.5° grid), 11° with Δε = 0.25 °/s².
//!
//! Not reproduced: at γ = 0 the "+" variant also exceeds Δα (≈ 1.4°), and s passes 1 near the
//! end (arcsin undefined from α ≈ 88.6°; [`boom::AngleRecovery::Atan2`] keeps it defined).
//! With ε in rad/s² the ε₀ prior is (180/π)² ≈ 3283 times weaker and WLS behaves like direct
//! inversion for "−" (δα ≈ 3.7°). When v₆ is evaluated (previous cycle or fixed point)
//! hardly matters on this profile.
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
#![deny(missing_docs)]

pub mod boom;
mod error;
pub mod solver;

pub use error::{Error, Result};
