//! The interacting multiple model (IMM) estimator over any mix of the crate's filters, with
//! modes of different state dimensions, and its forward–backward smoother ([`smoother`]).
//!
//! # Model
//! The system follows one of r modes at each step, `s_k ∈ {0, …, r−1}`, switching as a
//! Markov chain with transition matrix `Π` (`Π_ij = P(s_{k+1} = j | s_k = i)`, rows summing
//! to one). Mode j is a filter of the crate — the linear `Filter` (Joseph or standard form,
//! no cross-covariance S), the `nonlinear::Ekf` or the `nonlinear::Ukf` — over its own
//! state of dimension n_j, and every mode sees the same m measurements.
//!
//! # Common state and embedding
//! Each mode's state is a subset of a common state of dimension n_c, given by an
//! [`Embedding`]: the common index of each of the mode's states (a constant-velocity
//! (p, v) inside a constant-acceleration (p, v, a) is the embedding `[0, 1]` into n_c = 3).
//! - *Mixing into mode j* uses only j's components. A source mode i that does not carry one
//!   of them contributes mode j's own value there (mean and covariance block, no cross
//!   terms): the unbiased mixing of T. Yuan, Y. Bar-Shalom, P. Willett et al., "A multiple
//!   IMM estimation approach with unbiased mixing for thrusting projectiles", IEEE Trans.
//!   Aerospace and Electronic Systems 48(4), 2012, so a state the source does not model
//!   does not pull the target's estimate towards an arbitrary value.
//! - *The combined estimate* is over the common state; a component that mode i does not
//!   carry takes the embedding's fill mean and variance (zero by default).
//!
//! # One step (Blom and Bar-Shalom's IMM, in this crate's step order)
//! Before step k every mode holds its prior `x^j_{k|k−1}` and the IMM the predicted mode
//! probabilities `c^j_k` (before the first step: each filter's `x0, P0` and `μ0`). Step k:
//! 1. each mode updates with `z_k`, giving `x^j_{k|k}, P^j_{k|k}` and the log-likelihood
//!    `ℓ_j` of its innovation;
//! 2. `μ^j_k = c^j_k e^{ℓ_j} / Σ_i c^i_k e^{ℓ_i}` (in logarithms, so no likelihood
//!    underflows), and the IMM's log-likelihood `log Σ_j c^j_k e^{ℓ_j}`;
//! 3. the combined estimate `x_{k|k} = Σ_j μ^j_k x̄^j`,
//!    `P_{k|k} = Σ_j μ^j_k (P̄^j + (x̄^j − x_{k|k})(…)ᵀ)` (x̄^j, P̄^j: mode j in the common
//!    state);
//! 4. mixing: `c^j_{k+1} = Σ_i Π_ij μ^i_k`, `ω_{i|j} = Π_ij μ^i_k / c^j_{k+1}`,
//!    `x^{0j} = Σ_i ω_{i|j} x̃^{i→j}`, `P^{0j} = Σ_i ω_{i|j}(P̃^{i→j} + (x̃^{i→j} − x^{0j})(…)ᵀ)`
//!    written into mode j's posterior (a mode with `c^j_{k+1} = 0` keeps its own);
//! 5. each mode predicts to k + 1 from its mixed posterior with `u_k`.
//!
//! A step allocates nothing (the workspaces are sized at construction).
//!
//! # References
//! - H. A. P. Blom and Y. Bar-Shalom, "The interacting multiple model algorithm for systems
//!   with Markovian switching coefficients", IEEE Trans. Automatic Control 33(8), 1988.
//! - Y. Bar-Shalom, X. R. Li, T. Kirubarajan, *Estimation with Applications to Tracking and
//!   Navigation*, 2001, §11.6 (the cycle above; FilterPy's `IMMEstimator` is the same cycle
//!   for modes of one dimension).
//!
//! # Example
//! ```
//! use kalman::imm::{Embedding, Imm, Mode};
//! use kalman::{CovarianceForm, DynDims, Filter, Model};
//! # fn main() -> Result<(), kalman::Error> {
//! // A random walk observed in unit noise, with a quiet and a noisy mode.
//! let mode = |q: f64| -> Result<Box<dyn Mode>, kalman::Error> {
//!     let m = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[q]], &[[1.0]])?;
//!     Ok(Box::new(Filter::new(m, &[0.0], &[[1.0]], CovarianceForm::Joseph)?))
//! };
//! let mut imm = Imm::new(
//!     vec![(mode(0.01)?, Embedding::identity(1)), (mode(10.0)?, Embedding::identity(1))],
//!     &[[0.95, 0.05], [0.05, 0.95]],
//!     &[0.5, 0.5],
//! )?;
//! for z in [0.1, -0.2, 0.05, 8.0, 16.0, 24.0] {
//!     imm.step(&[z], None)?;
//! }
//! // The jumps are the noisy mode's.
//! assert!(imm.mode_probabilities()[1] > 0.9);
//! # Ok(())
//! # }
//! ```
#![allow(non_snake_case)]

