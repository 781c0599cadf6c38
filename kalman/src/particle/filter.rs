//! The particle filter: its buffers, its step (first stage, resampling, propagation,
//! weighting), its estimates and its recorded history.

use faer::Mat;
use rand::RngExt;

use super::propagate::Generation;
use super::resample::{deterministic_copies, normalise};
use super::{History, ParticleOptions, Propagate, Proposal, Purpose, Resampling, Trigger, stream};
use crate::Error;

/// A bootstrap or auxiliary particle filter over a [`super::ParticleModel`] (or a
/// [`super::PopulationModel`] through [`super::Vectorised`]; see the
/// [module documentation](super) for the recursion, the likelihood estimate and the random
/// streams).
///
/// The particles are stored row by row (`particles()[j·n + i]` is entry i of particle j),
/// with normalised log-weights. A step that fails leaves the filter as it was.
///
/// ```
/// use kalman::particle::{ParticleFilter, ParticleOptions};
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
/// let mut pf = ParticleFilter::new(Walk, ParticleOptions { particles: 500, ..Default::default() })?;
/// for z in [0.1, 0.12, f64::NAN, 0.15] {
///     pf.step(&[z])?; // NaN: no measurement, the particles only move
/// }
/// let total: f64 = pf.log_weights().iter().map(|l| l.exp()).sum();
/// assert!((total - 1.0).abs() < 1e-12);
/// assert!((pf.mean()[0] - 0.13).abs() < 0.1 && pf.covariance()[(0, 0)] > 0.0);
/// assert!(pf.ess() <= 500.0 && pf.log_likelihood().is_finite());
/// # Ok(())
/// # }
/// ```
pub struct ParticleFilter<M: Propagate> {
    model: M,
    options: ParticleOptions,
    n: usize,
    /// x_k, N × n row-major.
    particles: Vec<f64>,
    /// The propagated particles before they are accepted.
    next: Vec<f64>,
    /// Normalised ln W_k.
    log_w: Vec<f64>,
    /// The step's new log-weights (and the first-stage weights before them).
    work: Vec<f64>,
    /// ln g_k(z_k | μ^i) per ancestor (0 for the bootstrap filter).
    first: Vec<f64>,
    /// ln base^j.
    base: Vec<f64>,
    /// The look-ahead points, N × n.
    points: Vec<f64>,
    ancestors: Vec<usize>,
    /// The normalised weights W_k = exp(ln W_k).
    weights: Vec<f64>,
    /// The first-stage weights V, then the new weights before they are accepted.
    linear: Vec<f64>,
    cumulative: Vec<f64>,
    uniforms: Vec<f64>,
    mean: Vec<f64>,
    steps: usize,
    log_likelihood: f64,
    ess: f64,
    resampled: bool,
    history: Option<ParticleHistory>,
}

impl<M: Propagate> std::fmt::Debug for ParticleFilter<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParticleFilter")
            .field("n", &self.n)
            .field("options", &self.options)
            .field("steps", &self.steps)
            .field("log_likelihood", &self.log_likelihood)
            .field("ess", &self.ess)
            .finish_non_exhaustive()
    }
}

/// Every step's particles and normalised log-weights (after the step's update: the
/// filtering distributions `p(x_k | z_{0:k})`), kept with [`History::Keep`] for [`super::ffbsi`].
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
/// pf.step(&[0.1])?;
/// pf.step(&[0.2])?;
/// let h = pf.history().expect("kept");
/// assert_eq!((h.steps(), h.count(), h.state_dim()), (2, 100, 1));
/// assert_eq!(h.particles(1), Some(pf.particles()));
/// assert!(h.log_weights(2).is_none());
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleHistory {
    pub(super) n: usize,
    pub(super) count: usize,
    pub(super) particles: Vec<f64>,
    pub(super) log_weights: Vec<f64>,
}

impl ParticleHistory {
    /// n, the state dimension.
    pub fn state_dim(&self) -> usize {
        self.n
    }

    /// N, the number of particles per step.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The number of steps recorded.
    pub fn steps(&self) -> usize {
        self.log_weights.len() / self.count
    }

    /// The particles of step `k`, N × n row-major (`None` past the last step).
    pub fn particles(&self, k: usize) -> Option<&[f64]> {
        let len = self.count * self.n;
        self.particles.get(k * len..(k + 1) * len)
    }

    /// The normalised log-weights of step `k` (`None` past the last step).
    pub fn log_weights(&self, k: usize) -> Option<&[f64]> {
        self.log_weights.get(k * self.count..(k + 1) * self.count)
    }
}

/// The first NaN or +∞ log-weight, as the model's error.
fn check_log(values: &[f64], function: &'static str, step: usize) -> Result<(), Error> {
    match values
        .iter()
        .position(|v| v.is_nan() || *v == f64::INFINITY)
    {
        Some(index) => Err(Error::ModelNonFinite {
            function,
            step,
            index,
        }),
        None => Ok(()),
    }
}

