//! The nonlinear model traits, the closure-built model and Jacobians by central
//! differences.
#![allow(non_snake_case)]

use std::sync::Arc;

use super::{Ekf, EkfUpdate, Manifold, NlDims, SigmaPoints, SqrtUkf, Ukf};
use crate::Error;
use crate::model::{MatrixInput, checked_factor, load};
use crate::storage::{Dims, DynDims};

/// `out = a − b` entry by entry: the default residual and state difference.
#[inline]
pub(crate) fn difference(a: &[f64], b: &[f64], out: &mut [f64]) {
    for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
        *o = x - y;
    }
}

/// `out = x + δ` entry by entry: the default state addition.
#[inline]
pub(crate) fn sum(x: &[f64], dx: &[f64], out: &mut [f64]) {
    for ((o, a), b) in out.iter_mut().zip(x).zip(dx) {
        *o = a + b;
    }
}

/// The measurement residual, state addition and state difference of a model trait, as
/// provided methods: the entry-by-entry forms, which a model overrides to wrap angles.
macro_rules! default_hooks {
    () => {
        /// The measurement residual `a − b` (override to wrap angles); `out` has length m.
        fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
            $crate::nonlinear::models::difference(a, b, out);
        }
        /// The state addition `x ⊕ δ` (override to wrap angles); `out` has length n.
        fn state_add(&self, x: &[f64], dx: &[f64], out: &mut [f64]) {
            $crate::nonlinear::models::sum(x, dx, out);
        }
        /// The state difference `a ⊖ b` (override to wrap angles); `out` has length n.
        fn state_residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
            $crate::nonlinear::models::difference(a, b, out);
        }
    };
}
#[cfg(feature = "autodiff")]
pub(crate) use default_hooks;

/// The measurement residual, state addition and state difference forwarded to the wrapped
/// model in the field `$field`, for an implementation of a model trait over another.
macro_rules! forward_hooks {
    ($field:ident) => {
        fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
            self.$field.residual(a, b, out);
        }
        fn state_add(&self, x: &[f64], dx: &[f64], out: &mut [f64]) {
            self.$field.state_add(x, dx, out);
        }
        fn state_residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
            self.$field.state_residual(a, b, out);
        }
    };
}
// Named by path in `forward_model`, which expands in other modules too.
pub(crate) use forward_hooks;

/// A nonlinear state-space model `x_{k+1} = f(x_k, u_k, k) + w_k`, `z_k = h(x_k, k) + v_k`
/// with `cov(w_k) = Q_k`, `cov(v_k) = R_k`.
///
/// Matrices are written column-major into `out` (entry `(i, j)` at `out[i + j·rows]`);
/// vectors have length n (states) or m (measurements) as set by the filter's dimensions.
/// The methods take `&mut self` so that a model may keep workspaces (and closures may be
/// `FnMut`). The filters check every value for finiteness.
///
/// ```
/// use kalman::nonlinear::NonlinearModel;
/// /// A scalar random walk seen through z = x³.
/// struct Cube;
/// impl NonlinearModel for Cube {
///     fn f(&mut self, x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]) { out[0] = x[0]; }
///     fn h(&mut self, x: &[f64], _k: usize, out: &mut [f64]) { out[0] = x[0].powi(3); }
///     fn q(&mut self, _k: usize, out: &mut [f64]) { out[0] = 0.01; }
///     fn r(&mut self, _k: usize, out: &mut [f64]) { out[0] = 0.1; }
/// }
/// let mut z = [0.0];
/// Cube.h(&[2.0], 0, &mut z);
/// assert!((z[0] - 8.0).abs() < 1e-15);
/// ```
pub trait NonlinearModel {
    /// The transition `f(x, u, k)` (without noise) into `out` (length n). `u` is the
    /// control passed to the step, if any.
    fn f(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]);
    /// The measurement function `h(x, k)` into `out` (length m).
    fn h(&mut self, x: &[f64], k: usize, out: &mut [f64]);
    /// `Q_k` (n×n, symmetric PSD), the covariance of the noise of the step from k to k + 1.
    /// The filters use its symmetric part `(Q_k + Q_kᵀ)/2` (a `G Gᵀ` formed in floating
    /// point can differ from its transpose by round-off).
    fn q(&mut self, k: usize, out: &mut [f64]);
    /// `R_k` (m×m, symmetric PSD); as for `Q_k`, its symmetric part is used.
    fn r(&mut self, k: usize, out: &mut [f64]);
    default_hooks!();
    /// `Some((n, stored))` for a state on a manifold whose stored points are longer than
    /// its tangent dimension n (see [`super::Manifold`]): then `x` in f, h and the hooks is
    /// a stored point, `δ` and `a ⊖ b` are tangent vectors, Q and the Jacobians are
    /// tangent-space matrices (`∂(f(x ⊞ δ) ⊟ f(x))/∂δ`, `∂h(x ⊞ δ)/∂δ` at δ = 0), and the
    /// filter's dimensions must say the same ([`crate::Dims::stored`]). `None` (the
    /// default): a vector state of n entries.
    fn manifold_dims(&self) -> Option<(usize, usize)> {
        None
    }
}