mod mixture;
pub mod smoother;

pub use mixture::{Moments, mixing_probabilities, probability_vector};

pub use smoother::{ImmRecord, ImmSmoothed};

use faer::MatRef;

use crate::model::{MatrixInput, load, load_vec};
use crate::{Error, StepInfo};

/// The operations the IMM needs from a mode's filter (crate-private, so [`Mode`] is sealed).
pub(crate) mod ops {
    use crate::{Error, StepInfo};

    /// Update and prediction as separate stages, with the posterior readable and writable
    /// between them.
    pub trait ModeOps {
        /// (n, m): the mode's state and measurement dimensions.
        fn mode_dims(&mut self) -> (usize, usize);
        /// Whether the filter can run as a mode (the linear filter refuses the square-root
        /// form and a cross-covariance S).
        fn mode_check(&self) -> Result<(), Error>;
        /// The update with `z_k` from the prior, into the posterior.
        fn mode_update(&mut self, z: &[f64]) -> Result<StepInfo, Error>;
        /// The prediction to `k + 1` from the posterior, into the prior (the step index is
        /// not advanced).
        fn mode_predict(&mut self, u: Option<&[f64]>) -> Result<(), Error>;
        /// Advances the step index after a step's last prediction.
        fn mode_advance(&mut self, info: StepInfo);
        /// `(x_{k|k}, P_{k|k})`, column-major.
        fn mode_posterior(&self) -> (&[f64], &[f64]);
        /// `(x_{k|k}, P_{k|k})`, to overwrite.
        fn mode_posterior_mut(&mut self) -> (&mut [f64], &mut [f64]);
        /// `(x_{k+1|k}, P_{k+1|k})` of the last prediction.
        fn mode_prior(&self) -> (&[f64], &[f64]);
        /// `C_k = Cov(x_k, x_{k+1})` of the last prediction into `out` (n×n).
        fn mode_cross_covariance(&self, out: &mut [f64]);
    }
}

/// A filter that can be a mode of an [`Imm`]: the linear `Filter` (Joseph or standard
/// form, both storage paths), the `nonlinear::Ekf` and the `nonlinear::Ukf`. Sealed: the
/// IMM reads and overwrites the filters' estimates between their update and prediction.
/// ```
/// use kalman::imm::Mode;
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
/// let m = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.1]], &[[1.0]])?;
/// // Any of the crate's filters boxes into a mode.
/// let mode: Box<dyn Mode> = Box::new(Filter::new(m, &[0.0], &[[1.0]], CovarianceForm::Joseph)?);
/// # let _ = mode;
/// # Ok::<(), kalman::Error>(())
/// ```
pub trait Mode: ops::ModeOps {}

impl<T: ops::ModeOps + ?Sized> Mode for T {}