/// The first particle with a non-finite entry.
fn check_states(
    states: &[f64],
    n: usize,
    function: &'static str,
    step: usize,
) -> Result<(), Error> {
    match states.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(Error::ModelNonFinite {
            function,
            step,
            index: i / n,
        }),
        None => Ok(()),
    }
}

impl<M: Propagate> ParticleFilter<M> {
    /// Draws N particles from the model's prior, with equal weights.
    ///
    /// # Errors
    /// [`Error::Dimension`] for n = 0 or N = 0, [`Error::InvalidOption`] for an ESS fraction
    /// outside (0, 1], [`Error::ModelNonFinite`] (function `"sample_initial"`, index the
    /// particle) for a prior draw that is not finite.
    pub fn new(mut model: M, options: ParticleOptions) -> Result<Self, Error> {
        options.check()?;
        let n = model.state_dim();
        if n == 0 {
            return Err(Error::Dimension {
                name: "n",
                value: 0,
                rule: "the particle model's state needs at least one entry",
            });
        }
        let count = options.particles;
        let mut particles = vec![0.0; count * n];
        let mut work = vec![0.0; count];
        model.draw_initial(options.seed, &mut particles, &mut work);
        check_states(&particles, n, "sample_initial", 0)?;
        let ln_n = (count as f64).ln();
        let mut filter = Self {
            model,
            options,
            n,
            next: vec![0.0; count * n],
            log_w: vec![-ln_n; count],
            work,
            first: vec![0.0; count],
            base: vec![-ln_n; count],
            points: Vec::new(),
            ancestors: (0..count).collect(),
            weights: vec![1.0 / count as f64; count],
            linear: vec![0.0; count],
            cumulative: vec![0.0; count],
            uniforms: vec![0.0; count],
            mean: vec![0.0; n],
            steps: 0,
            log_likelihood: 0.0,
            ess: count as f64,
            resampled: false,
            history: (options.history == History::Keep).then(|| ParticleHistory {
                n,
                count,
                particles: Vec::new(),
                log_weights: Vec::new(),
            }),
            particles,
        };
        filter.update_mean();
        Ok(filter)
    }

    /// Step k: brings the particles to k (after the first step) and weights them by `z_k`
    /// (all NaN or empty: no measurement). See the [module documentation](super).
    ///
    /// # Errors
    /// [`Error::ModelNonFinite`] naming the step and the particle when a drawn state is not
    /// finite (`"sample_transition"`) or a log-likelihood is NaN or +∞ (`"log_likelihood"`,
    /// `"log_likelihood at the look-ahead point"`); [`Error::ParticleCollapse`] when every
    /// particle's likelihood (or look-ahead likelihood) is zero; [`Error::MissingFunction`]
    /// for the auxiliary filter over a model without [`super::ParticleModel::lookahead`]. The
    /// filter is then as it was before the step.
    pub fn step(&mut self, z: &[f64]) -> Result<(), Error> {
        let k = self.steps;
        let count = self.options.particles;
        let n = self.n;
        let seed = self.options.seed;
        let present = z.iter().any(|v| !v.is_nan());
        let ln_n = (count as f64).ln();
        let mut log_c = 0.0;
        let mut resampled = false;
        let Self {
            model,
            particles,
            next,
            log_w,
            work,
            first,
            base,
            points,
            ancestors,
            weights,
            linear,
            cumulative,
            uniforms,
            ..
        } = self;
        if k == 0 {
            // No propagation: weight the prior's draws.
            next.copy_from_slice(particles);
            if present {
                model.weigh(k, next, z, work);
            } else {
                work.fill(0.0);
            }
            for (v, b) in work.iter_mut().zip(base.iter()) {
                *v += *b;
            }
            check_log(work, "log_likelihood", k)?;
        } else {
            // First stage.
            let auxiliary = self.options.proposal == Proposal::Auxiliary && present;
            if auxiliary {
                points.resize(count * n, 0.0);
                if !model.lookahead(k, particles, z, points, first) {
                    return Err(Error::MissingFunction {
                        algorithm: "the auxiliary particle filter",
                        function: "lookahead",
                    });
                }
                check_log(first, "log_likelihood at the look-ahead point", k)?;
                for ((w, f), l) in work.iter_mut().zip(first.iter()).zip(log_w.iter()) {
                    *w = l + f;
                }
                log_c = normalise(work, linear);
                if log_c == f64::NEG_INFINITY {
                    return Err(Error::ParticleCollapse {
                        step: k,
                        what: "the look-ahead likelihood",
                    });
                }
            } else {
                first.fill(0.0);
                work.copy_from_slice(log_w);
                linear.copy_from_slice(weights);
            }
            // Resampling.
            let squares: f64 = linear.iter().map(|v| v * v).sum();
            resampled = match self.options.trigger {
                Trigger::Always => true,
                Trigger::Never => false,
                Trigger::EssBelow(f) => 1.0 / squares < f * count as f64,
            };
            if resampled {
                let total: f64 = linear.iter().sum();
                let scheme = self.options.resampling;
                let needed = match scheme {
                    Resampling::Multinomial | Resampling::Stratified => count,
                    Resampling::Systematic => 1,
                    Resampling::Residual => count - deterministic_copies(linear, total, count),
                };
                let mut rng = stream(seed, Purpose::Resample, k, 0);
                for u in uniforms[..needed].iter_mut() {
                    *u = rng.random::<f64>();
                }
                scheme.draw(linear, total, &uniforms[..needed], cumulative, ancestors);
                base.fill(-ln_n);
            } else {
                for (j, a) in ancestors.iter_mut().enumerate() {
                    *a = j;
                }
                base.copy_from_slice(work);
            }
            // Propagation and weighting.
            let zk = present.then_some(z);
            let g = Generation {
                k,
                seed,
                from: particles,
                ancestors,
                z: zk,
            };
            model.propagate(g, next, work);
            for ((v, b), a) in work.iter_mut().zip(base.iter()).zip(ancestors.iter()) {
                let like = if present { *v - first[*a] } else { 0.0 };
                *v = b + like;
            }
            check_states(next, n, "sample_transition", k)?;
            check_log(work, "log_likelihood", k)?;
        }
        let log_s = normalise(work, linear);
        if log_s == f64::NEG_INFINITY {
            return Err(Error::ParticleCollapse {
                step: k,
                what: "the likelihood",
            });
        }
        std::mem::swap(particles, next);
        std::mem::swap(log_w, work);
        std::mem::swap(weights, linear);
        self.log_likelihood += log_c + log_s;
        self.ess = 1.0 / self.weights.iter().map(|v| v * v).sum::<f64>();
        self.resampled = resampled;
        self.steps += 1;
        self.update_mean();
        if let Some(h) = &mut self.history {
            h.particles.extend_from_slice(&self.particles);
            h.log_weights.extend_from_slice(&self.log_w);
        }
        Ok(())
    }

