//! The arithmetic of mixtures the IMM and its smoother share: the mixing probabilities,
//! the moment matching of a Gaussian mixture, the check of a probability vector.
#![allow(non_snake_case)]

use crate::Error;

/// Moment matching of a Gaussian mixture with weights `w_i` (summing to one):
/// `x = Σ w_i x_i`, `P = Σ w_i (P_i + (x_i − x)(x_i − x)ᵀ)`, in two passes so no second moment
/// `x xᵀ` is formed and subtracted (which loses the spread of states far from the origin:
/// at |x| ≈ 1e4 the subtraction leaves errors of ~1e-8 in P, more than a tight covariance
/// itself). [`Moments::clear`], then [`Moments::add_mean`] every term, then
/// [`Moments::add_spread`] every term, then [`Moments::finish`]. Matrices are n×n in either
/// layout, the same for every term (the spread term is symmetric).
///
/// ```
/// use kalman::imm::Moments;
/// // Two unit-variance components at 1e4 ± 1, equally weighted: variance 1 + 1 = 2.
/// let terms = [([1e4 - 1.0], [1.0]), ([1e4 + 1.0], [1.0])];
/// let (mut x, mut p) = ([0.0], [0.0]);
/// Moments::clear(&mut x, &mut p);
/// for (xi, _) in &terms {
///     Moments::add_mean(0.5, xi, &mut x);
/// }
/// for (xi, pi) in &terms {
///     Moments::add_spread(0.5, (xi, pi), &x, &mut p);
/// }
/// Moments::finish(&mut p);
/// assert_eq!((x[0], p[0]), (1e4, 2.0));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Moments;

impl Moments {
    /// Zeroes the mean and the covariance.
    pub fn clear(x: &mut [f64], P: &mut [f64]) {
        x.fill(0.0);
        P.fill(0.0);
    }
    /// Adds `w x_i` to the mean `x`.
    pub fn add_mean(w: f64, xi: &[f64], x: &mut [f64]) {
        for (a, b) in x.iter_mut().zip(xi) {
            *a += b * w;
        }
    }
    /// Adds `w (P_i + (x_i − x)(x_i − x)ᵀ)` to `P`, `x` the finished mean.
    pub fn add_spread(w: f64, (xi, Pi): (&[f64], &[f64]), x: &[f64], P: &mut [f64]) {
        let n = x.len();
        for b in 0..n {
            let db = xi[b] - x[b];
            for a in 0..n {
                let da = xi[a] - x[a];
                P[a + b * n] += w * (da * db + Pi[a + b * n]);
            }
        }
    }
    /// Makes `P` exactly symmetric (the mean of the two triangles).
    ///
    /// # Panics
    /// If `P` is not square (a caller's bug).
    pub fn finish(P: &mut [f64]) {
        let n = P.len().isqrt();
        assert_eq!(n * n, P.len(), "P must be n×n");
        crate::kernels::symmetrise(P, n);
    }
}

/// The IMM's mixing probabilities from the transition matrix `pi` (row-major r×r,
/// `Π_ij = P(s_{k+1} = j | s_k = i)`) and the mode probabilities `mu`: the predicted mode
/// probabilities `cbar_j = Σ_i Π_ij μ_i` and `omega[i + j·r] = ω_{i|j} = Π_ij μ_i / cbar_j`
/// (column j all zero when `cbar_j = 0`).
///
/// ```
/// let pi = [0.9, 0.1, 0.2, 0.8];
/// let (mut cbar, mut omega) = ([0.0; 2], [0.0; 4]);
/// kalman::imm::mixing_probabilities(&pi, &[0.5, 0.5], &mut cbar, &mut omega);
/// assert_eq!(cbar, [0.55, 0.45]);
/// assert!((omega[0] - 0.45 / 0.55).abs() < 1e-15 && (omega[2] - 0.05 / 0.45).abs() < 1e-15);
/// ```
///
/// # Panics
/// If the lengths are not r², r, r, r² (a caller's bug, not data).
pub fn mixing_probabilities(pi: &[f64], mu: &[f64], cbar: &mut [f64], omega: &mut [f64]) {
    let r = mu.len();
    assert!(pi.len() == r * r && cbar.len() == r && omega.len() == r * r);
    for j in 0..r {
        let mut c = 0.0;
        for i in 0..r {
            c += mu[i] * pi[i * r + j];
        }
        cbar[j] = c;
        for i in 0..r {
            omega[i + j * r] = if c > 0.0 {
                pi[i * r + j] * mu[i] / c
            } else {
                0.0
            };
        }
    }
}

/// Checks a probability vector (a row of a transition matrix, a μ0): entries ≥ 0 summing
/// to one within 1e-9.
///
/// ```
/// use kalman::imm::probability_vector;
/// assert!(probability_vector("mu0", &[0.25, 0.75]).is_ok());
/// assert!(probability_vector("mu0", &[0.5, 0.6]).is_err());
/// assert!(probability_vector("mu0", &[1.5, -0.5]).is_err());
/// ```
///
/// # Errors
/// [`Error::InvalidOption`] naming `name`: a negative entry, or a sum off one.
pub fn probability_vector(name: &'static str, v: &[f64]) -> Result<(), Error> {
    if let Some(&x) = v.iter().find(|x| **x < 0.0) {
        return Err(Error::InvalidOption {
            name,
            value: x,
            rule: "a probability must be non-negative",
        });
    }
    let s: f64 = v.iter().sum();
    // Rows typed to a few digits sum to one within a few ulps; 1e-9 also accepts
    // probabilities printed to nine decimals.
    if (s - 1.0).abs() > 1e-9 {
        return Err(Error::InvalidOption {
            name,
            value: s,
            rule: "probabilities (each row of the transition matrix) must sum to one",
        });
    }
    Ok(())
}