/// The Jacobians of a [`NonlinearModel`], needed by the extended filters: written by hand,
/// from `AutoDiff` (feature `autodiff`) (exact) or from [`CentralDiff`].
///
/// ```
/// use kalman::nonlinear::{Jacobians, NonlinearModel};
/// struct Cube;
/// impl NonlinearModel for Cube {
///     fn f(&mut self, x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]) { out[0] = x[0]; }
///     fn h(&mut self, x: &[f64], _k: usize, out: &mut [f64]) { out[0] = x[0].powi(3); }
///     fn q(&mut self, _k: usize, out: &mut [f64]) { out[0] = 0.01; }
///     fn r(&mut self, _k: usize, out: &mut [f64]) { out[0] = 0.1; }
/// }
/// impl Jacobians for Cube {
///     fn f_jacobian(&mut self, _x: &[f64], _u: Option<&[f64]>, _k: usize, jac: &mut [f64]) { jac[0] = 1.0; }
///     fn h_jacobian(&mut self, x: &[f64], _k: usize, jac: &mut [f64]) { jac[0] = 3.0 * x[0] * x[0]; }
/// }
/// let mut j = [0.0];
/// Cube.h_jacobian(&[2.0], 0, &mut j);
/// assert!((j[0] - 12.0).abs() < 1e-15);
/// ```
pub trait Jacobians: NonlinearModel {
    /// `∂f/∂x` at `(x, u, k)`, n×n column-major (`jac[i + j·n] = ∂f_i/∂x_j`).
    fn f_jacobian(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, jac: &mut [f64]);
    /// `∂h/∂x` at `(x, k)`, m×n column-major (`jac[i + j·m] = ∂h_i/∂x_j`).
    fn h_jacobian(&mut self, x: &[f64], k: usize, jac: &mut [f64]);
}

/// A model from two closures and constant Q, R (validated symmetric PSD at construction).
///
/// `f: FnMut(x, u, k, out)`, `h: FnMut(x, k, out)`. Wrap it in [`CentralDiff`] for the
/// extended filters.
///
/// ```
/// use kalman::DynDims;
/// use kalman::nonlinear::{FnModel, NonlinearModel};
/// # fn main() -> Result<(), kalman::Error> {
/// let mut model = FnModel::new(
///     DynDims::new(1, 1, 0)?,
///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = 0.9 * x[0],
///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0].exp(),
///     &[[0.1]],
///     &[[0.2]],
/// )?;
/// let mut r = [0.0];
/// model.r(0, &mut r);
/// assert!((r[0] - 0.2).abs() < 1e-15);
/// # Ok(())
/// # }
/// ```
#[derive(Clone)]
pub struct FnModel<F, H, D = DynDims> {
    dims: D,
    f: F,
    h: H,
    q: Vec<f64>,
    r: Vec<f64>,
    hooks: Hooks,
    manifold: Option<Arc<dyn Manifold + Send + Sync>>,
}

/// A residual, state difference or state addition: `(a, b, out)`.
pub type Hook = fn(&[f64], &[f64], &mut [f64]);

/// The [`FnModel`]'s residual, state difference and state addition (entry by entry unless
/// set).
#[derive(Clone, Copy)]
struct Hooks {
    residual: Hook,
    state_residual: Hook,
    state_add: Hook,
}

impl Default for Hooks {
    fn default() -> Self {
        Self {
            residual: difference,
            state_residual: difference,
            state_add: sum,
        }
    }
}

impl<F, H, D: core::fmt::Debug> core::fmt::Debug for FnModel<F, H, D> {
    fn fmt(&self, fmt: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        fmt.debug_struct("FnModel")
            .field("dims", &self.dims)
            .field("q", &self.q)
            .field("r", &self.r)
            .finish_non_exhaustive()
    }
}

