//! The filter–smoother estimator: the EKF on the augmented kinematic model (Jacobians by
//! forward-mode AD of [`FlightModel`]) over the union grid, with every measurement gated
//! on its innovation before the update, and the extended RTS smoother over the recorded
//! forward pass; or the same pass on the model linearised about a nominal trajectory
//! ([`run_about`]), the step of the iterated extended smoother.
//!
//! **Iterated smoother.** The EKF linearises the bilinear air-data outputs
//! `(1 + λ) β + b` about its own running estimate. Early in a record, before the
//! manoeuvres, that estimate of the sideslip is off by the prior uncertainty of the
//! lateral velocity (metres per second, a sideslip of a degree where the truth is zero),
//! and `∂h/∂λ = β̂` then credits the scale factor with information the data do not hold;
//! no later step removes it. Linearising instead about the previous pass's smoothed
//! trajectory `x̄` (`f(x) ≈ f(x̄_k) + F(x̄_k)(x − x̄_k)`, likewise h, Q at `x̄_k`) makes each
//! pass the Kalman filter and RTS smoother of the linearised problem, that is, one
//! Gauss–Newton step towards the maximum a posteriori trajectory of the full record under
//! the original prior (Bell, "The iterated Kalman smoother as a Gauss–Newton method",
//! SIAM J. Optim. 4, 1994); at its fixed point the smoothed covariance is that of the
//! linearisation about the best estimate, as the output-error fit's Cramér–Rao bound is.
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
use faer::MatRef;
use kalman::DynDims;
use kalman::nonlinear::{
    AutoDiff, Ekf, EkfUpdate, ForwardPass, Jacobians, NonlinearModel, NonlinearRts, SigmaPoints,
    Ukf,
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

/// The flight model as the filter sees it: [`FlightModel`] itself (Jacobians by AD at the
/// filter's own estimates), or its linearisation about a nominal trajectory.
struct Linearised {
    ad: AutoDiff<FlightModel>,
    /// x̄ (n×N), or `None` for the model itself.
    nominal: Option<Mat<f64>>,
    /// The step whose `f(x̄_k)` and `F(x̄_k)` are in `fbar`, `fjac`.
    f_at: Option<usize>,
    fbar: Vec<f64>,
    fjac: Vec<f64>,
    /// The step whose `h(x̄_k)` and `H(x̄_k)` are in `hbar`, `hjac`.
    h_at: Option<usize>,
    hbar: [f64; M],
    hjac: Vec<f64>,
    xbar: Vec<f64>,
}

impl Linearised {
    fn new(model: FlightModel, dims: kalman::DynDims, nominal: Option<Mat<f64>>) -> Self {
        let n = model.n();
        Self {
            ad: AutoDiff::new(dims, model),
            nominal,
            f_at: None,
            fbar: vec![0.0; n],
            fjac: vec![0.0; n * n],
            h_at: None,
            hbar: [0.0; M],
            hjac: vec![0.0; M * n],
            xbar: vec![0.0; n],
        }
    }

    /// Sets the point Q is evaluated at: the prediction `x` for the model itself, `x̄_k`
    /// (set in [`NonlinearModel::q`]) for the linearisation.
    fn set_point(&mut self, x: &[f64]) {
        if self.nominal.is_none() {
            self.ad.inner_mut().set_point(x);
        }
    }

    /// Loads x̄_k into `xbar`; false for the model itself.
    fn load(&mut self, k: usize) -> bool {
        let Some(nom) = &self.nominal else {
            return false;
        };
        let k = k.min(nom.ncols() - 1);
        for (i, v) in self.xbar.iter_mut().enumerate() {
            *v = nom[(i, k)];
        }
        true
    }

    /// `out = bar + jac (x − x̄)` for a rows×n column-major `jac`.
    fn affine(bar: &[f64], jac: &[f64], x: &[f64], xbar: &[f64], out: &mut [f64]) {
        let rows = bar.len();
        out.copy_from_slice(bar);
        for (j, (a, b)) in x.iter().zip(xbar).enumerate() {
            let d = a - b;
            if d != 0.0 {
                for (o, c) in out.iter_mut().zip(&jac[j * rows..(j + 1) * rows]) {
                    *o += c * d;
                }
            }
        }
    }

    fn at_f(&mut self, u: Option<&[f64]>, k: usize) {
        if self.f_at != Some(k) {
            self.ad.f(&self.xbar, u, k, &mut self.fbar);
            self.ad.f_jacobian(&self.xbar, u, k, &mut self.fjac);
            self.f_at = Some(k);
        }
    }

    fn at_h(&mut self, k: usize) {
        if self.h_at != Some(k) {
            self.ad.h(&self.xbar, k, &mut self.hbar);
            self.ad.h_jacobian(&self.xbar, k, &mut self.hjac);
            self.h_at = Some(k);
        }
    }
}

impl NonlinearModel for Linearised {
    fn f(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]) {
        if !self.load(k) {
            return self.ad.f(x, u, k, out);
        }
        self.at_f(u, k);
        Self::affine(&self.fbar, &self.fjac, x, &self.xbar, out);
    }

    fn h(&mut self, x: &[f64], k: usize, out: &mut [f64]) {
        if !self.load(k) {
            return self.ad.h(x, k, out);
        }
        self.at_h(k);
        Self::affine(&self.hbar, &self.hjac, x, &self.xbar, out);
    }

    fn q(&mut self, k: usize, out: &mut [f64]) {
        if self.load(k) {
            self.ad.inner_mut().set_point(&self.xbar);
        }
        self.ad.q(k, out);
    }

    fn r(&mut self, k: usize, out: &mut [f64]) {
        self.ad.r(k, out);
    }

    fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        self.ad.residual(a, b, out);
    }
}

