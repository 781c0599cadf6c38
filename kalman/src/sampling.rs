//! Continuous–discrete filtering: a continuous model sampled exactly at each record's own
//! interval.
//!
//! A recorded log carries time stamps, not a sampling interval: its rows jitter, sensors
//! sample at their own rates, and a dropout leaves a gap. [`ContinuousModel`] holds
//! `ẋ = A x + B u + w` (w white with intensity `W`, as it enters the state; `W = G Qc Gᵀ`
//! for a noise input matrix G) with the measurement `z = H x + v`, `cov(v) = R` for one
//! sample, and [`ContinuousModel::sample`] turns it into the discrete [`Model`] of an
//! interval Δt:
//!
//! - `F = e^{AΔt}` and `Q_d = ∫₀^Δt e^{Aτ} W e^{Aᵀτ} dτ` by Van Loan's block exponential
//!   (the one of [`crate::continuous::van_loan`], on preallocated buffers);
//! - the input by zero-order hold, `B_d = ∫₀^Δt e^{Aτ} dτ B`, read from `e^{[[A, B], [0,
//!   0]]Δt}`;
//! - `Δt = 0` (two rows of one instant) is `F = I`, `B_d = 0`, `Q_d = 0` exactly.
//!
//! [`Sampler`] caches the sampled models by Δt (bit-exact keys, a bounded cache), so a
//! regular or quantised clock pays for one discretisation per distinct interval and a step
//! that hits the cache allocates nothing. [`Sampler::sequence`] samples a whole time vector
//! once into a [`Sampled`], a [`ModelSource`] for [`crate::Filter::step_source`], the smoother and
//! the fitting code.
//!
//! The time rule, for rows at `t_0 ≤ t_1 ≤ …`: `(x0, P0)` is the prior of the first row's
//! measurement; step k updates with `z_k` and predicts over `Δt_k = t_{k+1} − t_k` (the last
//! row predicts over Δt = 0).
//!
//! # Example
//! ```
//! use kalman::sampling::{ContinuousModel, Sampler};
//! use kalman::{CovarianceForm, Filter};
//!
//! // A constant-velocity target with white acceleration of intensity 0.5 m²/s³, position
//! // measured with 2 m standard deviation, at irregular time stamps.
//! let cv = ContinuousModel::new(
//!     &[[0.0, 1.0], [0.0, 0.0]],
//!     &[[1.0, 0.0]],
//!     &[[0.0, 0.0], [0.0, 0.5]],
//!     &[[4.0]],
//! )?;
//! let t = [0.0, 0.1, 0.25, 0.25, 0.3, 5.3];
//! let z = [[0.1], [3.0], [7.4], [7.6], [9.1], [160.0]];
//! let mut sampler = Sampler::new(cv, 64)?;
//! let mut kf = Filter::new(sampler.at(0.0)?.clone(), &[0.0, 30.0], &[[10.0, 0.0], [0.0, 100.0]], CovarianceForm::Joseph)?;
//! for k in 0..t.len() {
//!     let dt = if k + 1 < t.len() { t[k + 1] - t[k] } else { 0.0 };
//!     kf.step_with(sampler.at(dt)?, &z[k], None)?;
//! }
//! assert!((kf.state()[1] - 30.0).abs() < 5.0);
//! // 0.1, 0.15, 0, 0.05 and 5: five distinct intervals (the last row's 0 is one of them).
//! assert_eq!(sampler.distinct(), 5);
//! # Ok::<(), kalman::Error>(())
//! ```
#![allow(non_snake_case)]

use faer::{Mat, MatRef};

use std::collections::HashMap;

use crate::model::{check, owned};
use crate::storage::DynDims;
use crate::{Error, MatrixInput, Model, ModelSource};
use numerics::Expm;

