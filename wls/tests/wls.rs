//! The `wls` integration tests: the general solver (QR vs normal equations, worst-case bounds,
//! Tikhonov limits, typed errors) and the boom estimator (exactness, definedness, conditioning,
//! the paper's full turn and the γ sweep).
#![allow(non_snake_case)]

#[path = "wls/boom.rs"]
mod boom;
#[path = "wls/boom_paths.rs"]
mod boom_paths;
#[path = "wls/solver.rs"]
mod solver;
#[path = "wls/solver_paths.rs"]
mod solver_paths;
