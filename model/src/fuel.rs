//! Mazurenko's 7-state fuel-level model, assembled from its five blocks.

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::compose::{connect, connect_continuous};
use crate::discretize::zoh;
use crate::error::Result;
use crate::ss::{ContinuousSs, DiscreteSs};
use crate::tf::{ContinuousTf, PaperVariant};
use crate::validate;

/// Names of the physical outputs y1…y5 (rows of [`FuelModel::g`]).
pub const OUTPUT_NAMES: [&str; 5] = [
    "y1: fill-velocity fluctuation ΔV [m/s]",
    "y2: tank level h [m]",
    "y3: tilt deviation at the sensor R·α [m]",
    "y4: level at the sensor h + R·α [m]",
    "y5: level inside the hydro-damper [m]",
];

/// Parameters of the fuel-level model, SI units (seconds, metres, radians).
///
/// The paper's own parameter set (its reference to an earlier study) is not available;
/// [`FuelParams::default`] is a plausible set, **every value assumed**: Δt = 0.1 s,
/// T_a = 20 s, D_c = (1 mm/s)², V_c = 10 mm/s, δ = 10 mm, T_y = 2 s, R = 1.5 m, φ = 30°,
/// rolling period 2π/β = 10 s, μ = 0.08 s⁻¹, A_max = 1° (the top of the paper's 0…1° range;
/// σ_α = A_max/3), gyro noise 0 (the paper's noise-free tilt channel). Missing fields in
/// JSON/TOML take these defaults.
///
/// # Example
/// ```
/// use model::FuelParams;
///
/// let params = FuelParams { delta: 0.005, ..FuelParams::default() }; // a 5 mm sensor
/// params.validate()?;
/// // The quantization noise frequency γ_q = 2π V_c/δ doubles when δ halves.
/// let base = FuelParams::default();
/// assert!((params.gamma_q() - 2.0 * base.gamma_q()).abs() < 1e-12);
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FuelParams {
    /// Sampling interval Δt (s).
    pub dt: f64,
    /// Correlation time T_a of the fill-velocity fluctuation (s).
    pub t_a: f64,
    /// Variance D_c of the fill-velocity fluctuation ((m/s)²).
    pub d_c: f64,
    /// Mean fill rate V_c (m/s).
    pub v_c: f64,
    /// Quantization step δ of the level sensor (m).
    pub delta: f64,
    /// Time constant T_y of the hydro-damper (s).
    pub t_y: f64,
    /// Distance R of the sensor from the tank axis (m) (the paper's R).
    pub sensor_radius: f64,
    /// Angle φ between the direction to the stern and to the sensor (rad).
    pub phi: f64,
    /// Dominant rolling period 2π/β (s).
    pub rolling_period: f64,
    /// Irregularity μ of rolling (1/s).
    pub mu: f64,
    /// Maximum tilt amplitude A_max (rad); σ_α = A_max/3 for each of ψ and θ. 0 is allowed
    /// (no rolling: a zero entry of Q).
    pub max_tilt_amplitude: f64,
    /// Variance of the gyro's tilt reading (rad²); adds `R²·gyro_noise_var` to R₁₁.
    /// 0 is the paper (noise-free tilt channel, singular R).
    pub gyro_noise_var: f64,
}

impl Default for FuelParams {
    /// [`FuelParamsStated::DEFAULT`] in SI units.
    fn default() -> Self {
        FuelParamsStated::DEFAULT.to_si()
    }
}

/// [`FuelParams`] in the units a person states them in (and the fueling scenario's files
/// take): seconds, millimetres, degrees, and the fill-velocity fluctuation and the gyro noise
/// as standard deviations; each field is named by its symbol in [`FuelParams`] and its unit.
/// The defaults live here, once, in these units.
///
/// # Example
/// ```
/// use model::{FuelParams, FuelParamsStated};
///
/// // A 5 mm sensor: δ = 0.005 m, every other value the default.
/// let si = FuelParamsStated { delta_mm: 5.0, ..FuelParamsStated::DEFAULT }.to_si();
/// assert!((si.delta - 0.005).abs() < 1e-18);
/// assert!((si.phi - FuelParams::default().phi).abs() < 1e-15); // φ = 30° in radians
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FuelParamsStated {
    /// Δt, s.
    pub dt_s: f64,
    /// T_a, s.
    pub t_a_s: f64,
    /// √D_c, mm/s.
    pub sigma_c_mm_s: f64,
    /// V_c, mm/s.
    pub v_c_mm_s: f64,
    /// δ, mm.
    pub delta_mm: f64,
    /// T_y, s.
    pub t_y_s: f64,
    /// R, m.
    pub sensor_radius_m: f64,
    /// φ, degrees.
    pub phi_deg: f64,
    /// 2π/β, s.
    pub rolling_period_s: f64,
    /// μ, 1/s.
    pub mu_per_s: f64,
    /// A_max, degrees.
    pub max_tilt_amplitude_deg: f64,
    /// The gyro noise's standard deviation √`gyro_noise_var`, degrees.
    pub gyro_sigma_deg: f64,
}

