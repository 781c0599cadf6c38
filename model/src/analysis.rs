//! Analysis helpers: rank by SVD, controllability/observability, eigenvalues and stability,
//! DC gain, frequency and impulse responses, the discrete Lyapunov equation, PSD factors.

use nalgebra::{Complex, DMatrix, linalg::Schur};

use crate::error::{Error, Result};
use crate::ss::{ContinuousSs, DiscreteSs};
use crate::validate;

/// Iteration cap for the Schur decomposition behind eigenvalues.
const SCHUR_MAX_ITER: usize = 10_000;
/// Doubling steps allowed in [`discrete_lyapunov`] (covers spectral radius up to 1 − 1e-15).
const LYAP_MAX_DOUBLINGS: usize = 64;

/// Default rank tolerance used by [`rank`]: `max(rows, cols) · ε · σ_max` (as in LAPACK-based
/// tools: singular values below it are numerically zero).
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let m = dmatrix![1.0, 0.0; 0.0, 1e-20];
/// // max(rows, cols)·ε·σ_max: the tiny singular value counts as zero.
/// assert!(model::analysis::default_rank_tolerance(&m) > 1e-20);
/// assert_eq!(model::rank(&m, None)?, 1);
/// # Ok::<(), model::Error>(())
/// ```
pub fn default_rank_tolerance(m: &DMatrix<f64>) -> f64 {
    if m.is_empty() {
        return 0.0;
    }
    let smax = m.clone().svd(false, false).singular_values.max();
    m.nrows().max(m.ncols()) as f64 * f64::EPSILON * smax
}

/// Numerical rank: the number of singular values strictly above `tol`, or above
/// [`default_rank_tolerance`] when `tol` is `None`.
///
/// # Errors
/// [`Error::NonFiniteMatrix`] for NaN/∞ entries.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let m = dmatrix![1.0, 2.0; 2.0, 4.0]; // second row = 2 × first
/// assert_eq!(model::rank(&m, None)?, 1);
/// # Ok::<(), model::Error>(())
/// ```
pub fn rank(m: &DMatrix<f64>, tol: Option<f64>) -> Result<usize> {
    validate::finite("M", m)?;
    if m.is_empty() {
        return Ok(0);
    }
    let tol = tol.unwrap_or_else(|| default_rank_tolerance(m));
    let sv = m.clone().svd(false, false).singular_values;
    Ok(sv.iter().filter(|s| **s > tol).count())
}

/// Controllability matrix `[B, AB, …, A^{n−1}B]` (n × n·l).
///
/// # Errors
/// Shape and finiteness errors for `A`, `B`.
///
/// # Example
/// ```
/// use model::analysis::controllability_matrix;
/// use model::nalgebra::dmatrix;
///
/// let a = dmatrix![0.0, 1.0; 0.0, 0.0];
/// let b = dmatrix![0.0; 1.0];
/// let c = controllability_matrix(&a, &b)?; // [B, AB]
/// assert!((c - dmatrix![0.0, 1.0; 1.0, 0.0]).norm() < 1e-15);
/// # Ok::<(), model::Error>(())
/// ```
pub fn controllability_matrix(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = validate::square("A", a)?;
    validate::shape("B", b, n, b.ncols(), "B must have as many rows as A")?;
    let l = b.ncols();
    let mut out = DMatrix::zeros(n, n * l);
    let mut blk = b.clone();
    for i in 0..n {
        out.columns_mut(i * l, l).copy_from(&blk);
        blk = a * blk;
    }
    Ok(out)
}

/// Observability matrix `[C; CA; …; CA^{n−1}]` (n·m × n).
///
/// # Errors
/// Shape and finiteness errors for `A`, `C`.
///
/// # Example
/// ```
/// use model::analysis::observability_matrix;
/// use model::nalgebra::dmatrix;
///
/// let a = dmatrix![0.0, 1.0; 0.0, 0.0];
/// let c = dmatrix![1.0, 0.0];
/// let o = observability_matrix(&a, &c)?; // [C; CA]
/// assert!((o - dmatrix![1.0, 0.0; 0.0, 1.0]).norm() < 1e-15);
/// # Ok::<(), model::Error>(())
/// ```
pub fn observability_matrix(a: &DMatrix<f64>, c: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = validate::square("A", a)?;
    validate::shape("C", c, c.nrows(), n, "C must have as many columns as A")?;
    Ok(controllability_matrix(&a.transpose(), &c.transpose())?.transpose())
}

