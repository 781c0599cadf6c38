//! The existence checks before iterating: PBH rank tests of the (marginal or unstable) modes
//! on a balanced pair, the PSD square root of the noise weight they need, and the solvers'
//! one eigenvalue routine, whose cost is bounded.
#![allow(non_snake_case)]

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::{self, ComputeEigenvectors, EvdParams};
use faer::{Mat, MatRef, Par, Side, Spec};

use super::{RiccatiOptions, symmetrise};
use crate::Error;

/// Eigenvalues (re, im) of the square `M` by the double-shift QR iteration with a bounded
/// number of sweeps (30 per eigenvalue, LAPACK's `dlahqr` cap), or
/// [`Error::RiccatiNoConvergence`] naming `what` and how many eigenvalues converged.
///
/// faer's default for n ≥ 75 is the multishift QR with aggressive early deflation, whose
/// reordering of the deflation window has no iteration cap: on the closed loop of the
/// 421-state CAREX #20 it does not return. The unblocked iteration used here always
/// does (for n = 421 in about a second). faer also does not report an iteration that hit
/// its cap, so the eigenvalue buffers start as NaN and any one left unwritten is the
/// failure.
pub(super) fn eigenvalues(
    M: MatRef<'_, f64>,
    what: &'static str,
) -> Result<Vec<(f64, f64)>, Error> {
    let n = M.nrows();
    if n == 0 {
        return Ok(Vec::new());
    }
    let fail = |converged: usize| Error::RiccatiNoConvergence {
        equation: what,
        iterations: converged,
        reason: "eigenvalues: the QR iteration reached its cap of 30 sweeps per eigenvalue (the count is of converged eigenvalues) or the matrix is not finite",
    };
    let mut params: Spec<EvdParams, f64> = Spec::default();
    params.config.schur.blocking_threshold = usize::MAX;
    let mut re = Diag::<f64>::full(n, f64::NAN);
    let mut im = Diag::<f64>::full(n, f64::NAN);
    let req = evd::evd_scratch::<f64>(
        n,
        ComputeEigenvectors::No,
        ComputeEigenvectors::No,
        Par::Seq,
        params,
    );
    let mut buf = MemBuffer::new(req);
    evd::evd_real(
        M,
        re.as_mut(),
        im.as_mut(),
        None,
        None,
        Par::Seq,
        MemStack::new(&mut buf),
        params,
    )
    .map_err(|_| fail(0))?;
    let (re, im) = (re.column_vector(), im.column_vector());
    let converged = (0..n)
        .filter(|&i| re[i].is_finite() && im[i].is_finite())
        .count();
    if converged < n {
        return Err(fail(converged));
    }
    Ok((0..n).map(|i| (re[i], im[i])).collect())
}

/// Ruiz's equilibration of M in place: rows and columns scaled (by powers of two, so
/// exactly) towards unit largest entry, at most 20 sweeps. Rank is invariant under any
/// non-singular row and column scaling, so the PBH rank test may take its σ_min on the
/// equilibrated matrix: a mode coupled to the output through entries small beside others
/// (CAREX #13: 0.4 and 0.345 beside 10⁶) is then not mistaken for an unobservable one.
///
/// A row or column whose largest entry is below 10⁻⁸ of the matrix's largest is left as it
/// is: it is (or may be) rounding noise of an exactly rank-deficient matrix, such as the
/// eigenvalue's own error on the diagonal of an unobservable mode, which scaling up would
/// turn into a spurious rank.
fn equilibrate(M: &mut Mat<f64>) {
    let (rows, cols) = (M.nrows(), M.ncols());
    let pow2 = |x: f64| 2f64.powi(x.log2().round() as i32);
    let top = (0..cols)
        .flat_map(|j| (0..rows).map(move |i| (i, j)))
        .map(|ij| M[ij].abs())
        .fold(0.0, f64::max);
    let noise = 1e-8 * top;
    for _ in 0..20 {
        let mut worst = 0.0f64;
        for i in 0..rows {
            let r = (0..cols).map(|j| M[(i, j)].abs()).fold(0.0, f64::max);
            if r > noise && r.is_finite() {
                let s = pow2(1.0 / r.sqrt());
                worst = worst.max((r.log2()).abs());
                for j in 0..cols {
                    M[(i, j)] *= s;
                }
            }
        }
        for j in 0..cols {
            let c = (0..rows).map(|i| M[(i, j)].abs()).fold(0.0, f64::max);
            if c > noise && c.is_finite() {
                let s = pow2(1.0 / c.sqrt());
                worst = worst.max((c.log2()).abs());
                for i in 0..rows {
                    M[(i, j)] *= s;
                }
            }
        }
        if worst <= 1.0 {
            break;
        }
    }
}

/// Symmetric PSD square root: eigenvalues below n·ε times the largest (rounding of a
/// singular Q, or negative) are taken as 0, so a direction Q does not reach has no
/// √ε-sized entries in the root for the PBH test to mistake for a small reach.
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
    let top = (0..n).map(|j| s[j]).fold(0.0, f64::max);
    let cut = n as f64 * f64::EPSILON * top;
    let mut US = U.to_owned();
    for j in 0..n {
        let r = if s[j] > cut { s[j].sqrt() } else { 0.0 };
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
    let eig = eigenvalues(F, "PBH test")?;
    let margin = opts.marginal_margin;
    Ok(eig
        .into_iter()
        .filter(|&(_, im)| im >= 0.0)
        .filter(|&(re, im)| {
            let modulus = re.hypot(im);
            match (continuous, which) {
                (true, _) => re >= -margin * modulus.max(1.0),
                (false, Modes::OnOrOutside) => modulus >= 1.0 - margin,
                (false, Modes::On) => (modulus - 1.0).abs() <= margin,
            }
        })
        .collect())
}

/// PBH test: returns the first of the (marginal or unstable) `modes` of F whose
/// eigenvector C does not see, i.e. σ_min([λI − F; C]) small. The rank decision is taken
/// on the equilibrated matrix ([`equilibrate`], so it depends neither on the units of the
/// states nor on those of the outputs), relative to its own largest singular value:
/// rank-deficient when σ_min ≤ `pbh_tolerance`·σ_max.
pub(super) fn pbh(
    F: MatRef<'_, f64>,
    C: MatRef<'_, f64>,
    modes: &[(f64, f64)],
    opts: &RiccatiOptions,
) -> Result<Option<(f64, f64)>, Error> {
    let n = F.nrows();
    let p = C.nrows();
    // C rescaled to ‖F‖_F first (a row scaling, so rank-preserving): an output in small
    // units (DAREX #14's B = 10⁻⁸) is not taken for rounding noise by the equilibration.
    let cnorm = C.norm_l2();
    let cscale = if cnorm > 0.0 {
        F.norm_l2().max(1.0) / cnorm
    } else {
        0.0
    };
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
        equilibrate(&mut M);
        let sv = M
            .singular_values()
            .map_err(|_| Error::RiccatiNoConvergence {
                equation: "PBH test",
                iterations: 0,
                reason: "singular value decomposition failed",
            })?;
        let smin = sv.iter().copied().fold(f64::INFINITY, f64::min);
        let smax = sv.iter().copied().fold(0.0, f64::max);
        if smin <= opts.pbh_tolerance * smax {
            return Ok(Some((re, im)));
        }
    }
    Ok(None)
}