/// A continuous-time linear model with a discrete measurement: `ẋ = A x + B u + w`,
/// `E[w(t) w(s)ᵀ] = W δ(t − s)`, and `z_k = H x(t_k) + v_k` with `cov(v_k) = R`.
///
/// Built by [`ContinuousModel::new`], which checks shapes, finiteness and that `W` and `R`
/// are symmetric positive semidefinite (the workspace's tolerance policy).
#[derive(Debug, Clone)]
pub struct ContinuousModel {
    A: Mat<f64>,
    B: Mat<f64>,
    W: Mat<f64>,
    H: Mat<f64>,
    R: Mat<f64>,
}

impl ContinuousModel {
    /// The model `A` (n×n), `H` (m×n), `W` (n×n noise intensity), `R` (m×m covariance of
    /// one sample's measurement noise), without control input.
    ///
    /// # Errors
    /// [`Error::Shape`] or [`Error::NonFinite`] naming the matrix; [`Error::NotSymmetric`] or
    /// [`Error::NotPositiveSemidefinite`] for `W` or `R`; [`Error::Dimension`] for n = 0 or
    /// m = 0.
    pub fn new(
        A: &impl MatrixInput,
        H: &impl MatrixInput,
        W: &impl MatrixInput,
        R: &impl MatrixInput,
    ) -> Result<Self, Error> {
        let (n, m) = (A.nrows(), H.nrows());
        // The discrete model of Δt = 0 runs every check of W and R (and of n, m).
        let mut this = ContinuousModel {
            A: checked("A", A, n, n)?,
            B: Mat::zeros(n, 0),
            W: checked("W", W, n, n)?,
            H: checked("H", H, m, n)?,
            R: checked("R", R, m, m)?,
        };
        Model::new(
            DynDims::new(n, m, 0)?,
            &this.identity(),
            &this.H,
            &this.W,
            &this.R,
        )
        .map_err(as_intensity)?;
        this.W = crate::riccati::symmetrised(this.W.as_ref());
        this.R = crate::riccati::symmetrised(this.R.as_ref());
        Ok(this)
    }

    /// Adds the control input matrix `B` (n×p), held constant over each interval.
    ///
    /// # Errors
    /// [`Error::Shape`] or [`Error::NonFinite`] naming `B`.
    pub fn with_control(mut self, B: &impl MatrixInput) -> Result<Self, Error> {
        self.B = checked("B", B, self.n(), B.ncols())?;
        Ok(self)
    }

    /// Number of states n.
    pub fn n(&self) -> usize {
        self.A.nrows()
    }
    /// Number of measurements m.
    pub fn m(&self) -> usize {
        self.H.nrows()
    }
    /// Number of control inputs p.
    pub fn p(&self) -> usize {
        self.B.ncols()
    }
    /// The state matrix A.
    pub fn a(&self) -> MatRef<'_, f64> {
        self.A.as_ref()
    }
    /// The control input matrix B (n×p).
    pub fn b(&self) -> MatRef<'_, f64> {
        self.B.as_ref()
    }
    /// The noise intensity W.
    pub fn w(&self) -> MatRef<'_, f64> {
        self.W.as_ref()
    }
    /// The measurement matrix H.
    pub fn h(&self) -> MatRef<'_, f64> {
        self.H.as_ref()
    }
    /// The covariance R of one sample's measurement noise.
    pub fn r(&self) -> MatRef<'_, f64> {
        self.R.as_ref()
    }

    fn identity(&self) -> Mat<f64> {
        Mat::identity(self.n(), self.n())
    }

    /// The exact discrete model of the interval `dt` (seconds, `≥ 0`): `F = e^{AΔt}`,
    /// `B_d` by zero-order hold, `Q_d` by Van Loan, the same `H` and `R`.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming `dt` for a negative or non-finite interval, or one so
    /// long that `e^{AΔt}` or `Q_d` overflows (the model grows by more than f64 can hold over
    /// it).
    pub fn sample(&self, dt: f64) -> Result<Model<DynDims>, Error> {
        Ok(Sampler::new(self.clone(), 1)?.at(dt)?.clone())
    }
}