impl FuelParamsStated {
    /// The defaults, every value assumed (see [`FuelParams`]).
    pub const DEFAULT: Self = Self {
        dt_s: 0.1,
        t_a_s: 20.0,
        sigma_c_mm_s: 1.0,
        v_c_mm_s: 10.0,
        delta_mm: 10.0,
        t_y_s: 2.0,
        sensor_radius_m: 1.5,
        phi_deg: 30.0,
        rolling_period_s: 10.0,
        mu_per_s: 0.08,
        max_tilt_amplitude_deg: 1.0,
        gyro_sigma_deg: 0.0,
    };

    /// The same parameters in SI units (m, rad, variances).
    pub fn to_si(&self) -> FuelParams {
        FuelParams {
            dt: self.dt_s,
            t_a: self.t_a_s,
            d_c: (self.sigma_c_mm_s * 1e-3).powi(2),
            v_c: self.v_c_mm_s * 1e-3,
            delta: self.delta_mm * 1e-3,
            t_y: self.t_y_s,
            sensor_radius: self.sensor_radius_m,
            phi: self.phi_deg.to_radians(),
            rolling_period: self.rolling_period_s,
            mu: self.mu_per_s,
            max_tilt_amplitude: self.max_tilt_amplitude_deg.to_radians(),
            gyro_noise_var: self.gyro_sigma_deg.to_radians().powi(2),
        }
    }
}

/// The scalar coefficients of Mazurenko's discrete model, in the paper's names.
///
/// They are the Tustin (`s = (2/Δt)(1 − z⁻¹)/(1 + z⁻¹)`) images of the five blocks listed in
/// [`FuelParams::blocks`]; see [`FuelParams::paper_coefficients`] for the formulas.
///
/// # Example
/// ```
/// use model::FuelParams;
///
/// let p = FuelParams::default();
/// let k = p.paper_coefficients()?;
/// // The Tustin pole of the velocity filter 1/(T_a s + 1).
/// assert!((k.p_a - (p.t_a - p.dt / 2.0) / (p.t_a + p.dt / 2.0)).abs() < 1e-15);
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PaperCoefficients {
    /// Velocity filter pole `p_a = (T_a − Δt/2)/(T_a + Δt/2)`.
    pub p_a: f64,
    /// Velocity filter noise gain `k_a = T_aΔt/(T_a + Δt/2)²`.
    pub k_a: f64,
    /// Velocity filter feed-through `g_a = Δt/(2(T_a + Δt/2))`.
    pub g_a: f64,
    /// Damper pole `q_y = (T_y − Δt/2)/(T_y + Δt/2)`.
    pub q_y: f64,
    /// Damper gain `k_y = T_yΔt/(T_y + Δt/2)²`.
    pub k_y: f64,
    /// Damper feed-through `g_y = Δt/(2(T_y + Δt/2))`.
    pub g_y: f64,
    /// Rolling filter `a = 2μ/(μ²+β²)`.
    pub a: f64,
    /// Rolling filter `b = 1/(μ²+β²)`.
    pub b: f64,
    /// Quantization filter `c = 2ξ/(ξ²+γ_q²)`.
    pub c: f64,
    /// Quantization filter `d = 1/(ξ²+γ_q²)`.
    pub d: f64,
    /// Rolling filter normaliser `n₁ = 1 + 2a/Δt + 4b/Δt²`.
    pub n1: f64,
    /// Rolling filter denominator `a₁ = (2 − 8b/Δt²)/n₁`.
    pub a1: f64,
    /// Rolling filter denominator `a₂ = (1 − 2a/Δt + 4b/Δt²)/n₁`.
    pub a2: f64,
    /// Rolling filter numerator `b₁ = 2/n₁` (the paper's `2z⁻¹(1 + z⁻¹)` numerator).
    pub b1: f64,
    /// Rolling filter numerator `b₂ = 2/n₁`.
    pub b2: f64,
    /// Quantization filter normaliser `n₂ = 1 + 2c/Δt + 4d/Δt²`.
    pub n2: f64,
    /// Quantization filter denominator `c₁ = (2 − 8d/Δt²)/n₂`.
    pub c1: f64,
    /// Quantization filter denominator `c₂ = (1 − 2c/Δt + 4d/Δt²)/n₂`.
    pub c2: f64,
    /// Quantization filter numerator `d₀ = (2 + 4√d/Δt)/n₂` (the paper's `2(n₀ + n₁z⁻¹)`).
    pub d0: f64,
    /// Quantization filter numerator `d₁ = (2 − 4√d/Δt)/n₂`.
    pub d1: f64,
}

