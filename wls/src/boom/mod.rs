//! The erector-boom angular-acceleration estimator of Zavyalov and Shatov: the per-cycle
//! estimator, the rotation profile that generates test trajectories, and the
//! sensor-offset-angle (γ) sweep.
//!
//! # The equations (numbered as in the paper)
//! A boom turns from horizontal (α = 0) to vertical (α = 90°); one accelerometer at radius r
//! from the pivot reads (1) a_x = g·sin α, a_y = g·cos α + ε·r (a_z ≈ 0 only checks the
//! mounting).
//! - Direct inversion (2)–(3): α = arcsin(a_x/g), ε = (a_y − √(g² − a_x²))/r, defined only
//!   while g² ≥ a_x². Its error (4), dα = da_x/(g cos α), dε = (da_y + tan α·da_x)/r, grows
//!   without bound as α → 90°.
//! - Linear form (7): unknowns x = (s, c, ε) with s = sin α, c = cos α, plus the row
//!   s₀·s + c₀·c = 1 with (s₀, c₀) from the previous cycle: z = (a_x, a_y, 1),
//!   H = [[g, 0, 0], [0, g, r], [s₀, c₀, 0]], det H = −g·r·c₀ → 0 near 90°.
//! - Weighted least squares (8)–(10): the previous cycle's values as extra measurements,
//!   z = (a_x, a_y, 1, s₀, c₀, ε₀), H = (7) stacked on the 3×3 identity,
//!   x = (HᵀVH)⁻¹HᵀVz with V = diag(cos α₀, 1, 100, 1, 1, 0.5/(1 + 2|ε̇|)²) and
//!   ε̇ = (ε − ε₀)/dt: the a_x row is weak near 90°, the unit-circle row nearly exact, and the
//!   prior ε₀ trusted less when ε changes fast. α = arcsin s.
//! - Sensor offset angle γ: mounted γ lower along the arc, the sensor reads
//!   a_x = g·sin(α − γ), a_y = g·cos(α − γ) + ε·r; the estimator solves for β = α − γ and adds
//!   γ back, so the ill-conditioned direction is never reached. The smallest γ that keeps
//!   both errors within the limits is the one to mount ([`gamma`]).
//! - Rotation profile (6): α̇ = ω, ω̇ = ε(α), ε(α) a piecewise-linear table ([`profile`]).
//!
//! Errors are judged at the sensor's limit: variant "+" adds +Δa to a_x and a_y, "−" adds −Δa;
//! δα± = |α± − α|, δε± = |ε± − ε| against the allowed Δα, Δε.

pub mod config;
pub mod estimator;
pub mod gamma;
pub mod profile;

pub use config::{
    AngleRecovery, AngleUnit, AxWeightLaw, BoomConfig, BoomMethod, BoomSolver, Estimate,
    RateWeight, WlsWeights,
};
pub use estimator::BoomEstimator;
pub use gamma::{
    CycleError, ErrorVariant, GammaRow, GammaSweepReport, Limits, Sign, TurnRun,
    ideal_accelerometer, run_turn, sweep_gamma,
};
pub use profile::{Breakpoint, Deceleration, Level, RotationProfile, Trajectory, TrajectoryPoint};
