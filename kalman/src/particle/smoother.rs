//! The forward-filtering backward-simulation (FFBSi) particle smoother over a filter's
//! recorded history.

use faer::Mat;
use rand::RngExt;

use super::{ParticleHistory, ParticleModel, Purpose, stream};
use crate::Error;

/// Trajectories drawn from the joint smoothing distribution `p(x_{0:T−1} | z_{0:T−1})` by
/// [`ffbsi`], and their means and covariances per step.
///
/// ```
/// use kalman::particle::{History, ParticleFilter, ParticleOptions, ffbsi};
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
/// let options = ParticleOptions { particles: 200, history: History::Keep, ..Default::default() };
/// let mut pf = ParticleFilter::new(Walk, options)?;
/// for z in [0.1, 0.12, 0.15] {
///     pf.step(&[z])?;
/// }
/// let s = ffbsi(pf.model(), pf.history().expect("kept"), 30, 0)?;
/// assert_eq!((s.trajectories(), s.means.ncols(), s.covariances.len()), (30, 3, 3));
/// assert_eq!(s.path(0).map(<[f64]>::len), Some(3));
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleSmoothed {
    n: usize,
    steps: usize,
    paths: Vec<f64>,
    /// Column k is the smoothed mean `x̂_{k|T−1}` (the trajectories' average), n × T.
    pub means: Mat<f64>,
    /// The smoothed covariances per step (the trajectories' covariance, divided by M).
    pub covariances: Vec<Mat<f64>>,
}

impl ParticleSmoothed {
    /// M, the number of trajectories.
    pub fn trajectories(&self) -> usize {
        self.paths.len() / (self.steps * self.n)
    }

    /// Trajectory `j`, T × n row-major (`None` for `j ≥ M`).
    pub fn path(&self, j: usize) -> Option<&[f64]> {
        let len = self.steps * self.n;
        self.paths.get(j * len..(j + 1) * len)
    }
}

/// The index of `u · Σ e^{b_i}` in the running sums of `e^{b_i − max}` (`b` overwritten).
fn draw(b: &mut [f64], u: f64) -> usize {
    let max = b.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut total = 0.0;
    for v in b.iter_mut() {
        total += (*v - max).exp();
        *v = total;
    }
    let target = u * total;
    let j = b.partition_point(|&c| c <= target);
    if j < b.len() {
        return j;
    }
    (1..b.len()).rev().find(|&i| b[i] > b[i - 1]).unwrap_or(0)
}

/// One backward trajectory.
fn backward<M: ParticleModel>(
    model: &M,
    history: &ParticleHistory,
    seed: u64,
    j: usize,
) -> Result<Vec<f64>, Error> {
    let (n, count, steps) = (history.n, history.count, history.steps());
    let mut rng = stream(seed, Purpose::Smooth, 0, j);
    let mut path = vec![0.0; steps * n];
    let mut b = vec![0.0; count];
    let last = steps - 1;
    b.copy_from_slice(&history.log_weights[last * count..steps * count]);
    let mut i = draw(&mut b, rng.random::<f64>());
    let xs = &history.particles[last * count * n..steps * count * n];
    path[last * n..].copy_from_slice(&xs[i * n..(i + 1) * n]);
    for k in (0..last).rev() {
        let xs = &history.particles[k * count * n..(k + 1) * count * n];
        let lw = &history.log_weights[k * count..(k + 1) * count];
        let (head, tail) = path.split_at_mut((k + 1) * n);
        let after = &tail[..n];
        for (idx, (bi, (x, l))) in b.iter_mut().zip(xs.chunks(n).zip(lw)).enumerate() {
            let d = model
                .log_transition_density(k, x, after)
                .ok_or(Error::MissingFunction {
                    algorithm: "FFBSi",
                    function: "log_transition_density",
                })?;
            if d.is_nan() || d == f64::INFINITY {
                return Err(Error::ModelNonFinite {
                    function: "log_transition_density",
                    step: k,
                    index: idx,
                });
            }
            *bi = l + d;
        }
        if b.iter().all(|v| *v == f64::NEG_INFINITY) {
            return Err(Error::ParticleCollapse {
                step: k,
                what: "the transition density",
            });
        }
        i = draw(&mut b, rng.random::<f64>());
        head[k * n..].copy_from_slice(&xs[i * n..(i + 1) * n]);
    }
    Ok(path)
}

