//! The extended Kalman filter and its iterated (Gauss–Newton) measurement update.
#![allow(non_snake_case)]

use faer::MatRef;

use super::linalg::{
    RowPattern, joseph, mirror_lower, mul, mul_nt, nis_logdet, pd_cholesky, right_solve, symmetrise,
};
use super::{
    Core, Jacobians, NlDims, Stages, StepInfo, UpdateWork, compact_rows, compact_square,
    compact_vec, finite, observed_info,
};
use crate::storage::Buf;
use crate::{Error, MatrixInput, RANK_TOL};

/// The measurement update of an [`Ekf`].
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum EkfUpdate {
    /// One linearisation of h at the prediction (the extended Kalman filter).
    #[default]
    Extended,
    /// The iterated EKF: Gauss–Newton iterations `x_{i+1} = x⁻ ⊕ K_i (z − h(x_i) +
    /// H_i (x_i ⊖ x⁻))` from `x_0 = x⁻`, at most `max_iterations` linearisations, stopping
    /// when `‖x_{i+1} ⊖ x_i‖ ≤ tolerance·(1 + ‖x_i‖)`. The covariance uses the last
    /// linearisation.
    Iterated {
        /// Cap on the linearisations per update (at least 1; 1 is the EKF).
        max_iterations: usize,
        /// Relative step tolerance (finite, ≥ 0).
        tolerance: f64,
    },
}

/// The extended Kalman filter (one or iterated measurement linearisations) on the storage
/// path `D`, for a model with [`Jacobians`].
///
/// Update with z_k: `H = ∂h/∂x(x⁻)`, `e = z ⊖ h(x⁻)`, `Σ = H P⁻ Hᵀ + R`, `K = P⁻ Hᵀ Σ⁻¹`
/// (Cholesky solve), `x = x⁻ ⊕ K e`, `P = (I − KH) P⁻ (I − KH)ᵀ + K R Kᵀ` (Joseph).
/// Prediction: `F = ∂f/∂x(x, u)`, `x⁺ = f(x, u, k)`, `P⁺ = F P Fᵀ + Q`. A step allocates
/// nothing.
///
/// ```
/// use kalman::FixedDims;
/// use kalman::nonlinear::{CentralDiff, Ekf, EkfUpdate, FnModel};
/// # fn main() -> Result<(), kalman::Error> {
/// let d = FixedDims::<1, 1>::new();
/// let model = FnModel::new(
///     d,
///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0] * x[0] * x[0],
///     &[[1e-4]],
///     &[[1e-2]],
/// )?;
/// let update = EkfUpdate::Iterated { max_iterations: 10, tolerance: 1e-12 };
/// let mut iekf = Ekf::new(d, CentralDiff::new(d, model), &[1.0], &[[0.25]], update)?;
/// let info = iekf.step(&[1.331], None)?; // 1.1³
/// assert!(info.iterations > 1);
/// assert!((iekf.state()[0] - 1.1).abs() < 0.02);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct Ekf<D: NlDims, M> {
    model: M,
    update: EkfUpdate,
    c: Core<D>,
    /// ∂f/∂x at x_{k|k} of the last prediction.
    fj: D::Nn,
    /// The nonzero pattern of `fj`.
    fpat: RowPattern,
    hj: D::Mn,
    hc: D::Mn,
    zh: D::Mv,
    ef: D::Mv,
    xi: D::Sv,
    xn: D::Sv,
    w: UpdateWork<D>,
}

impl<D: NlDims, M: Jacobians> Ekf<D, M> {
    /// A filter for `model` with prior mean `x0` (length n) and covariance `P0` (n×n,
    /// symmetric PSD). All workspaces are allocated here.
    ///
    /// # Errors
    /// [`Error::Shape`]/[`Error::NonFinite`]/[`Error::NotSymmetric`]/
    /// [`Error::NotPositiveSemidefinite`] naming `x0` or `P0`; [`Error::InvalidOption`] for
    /// an iteration cap of 0 or a negative or non-finite tolerance.
    pub fn new(
        dims: D,
        model: M,
        x0: &[f64],
        P0: &impl MatrixInput,
        update: EkfUpdate,
    ) -> Result<Self, Error> {
        if let EkfUpdate::Iterated {
            max_iterations,
            tolerance,
        } = update
        {
            if max_iterations == 0 {
                return Err(Error::InvalidOption {
                    name: "max_iterations",
                    value: 0.0,
                    rule: "at least one linearisation",
                });
            }
            if !(tolerance.is_finite() && tolerance >= 0.0) {
                return Err(Error::InvalidOption {
                    name: "tolerance",
                    value: tolerance,
                    rule: "must be finite and non-negative",
                });
            }
        }
        let c = Core::new(dims, &model, x0, P0)?;
        let (n, m, ns) = (dims.n(), dims.m(), dims.stored());
        Ok(Self {
            w: UpdateWork::new(n, m),
            model,
            update,
            c,
            fj: D::Nn::zeros(n * n),
            fpat: RowPattern::new(n),
            hj: D::Mn::zeros(m * n),
            hc: D::Mn::zeros(m * n),
            zh: D::Mv::zeros(m),
            ef: D::Mv::zeros(m),
            xi: D::Sv::zeros(ns),
            xn: D::Sv::zeros(ns),
        })
    }

