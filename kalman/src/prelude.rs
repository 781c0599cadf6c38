//! One import for a program: `use kalman::prelude::*;` brings the engine's model and filter,
//! the Riccati solvers and, with the feature `nalgebra`, the nalgebra matrix types and macros
//! this crate is built against together with `ToNalgebra`, so nalgebra
//! goes in and comes out without a second import.
//!
//! ```
//! use kalman::prelude::*;
//!
//! // nalgebra in: a random walk observed in unit noise, q = 1.
//! let one = dmatrix![1.0];
//! // nalgebra out: P = (1 + √5)/2.
//! let steady: DMatrix<f64> = Dare::new(&one, &one, &one, &one)?.solve()?.to_nalgebra().prior;
//! assert!((steady[(0, 0)] - (1.0 + 5f64.sqrt()) / 2.0).abs() < 1e-12);
//! # Ok::<(), kalman::Error>(())
//! ```

#[cfg(feature = "nalgebra")]
pub use crate::ToNalgebra;
pub use crate::riccati::{Care, Clqr, Dare, Dlqr, RiccatiOptions};
pub use crate::{CovarianceForm, DynDims, Filter, FixedDims, MatrixInput, Model};
#[cfg(feature = "nalgebra")]
pub use nalgebra::{DMatrix, DVector, dmatrix, dvector};