/// The FFBSi smoother (Godsill, Doucet and West): M trajectories, each drawn backwards from
/// the filter's history — `x̃_{T−1}` from the last filtering weights, then `x̃_k = x_k^i` with
/// probability ∝ `W_k^i f_k(x̃_{k+1} | x_k^i)` — so that they are draws from the joint
/// smoothing distribution; the cost is O(M N T) transition densities. Trajectory j draws from
/// its own stream of `(seed, j)`; with the feature `parallel` the trajectories run on rayon's
/// threads, with the same result for any thread count.
///
/// # Errors
/// [`Error::Dimension`] for M = 0 or an empty history; [`Error::MissingFunction`] when the
/// model has no [`ParticleModel::log_transition_density`]; [`Error::ModelNonFinite`] for a NaN
/// or +∞ density; [`Error::ParticleCollapse`] when no particle of a step can reach the state
/// drawn at the next one; [`Error::ParticleInput`] for a history of another state dimension.
///
/// ```
/// use kalman::particle::{History, ParticleFilter, ParticleModel, ParticleOptions, ParticleRng, ffbsi};
/// use kalman::particle::rand::RngExt;
///
/// // x_{k+1} = x_k + w, w uniform on [-0.5, 0.5); z = x + uniform noise on [-0.5, 0.5).
/// struct Boxed;
/// impl ParticleModel for Boxed {
///     fn state_dim(&self) -> usize { 1 }
///     fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]) { x[0] = rng.random::<f64>() - 0.5; }
///     fn sample_transition(&self, _k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]) {
///         next[0] = x[0] + rng.random::<f64>() - 0.5;
///     }
///     fn log_likelihood(&self, _k: usize, x: &[f64], z: &[f64]) -> f64 {
///         if (z[0] - x[0]).abs() < 0.5 { 0.0 } else { f64::NEG_INFINITY }
///     }
///     fn log_transition_density(&self, _k: usize, x: &[f64], next: &[f64]) -> Option<f64> {
///         Some(if (next[0] - x[0]).abs() < 0.5 { 0.0 } else { f64::NEG_INFINITY })
///     }
/// }
/// # fn main() -> Result<(), kalman::Error> {
/// let options = ParticleOptions { particles: 200, history: History::Keep, ..ParticleOptions::default() };
/// let mut pf = ParticleFilter::new(Boxed, options)?;
/// for z in [0.1, 0.3, 0.2] {
///     pf.step(&[z])?;
/// }
/// let history = pf.history().expect("kept");
/// let smoothed = ffbsi(pf.model(), history, 50, 1)?;
/// // Every trajectory is consistent with the measurements and the dynamics.
/// for j in 0..smoothed.trajectories() {
///     let path = smoothed.path(j).expect("j < M");
///     assert!(path.iter().zip([0.1, 0.3, 0.2]).all(|(x, z)| (x - z).abs() < 0.5));
///     assert!(path.windows(2).all(|w| (w[1] - w[0]).abs() < 0.5));
/// }
/// # Ok(())
/// # }
/// ```
pub fn ffbsi<M: ParticleModel>(
    model: &M,
    history: &ParticleHistory,
    trajectories: usize,
    seed: u64,
) -> Result<ParticleSmoothed, Error> {
    let (n, steps) = (history.n, history.steps());
    if trajectories == 0 {
        return Err(Error::Dimension {
            name: "trajectories",
            value: 0,
            rule: "the smoother draws at least one trajectory",
        });
    }
    if steps == 0 {
        return Err(Error::Dimension {
            name: "steps",
            value: 0,
            rule: "the history must hold at least one step",
        });
    }
    if model.state_dim() != n {
        return Err(Error::ParticleInput {
            name: "history",
            rule: format!(
                "its states have {n} entries, the model's {}",
                model.state_dim()
            ),
        });
    }
    let x = &history.particles[..n];
    if model.log_transition_density(0, x, x).is_none() {
        return Err(Error::MissingFunction {
            algorithm: "FFBSi",
            function: "log_transition_density",
        });
    }
    #[cfg(feature = "parallel")]
    let results: Vec<Result<Vec<f64>, Error>> = {
        use rayon::prelude::*;
        (0..trajectories)
            .into_par_iter()
            .map(|j| backward(model, history, seed, j))
            .collect()
    };
    #[cfg(not(feature = "parallel"))]
    let results: Vec<Result<Vec<f64>, Error>> = (0..trajectories)
        .map(|j| backward(model, history, seed, j))
        .collect();
    let mut paths = Vec::with_capacity(trajectories * steps * n);
    for r in results {
        paths.extend_from_slice(&r?);
    }
    let m = trajectories as f64;
    let mut means = Mat::<f64>::zeros(n, steps);
    for path in paths.chunks(steps * n) {
        for k in 0..steps {
            for i in 0..n {
                means[(i, k)] += path[k * n + i] / m;
            }
        }
    }
    let mut covariances = vec![Mat::<f64>::zeros(n, n); steps];
    for path in paths.chunks(steps * n) {
        for (k, p) in covariances.iter_mut().enumerate() {
            for c in 0..n {
                let dc = path[k * n + c] - means[(c, k)];
                for r in 0..n {
                    p[(r, c)] += (path[k * n + r] - means[(r, k)]) * dc / m;
                }
            }
        }
    }
    Ok(ParticleSmoothed {
        n,
        steps,
        paths,
        means,
        covariances,
    })
}
