//! Nonlinear estimation: the extended Kalman filter (one or iterated Gauss–Newton updates),
//! the unscented Kalman filter (Merwe's scaled and the cubature sigma-point sets), and the
//! extended and unscented Rauch–Tung–Striebel smoothers over a recorded forward pass.
//!
//! # Model
//! ```text
//! x_{k+1} = f(x_k, u_k, k) + w_k,     z_k = h(x_k, k) + v_k,
//! cov(w_k) = Q_k,   cov(v_k) = R_k   (both may vary with k),
//! ```
//! written as a [`NonlinearModel`] (or from closures with [`FnModel`]). The step semantics
//! are the linear filter's: `(x0, P0)` is the prior of the first measurement and step `k`
//! updates with `z_k`, then predicts to `k + 1` with `u_k`. Wrapped quantities (angles) are
//! handled by the model's [`NonlinearModel::residual`] (z − ẑ),
//! [`NonlinearModel::state_add`] (x ⊕ δ) and [`NonlinearModel::state_residual`] (x ⊖ y),
//! as FilterPy's `residual_z`, `x_add` and `residual_x` do.
//!
//! # States on manifolds
//! A state that is not a vector — a unit quaternion of attitude, an angle, products of them
//! with vectors — is a [`Manifold`] ([`Product`] of [`Part`]s, or a type of one's own) given
//! to the model ([`FnModel::with_manifold`], or [`NonlinearModel::manifold_dims`] with the
//! two state hooks). The mean is then a stored point (4 numbers for a quaternion) and P, Q
//! and the Jacobians live in the tangent space at it (3 dimensions), the error-state form:
//! sigma points are drawn as `x ⊞ L ξ_i`, means and corrections go through `⊞`/`⊟`, and
//! every estimate stays on the manifold (a quaternion of unit norm to round-off after every
//! step). The dimensions say both sizes: `FixedDims::<6, M, P, 7>` or
//! `DynDims::new(6, m, p)?.with_stored(7)?` for a quaternion and a gyro bias. The EKF
//! takes tangent Jacobians (by hand, or [`CentralDiff`], which perturbs through `⊞`;
//! `AutoDiff` differentiates vector states only), the smoothers run on the manifold with
//! [`NonlinearRts::smooth_on`] and [`FixedLag::with_manifold`], and the IMM mixes vector
//! states only (a manifold mode is refused).
//!
//! Dynamics in continuous time over a record's own time stamps, `ẋ = a(x, u, t)`, are a
//! `ContinuousDynamics` wrapped in `TimeStamped` (feature `autodiff`): each step integrates
//! its interval by RK4, and `AutoDiff` differentiates the integrated map.
//!
//! # Jacobians (extended filters)
//! The [`Ekf`] needs the [`Jacobians`] of f and h, from one of three sources:
//! - written by hand: implement [`Jacobians`] for the model;
//! - exact, by forward-mode automatic differentiation: write f and h once, generic over the
//!   scalar, as a `GenericModel`, and wrap it in `AutoDiff` (feature `autodiff`, over the
//!   `num-dual` crate);
//! - approximate, by central differences: wrap any model in [`CentralDiff`] (step and
//!   truncation error documented there).
//!
//! # Filters
//! - [`Ekf`] with [`EkfUpdate::Extended`]: linearise h at the prediction, Joseph-form
//!   covariance update; f linearised at the filtered estimate for the prediction.
//! - [`Ekf`] with [`EkfUpdate::Iterated`]: the iterated EKF, whose measurement update is the
//!   Gauss–Newton iteration of the MAP problem
//!   `x_{i+1} = x⁻ ⊕ K_i (z − h(x_i) + H_i (x_i ⊖ x⁻))` (Bell and Cathey, "The iterated
//!   Kalman filter update as a Gauss–Newton method"), stopped at an iteration cap or when
//!   the step is below a relative tolerance; [`StepInfo::iterations`] reports the count.
//! - [`Ukf`]: the unscented filter with additive noise; the sigma points are redrawn from
//!   the predicted mean and covariance before each update (so Q is seen by the update and a
//!   linear model gives the linear filter exactly). The covariance update is Joseph-style
//!   with the statistically linearised measurement matrix H̃ = Cᵀ P⁻¹ and effective noise
//!   R̃ = Σ − Cᵀ P⁻¹ C: `P⁺ = (I − K H̃) P (I − K H̃)ᵀ + K R̃ Kᵀ`, equal to `P − K Σ Kᵀ` in
//!   exact arithmetic but kept symmetric PSD by its form. It is evaluated through the
//!   sigma points' factor P = L Lᵀ: with G = L⁻¹ C, `(I − K H̃) L = L − K Gᵀ` and
//!   R̃ = Σ − Gᵀ G, so `P⁺ = (L − K Gᵀ)(L − K Gᵀ)ᵀ + K R̃ Kᵀ` (no P⁻¹, no n³ product).
//!
//! All filters skip NaN rows of z (an all-NaN z is a predict-only step), report the
//! normalised innovation squared and the Gaussian log-likelihood ([`StepInfo`]), run on the
//! [`crate::FixedDims`] path without allocating per step and on the [`crate::DynDims`] path with
//! heap buffers sized once. A non-finite f, h, Jacobian, Q or R, a sigma-point covariance
//! that is not PSD, or a singular innovation covariance is a typed [`crate::Error`] naming
//! the step.
//!
//! # Example
//! ```
//! use kalman::FixedDims;
//! use kalman::nonlinear::{CentralDiff, Ekf, EkfUpdate, FnModel, SigmaPoints, Ukf};
//! # fn main() -> Result<(), kalman::Error> {
//! // A pendulum: x = (θ, ω), sin θ measured.
//! let dt = 0.05;
//! let model = FnModel::new(
//!     FixedDims::<2, 1>::new(),
//!     move |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
//!         out[0] = x[0] + dt * x[1];
//!         out[1] = x[1] - dt * 9.81 * x[0].sin();
//!     },
//!     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0].sin(),
//!     &[[1e-6, 0.0], [0.0, 1e-4]],
//!     &[[1e-3]],
//! )?;
//! let mut ukf = Ukf::new(FixedDims::<2, 1>::new(), model.clone(), &[0.5, 0.0],
//!     &[[0.1, 0.0], [0.0, 0.1]], SigmaPoints::merwe(1e-3, 2.0, 0.0))?;
//! let ekf_model = CentralDiff::new(FixedDims::<2, 1>::new(), model);
//! let mut ekf = Ekf::new(FixedDims::<2, 1>::new(), ekf_model, &[0.5, 0.0],
//!     &[[0.1, 0.0], [0.0, 0.1]], EkfUpdate::Extended)?;
//! for z in [0.45, 0.44, f64::NAN, 0.39] {
//!     let a = ukf.step(&[z], None)?;
//!     let b = ekf.step(&[z], None)?;
//!     assert_eq!(a.nis.is_some(), z.is_finite());
//!     assert!((ukf.state()[0] - ekf.state()[0]).abs() < 0.05 && b.iterations <= 1);
//! }
//! # Ok(())
//! # }
//! ```
#![allow(non_snake_case)]