impl<F, H, D: Dims> FnModel<F, H, D>
where
    F: FnMut(&[f64], Option<&[f64]>, usize, &mut [f64]),
    H: FnMut(&[f64], usize, &mut [f64]),
{
    /// The model with transition `f`, measurement `h` and noise covariances `Q` (n×n) and
    /// `R` (m×m) for the dimensions `dims`.
    ///
    /// # Errors
    /// [`Error::Shape`], [`Error::NonFinite`], [`Error::NotSymmetric`] or
    /// [`Error::NotPositiveSemidefinite`] naming `Q` or `R`.
    pub fn new(
        dims: D,
        f: F,
        h: H,
        Q: &impl MatrixInput,
        R: &impl MatrixInput,
    ) -> Result<Self, Error> {
        let (n, m) = (dims.n(), dims.m());
        let mut q = vec![0.0; n * n];
        let mut r = vec![0.0; m * m];
        let mut work = vec![0.0; n.max(m) * n.max(m)];
        load_cov("Q", Q, n, &mut q, &mut work)?;
        load_cov("R", R, m, &mut r, &mut work)?;
        Ok(Self {
            dims,
            f,
            h,
            q,
            r,
            hooks: Hooks::default(),
            manifold: None,
        })
    }

    /// The model with the measurement residual `a − b` replaced by `residual(a, b, out)`:
    /// a bearing's wrapped difference, so that an innovation of 359° is −1°.
    ///
    /// ```
    /// use kalman::FixedDims;
    /// use kalman::nonlinear::{FnModel, NonlinearModel};
    /// use std::f64::consts::PI;
    /// # fn main() -> Result<(), kalman::Error> {
    /// let wrap = |a: &[f64], b: &[f64], out: &mut [f64]| {
    ///     out[0] = (a[0] - b[0] + PI).rem_euclid(2.0 * PI) - PI;
    /// };
    /// let model = FnModel::new(
    ///     FixedDims::<1, 1>::new(),
    ///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
    ///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0],
    ///     &[[1e-4]],
    ///     &[[1e-2]],
    /// )?
    /// .with_residual(wrap);
    /// let mut y = [0.0];
    /// model.residual(&[PI - 0.1], &[-PI + 0.1], &mut y);
    /// assert!((y[0] + 0.2).abs() < 1e-12);
    /// # Ok(())
    /// # }
    /// ```
    pub fn with_residual(mut self, residual: Hook) -> Self {
        self.hooks.residual = residual;
        self
    }

    /// The model with the state difference `a ⊖ b` and the state addition `x ⊕ δ` replaced
    /// (a heading state wrapped to (−π, π]): the unscented filters and smoothers form every
    /// spread and correction of the state through these two.
    pub fn with_state_hooks(mut self, state_residual: Hook, state_add: Hook) -> Self {
        self.hooks.state_residual = state_residual;
        self.hooks.state_add = state_add;
        self
    }

    /// The model with its state on the manifold `space`: f and h take stored points, Q
    /// (given to [`FnModel::new`]) is a tangent-space covariance, and the state addition
    /// and difference are `space`'s `⊞` and `⊟`. The filter's dimensions are then
    /// n = `space.dim()` with [`crate::Dims::stored`] = `space.stored()`.
    ///
    /// ```
    /// use kalman::{Dims, DynDims};
    /// use kalman::nonlinear::{FnModel, NonlinearModel, Part, Product};
    /// # fn main() -> Result<(), kalman::Error> {
    /// // An attitude held still, seen through its rotation of the vertical.
    /// let d = DynDims::new(3, 3, 0)?.with_stored(4)?;
    /// let model = FnModel::new(
    ///     d,
    ///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out.copy_from_slice(x),
    ///     |x: &[f64], _k: usize, out: &mut [f64]| {
    ///         use kalman::nonlinear::quaternion;
    ///         let g = quaternion::rotate_inverse([x[0], x[1], x[2], x[3]], [0.0, 0.0, 1.0]);
    ///         out.copy_from_slice(&g);
    ///     },
    ///     &[[1e-6, 0.0, 0.0], [0.0, 1e-6, 0.0], [0.0, 0.0, 1e-6]],
    ///     &[[1e-4, 0.0, 0.0], [0.0, 1e-4, 0.0], [0.0, 0.0, 1e-4]],
    /// )?
    /// .with_manifold(Product::new([Part::Quaternion]))?;
    /// assert_eq!(model.manifold_dims(), Some((d.n(), d.stored())));
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// [`Error::Dimension`] naming `manifold` if `space.dim()` is not the n of Q.
    pub fn with_manifold(
        mut self,
        space: impl Manifold + Send + Sync + 'static,
    ) -> Result<Self, Error> {
        let n = self.q.len().isqrt();
        if space.dim() != n {
            return Err(Error::Dimension {
                name: "manifold",
                value: space.dim(),
                rule: "a manifold's tangent dimension must be the model's n (Q is n×n)",
            });
        }
        self.manifold = Some(Arc::new(space));
        Ok(self)
    }
}