/// A checked faer copy of a matrix input.
fn checked(
    name: &'static str,
    a: &impl MatrixInput,
    rows: usize,
    cols: usize,
) -> Result<Mat<f64>, Error> {
    check(name, a, rows, cols)?;
    Ok(owned(a))
}

/// The engine's error about `Q` of the Δt = 0 model is about `W`.
fn as_intensity(e: Error) -> Error {
    match e {
        Error::NotSymmetric {
            name: "Q",
            n,
            row,
            col,
            diff,
            tol,
        } => Error::NotSymmetric {
            name: "W",
            n,
            row,
            col,
            diff,
            tol,
        },
        Error::NotPositiveSemidefinite {
            name: "Q",
            n,
            min_eigenvalue,
            tol,
        } => Error::NotPositiveSemidefinite {
            name: "W",
            n,
            min_eigenvalue,
            tol,
        },
        e => e,
    }
}

/// The sampled models of a [`ContinuousModel`], cached by interval.
///
/// The key is the interval's bit pattern: two intervals that differ in the last bit are two
/// entries, so the cache never returns a model of a nearby interval. When the cache is full
/// the oldest entry is replaced (first in, first out): a record whose intervals repeat within
/// `capacity` distinct values pays one discretisation per distinct value.
#[derive(Debug, Clone)]
pub struct Sampler {
    model: ContinuousModel,
    /// The model of Δt = 0, which each new cache entry starts from.
    template: Model<DynDims>,
    keys: Vec<u64>,
    index: HashMap<u64, usize>,
    models: Vec<Model<DynDims>>,
    capacity: usize,
    oldest: usize,
    misses: usize,
    work: Expm,
    /// The exponential of the block matrix, F, Q_d and B_d of the interval being sampled.
    e: Vec<f64>,
    f: Vec<f64>,
    q: Vec<f64>,
    b: Vec<f64>,
}

/// The key of an interval: its bit pattern, +0 and −0 one key.
fn key(dt: f64) -> u64 {
    if dt == 0.0 { 0 } else { dt.to_bits() }
}

/// The key of a cache slot whose model failed to sample (NaN's bit pattern, never a key of a
/// valid interval).
const EMPTY: u64 = u64::MAX;

impl Sampler {
    /// A sampler of `model` keeping at most `capacity` sampled models (≥ 1).
    ///
    /// # Errors
    /// [`Error::Dimension`] for a capacity of 0.
    pub fn new(model: ContinuousModel, capacity: usize) -> Result<Self, Error> {
        if capacity == 0 {
            return Err(Error::Dimension {
                name: "capacity",
                value: 0,
                rule: "the sampler's cache must hold at least one model",
            });
        }
        let (n, m, p) = (model.n(), model.m(), model.p());
        let mut template = Model::new(
            DynDims::new(n, m, p)?,
            &model.identity(),
            &model.H,
            &Mat::<f64>::zeros(n, n),
            &model.R,
        )?;
        if p > 0 {
            template = template.with_control(&Mat::<f64>::zeros(n, p))?;
        }
        let k = (2 * n).max(n + p);
        Ok(Sampler {
            model,
            template,
            keys: Vec::with_capacity(capacity),
            index: HashMap::with_capacity(capacity),
            models: Vec::with_capacity(capacity),
            capacity,
            oldest: 0,
            misses: 0,
            work: Expm::new(k),
            e: vec![0.0; k * k],
            f: vec![0.0; n * n],
            q: vec![0.0; n * n],
            b: vec![0.0; n * p],
        })
    }

    /// The continuous model.
    pub fn continuous(&self) -> &ContinuousModel {
        &self.model
    }

    /// How many intervals were discretised so far (cache misses).
    pub fn distinct(&self) -> usize {
        self.misses
    }

