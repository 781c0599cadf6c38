//! Particle filters (feature `particle`): bootstrap and auxiliary sequential importance
//! resampling over a user's transition and likelihood ([`ParticleModel`], any noise),
//! log-weights throughout, four resampling schemes ([`Resampling`]) under an
//! effective-sample-size trigger ([`Trigger`]), an unbiased likelihood estimate, and the
//! forward-filtering backward-simulation smoother ([`ffbsi`]).
//!
//! # The recursion
//! The model is `x_0 ~ p(x_0)`, `x_{k+1} ~ f_k(· | x_k)`, `z_k ~ g_k(· | x_k)`; the filter holds
//! N particles `x_k^i` with normalised log-weights `ln W_k^i` targeting `p(x_k | z_{0:k})`. As
//! in the Kalman filters of this crate, [`ParticleFilter::new`] draws the prior of the first
//! measurement and step `k` ([`ParticleFilter::step`]) brings the particles from `k − 1` to `k`
//! and weights them by `z_k`:
//!
//! 1. first-stage weights `v^i = ln W_{k−1}^i + ln g_k(z_k | μ^i)`, with `μ^i` the model's
//!    [`lookahead`](ParticleModel::lookahead) point of `x_k` given `x_{k−1}^i` for the
//!    auxiliary filter (Pitt and Shephard) and `ln g = 0` for the bootstrap filter; `c = Σ e^{v^i}`,
//!    `V^i = e^{v^i}/c`;
//! 2. if the trigger fires on the effective sample size `1/Σ (V^i)²`, ancestors `a_j` are
//!    drawn from `V` and the base weights are `1/N`; otherwise `a_j = j` and the base weights
//!    are `V^j`;
//! 3. `x_k^j ~ f_{k−1}(· | x_{k−1}^{a_j})`;
//! 4. `ln w^j = ln base^j + ln g_k(z_k | x_k^j) − ln g_k(z_k | μ^{a_j})`, normalised to `ln W_k`.
//!
//! The likelihood increment `p̂(z_k | z_{0:k−1}) = c · Σ_j base^j g_k(z_k | x_k^j) / g_k(z_k | μ^{a_j})`
//! (the base weights sum to 1) is accumulated in [`ParticleFilter::log_likelihood`]; its exponential is an unbiased
//! estimate of `p(z_{0:k})` for every scheme and trigger (Del Moral, *Feynman–Kac
//! formulae*, 2004). Step 0 has no propagation. A measurement whose entries are all NaN (or
//! an empty one) is skipped: the step only propagates.
//!
//! # Random numbers and threads
//! Every draw comes from a ChaCha8 stream ([`ParticleRng`]) derived from `(seed, purpose,
//! step, block)` alone, where a block is a fixed run of [`BLOCK`] consecutive particles.
//! With the feature `parallel` the blocks are propagated and weighted on rayon's threads;
//! reductions (normalisation, the estimate, the mean) run in particle order on one thread.
//! So a seed gives the same particles, weights and estimates, bit for bit, for any number of
//! threads, with or without `parallel`.
//!
//! # Example
//! A random walk observed in Student-t noise (not a Gaussian filter's territory):
//! ```
//! use kalman::particle::{ParticleFilter, ParticleModel, ParticleOptions, ParticleRng};
//! use kalman::particle::rand::RngExt;
//!
//! struct Walk;
//! impl ParticleModel for Walk {
//!     fn state_dim(&self) -> usize { 1 }
//!     fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]) {
//!         x[0] = 4.0 * (rng.random::<f64>() - 0.5);
//!     }
//!     fn sample_transition(&self, _k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]) {
//!         // A uniform step of variance 0.01.
//!         next[0] = x[0] + 0.2 * 3f64.sqrt() * (rng.random::<f64>() - 0.5);
//!     }
//!     fn log_likelihood(&self, _k: usize, x: &[f64], z: &[f64]) -> f64 {
//!         // Student-t with 3 degrees of freedom, scale 0.1 (constant terms dropped).
//!         let e = (z[0] - x[0]) / 0.1;
//!         -2.0 * (1.0 + e * e / 3.0).ln()
//!     }
//! }
//! # fn main() -> Result<(), kalman::Error> {
//! let options = ParticleOptions { particles: 500, seed: 7, ..ParticleOptions::default() };
//! let mut pf = ParticleFilter::new(Walk, options)?;
//! for z in [1.02, 0.97, 5.0 /* an outlier */, 1.05, 0.99] {
//!     pf.step(&[z])?;
//! }
//! assert!((pf.mean()[0] - 1.0).abs() < 0.2);
//! # Ok(())
//! # }
//! ```
//!
//! # References
//! - N. J. Gordon, D. J. Salmond, A. F. M. Smith, *Novel approach to nonlinear/non-Gaussian
//!   Bayesian state estimation*, 1993 (the bootstrap filter).
//! - M. K. Pitt, N. Shephard, *Filtering via simulation: auxiliary particle filters*, 1999.
//! - A. Doucet, A. M. Johansen, *A tutorial on particle filtering and smoothing: fifteen
//!   years later*, 2009 (the general recursion, the likelihood estimate, adaptive resampling).
//! - S. J. Godsill, A. Doucet, M. West, *Monte Carlo smoothing for nonlinear time series*,
//!   2004 ([`ffbsi`]).