    /// The weighted mean `Σ W^j x^j` into `self.mean`, in particle order.
    fn update_mean(&mut self) {
        let n = self.n;
        self.mean.fill(0.0);
        for (x, &w) in self.particles.chunks(n).zip(&self.weights) {
            for (m, xi) in self.mean.iter_mut().zip(x) {
                *m += w * xi;
            }
        }
    }

    /// The weighted mean of the particles, `x̂_{k|k}` after step k (the prior mean's
    /// estimate before the first step).
    pub fn mean(&self) -> &[f64] {
        &self.mean
    }

    /// The weighted covariance `Σ W^j (x^j − x̂)(x^j − x̂)ᵀ` (n × n).
    pub fn covariance(&self) -> Mat<f64> {
        let n = self.n;
        let mut p = Mat::<f64>::zeros(n, n);
        for (x, &w) in self.particles.chunks(n).zip(&self.weights) {
            for c in 0..n {
                let dc = x[c] - self.mean[c];
                for r in c..n {
                    p[(r, c)] += w * (x[r] - self.mean[r]) * dc;
                }
            }
        }
        for c in 0..n {
            for r in c + 1..n {
                p[(c, r)] = p[(r, c)];
            }
        }
        p
    }

    /// The particles, N × n row-major.
    pub fn particles(&self) -> &[f64] {
        &self.particles
    }

    /// The normalised log-weights `ln W^j` (their exponentials sum to 1).
    pub fn log_weights(&self) -> &[f64] {
        &self.log_w
    }

    /// The effective sample size `1/Σ (W^j)²` of the current weights.
    pub fn ess(&self) -> f64 {
        self.ess
    }

    /// Whether the last step resampled.
    pub fn resampled(&self) -> bool {
        self.resampled
    }

    /// `ln p̂(z_{0:k})`, the log of the unbiased likelihood estimate over the steps so far.
    pub fn log_likelihood(&self) -> f64 {
        self.log_likelihood
    }

    /// The number of steps taken.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The model.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The model, to change between steps (a time-varying parameter, or to read back what a
    /// model recorded).
    pub fn model_mut(&mut self) -> &mut M {
        &mut self.model
    }

    /// The options.
    pub fn options(&self) -> &ParticleOptions {
        &self.options
    }

    /// The recorded history (with [`History::Keep`]).
    pub fn history(&self) -> Option<&ParticleHistory> {
        self.history.as_ref()
    }
}