/// Which measurements the model has.
///
/// # Example
/// ```
/// use model::{Channels, FuelParams, Realisation};
///
/// let one = FuelParams::default().build(Channels::LevelOnly, Realisation::Paper)?;
/// let two = FuelParams::default().build(Channels::LevelAndTilt, Realisation::Paper)?;
/// assert_eq!((one.n_measurements(), two.n_measurements()), (1, 2));
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Channels {
    /// z2 only (the level sensor): the one-channel filter.
    LevelOnly,
    /// z1 (tilt channel R·α from the gyro) and z2 (level sensor): the two-channel filter.
    LevelAndTilt,
}

/// How the blocks are discretised.
///
/// # Example
/// ```
/// use model::{Channels, FuelParams, Realisation};
///
/// let zoh = FuelParams::default().build(Channels::LevelAndTilt, Realisation::Zoh)?;
/// assert_eq!(zoh.a.shape(), (7, 7));
/// // ZOH keeps power at the Nyquist frequency on both channels.
/// assert!(zoh.nyquist_measurement_power()?.iter().all(|&p| p > 0.0));
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Realisation {
    /// The paper: Tustin per block, with the paper's numerators for the rolling filter
    /// (`2z⁻¹(1+z⁻¹)`) and the quantization filter (`2(n₀+n₁z⁻¹)`). Reproduces the paper's A–D.
    Paper,
    /// Exact Tustin per block (feed-through of the rolling noise appears in B and D).
    ///
    /// **Not for a filter that uses the cross-covariance S against real data.** The bilinear
    /// map sends s = ∞ to z = −1, so every exact-Tustin block of relative degree ≥ 1 (all
    /// five here, the quantization filter included) carries a numerator factor (1 + z⁻¹).
    /// With the same u_k driving z_k (through D) and x_{k+1} (through B), the model's
    /// measurements therefore have **no power at the Nyquist frequency** on either channel
    /// ([`FuelModel::nyquist_measurement_power`] is 0 up to round-off): the model claims the
    /// alternating component of z is exactly predictable. The Kalman filter with S is
    /// optimal and consistent for that model, but its steady predictor `A − K_p C` then has
    /// an eigenvalue at −1, so it integrates any alternating content of real data undamped.
    /// A floor quantizer's steps have plenty; in a fuelling simulation the level estimate
    /// swings, the stop fires on a swing and the fuelling error grows several-fold. A filter that
    /// ignores S (R then acts as a white floor) and the other realisations are unaffected: the
    /// paper's quantization numerator `2(n₀ + n₁z⁻¹)` and zero-order hold keep power at Nyquist.
    /// This is a property of the model, not of the filter engine.
    ExactTustin,
    /// The continuous 7-state cascade discretised as a whole by zero-order hold, the noise
    /// held over the step (variance N/Δt, the paper's convention). States differ in scale
    /// from the paper's (x2 is the level itself, not level/Δt); `D = 0`.
    Zoh,
}

impl Realisation {
    /// How each of the five blocks of [`FuelParams::blocks`] is mapped by Tustin: the
    /// paper's numerator variant for the rolling (`Delay`) and quantization (`Drop`) filters
    /// under [`Realisation::Paper`], the exact map (`None`) otherwise. Not used by
    /// [`Realisation::Zoh`], which discretises the cascade as a whole.
    ///
    /// ```
    /// use model::{PaperVariant, Realisation};
    /// assert_eq!(Realisation::Paper.tustin_variants()[2], Some(PaperVariant::Delay));
    /// assert_eq!(Realisation::ExactTustin.tustin_variants(), [None; 5]);
    /// ```
    pub fn tustin_variants(self) -> [Option<PaperVariant>; 5] {
        match self {
            Realisation::Paper => [
                None,
                None,
                Some(PaperVariant::Delay),
                None,
                Some(PaperVariant::Drop),
            ],
            Realisation::ExactTustin | Realisation::Zoh => [None; 5],
        }
    }
}