    /// Step k: update with `z_k` (NaN entries are missing; all NaN is predict-only), then
    /// predict to k + 1 with the control `u_k` (passed to f).
    ///
    /// # Errors
    /// [`Error::Shape`] naming `z`; [`Error::ModelNonFinite`] naming the function and the
    /// step; [`Error::SingularInnovation`]. After an error the step counter has not
    /// advanced and the filtered estimate may be partly written: [`Ekf::reset`] the filter.
    pub fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, Error> {
        self.run_step(z, u)
    }
}

impl<D: NlDims, M: Jacobians> Stages<D> for Ekf<D, M> {
    fn core(&mut self) -> &mut Core<D> {
        &mut self.c
    }

    fn update_stage(&mut self, z: &[f64]) -> Result<StepInfo, Error> {
        let (n, m, k) = (self.c.dims.n(), self.c.dims.m(), self.c.k);
        let ns = self.c.dims.stored();
        let mut info = self.c.open_update(&mut self.model, z)?;
        let mo = info.observed;
        if mo == 0 {
            return Ok(info);
        }
        let xp = &self.c.xp.as_slice()[..ns];
        let pp = &self.c.pp.as_slice()[..n * n];
        let (max_it, tol, name) = match self.update {
            EkfUpdate::Extended => (1, 0.0, "EKF"),
            EkfUpdate::Iterated {
                max_iterations,
                tolerance,
            } => (max_iterations, tolerance, "iterated EKF"),
        };
        compact_square(self.c.r.as_slice(), m, z, mo, self.w.rc.as_mut_slice());
        self.xi.as_mut_slice()[..ns].copy_from_slice(xp);
        let mut nis = (0.0, 0.0);
        for it in 1..=max_it {
            let xi = &self.xi.as_slice()[..ns];
            let zh = &mut self.zh.as_mut_slice()[..m];
            self.model.h(xi, k, zh);
            finite("h", k, zh)?;
            let hj = &mut self.hj.as_mut_slice()[..m * n];
            self.model.h_jacobian(xi, k, hj);
            finite("h_jacobian", k, hj)?;
            self.model.residual(
                z,
                &self.zh.as_slice()[..m],
                &mut self.ef.as_mut_slice()[..m],
            );
            let e = &mut self.w.e.as_mut_slice()[..mo];
            compact_vec(&self.ef.as_slice()[..m], z, e);
            let hc = &mut self.hc.as_mut_slice()[..mo * n];
            compact_rows(&self.hj.as_slice()[..m * n], m, n, z, mo, hc);
            if it > 1 {
                // Gauss–Newton: e + H_i (x_i ⊖ x⁻).
                let dx = &mut self.w.dx.as_mut_slice()[..n];
                self.model.state_residual(xi, xp, dx);
                mul(e, hc, dx, mo, n, 1, true);
            }
            // PHᵀ (n×mo) into the gain buffer, Σ = H PHᵀ + R.
            let K = &mut self.w.gain.as_mut_slice()[..n * mo];
            mul_nt(K, pp, hc, n, n, mo, false);
            let sig = &mut self.w.sig.as_mut_slice()[..mo * mo];
            mul(sig, hc, K, mo, n, mo, false);
            for (s, r) in sig.iter_mut().zip(&self.w.rc.as_slice()[..mo * mo]) {
                *s += r;
            }
            symmetrise(sig, mo);
            let sinv = &mut self.w.sinv.as_mut_slice()[..mo];
            if let Err(pivot) = pd_cholesky(sig, mo, sinv, RANK_TOL) {
                return Err(Error::SingularInnovation {
                    filter: name,
                    step: k,
                    m: mo,
                    pivot,
                    tol: RANK_TOL,
                });
            }
            right_solve(sig, sinv, mo, K, n);
            let dx = &mut self.w.dx.as_mut_slice()[..n];
            mul(dx, K, e, n, mo, 1, false);
            self.model.state_add(
                xp,
                &self.w.dx.as_slice()[..n],
                &mut self.xn.as_mut_slice()[..ns],
            );
            nis = nis_logdet(sig, sinv, mo, e, &mut self.w.tmpm.as_mut_slice()[..mo]);
            info.iterations = it;
            if it == max_it {
                break;
            }
            let (xi, xn) = (&self.xi.as_slice()[..ns], &self.xn.as_slice()[..ns]);
            let dx = &mut self.w.dx.as_mut_slice()[..n];
            self.model.state_residual(xn, xi, dx);
            let step = dx.iter().map(|v| v * v).sum::<f64>().sqrt();
            let size = xi.iter().map(|v| v * v).sum::<f64>().sqrt();
            self.xi.as_mut_slice()[..ns].copy_from_slice(&self.xn.as_slice()[..ns]);
            if step <= tol * (1.0 + size) {
                break;
            }
        }
        self.c.xf.as_mut_slice()[..ns].copy_from_slice(&self.xn.as_slice()[..ns]);
        joseph(
            pp,
            &self.w.gain.as_slice()[..n * mo],
            &self.hc.as_slice()[..mo * n],
            &self.w.rc.as_slice()[..mo * mo],
            n,
            mo,
            &mut self.c.pf.as_mut_slice()[..n * n],
            &mut self.w.a.as_mut_slice()[..n * n],
            &mut self.w.t.as_mut_slice()[..n * n],
            &mut self.w.kr.as_mut_slice()[..n * mo],
        );
        Ok(observed_info(info, nis.0, nis.1, info.iterations))
    }

