//! The extended and unscented Rauch–Tung–Striebel smoothers over a recorded forward pass.
#![allow(non_snake_case)]

use faer::{Mat, MatRef};

use super::{Ekf, Jacobians, NlDims, NonlinearModel, SqrtUkf, StepInfo, Ukf};
use crate::Error;
use crate::smoother::{Nonlinear, Rts, Smoothed};

/// A nonlinear filter's step, for code generic over the [`Ekf`], the [`Ukf`] and the
/// [`SqrtUkf`] ([`NonlinearRts::run`]): each filter's own `step`.
pub trait NonlinearStep: ForwardPass {
    /// Step k: update with `z_k` (NaN entries missing), then predict with `u_k`.
    ///
    /// # Errors
    /// The filter's `step` errors.
    fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, Error>;
}

impl<D: NlDims, M: Jacobians> NonlinearStep for Ekf<D, M> {
    fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, Error> {
        Ekf::step(self, z, u)
    }
}

impl<D: NlDims, M: NonlinearModel> NonlinearStep for Ukf<D, M> {
    fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, Error> {
        Ukf::step(self, z, u)
    }
}

impl<D: NlDims, M: NonlinearModel> NonlinearStep for SqrtUkf<D, M> {
    fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, Error> {
        SqrtUkf::step(self, z, u)
    }
}

/// A filter whose steps a [`NonlinearRts`] can record: after step k it holds
/// `(x_{k|k}, P_{k|k})`, `(x_{k+1|k}, P_{k+1|k})` and the cross-covariance
/// `C_k = Cov(x_k, x_{k+1} | z_0..z_k)`. Matrices are column-major slices.
pub trait ForwardPass {
    /// `(x_{k|k}, P_{k|k})`.
    fn filtered(&self) -> (&[f64], &[f64]);
    /// `(x_{k+1|k}, P_{k+1|k})`.
    fn predicted(&self) -> (&[f64], &[f64]);
    /// `C_k` into `out` (n×n): `P_{k|k} F_kᵀ` for the [`super::Ekf`] (F_k the Jacobian of f
    /// at `x_{k|k}`), `Σ Wc_i (χ_i − x_{k|k})(f(χ_i) − x_{k+1|k})ᵀ` for the [`super::Ukf`].
    fn cross_covariance(&self, out: &mut [f64]);
}

/// The nonlinear Rauch–Tung–Striebel smoother ([`Rts`] of the [`Nonlinear`] family): recorded
/// from an [`super::Ekf`] it is the extended RTS smoother, from a [`super::Ukf`] the
/// unscented RTS smoother (Särkkä, "Unscented Rauch–Tung–Striebel smoother"): both run the
/// backward pass
///
/// `J_k = C_k P_{k+1|k}⁻¹`,  `x_{k|N} = x_{k|k} + J_k (x_{k+1|N} − x_{k+1|k})`,
/// `P_{k|N} = P_{k|k} + J_k (P_{k+1|N} − P_{k+1|k}) J_kᵀ`
///
/// with `J_k` from a Cholesky solve (the minimum-norm solution when `P_{k+1|k}` is
/// singular), and differ only in how the filter formed `C_k` ([`ForwardPass`]). In
/// [`Self::smooth`] differences are plain subtractions (the smoother does not hold the
/// model); [`Self::smooth_on`] runs the pass on the model's manifold (wrapped angles, unit
/// quaternions), and is the only pass for steps whose means are stored points longer than n.
///
/// ```
/// use kalman::DynDims;
/// use kalman::nonlinear::{FnModel, NonlinearRts, SigmaPoints, Ukf};
/// # fn main() -> Result<(), kalman::Error> {
/// let d = DynDims::new(1, 1, 0)?;
/// let model = FnModel::new(
///     d,
///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0],
///     &[[1.0]],
///     &[[1.0]],
/// )?;
/// let mut ukf = Ukf::new(d, model, &[0.0], &[[1.0]], SigmaPoints::merwe(1.0, 2.0, 0.0))?;
/// let mut rts = NonlinearRts::new();
/// for z in [1.0, 3.0] {
///     ukf.step(&[z], None)?;
///     rts.record(&ukf)?;
/// }
/// let s = rts.smooth()?;
/// // The batch solution of this random walk (see the linear smoother): x = (1, 2).
/// assert!((s.means[(0, 0)] - 1.0).abs() < 1e-14 && (s.means[(0, 1)] - 2.0).abs() < 1e-14);
/// # Ok(())
/// # }
/// ```
pub type NonlinearRts = Rts<Nonlinear>;