/// Where a mode's states sit in the common state: `indices[i]` is the common index of the
/// mode's state i; the common states the mode does not carry take `fill` values in the
/// combined estimate (mean and variance, zero by default).
///
/// ```
/// use kalman::imm::Embedding;
/// // Constant velocity (p, v) inside constant acceleration (p, v, a); a reported as 0 ± 1.
/// let e = Embedding::new(3, &[0, 1])?.with_fill(&[0.0, 0.0, 0.0], &[0.0, 0.0, 1.0])?;
/// assert_eq!(e.indices(), &[0, 1]);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Embedding {
    common: usize,
    indices: Vec<usize>,
    fill_mean: Vec<f64>,
    fill_var: Vec<f64>,
}

impl Embedding {
    /// The mode's state is the whole common state (n_c = n).
    pub fn identity(n: usize) -> Self {
        Self {
            common: n,
            indices: (0..n).collect(),
            fill_mean: vec![0.0; n],
            fill_var: vec![0.0; n],
        }
    }

    /// The mode's state i is common state `indices[i]` of `common` states.
    ///
    /// # Errors
    /// [`Error::Dimension`] naming `indices` if it is empty, has an entry `≥ common` or a
    /// repeated entry.
    pub fn new(common: usize, indices: &[usize]) -> Result<Self, Error> {
        let bad = |value, rule| {
            Err(Error::Dimension {
                name: "indices",
                value,
                rule,
            })
        };
        if indices.is_empty() {
            return bad(0, "an embedding maps at least one state");
        }
        for (i, &c) in indices.iter().enumerate() {
            if c >= common {
                return bad(c, "an embedding index must be below the common dimension");
            }
            if indices[..i].contains(&c) {
                return bad(c, "an embedding index may appear once");
            }
        }
        Ok(Self {
            common,
            indices: indices.to_vec(),
            fill_mean: vec![0.0; common],
            fill_var: vec![0.0; common],
        })
    }

    /// The values the combined estimate takes for the common states this mode does not
    /// carry (entries at carried indices are ignored).
    ///
    /// # Errors
    /// [`Error::Shape`] or [`Error::NonFinite`] naming `fill_mean`/`fill_variance`;
    /// [`Error::InvalidOption`] for a negative variance.
    pub fn with_fill(mut self, mean: &[f64], variance: &[f64]) -> Result<Self, Error> {
        load_vec("fill_mean", mean, self.common, &mut self.fill_mean)?;
        load_vec("fill_variance", variance, self.common, &mut self.fill_var)?;
        if let Some(&v) = self.fill_var.iter().find(|v| **v < 0.0) {
            return Err(Error::InvalidOption {
                name: "fill_variance",
                value: v,
                rule: "a variance must be non-negative",
            });
        }
        Ok(self)
    }

    /// The common index of each of the mode's states.
    pub fn indices(&self) -> &[usize] {
        &self.indices
    }
    /// The common dimension n_c.
    pub fn common_dim(&self) -> usize {
        self.common
    }
}

/// What one IMM step produced.
///
/// ```
/// use kalman::imm::{Embedding, Imm, Mode};
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
/// let m = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.1]], &[[1.0]])?;
/// let f: Box<dyn Mode> = Box::new(Filter::new(m, &[0.0], &[[1.0]], CovarianceForm::Joseph)?);
/// let mut imm = Imm::new(vec![(f, Embedding::identity(1))], &[[1.0]], &[1.0])?;
/// // z = 0 against the prior N(0, 1 + 1): ln L = −½ ln(2π·2).
/// let s = imm.step(&[0.0], None)?;
/// assert!((s.log_likelihood + 0.5 * (4.0 * std::f64::consts::PI).ln()).abs() < 1e-12);
/// assert_eq!((s.step, s.observed), (0, 1));
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImmStep {
    /// Index k of the step.
    pub step: usize,
    /// `log Σ_j c^j_k e^{ℓ_j}`: the log-likelihood of `z_k` under the IMM's Gaussian
    /// mixture prediction (0 on a predict-only step).
    pub log_likelihood: f64,
    /// Measurement entries observed (not NaN).
    pub observed: usize,
}

