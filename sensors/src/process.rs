//! Seeded, stationary, zero-mean Gaussian random processes with exact discretisations, each
//! exposing its theoretical correlation function (the correlation functions of Mazurenko's
//! fuel-level paper).
//!
//! Every process is stepped at a fixed sampling interval Δt given at construction. The first
//! call to [`Process::next`] draws the state from the stationary distribution, so the output
//! is stationary from the first sample; each later call propagates the state by Δt with the
//! *exact* discrete transition and noise covariance of the continuous model, so the sampled
//! sequence has exactly the autocovariance `correlation(k·Δt)` at every lag, whatever Δt.
//! No step allocates. Every step draws the same number of normals whatever the parameters,
//! so two configurations driven by equal seeds stay on the same random stream.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::error::{Error, non_negative, positive};

/// One standard normal draw.
#[inline]
pub(crate) fn normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    StandardNormal.sample(rng)
}

/// The crate's reproducible generator: ChaCha8 seeded from a `u64` (bit-identical output for a
/// given seed on every platform).
///
/// # Example
/// ```
/// use sensors::rand::RngExt;
/// use sensors::seeded_rng;
///
/// let (mut a, mut b) = (seeded_rng(42), seeded_rng(42));
/// let x: f64 = a.random();
/// let y: f64 = b.random();
/// assert_eq!(x.to_bits(), y.to_bits()); // the same seed, the same stream
/// ```
#[must_use]
pub fn seeded_rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// A stationary zero-mean random process sampled at a fixed interval Δt.
///
/// # Example
/// ```
/// use sensors::{ExpCorrelated, ExpCorrelatedConfig, Process, seeded_rng};
///
/// fn mean_square<P: Process>(p: &mut P, n: usize) -> f64 {
///     let mut rng = seeded_rng(9);
///     (0..n).map(|_| p.next(&mut rng).powi(2)).sum::<f64>() / n as f64
/// }
/// let cfg = ExpCorrelatedConfig { std_dev: 1.0, correlation_time_s: 0.5 };
/// let mut p = ExpCorrelated::new(&cfg, 0.1)?;
/// // The sample variance approaches R(0) = σ² = 1.
/// assert!((mean_square(&mut p, 20_000) - p.variance()).abs() < 0.1);
/// # Ok::<(), sensors::Error>(())
/// ```
pub trait Process {
    /// Returns the next sample (the first call draws from the stationary distribution).
    fn next<R: Rng + ?Sized>(&mut self, rng: &mut R) -> f64;
    /// Theoretical correlation (auto-covariance) function R(τ) = E[x(t)·x(t+τ)], τ in seconds.
    fn correlation(&self, tau: f64) -> f64;
    /// Theoretical variance R(0).
    fn variance(&self) -> f64 {
        self.correlation(0.0)
    }
    /// Sampling interval Δt, s.
    fn dt(&self) -> f64;
    /// Forgets the state: the next sample is again a fresh stationary draw.
    fn reset(&mut self);
}

/// A process bundled with its own seeded [`ChaCha8Rng`]; also an endless iterator of samples.
///
/// # Example
/// ```
/// use sensors::{Seeded, WhiteNoise};
///
/// let noise = Seeded::new(WhiteNoise::new(0.1, 0.01)?, 7);
/// let samples: Vec<f64> = noise.take(5).collect();
/// assert_eq!(samples.len(), 5);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Seeded<P> {
    process: P,
    rng: ChaCha8Rng,
}

impl<P: Process> Seeded<P> {
    /// Wraps `process` with a generator seeded from `seed`.
    #[must_use]
    pub fn new(process: P, seed: u64) -> Self {
        Self {
            process,
            rng: seeded_rng(seed),
        }
    }
    /// Returns the next sample.
    pub fn sample(&mut self) -> f64 {
        self.process.next(&mut self.rng)
    }
    /// The wrapped process.
    pub fn process(&self) -> &P {
        &self.process
    }
}

impl<P: Process> Iterator for Seeded<P> {
    type Item = f64;
    fn next(&mut self) -> Option<f64> {
        Some(self.sample())
    }
}

