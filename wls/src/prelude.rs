//! One import for a program: `use wls::prelude::*;` brings the solver, its options and
//! weights, and the nalgebra matrix types and macros this crate is built against.
//!
//! ```
//! use wls::prelude::*;
//!
//! // The mean of three readings, and ridge regression on H = I: x = z/(1 + λ).
//! let mean = solve(&dmatrix![1.0; 1.0; 1.0], &dvector![1.0, 2.0, 3.0], &Weights::Identity, &SolveOptions::default())?;
//! assert!((mean.x[0] - 2.0).abs() < 1e-12);
//! let ridge = solve(&DMatrix::identity(2, 2), &dvector![2.0, 4.0], &Weights::Identity, &SolveOptions::ridge(1.0))?;
//! assert!((ridge.x - DVector::from_vec(vec![1.0, 2.0])).norm() < 1e-12);
//! # Ok::<(), wls::Error>(())
//! ```

pub use crate::solver::{Solution, SolveMethod, SolveOptions, Tikhonov, Weights, solve};
pub use nalgebra::{DMatrix, DVector, dmatrix, dvector};
