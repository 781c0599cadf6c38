//! Iteratively re-weighted least squares: the weights V(x) from a closure, the weighted solve
//! of the parent module repeated to a fixed point.
#![allow(non_snake_case)]

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::{Solution, SolveOptions, Weights, check_finite, check_len, solve};
use crate::error::{Error, Result};

/// Options of the iteratively re-weighted solve [`solve_irls`].
///
/// ```
/// use wls::solver::IrlsOptions;
/// let tight = IrlsOptions { max_iterations: 200, ..IrlsOptions::default() };
/// assert!(tight.tolerance > 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IrlsOptions {
    /// Stop when ‖x_{k+1} − x_k‖ ≤ tolerance·(1 + ‖x_{k+1}‖).
    pub tolerance: f64,
    /// Iteration cap (≥ 1).
    pub max_iterations: usize,
}

impl Default for IrlsOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-12,
            max_iterations: 50,
        }
    }
}

/// The result of [`solve_irls`].
///
/// ```
/// use wls::nalgebra::{DVector, dmatrix, dvector};
/// use wls::solver::{IrlsOptions, SolveOptions, Weights, solve_irls};
/// // A robust mean: weights 1/max(|r|, 1e-3) push towards the median.
/// let h = dmatrix![1.0; 1.0; 1.0; 1.0];
/// let z = dvector![1.0, 1.1, 0.9, 10.0];
/// let weights = |x: &DVector<f64>| Weights::Diagonal(z.map(|v| 1.0 / (v - x[0]).abs().max(1e-3)));
/// let (opts, irls) = (SolveOptions::default(), IrlsOptions::default());
/// let fit = solve_irls(&h, &z, &dvector![0.0], weights, &opts, &irls)?;
/// assert!(fit.iterations >= 2 && (fit.solution.x[0] - 1.05).abs() < 0.1);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IrlsSolution {
    /// The last solve.
    pub solution: Solution,
    /// Solves performed.
    pub iterations: usize,
    /// Whether the fixed-point tolerance was met within the cap.
    pub converged: bool,
    /// ‖x_k − x_{k−1}‖ of the last iteration.
    pub last_step: f64,
}

/// Iteratively re-weighted least squares: weights V(x) from a closure, iterated from
/// `initial` to a fixed point x = argmin ‖V(x)^{1/2}(H x − z)‖².
///
/// Returns the last solve with the iteration count and whether ‖x_{k+1} − x_k‖ ≤
/// tolerance·(1 + ‖x_{k+1}‖) was reached within `max_iterations` (not converging is reported,
/// not an error).
///
/// # Errors
/// As [`solve`] for any iterate, plus invalid `initial`, tolerance or iteration cap.
///
/// ```
/// use wls::nalgebra::{dmatrix, dvector};
/// use wls::solver::{IrlsOptions, SolveOptions, Weights, solve_irls};
/// // Weights that do not depend on x converge in two solves to the plain WLS answer.
/// let h = dmatrix![1.0; 1.0];
/// let z = dvector![1.0, 3.0];
/// let (opts, irls) = (SolveOptions::default(), IrlsOptions::default());
/// let fit = solve_irls(&h, &z, &dvector![0.0], |_| Weights::Identity, &opts, &irls)?;
/// assert!(fit.converged && (fit.solution.x[0] - 2.0).abs() < 1e-12);
/// # Ok::<(), wls::Error>(())
/// ```
pub fn solve_irls<F: FnMut(&DVector<f64>) -> Weights>(
    H: &DMatrix<f64>,
    z: &DVector<f64>,
    initial: &DVector<f64>,
    mut weights_of: F,
    options: &SolveOptions,
    irls: &IrlsOptions,
) -> Result<IrlsSolution> {
    check_len("initial", initial, H.ncols(), "one entry per unknown")?;
    check_finite("initial", initial)?;
    if !irls.tolerance.is_finite() || irls.tolerance <= 0.0 {
        return Err(Error::InvalidParameter {
            name: "irls.tolerance",
            value: irls.tolerance,
            rule: "must be finite and > 0",
        });
    }
    if irls.max_iterations == 0 {
        return Err(Error::InvalidParameter {
            name: "irls.max_iterations",
            value: 0.0,
            rule: "must be ≥ 1",
        });
    }
    let mut x = initial.clone();
    let mut k = 0;
    loop {
        k += 1;
        let w = weights_of(&x);
        let solution = solve(H, z, &w, options)?;
        let last_step = (&solution.x - &x).norm();
        let converged = last_step <= irls.tolerance * (1.0 + solution.x.norm());
        if converged || k >= irls.max_iterations {
            return Ok(IrlsSolution {
                solution,
                iterations: k,
                converged,
                last_step,
            });
        }
        x = solution.x;
    }
}