    /// The discrete model of the interval `dt` (seconds, `≥ 0`), from the cache when this
    /// exact interval was sampled recently.
    ///
    /// # Errors
    /// As [`ContinuousModel::sample`].
    pub fn at(&mut self, dt: f64) -> Result<&Model<DynDims>, Error> {
        let key = key(dt);
        if let Some(&i) = self.index.get(&key) {
            return Ok(&self.models[i]);
        }
        self.interval(dt)?;
        self.misses += 1;
        let i = if self.models.len() < self.capacity {
            self.models.push(self.template.clone());
            self.keys.push(EMPTY);
            self.models.len() - 1
        } else {
            let i = self.oldest;
            self.index.remove(&self.keys[i]);
            self.keys[i] = EMPTY;
            self.oldest = (i + 1) % self.capacity;
            i
        };
        self.models[i].resample(&self.f, &self.q, &self.b)?;
        self.keys[i] = key;
        self.index.insert(key, i);
        Ok(&self.models[i])
    }

    /// F, Q_d and B_d of the interval `dt` into `f`, `q`, `b`: Van Loan's
    /// `e^{[[−A, W], [0, Aᵀ]]Δt} = [[·, F⁻¹Q_d], [0, Fᵀ]]` and the zero-order hold
    /// `e^{[[A, B], [0, 0]]Δt} = [[F, B_d], [0, I]]`.
    fn interval(&mut self, dt: f64) -> Result<(), Error> {
        let (n, p) = (self.model.n(), self.model.p());
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(Error::InvalidOption {
                name: "dt",
                value: dt,
                rule: "a sampling interval must be finite and >= 0 (time stamps must not go back)",
            });
        }
        let (f, q, b) = (&mut self.f, &mut self.q, &mut self.b);
        if dt == 0.0 {
            f.iter_mut().for_each(|x| *x = 0.0);
            (0..n).for_each(|i| f[i + i * n] = 1.0);
            q.iter_mut().for_each(|x| *x = 0.0);
            b.iter_mut().for_each(|x| *x = 0.0);
            return Ok(());
        }
        let overflow = Error::InvalidOption {
            name: "dt",
            value: dt,
            rule: "e^{A dt} or the noise integrated over dt overflows: the model grows beyond \
                   f64 over this interval",
        };
        let (A, W) = (&self.model.A, &self.model.W);
        let k = 2 * n;
        let M = self.work.input(k);
        M.iter_mut().for_each(|x| *x = 0.0);
        for j in 0..n {
            for i in 0..n {
                M[i + j * k] = -A[(i, j)] * dt;
                M[i + (n + j) * k] = W[(i, j)] * dt;
                M[n + i + (n + j) * k] = A[(j, i)] * dt;
            }
        }
        let E = &mut self.e[..k * k];
        if !self.work.run_block(k, n, E) {
            return Err(overflow);
        }
        // F = (E₂₂)ᵀ, Q_d = F E₁₂, symmetrised.
        for j in 0..n {
            for i in 0..n {
                f[i + j * n] = E[n + j + (n + i) * k];
            }
        }
        for j in 0..n {
            for i in 0..n {
                q[i + j * n] = (0..n).map(|l| f[i + l * n] * E[l + (n + j) * k]).sum();
            }
        }
        crate::kernels::symmetrise(q, n);
        if !q.iter().all(|x| x.is_finite()) {
            return Err(overflow);
        }
        if p > 0 {
            let (Bc, k) = (&self.model.B, n + p);
            let M = self.work.input(k);
            M.iter_mut().for_each(|x| *x = 0.0);
            for j in 0..n {
                for i in 0..n {
                    M[i + j * k] = A[(i, j)] * dt;
                }
            }
            for j in 0..p {
                for i in 0..n {
                    M[i + (n + j) * k] = Bc[(i, j)] * dt;
                }
            }
            let E = &mut self.e[..k * k];
            if !self.work.run_block(k, n, E) {
                return Err(overflow);
            }
            for j in 0..p {
                for i in 0..n {
                    b[i + j * n] = E[i + (n + j) * k];
                }
            }
        }
        Ok(())
    }

    /// The models of the steps of a record at the time stamps `t` (non-decreasing): step k
    /// predicts over `t[k+1] − t[k]`, the last over 0. Each distinct interval is sampled and
    /// stored once.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming `t` for a non-finite stamp or one that goes back, and
    /// as [`ContinuousModel::sample`].
    pub fn sequence(&mut self, t: &[f64]) -> Result<Sampled, Error> {
        let mut slots: HashMap<u64, usize> = HashMap::new();
        let mut models = Vec::new();
        let mut index = Vec::with_capacity(t.len());
        for k in 0..t.len() {
            if !t[k].is_finite() {
                return Err(Error::InvalidOption {
                    name: "t",
                    value: t[k],
                    rule: "time stamps must be finite",
                });
            }
            let dt = match t.get(k + 1) {
                Some(&next) if !next.is_finite() => {
                    return Err(Error::InvalidOption {
                        name: "t",
                        value: next,
                        rule: "time stamps must be finite",
                    });
                }
                Some(&next) if next < t[k] => {
                    return Err(Error::InvalidOption {
                        name: "t",
                        value: next,
                        rule: "time stamps must not go back",
                    });
                }
                Some(&next) => next - t[k],
                None => 0.0,
            };
            let i = match slots.get(&key(dt)) {
                Some(&i) => i,
                None => {
                    models.push(self.at(dt)?.clone());
                    slots.insert(key(dt), models.len() - 1);
                    models.len() - 1
                }
            };
            index.push(i);
        }
        Ok(Sampled { models, index })
    }
}

