//! How a particle filter draws and weights its particles: one particle at a time through a
//! [`ParticleModel`] (in blocks of [`BLOCK`], on rayon's threads with the feature
//! `parallel`), or the whole population in one call through a [`PopulationModel`] (a model
//! vectorised over particles, such as NumPy code called from Python).

use super::{BLOCK, ParticleModel, ParticleRng, Purpose, stream};

/// A particle model evaluated on the whole population at once: every method takes all N
/// particles, N × n row-major. For a model whose natural form is vectorised (array code, a
/// call into another runtime per step rather than per particle). It runs the bootstrap
/// filter (no look-ahead point) on one thread; its draws come from the one `rng` it is
/// given per call, so a seed gives the same run every time.
///
/// ```
/// use kalman::particle::{ParticleFilter, ParticleOptions, ParticleRng, PopulationModel, Vectorised};
/// use kalman::particle::rand::RngExt;
///
/// /// A random walk with uniform steps, observed in Gaussian noise of unit variance.
/// struct Walk;
/// impl PopulationModel for Walk {
///     fn state_dim(&self) -> usize { 1 }
///     fn sample_initial_all(&mut self, rng: &mut ParticleRng, xs: &mut [f64]) {
///         xs.iter_mut().for_each(|x| *x = 4.0 * (rng.random::<f64>() - 0.5));
///     }
///     fn sample_transition_all(&mut self, _k: usize, rng: &mut ParticleRng, xs: &mut [f64]) {
///         xs.iter_mut().for_each(|x| *x += rng.random::<f64>() - 0.5);
///     }
///     fn log_likelihood_all(&mut self, _k: usize, xs: &[f64], z: &[f64], out: &mut [f64]) {
///         for (o, x) in out.iter_mut().zip(xs) {
///             *o = -0.5 * (z[0] - x).powi(2);
///         }
///     }
/// }
/// # fn main() -> Result<(), kalman::Error> {
/// let options = ParticleOptions { particles: 400, seed: 3, ..ParticleOptions::default() };
/// let mut pf = ParticleFilter::new(Vectorised(Walk), options)?;
/// for z in [1.0, 1.2, 0.9, 1.1] {
///     pf.step(&[z])?;
/// }
/// assert!((pf.mean()[0] - 1.0).abs() < 0.5);
/// # Ok(())
/// # }
/// ```
pub trait PopulationModel {
    /// n, the state dimension (at least 1).
    fn state_dim(&self) -> usize;
    /// Draws the N particles of the prior of the first measurement into `xs`.
    fn sample_initial_all(&mut self, rng: &mut ParticleRng, xs: &mut [f64]);
    /// Replaces every particle `x_k` (a row of `xs`) by a draw of `x_{k+1} ~ f_k(· | x_k)`.
    fn sample_transition_all(&mut self, k: usize, rng: &mut ParticleRng, xs: &mut [f64]);
    /// `ln g_k(z | x)` of every particle into `out` (length N); −∞ for an impossible
    /// measurement, never NaN or +∞.
    fn log_likelihood_all(&mut self, k: usize, xs: &[f64], z: &[f64], out: &mut [f64]);
}

/// A [`PopulationModel`] as the model of a [`super::ParticleFilter`].
#[derive(Clone, Copy, Debug, Default)]
pub struct Vectorised<P>(pub P);

/// What one propagation reads: the step k, the filter's seed, the particles of step k − 1,
/// the ancestor of each new particle, and the measurement of step k (None: only propagate).
#[doc(hidden)]
#[derive(Clone, Copy, Debug)]
pub struct Generation<'a> {
    pub k: usize,
    pub seed: u64,
    pub from: &'a [f64],
    pub ancestors: &'a [usize],
    pub z: Option<&'a [f64]>,
}

