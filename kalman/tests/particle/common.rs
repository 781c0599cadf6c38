//! The scalar linear-Gaussian model the particle filters are checked on, its exact Kalman
//! filter and RTS smoother (the scalar recursions written out), and a simulated record.

use kalman::particle::rand::RngExt;
use kalman::particle::{ParticleModel, ParticleRng, PopulationModel};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// `x_0 ~ N(0, p0)`, `x_{k+1} = a x_k + w`, `w ~ N(0, q)`, `z_k = x_k + v`, `v ~ N(0, r)`.
#[derive(Clone, Copy, Debug)]
pub struct Linear {
    pub a: f64,
    pub q: f64,
    pub r: f64,
    pub p0: f64,
}

/// The model of the tests: a = 0.9, q = 0.5, r = 1, p0 = 1 (filtered and smoothed
/// variances differ by about a third, so the smoother test can tell them apart).
pub const MODEL: Linear = Linear {
    a: 0.9,
    q: 0.5,
    r: 1.0,
    p0: 1.0,
};

const LN_2PI: f64 = 1.837_877_066_409_345_5;

fn normal_log_density(e: f64, var: f64) -> f64 {
    -0.5 * (LN_2PI + var.ln() + e * e / var)
}

impl ParticleModel for Linear {
    fn state_dim(&self) -> usize {
        1
    }
    fn sample_initial(&self, rng: &mut ParticleRng, x: &mut [f64]) {
        x[0] = self.p0.sqrt() * rng.sample::<f64, _>(StandardNormal);
    }
    fn sample_transition(&self, _k: usize, x: &[f64], rng: &mut ParticleRng, next: &mut [f64]) {
        next[0] = self.a * x[0] + self.q.sqrt() * rng.sample::<f64, _>(StandardNormal);
    }
    fn log_likelihood(&self, _k: usize, x: &[f64], z: &[f64]) -> f64 {
        normal_log_density(z[0] - x[0], self.r)
    }
    fn log_transition_density(&self, _k: usize, x: &[f64], next: &[f64]) -> Option<f64> {
        Some(normal_log_density(next[0] - self.a * x[0], self.q))
    }
    fn lookahead(&self, _k: usize, x: &[f64], point: &mut [f64]) -> bool {
        point[0] = self.a * x[0];
        true
    }
}

/// The same model evaluated on the whole population at once (for `Vectorised`).
impl PopulationModel for Linear {
    fn state_dim(&self) -> usize {
        1
    }
    fn sample_initial_all(&mut self, rng: &mut ParticleRng, xs: &mut [f64]) {
        for x in xs {
            *x = self.p0.sqrt() * rng.sample::<f64, _>(StandardNormal);
        }
    }
    fn sample_transition_all(&mut self, _k: usize, rng: &mut ParticleRng, xs: &mut [f64]) {
        for x in xs {
            *x = self.a * *x + self.q.sqrt() * rng.sample::<f64, _>(StandardNormal);
        }
    }
    fn log_likelihood_all(&mut self, _k: usize, xs: &[f64], z: &[f64], out: &mut [f64]) {
        for (o, x) in out.iter_mut().zip(xs) {
            *o = normal_log_density(z[0] - x, self.r);
        }
    }
}

/// The exact filter: x_{k|k}, P_{k|k} per step and ln p(z_{0:T−1}); with the predictions
/// x_{k+1|k}, P_{k+1|k} for the smoother.
pub struct Exact {
    pub means: Vec<f64>,
    pub variances: Vec<f64>,
    pub predicted: Vec<(f64, f64)>,
    pub log_likelihood: f64,
}

pub fn kalman(m: &Linear, zs: &[f64]) -> Exact {
    let (mut x, mut p) = (0.0, m.p0);
    let mut out = Exact {
        means: vec![],
        variances: vec![],
        predicted: vec![],
        log_likelihood: 0.0,
    };
    for &z in zs {
        let s = p + m.r;
        out.log_likelihood += normal_log_density(z - x, s);
        let k = p / s;
        x += k * (z - x);
        p *= 1.0 - k;
        out.means.push(x);
        out.variances.push(p);
        x *= m.a;
        p = m.a * m.a * p + m.q;
        out.predicted.push((x, p));
    }
    out
}

/// The RTS smoother over the exact filter: x_{k|T−1}, P_{k|T−1}.
pub fn rts(m: &Linear, f: &Exact) -> (Vec<f64>, Vec<f64>) {
    let t = f.means.len();
    let (mut xs, mut ps) = (f.means.clone(), f.variances.clone());
    for k in (0..t - 1).rev() {
        let (xp, pp) = f.predicted[k];
        let c = f.variances[k] * m.a / pp;
        xs[k] = f.means[k] + c * (xs[k + 1] - xp);
        ps[k] = f.variances[k] + c * c * (ps[k + 1] - pp);
    }
    (xs, ps)
}

/// A record of `steps` measurements simulated from the model.
pub fn record(m: &Linear, steps: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = m.p0.sqrt() * rng.sample::<f64, _>(StandardNormal);
    (0..steps)
        .map(|_| {
            let z = x + m.r.sqrt() * rng.sample::<f64, _>(StandardNormal);
            x = m.a * x + m.q.sqrt() * rng.sample::<f64, _>(StandardNormal);
            z
        })
        .collect()
}