/// Whether `(A, B)` is controllable: the controllability matrix has rank n by SVD with the
/// tolerance of [`rank`] (`tol = None`: `max(rows, cols)·ε·σ_max`).
///
/// # Errors
/// Shape and finiteness errors for `A`, `B`.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let a = dmatrix![0.0, 1.0; 0.0, 0.0]; // double integrator
/// assert!(model::is_controllable(&a, &dmatrix![0.0; 1.0], None)?); // force on the velocity
/// assert!(!model::is_controllable(&a, &dmatrix![1.0; 0.0], None)?); // velocity unreachable
/// # Ok::<(), model::Error>(())
/// ```
pub fn is_controllable(a: &DMatrix<f64>, b: &DMatrix<f64>, tol: Option<f64>) -> Result<bool> {
    Ok(rank(&controllability_matrix(a, b)?, tol)? == a.nrows())
}

/// Whether `(A, C)` is observable (dual of [`is_controllable`], same tolerance rule).
///
/// # Errors
/// Shape and finiteness errors for `A`, `C`.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let a = dmatrix![0.0, 1.0; 0.0, 0.0];
/// assert!(model::is_observable(&a, &dmatrix![1.0, 0.0], None)?); // position measured
/// assert!(!model::is_observable(&a, &dmatrix![0.0, 1.0], None)?); // only velocity
/// # Ok::<(), model::Error>(())
/// ```
pub fn is_observable(a: &DMatrix<f64>, c: &DMatrix<f64>, tol: Option<f64>) -> Result<bool> {
    Ok(rank(&observability_matrix(a, c)?, tol)? == a.nrows())
}

/// Complex eigenvalues of a square matrix (real Schur form).
///
/// # Errors
/// [`Error::NotSquare`], [`Error::NonFiniteMatrix`], [`Error::NoConvergence`].
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let a = dmatrix![0.0, 1.0; -4.0, 0.0]; // undamped oscillator, ω = 2
/// let mut im: Vec<f64> = model::eigenvalues(&a)?.iter().map(|l| l.im).collect();
/// im.sort_by(f64::total_cmp);
/// assert!((im[0] + 2.0).abs() < 1e-12 && (im[1] - 2.0).abs() < 1e-12);
/// # Ok::<(), model::Error>(())
/// ```
pub fn eigenvalues(a: &DMatrix<f64>) -> Result<Vec<Complex<f64>>> {
    let n = validate::square("A", a)?;
    if n == 0 {
        return Ok(Vec::new());
    }
    let schur =
        Schur::try_new(a.clone(), f64::EPSILON, SCHUR_MAX_ITER).ok_or(Error::NoConvergence {
            algorithm: "Schur decomposition",
            iterations: SCHUR_MAX_ITER,
        })?;
    Ok(schur.complex_eigenvalues().iter().copied().collect())
}

/// Spectral radius `max |λ_i(F)|` (0 for an empty matrix).
///
/// # Errors
/// As [`eigenvalues`].
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let f = dmatrix![0.5, 1.0; 0.0, -0.8];
/// assert!((model::spectral_radius(&f)? - 0.8).abs() < 1e-12); // stable: < 1
/// # Ok::<(), model::Error>(())
/// ```
pub fn spectral_radius(f: &DMatrix<f64>) -> Result<f64> {
    Ok(eigenvalues(f)?.iter().map(|l| l.norm()).fold(0.0, f64::max))
}