/// The per-step models of one record ([`Sampler::sequence`]): each distinct interval's model
/// once, and each step's index into them.
#[derive(Debug, Clone)]
pub struct Sampled {
    models: Vec<Model<DynDims>>,
    index: Vec<usize>,
}

impl Sampled {
    /// Number of steps.
    pub fn len(&self) -> usize {
        self.index.len()
    }
    /// Whether the record has no step.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }
    /// Number of distinct intervals (models stored).
    pub fn distinct(&self) -> usize {
        self.models.len()
    }
}

impl ModelSource<DynDims> for Sampled {
    fn model(&self, k: usize) -> Option<&Model<DynDims>> {
        self.index.get(k).map(|&i| &self.models[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cv() -> ContinuousModel {
        ContinuousModel::new(
            &[[0.0, 1.0], [0.0, 0.0]],
            &[[1.0, 0.0]],
            &[[0.0, 0.0], [0.0, 0.5]],
            &[[4.0]],
        )
        .expect("valid")
    }

    /// The white-acceleration model's closed forms: F = [[1, Δt], [0, 1]], Q_d = q [[Δt³/3,
    /// Δt²/2], [Δt²/2, Δt]], and the ZOH input of an acceleration command B_d = [Δt²/2, Δt].
    #[test]
    fn a_constant_velocity_model_samples_to_its_closed_forms() {
        let model = cv().with_control(&[[0.0], [1.0]]).expect("valid");
        for dt in [1e-3, 0.1, 0.37, 5.0] {
            let d = model.sample(dt).expect("sampled");
            let (F, Q, B) = (d.f(), d.q(), d.b());
            let q = 0.5;
            let want_q = [[dt.powi(3) / 3.0, dt * dt / 2.0], [dt * dt / 2.0, dt]];
            // Tolerance: the Padé approximant and its squarings are exact to a few ulps on
            // these nilpotent blocks; 1e-13 relative to the largest entry is ample.
            let scale = dt.max(dt.powi(3));
            for i in 0..2 {
                for j in 0..2 {
                    assert!(
                        (Q[(i, j)] - q * want_q[i][j]).abs() < 1e-13 * q * scale,
                        "dt {dt} Q"
                    );
                }
            }
            assert!((F[(0, 1)] - dt).abs() < 1e-13 * dt.max(1.0));
            assert!((F[(0, 0)] - 1.0).abs() < 1e-14 && (F[(1, 0)]).abs() < 1e-14);
            assert!((B[(0, 0)] - dt * dt / 2.0).abs() < 1e-13 * dt.max(dt * dt));
            assert!((B[(1, 0)] - dt).abs() < 1e-13 * dt.max(1.0));
        }
    }

    #[test]
    fn a_zero_interval_is_one_instant() {
        let d = cv()
            .with_control(&[[0.0], [1.0]])
            .expect("valid")
            .sample(0.0)
            .expect("sampled");
        for i in 0..2 {
            for j in 0..2 {
                let id = if i == j { 1.0 } else { 0.0 };
                assert!((d.f()[(i, j)] - id).abs() < f64::MIN_POSITIVE);
                assert!(d.q()[(i, j)].abs() < f64::MIN_POSITIVE);
            }
            assert!(d.b()[(i, 0)].abs() < f64::MIN_POSITIVE);
        }
    }

    #[test]
    fn bad_intervals_are_named() {
        let model = cv();
        for dt in [-0.1, f64::NAN, f64::INFINITY] {
            let err = model.sample(dt).expect_err("a bad dt");
            assert!(
                matches!(err, Error::InvalidOption { name: "dt", .. }),
                "{err}"
            );
        }
        // e^{1000·Δt} overflows f64 for Δt = 1: refused, not an infinite F.
        let growing =
            ContinuousModel::new(&[[1000.0]], &[[1.0]], &[[1.0]], &[[1.0]]).expect("valid");
        let err = growing.sample(1.0).expect_err("overflow");
        assert!(
            matches!(err, Error::InvalidOption { name: "dt", .. }),
            "{err}"
        );
        assert!(growing.sample(0.01).is_ok());
    }

    #[test]
    fn the_cache_pays_once_per_distinct_interval_and_stays_bounded() {
        let mut s = Sampler::new(cv(), 2).expect("capacity");
        for dt in [0.1, 0.1, 0.2, 0.1, 0.2] {
            s.at(dt).expect("sampled");
        }
        assert_eq!(s.distinct(), 2);
        // A third interval replaces the oldest (0.1), which is then sampled again.
        s.at(0.3).expect("sampled");
        s.at(0.2).expect("sampled");
        assert_eq!(s.distinct(), 3);
        s.at(0.1).expect("sampled");
        assert_eq!(s.distinct(), 4);
        // A cached model is the model sampled directly.
        let direct = cv().sample(0.2).expect("sampled");
        let cached = s.at(0.2).expect("sampled");
        assert!((cached.q() - direct.q()).norm_max() < f64::MIN_POSITIVE);
        assert!(Sampler::new(cv(), 0).is_err());
    }

    #[test]
    fn a_sequence_indexes_each_step_by_its_interval() {
        let mut s = Sampler::new(cv(), 8).expect("capacity");
        let t = [0.0, 0.1, 0.2, 0.2, 0.5];
        let seq = s.sequence(&t).expect("sampled");
        assert_eq!(seq.len(), t.len());
        // 0.1 (twice, if the subtraction rounds alike), 0, 0.3, and 0 for the last step.
        let zero = seq.model(2).expect("step 2");
        assert!(zero.q().norm_max() < f64::MIN_POSITIVE);
        assert!(seq.model(4).expect("last").q().norm_max() < f64::MIN_POSITIVE);
        assert!(seq.model(5).is_none());
        let err = s.sequence(&[0.0, 0.2, 0.1]).expect_err("t goes back");
        assert!(matches!(err, Error::InvalidOption { name: "t", .. }));
        let err = s.sequence(&[0.0, f64::NAN]).expect_err("NaN t");
        assert!(matches!(err, Error::InvalidOption { name: "t", .. }));
    }
}
