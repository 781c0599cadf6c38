//! The structured doubling algorithm (Chu, Fan, Lin & Wang, 2004) shared by the discrete and
//! (after a Cayley transform) continuous equations.
#![allow(non_snake_case)]

use faer::Mat;
use faer::linalg::solvers::Solve;

use super::{RiccatiOptions, all_finite, symmetrise};
use crate::Error;

/// The structured doubling algorithm on a control-form DARE in standard symplectic form
/// X = H₀ + A₀ᵀ X (I + G₀ X)⁻¹ A₀. Returns (X, iterations).
pub(super) fn sda(
    mut A: Mat<f64>,
    mut G: Mat<f64>,
    mut Hh: Mat<f64>,
    opts: &RiccatiOptions,
    equation: &'static str,
) -> Result<(Mat<f64>, usize), Error> {
    let n = A.nrows();
    let I = Mat::<f64>::identity(n, n);
    for it in 1..=opts.max_iterations {
        let W = &I + &G * &Hh;
        let lu = W.partial_piv_lu();
        let WA = lu.solve(&A); // W⁻¹ A_k
        let WG = lu.solve(&G); // W⁻¹ G_k
        let A_next = &A * &WA;
        let mut G_next = &G + &A * &WG * A.transpose();
        let mut H_next = &Hh + A.transpose() * (&Hh * &WA);
        symmetrise(&mut G_next);
        symmetrise(&mut H_next);
        if !all_finite(A_next.as_ref())
            || !all_finite(G_next.as_ref())
            || !all_finite(H_next.as_ref())
        {
            return Err(Error::RiccatiNoConvergence {
                equation,
                iterations: it,
                reason: "doubling iterate became non-finite (I + G H singular or divergent)",
            });
        }
        let change = (&H_next - &Hh).norm_l2();
        let scale = H_next.norm_l2();
        A = A_next;
        G = G_next;
        Hh = H_next;
        if change <= opts.tolerance * scale {
            return Ok((Hh, it));
        }
    }
    Err(Error::RiccatiNoConvergence {
        equation,
        iterations: opts.max_iterations,
        reason: "doubling did not reach the tolerance",
    })
}