/// The accessors the EKF and the UKF share, over their `model` and `c` ([`Core`]) fields.
macro_rules! filter_accessors {
    () => {
        /// The model.
        pub fn model(&self) -> &M {
            &self.model
        }
        /// The model, mutable (e.g. to change a parameter between steps).
        pub fn model_mut(&mut self) -> &mut M {
            &mut self.model
        }
        /// Steps taken.
        pub fn steps(&self) -> usize {
            self.c.k
        }
        /// What the last step produced.
        pub fn last_step(&self) -> StepInfo {
            self.c.info
        }
        /// `x_{k|k}` after step k (before the first step: `x0`); a stored point for a
        /// state on a manifold.
        pub fn state(&self) -> &[f64] {
            &self.c.xf.as_slice()[..self.c.dims.stored()]
        }
        /// `P_{k|k}` (n×n; in the tangent space at the state for a state on a manifold).
        pub fn covariance(&self) -> MatRef<'_, f64> {
            let n = self.c.dims.n();
            MatRef::from_column_major_slice(&self.c.pf.as_slice()[..n * n], n, n)
        }
        /// `x_{k+1|k}`.
        pub fn predicted_state(&self) -> &[f64] {
            &self.c.xp.as_slice()[..self.c.dims.stored()]
        }
        /// `P_{k+1|k}`.
        pub fn predicted_covariance(&self) -> MatRef<'_, f64> {
            let n = self.c.dims.n();
            MatRef::from_column_major_slice(&self.c.pp.as_slice()[..n * n], n, n)
        }
    };
}