/// The discrete fuel-level model in Mazurenko's convention:
///
/// ```text
/// x_{k+1} = A x_k + B u_k + known_input,   z_k = C x_k + D u_k,   y_k = G x_k (+ G_ff u_k),
/// cov(u_k) = Q = diag(2T_aD_c/Δt, 2aD_αR²/Δt, δ²c/(12Δt)),
/// R = D Q Dᵀ (+ gyro noise in R₁₁),  S = cov(B u_k, D u_k) = B Q Dᵀ,  process cov = B Q Bᵀ.
/// ```
///
/// (The paper writes `x_k = A x_{k−1} + B u_{k−1}`; the same u_k enters the state at the next
/// step and the measurement now, hence the cross-covariance S.)
///
/// # The paper's letters and the workspace's notation
/// The fields keep the paper's letters so the code reads against its equations; everywhere
/// else the crate uses the workspace notation ([`crate`] docs), and
/// [`FuelModel::to_discrete_ss`] gives the model in it:
///
/// | paper (field) | workspace notation | meaning |
/// |---|---|---|
/// | `A` ([`a`](Self::a)) | `F` | transition, 7×7 |
/// | `B` ([`b`](Self::b)) | `G` | noise input, 7×3 (u₁…u₃ are the noise `w`) |
/// | `C` ([`c`](Self::c)) | `H` | measurement, m×7 |
/// | `D` ([`d`](Self::d)) | `J` | noise feed-through into the measurement, m×3 (not a control `D`) |
/// | `G` ([`g`](Self::g)) | — | physical outputs y₁…y₅, 5×7 (not a noise input) |
/// | `Q`, `R`, `S` | `Q`, `R`, `S` | the same |
/// | known input | `B` with `u ≡ 1` | the mean fill rate V_c |
///
/// # Example
/// ```
/// use model::{Channels, FuelParams, Realisation};
///
/// let fuel = FuelParams::default().build(Channels::LevelAndTilt, Realisation::Paper)?;
/// let d = fuel.to_discrete_ss()?;
/// assert_eq!((d.n_states(), d.n_outputs()), (7, 2));
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub struct FuelModel {
    /// The parameters it was built from.
    pub params: FuelParams,
    /// Channel selection.
    pub channels: Channels,
    /// Realisation.
    pub realisation: Realisation,
    /// Transition matrix A (7×7).
    pub a: DMatrix<f64>,
    /// Noise input B (7×3), columns u1 (velocity), u2 (rolling), u3 (quantization).
    pub b: DMatrix<f64>,
    /// Measurement matrix C: 2×7 rows (z1 tilt, z2 level) or 1×7 (z2).
    pub c: DMatrix<f64>,
    /// Measurement feed-through of the noise, D: 2×3 or 1×3.
    pub d: DMatrix<f64>,
    /// Physical outputs y1…y5 (5×7); see [`OUTPUT_NAMES`].
    pub g: DMatrix<f64>,
    /// Feed-through of the noise into y1…y5 (5×3), omitted by the paper's G.
    pub g_feedthrough: DMatrix<f64>,
    /// Noise covariance Q (3×3, diagonal; an entry is 0 when its variance is 0).
    pub q: DMatrix<f64>,
    /// Measurement noise covariance R = D Q Dᵀ (+ R²·gyro_noise_var in R₁₁).
    pub r: DMatrix<f64>,
    /// Cross-covariance S = B Q Dᵀ (7×m) of process and measurement noise, in the filter
    /// engine's convention `E[w_k v_kᵀ]` with `x_{k+1} = A x_k + w_k`, `z_k = C x_k + v_k`,
    /// `w_k = B u_k`, `v_k = D u_k`. Exact for the model in every realisation; see
    /// [`Realisation::ExactTustin`] for why using it there fails against real data.
    pub s: DMatrix<f64>,
    /// Process noise covariance B Q Bᵀ (7×7).
    pub process_covariance: DMatrix<f64>,
    /// Known input added to the state every step for the mean fill rate V_c. Paper and exact
    /// Tustin: `[0, V_c, 0, 0, 0, 0, 0]` (x2 += V_c ⇒ level y2 = Δt·x2 + … rises by V_c·Δt);
    /// the Tustin integrator's half-step feed-through of the constant rate (Δt/2·V_c into the
    /// level and downstream, including the damper state) is exactly the same as starting x2
    /// higher by V_c/2, so it needs no separate term: with this vector there is no output
    /// offset. ZOH: the exact held-input response to V_c (x2 is the level itself, so
    /// level += V_c·Δt, plus the damper's share). Serialised as a plain list.
    #[serde(with = "vector_as_list")]
    pub known_input: DVector<f64>,
}

