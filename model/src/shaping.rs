//! Shaping filters: white noise → a stationary process with a given correlation function
//! (exponential, irregular rolling, damped cosine), with their spectra and discrete models.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::discretize::{Discretization, NoiseConvention, discretize};
use crate::error::{Error, Result};
use crate::ss::{ContinuousSs, DiscreteSs};
use crate::tf::{ContinuousTf, DiscreteTf, PaperVariant};
use crate::validate;

/// A shaping filter: a strictly proper transfer function `H(s)` driven by white noise of
/// intensity `N`, whose stationary output has the correlation function
/// [`ShapingFilter::correlation`] and variance `D = R(0) = N·∫|H(jω)|²dω/2π`.
///
/// Conventions: the spectral density is two-sided, `S(ω) = N·|H(jω)|²`, with
/// `R(τ) = (1/2π)∫S(ω)e^{jωτ}dω`.
///
/// # Example
/// ```
/// use model::{ExponentialShaping, Discretization, NoiseConvention, ShapingFilter};
///
/// // A first-order Gauss–Markov process of variance 4 and correlation time 2 s.
/// let f = ExponentialShaping::new(4.0, 2.0)?;
/// assert!((f.intensity() - 16.0).abs() < 1e-12); // N = 2 T D
/// let d = f.discretize(0.1, Discretization::Zoh, NoiseConvention::VanLoan)?;
/// // Its stationary variance is D again: P = F P Fᵀ + Q.
/// let p = model::discrete_lyapunov(d.f(), &d.process_covariance())?;
/// assert!((p[(0, 0)] * d.h()[(0, 0)].powi(2) - 4.0).abs() < 1e-9);
/// # Ok::<(), model::Error>(())
/// ```
pub trait ShapingFilter {
    /// Stationary variance `D` of the output.
    fn variance(&self) -> f64;
    /// The normalised filter `H(s)` (unit DC gain).
    fn transfer_function(&self) -> ContinuousTf;
    /// White-noise intensity `N` that gives the variance `D`.
    fn intensity(&self) -> f64;
    /// Correlation function `R(τ)`.
    fn correlation(&self, tau: f64) -> f64;
    /// Two-sided spectral density `S(ω) = N·|H(jω)|²`.
    fn spectral_density(&self, omega: f64) -> f64 {
        self.intensity() * self.transfer_function().freq_response(omega).norm_sqr()
    }
    /// The shortest time constant of the correlation (1/decay rate or 1/frequency): choose
    /// `Δt` well below it.
    fn shortest_time_constant(&self) -> f64;
    /// Mazurenko's Tustin variant for this filter, or `None` for exact Tustin.
    fn paper_variant(&self) -> Option<PaperVariant> {
        None
    }

    /// Continuous model: `ẋ = A x + G w`, `y = C x`, intensity `W = [N]`, no control input.
    fn continuous(&self) -> ContinuousSs {
        let r = self.transfer_function().realize();
        let n = r.n_states();
        ContinuousSs::from_parts_unchecked(
            r.a().clone(),
            DMatrix::zeros(n, 0),
            r.c().clone(),
            DMatrix::zeros(1, 0),
            r.b().clone(),
            DMatrix::from_element(1, 1, self.intensity()),
        )
    }

    /// Discrete model by any [`Discretization`] and [`NoiseConvention`].
    ///
    /// # Errors
    /// As [`discretize`] (`dt` ≤ 0, bad pre-warp frequency).
    fn discretize(
        &self,
        dt: f64,
        method: Discretization,
        noise: NoiseConvention,
    ) -> Result<DiscreteSs> {
        discretize(&self.continuous(), dt, method, noise)
    }

    /// Discrete model by Mazurenko's rule: Tustin with the paper's numerator change
    /// where it has one (rolling: `(1+z⁻¹) → 2z⁻¹`; quantization: `(1+z⁻¹) → 2`; exponential:
    /// exact Tustin), realised in controllable canonical form, noise `w_k` of variance `N/Δt`
    /// entering as the filter input (`G = B`, `J = D` of the realisation).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for `dt` ≤ 0.
    fn discretize_paper(&self, dt: f64) -> Result<DiscreteSs> {
        let tf = self.transfer_function();
        let dtf = match self.paper_variant() {
            Some(v) => tf.paper_tustin(dt, v)?,
            None => tf.tustin(dt, None)?,
        };
        noise_driven(&dtf, self.intensity() / dt)
    }
}