// ----------------------------------------------------------------------------------------------

/// Discrete white Gaussian noise: independent N(0, σ²) samples.
///
/// Correlation: R(τ) = σ² for |τ| < Δt/2, 0 otherwise (the sampled sequence is uncorrelated).
/// [`WhiteNoise::from_intensity`] builds the discrete equivalent of continuous white noise of
/// intensity N: σ² = N/Δt (Mazurenko's convention).
///
/// # Example
/// ```
/// use sensors::{Process, WhiteNoise};
///
/// // Continuous white noise of intensity N = 0.02 sampled every 0.01 s: σ² = N/Δt = 2.
/// let w = WhiteNoise::from_intensity(0.02, 0.01)?;
/// assert!((w.variance() - 2.0).abs() < 1e-12);
/// assert!(w.correlation(0.01).abs() < 1e-15); // uncorrelated between samples
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct WhiteNoise {
    std_dev: f64,
    dt: f64,
}

impl WhiteNoise {
    /// White noise of standard deviation `std_dev` (≥ 0, process units) sampled every `dt` s.
    ///
    /// # Errors
    /// [`Error`] if `std_dev` is negative or `dt` is not positive (or either is not finite).
    pub fn new(std_dev: f64, dt: f64) -> Result<Self, Error> {
        Ok(Self {
            std_dev: non_negative("std_dev", std_dev)?,
            dt: positive("dt_s", dt)?,
        })
    }
    /// The discrete equivalent of continuous white noise of two-sided intensity `intensity`
    /// (units²·s): variance N/Δt.
    ///
    /// # Errors
    /// As [`WhiteNoise::new`], for `intensity` and `dt`.
    pub fn from_intensity(intensity: f64, dt: f64) -> Result<Self, Error> {
        let n = non_negative("intensity", intensity)?;
        let dt = positive("dt_s", dt)?;
        Self::new((n / dt).sqrt(), dt)
    }
    /// Standard deviation σ.
    pub fn std_dev(&self) -> f64 {
        self.std_dev
    }
}