impl FuelParams {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`crate::Error::InvalidParameter`] naming the parameter: all must be finite; `dt`,
    /// `t_a`, `d_c`, `v_c`, `delta`, `t_y`, `sensor_radius`, `rolling_period`, `mu` > 0;
    /// `max_tilt_amplitude`, `gyro_noise_var` ≥ 0.
    pub fn validate(&self) -> Result<()> {
        validate::positive("dt", self.dt)?;
        validate::positive("t_a", self.t_a)?;
        validate::positive("d_c", self.d_c)?;
        validate::positive("v_c", self.v_c)?;
        validate::positive("delta", self.delta)?;
        validate::positive("t_y", self.t_y)?;
        validate::positive("sensor_radius", self.sensor_radius)?;
        validate::finite_scalar("phi", self.phi)?;
        validate::positive("rolling_period", self.rolling_period)?;
        validate::positive("mu", self.mu)?;
        validate::non_negative("max_tilt_amplitude", self.max_tilt_amplitude)?;
        validate::non_negative("gyro_noise_var", self.gyro_noise_var)?;
        Ok(())
    }

    /// Dominant rolling frequency β = 2π / rolling period (rad/s).
    pub fn beta(&self) -> f64 {
        2.0 * PI / self.rolling_period
    }
    /// σ_α = A_max/3 (rad).
    pub fn sigma_alpha(&self) -> f64 {
        self.max_tilt_amplitude / 3.0
    }
    /// Tilt variance D_α = σ_α² (α = ψ cos φ + θ sin φ with ψ, θ independent of variance σ_α²
    /// each has variance σ_α²).
    pub fn d_alpha(&self) -> f64 {
        self.sigma_alpha().powi(2)
    }
    /// Mean time to pass one quantization step T_c = δ/V_c (s).
    pub fn t_c(&self) -> f64 {
        self.delta / self.v_c
    }
    /// Quantization frequency γ_q = 2π/T_c (rad/s).
    pub fn gamma_q(&self) -> f64 {
        2.0 * PI / self.t_c()
    }
    /// ξ = 1/T_a (1/s).
    pub fn xi(&self) -> f64 {
        1.0 / self.t_a
    }
    /// Tilt toward the sensor α = ψ·cos φ + θ·sin φ (the paper's eq. 7–8).
    pub fn tilt_toward_sensor(&self, pitch_psi: f64, roll_theta: f64) -> f64 {
        pitch_psi * self.phi.cos() + roll_theta * self.phi.sin()
    }

    /// The coefficients of the paper's discrete model at these parameters.
    ///
    /// # Errors
    /// As [`FuelParams::validate`].
    pub fn paper_coefficients(&self) -> Result<PaperCoefficients> {
        self.validate()?;
        let dt = self.dt;
        let (ta, ty) = (self.t_a, self.t_y);
        let (mu, beta) = (self.mu, self.beta());
        let (xi, gq) = (self.xi(), self.gamma_q());
        let a = 2.0 * mu / (mu * mu + beta * beta);
        let b = 1.0 / (mu * mu + beta * beta);
        let c = 2.0 * xi / (xi * xi + gq * gq);
        let d = 1.0 / (xi * xi + gq * gq);
        let n1 = 1.0 + 2.0 * a / dt + 4.0 * b / (dt * dt);
        let n2 = 1.0 + 2.0 * c / dt + 4.0 * d / (dt * dt);
        Ok(PaperCoefficients {
            p_a: (ta - dt / 2.0) / (ta + dt / 2.0),
            k_a: ta * dt / (ta + dt / 2.0).powi(2),
            g_a: dt / (2.0 * (ta + dt / 2.0)),
            q_y: (ty - dt / 2.0) / (ty + dt / 2.0),
            k_y: ty * dt / (ty + dt / 2.0).powi(2),
            g_y: dt / (2.0 * (ty + dt / 2.0)),
            a,
            b,
            c,
            d,
            n1,
            a1: (2.0 - 8.0 * b / (dt * dt)) / n1,
            a2: (1.0 - 2.0 * a / dt + 4.0 * b / (dt * dt)) / n1,
            b1: 2.0 / n1,
            b2: 2.0 / n1,
            n2,
            c1: (2.0 - 8.0 * d / (dt * dt)) / n2,
            c2: (1.0 - 2.0 * c / dt + 4.0 * d / (dt * dt)) / n2,
            d0: (2.0 + 4.0 * d.sqrt() / dt) / n2,
            d1: (2.0 - 4.0 * d.sqrt() / dt) / n2,
        })
    }

    /// The white-noise intensities (N₁, N₂, N₃) of the three shaping filters, in the units
    /// of their outputs: velocity `2T_aD_c`, tilt deviation R·α `2aD_αR²`, quantization
    /// `δ²c/12`.
    ///
    /// # Errors
    /// As [`FuelParams::validate`].
    pub fn intensities(&self) -> Result<[f64; 3]> {
        let k = self.paper_coefficients()?;
        Ok([
            2.0 * self.t_a * self.d_c,
            2.0 * k.a * self.d_alpha() * self.sensor_radius.powi(2),
            self.delta.powi(2) * k.c / 12.0,
        ])
    }

    /// The five continuous blocks: velocity `1/(T_a s+1)`, integrator `1/s`, rolling
    /// `1/(b s²+a s+1)`, damper `1/(T_y s+1)`, quantization `(1+√d s)/(d s²+c s+1)`.
    ///
    /// # Errors
    /// As [`FuelParams::validate`].
    pub fn blocks(&self) -> Result<[ContinuousTf; 5]> {
        let k = self.paper_coefficients()?;
        Ok([
            ContinuousTf::new(vec![1.0], vec![1.0, self.t_a])?,
            ContinuousTf::new(vec![1.0], vec![0.0, 1.0])?,
            ContinuousTf::new(vec![1.0], vec![1.0, k.a, k.b])?,
            ContinuousTf::new(vec![1.0], vec![1.0, self.t_y])?,
            ContinuousTf::new(vec![1.0, k.d.sqrt()], vec![1.0, k.c, k.d])?,
        ])
    }

    /// Builds the discrete model (see [`FuelModel`]).
    ///
    /// # Errors
    /// As [`FuelParams::validate`]; [`crate::Error::NonFiniteMatrix`] if extreme parameters
    /// overflow.
    pub fn build(&self, channels: Channels, realisation: Realisation) -> Result<FuelModel> {
        let blocks = self.blocks()?;
        let w = wiring();
        let (a, bfull, hfull, dfull) = match realisation {
            Realisation::Paper | Realisation::ExactTustin => {
                let variants = realisation.tustin_variants();
                let mut ds: Vec<DiscreteSs> = Vec::with_capacity(5);
                for (tf, v) in blocks.iter().zip(variants) {
                    let dtf = match v {
                        Some(v) => tf.paper_tustin(self.dt, v)?,
                        None => tf.tustin(self.dt, None)?,
                    };
                    ds.push(dtf.realize());
                }
                let refs: Vec<&DiscreteSs> = ds.iter().collect();
                let sys = connect(&refs, &w.k, &w.e, &w.p, &w.qd)?;
                (
                    sys.f().clone(),
                    sys.b().clone(),
                    sys.h().clone(),
                    sys.d().clone(),
                )
            }
            Realisation::Zoh => {
                let cs: Vec<ContinuousSs> = blocks.iter().map(ContinuousTf::realize).collect();
                let refs: Vec<&ContinuousSs> = cs.iter().collect();
                let sys = connect_continuous(&refs, &w.k, &w.e, &w.p, &w.qd)?;
                let (phi, gamma) = zoh(sys.a(), sys.b(), self.dt)?;
                (phi, gamma, sys.c().clone(), sys.d().clone())
            }
        };
        let b = bfull.columns(0, 3).into_owned();
        // Column 3 of the wiring is the known mean fill rate, entering at the integrator.
        // Through a Tustin integrator that column is e2 plus the half-step feed-through
        // Δt/2 into the damper (and Δt/2·V_c into the outputs); that constant part is the
        // same as starting x2 higher by V_c/2, so the paper's form `x2 += V_c` is exact up to
        // the initial state and is what we use.
        let known_input = match realisation {
            Realisation::Zoh => bfull.column(3) * self.v_c,
            _ => {
                let mut v = DVector::zeros(7);
                v[1] = self.v_c;
                v
            }
        };
        let g = hfull.rows(0, 5).into_owned();
        let g_feedthrough = dfull.view((0, 0), (5, 3)).into_owned();
        let (c, d) = match channels {
            Channels::LevelAndTilt => (
                hfull.rows(5, 2).into_owned(),
                dfull.view((5, 0), (2, 3)).into_owned(),
            ),
            Channels::LevelOnly => (
                hfull.rows(6, 1).into_owned(),
                dfull.view((6, 0), (1, 3)).into_owned(),
            ),
        };
        let [n1, n2, n3] = self.intensities()?;
        let q = DMatrix::from_diagonal(&DVector::from_vec(vec![n1, n2, n3])) / self.dt;
        let mut r = validate::symmetrize(&(&d * &q * d.transpose()));
        if channels == Channels::LevelAndTilt {
            r[(0, 0)] += self.sensor_radius.powi(2) * self.gyro_noise_var;
        }
        let s = &b * &q * d.transpose();
        let process_covariance = validate::symmetrize(&(&b * &q * b.transpose()));
        for (name, m) in [("A", &a), ("B", &b), ("C", &c), ("Q", &q), ("R", &r)] {
            validate::finite(name, m)?;
        }
        Ok(FuelModel {
            params: *self,
            channels,
            realisation,
            a,
            b,
            c,
            d,
            g,
            g_feedthrough,
            q,
            r,
            s,
            process_covariance,
            known_input,
        })
    }
}

