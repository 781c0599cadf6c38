//! The filter–smoother estimator: the EKF on the augmented kinematic model (Jacobians by
//! forward-mode AD of [`FlightModel`]) over the union grid, with every measurement gated
//! on its innovation before the update, and the extended RTS smoother over the recorded
//! forward pass.
//!
//! **Gate.** Before step k, each sampled entry i of z_k is tested against the prediction:
//! `e_i² / Σ_ii > g` with `e = z ⊖ h(x⁻)` and `Σ_ii = H_i P⁻ H_iᵀ + R_ii` rejects it (set
//! to NaN, so the EKF, the smoother and the output-error fit all see it missing); `g` is
//! the χ²(1) quantile of the configured probability. This is the entry-wise test of
//! `kalman::gate` applied to the EKF's linearisation at the prediction. A wild point is one
//! sample; a channel rejected on `gate_reset` consecutive samples means the filter, not the
//! sensor, is off (early in a record, while the instrument errors are still uncertain and
//! the linearisation poor), so its next sample is accepted: without this reset the gate
//! can lock a channel out for good.

use faer::Mat;
use kalman::nonlinear::{
    AutoDiff, Ekf, EkfUpdate, GenericModel, Jacobians, NonlinearModel, NonlinearRts,
};

use super::data::Grid;
use super::model::{FlightModel, M, Noise};
use crate::error::{Error, Result};

/// The `kalman` error of `context` as the program's error.
fn kal(context: &'static str) -> impl Fn(kalman::Error) -> Error {
    move |source| Error::Kalman { context, source }
}

/// What the filter–smoother needs besides the record.
#[derive(Debug, Clone)]
pub struct Settings {
    /// The noise model.
    pub noise: Noise,
    /// Prior standard deviations of the state (n entries; 0 pins a state to its x0).
    pub prior_std: Vec<f64>,
    /// The prior mean (n entries).
    pub x0: Vec<f64>,
    /// The gate's χ²(1) threshold on e²/Σ (∞ switches the gate off).
    pub gate: f64,
    /// A channel rejected on this many consecutive samples is accepted on the next.
    pub gate_reset: usize,
    /// With the instrument-error states.
    pub augmented: bool,
}

/// The estimates of one pass.
#[derive(Debug, Clone)]
pub struct Pass {
    /// x_{k|k}, n×N.
    pub filtered: Mat<f64>,
    /// diag P_{k|k}, n×N.
    pub filtered_var: Mat<f64>,
    /// x_{k|N}, n×N.
    pub smoothed: Mat<f64>,
    /// diag P_{k|N}, n×N.
    pub smoothed_var: Mat<f64>,
    /// P_{k|N} at the steps asked for.
    pub smoothed_cov_at: Vec<Mat<f64>>,
    /// The measurements after the gate (rejected entries NaN).
    pub gated: Vec<[f64; M]>,
    /// Rejected entries per sensor (air data, AHRS, GNSS).
    pub rejected: [usize; 3],
    /// The prediction residuals z ⊖ h(x_{k|k−1}) (NaN where missing), N×M.
    pub residuals: Vec<[f64; M]>,
}

/// Runs the gated EKF and the extended RTS smoother over `grid`; the full smoothed
/// covariance is kept at the steps `keep_cov` (indices into the grid).
///
/// # Errors
/// A filter or smoother error of `kalman` (divergence, a singular innovation).
pub fn run(grid: &Grid, s: &Settings, keep_cov: &[usize]) -> Result<Pass> {
    let model = FlightModel::new(grid, &s.noise, s.augmented);
    let n = model.n();
    let big_n = grid.t.len();
    let dims = kalman::DynDims::new(n, M, 0).map_err(kal("flightpath filter"))?;
    let mut p0 = Mat::<f64>::zeros(n, n);
    for i in 0..n {
        p0[(i, i)] = s.prior_std[i] * s.prior_std[i];
    }
    let mut ekf = Ekf::new(
        dims,
        AutoDiff::new(model, dims),
        &s.x0,
        &p0,
        EkfUpdate::Extended,
    )
    .map_err(kal("flightpath filter: prior"))?;
    let mut rts = NonlinearRts::new();
    let mut filtered = Mat::<f64>::zeros(n, big_n);
    let mut filtered_var = Mat::<f64>::zeros(n, big_n);
    let mut gated = grid.z.clone();
    let mut residuals = vec![[f64::NAN; M]; big_n];
    let mut rejected = [0usize; 3];
    let (mut xp, mut pp) = (vec![0.0; n], vec![0.0; n * n]);
    let (mut zh, mut hj, mut e) = ([0.0; M], vec![0.0; M * n], [0.0; M]);
    let mut r = [0.0; M * M];
    // Consecutive rejections per channel.
    let mut run = [0usize; M];
    for k in 0..big_n {
        xp.copy_from_slice(ekf.predicted_state());
        let pm = ekf.predicted_covariance();
        for j in 0..n {
            for i in 0..n {
                pp[i + j * n] = pm[(i, j)];
            }
        }
        let z = &mut gated[k];
        if z.iter().any(|v| v.is_finite()) {
            let ad = ekf.model_mut();
            ad.h(&xp, k, &mut zh);
            ad.h_jacobian(&xp, k, &mut hj);
            ad.inner().r(k, &mut r);
            ad.residual(z, &zh, &mut e);
            for i in 0..M {
                if !z[i].is_finite() {
                    continue;
                }
                // Σ_ii = H_i P⁻ H_iᵀ + R_ii.
                let mut sii = r[i + i * M];
                for a in 0..n {
                    let ha = hj[i + a * M];
                    if ha == 0.0 {
                        continue;
                    }
                    for b in 0..n {
                        sii += ha * pp[a + b * n] * hj[i + b * M];
                    }
                }
                residuals[k][i] = e[i];
                if e[i] * e[i] > s.gate * sii && run[i] < s.gate_reset {
                    z[i] = f64::NAN;
                    rejected[i / 3] += 1;
                    run[i] += 1;
                } else {
                    run[i] = 0;
                }
            }
        }
        ekf.model_mut().inner_mut().set_point(&xp);
        ekf.step(z, None).map_err(kal("flightpath EKF"))?;
        rts.record(&ekf).map_err(kal("flightpath smoother"))?;
        let (x, p) = (ekf.state(), ekf.covariance());
        for i in 0..n {
            filtered[(i, k)] = x[i];
            filtered_var[(i, k)] = p[(i, i)];
        }
    }
    drop(ekf);
    let sm = rts.smooth().map_err(kal("flightpath smoother"))?;
    drop(rts);
    let mut smoothed_var = Mat::<f64>::zeros(n, big_n);
    for (k, c) in sm.covariances.iter().enumerate() {
        for i in 0..n {
            smoothed_var[(i, k)] = c[(i, i)];
        }
    }
    let smoothed_cov_at = keep_cov
        .iter()
        .map(|&k| sm.covariances[k.min(big_n - 1)].clone())
        .collect();
    Ok(Pass {
        filtered,
        filtered_var,
        smoothed: sm.means,
        smoothed_var,
        smoothed_cov_at,
        gated,
        rejected,
        residuals,
    })
}