impl Process for WhiteNoise {
    #[inline]
    fn next<R: Rng + ?Sized>(&mut self, rng: &mut R) -> f64 {
        self.std_dev * normal(rng)
    }
    fn correlation(&self, tau: f64) -> f64 {
        if tau.abs() < 0.5 * self.dt {
            self.std_dev * self.std_dev
        } else {
            0.0
        }
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn reset(&mut self) {}
}

// ----------------------------------------------------------------------------------------------

/// Configuration of an [`ExpCorrelated`] process. Defaults: the fill-velocity fluctuation ΔV of
/// the fuel-level paper (σ = 1 mm/s, T_a = 20 s; assumed values, the paper's set is unavailable).
///
/// # Example
/// ```
/// use sensors::{ExpCorrelated, ExpCorrelatedConfig, Process};
///
/// let cfg = ExpCorrelatedConfig { std_dev: 2.0, correlation_time_s: 10.0 };
/// let p = ExpCorrelated::new(&cfg, 1.0)?;
/// assert!((p.correlation(10.0) - 4.0 * (-1.0f64).exp()).abs() < 1e-12); // σ² e^{−τ/T}
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ExpCorrelatedConfig {
    /// Standard deviation σ = √D, process units (default 0.001, i.e. 1 mm/s for ΔV in m/s).
    pub std_dev: f64,
    /// Correlation time T, s (default 20).
    pub correlation_time_s: f64,
}

impl Default for ExpCorrelatedConfig {
    fn default() -> Self {
        Self {
            std_dev: 0.001,
            correlation_time_s: 20.0,
        }
    }
}

/// Exponentially correlated process, R(τ) = σ²·e^{−|τ|/T}, shaping filter 1/(T s + 1).
///
/// Exact AR(1): x_{k+1} = ρ·x_k + σ·√(1 − ρ²)·w_k with ρ = e^{−Δt/T}, w_k ~ N(0, 1).
///
/// # Example
/// ```
/// use sensors::{ExpCorrelated, ExpCorrelatedConfig, Process, seeded_rng};
///
/// let mut p = ExpCorrelated::new(&ExpCorrelatedConfig::default(), 0.1)?;
/// assert!((p.rho() - (-0.1f64 / 20.0).exp()).abs() < 1e-15);
/// let mut rng = seeded_rng(1);
/// let x0 = p.next(&mut rng);
/// let x1 = p.next(&mut rng);
/// assert!((x1 - x0).abs() < 0.01); // T = 20 s: consecutive samples barely move
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct ExpCorrelated {
    std_dev: f64,
    time: f64,
    dt: f64,
    rho: f64,
    innovation: f64,
    x: Option<f64>,
}

impl ExpCorrelated {
    /// Builds the process sampled every `dt` s.
    ///
    /// # Errors
    /// [`Error`] if σ is negative, T or Δt not positive, or any is not finite.
    pub fn new(config: &ExpCorrelatedConfig, dt: f64) -> Result<Self, Error> {
        let std_dev = non_negative("std_dev", config.std_dev)?;
        let time = positive("correlation_time_s", config.correlation_time_s)?;
        let dt = positive("dt_s", dt)?;
        Ok(Self {
            std_dev,
            time,
            dt,
            rho: (-dt / time).exp(),
            // √(1 − ρ²) without cancellation for Δt ≪ T.
            innovation: std_dev * (-(-2.0 * dt / time).exp_m1()).sqrt(),
            x: None,
        })
    }
    /// One-step correlation coefficient ρ = e^{−Δt/T}.
    pub fn rho(&self) -> f64 {
        self.rho
    }
}

impl Process for ExpCorrelated {
    #[inline]
    fn next<R: Rng + ?Sized>(&mut self, rng: &mut R) -> f64 {
        let w = normal(rng);
        let x = match self.x {
            Some(x) => self.rho * x + self.innovation * w,
            None => self.std_dev * w,
        };
        self.x = Some(x);
        x
    }
    fn correlation(&self, tau: f64) -> f64 {
        self.std_dev * self.std_dev * (-tau.abs() / self.time).exp()
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn reset(&mut self) {
        self.x = None;
    }
}

// ----------------------------------------------------------------------------------------------

/// Configuration of an [`IrregularRollingProcess`]. Defaults: the fuel-level paper's rolling
/// (period 2π/β = 10 s, μ = 0.08 s⁻¹; assumed) with unit σ.
///
/// # Example
/// ```
/// use sensors::{IrregularRollingProcess, IrregularRollingConfig, Process};
///
/// // Roll of 1° standard deviation with an 8 s period.
/// let cfg = IrregularRollingConfig {
///     std_dev: 1f64.to_radians(),
///     period_s: 8.0,
///     ..IrregularRollingConfig::default()
/// };
/// let p = IrregularRollingProcess::new(&cfg, 0.1)?;
/// assert!((p.variance() - cfg.std_dev.powi(2)).abs() < 1e-18);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IrregularRollingConfig {
    /// Standard deviation σ = √D, process units (default 1).
    pub std_dev: f64,
    /// Dominant period 2π/β, s (default 10).
    pub period_s: f64,
    /// Irregularity μ, s⁻¹ (default 0.08); must be > 0 (μ = 0 is a pure sinusoid, which no
    /// stable shaping filter produces).
    pub irregularity_per_s: f64,
}

impl Default for IrregularRollingConfig {
    fn default() -> Self {
        Self {
            std_dev: 1.0,
            period_s: 10.0,
            irregularity_per_s: 0.08,
        }
    }
}

/// "Irregular rolling": R(τ) = D·e^{−μ|τ|}(cos βτ + (μ/β)·sin β|τ|), D = σ².
///
/// This is the output of the shaping filter 1/(b s² + a s + 1), b = 1/(μ²+β²),
/// a = 2μ/(μ²+β²), i.e. ẍ + 2μẋ + ω₀²x = ω₀²u with ω₀² = μ² + β², whose stationary
/// covariance of (x, ẋ) is P∞ = D·diag(1, ω₀²). The state is propagated with the exact
/// transition Φ = e^{AΔt} (closed form for the under-damped oscillator) and the exact discrete
/// noise covariance Q_d = P∞ − Φ·P∞·Φᵀ (the Van Loan integral, evaluated through the
/// stationarity identity), drawn through its 2×2 Cholesky factor: two normals and a dozen
/// flops per sample, exact at any Δt. Q_d loses relative accuracy like ε/(ω₀Δt)³ when
/// ω₀Δt ≪ 1 (about 1e-10 at the defaults), which is immaterial for simulation.
///
/// # Example
/// ```
/// use sensors::{IrregularRollingProcess, IrregularRollingConfig, Process};
///
/// let p = IrregularRollingProcess::new(&IrregularRollingConfig::default(), 0.1)?;
/// // Half a period later the correlation is negative: the platform has swung back.
/// assert!(p.correlation(5.0) < 0.0);
/// assert!((p.correlation(0.0) - 1.0).abs() < 1e-12);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct IrregularRollingProcess {
    std_dev: f64,
    mu: f64,
    beta: f64,
    dt: f64,
    phi: [[f64; 2]; 2],
    /// Cholesky factor of Q_d for unit D: [l11, l21, l22].
    chol: [f64; 3],
    omega0: f64,
    /// Unit-variance state (x, ẋ).
    state: Option<[f64; 2]>,
}