struct Wiring {
    k: DMatrix<f64>,
    e: DMatrix<f64>,
    p: DMatrix<f64>,
    qd: DMatrix<f64>,
}

/// Block order: 0 velocity, 1 integrator, 2 rolling, 3 damper, 4 quantization.
/// External inputs: u1, u2, u3 (noise), 3 = known mean fill rate (into the integrator).
/// Outputs: y1…y5, z1, z2.
fn wiring() -> Wiring {
    let mut k = DMatrix::zeros(5, 5);
    k[(1, 0)] = 1.0; // integrator ← velocity fluctuation
    k[(3, 1)] = 1.0; // damper ← level …
    k[(3, 2)] = 1.0; // … + tilt deviation R·α
    let mut e = DMatrix::zeros(5, 4);
    e[(0, 0)] = 1.0; // velocity filter ← u1
    e[(2, 1)] = 1.0; // rolling filter ← u2
    e[(4, 2)] = 1.0; // quantization filter ← u3
    e[(1, 3)] = 1.0; // integrator ← mean fill rate
    let mut p = DMatrix::zeros(7, 5);
    p[(0, 0)] = 1.0; // y1 velocity fluctuation
    p[(1, 1)] = 1.0; // y2 level
    p[(2, 2)] = 1.0; // y3 R·α
    p[(3, 1)] = 1.0; // y4 = y2 + y3
    p[(3, 2)] = 1.0;
    p[(4, 3)] = 1.0; // y5 damper
    p[(5, 2)] = 1.0; // z1 tilt channel
    p[(6, 3)] = 1.0; // z2 = damper + quantization noise
    p[(6, 4)] = 1.0;
    Wiring {
        k,
        e,
        p,
        qd: DMatrix::zeros(7, 4),
    }
}