/// [`ForwardPass::filtered`] and [`ForwardPass::predicted`] for the EKF and the UKF, over
/// their `c` ([`Core`]) field.
macro_rules! forward_pass_moments {
    () => {
        fn filtered(&self) -> (&[f64], &[f64]) {
            let (n, s) = (self.c.dims.n(), self.c.dims.stored());
            (&self.c.xf.as_slice()[..s], &self.c.pf.as_slice()[..n * n])
        }
        fn predicted(&self) -> (&[f64], &[f64]) {
            let (n, s) = (self.c.dims.n(), self.c.dims.stored());
            (&self.c.xp.as_slice()[..s], &self.c.pp.as_slice()[..n * n])
        }
    };
}

#[cfg(feature = "autodiff")]
mod autodiff;
#[cfg(feature = "autodiff")]
mod continuous;
mod ekf;
mod fixed_lag;
mod imm_mode;
pub(crate) mod linalg;
mod manifold;
mod models;
mod sigma;
mod smoother;
mod sqrt_ukf;
mod ukf;
mod unscented;

#[cfg(feature = "autodiff")]
pub use autodiff::{AutoDiff, GenericModel, Scalar};
#[cfg(feature = "autodiff")]
pub use continuous::{
    ContinuousDynamics, DEFAULT_MAX_SUBSTEP, MAX_CONTINUOUS_STATES, MAX_SUBSTEPS, TimeStamped,
};
pub use ekf::{Ekf, EkfUpdate};
pub use fixed_lag::{FixedLag, FixedLagState};
pub use manifold::{Manifold, Part, Product, quaternion};
pub use models::{CentralDiff, FnModel, Hook, Jacobians, NonlinearModel};
pub use sigma::SigmaPoints;
pub use smoother::{ForwardPass, NonlinearRts, NonlinearStep};
pub use sqrt_ukf::SqrtUkf;
pub use ukf::Ukf;

use crate::kernels::LN_2PI;
use crate::storage::sealed::Arr;
use crate::storage::{Buf, Dims, DynDims, FixedDims};

/// What one nonlinear step produced: the linear filter's [`crate::StepInfo`], with `rank`
/// equal to `observed` (the nonlinear updates have no pseudo-inverse path) and `iterations`
/// the measurement linearisations done.
pub use crate::StepInfo;

/// Storage of the nonlinear filters: the linear engine's buffers plus the sigma-point
/// arrays. Implemented for [`DynDims`] and [`FixedDims`] (where the sigma arrays are sized for the
/// largest fixed model, 2·16 + 1 points, and used with a leading dimension).
pub trait NlDims: Dims {
    /// n×(2n+1) buffers (sigma points in state space).
    type Sig: Buf<f64>;
    /// m×(2n+1) buffers (sigma points in measurement space).
    type ZSig: Buf<f64>;
    /// (2n+1)-vectors (weights).
    type W: Buf<f64>;
    /// Stored states ([`Dims::stored`] entries; n for a vector state).
    type Sv: Buf<f64>;
    /// stored×(2n+1) buffers (sigma points as stored states).
    type SSig: Buf<f64>;
}