impl IrregularRollingProcess {
    /// Builds the process sampled every `dt` s.
    ///
    /// # Errors
    /// [`Error`] if σ is negative, period, μ or Δt not positive, or any is not finite.
    pub fn new(config: &IrregularRollingConfig, dt: f64) -> Result<Self, Error> {
        let std_dev = non_negative("std_dev", config.std_dev)?;
        let period = positive("period_s", config.period_s)?;
        let mu = positive("irregularity_per_s", config.irregularity_per_s)?;
        let dt = positive("dt_s", dt)?;
        let beta = 2.0 * std::f64::consts::PI / period;
        let w2 = mu * mu + beta * beta;
        let e = (-mu * dt).exp();
        let (s, c) = (beta * dt).sin_cos();
        let phi = [
            [e * (c + mu / beta * s), e * s / beta],
            [-e * w2 / beta * s, e * (c - mu / beta * s)],
        ];
        // Q_d = P∞ − Φ P∞ Φᵀ with P∞ = diag(1, ω₀²).
        let q11 = 1.0 - (phi[0][0] * phi[0][0] + w2 * phi[0][1] * phi[0][1]);
        let q12 = -(phi[0][0] * phi[1][0] + w2 * phi[0][1] * phi[1][1]);
        let q22 = w2 - (phi[1][0] * phi[1][0] + w2 * phi[1][1] * phi[1][1]);
        let l11 = q11.max(0.0).sqrt();
        let l21 = if l11 > 0.0 { q12 / l11 } else { 0.0 };
        let l22 = (q22 - l21 * l21).max(0.0).sqrt();
        Ok(Self {
            std_dev,
            mu,
            beta,
            dt,
            phi,
            chol: [l11, l21, l22],
            omega0: w2.sqrt(),
            state: None,
        })
    }
    /// Dominant angular frequency β, rad/s.
    pub fn beta(&self) -> f64 {
        self.beta
    }
    /// Irregularity μ, s⁻¹.
    pub fn mu(&self) -> f64 {
        self.mu
    }
    /// Standard deviation σ.
    pub fn std_dev(&self) -> f64 {
        self.std_dev
    }
    /// Exact one-step transition Φ of the state (x, ẋ).
    pub fn transition(&self) -> [[f64; 2]; 2] {
        self.phi
    }
    /// Exact one-step noise covariance Q_d of the state (x, ẋ), for the configured σ.
    pub fn noise_covariance(&self) -> [[f64; 2]; 2] {
        let [l11, l21, l22] = self.chol;
        let d = self.std_dev * self.std_dev;
        [
            [d * l11 * l11, d * l11 * l21],
            [d * l11 * l21, d * (l21 * l21 + l22 * l22)],
        ]
    }
    /// Time derivative ẋ at the last sample (0 before the first), process units per second.
    pub fn rate(&self) -> f64 {
        self.state.map_or(0.0, |s| self.std_dev * s[1])
    }
}