/// Spectral abscissa `max Re λ_i(A)` (−∞ for an empty matrix).
///
/// # Errors
/// As [`eigenvalues`].
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let a = dmatrix![-1.0, 5.0; 0.0, -3.0];
/// assert!((model::spectral_abscissa(&a)? + 1.0).abs() < 1e-12); // stable: < 0
/// # Ok::<(), model::Error>(())
/// ```
pub fn spectral_abscissa(a: &DMatrix<f64>) -> Result<f64> {
    Ok(eigenvalues(a)?
        .iter()
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max))
}

/// Solves `P = F·P·Fᵀ + Q` for the stationary covariance (Smith's doubling:
/// `P ← P + Fᵏ P Fᵏᵀ`, `Fᵏ ← Fᵏ·Fᵏ`; the result is symmetrised).
///
/// # Errors
/// [`Error::Unstable`] when the spectral radius of `F` is ≥ 1 (no stationary covariance);
/// shape, finiteness and PSD errors for `F`, `Q`; [`Error::NoConvergence`].
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// // AR(1) x_{k+1} = 0.9 x_k + w_k, var w = 0.19: stationary variance 0.19/(1 − 0.81) = 1.
/// let p = model::discrete_lyapunov(&dmatrix![0.9], &dmatrix![0.19])?;
/// assert!((p[(0, 0)] - 1.0).abs() < 1e-12);
/// # Ok::<(), model::Error>(())
/// ```
pub fn discrete_lyapunov(f: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = validate::square("F", f)?;
    validate::covariance("Q", q, n, "Q must be n×n like F")?;
    let rho = spectral_radius(f)?;
    if rho >= 1.0 {
        return Err(Error::Unstable {
            name: "F",
            measure: "spectral radius",
            value: rho,
            rule: "< 1",
        });
    }
    let mut p = q.clone();
    let mut ak = f.clone();
    for _ in 0..LYAP_MAX_DOUBLINGS {
        let add = &ak * &p * ak.transpose();
        p += &add;
        ak = &ak * &ak;
        // Later terms are bounded by ‖Fᵏ‖²·(this one): stop once it is below rounding and
        // Fᵏ is contracting.
        if add.amax() <= f64::EPSILON * p.amax() && ak.norm() < 1.0 {
            return Ok(validate::symmetrize(&p));
        }
    }
    Err(Error::NoConvergence {
        algorithm: "discrete Lyapunov doubling",
        iterations: LYAP_MAX_DOUBLINGS,
    })
}

/// A factor `L` (n×n) with `L·Lᵀ = Q` for a symmetric PSD `Q` (from the symmetric
/// eigen-decomposition; eigenvalues within the PSD tolerance below zero are set to zero).
/// Use it to draw `w = L·ξ`, ξ standard normal, even when `Q` is singular.
///
/// # Errors
/// Shape, finiteness, symmetry and PSD errors for `Q`.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// let q = dmatrix![1.0, 1.0; 1.0, 1.0]; // singular: Cholesky would fail
/// let l = model::psd_factor(&q)?;
/// assert!((&l * l.transpose() - &q).norm() < 1e-12);
/// # Ok::<(), model::Error>(())
/// ```
pub fn psd_factor(q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    validate::covariance("Q", q, q.nrows(), "Q must be square")?;
    if q.is_empty() {
        return Ok(q.clone());
    }
    let eig = validate::symmetrize(q).symmetric_eigen();
    let mut l = eig.eigenvectors.clone();
    for (j, lam) in eig.eigenvalues.iter().enumerate() {
        let s = lam.max(0.0).sqrt();
        l.column_mut(j).scale_mut(s);
    }
    Ok(l)
}