/// Realises a discrete transfer function as a noise-driven model: the input becomes the noise
/// `w_k` with variance `q` (`G = B`, `J = D`), no control input.
///
/// # Errors
/// [`Error::InvalidParameter`] for a negative or non-finite `q`.
///
/// # Example
/// ```
/// use model::{DiscreteTf, noise_driven};
///
/// // AR(1) y_k = 0.8 y_{k−1} + w_k as 1/(1 − 0.8 z⁻¹), var w = 0.36: var y = 0.36/(1 − 0.64) = 1.
/// let tf = DiscreteTf::new(vec![1.0], vec![1.0, -0.8], 1.0)?;
/// let s = noise_driven(&tf, 0.36)?;
/// let p = model::discrete_lyapunov(s.f(), &s.process_covariance())?;
/// // y_k = H x_k + J w_k with x_k independent of w_k.
/// let var = (s.h() * &p * s.h().transpose() + s.output_noise_covariance())[(0, 0)];
/// assert!((var - 1.0).abs() < 1e-9);
/// # Ok::<(), model::Error>(())
/// ```
pub fn noise_driven(tf: &DiscreteTf, q: f64) -> Result<DiscreteSs> {
    validate::non_negative("q", q)?;
    let r = tf.realize();
    DiscreteSs::autonomous(r.f().clone(), r.h().clone(), r.dt())?.with_noise(
        r.b().clone(),
        r.d().clone(),
        DMatrix::from_element(1, 1, q),
    )
}

/// Exponential correlation `R(τ) = D·e^{−|τ|/T}`; filter `1/(T s + 1)`, `N = 2·T·D`.
///
/// # Example
/// ```
/// use model::{ExponentialShaping, ShapingFilter};
///
/// let f = ExponentialShaping::new(1.0, 0.5)?;
/// assert!((f.correlation(0.5) - (-1.0f64).exp()).abs() < 1e-15); // R(T) = D/e
/// assert!(ExponentialShaping::new(1.0, 0.0).is_err()); // T must be > 0
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ExponentialRaw")]
pub struct ExponentialShaping {
    variance: f64,
    time_constant: f64,
}

deserialize_via! {
    ExponentialShaping, ExponentialRaw { variance: f64, time_constant: f64 },
    |r| ExponentialShaping::new(r.variance, r.time_constant)
}

impl ExponentialShaping {
    /// `variance` = D > 0, `time_constant` = T > 0 (seconds).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `variance` or `time_constant`.
    pub fn new(variance: f64, time_constant: f64) -> Result<Self> {
        Ok(Self {
            variance: validate::positive("variance", variance)?,
            time_constant: validate::positive("time_constant", time_constant)?,
        })
    }
    /// Correlation time T.
    pub fn time_constant(&self) -> f64 {
        self.time_constant
    }
}

impl ShapingFilter for ExponentialShaping {
    fn variance(&self) -> f64 {
        self.variance
    }
    fn transfer_function(&self) -> ContinuousTf {
        ContinuousTf::from_validated(vec![1.0], vec![1.0, self.time_constant])
    }
    fn intensity(&self) -> f64 {
        2.0 * self.time_constant * self.variance
    }
    fn correlation(&self, tau: f64) -> f64 {
        self.variance * (-tau.abs() / self.time_constant).exp()
    }
    fn spectral_density(&self, omega: f64) -> f64 {
        self.intensity() / (1.0 + (self.time_constant * omega).powi(2))
    }
    fn shortest_time_constant(&self) -> f64 {
        self.time_constant
    }
}

/// Irregular rolling `R(τ) = D·e^{−μ|τ|}(cos βτ + (μ/β)·sin β|τ|)`; filter
/// `1/(b s² + a s + 1)` with `a = 2μ/(μ²+β²)`, `b = 1/(μ²+β²)`; `N = 2·a·D`.
///
/// # Example
/// ```
/// use model::{IrregularRollingShaping, ShapingFilter};
///
/// // Rolling with a 10 s period (β = 2π/10) and irregularity μ = 0.08 s⁻¹, σ = 1°.
/// let beta = 2.0 * std::f64::consts::PI / 10.0;
/// let f = IrregularRollingShaping::new(1f64.to_radians().powi(2), 0.08, beta)?;
/// let (a, b) = f.coefficients();
/// assert!((b - 1.0 / (0.08f64.powi(2) + f.beta().powi(2))).abs() < 1e-12);
/// assert!((f.intensity() - 2.0 * a * f.variance()).abs() < 1e-18);
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RollingRaw")]
pub struct IrregularRollingShaping {
    variance: f64,
    mu: f64,
    beta: f64,
}

deserialize_via! {
    IrregularRollingShaping, RollingRaw { variance: f64, mu: f64, beta: f64 },
    |r| IrregularRollingShaping::new(r.variance, r.mu, r.beta)
}

impl IrregularRollingShaping {
    /// `variance` = D > 0, `mu` = μ > 0 (1/s, irregularity), `beta` = β > 0 (rad/s, dominant
    /// frequency).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `variance`, `mu` or `beta`.
    pub fn new(variance: f64, mu: f64, beta: f64) -> Result<Self> {
        Ok(Self {
            variance: validate::positive("variance", variance)?,
            mu: validate::positive("mu", mu)?,
            beta: validate::positive("beta", beta)?,
        })
    }
    /// The filter coefficients `(a, b)`.
    pub fn coefficients(&self) -> (f64, f64) {
        let s = self.mu * self.mu + self.beta * self.beta;
        (2.0 * self.mu / s, 1.0 / s)
    }
    /// μ.
    pub fn mu(&self) -> f64 {
        self.mu
    }
    /// β.
    pub fn beta(&self) -> f64 {
        self.beta
    }
}