impl<F, H, D: NlDims> FnModel<F, H, D>
where
    F: FnMut(&[f64], Option<&[f64]>, usize, &mut [f64]),
    H: FnMut(&[f64], usize, &mut [f64]),
{
    /// The dimensions the model was built for.
    pub fn dims(&self) -> D {
        self.dims
    }

    /// The unscented filter of this model on its own dimensions, from the prior `(x0, P0)`
    /// with the sigma points `points`: [`Ukf::new`] without repeating the dimensions.
    ///
    /// ```
    /// use kalman::FixedDims;
    /// use kalman::nonlinear::{FnModel, SigmaPoints};
    /// # fn main() -> Result<(), kalman::Error> {
    /// let model = FnModel::new(
    ///     FixedDims::<1, 1>::new(),
    ///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
    ///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0],
    ///     &[[1.0]],
    ///     &[[1.0]],
    /// )?;
    /// let mut ukf = model.ukf(&[0.0], &[[1.0]], SigmaPoints::Cubature)?;
    /// ukf.step(&[2.0], None)?;
    /// assert!((ukf.state()[0] - 1.0).abs() < 1e-12);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// As [`Ukf::new`].
    pub fn ukf(
        self,
        x0: &[f64],
        P0: &impl MatrixInput,
        points: SigmaPoints,
    ) -> Result<Ukf<D, Self>, Error> {
        Ukf::new(self.dims, self, x0, P0, points)
    }

    /// The square-root unscented filter of this model on its own dimensions
    /// ([`SqrtUkf::new`]).
    ///
    /// # Errors
    /// As [`SqrtUkf::new`].
    pub fn sqrt_ukf(
        self,
        x0: &[f64],
        P0: &impl MatrixInput,
        points: SigmaPoints,
    ) -> Result<SqrtUkf<D, Self>, Error> {
        SqrtUkf::new(self.dims, self, x0, P0, points)
    }

    /// The extended filter of this model on its own dimensions, with Jacobians by
    /// [`CentralDiff`] ([`Ekf::new`]).
    ///
    /// # Errors
    /// As [`Ekf::new`].
    pub fn ekf(
        self,
        x0: &[f64],
        P0: &impl MatrixInput,
        update: EkfUpdate,
    ) -> Result<Ekf<D, CentralDiff<Self>>, Error> {
        let d = self.dims;
        Ekf::new(d, CentralDiff::new(d, self), x0, P0, update)
    }
}

/// Loads a d×d covariance, checks it symmetric PSD and symmetrises it.
fn load_cov(
    name: &'static str,
    a: &impl MatrixInput,
    d: usize,
    dst: &mut [f64],
    work: &mut [f64],
) -> Result<(), Error> {
    load(name, a, d, d, dst)?;
    checked_factor(name, dst, d, work)
}

impl<F, H, D> NonlinearModel for FnModel<F, H, D>
where
    F: FnMut(&[f64], Option<&[f64]>, usize, &mut [f64]),
    H: FnMut(&[f64], usize, &mut [f64]),
{
    fn f(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]) {
        (self.f)(x, u, k, out);
    }
    fn h(&mut self, x: &[f64], k: usize, out: &mut [f64]) {
        (self.h)(x, k, out);
    }
    fn q(&mut self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&self.q);
    }
    fn r(&mut self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&self.r);
    }
    fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        (self.hooks.residual)(a, b, out);
    }
    fn state_add(&self, x: &[f64], dx: &[f64], out: &mut [f64]) {
        match &self.manifold {
            Some(space) => space.boxplus(x, dx, out),
            None => (self.hooks.state_add)(x, dx, out),
        }
    }
    fn state_residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        match &self.manifold {
            Some(space) => space.boxminus(a, b, out),
            None => (self.hooks.state_residual)(a, b, out),
        }
    }
    fn manifold_dims(&self) -> Option<(usize, usize)> {
        self.manifold.as_ref().map(|s| (s.dim(), s.stored()))
    }
}