mod filter;
mod propagate;
mod resample;
mod smoother;

pub use filter::{ParticleFilter, ParticleHistory};
#[doc(hidden)]
pub use propagate::Generation;
pub use propagate::{PopulationModel, Propagate, Vectorised};
pub use resample::{Resampling, effective_sample_size};
pub use smoother::{ParticleSmoothed, ffbsi};

/// Re-export of the rand version [`ParticleRng`] implements (`kalman::particle::rand::RngExt`
/// for `rng.random::<f64>()` and `rng.sample(…)` with rand_distr's distributions).
pub use rand;

use serde::{Deserialize, Serialize};

use crate::Error;

/// The random number generator every model function draws from.
pub type ParticleRng = rand_chacha::ChaCha8Rng;

/// Particles per block, the unit of the random streams and of the work on threads (fixed,
/// so the draws do not depend on the thread count).
pub const BLOCK: usize = 64;

/// A state-space model for the particle filters: a prior and a transition to draw from, and
/// a measurement log-likelihood to weight by; optionally the transition's log-density (for
/// [`ffbsi`]) and a look-ahead point (for [`Proposal::Auxiliary`]).
///
/// The functions are called from several threads at once with the feature `parallel`
/// (hence `Sync`); they must draw only from the `rng` they are given, so that the results are
/// reproducible. A log-likelihood may be −∞ (an impossible measurement: a quantizer's
/// interval the state is not in); NaN or +∞ is an error. For
/// [`ParticleFilter::log_likelihood`] to be the model's log-likelihood, `log_likelihood`
/// must be the full log-density, constants included; the filter itself needs it only up to a
/// constant.
///
/// ```
/// use kalman::particle::{ParticleModel, ParticleRng};
/// use kalman::particle::rand::RngExt;
///
/// /// x_{k+1} = 0.9 x_k + w, w uniform on [−0.5, 0.5); z = x + Laplace noise of scale 0.2.
/// struct Ar1;
/// impl ParticleModel for Ar1 {
///     fn state_dim(&self) -> usize { 1 }
///     fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]) {
///         x[0] = 2.0 * rng.random::<f64>() - 1.0;
///     }
///     fn sample_transition(&self, _k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]) {
///         next[0] = 0.9 * x[0] + rng.random::<f64>() - 0.5;
///     }
///     fn log_likelihood(&self, _k: usize, x: &[f64], z: &[f64]) -> f64 {
///         -(z[0] - x[0]).abs() / 0.2 - 0.4f64.ln()
///     }
///     fn log_transition_density(&self, _k: usize, x: &[f64], next: &[f64]) -> Option<f64> {
///         Some(if (next[0] - 0.9 * x[0]).abs() <= 0.5 { 0.0 } else { f64::NEG_INFINITY })
///     }
///     fn lookahead(&self, _k: usize, x: &[f64], point: &mut [f64]) -> bool {
///         point[0] = 0.9 * x[0]; // the transition's mean
///         true
///     }
/// }
/// assert!((Ar1.log_likelihood(0, &[1.0], &[1.0]) + 0.4f64.ln()).abs() < 1e-15);
/// ```
pub trait ParticleModel: Sync {
    /// n, the state dimension (at least 1).
    fn state_dim(&self) -> usize;