    fn predict_stage(&mut self, u: Option<&[f64]>) -> Result<(), Error> {
        let (n, k, ns) = (self.c.dims.n(), self.c.k, self.c.dims.stored());
        self.c.load_q(&mut self.model)?;
        let xf = &self.c.xf.as_slice()[..ns];
        let xp = &mut self.c.xp.as_mut_slice()[..ns];
        self.model.f(xf, u, k, xp);
        finite("f", k, xp)?;
        if ns != n {
            // f's image of a stored point, projected onto the manifold (x ⊞ 0: a
            // quaternion renormalised), through the scratch point of the update.
            let x = &mut self.xi.as_mut_slice()[..ns];
            x.copy_from_slice(xp);
            let zero = &mut self.w.dx.as_mut_slice()[..n];
            zero.fill(0.0);
            self.model.state_add(x, zero, xp);
            finite("f", k, xp)?;
        }
        let F = &mut self.fj.as_mut_slice()[..n * n];
        self.model.f_jacobian(xf, u, k, F);
        finite("f_jacobian", k, F)?;
        let t = &mut self.w.t.as_mut_slice()[..n * n];
        let pp = &mut self.c.pp.as_mut_slice()[..n * n];
        pp.copy_from_slice(&self.c.q.as_slice()[..n * n]);
        self.fpat.find(F, n);
        if self.fpat.sparse {
            self.fpat.mul(t, F, &self.c.pf.as_slice()[..n * n], n);
        } else {
            mul(t, F, &self.c.pf.as_slice()[..n * n], n, n, n, false);
        }
        // Q + (F P) Fᵀ on the lower triangle (over F's nonzeros), mirrored.
        self.fpat.add_mul_nt_lower(pp, t, F, n);
        mirror_lower(pp, n);
        Ok(())
    }
}

impl<D: NlDims, M: super::NonlinearModel> Ekf<D, M> {
    /// Restarts from the prior `(x0, P0)` at step 0, keeping the model and workspaces.
    ///
    /// # Errors
    /// As [`Ekf::new`] for `x0` and `P0`.
    pub fn reset(&mut self, x0: &[f64], P0: &impl MatrixInput) -> Result<(), Error> {
        self.c.reset(&self.model, x0, P0)
    }
}

impl<D: NlDims, M> Ekf<D, M> {
    filter_accessors!();
    /// `F_k = ∂f/∂x` at `x_{k|k}` used by the last prediction.
    pub fn transition_jacobian(&self) -> MatRef<'_, f64> {
        let n = self.c.dims.n();
        MatRef::from_column_major_slice(&self.fj.as_slice()[..n * n], n, n)
    }
}

impl<D: NlDims, M: super::NonlinearModel> super::ForwardPass for Ekf<D, M> {
    forward_pass_moments!();
    /// `C_k = P_{k|k} F_kᵀ`.
    fn cross_covariance(&self, out: &mut [f64]) {
        let n = self.c.dims.n();
        if self.fpat.sparse {
            let (pf, F) = (&self.c.pf.as_slice()[..n * n], &self.fj.as_slice()[..n * n]);
            return self.fpat.mul_nt(&mut out[..n * n], pf, F, n);
        }
        mul_nt(
            out,
            &self.c.pf.as_slice()[..n * n],
            &self.fj.as_slice()[..n * n],
            n,
            n,
            n,
            false,
        );
    }
}