/// Markov parameters (impulse response) `[D, H B, H F B, …]` of `(F, B, H, D)`, `len` terms.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
///
/// // y_k = x_k, x_{k+1} = 0.5 x_k + u_k: impulse response 0, 1, 0.5, 0.25.
/// let (f, b, h, d) = (dmatrix![0.5], dmatrix![1.0], dmatrix![1.0], dmatrix![0.0]);
/// let h = model::markov_parameters(&f, &b, &h, &d, 4);
/// let seq: Vec<f64> = h.iter().map(|m| m[(0, 0)]).collect();
/// assert!(seq.iter().zip([0.0, 1.0, 0.5, 0.25]).all(|(a, b)| (a - b).abs() < 1e-15));
/// ```
pub fn markov_parameters(
    f: &DMatrix<f64>,
    b: &DMatrix<f64>,
    h: &DMatrix<f64>,
    d: &DMatrix<f64>,
    len: usize,
) -> Vec<DMatrix<f64>> {
    let mut out = Vec::with_capacity(len);
    if len == 0 {
        return out;
    }
    out.push(d.clone());
    let mut fb = b.clone();
    for _ in 1..len {
        out.push(h * &fb);
        fb = f * fb;
    }
    out
}

fn to_complex(m: &DMatrix<f64>) -> DMatrix<Complex<f64>> {
    m.map(|v| Complex::new(v, 0.0))
}

/// `H·(z I − F)⁻¹·B + D` at a complex point, by an LU solve.
fn resolvent_gain(
    z: Complex<f64>,
    f: &DMatrix<f64>,
    b: &DMatrix<f64>,
    h: &DMatrix<f64>,
    d: &DMatrix<f64>,
    name: &'static str,
) -> Result<DMatrix<Complex<f64>>> {
    let n = f.nrows();
    let mut m = -to_complex(f);
    for i in 0..n {
        m[(i, i)] += z;
    }
    let x = m.lu().solve(&to_complex(b)).ok_or(Error::Singular {
        name,
        context: "the frequency is an eigenvalue (a pole) of the system",
    })?;
    Ok(to_complex(h) * x + to_complex(d))
}

impl ContinuousSs {
    /// Whether all eigenvalues of `A` have negative real part.
    ///
    /// # Errors
    /// [`Error::NoConvergence`] from the eigenvalue solver.
    pub fn is_stable(&self) -> Result<bool> {
        Ok(spectral_abscissa(self.a())? < 0.0)
    }

    /// Controllability of `(A, B)` (see [`is_controllable`]).
    ///
    /// # Errors
    /// None in practice (the model is validated); kept for the solver.
    pub fn is_controllable(&self, tol: Option<f64>) -> Result<bool> {
        is_controllable(self.a(), self.b(), tol)
    }

    /// Observability of `(A, C)` (see [`is_observable`]).
    ///
    /// # Errors
    /// None in practice (the model is validated).
    pub fn is_observable(&self, tol: Option<f64>) -> Result<bool> {
        is_observable(self.a(), self.c(), tol)
    }

    /// Frequency response `C (jωI − A)⁻¹ B + D` (m×p).
    ///
    /// # Errors
    /// [`Error::Singular`] when jω is a pole.
    pub fn freq_response(&self, omega: f64) -> Result<DMatrix<Complex<f64>>> {
        resolvent_gain(
            Complex::new(0.0, omega),
            self.a(),
            self.b(),
            self.c(),
            self.d(),
            "jωI − A",
        )
    }

    /// DC gain `D − C A⁻¹ B` (m×p), by a solve.
    ///
    /// # Errors
    /// [`Error::Singular`] when `A` is singular (a pole at s = 0).
    pub fn dc_gain(&self) -> Result<DMatrix<f64>> {
        let x = self
            .a()
            .clone()
            .lu()
            .solve(self.b())
            .ok_or(Error::Singular {
                name: "A",
                context: "DC gain needs A⁻¹B (pole at s = 0)",
            })?;
        Ok(self.d() - self.c() * x)
    }
}

impl DiscreteSs {
    /// Whether the spectral radius of `F` is below 1.
    ///
    /// # Errors
    /// [`Error::NoConvergence`] from the eigenvalue solver.
    pub fn is_stable(&self) -> Result<bool> {
        Ok(spectral_radius(self.f())? < 1.0)
    }

    /// Spectral radius of `F`.
    ///
    /// # Errors
    /// [`Error::NoConvergence`] from the eigenvalue solver.
    pub fn spectral_radius(&self) -> Result<f64> {
        spectral_radius(self.f())
    }