    /// Draws `x_0` from the prior of the first measurement into `x` (length n).
    fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]);

    /// Draws `x_{k+1} ~ f_k(· | x_k = x)` into `next` (length n).
    fn sample_transition(&self, k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]);

    /// `ln g_k(z | x_k = x)`.
    fn log_likelihood(&self, k: usize, x: &[f64], z: &[f64]) -> f64;

    /// `ln f_k(next | x_k = x)`, the transition's log-density (constants may be dropped);
    /// `None` (the default) when the model has none, which [`ffbsi`] refuses.
    fn log_transition_density(&self, k: usize, x: &[f64], next: &[f64]) -> Option<f64> {
        let _ = (k, x, next);
        None
    }

    /// Writes into `point` a look-ahead point of `x_{k+1}` given `x_k = x` (typically the
    /// transition's mean or mode) and returns `true`; the default returns `false`, which
    /// [`Proposal::Auxiliary`] refuses.
    fn lookahead(&self, k: usize, x: &[f64], point: &mut [f64]) -> bool {
        let _ = (k, x, point);
        false
    }
}

/// When a step resamples.
///
/// ```
/// use kalman::particle::{ParticleFilter, ParticleOptions, Trigger};
/// # use kalman::particle::{ParticleModel, ParticleRng};
/// # use kalman::particle::rand::RngExt;
/// # struct Walk;
/// # impl ParticleModel for Walk {
/// #     fn state_dim(&self) -> usize { 1 }
/// #     fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]) { x[0] = rng.random::<f64>() - 0.5; }
/// #     fn sample_transition(&self, _k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]) {
/// #         next[0] = x[0] + 0.1 * (rng.random::<f64>() - 0.5);
/// #     }
/// #     fn log_likelihood(&self, _k: usize, x: &[f64], z: &[f64]) -> f64 { -50.0 * (z[0] - x[0]).powi(2) }
/// #     fn log_transition_density(&self, _k: usize, x: &[f64], next: &[f64]) -> Option<f64> {
/// #         Some(if (next[0] - x[0]).abs() < 0.05 { 0.0 } else { f64::NEG_INFINITY })
/// #     }
/// # }
/// # fn main() -> Result<(), kalman::Error> {
/// for (trigger, resamples) in [(Trigger::Always, true), (Trigger::Never, false)] {
///     let mut pf = ParticleFilter::new(Walk, ParticleOptions { particles: 100, trigger, ..Default::default() })?;
///     pf.step(&[0.1])?;
///     pf.step(&[0.2])?; // resampling happens before propagating, from the second step
///     assert_eq!(pf.resampled(), resamples);
/// }
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Trigger {
    /// At every step (the classic bootstrap filter).
    Always,
    /// When the effective sample size falls below this fraction of N (in (0, 1]).
    EssBelow(f64),
    /// Never (sequential importance sampling; the weights degenerate).
    Never,
}

impl Default for Trigger {
    fn default() -> Self {
        Self::EssBelow(0.5)
    }
}

/// The proposal of each step.
///
/// ```
/// use kalman::particle::{ParticleFilter, ParticleOptions, Proposal};
/// # use kalman::particle::{ParticleModel, ParticleRng};
/// # use kalman::particle::rand::RngExt;
/// # struct Walk;
/// # impl ParticleModel for Walk {
/// #     fn state_dim(&self) -> usize { 1 }
/// #     fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]) { x[0] = rng.random::<f64>() - 0.5; }
/// #     fn sample_transition(&self, _k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]) {
/// #         next[0] = x[0] + 0.1 * (rng.random::<f64>() - 0.5);
/// #     }
/// #     fn log_likelihood(&self, _k: usize, x: &[f64], z: &[f64]) -> f64 { -50.0 * (z[0] - x[0]).powi(2) }
/// #     fn log_transition_density(&self, _k: usize, x: &[f64], next: &[f64]) -> Option<f64> {
/// #         Some(if (next[0] - x[0]).abs() < 0.05 { 0.0 } else { f64::NEG_INFINITY })
/// #     }
/// # }
/// # fn main() -> Result<(), kalman::Error> {
/// // This model has no look-ahead point: the auxiliary filter says so at its first propagation.
/// let options = ParticleOptions { particles: 100, proposal: Proposal::Auxiliary, ..Default::default() };
/// let mut pf = ParticleFilter::new(Walk, options)?;
/// pf.step(&[0.1])?;
/// assert!(matches!(pf.step(&[0.2]), Err(kalman::Error::MissingFunction { function: "lookahead", .. })));
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Proposal {
    /// Propagate by the transition, weight by the likelihood (Gordon, Salmond and Smith).
    #[default]
    Bootstrap,
    /// Reweight by the likelihood at the model's look-ahead point before resampling and
    /// propagating (Pitt and Shephard); needs [`ParticleModel::lookahead`].
    Auxiliary,
}