/// What a [`super::ParticleFilter`] needs of its model: implemented for every
/// [`ParticleModel`] and for [`Vectorised`] over a [`PopulationModel`]; not meant to be
/// implemented elsewhere.
pub trait Propagate {
    /// n, the state dimension.
    fn state_dim(&self) -> usize;
    /// The prior's N draws into `xs`.
    #[doc(hidden)]
    fn draw_initial(&mut self, seed: u64, xs: &mut [f64], work: &mut [f64]);
    /// `out[j] = ln g_k(z | x_j)` for the particles `xs`.
    #[doc(hidden)]
    fn weigh(&mut self, k: usize, xs: &mut [f64], z: &[f64], out: &mut [f64]);
    /// `to_j ~ f_{k−1}(· | from_{a_j})`, and with `z` `out[j] = ln g_k(z | to_j)`.
    #[doc(hidden)]
    fn propagate(&mut self, g: Generation<'_>, to: &mut [f64], out: &mut [f64]);
    /// The look-ahead points `μ^i` of `x_k` given the particles `from` into `points` and
    /// `first[i] = ln g_k(z | μ^i)`; false when the model has no look-ahead point.
    #[doc(hidden)]
    fn lookahead(
        &mut self,
        k: usize,
        from: &[f64],
        z: &[f64],
        points: &mut [f64],
        first: &mut [f64],
    ) -> bool;
}

/// Runs `body(block, particles, values)` over the blocks of [`BLOCK`] particles, on rayon's
/// threads with the feature `parallel`.
fn blocks<F>(particles: &mut [f64], values: &mut [f64], n: usize, body: F)
where
    F: Fn(usize, &mut [f64], &mut [f64]) + Sync + Send,
{
    #[cfg(feature = "parallel")]
    if values.len() > BLOCK {
        use rayon::prelude::*;
        particles
            .par_chunks_mut(BLOCK * n)
            .zip(values.par_chunks_mut(BLOCK))
            .enumerate()
            .for_each(|(b, (p, v))| body(b, p, v));
        return;
    }
    for (b, (p, v)) in particles
        .chunks_mut(BLOCK * n)
        .zip(values.chunks_mut(BLOCK))
        .enumerate()
    {
        body(b, p, v);
    }
}

impl<M: ParticleModel> Propagate for M {
    fn state_dim(&self) -> usize {
        ParticleModel::state_dim(self)
    }

    fn draw_initial(&mut self, seed: u64, xs: &mut [f64], work: &mut [f64]) {
        let (model, n) = (&*self, ParticleModel::state_dim(self));
        blocks(xs, work, n, |b, chunk, _| {
            let mut rng = stream(seed, Purpose::Initial, 0, b);
            for x in chunk.chunks_mut(n) {
                model.sample_initial(&mut rng, x);
            }
        });
    }

    fn weigh(&mut self, k: usize, xs: &mut [f64], z: &[f64], out: &mut [f64]) {
        let (model, n) = (&*self, ParticleModel::state_dim(self));
        blocks(xs, out, n, |_, chunk, vals| {
            for (x, v) in chunk.chunks(n).zip(vals.iter_mut()) {
                *v = model.log_likelihood(k, x, z);
            }
        });
    }

    fn propagate(&mut self, g: Generation<'_>, to: &mut [f64], out: &mut [f64]) {
        let Generation {
            k,
            seed,
            from,
            ancestors,
            z,
        } = g;
        let (model, n) = (&*self, ParticleModel::state_dim(self));
        blocks(to, out, n, |b, chunk, vals| {
            let mut rng = stream(seed, Purpose::Propagate, k, b);
            for (jj, (x, v)) in chunk.chunks_mut(n).zip(vals.iter_mut()).enumerate() {
                let a = ancestors[b * BLOCK + jj];
                model.sample_transition(k - 1, &from[a * n..(a + 1) * n], &mut rng, x);
                *v = z.map_or(0.0, |z| model.log_likelihood(k, x, z));
            }
        });
    }

    fn lookahead(
        &mut self,
        k: usize,
        from: &[f64],
        z: &[f64],
        points: &mut [f64],
        first: &mut [f64],
    ) -> bool {
        let (model, n) = (&*self, ParticleModel::state_dim(self));
        if !model.lookahead(k - 1, &from[..n], &mut points[..n]) {
            return false;
        }
        blocks(points, first, n, |b, chunk, vals| {
            for (jj, (mu, v)) in chunk.chunks_mut(n).zip(vals.iter_mut()).enumerate() {
                let i = b * BLOCK + jj;
                model.lookahead(k - 1, &from[i * n..(i + 1) * n], mu);
                *v = model.log_likelihood(k, mu, z);
            }
        });
        true
    }
}

impl<P: PopulationModel> Propagate for Vectorised<P> {
    fn state_dim(&self) -> usize {
        self.0.state_dim()
    }

    fn draw_initial(&mut self, seed: u64, xs: &mut [f64], _work: &mut [f64]) {
        self.0
            .sample_initial_all(&mut stream(seed, Purpose::Initial, 0, 0), xs);
    }

    fn weigh(&mut self, k: usize, xs: &mut [f64], z: &[f64], out: &mut [f64]) {
        self.0.log_likelihood_all(k, xs, z, out);
    }

    fn propagate(&mut self, g: Generation<'_>, to: &mut [f64], out: &mut [f64]) {
        let n = self.0.state_dim();
        for (x, &a) in to.chunks_mut(n).zip(g.ancestors) {
            x.copy_from_slice(&g.from[a * n..(a + 1) * n]);
        }
        self.0
            .sample_transition_all(g.k - 1, &mut stream(g.seed, Purpose::Propagate, g.k, 0), to);
        match g.z {
            Some(z) => self.0.log_likelihood_all(g.k, to, z, out),
            None => out.fill(0.0),
        }
    }

    fn lookahead(&mut self, _: usize, _: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]) -> bool {
        false
    }
}
