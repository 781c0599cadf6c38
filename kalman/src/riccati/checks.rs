//! The existence checks before iterating: PBH rank tests of the (marginal or unstable) modes
//! and the PSD square root of the noise weight they need.
#![allow(non_snake_case)]

use faer::{Mat, MatRef, Side};

use super::{RiccatiOptions, symmetrise};
use crate::Error;

/// Symmetric PSD square root (negative eigenvalues from rounding clamped to 0).
pub(super) fn psd_sqrt(Q: MatRef<'_, f64>) -> Result<Mat<f64>, Error> {
    let mut Qs = Q.to_owned();
    symmetrise(&mut Qs);
    let evd = Qs
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| Error::RiccatiNoConvergence {
            equation: "Q^{1/2}",
            iterations: 0,
            reason: "symmetric eigendecomposition failed",
        })?;
    let U = evd.U();
    let s = evd.S().column_vector();
    let n = Qs.nrows();
    let mut US = U.to_owned();
    for j in 0..n {
        let r = s[j].max(0.0).sqrt();
        for i in 0..n {
            US[(i, j)] *= r;
        }
    }
    Ok(&US * U.transpose())
}

/// Which eigenvalues a PBH test looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Modes {
    /// On or outside the stability boundary: what detectability needs.
    OnOrOutside,
    /// On the boundary only: what the existence of a stabilising solution needs of the
    /// noise (or state-weight) pair.
    On,
}

/// Eigenvalues of F on (or outside) the stability boundary, within `margin`: |λ| ≥ 1 − margin
/// (|1 − |λ|| ≤ margin for [`Modes::On`]) discrete, Re λ ≥ −margin·max(1, |λ|) continuous;
/// one of each conjugate pair. The continuous equations always test on-or-right of the axis
/// (the CARE keeps the stricter test), so `which` matters for the discrete ones only.
pub(super) fn marginal_modes(
    F: MatRef<'_, f64>,
    continuous: bool,
    which: Modes,
    opts: &RiccatiOptions,
) -> Result<Vec<(f64, f64)>, Error> {
    if F.nrows() == 0 {
        return Ok(Vec::new());
    }
    let eig = F.eigenvalues().map_err(|_| Error::RiccatiNoConvergence {
        equation: "PBH test",
        iterations: 0,
        reason: "eigenvalue computation failed",
    })?;
    let margin = opts.marginal_margin;
    Ok(eig
        .into_iter()
        .filter(|l| l.im >= 0.0)
        .filter(|l| {
            let modulus = l.norm();
            match (continuous, which) {
                (true, _) => l.re >= -margin * modulus.max(1.0),
                (false, Modes::OnOrOutside) => modulus >= 1.0 - margin,
                (false, Modes::On) => (modulus - 1.0).abs() <= margin,
            }
        })
        .map(|l| (l.re, l.im))
        .collect())
}

/// PBH test: returns the first of the (marginal or unstable) `modes` of F whose
/// eigenvector C does not see, i.e. σ_min([λI − F; C]) small. C (p×n) is rescaled to ‖F‖_F
/// so the test does not depend on the units of the output.
pub(super) fn pbh(
    F: MatRef<'_, f64>,
    C: MatRef<'_, f64>,
    modes: &[(f64, f64)],
    opts: &RiccatiOptions,
) -> Result<Option<(f64, f64)>, Error> {
    let n = F.nrows();
    let p = C.nrows();
    let fnorm = F.norm_l2();
    let scale = fnorm.max(1.0);
    let cnorm = C.norm_l2();
    let cscale = if cnorm > 0.0 { scale / cnorm } else { 0.0 };
    for &(re, im) in modes {
        // Real embedding of the complex matrix M = [λI − F; C]: [[Re M, −Im M], [Im M, Re M]]
        // has the singular values of M, each twice.
        let complex = im > 0.0;
        let (rows, cols) = if complex {
            (2 * (n + p), 2 * n)
        } else {
            (n + p, n)
        };
        let mut M = Mat::<f64>::zeros(rows, cols);
        let blocks: &[(usize, usize, f64)] = if complex {
            &[(0, 0, 1.0), (n + p, n, 1.0)]
        } else {
            &[(0, 0, 1.0)]
        };
        for &(r0, c0, _) in blocks {
            for j in 0..n {
                for i in 0..n {
                    M[(r0 + i, c0 + j)] = -F[(i, j)];
                }
                M[(r0 + j, c0 + j)] += re;
                for i in 0..p {
                    M[(r0 + n + i, c0 + j)] = C[(i, j)] * cscale;
                }
            }
        }
        if complex {
            for j in 0..n {
                M[(j, n + j)] = -im; // −Im M in the top-right block
                M[(n + p + j, j)] = im; // Im M in the bottom-left block
            }
        }
        let sv = M
            .singular_values()
            .map_err(|_| Error::RiccatiNoConvergence {
                equation: "PBH test",
                iterations: 0,
                reason: "singular value decomposition failed",
            })?;
        let smin = sv.iter().copied().fold(f64::INFINITY, f64::min);
        if smin <= opts.pbh_tolerance * scale {
            return Ok(Some((re, im)));
        }
    }
    Ok(None)
}
