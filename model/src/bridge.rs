//! From a discrete model to the noise covariances a Kalman filter needs, and (feature
//! `kalman`) to a ready `kalman::Model` in one call.
//!
//! A [`DiscreteSs`] carries one noise vector `w_k` (covariance `Q`) that may drive both the
//! state (through `G`) and the output (through `J`), plus — outside the model — the
//! measurement noise `v_k` of the sensors (covariance `R_c`, independent of `w_k`). The filter
//! form `x_{k+1} = F x_k + B u_k + w'_k`, `z_k = H x_k + v'_k` needs
//!
//! ```text
//! Q' = cov(G w_k)                = G Q Gᵀ          (n×n)
//! R' = cov(J w_k + v_k)          = R_c + J Q Jᵀ    (m×m)
//! S' = cov(G w_k, J w_k + v_k)   = G Q Jᵀ          (n×m)
//! ```
//!
//! `J ≠ 0` arises from Tustin discretisation and from
//! [`NoiseConvention::IntensityOverDt`](crate::NoiseConvention::IntensityOverDt); with Van
//! Loan noise and ZOH `J = 0` and `S' = 0`. A control feed-through `D ≠ 0` has no place in
//! the filter form (its measurement equation has no input term): [`DiscreteSs::filter_noise`]
//! does not need it, [`DiscreteSs::to_kalman`] rejects it, and a caller subtracts `D u_k`
//! from `z_k` instead.

use nalgebra::DMatrix;

#[cfg(feature = "kalman")]
use crate::error::Error;
use crate::error::Result;
use crate::ss::DiscreteSs;
use crate::validate;

/// The noise covariances of a [`DiscreteSs`] in the form a Kalman filter takes (see the
/// module docs): `q = G Q Gᵀ`, `r = R_c + J Q Jᵀ`, `s = G Q Jᵀ`.
///
/// # Example
/// ```
/// use model::nalgebra::dmatrix;
/// use model::DiscreteSs;
///
/// // One noise drives state (G = 1) and output (J = 0.5), cov = 0.04; sensor noise 0.01.
/// let d = DiscreteSs::autonomous(dmatrix![0.9], dmatrix![1.0], 0.1)?
///     .with_noise(dmatrix![1.0], dmatrix![0.5], dmatrix![0.04])?;
/// let noise = d.filter_noise(Some(&dmatrix![0.01]))?;
/// assert!((noise.q[(0, 0)] - 0.04).abs() < 1e-15); // G Q Gᵀ
/// assert!((noise.r[(0, 0)] - (0.01 + 0.25 * 0.04)).abs() < 1e-15); // R_c + J Q Jᵀ
/// assert!((noise.s.expect("J ≠ 0")[(0, 0)] - 0.02).abs() < 1e-15); // G Q Jᵀ
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct FilterNoise {
    /// Process noise covariance as it enters the state, n×n.
    pub q: DMatrix<f64>,
    /// Measurement noise covariance, m×m.
    pub r: DMatrix<f64>,
    /// Cross-covariance of process and measurement noise, n×m (`None` when it is zero).
    pub s: Option<DMatrix<f64>>,
}