impl NlDims for DynDims {
    type Sig = Vec<f64>;
    type ZSig = Vec<f64>;
    type W = Vec<f64>;
    type Sv = Vec<f64>;
    type SSig = Vec<f64>;
}

impl<const N: usize, const M: usize, const P: usize, const S: usize> NlDims
    for FixedDims<N, M, P, S>
{
    type Sig = Arr<f64, N, 33>;
    type ZSig = Arr<f64, M, 33>;
    type W = Arr<f64, 33, 1>;
    type Sv = Arr<f64, S, 1>;
    type SSig = Arr<f64, S, 33>;
}

/// [`crate::Error::ModelNonFinite`] for the first non-finite entry of `v`.
#[inline(always)]
fn finite(function: &'static str, step: usize, v: &[f64]) -> Result<(), crate::Error> {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(index) => Err(crate::Error::ModelNonFinite {
            function,
            step,
            index,
        }),
    }
}

/// Filter state shared by the extended and unscented filters.
#[derive(Clone, Debug)]
struct Core<D: NlDims> {
    dims: D,
    k: usize,
    /// `x_{k+1|k}`, `P_{k+1|k}` (before the first step: `x0`, `P0`); the means are
    /// stored states ([`Dims::stored`] entries), the covariances tangent (n×n).
    xp: D::Sv,
    pp: D::Nn,
    /// `x_{k|k}`, `P_{k|k}`.
    xf: D::Sv,
    pf: D::Nn,
    q: D::Nn,
    r: D::Mm,
    info: StepInfo,
}

/// A nonlinear filter's step is its update with `z_k`, then its prediction with `u_k`; the
/// step counter advances only when both succeed. Written once here for the EKF and the UKF.
trait Stages<D: NlDims> {
    fn core(&mut self) -> &mut Core<D>;
    fn update_stage(&mut self, z: &[f64]) -> Result<StepInfo, crate::Error>;
    fn predict_stage(&mut self, u: Option<&[f64]>) -> Result<(), crate::Error>;

    fn run_step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, crate::Error> {
        self.core().check_z(z)?;
        let info = self.update_stage(z)?;
        self.predict_stage(u)?;
        let c = self.core();
        c.info = info;
        c.k += 1;
        Ok(info)
    }
}

/// An update stage that is an update with the mo ≥ 1 rows z observes, for the unscented
/// filters.
trait ObservedUpdate<D: NlDims>: Stages<D> {
    /// The update with `mo` ≥ 1 observed rows, reporting into `info`.
    fn update_observed(
        &mut self,
        z: &[f64],
        mo: usize,
        info: StepInfo,
    ) -> Result<StepInfo, crate::Error>;

    /// The update with z_k, opened as `info` ([`Core::open_update`]): with no row observed
    /// `info` is the result. The usual case, every row observed, gets its own copy of
    /// [`ObservedUpdate::update_observed`] in which mo is the constant m on the fixed-size
    /// path: its loops and copies unroll.
    #[inline(always)]
    fn update_rows(&mut self, z: &[f64], info: StepInfo) -> Result<StepInfo, crate::Error> {
        let m = self.core().dims.m();
        match info.observed {
            0 => Ok(info),
            mo if mo == m => self.update_observed(z, m, info),
            mo => self.update_observed(z, mo, info),
        }
    }
}

/// `info` completed by an update whose innovation has the normalised square `nis`
/// (`eᵀ Σ⁻¹ e`) and `ln det Σ` = `logdet` after `iterations` linearisations: the Gaussian
/// log-likelihood of the rows observed.
#[inline(always)]
fn observed_info(mut info: StepInfo, nis: f64, logdet: f64, iterations: usize) -> StepInfo {
    info.nis = Some(nis);
    info.log_likelihood = -0.5 * (nis + logdet + info.observed as f64 * LN_2PI);
    info.iterations = iterations;
    info
}