/// The structure the step and the smoother share: the transition matrix and where each
/// mode's states sit in the common state.
#[derive(Clone, Debug)]
pub(crate) struct Structure {
    pub(crate) r: usize,
    pub(crate) nc: usize,
    /// Π, row-major r×r.
    pub(crate) pi: Vec<f64>,
    pub(crate) emb: Vec<Embedding>,
    /// `pos[i * nc + c]`: the position of common state c in mode i (`usize::MAX` if absent).
    pub(crate) pos: Vec<usize>,
}

const ABSENT: usize = usize::MAX;

impl Structure {
    fn n(&self, j: usize) -> usize {
        self.emb[j].indices.len()
    }

    /// Source mode `i`'s estimate `(x, P)` seen in target mode `j`'s components, the
    /// components `i` lacks taken from `(xj, Pj)`; into `(ex, ep)` (n_j, n_j²).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn project(
        &self,
        i: usize,
        (x, P): (&[f64], &[f64]),
        j: usize,
        (xj, Pj): (&[f64], &[f64]),
        ex: &mut [f64],
        ep: &mut [f64],
    ) {
        let (ni, nj) = (self.n(i), self.n(j));
        let idx = &self.emb[j].indices;
        let pos = &self.pos[i * self.nc..(i + 1) * self.nc];
        for a in 0..nj {
            let pa = pos[idx[a]];
            ex[a] = if pa == ABSENT { xj[a] } else { x[pa] };
            for b in 0..nj {
                let pb = pos[idx[b]];
                ep[a + b * nj] = match (pa == ABSENT, pb == ABSENT) {
                    (false, false) => P[pa + pb * ni],
                    (true, true) => Pj[a + b * nj],
                    _ => 0.0,
                };
            }
        }
    }

    /// Mode `i`'s `(x, P)` in the common state (fill values where absent), into `(ex, ep)`.
    pub(crate) fn lift(&self, i: usize, (x, P): (&[f64], &[f64]), ex: &mut [f64], ep: &mut [f64]) {
        let (nc, ni) = (self.nc, self.n(i));
        let e = &self.emb[i];
        let pos = &self.pos[i * nc..(i + 1) * nc];
        for a in 0..nc {
            let pa = pos[a];
            ex[a] = if pa == ABSENT { e.fill_mean[a] } else { x[pa] };
            for b in 0..nc {
                let pb = pos[b];
                ep[a + b * nc] = match (pa == ABSENT, pb == ABSENT) {
                    (false, false) => P[pa + pb * ni],
                    (true, true) if a == b => e.fill_var[a],
                    _ => 0.0,
                };
            }
        }
    }
}

/// The interacting multiple model estimator over r boxed [`Mode`]s.
///
/// See the [module documentation](self) for the cycle and the embedding rules, and
/// [`ImmRecord`] for the smoother.
///
/// ```
/// use kalman::imm::{Embedding, Imm, Mode};
/// use kalman::nonlinear::{FnModel, SigmaPoints, Ukf};
/// use kalman::{CovarianceForm, FixedDims, Filter, Model};
/// # fn main() -> Result<(), kalman::Error> {
/// // A linear random walk and a UKF whose state decays, side by side.
/// let lin = Model::new(FixedDims::<1, 1>::new(), &[[1.0]], &[[1.0]], &[[0.01]], &[[0.01]])?;
/// let lin: Box<dyn Mode> = Box::new(Filter::new(lin, &[8.0], &[[1.0]], CovarianceForm::Joseph)?);
/// let decay = FnModel::new(
///     FixedDims::<1, 1>::new(),
///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = 0.5 * x[0],
///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0],
///     &[[0.01]],
///     &[[0.01]],
/// )?;
/// let ukf: Box<dyn Mode> = Box::new(Ukf::new(FixedDims::<1, 1>::new(), decay, &[8.0], &[[1.0]],
///     SigmaPoints::Cubature)?);
/// let pi = [[0.9, 0.1], [0.1, 0.9]];
/// let mut imm = Imm::new(vec![(lin, Embedding::identity(1)), (ukf, Embedding::identity(1))], &pi,
///     &[0.5, 0.5])?;
/// for z in [8.0, 4.0, 2.0, 1.0, 0.5] {
///     imm.step(&[z], None)?;
/// }
/// // Halving each step is the decaying mode's.
/// assert!(imm.mode_probabilities()[1] > 0.9);
/// # Ok(())
/// # }
/// ```
pub struct Imm {
    modes: Vec<Box<dyn Mode>>,
    s: Structure,
    m: usize,
    k: usize,
    /// μ_k (after a step) and c_{k+1} (the prior of the next step's mode probabilities).
    mu: Vec<f64>,
    cbar: Vec<f64>,
    ll: Vec<f64>,
    infos: Vec<StepInfo>,
    /// ω_{i|j}, column j for target j (r×r column-major).
    omega: Vec<f64>,
    x: Vec<f64>,
    P: Vec<f64>,
    /// Mixed estimates of every mode, at offsets `off[j]` (n_j) and `offp[j]` (n_j²).
    xm: Vec<f64>,
    pm: Vec<f64>,
    off: Vec<usize>,
    offp: Vec<usize>,
    /// Scratch of the common size.
    ex: Vec<f64>,
    ep: Vec<f64>,
    last: ImmStep,
}