/// Whether the filter keeps every step's particles and weights for [`ffbsi`].
///
/// ```
/// use kalman::particle::{History, ParticleFilter, ParticleOptions};
/// # use kalman::particle::{ParticleModel, ParticleRng};
/// # use kalman::particle::rand::RngExt;
/// # struct Walk;
/// # impl ParticleModel for Walk {
/// #     fn state_dim(&self) -> usize { 1 }
/// #     fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]) { x[0] = rng.random::<f64>() - 0.5; }
/// #     fn sample_transition(&self, _k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]) {
/// #         next[0] = x[0] + 0.1 * (rng.random::<f64>() - 0.5);
/// #     }
/// #     fn log_likelihood(&self, _k: usize, x: &[f64], z: &[f64]) -> f64 { -50.0 * (z[0] - x[0]).powi(2) }
/// #     fn log_transition_density(&self, _k: usize, x: &[f64], next: &[f64]) -> Option<f64> {
/// #         Some(if (next[0] - x[0]).abs() < 0.05 { 0.0 } else { f64::NEG_INFINITY })
/// #     }
/// # }
/// # fn main() -> Result<(), kalman::Error> {
/// let options = ParticleOptions { particles: 100, history: History::Keep, ..Default::default() };
/// let mut pf = ParticleFilter::new(Walk, options)?;
/// for z in [0.1, 0.2, 0.15] {
///     pf.step(&[z])?;
/// }
/// assert_eq!(pf.history().map(|h| h.steps()), Some(3));
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum History {
    /// Keep only the current step.
    #[default]
    Discard,
    /// Keep all steps (N·n + N numbers per step) in a [`ParticleHistory`].
    Keep,
}

/// The options of a [`ParticleFilter`].
///
/// ```
/// use kalman::particle::{ParticleOptions, Resampling, Trigger};
/// let options = ParticleOptions { particles: 5000, seed: 3, ..ParticleOptions::default() };
/// assert_eq!(options.resampling, Resampling::Systematic);
/// assert_eq!(options.trigger, Trigger::EssBelow(0.5));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParticleOptions {
    /// N, the number of particles (at least 1).
    pub particles: usize,
    /// The resampling scheme.
    pub resampling: Resampling,
    /// When to resample.
    pub trigger: Trigger,
    /// Bootstrap or auxiliary.
    pub proposal: Proposal,
    /// The seed of every random stream.
    pub seed: u64,
    /// Whether to keep the history for the smoother.
    pub history: History,
}

impl Default for ParticleOptions {
    /// 1000 particles, systematic resampling when the ESS falls below N/2, bootstrap, seed 0,
    /// no history.
    fn default() -> Self {
        Self {
            particles: 1000,
            resampling: Resampling::Systematic,
            trigger: Trigger::default(),
            proposal: Proposal::Bootstrap,
            seed: 0,
            history: History::Discard,
        }
    }
}

impl ParticleOptions {
    /// Checks the options.
    fn check(&self) -> Result<(), Error> {
        if self.particles == 0 {
            return Err(Error::Dimension {
                name: "particles",
                value: 0,
                rule: "a particle filter needs at least one particle",
            });
        }
        if let Trigger::EssBelow(f) = self.trigger {
            if !(f > 0.0 && f <= 1.0) {
                return Err(Error::InvalidOption {
                    name: "Trigger::EssBelow",
                    value: f,
                    rule: "the fraction of N must be in (0, 1]",
                });
            }
        }
        Ok(())
    }
}

/// What a random stream is for (part of its derivation).
#[derive(Clone, Copy)]
#[repr(u64)]
enum Purpose {
    Initial = 1,
    Propagate = 2,
    Resample = 3,
    Smooth = 4,
}

/// SplitMix64's finaliser: a bijective mix of 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The stream of `(seed, purpose, step, index)`.
fn stream(seed: u64, purpose: Purpose, step: usize, index: usize) -> ParticleRng {
    use rand::SeedableRng;
    let h = mix(mix(mix(mix(seed) ^ purpose as u64) ^ step as u64) ^ index as u64);
    ParticleRng::seed_from_u64(h)
}