impl FuelModel {
    /// Number of measurements m (1 or 2).
    pub fn n_measurements(&self) -> usize {
        self.c.nrows()
    }

    /// Spectral density of each measurement's random part at the Nyquist frequency
    /// (ω = π per sample, z = −1), in units of variance: `Φ(ω)` normalised so that
    /// `var = (1/2π)∫_{−π}^{π} Φ(ω) dω`, i.e. a white sequence of variance σ² has `Φ ≡ σ²`.
    /// It is the diagonal of `T Q Tᵀ` with `T = C(−I − A)⁻¹B + D` (real at z = −1), plus the
    /// gyro noise `R²·gyro_noise_var` on the tilt channel.
    ///
    /// A zero entry means the model holds that channel's alternating component exactly
    /// predictable, which makes a filter that uses [`FuelModel::s`] marginally stable at
    /// Nyquist (see [`Realisation::ExactTustin`]).
    ///
    /// # Errors
    /// [`crate::Error::Singular`] if A has an eigenvalue at −1 (no realisation built here
    /// has: all poles are those of the stable blocks and the integrator's +1).
    pub fn nyquist_measurement_power(&self) -> Result<DVector<f64>> {
        let n = self.a.nrows();
        let z_minus_a = -DMatrix::<f64>::identity(n, n) - &self.a;
        let x = z_minus_a
            .lu()
            .solve(&self.b)
            .ok_or(crate::Error::Singular {
                name: "−I − A",
                context: "transfer from the noise u to z at z = −1 (A has an eigenvalue −1)",
            })?;
        let t = &self.c * x + &self.d;
        let mut power = (&t * &self.q * t.transpose()).diagonal();
        if self.channels == Channels::LevelAndTilt {
            power[0] += self.params.sensor_radius.powi(2) * self.params.gyro_noise_var;
        }
        Ok(power)
    }

