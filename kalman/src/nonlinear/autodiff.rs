//! Exact Jacobians by forward-mode automatic differentiation (feature `autodiff`, over the
//! `num-dual` crate): f and h written once, generic over the scalar.

use num_dual::{Dual64, DualNum};

use super::Jacobians;
use super::models::{default_hooks, forward_model};
use crate::storage::Dims;

/// The scalars a [`GenericModel`] is evaluated with: `f64` for values, `num_dual::Dual64`
/// for derivatives. Arithmetic with `f64` operands, `T::from(c)` for constants and the
/// usual functions (`sin`, `cos`, `sqrt`, `atan2`, `powi`, …) are available.
pub trait Scalar: DualNum<Primitive = f64> + Copy {}

impl<T: DualNum<Primitive = f64> + Copy> Scalar for T {}

/// A nonlinear model with f and h generic over the scalar, for [`AutoDiff`]. Otherwise as
/// [`NonlinearModel`](super::NonlinearModel).
///
/// ```
/// use kalman::DynDims;
/// use kalman::nonlinear::{AutoDiff, GenericModel, Jacobians, Scalar};
/// /// Range and bearing of a planar position (x, y).
/// struct RangeBearing;
/// impl GenericModel for RangeBearing {
///     fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
///         out.copy_from_slice(x);
///     }
///     fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
///         out[0] = (x[0] * x[0] + x[1] * x[1]).sqrt();
///         out[1] = x[1].atan2(x[0]);
///     }
///     fn q(&self, _k: usize, out: &mut [f64]) { out.copy_from_slice(&[1e-2, 0.0, 0.0, 1e-2]); }
///     fn r(&self, _k: usize, out: &mut [f64]) { out.copy_from_slice(&[1e-2, 0.0, 0.0, 1e-4]); }
/// }
/// # fn main() -> Result<(), kalman::Error> {
/// let mut ad = AutoDiff::new(DynDims::new(2, 2, 0)?, RangeBearing);
/// let mut jac = [0.0; 4];
/// ad.h_jacobian(&[3.0, 4.0], 0, &mut jac);
/// // ∂r/∂x = x/r, ∂θ/∂x = −y/r² (column-major: jac[0], jac[1] are column x).
/// assert!((jac[0] - 0.6).abs() < 1e-15 && (jac[1] + 4.0 / 25.0).abs() < 1e-15);
/// # Ok(())
/// # }
/// ```
pub trait GenericModel {
    /// The transition `f(x, u, k)` into `out` (length n).
    fn f<T: Scalar>(&self, x: &[T], u: Option<&[f64]>, k: usize, out: &mut [T]);
    /// The measurement function `h(x, k)` into `out` (length m).
    fn h<T: Scalar>(&self, x: &[T], k: usize, out: &mut [T]);
    /// `Q_k` (n×n, column-major).
    fn q(&self, k: usize, out: &mut [f64]);
    /// `R_k` (m×m, column-major).
    fn r(&self, k: usize, out: &mut [f64]);
    default_hooks!();
}

/// A [`GenericModel`] with exact Jacobians by forward-mode automatic differentiation:
/// column j of a Jacobian is the derivative part of one evaluation with the dual seed
/// `e_j` (n evaluations per Jacobian, no truncation error). Workspaces are allocated at
/// construction; a Jacobian allocates nothing.
#[derive(Clone, Debug)]
pub struct AutoDiff<G> {
    model: G,
    xd: Vec<Dual64>,
    yd: Vec<Dual64>,
}

impl<G: GenericModel> AutoDiff<G> {
    /// Wraps `model` for the dimensions `dims`.
    pub fn new(dims: impl Dims, model: G) -> Self {
        Self {
            model,
            xd: vec![Dual64::from_re(0.0); dims.n()],
            yd: vec![Dual64::from_re(0.0); dims.n().max(dims.m())],
        }
    }

    /// The wrapped model.
    pub fn inner(&self) -> &G {
        &self.model
    }

    /// The wrapped model, mutable.
    pub fn inner_mut(&mut self) -> &mut G {
        &mut self.model
    }

    fn seed(&mut self, x: &[f64], j: usize) {
        for (i, (d, v)) in self.xd.iter_mut().zip(x).enumerate() {
            *d = Dual64::new(*v, if i == j { 1.0 } else { 0.0 });
        }
    }
}

forward_model!(impl<G: GenericModel> for AutoDiff<G>);

impl<G: GenericModel> Jacobians for AutoDiff<G> {
    fn f_jacobian(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, jac: &mut [f64]) {
        let n = x.len();
        for j in 0..n {
            self.seed(x, j);
            self.model.f(&self.xd[..n], u, k, &mut self.yd[..n]);
            for i in 0..n {
                jac[i + j * n] = self.yd[i].eps;
            }
        }
    }
    fn h_jacobian(&mut self, x: &[f64], k: usize, jac: &mut [f64]) {
        let n = x.len();
        let m = jac.len() / n;
        for j in 0..n {
            self.seed(x, j);
            self.model.h(&self.xd[..n], k, &mut self.yd[..m]);
            for i in 0..m {
                jac[i + j * m] = self.yd[i].eps;
            }
        }
    }
}