impl std::fmt::Debug for Imm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Imm")
            .field("modes", &self.s.r)
            .field("common_dim", &self.s.nc)
            .field("step", &self.k)
            .field("mu", &self.mu)
            .finish()
    }
}

impl Imm {
    /// An IMM over `modes` (each filter with the [`Embedding`] of its state into the common
    /// state), the r×r Markov `transition` matrix Π (`Π_ij = P(s_{k+1} = j | s_k = i)`) and
    /// the mode probabilities `mu0` of the first step. The filters' own `x0, P0` are the
    /// priors of the first step.
    ///
    /// # Errors
    /// [`Error::Dimension`] naming `modes` (none, or embeddings of different common
    /// dimensions, a mode whose n differs from its embedding's length, or whose m differs
    /// from the first mode's); [`Error::Shape`]/[`Error::NonFinite`] naming `transition` or
    /// `mu0`; [`Error::InvalidOption`] naming `transition` (a negative entry, a row not
    /// summing to one within 1e-9) or `mu0` (likewise); a mode's own refusal (the linear
    /// filter's square-root form, a cross-covariance S).
    pub fn new(
        mut modes: Vec<(Box<dyn Mode>, Embedding)>,
        transition: &impl MatrixInput,
        mu0: &[f64],
    ) -> Result<Self, Error> {
        let r = modes.len();
        let dim = |value, rule| Error::Dimension {
            name: "modes",
            value,
            rule,
        };
        let Some(first) = modes.first_mut() else {
            return Err(dim(0, "an IMM needs at least one mode"));
        };
        let nc = first.1.common;
        let m = first.0.mode_dims().1;
        for (f, e) in &mut modes {
            let (n, mj) = f.mode_dims();
            if e.common != nc {
                return Err(dim(
                    e.common,
                    "every embedding has the same common dimension",
                ));
            }
            if n != e.indices.len() {
                return Err(dim(n, "a mode's n must equal its embedding's length"));
            }
            if mj != m {
                return Err(dim(mj, "every mode has the same number of measurements m"));
            }
            f.mode_check()?;
        }
        let mut pi_cm = vec![0.0; r * r];
        load("transition", transition, r, r, &mut pi_cm)?;
        let mut pi = vec![0.0; r * r];
        for i in 0..r {
            for j in 0..r {
                pi[i * r + j] = pi_cm[i + j * r];
            }
            probability_vector("transition", &pi[i * r..(i + 1) * r])?;
        }
        let mut mu = vec![0.0; r];
        load_vec("mu0", mu0, r, &mut mu)?;
        probability_vector("mu0", &mu)?;
        let mut pos = vec![ABSENT; r * nc];
        for (i, (_, e)) in modes.iter().enumerate() {
            for (p, &c) in e.indices.iter().enumerate() {
                pos[i * nc + c] = p;
            }
        }
        let (mut off, mut offp) = (Vec::with_capacity(r), Vec::with_capacity(r));
        let (mut a, mut b) = (0, 0);
        for (_, e) in &modes {
            off.push(a);
            offp.push(b);
            a += e.indices.len();
            b += e.indices.len() * e.indices.len();
        }
        let (filters, emb): (Vec<_>, Vec<_>) = modes.into_iter().unzip();
        let s = Structure {
            r,
            nc,
            pi,
            emb,
            pos,
        };
        let mut imm = Self {
            modes: filters,
            s,
            m,
            k: 0,
            cbar: mu.clone(),
            mu,
            ll: vec![0.0; r],
            infos: vec![StepInfo::default(); r],
            omega: vec![0.0; r * r],
            x: vec![0.0; nc],
            P: vec![0.0; nc * nc],
            xm: vec![0.0; a],
            pm: vec![0.0; b],
            off,
            offp,
            ex: vec![0.0; nc],
            ep: vec![0.0; nc * nc],
            last: ImmStep::default(),
        };
        // Before the first step the filters' posteriors are their priors x0, P0.
        imm.combine();
        Ok(imm)
    }