/// Jacobians of any [`NonlinearModel`] by central differences.
///
/// Column j of `∂f/∂x` is `(f(x + δ_j e_j) ⊖ f(x − δ_j e_j)) / (2δ_j)` (the model's
/// [`NonlinearModel::state_residual`]; for h its [`NonlinearModel::residual`]), with the
/// step `δ_j = s·max(1, |x_j|)` and the relative step `s = ε^{1/3} ≈ 6.06e-6` by default
/// (ε = `f64::EPSILON`), which balances the two error terms. Each entry's error is at most
///
/// `δ_j²/6 · max|∂³g_i/∂x_j³| + ε·max|g_i| / δ_j` (truncation + rounding)
///
/// about 6e-11 relative for a well-scaled g. Costs 2n evaluations of f (or h) per Jacobian.
///
/// ```
/// use kalman::DynDims;
/// use kalman::nonlinear::{CentralDiff, FnModel, Jacobians};
/// # fn main() -> Result<(), kalman::Error> {
/// let model = FnModel::new(
///     DynDims::new(1, 1, 0)?,
///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0].sin(),
///     &[[0.1]],
///     &[[0.2]],
/// )?;
/// let mut cd = CentralDiff::new(DynDims::new(1, 1, 0)?, model);
/// let mut j = [0.0];
/// cd.h_jacobian(&[0.3], 0, &mut j);
/// assert!((j[0] - 0.3_f64.cos()).abs() < 1e-9);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct CentralDiff<M> {
    model: M,
    step: f64,
    xs: Vec<f64>,
    plus: Vec<f64>,
    minus: Vec<f64>,
    diff: Vec<f64>,
    /// Manifold states: f(x), the tangent perturbation, and the two images' differences
    /// from f(x).
    centre: Vec<f64>,
    delta: Vec<f64>,
    up: Vec<f64>,
}

/// The default relative step of [`CentralDiff`], `f64::EPSILON^{1/3}`.
pub const CENTRAL_DIFF_STEP: f64 = 6.055_454_452_393_343e-6;

impl<M: NonlinearModel> CentralDiff<M> {
    /// Wraps `model` for the dimensions `dims` (workspaces are allocated here, not per
    /// step), with the default relative step ε^{1/3}.
    pub fn new(dims: impl Dims, model: M) -> Self {
        let k = dims.stored().max(dims.m());
        Self {
            model,
            step: CENTRAL_DIFF_STEP,
            xs: vec![0.0; dims.stored()],
            plus: vec![0.0; k],
            minus: vec![0.0; k],
            diff: vec![0.0; k],
            centre: vec![0.0; dims.stored()],
            delta: vec![0.0; dims.n()],
            up: vec![0.0; dims.n()],
        }
    }

    /// The same with relative step `s` (`δ_j = s·max(1, |x_j|)`).
    ///
    /// # Errors
    /// [`Error::InvalidOption`] unless `s` is finite and positive.
    pub fn with_step(mut self, s: f64) -> Result<Self, Error> {
        if !(s.is_finite() && s > 0.0) {
            return Err(Error::InvalidOption {
                name: "central-difference step",
                value: s,
                rule: "must be finite and positive",
            });
        }
        self.step = s;
        Ok(self)
    }

    /// The wrapped model.
    pub fn inner(&self) -> &M {
        &self.model
    }

    /// The wrapped model, mutable.
    pub fn inner_mut(&mut self) -> &mut M {
        &mut self.model
    }

    fn difference(
        &mut self,
        x: &[f64],
        rows: usize,
        jac: &mut [f64],
        mut eval: impl FnMut(&mut M, &[f64], &mut [f64]),
        state: bool,
    ) {
        let n = x.len();
        self.xs[..n].copy_from_slice(x);
        for j in 0..n {
            let d = self.step * x[j].abs().max(1.0);
            let (xp, xm) = (x[j] + d, x[j] - d);
            self.xs[j] = xp;
            eval(&mut self.model, &self.xs[..n], &mut self.plus[..rows]);
            self.xs[j] = xm;
            eval(&mut self.model, &self.xs[..n], &mut self.minus[..rows]);
            self.xs[j] = x[j];
            if state {
                self.model.state_residual(
                    &self.plus[..rows],
                    &self.minus[..rows],
                    &mut self.diff[..rows],
                );
            } else {
                self.model.residual(
                    &self.plus[..rows],
                    &self.minus[..rows],
                    &mut self.diff[..rows],
                );
            }
            let inv = 1.0 / (xp - xm);
            for i in 0..rows {
                jac[i + j * rows] = self.diff[i] * inv;
            }
        }
    }
}