/// The update's workspaces that the EKF and the UKF share: the gain (or the UKF's
/// cross-covariance before it becomes the gain), R and Σ with the reciprocals of its factor's
/// diagonal, the innovation, and the Joseph form's scratch.
#[derive(Clone, Debug)]
struct UpdateWork<D: NlDims> {
    gain: D::Nm,
    rc: D::Mm,
    sig: D::Mm,
    /// Reciprocals of the diagonal of the factor of Σ (in `sig`).
    sinv: D::Mv,
    e: D::Mv,
    tmpm: D::Mv,
    dx: D::Nv,
    a: D::Nn,
    t: D::Nn,
    kr: D::Nm,
}

impl<D: NlDims> UpdateWork<D> {
    fn new(n: usize, m: usize) -> Self {
        Self {
            gain: D::Nm::zeros(n * m),
            rc: D::Mm::zeros(m * m),
            sig: D::Mm::zeros(m * m),
            sinv: D::Mv::zeros(m),
            e: D::Mv::zeros(m),
            tmpm: D::Mv::zeros(m),
            dx: D::Nv::zeros(n),
            a: D::Nn::zeros(n * n),
            t: D::Nn::zeros(n * n),
            kr: D::Nm::zeros(n * m),
        }
    }
}

impl<D: NlDims> Core<D> {
    /// The prior `(x0, P0)` for `model`. For a state on a manifold `x0` is a stored point,
    /// projected onto the manifold (`x0 ⊞ 0`: a quaternion normalised).
    fn new<M: NonlinearModel + ?Sized>(
        dims: D,
        model: &M,
        x0: &[f64],
        P0: &impl crate::MatrixInput,
    ) -> Result<Self, crate::Error> {
        let (n, m, ns) = (dims.n(), dims.m(), dims.stored());
        if dims.is_fixed() && (n > crate::FIXED_MAX || m > crate::FIXED_MAX) {
            return Err(crate::Error::Dimension {
                name: "n",
                value: n.max(m),
                rule: "the fixed-size path holds n, m <= 16",
            });
        }
        match model.manifold_dims() {
            Some((tangent, stored)) if (tangent, stored) != (n, ns) => {
                return Err(crate::Error::Dimension {
                    name: if tangent != n { "n" } else { "stored" },
                    value: if tangent != n { n } else { ns },
                    rule: "the filter's n and stored length must be the model's manifold's \
                           tangent dimension and stored length",
                });
            }
            None if ns != n => {
                return Err(crate::Error::Dimension {
                    name: "stored",
                    value: ns,
                    rule: "a model without a manifold has a vector state: stored length = n",
                });
            }
            _ => {}
        }
        let mut xp = D::Sv::zeros(ns);
        let mut pp = D::Nn::zeros(n * n);
        crate::model::load_vec("x0", x0, ns, xp.as_mut_slice())?;
        if model.manifold_dims().is_some() {
            let x = xp.as_slice()[..ns].to_vec();
            model.state_add(&x, &vec![0.0; n], &mut xp.as_mut_slice()[..ns]);
            finite("x0 ⊞ 0", 0, &xp.as_slice()[..ns])?;
        }
        crate::model::load("P0", P0, n, n, pp.as_mut_slice())?;
        let mut factor = vec![0.0; n * n];
        crate::model::checked_factor("P0", pp.as_mut_slice(), n, &mut factor)?;
        Ok(Self {
            dims,
            k: 0,
            xf: xp.clone(),
            pf: pp.clone(),
            xp,
            pp,
            q: D::Nn::zeros(n * n),
            r: D::Mm::zeros(m * m),
            info: StepInfo::default(),
        })
    }

    fn check_z(&self, z: &[f64]) -> Result<(), crate::Error> {
        let m = self.dims.m();
        if z.len() != m {
            return Err(crate::Error::Shape {
                name: "z",
                rows: z.len(),
                cols: 1,
                expected_rows: m,
                expected_cols: 1,
            });
        }
        Ok(())
    }

