//! The sigma-point sets of the unscented filters (Merwe's scaled, Julier's, the cubature and
//! the simplex sets) and the draw both unscented filters share: the points `χ_i = x ⊕ L ξ_i`
//! of `(x, P = L Lᵀ)` from the set's unit points `ξ_i`.
#![allow(non_snake_case)]

use faer::Mat;

use super::linalg::psd_cholesky;
use super::{NlDims, NonlinearModel};
use crate::storage::Buf;
use crate::{Error, MatrixInput, PSD_TOL, RANK_TOL};

/// A sigma-point set: points `χ_i = x ⊕ L ξ_i` of `(x, P)` (L the lower Cholesky factor of
/// P) with mean weights `Wm` and covariance weights `Wc`. The symmetric sets have 2n + 1
/// points, `ξ_0 = 0`, `ξ_i = c·e_i`, `ξ_{n+i} = −c·e_i` (so `χ_i = x ⊕ c·L_i`, L_i column i
/// of L; FilterPy's order); the simplex set has n + 1. Every set reproduces the first two
/// moments, `Σ Wm_i ξ_i = 0` and `Σ Wc_i ξ_i ξ_iᵀ = I`, so a linear model gives the linear
/// filter exactly.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum SigmaPoints {
    /// Van der Merwe's scaled set: `λ = α²(n + κ) − n`, `c = √(n + λ)`,
    /// `Wm_0 = λ/(n + λ)`, `Wc_0 = Wm_0 + 1 − α² + β`, `Wm_i = Wc_i = 1/(2(n + λ))`
    /// (FilterPy's `MerweScaledSigmaPoints`). β = 2 is optimal for Gaussian priors.
    Merwe {
        /// Spread α (0 < α ≤ 1 usually; small keeps the points close to the mean).
        alpha: f64,
        /// Prior-knowledge weight β.
        beta: f64,
        /// Secondary scaling κ (0 or 3 − n usually).
        kappa: f64,
    },
    /// The third-degree spherical-radial cubature set (Arasaratnam and Haykin, "Cubature
    /// Kalman filters"): `c = √n`, weights 1/(2n), and a zero-weight centre point (the same
    /// as Merwe with α = 1, β = 0, κ = 0).
    Cubature,
    /// Julier and Uhlmann's original set ("A new extension of the Kalman filter to
    /// nonlinear systems"): `c = √(n + κ)`, `W_0 = κ/(n + κ)`, `W_i = 1/(2(n + κ))`, one
    /// set of weights for the mean and the covariance (FilterPy's `JulierSigmaPoints`; the
    /// same as Merwe with α = 1, β = 0). κ = 3 − n matches the fourth moments of a Gaussian.
    Julier {
        /// Scaling κ (n + κ > 0).
        kappa: f64,
    },
    /// The n + 1 points of a simplex (Moireau and Chapelle, "Reduced-order unscented Kalman
    /// filtering with application to parameter identification in large-dimensional
    /// systems"; FilterPy's `SimplexSigmaPoints`): weights 1/(n + 1), `ξ = √n·I*` with the
    /// unit simplex `I*` (n × (n + 1)) built row by row — row 1 `(−1, 1)/√(2λ)`, row
    /// d ≥ 2 `(1, …, 1, −d)/√(λ d (d + 1))` on its first d + 1 columns — and
    /// `λ = n/(n + 1)`. The cheapest set that matches the mean and covariance; no point sits
    /// at the mean. (FilterPy 1.4.5 multiplies the simplex by the *upper* factor U, UᵀU = P,
    /// whose points have covariance U Uᵀ ≠ P when P is not diagonal; here it is L, L Lᵀ = P,
    /// which is FilterPy's set with `sqrt_method` returning the lower factor.)
    Simplex,
}

impl SigmaPoints {
    /// Merwe's scaled set.
    ///
    /// ```
    /// use kalman::nonlinear::SigmaPoints;
    /// let s = SigmaPoints::merwe(0.1, 2.0, 1.0);
    /// let (mut wm, mut wc) = ([0.0; 5], [0.0; 5]);
    /// let c = s.weights(2, &mut wm, &mut wc).expect("valid");
    /// // λ = 0.01·3 − 2: the mean weights sum to one.
    /// assert!((wm.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    /// assert!((c * c - 0.03).abs() < 1e-15);
    /// ```
    pub const fn merwe(alpha: f64, beta: f64, kappa: f64) -> Self {
        SigmaPoints::Merwe { alpha, beta, kappa }
    }