impl Process for IrregularRollingProcess {
    #[inline]
    fn next<R: Rng + ?Sized>(&mut self, rng: &mut R) -> f64 {
        let w1 = normal(rng);
        let w2 = normal(rng);
        let s = match self.state {
            Some([x, v]) => {
                let [l11, l21, l22] = self.chol;
                [
                    self.phi[0][0] * x + self.phi[0][1] * v + l11 * w1,
                    self.phi[1][0] * x + self.phi[1][1] * v + l21 * w1 + l22 * w2,
                ]
            }
            None => [w1, self.omega0 * w2],
        };
        self.state = Some(s);
        self.std_dev * s[0]
    }
    fn correlation(&self, tau: f64) -> f64 {
        let t = tau.abs();
        self.std_dev
            * self.std_dev
            * (-self.mu * t).exp()
            * ((self.beta * t).cos() + self.mu / self.beta * (self.beta * t).sin())
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn reset(&mut self) {
        self.state = None;
    }
}

// ----------------------------------------------------------------------------------------------

/// Configuration of a [`DampedCosineProcess`]. Defaults: σ = 0.01/√12, ξ = 0.05 s⁻¹,
/// γ = 2π rad/s, the fuel-level paper's quantization noise at its assumed defaults (the law,
/// σ² = δ²/12, ξ = 1/T_a, γ = 2πV_c/δ, is `model::FuelParams`'s: `intensities`, `xi`,
/// `gamma_q`).
///
/// # Example
/// ```
/// use sensors::{DampedCosineConfig, DampedCosineProcess};
///
/// // Correlation σ²·e^{−ξ|τ|}·cos γτ with one period a second, sampled every 0.1 s.
/// let cfg = DampedCosineConfig { std_dev: 0.003, decay_per_s: 0.05, frequency_rad_s: 6.283 };
/// let p = DampedCosineProcess::new(&cfg, 0.1)?;
/// # let _ = p;
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DampedCosineConfig {
    /// Standard deviation σ = √D, process units (default 0.01/√12 ≈ 2.89e-3).
    pub std_dev: f64,
    /// Decay rate ξ, s⁻¹ (default 0.05); must be > 0.
    pub decay_per_s: f64,
    /// Angular frequency γ, rad/s (default 2π); any finite value (≥ 0 by convention).
    pub frequency_rad_s: f64,
}

impl Default for DampedCosineConfig {
    fn default() -> Self {
        Self {
            std_dev: 0.01 / 12f64.sqrt(),
            decay_per_s: 0.05,
            frequency_rad_s: 2.0 * std::f64::consts::PI,
        }
    }
}

/// Damped cosine correlation: R(τ) = σ²·e^{−ξ|τ|}·cos γτ.
///
/// Generated exactly as the first component of a rotating, decaying 2-vector:
/// z_{k+1} = e^{−ξΔt}·Rot(γΔt)·z_k + σ·√(1 − e^{−2ξΔt})·w_k with w_k ~ N(0, I₂) and
/// z₀ ~ N(0, σ²I₂), so E[z₁(t)z₁(t+kΔt)] = σ²e^{−ξkΔt}cos(γkΔt) exactly.
///
/// # Example
/// ```
/// use sensors::{DampedCosineProcess, DampedCosineConfig, Process};
///
/// let p = DampedCosineProcess::new(&DampedCosineConfig::default(), 0.1)?;
/// let d = p.variance();
/// // R(τ) = σ² e^{−ξτ} cos γτ with ξ = 0.05, γ = 2π: a full period later, e^{−0.05} of R(0).
/// assert!((p.correlation(1.0) - d * (-0.05f64).exp()).abs() < 1e-12 * d);
/// # Ok::<(), sensors::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct DampedCosineProcess {
    std_dev: f64,
    xi: f64,
    gamma: f64,
    dt: f64,
    /// e^{−ξΔt}·(cos γΔt, sin γΔt).
    ac: f64,
    as_: f64,
    innovation: f64,
    state: Option<[f64; 2]>,
}