    /// One step: every mode updates with `z_k` (NaN entries missing, all NaN a predict-only
    /// step), the mode probabilities and the combined estimate are formed, the modes are
    /// mixed and predict to k + 1 with `u_k`. Allocates nothing.
    ///
    /// # Errors
    /// A mode's error ([`Error::Shape`] naming `z` or `u`, [`Error::Diverged`], …; the IMM
    /// is then unusable: build a new one); [`Error::Factorisation`] naming `mu` if no
    /// mode gives `z_k` a positive likelihood.
    pub fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<ImmStep, Error> {
        self.step_inner(z, u, None)
    }

    pub(crate) fn step_inner(
        &mut self,
        z: &[f64],
        u: Option<&[f64]>,
        rec: Option<&mut ImmRecord>,
    ) -> Result<ImmStep, Error> {
        let r = self.s.r;
        let mut observed = 0;
        for j in 0..r {
            let info = self.modes[j].mode_update(z)?;
            self.ll[j] = info.log_likelihood;
            observed = info.observed;
            self.infos[j] = info;
        }
        // μ_j ∝ c_j e^{ℓ_j}, in logarithms.
        let top = (0..r)
            .filter(|&j| self.cbar[j] > 0.0)
            .map(|j| self.ll[j])
            .fold(f64::NEG_INFINITY, f64::max);
        let mut sum = 0.0;
        for j in 0..r {
            self.mu[j] = if self.cbar[j] > 0.0 {
                self.cbar[j] * (self.ll[j] - top).exp()
            } else {
                0.0
            };
            sum += self.mu[j];
        }
        if !(sum > 0.0 && sum.is_finite() && top.is_finite()) {
            return Err(Error::Factorisation {
                name: "mu",
                reason: "no mode gives the measurement a positive finite likelihood",
            });
        }
        for v in &mut self.mu {
            *v /= sum;
        }
        let log_likelihood = if observed == 0 { 0.0 } else { top + sum.ln() };
        self.combine();
        if let Some(rec) = rec {
            rec.begin(self);
            for j in 0..r {
                self.modes[j].mode_predict(u)?;
                rec.push_mode(&*self.modes[j], self.s.n(j));
            }
        }
        self.mix();
        for j in 0..r {
            self.modes[j].mode_predict(u)?;
            self.modes[j].mode_advance(self.infos[j]);
        }
        self.last = ImmStep {
            step: self.k,
            log_likelihood,
            observed,
        };
        self.k += 1;
        Ok(self.last)
    }