    /// Julier's set with scaling κ.
    ///
    /// ```
    /// use kalman::nonlinear::SigmaPoints;
    /// let (mut wm, mut wc) = ([0.0; 7], [0.0; 7]);
    /// let c = SigmaPoints::julier(0.0).weights(3, &mut wm, &mut wc).expect("valid");
    /// // κ = 0: no weight on the centre, 1/6 on each of the six others, c = √3.
    /// assert!(wm[0].abs() < 1e-16 && (wc[1] - 1.0 / 6.0).abs() < 1e-16);
    /// assert!((c - 3f64.sqrt()).abs() < 1e-15);
    /// ```
    pub const fn julier(kappa: f64) -> Self {
        SigmaPoints::Julier { kappa }
    }

    /// Number of points of the symmetric sets for n states, 2n + 1 (see
    /// [`SigmaPoints::len`] for any set).
    pub const fn count(n: usize) -> usize {
        2 * n + 1
    }

    /// Number of points of this set for n states: 2n + 1, or n + 1 for the simplex.
    ///
    /// ```
    /// use kalman::nonlinear::SigmaPoints;
    /// assert_eq!((SigmaPoints::Cubature.len(4), SigmaPoints::Simplex.len(4)), (9, 5));
    /// ```
    pub const fn len(&self, n: usize) -> usize {
        match self {
            SigmaPoints::Simplex => n + 1,
            _ => 2 * n + 1,
        }
    }

    /// Writes the [`SigmaPoints::len`] weights and returns the spread `c` of the symmetric
    /// sets (χ_i = x ± c·L_i); for the simplex, √n, the scale of its unit simplex.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] if a parameter is not finite, α ≤ 0, or n + κ ≤ 0;
    /// [`Error::Dimension`] if a slice is shorter than the number of points.
    pub fn weights(&self, n: usize, wm: &mut [f64], wc: &mut [f64]) -> Result<f64, Error> {
        let s = self.len(n);
        if wm.len() < s || wc.len() < s {
            return Err(Error::Dimension {
                name: "weights",
                value: wm.len().min(wc.len()),
                rule: "the weight slices must hold one entry per sigma point",
            });
        }
        let nf = n as f64;
        let (alpha, beta, kappa) = match *self {
            SigmaPoints::Merwe { alpha, beta, kappa } => (alpha, beta, kappa),
            SigmaPoints::Cubature => (1.0, 0.0, 0.0),
            SigmaPoints::Julier { kappa } => (1.0, 0.0, kappa),
            SigmaPoints::Simplex => {
                let w = 1.0 / (nf + 1.0);
                wm[..s].fill(w);
                wc[..s].fill(w);
                return Ok(nf.sqrt());
            }
        };
        for (name, v) in [("alpha", alpha), ("beta", beta), ("kappa", kappa)] {
            if !v.is_finite() {
                return Err(Error::InvalidOption {
                    name,
                    value: v,
                    rule: "must be finite",
                });
            }
        }
        if alpha <= 0.0 {
            return Err(Error::InvalidOption {
                name: "alpha",
                value: alpha,
                rule: "must be positive",
            });
        }
        if nf + kappa <= 0.0 {
            return Err(Error::InvalidOption {
                name: "kappa",
                value: kappa,
                rule: "n + kappa must be positive",
            });
        }
        let lambda = alpha * alpha * (nf + kappa) - nf;
        let w = 0.5 / (nf + lambda);
        for i in 1..=2 * n {
            wm[i] = w;
            wc[i] = w;
        }
        wm[0] = lambda / (nf + lambda);
        wc[0] = wm[0] + 1.0 - alpha * alpha + beta;
        Ok((nf + lambda).sqrt())
    }