    /// The model as a [`DiscreteSs`]: `F = A`, one control input `u ≡ 1` through
    /// `B = known_input`, `H = C`, noise `G = B`, `J = D`, `Q = Q`. (The gyro noise part of R
    /// has no slot there.)
    ///
    /// # Errors
    /// Only if the model was edited into an invalid state.
    pub fn to_discrete_ss(&self) -> Result<DiscreteSs> {
        let m = self.c.nrows();
        DiscreteSs::new(
            self.a.clone(),
            DMatrix::from_column_slice(7, 1, self.known_input.as_slice()),
            self.c.clone(),
            DMatrix::zeros(m, 1),
            self.params.dt,
        )?
        .with_noise(self.b.clone(), self.d.clone(), self.q.clone())
    }
}

/// Serde for a `DVector` as a plain list of numbers (nalgebra's own format writes the
/// static column count as a unit value, which TOML cannot hold).
mod vector_as_list {
    use nalgebra::DVector;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub(super) fn serialize<S: Serializer>(v: &DVector<f64>, s: S) -> Result<S::Ok, S::Error> {
        v.as_slice().serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<DVector<f64>, D::Error> {
        Ok(DVector::from_vec(Vec::<f64>::deserialize(d)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_as_documented() {
        let p = FuelParams::default();
        assert!(p.validate().is_ok());
        assert!((p.beta() - 2.0 * PI / 10.0).abs() < 1e-15);
        assert!((p.t_c() - 1.0).abs() < 1e-15, "T_c = δ/V_c = 1 s");
        assert!((p.sigma_alpha() - 1f64.to_radians() / 3.0).abs() < 1e-18);
    }

    #[test]
    fn only_exact_tustin_has_no_measurement_power_at_nyquist() {
        // The reported failure of the two-channel filter with S in the exact-Tustin
        // realisation: its z spectrum vanishes at z = −1 on both channels. The scale is the
        // quantization noise variance δ²/12 (≈ 8e-6 m²); the paper's z2 has ≈ 2e-8 m² at
        // Nyquist (ratio ≈ 2.5e-3), ZOH about the same, exact Tustin ≈ 1e-44 m² (round-off).
        // 1e-9 of the scale separates the two by six orders of magnitude either way.
        for amplitude_deg in [0.0, 1.0] {
            let p = FuelParams {
                max_tilt_amplitude: f64::to_radians(amplitude_deg),
                ..FuelParams::default()
            };
            let scale = p.delta.powi(2) / 12.0;
            let z2 = |r: Realisation| {
                let m = p.build(Channels::LevelAndTilt, r).expect("model");
                let power = m.nyquist_measurement_power().expect("A has no pole at −1");
                assert!(power.iter().all(|v| *v >= 0.0), "{r:?}: {power}");
                (power[0] / scale, power[1] / scale)
            };
            let (tilt, level) = z2(Realisation::ExactTustin);
            assert!(
                tilt < 1e-9 && level < 1e-9,
                "exact Tustin: {tilt:e}, {level:e}"
            );
            for r in [Realisation::Paper, Realisation::Zoh] {
                let (_, level) = z2(r);
                assert!(level > 1e-4, "{r:?} level channel at Nyquist: {level:e}");
            }
        }
    }

    #[test]
    fn wiring_shapes() {
        let w = wiring();
        assert_eq!(w.k.shape(), (5, 5));
        assert_eq!(w.e.shape(), (5, 4));
        assert_eq!(w.p.shape(), (7, 5));
        // No block feeds itself: no algebraic self-loop.
        for i in 0..5 {
            assert!(w.k[(i, i)].abs() < 1e-300);
        }
    }
}