impl Rts<Nonlinear> {
    /// Runs `filter` over `measurements` (one z per step, NaN entries missing, no control
    /// input; FilterPy's `batch_filter`), recording every step: returns the filtered means
    /// (column k is x_{k|k}, stored × N) and the record, for [`Self::smooth`] or
    /// [`Self::smooth_on`]. The filter is left after the last step.
    ///
    /// ```
    /// use kalman::DynDims;
    /// use kalman::nonlinear::{FnModel, NonlinearRts, SigmaPoints};
    /// # fn main() -> Result<(), kalman::Error> {
    /// let model = FnModel::new(
    ///     DynDims::new(1, 1, 0)?,
    ///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
    ///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0],
    ///     &[[1.0]],
    ///     &[[1.0]],
    /// )?;
    /// let mut ukf = model.ukf(&[0.0], &[[1.0]], SigmaPoints::Cubature)?;
    /// let (filtered, rts) = NonlinearRts::run(&mut ukf, [[1.0], [3.0]])?;
    /// // The random walk of `smooth`'s example: filtered 1/2 and 2 (gains 1/2, 3/5),
    /// // smoothed 1 and 2.
    /// assert!((filtered[(0, 0)] - 0.5).abs() < 1e-14 && (filtered[(0, 1)] - 2.0).abs() < 1e-14);
    /// assert!((rts.smooth()?.means[(0, 0)] - 1.0).abs() < 1e-14);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// The filter's step errors (naming the step); [`Self::record`]'s.
    pub fn run<Z: AsRef<[f64]>>(
        filter: &mut impl NonlinearStep,
        measurements: impl IntoIterator<Item = Z>,
    ) -> Result<(Mat<f64>, Self), Error> {
        let mut rts = Self::new();
        let mut means = Vec::new();
        for z in measurements {
            filter.step(z.as_ref(), None)?;
            rts.record(filter)?;
            means.extend_from_slice(filter.filtered().0);
        }
        let stored = filter.filtered().0.len();
        let steps = rts.len();
        let filtered = MatRef::from_column_major_slice(&means, stored, steps).to_owned();
        Ok((filtered, rts))
    }

    /// Records the step the filter has just taken.
    ///
    /// # Errors
    /// [`Error::Dimension`] if the filter's n differs from that of the steps recorded before,
    /// or a vector or matrix it hands over is not of size n or n×n.
    pub fn record(&mut self, filter: &impl ForwardPass) -> Result<(), Error> {
        let (xf, pf) = filter.filtered();
        // n from P (n×n); the mean may be a longer stored point of a manifold.
        let n = pf.len().isqrt();
        let ns = xf.len();
        if n * n != pf.len() || ns < n {
            return Err(Error::Dimension {
                name: "P_{k|k}",
                value: pf.len(),
                rule: "a recorded step must hold an n-by-n P_{k|k} and a mean of at least n",
            });
        }
        self.admit_stored(n, ns)?;
        let (xp, pp) = filter.predicted();
        for (name, value, len) in [("x_{k+1|k}", xp.len(), ns), ("P_{k+1|k}", pp.len(), n * n)] {
            if value != len {
                return Err(Error::Dimension {
                    name,
                    value,
                    rule: "a recorded step must hold n-vectors and n-by-n matrices",
                });
            }
        }
        let mut c = vec![0.0; n * n];
        filter.cross_covariance(&mut c);
        let square = |v| MatRef::from_column_major_slice(v, n, n);
        self.push(xf, xp, [square(pf), square(pp), square(&c)]);
        Ok(())
    }

    /// The backward pass on the manifold `space` (the model's, see
    /// [`super::FnModel::with_manifold`]): `x_{k|N} = x_{k|k} ⊞ J_k (x_{k+1|N} ⊟ x_{k+1|k})`
    /// with J_k and the tangent covariances as in [`Self::smooth`]; the means are stored
    /// points (stored × N, a quaternion of unit norm in every column). The smoothed
    /// covariance adds tangent-space matrices taken at x_{k+1|N} and x_{k+1|k} without
    /// transporting one to the other, an error of second order in their distance (the
    /// convention of the error-state smoothers). With a [`super::Part::Angle`] the
    /// differences wrap, which [`Self::smooth`]'s do not.
    ///
    /// # Errors
    /// As [`Self::smooth`]; [`Error::Dimension`] naming `manifold` if `space` does not have
    /// the recorded n and stored length.
    pub fn smooth_on(&self, space: &impl super::Manifold) -> Result<Smoothed, Error> {
        if !self.is_empty() && !self.fits(space) {
            return Err(Error::Dimension {
                name: "manifold",
                value: space.stored(),
                rule: "the manifold must have the recorded steps' n and stored length",
            });
        }
        let mut covs = Vec::with_capacity(self.len());
        let means = self.backward_on(Some(space), |_, _, p| {
            covs.push(p.clone());
            Ok(())
        })?;
        covs.reverse();
        Ok(Smoothed {
            means,
            covariances: covs,
        })
    }