impl DampedCosineProcess {
    /// Builds the process sampled every `dt` s.
    ///
    /// # Errors
    /// [`Error`] if σ is negative, ξ or Δt not positive, or any is not finite.
    pub fn new(config: &DampedCosineConfig, dt: f64) -> Result<Self, Error> {
        let std_dev = non_negative("std_dev", config.std_dev)?;
        let xi = positive("decay_per_s", config.decay_per_s)?;
        let gamma = crate::error::finite("frequency_rad_s", config.frequency_rad_s)?;
        let dt = positive("dt_s", dt)?;
        let a = (-xi * dt).exp();
        let (s, c) = (gamma * dt).sin_cos();
        Ok(Self {
            std_dev,
            xi,
            gamma,
            dt,
            ac: a * c,
            as_: a * s,
            innovation: std_dev * (-(-2.0 * xi * dt).exp_m1()).sqrt(),
            state: None,
        })
    }
}

impl Process for DampedCosineProcess {
    #[inline]
    fn next<R: Rng + ?Sized>(&mut self, rng: &mut R) -> f64 {
        let w1 = normal(rng);
        let w2 = normal(rng);
        let z = match self.state {
            Some([z1, z2]) => [
                self.ac * z1 - self.as_ * z2 + self.innovation * w1,
                self.as_ * z1 + self.ac * z2 + self.innovation * w2,
            ],
            None => [self.std_dev * w1, self.std_dev * w2],
        };
        self.state = Some(z);
        z[0]
    }
    fn correlation(&self, tau: f64) -> f64 {
        self.std_dev * self.std_dev * (-self.xi * tau.abs()).exp() * (self.gamma * tau).cos()
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn reset(&mut self) {
        self.state = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn rolling_discretisation_is_stationary_and_psd() {
        let p =
            IrregularRollingProcess::new(&IrregularRollingConfig::default(), 0.1).expect("valid");
        let f = p.transition();
        let q = p.noise_covariance();
        let w2 = p.mu() * p.mu() + p.beta() * p.beta();
        let pinf = [[1.0, 0.0], [0.0, w2]];
        // Φ P∞ Φᵀ + Q_d = P∞ (to rounding: entries are O(1)·ε).
        for i in 0..2 {
            for j in 0..2 {
                let mut s = q[i][j];
                for k in 0..2 {
                    s += f[i][k] * pinf[k][k] * f[j][k];
                }
                assert_relative_eq!(s, pinf[i][j], epsilon = 1e-12);
            }
        }
        assert!(q[0][0] > 0.0 && q[1][1] > 0.0);
        assert!(q[0][0] * q[1][1] - q[0][1] * q[0][1] >= 0.0);
    }

    #[test]
    fn first_sample_is_stationary_and_reset_forgets() {
        let mut p = ExpCorrelated::new(&ExpCorrelatedConfig::default(), 0.1).expect("valid");
        let mut rng = seeded_rng(3);
        let a = p.next(&mut rng);
        p.reset();
        let mut rng = seeded_rng(3);
        let b = p.next(&mut rng);
        assert_eq!(a.to_bits(), b.to_bits());
    }

    #[test]
    fn zero_variance_processes_stay_at_zero() {
        let mut rng = seeded_rng(1);
        let mut r = IrregularRollingProcess::new(
            &IrregularRollingConfig {
                std_dev: 0.0,
                ..IrregularRollingConfig::default()
            },
            0.1,
        )
        .expect("σ = 0 is valid (A_max = 0)");
        for _ in 0..10 {
            assert!(r.next(&mut rng).abs() < f64::MIN_POSITIVE);
        }
    }
}