impl DiscreteSs {
    /// The filter-form noise covariances with sensor noise `r_c` (m×m; `None` for none).
    ///
    /// # Errors
    /// [`crate::Error::DimensionMismatch`], [`crate::Error::NonFiniteMatrix`],
    /// [`crate::Error::NotSymmetric`] or [`crate::Error::NotPositiveSemiDefinite`] naming `R`
    /// for a bad `r_c`.
    ///
    /// # Example
    /// ```
    /// use model::nalgebra::dmatrix;
    /// use model::{ContinuousSs, Discretization, NoiseConvention};
    ///
    /// // A first-order lag with white input noise, discretised by Tustin: J ≠ 0.
    /// let sys = ContinuousSs::autonomous(dmatrix![-1.0], dmatrix![1.0])?
    ///     .with_noise(dmatrix![1.0], dmatrix![2.0])?;
    /// let d = sys.discretize(0.1, Discretization::Tustin, NoiseConvention::IntensityOverDt)?;
    /// let noise = d.filter_noise(Some(&dmatrix![0.01]))?;
    /// let jqj = d.output_noise_covariance();
    /// assert!((noise.r[(0, 0)] - (0.01 + jqj[(0, 0)])).abs() < 1e-15);
    /// assert!(noise.s.is_some()); // the same w_k drives state and output
    /// # Ok::<(), model::Error>(())
    /// ```
    pub fn filter_noise(&self, r_c: Option<&DMatrix<f64>>) -> Result<FilterNoise> {
        let m = self.n_outputs();
        let jqj = self.output_noise_covariance();
        let r = match r_c {
            Some(r_c) => {
                validate::covariance("R", r_c, m, "R must be m×m with m = rows of H")?;
                validate::symmetrize(&(r_c + &jqj))
            }
            None => jqj,
        };
        let s = self.cross_covariance();
        let s = s.iter().any(|v| v.abs() > 0.0).then_some(s);
        Ok(FilterNoise {
            q: self.process_covariance(),
            r,
            s,
        })
    }

    /// The model as a `kalman::Model` on the run-time-sized storage path in one call: `F`,
    /// `H`, `B` as they are, the noise by [`DiscreteSs::filter_noise`] (feature `kalman`).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `D` when the control feed-through is not zero (the
    /// filter's measurement equation has no input term); the errors of
    /// [`DiscreteSs::filter_noise`]; [`Error::Kalman`] when the engine rejects the model (for
    /// example a measurement-free model, m = 0).
    ///
    /// # Example
    /// ```
    /// use model::nalgebra::dmatrix;
    /// use model::{ContinuousSs, Discretization, NoiseConvention};
    /// use kalman::{CovarianceForm, Filter};
    ///
    /// // Constant velocity with white acceleration noise, position measured (R_c = 0.25).
    /// let sys = ContinuousSs::autonomous(dmatrix![0.0, 1.0; 0.0, 0.0], dmatrix![1.0, 0.0])?
    ///     .with_noise(dmatrix![0.0; 1.0], dmatrix![0.1])?;
    /// let disc = sys.discretize(0.5, Discretization::Zoh, NoiseConvention::VanLoan)?;
    /// let model = disc.to_kalman(Some(&dmatrix![0.25]))?;
    /// // Van Loan's Q of integrated white noise: q·[[Δt³/3, Δt²/2], [Δt²/2, Δt]].
    /// assert!((model.q()[(0, 0)] - 0.1 * 0.125 / 3.0).abs() < 1e-15);
    /// let mut filter = Filter::new(model, &[0.0, 0.0], &dmatrix![1.0, 0.0; 0.0, 1.0], CovarianceForm::Joseph)?;
    /// filter.step(&[0.3], None)?;
    /// # Ok::<(), model::Error>(())
    /// ```
    #[cfg(feature = "kalman")]
    pub fn to_kalman(&self, r_c: Option<&DMatrix<f64>>) -> Result<kalman::Model<kalman::DynDims>> {
        if let Some(v) = self.d().iter().find(|v| v.abs() > 0.0) {
            return Err(Error::InvalidParameter {
                name: "D",
                value: *v,
                rule: "zero for a Kalman filter model (subtract D·u from the measurement first)",
            });
        }
        let noise = self.filter_noise(r_c)?;
        let dims = kalman::DynDims::new(self.n_states(), self.n_outputs(), self.n_inputs())?;
        let mut model = kalman::Model::new(dims, self.f(), self.h(), &noise.q, &noise.r)?;
        if self.n_inputs() > 0 {
            model = model.with_control(self.b())?;
        }
        if let Some(s) = &noise.s {
            model = model.with_cross_covariance(s)?;
        }
        Ok(model)
    }
}