    /// Controllability of `(F, B)` (see [`is_controllable`]).
    ///
    /// # Errors
    /// None in practice (the model is validated).
    pub fn is_controllable(&self, tol: Option<f64>) -> Result<bool> {
        is_controllable(self.f(), self.b(), tol)
    }

    /// Observability of `(F, H)` (see [`is_observable`]).
    ///
    /// # Errors
    /// None in practice (the model is validated).
    pub fn is_observable(&self, tol: Option<f64>) -> Result<bool> {
        is_observable(self.f(), self.h(), tol)
    }

    /// Frequency response `H (zI − F)⁻¹ B + D` at `z = e^{jωΔt}` (ω in rad/s).
    ///
    /// # Errors
    /// [`Error::Singular`] when z is a pole.
    pub fn freq_response(&self, omega: f64) -> Result<DMatrix<Complex<f64>>> {
        resolvent_gain(
            Complex::from_polar(1.0, omega * self.dt()),
            self.f(),
            self.b(),
            self.h(),
            self.d(),
            "zI − F",
        )
    }

    /// DC gain `H (I − F)⁻¹ B + D`.
    ///
    /// # Errors
    /// [`Error::Singular`] when `I − F` is singular (a pole at z = 1).
    pub fn dc_gain(&self) -> Result<DMatrix<f64>> {
        let n = self.n_states();
        let m = DMatrix::<f64>::identity(n, n) - self.f();
        let x = m.lu().solve(self.b()).ok_or(Error::Singular {
            name: "I − F",
            context: "DC gain needs (I − F)⁻¹B (pole at z = 1)",
        })?;
        Ok(self.h() * x + self.d())
    }

    /// Impulse response from the control inputs: `[D, HB, HFB, …]`, `len` terms.
    pub fn impulse_response(&self, len: usize) -> Vec<DMatrix<f64>> {
        markov_parameters(self.f(), self.b(), self.h(), self.d(), len)
    }

    /// Impulse response from the noise inputs: `[J, HG, HFG, …]`, `len` terms.
    pub fn noise_impulse_response(&self, len: usize) -> Vec<DMatrix<f64>> {
        markov_parameters(self.f(), self.g(), self.h(), self.j(), len)
    }

    /// Stationary state covariance `P = F P Fᵀ + G Q Gᵀ`.
    ///
    /// # Errors
    /// [`Error::Unstable`] when the spectral radius of `F` is ≥ 1.
    pub fn stationary_covariance(&self) -> Result<DMatrix<f64>> {
        discrete_lyapunov(self.f(), &self.process_covariance())
    }

    /// Stationary output covariance under the noise alone: `H P Hᵀ + J Q Jᵀ` (`x_k` and
    /// `w_k` are independent).
    ///
    /// # Errors
    /// [`Error::Unstable`] when the spectral radius of `F` is ≥ 1.
    pub fn stationary_output_covariance(&self) -> Result<DMatrix<f64>> {
        let p = self.stationary_covariance()?;
        Ok(validate::symmetrize(
            &(self.h() * p * self.h().transpose() + self.output_noise_covariance()),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_and_trivial_cases() {
        assert!(eigenvalues(&DMatrix::zeros(0, 0)).expect("ok").is_empty());
        assert!(spectral_radius(&DMatrix::zeros(0, 0)).expect("ok").abs() < 1e-300);
        let f = DMatrix::from_element(1, 1, 0.5);
        assert!(markov_parameters(&f, &f, &f, &f, 0).is_empty());
        let h = markov_parameters(&f, &f, &f, &f, 3);
        assert!((h[2][(0, 0)] - 0.125).abs() < 1e-15);
        assert_eq!(rank(&DMatrix::zeros(0, 3), None).expect("ok"), 0);
    }

    #[test]
    fn psd_factor_of_singular_matrix() {
        let q = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        let l = psd_factor(&q).expect("PSD");
        assert!((&l * l.transpose() - &q).amax() < 1e-14);
    }
}
