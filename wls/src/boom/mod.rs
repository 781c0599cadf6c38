//! The erector-boom angular-acceleration estimator of SPEC B: the per-cycle estimator, the
//! rotation profile that generates test trajectories, and the sensor-offset-angle (γ) sweep.

pub mod estimator;
pub mod gamma;
pub mod profile;

pub use estimator::{
    AngleRecovery, AngleUnit, AxWeightLaw, BoomConfig, BoomEstimator, BoomMethod, BoomSolver,
    Estimate, RateWeight, WlsWeights,
};
pub use gamma::{
    CycleError, ErrorVariant, GammaRow, GammaSweepReport, Limits, Sign, TurnRun,
    ideal_accelerometer, run_turn, sweep_gamma,
};
pub use profile::{Breakpoint, Deceleration, Level, RotationProfile, Trajectory, TrajectoryPoint};
