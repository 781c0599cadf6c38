//! Proptest strategies for random consistent filter problems (feature `proptest`): a
//! model with a valid joint noise covariance, a prior, and a measurement stream simulated
//! from the model with its truth. Seeded (ChaCha8), so every case is reproducible.
#![allow(non_snake_case)]

use faer::Mat;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::fit::System;
use crate::{Dims, Error, Model};

/// Options of a random problem.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProblemOptions {
    /// Number of steps simulated.
    pub steps: usize,
    /// Whether process and measurement noise are correlated (`S ≠ 0`).
    pub correlated: bool,
    /// Whether one measurement channel is exact (`R` singular: that row of the noise
    /// factor is zero).
    pub exact_channel: bool,
    /// Probability that a measurement entry is missing (NaN).
    pub missing: f64,
    /// Number of control inputs.
    pub p: usize,
}

impl Default for ProblemOptions {
    fn default() -> Self {
        ProblemOptions {
            steps: 20,
            correlated: false,
            exact_channel: false,
            missing: 0.0,
            p: 0,
        }
    }
}

/// A random consistent filter problem and a simulated measurement stream with its truth:
/// the model and prior as a [`System`] (the fitting code's model type, so a problem is also
/// a fitting problem), the cross-covariance S the fit does not carry, and the data.
///
/// # Example
/// ```
/// use kalman::DynDims;
/// use kalman::strategies::{FilterProblem, ProblemOptions};
///
/// let p = FilterProblem::generate(3, 2, ProblemOptions::default(), 7);
/// assert_eq!((p.system.n(), p.system.m(), p.z.len()), (3, 2, 20));
/// // Its model passes the engine's validation on the dynamic path.
/// let model = p.model(DynDims::new(3, 2, 0)?)?;
/// assert_eq!(model.f().nrows(), 3);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct FilterProblem {
    /// F (n×n, spectral norm ≤ 0.98), H, Q, R, B and the prior (x₀, P₀).
    pub system: System,
    /// Cross-covariance S (n×m, present when `correlated`).
    pub s: Option<Mat<f64>>,
    /// True states `x_0 … x_{T−1}` (x_0 drawn from the prior).
    pub truth: Vec<Vec<f64>>,
    /// Measurements `z_0 … z_{T−1}` (NaN = missing).
    pub z: Vec<Vec<f64>>,
    /// Control inputs `u_0 … u_{T−1}`.
    pub u: Vec<Vec<f64>>,
}

fn randn(rng: &mut ChaCha8Rng, r: usize, c: usize) -> Mat<f64> {
    Mat::from_fn(r, c, |_, _| rng.sample::<f64, _>(StandardNormal))
}

impl FilterProblem {
    /// Builds a problem with n states and m measurements from `seed`.
    pub fn generate(n: usize, m: usize, opts: ProblemOptions, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let A = randn(&mut rng, n, n);
        let norm = A.norm_l2().max(1e-12);
        let F = A * faer::Scale(0.98 / norm);
        let H = randn(&mut rng, m, n);
        let d = n + m;
        // Joint noise [v; w] = G η (v first). Block-diagonal G without correlation.
        let mut G = randn(&mut rng, d, d) * faer::Scale(0.5);
        for i in 0..d {
            G[(i, i)] += 0.5;
        }
        if !opts.correlated {
            for i in 0..m {
                for j in m..d {
                    G[(i, j)] = 0.0;
                    G[(j, i)] = 0.0;
                }
            }
        }
        if opts.exact_channel {
            for j in 0..d {
                G[(0, j)] = 0.0;
            }
        }
        let W = &G * G.transpose();
        let R = W.submatrix(0, 0, m, m).to_owned();
        let Q = W.submatrix(m, m, n, n).to_owned();
        let S = opts.correlated.then(|| W.submatrix(m, 0, n, m).to_owned());
        let B = randn(&mut rng, n, opts.p);
        let Gp = randn(&mut rng, n, n);
        let P0 = &Gp * Gp.transpose() + Mat::<f64>::identity(n, n) * faer::Scale(0.1);
        let x0: Vec<f64> = (0..n)
            .map(|_| rng.sample::<f64, _>(StandardNormal))
            .collect();
        // x_true0 ~ N(x0, P0) through a Cholesky factor of P0 (positive definite here).
        let L = match P0.llt(faer::Side::Lower) {
            Ok(l) => l.L().to_owned(),
            Err(_) => Mat::<f64>::identity(n, n),
        };
        let eta: Vec<f64> = (0..n)
            .map(|_| rng.sample::<f64, _>(StandardNormal))
            .collect();
        let mut x: Vec<f64> = (0..n)
            .map(|i| x0[i] + (0..n).map(|j| L[(i, j)] * eta[j]).sum::<f64>())
            .collect();
        let (mut truth, mut zs, mut us) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..opts.steps {
            let eta: Vec<f64> = (0..d)
                .map(|_| rng.sample::<f64, _>(StandardNormal))
                .collect();
            let noise: Vec<f64> = (0..d)
                .map(|i| (0..d).map(|j| G[(i, j)] * eta[j]).sum())
                .collect();
            let u: Vec<f64> = (0..opts.p)
                .map(|_| rng.sample::<f64, _>(StandardNormal))
                .collect();
            let z: Vec<f64> = (0..m)
                .map(|i| {
                    let zi = (0..n).map(|j| H[(i, j)] * x[j]).sum::<f64>() + noise[i];
                    if rng.random::<f64>() < opts.missing {
                        f64::NAN
                    } else {
                        zi
                    }
                })
                .collect();
            let next: Vec<f64> = (0..n)
                .map(|i| {
                    (0..n).map(|j| F[(i, j)] * x[j]).sum::<f64>()
                        + (0..opts.p).map(|l| B[(i, l)] * u[l]).sum::<f64>()
                        + noise[m + i]
                })
                .collect();
            truth.push(x);
            zs.push(z);
            us.push(u);
            x = next;
        }
        FilterProblem {
            system: System {
                f: F,
                h: H,
                q: Q,
                r: R,
                b: B,
                x0,
                p0: P0,
            },
            s: S,
            truth,
            z: zs,
            u: us,
        }
    }

    /// The validated model on storage path `dims` (whose n, m, p must match).
    ///
    /// # Errors
    /// As [`Model::new`].
    pub fn model<D: Dims>(&self, dims: D) -> Result<Model<D>, Error> {
        let model = self.system.model_on(dims)?;
        match &self.s {
            Some(s) => model.with_cross_covariance(s),
            None => Ok(model),
        }
    }
}

/// A strategy for random problems with n in `n`, m in `m` and the given options (the seed
/// is drawn by proptest, so failures shrink to small dimensions).
pub fn problem(
    n: core::ops::RangeInclusive<usize>,
    m: core::ops::RangeInclusive<usize>,
    opts: ProblemOptions,
) -> impl Strategy<Value = FilterProblem> {
    (n, m, any::<u64>()).prop_map(move |(n, m, seed)| FilterProblem::generate(n, m, opts, seed))
}