    /// The combined estimate from the modes' posteriors and μ.
    fn combine(&mut self) {
        let nc = self.s.nc;
        Moments::clear(&mut self.x, &mut self.P);
        for pass in 0..2 {
            for i in 0..self.s.r {
                self.s.lift(
                    i,
                    self.modes[i].mode_posterior(),
                    &mut self.ex,
                    &mut self.ep,
                );
                let (ex, ep) = (&self.ex[..nc], &self.ep[..nc * nc]);
                if pass == 0 {
                    Moments::add_mean(self.mu[i], ex, &mut self.x);
                } else {
                    Moments::add_spread(self.mu[i], (ex, ep), &self.x, &mut self.P);
                }
            }
        }
        Moments::finish(&mut self.P);
    }

    /// Mixing: c_{k+1}, ω, the mixed estimates, written into the modes' posteriors.
    fn mix(&mut self) {
        let r = self.s.r;
        mixing_probabilities(&self.s.pi, &self.mu, &mut self.cbar, &mut self.omega);
        for j in 0..r {
            let nj = self.s.n(j);
            let (o, op) = (self.off[j], self.offp[j]);
            let xm = &mut self.xm[o..o + nj];
            let pm = &mut self.pm[op..op + nj * nj];
            if self.cbar[j] <= 0.0 {
                let (x, P) = self.modes[j].mode_posterior();
                xm.copy_from_slice(x);
                pm.copy_from_slice(P);
                continue;
            }
            Moments::clear(xm, pm);
            for pass in 0..2 {
                for i in 0..r {
                    let w = self.omega[i + j * r];
                    if w <= 0.0 {
                        continue;
                    }
                    self.s.project(
                        i,
                        self.modes[i].mode_posterior(),
                        j,
                        self.modes[j].mode_posterior(),
                        &mut self.ex[..nj],
                        &mut self.ep[..nj * nj],
                    );
                    let (ex, ep) = (&self.ex[..nj], &self.ep[..nj * nj]);
                    if pass == 0 {
                        Moments::add_mean(w, ex, xm);
                    } else {
                        Moments::add_spread(w, (ex, ep), xm, pm);
                    }
                }
            }
            Moments::finish(pm);
        }
        for j in 0..r {
            let nj = self.s.n(j);
            let (o, op) = (self.off[j], self.offp[j]);
            let (x, P) = self.modes[j].mode_posterior_mut();
            x.copy_from_slice(&self.xm[o..o + nj]);
            P.copy_from_slice(&self.pm[op..op + nj * nj]);
        }
    }

    /// Number of modes r.
    pub fn modes(&self) -> usize {
        self.s.r
    }
    /// The common dimension n_c.
    pub fn common_dim(&self) -> usize {
        self.s.nc
    }
    /// Measurements per step m.
    pub fn measurements(&self) -> usize {
        self.m
    }
    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.k
    }
    /// What the last step produced.
    pub fn last_step(&self) -> ImmStep {
        self.last
    }
    /// μ_k, the mode probabilities after step k (before the first step: μ0).
    pub fn mode_probabilities(&self) -> &[f64] {
        &self.mu
    }
    /// `c_{k+1}`, the predicted mode probabilities of the next step.
    pub fn predicted_mode_probabilities(&self) -> &[f64] {
        &self.cbar
    }
    /// The combined `x_{k|k}` in the common state.
    pub fn state(&self) -> &[f64] {
        &self.x
    }
    /// The combined `P_{k|k}`.
    pub fn covariance(&self) -> MatRef<'_, f64> {
        let nc = self.s.nc;
        MatRef::from_column_major_slice(&self.P, nc, nc)
    }
    /// Mode j's prior for the next step `x^j_{k+1|k}` (in its own state).
    ///
    /// # Panics
    /// If `j ≥ r` (an index, not user data).
    pub fn mode_predicted_state(&self, j: usize) -> &[f64] {
        self.modes[j].mode_prior().0
    }
    /// Mode j's mixed posterior of the last step, `x^{0j}_{k|k}` (the start of its
    /// prediction; the mode-matched `x^j_{k|k}` is not kept after mixing).
    ///
    /// # Panics
    /// If `j ≥ r`.
    pub fn mode_mixed_state(&self, j: usize) -> &[f64] {
        self.modes[j].mode_posterior().0
    }
}