/// Implements [`NonlinearModel`] for a Jacobian wrapper by forwarding every method to its
/// `model` field: the wrappers add derivatives, never change the dynamics.
macro_rules! forward_model {
    (impl<$p:ident: $bound:path> for $wrapper:ty $(, $manifold:ident)?) => {
        impl<$p: $bound> $crate::nonlinear::NonlinearModel for $wrapper {
            fn f(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]) {
                self.model.f(x, u, k, out);
            }
            fn h(&mut self, x: &[f64], k: usize, out: &mut [f64]) {
                self.model.h(x, k, out);
            }
            fn q(&mut self, k: usize, out: &mut [f64]) {
                self.model.q(k, out);
            }
            fn r(&mut self, k: usize, out: &mut [f64]) {
                self.model.r(k, out);
            }
            $crate::nonlinear::models::forward_hooks!(model);
            $(
                fn $manifold(&self) -> Option<(usize, usize)> {
                    self.model.$manifold()
                }
            )?
        }
    };
}
#[cfg(feature = "autodiff")]
pub(crate) use forward_model;

forward_model!(impl<M: NonlinearModel> for CentralDiff<M>, manifold_dims);

impl<M: NonlinearModel> CentralDiff<M> {
    /// The tangent-space Jacobian of a manifold state (n tangent, s stored): column j is
    /// `(g(x ⊞ δ e_j) ⊖ g(x ⊞ −δ e_j)) / 2δ` with `δ` the relative step itself (tangent
    /// coordinates have no scale of their own to multiply it by), the difference of f's
    /// images taken as `(y⁺ ⊟ f(x)) − (y⁻ ⊟ f(x))` in the tangent space at f(x), that of
    /// h's by the measurement residual.
    fn tangent_difference(
        &mut self,
        x: &[f64],
        (n, s): (usize, usize),
        rows: usize,
        jac: &mut [f64],
        mut eval: impl FnMut(&mut M, &[f64], &mut [f64]),
        state: bool,
    ) {
        let d = self.step;
        if state {
            eval(&mut self.model, x, &mut self.centre[..s]);
        }
        let out = if state { s } else { rows };
        for j in 0..n {
            self.delta[..n].fill(0.0);
            for (sign, image) in [(1.0, 0), (-1.0, 1)] {
                self.delta[j] = sign * d;
                self.model.state_add(x, &self.delta[..n], &mut self.xs[..s]);
                let y = if image == 0 {
                    &mut self.plus[..out]
                } else {
                    &mut self.minus[..out]
                };
                eval(&mut self.model, &self.xs[..s], y);
            }
            if state {
                self.model
                    .state_residual(&self.plus[..s], &self.centre[..s], &mut self.up[..n]);
                self.model
                    .state_residual(&self.minus[..s], &self.centre[..s], &mut self.diff[..n]);
                for i in 0..n {
                    jac[i + j * n] = (self.up[i] - self.diff[i]) / (2.0 * d);
                }
            } else {
                self.model.residual(
                    &self.plus[..rows],
                    &self.minus[..rows],
                    &mut self.diff[..rows],
                );
                for i in 0..rows {
                    jac[i + j * rows] = self.diff[i] / (2.0 * d);
                }
            }
        }
    }
}

impl<M: NonlinearModel> Jacobians for CentralDiff<M> {
    fn f_jacobian(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, jac: &mut [f64]) {
        if let Some(dims) = self.model.manifold_dims() {
            let n = dims.0;
            return self.tangent_difference(x, dims, n, jac, |m, x, out| m.f(x, u, k, out), true);
        }
        let n = x.len();
        self.difference(x, n, jac, |m, x, out| m.f(x, u, k, out), true);
    }
    fn h_jacobian(&mut self, x: &[f64], k: usize, jac: &mut [f64]) {
        if let Some(dims) = self.model.manifold_dims() {
            let rows = jac.len() / dims.0;
            return self.tangent_difference(x, dims, rows, jac, |m, x, out| m.h(x, k, out), false);
        }
        let rows = jac.len() / x.len();
        self.difference(x, rows, jac, |m, x, out| m.h(x, k, out), false);
    }
}