impl Jacobians for Linearised {
    fn f_jacobian(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, jac: &mut [f64]) {
        if !self.load(k) {
            return self.ad.f_jacobian(x, u, k, jac);
        }
        self.at_f(u, k);
        jac.copy_from_slice(&self.fjac);
    }

    fn h_jacobian(&mut self, x: &[f64], k: usize, jac: &mut [f64]) {
        if !self.load(k) {
            return self.ad.h_jacobian(x, k, jac);
        }
        self.at_h(k);
        jac.copy_from_slice(&self.hjac);
    }
}

/// Runs the gated EKF and the extended RTS smoother over `grid`; the full smoothed
/// covariance is kept at the steps `keep_cov` (indices into the grid).
///
/// # Errors
/// A filter or smoother error of `kalman` (divergence, a singular innovation).
pub fn run(grid: &Grid, s: &Settings, keep_cov: &[usize]) -> Result<Pass> {
    run_about(grid, s, keep_cov, None)
}

/// As [`run`], on the model linearised about `nominal` (n×N, one state per grid step; the
/// iterated smoother's step, see the module documentation), or on the model itself when
/// `nominal` is `None`.
///
/// # Errors
/// As [`run`].
pub fn run_about(
    grid: &Grid,
    s: &Settings,
    keep_cov: &[usize],
    nominal: Option<Mat<f64>>,
) -> Result<Pass> {
    let model = FlightModel::new(grid, &s.noise, s.augmented);
    let dims = kalman::DynDims::new(model.n(), M, 0).map_err(kal("flightpath filter"))?;
    let ekf = Ekf::new(
        dims,
        Linearised::new(model, dims, nominal),
        &s.x0,
        &prior(s),
        EkfUpdate::Extended,
    )
    .map_err(kal("flightpath filter: prior"))?;
    forward_backward(ekf, grid, s, keep_cov)
}