    /// The sigma points of `(x, P)` as the columns of an n×[`SigmaPoints::len`] matrix
    /// (plain addition; for inspection and tests — the filters draw theirs without
    /// allocating).
    ///
    /// ```
    /// use kalman::nonlinear::SigmaPoints;
    /// let pts = SigmaPoints::Cubature.points(&[1.0, 2.0], &[[4.0, 0.0], [0.0, 9.0]]).expect("PSD");
    /// assert!((pts[(0, 1)] - (1.0 + 2.0 * 2f64.sqrt())).abs() < 1e-14);
    /// assert!((pts[(1, 4)] - (2.0 - 3.0 * 2f64.sqrt())).abs() < 1e-14);
    /// // The simplex set: three points whose mean is x.
    /// let s = SigmaPoints::Simplex.points(&[1.0, 2.0], &[[4.0, 1.0], [1.0, 9.0]]).expect("PSD");
    /// assert_eq!(s.ncols(), 3);
    /// assert!(((s[(1, 0)] + s[(1, 1)] + s[(1, 2)]) / 3.0 - 2.0).abs() < 1e-14);
    /// ```
    ///
    /// # Errors
    /// [`Error::Shape`]/[`Error::NonFinite`] naming `x` or `P`; [`Error::SigmaCovariance`]
    /// if P is not PSD; as [`SigmaPoints::weights`].
    pub fn points(&self, x: &[f64], P: &impl MatrixInput) -> Result<Mat<f64>, Error> {
        let n = x.len();
        crate::model::check_vec("x", x, n)?;
        let mut p = vec![0.0; n * n];
        crate::model::load("P", P, n, n, &mut p)?;
        let set = SigmaSet::<crate::DynDims>::new(*self, n)?;
        let (mut L, mut inv) = (vec![0.0; n * n], vec![0.0; n]);
        psd_cholesky(&p, n, &mut L, &mut inv, RANK_TOL, PSD_TOL).map_err(|pivot| {
            Error::SigmaCovariance {
                name: "P",
                step: 0,
                n,
                pivot,
                tol: PSD_TOL,
            }
        })?;
        let s = set.count;
        let mut dx = vec![0.0; n];
        let mut out = Mat::zeros(n, s);
        for j in 0..s {
            set.offset(&L, n, j, &mut dx);
            for i in 0..n {
                out[(i, j)] = x[i] + dx[i];
            }
        }
        Ok(out)
    }
}

/// A sigma-point set sized for one filter: its weights, its spread and, for the simplex,
/// its unit points `ξ` (n × (n + 1), column-major).
#[derive(Clone, Debug)]
pub(super) struct SigmaSet<D: NlDims> {
    pub(super) points: SigmaPoints,
    /// Number of points s.
    pub(super) count: usize,
    pub(super) spread: f64,
    pub(super) wm: D::W,
    pub(super) wc: D::W,
    /// The simplex's unit points (zero for the symmetric sets, which never read them).
    xi: D::Sig,
    simplex: bool,
}

impl<D: NlDims> SigmaSet<D> {
    pub(super) fn new(points: SigmaPoints, n: usize) -> Result<Self, Error> {
        let s = points.len(n);
        let mut wm = D::W::zeros(s);
        let mut wc = D::W::zeros(s);
        let spread = points.weights(n, wm.as_mut_slice(), wc.as_mut_slice())?;
        let simplex = matches!(points, SigmaPoints::Simplex);
        let mut xi = D::Sig::zeros(n * s);
        if simplex {
            unit_simplex(n, &mut xi.as_mut_slice()[..n * s]);
        }
        Ok(Self {
            points,
            count: s,
            spread,
            wm,
            wc,
            xi,
            simplex,
        })
    }

    /// `ξ_i` (n entries) into `out`.
    #[inline(always)]
    pub(super) fn unit(&self, n: usize, i: usize, out: &mut [f64]) {
        let out = &mut out[..n];
        if self.simplex {
            out.copy_from_slice(&self.xi.as_slice()[i * n..(i + 1) * n]);
            return;
        }
        out.fill(0.0);
        if i >= 1 && i <= n {
            out[i - 1] = self.spread;
        } else if i > n {
            out[i - 1 - n] = -self.spread;
        }
    }