    /// Loads `R_k` (checked finite, symmetrised) and returns the number of observed rows.
    fn load_r<M: NonlinearModel + ?Sized>(
        &mut self,
        model: &mut M,
        z: &[f64],
    ) -> Result<usize, crate::Error> {
        let m = self.dims.m();
        let r = &mut self.r.as_mut_slice()[..m * m];
        model.r(self.k, r);
        finite("R", self.k, r)?;
        linalg::symmetrise(r, m);
        Ok(z.iter().filter(|v| !v.is_nan()).count())
    }

    /// Opens the update with `z_k`: loads `R_k` and starts the step's report with the rows
    /// z observes. With none observed (an all-NaN z: a predict-only step) the filtered
    /// moments are the predicted ones.
    #[inline(always)]
    fn open_update<M: NonlinearModel + ?Sized>(
        &mut self,
        model: &mut M,
        z: &[f64],
    ) -> Result<StepInfo, crate::Error> {
        let (n, ns) = (self.dims.n(), self.dims.stored());
        let mo = self.load_r(model, z)?;
        if mo == 0 {
            self.xf.as_mut_slice()[..ns].copy_from_slice(&self.xp.as_slice()[..ns]);
            self.pf.as_mut_slice()[..n * n].copy_from_slice(&self.pp.as_slice()[..n * n]);
        }
        Ok(StepInfo {
            step: self.k,
            observed: mo,
            rank: mo,
            ..StepInfo::default()
        })
    }

    /// The `mo`×`mo` block of `R_k` on the rows z observes into `dst` (a copy when every
    /// row is observed).
    #[inline(always)]
    fn observed_r(&self, z: &[f64], mo: usize, dst: &mut [f64]) {
        let m = self.dims.m();
        if mo == m {
            dst[..m * m].copy_from_slice(&self.r.as_slice()[..m * m]);
        } else {
            compact_square(self.r.as_slice(), m, z, mo, dst);
        }
    }

    /// Loads `Q_k` (checked finite, symmetrised).
    fn load_q<M: NonlinearModel + ?Sized>(&mut self, model: &mut M) -> Result<(), crate::Error> {
        let n = self.dims.n();
        let q = &mut self.q.as_mut_slice()[..n * n];
        model.q(self.k, q);
        finite("Q", self.k, q)?;
        linalg::symmetrise(q, n);
        Ok(())
    }

    fn reset<M: NonlinearModel + ?Sized>(
        &mut self,
        model: &M,
        x0: &[f64],
        P0: &impl crate::MatrixInput,
    ) -> Result<(), crate::Error> {
        let fresh = Self::new(self.dims, model, x0, P0)?;
        *self = fresh;
        Ok(())
    }
}

/// Copies the rows `i` of the `rows`×`cols` matrix `src` where `z_i` is not NaN into the
/// compact `mo`×`cols` matrix `dst` (`mo` = number of such rows).
#[inline(always)]
fn compact_rows(src: &[f64], rows: usize, cols: usize, z: &[f64], mo: usize, dst: &mut [f64]) {
    for j in 0..cols {
        let mut r = 0;
        for i in 0..rows {
            if !z[i].is_nan() {
                dst[r + j * mo] = src[i + j * rows];
                r += 1;
            }
        }
    }
}

/// The observed-rows-and-columns block of the `m`×`m` matrix `src` into `dst` (`mo`×`mo`).
#[inline(always)]
fn compact_square(src: &[f64], m: usize, z: &[f64], mo: usize, dst: &mut [f64]) {
    let mut c = 0;
    for j in 0..m {
        if z[j].is_nan() {
            continue;
        }
        let mut r = 0;
        for i in 0..m {
            if !z[i].is_nan() {
                dst[r + c * mo] = src[i + j * m];
                r += 1;
            }
        }
        c += 1;
    }
}

/// The non-NaN entries of `v` (indexed by the rows of `z`), in order, into `dst`.
#[inline(always)]
fn compact_vec(v: &[f64], z: &[f64], dst: &mut [f64]) {
    let mut r = 0;
    for (vi, zi) in v.iter().zip(z) {
        if !zi.is_nan() {
            dst[r] = *vi;
            r += 1;
        }
    }
}