/// The gated unscented Kalman filter (cubature points: every weight positive, so no
/// covariance is formed by a subtraction) and the unscented RTS smoother over `grid`, on the
/// model itself; the gate linearises h at the prediction as [`run`]'s does. One pass, not
/// iterated: a comparison with the extended smoother's first pass.
///
/// # Errors
/// As [`run`].
pub fn run_unscented(grid: &Grid, s: &Settings, keep_cov: &[usize]) -> Result<Pass> {
    let model = FlightModel::new(grid, &s.noise, s.augmented);
    let dims = kalman::DynDims::new(model.n(), M, 0).map_err(kal("flightpath filter"))?;
    let ukf = Ukf::new(
        dims,
        Linearised::new(model, dims, None),
        &s.x0,
        &prior(s),
        SigmaPoints::Cubature,
    )
    .map_err(kal("flightpath unscented filter: prior"))?;
    forward_backward(ukf, grid, s, keep_cov)
}

/// The prior covariance: diagonal, from the settings' standard deviations.
fn prior(s: &Settings) -> Mat<f64> {
    let n = s.prior_std.len();
    Mat::from_fn(n, n, |i, j| {
        if i == j {
            s.prior_std[i] * s.prior_std[i]
        } else {
            0.0
        }
    })
}

/// The two filters the pass runs, as it uses them.
trait Forward: ForwardPass {
    fn prediction(&self) -> (&[f64], MatRef<'_, f64>);
    fn estimate(&self) -> (&[f64], MatRef<'_, f64>);
    fn linearised(&mut self) -> &mut Linearised;
    fn advance(&mut self, z: &[f64]) -> std::result::Result<(), kalman::Error>;
}

macro_rules! forward {
    ($($filter:ident),+) => {$(
        impl Forward for $filter<DynDims, Linearised> {
            fn prediction(&self) -> (&[f64], MatRef<'_, f64>) {
                (self.predicted_state(), self.predicted_covariance())
            }
            fn estimate(&self) -> (&[f64], MatRef<'_, f64>) {
                (self.state(), self.covariance())
            }
            fn linearised(&mut self) -> &mut Linearised {
                self.model_mut()
            }
            fn advance(&mut self, z: &[f64]) -> std::result::Result<(), kalman::Error> {
                self.step(z, None).map(|_| ())
            }
        }
    )+};
}
forward!(Ekf, Ukf);

/// The gated forward pass of `filter` over `grid`, recorded, and the RTS smoother over it.
fn forward_backward(
    mut filter: impl Forward,
    grid: &Grid,
    s: &Settings,
    keep_cov: &[usize],
) -> Result<Pass> {
    let n = s.prior_std.len();
    let big_n = grid.t.len();
    let mut rts = NonlinearRts::new();
    rts.reserve(n, big_n);
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
        let (x_pred, pm) = filter.prediction();
        xp.copy_from_slice(x_pred);
        for j in 0..n {
            for i in 0..n {
                pp[i + j * n] = pm[(i, j)];
            }
        }
        let z = &mut gated[k];
        if z.iter().any(|v| v.is_finite()) {
            let ad = filter.linearised();
            ad.h(&xp, k, &mut zh);
            ad.h_jacobian(&xp, k, &mut hj);
            ad.r(k, &mut r);
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
        filter.linearised().set_point(&xp);
        filter.advance(z).map_err(kal("flightpath filter step"))?;
        rts.record(&filter).map_err(kal("flightpath smoother"))?;
        let (x, p) = filter.estimate();
        for i in 0..n {
            filtered[(i, k)] = x[i];
            filtered_var[(i, k)] = p[(i, i)];
        }
    }
    drop(filter);
    let mut smoothed_var = Mat::<f64>::zeros(n, big_n);
    let mut smoothed_cov_at = vec![Mat::<f64>::zeros(n, n); keep_cov.len()];
    let means = rts
        .smooth_each(|k, c| {
            for i in 0..n {
                smoothed_var[(i, k)] = c[(i, i)];
            }
            for (slot, &want) in smoothed_cov_at.iter_mut().zip(keep_cov) {
                if want.min(big_n - 1) == k {
                    slot.copy_from(c);
                }
            }
        })
        .map_err(kal("flightpath smoother"))?;
    drop(rts);
    Ok(Pass {
        filtered,
        filtered_var,
        smoothed: means,
        smoothed_var,
        smoothed_cov_at,
        gated,
        rejected,
        residuals,
    })
}