impl ShapingFilter for IrregularRollingShaping {
    fn variance(&self) -> f64 {
        self.variance
    }
    fn transfer_function(&self) -> ContinuousTf {
        let (a, b) = self.coefficients();
        ContinuousTf::from_validated(vec![1.0], vec![1.0, a, b])
    }
    fn intensity(&self) -> f64 {
        2.0 * self.coefficients().0 * self.variance
    }
    fn correlation(&self, tau: f64) -> f64 {
        let t = tau.abs();
        self.variance
            * (-self.mu * t).exp()
            * ((self.beta * t).cos() + self.mu / self.beta * (self.beta * t).sin())
    }
    fn spectral_density(&self, omega: f64) -> f64 {
        let (a, b) = self.coefficients();
        let w2 = omega * omega;
        self.intensity() / ((1.0 - b * w2).powi(2) + a * a * w2)
    }
    fn shortest_time_constant(&self) -> f64 {
        (1.0 / self.mu).min(1.0 / self.beta)
    }
    fn paper_variant(&self) -> Option<PaperVariant> {
        Some(PaperVariant::Delay)
    }
}

/// Damped cosine `R(τ) = D·e^{−ξ|τ|}·cos ωτ`; filter `(1 + √d·s)/(d s² + c s + 1)` with
/// `c = 2ξ/(ξ²+ω²)`, `d = 1/(ξ²+ω²)`; `N = c·D`. The paper's quantization-noise model
/// (`D = δ²/12`, `ξ = 1/T_a`, `ω = γ_q`).
///
/// # Example
/// ```
/// use model::{DampedCosineShaping, ShapingFilter};
///
/// let f = DampedCosineShaping::new(1.0, 0.05, std::f64::consts::PI)?;
/// // R(τ) = D e^{−ξτ} cos ωτ: half a period later the sign has flipped.
/// assert!((f.correlation(1.0) + (-0.05f64).exp()).abs() < 1e-12);
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DampedRaw")]
pub struct DampedCosineShaping {
    variance: f64,
    xi: f64,
    omega: f64,
}

deserialize_via! {
    DampedCosineShaping, DampedRaw { variance: f64, xi: f64, omega: f64 },
    |r| DampedCosineShaping::new(r.variance, r.xi, r.omega)
}

impl DampedCosineShaping {
    /// `variance` = D > 0, `xi` = ξ > 0 (1/s), `omega` = ω > 0 (rad/s).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `variance`, `xi` or `omega`.
    pub fn new(variance: f64, xi: f64, omega: f64) -> Result<Self> {
        Ok(Self {
            variance: validate::positive("variance", variance)?,
            xi: validate::positive("xi", xi)?,
            omega: validate::positive("omega", omega)?,
        })
    }
    /// The filter coefficients `(c, d)`.
    pub fn coefficients(&self) -> (f64, f64) {
        let s = self.xi * self.xi + self.omega * self.omega;
        (2.0 * self.xi / s, 1.0 / s)
    }
    /// ξ.
    pub fn xi(&self) -> f64 {
        self.xi
    }
    /// ω.
    pub fn omega(&self) -> f64 {
        self.omega
    }
}

impl ShapingFilter for DampedCosineShaping {
    fn variance(&self) -> f64 {
        self.variance
    }
    fn transfer_function(&self) -> ContinuousTf {
        let (c, d) = self.coefficients();
        ContinuousTf::from_validated(vec![1.0, d.sqrt()], vec![1.0, c, d])
    }
    fn intensity(&self) -> f64 {
        self.coefficients().0 * self.variance
    }
    fn correlation(&self, tau: f64) -> f64 {
        self.variance * (-self.xi * tau.abs()).exp() * (self.omega * tau).cos()
    }
    fn spectral_density(&self, omega: f64) -> f64 {
        let (c, d) = self.coefficients();
        let w2 = omega * omega;
        self.intensity() * (1.0 + d * w2) / ((1.0 - d * w2).powi(2) + c * c * w2)
    }
    fn shortest_time_constant(&self) -> f64 {
        (1.0 / self.xi).min(1.0 / self.omega)
    }
    fn paper_variant(&self) -> Option<PaperVariant> {
        Some(PaperVariant::Drop)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_match_spec() {
        let r = IrregularRollingShaping::new(1.0, 0.08, 0.6).expect("valid");
        let (a, b) = r.coefficients();
        let s = 0.08f64.powi(2) + 0.36;
        assert!((a - 0.16 / s).abs() < 1e-15 && (b - 1.0 / s).abs() < 1e-15);
        assert!((r.intensity() - 2.0 * a).abs() < 1e-15);
        let q = DampedCosineShaping::new(2.0, 0.05, 6.0).expect("valid");
        let (c, _) = q.coefficients();
        assert!((q.intensity() - 2.0 * c).abs() < 1e-15);
        let e = ExponentialShaping::new(3.0, 2.0).expect("valid");
        assert!((e.intensity() - 12.0).abs() < 1e-15);
        assert!((e.correlation(-2.0) - 3.0 / std::f64::consts::E).abs() < 1e-15);
    }
}