    /// `dx = L ξ_i`, the offset of point i from the mean (`L` lower n×n).
    #[inline(always)]
    pub(super) fn offset(&self, L: &[f64], n: usize, i: usize, dx: &mut [f64]) {
        let dx = &mut dx[..n];
        if self.simplex {
            let xi = &self.xi.as_slice()[i * n..(i + 1) * n];
            dx.fill(0.0);
            for (j, &c) in xi.iter().enumerate() {
                for r in j..n {
                    dx[r] += L[r + j * n] * c;
                }
            }
        } else if i == 0 {
            dx.fill(0.0);
        } else {
            let (j, f) = if i <= n {
                (i - 1, self.spread)
            } else {
                (i - 1 - n, -self.spread)
            };
            for r in 0..n {
                dx[r] = f * L[r + j * n];
            }
        }
    }

    /// The points `χ_i = x ⊕ L ξ_i` into `chi` (stored × s, the stored length being
    /// `x.len()`, n for a vector state), through the model's state addition (the
    /// symmetric sets' centre is `x` itself). `dx` is an n-vector workspace.
    #[inline(always)]
    pub(super) fn draw<M: NonlinearModel + ?Sized>(
        &self,
        model: &M,
        x: &[f64],
        L: &[f64],
        n: usize,
        dx: &mut [f64],
        chi: &mut [f64],
    ) {
        let ns = x.len();
        if self.simplex {
            for i in 0..self.count {
                self.offset(L, n, i, dx);
                model.state_add(x, &dx[..n], &mut chi[i * ns..(i + 1) * ns]);
            }
            return;
        }
        chi[..ns].copy_from_slice(x);
        let dx = &mut dx[..n];
        for j in 0..n {
            for (sign, col) in [(1.0, 1 + j), (-1.0, 1 + n + j)] {
                let f = sign * self.spread;
                for i in 0..n {
                    dx[i] = f * L[i + j * n];
                }
                model.state_add(x, dx, &mut chi[col * ns..(col + 1) * ns]);
            }
        }
    }
}

/// `√n·I*`, the simplex set's unit points (see [`SigmaPoints::Simplex`]), column-major
/// n × (n + 1).
fn unit_simplex(n: usize, out: &mut [f64]) {
    let nf = n as f64;
    let lambda = nf / (nf + 1.0);
    out.fill(0.0);
    for d in 1..=n {
        let row = d - 1;
        if d == 1 {
            let v = nf.sqrt() / (2.0 * lambda).sqrt();
            out[row] = -v;
            out[row + n] = v;
            continue;
        }
        let df = d as f64;
        let v = nf.sqrt() / (lambda * df * (df + 1.0)).sqrt();
        for col in 0..d {
            out[row + col * n] = v;
        }
        out[row + d * n] = -df * v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DynDims;

    /// Every set's unit points reproduce the first two moments of N(0, I): Σ Wm ξ = 0 and
    /// Σ Wc ξ ξᵀ = I (sums of n + 1 to 2n + 1 terms of size ≤ n: 1e-13 is rounding).
    #[test]
    fn unit_points_match_the_mean_and_the_identity_covariance() {
        for n in 1..=7 {
            for set in [
                SigmaPoints::merwe(0.3, 2.0, 1.0),
                SigmaPoints::Cubature,
                SigmaPoints::julier(3.0 - n as f64 + 0.5),
                SigmaPoints::Simplex,
            ] {
                let s = SigmaSet::<DynDims>::new(set, n).expect("set");
                let (wm, wc) = (s.wm.as_slice(), s.wc.as_slice());
                let mut xi = vec![0.0; n];
                let mut mean = vec![0.0; n];
                let mut cov = vec![0.0; n * n];
                for i in 0..s.count {
                    s.unit(n, i, &mut xi);
                    for a in 0..n {
                        mean[a] += wm[i] * xi[a];
                        for b in 0..n {
                            cov[a + b * n] += wc[i] * xi[a] * xi[b];
                        }
                    }
                }
                for a in 0..n {
                    assert!(mean[a].abs() < 1e-13, "{set:?} n {n} mean {a}");
                    for b in 0..n {
                        let want = if a == b { 1.0 } else { 0.0 };
                        assert!(
                            (cov[a + b * n] - want).abs() < 1e-13,
                            "{set:?} n {n} cov ({a}, {b}) = {}",
                            cov[a + b * n]
                        );
                    }
                }
            }
        }
    }
}