    /// The backward pass over all recorded steps.
    ///
    /// # Errors
    /// [`Error::Dimension`] if nothing was recorded, or naming `stored` if the steps'
    /// means are stored points of a manifold ([`Self::smooth_on`]); [`Error::Factorisation`] if the eigen
    /// fallback for a singular `P_{k+1|k}` fails.
    pub fn smooth(&self) -> Result<Smoothed, Error> {
        self.vector_states()?;
        self.backward(|_, _, _| Ok(()))
    }

    /// The backward pass without keeping every covariance: `visit(k, P_{k|N})` sees each
    /// step's smoothed covariance (last step first) and the smoothed means are returned
    /// (n×N). For long records, where the N covariances of [`Self::smooth`] would be the
    /// largest allocation of the run.
    ///
    /// ```
    /// use kalman::DynDims;
    /// use kalman::nonlinear::{FnModel, NonlinearRts, SigmaPoints, Ukf};
    /// # fn main() -> Result<(), kalman::Error> {
    /// let d = DynDims::new(1, 1, 0)?;
    /// let model = FnModel::new(
    ///     d,
    ///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
    ///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0],
    ///     &[[1.0]],
    ///     &[[1.0]],
    /// )?;
    /// let mut ukf = Ukf::new(d, model, &[0.0], &[[1.0]], SigmaPoints::merwe(1.0, 2.0, 0.0))?;
    /// let mut rts = NonlinearRts::new();
    /// for z in [1.0, 3.0] {
    ///     ukf.step(&[z], None)?;
    ///     rts.record(&ukf)?;
    /// }
    /// let mut variances = [0.0; 2];
    /// let means = rts.smooth_each(|k, p| variances[k] = p[(0, 0)])?;
    /// let all = rts.smooth()?;
    /// assert_eq!(means, all.means);
    /// assert_eq!(variances[0], all.covariances[0][(0, 0)]);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// As [`Self::smooth`].
    pub fn smooth_each(
        &self,
        mut visit: impl FnMut(usize, MatRef<'_, f64>),
    ) -> Result<Mat<f64>, Error> {
        self.vector_states()?;
        self.backward_each(|k, _, p| {
            visit(k, p.as_ref());
            Ok(())
        })
    }
}

impl Rts<Nonlinear> {
    /// Whether `space` has the recorded n and stored length.
    fn fits(&self, space: &impl super::Manifold) -> bool {
        space.dim() * space.dim() == self.covariance_len() && space.stored() == self.mean_len()
    }

    /// [`Error::Dimension`] naming `stored` for steps whose means are stored points longer
    /// than n, which a vector pass would add and subtract as vectors.
    fn vector_states(&self) -> Result<(), Error> {
        if self.is_stored() {
            return Err(Error::Dimension {
                name: "stored",
                value: self.mean_len(),
                rule: "the steps' states are on a manifold: smooth them with smooth_on",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A forward pass of two states whose P_{k+1|k} has three entries instead of four.
    struct Short;

    impl ForwardPass for Short {
        fn filtered(&self) -> (&[f64], &[f64]) {
            (&[0.0, 0.0], &[1.0, 0.0, 0.0, 1.0])
        }
        fn predicted(&self) -> (&[f64], &[f64]) {
            (&[0.0, 0.0], &[1.0, 0.0, 0.0])
        }
        fn cross_covariance(&self, out: &mut [f64]) {
            out.fill(0.0);
        }
    }

    #[test]
    fn a_step_of_the_wrong_size_is_a_typed_error_and_is_not_recorded() {
        let mut rts = NonlinearRts::new();
        let e = rts
            .record(&Short)
            .expect_err("P_{k+1|k} has 3 entries, not 4");
        assert!(
            matches!(
                e,
                Error::Dimension {
                    name: "P_{k+1|k}",
                    value: 3,
                    ..
                }
            ),
            "{e}"
        );
        assert!(rts.is_empty());
    }
}
