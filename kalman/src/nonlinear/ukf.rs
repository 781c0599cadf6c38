//! The unscented Kalman filter over any of the sigma-point sets of [`super::SigmaPoints`].
#![allow(non_snake_case)]

use faer::MatRef;

use super::linalg::{
    factored_joseph, forward, mirror_lower, mul, mul_tn, nis_logdet, pd_cholesky, psd_cholesky,
    rank1, rank1_lower, right_solve,
};
use super::sigma::SigmaPoints;
use super::unscented::Unscented;
use super::{
    Core, NlDims, NonlinearModel, ObservedUpdate, Stages, StepInfo, UpdateWork, observed_info,
};
use crate::storage::Buf;
use crate::{Error, MatrixInput, PSD_TOL, RANK_TOL};

/// The unscented Kalman filter (additive noise) on the storage path `D`.
///
/// Update with z_k: sigma points `χ_i` of `(x⁻, P⁻)`, `Z_i = h(χ_i)`, `ẑ = Σ Wm_i Z_i`,
/// (computed as `Z_0 + Σ_{i≥1} Wm_i (Z_i ⊖ Z_0)`, free of cancellation when `Wm_0` is large
/// and negative, and averaging wrapped angles around `Z_0`),
/// `Σ = Σ Wc_i (Z_i ⊖ ẑ)(Z_i ⊖ ẑ)ᵀ + R`, `C = Σ Wc_i (χ_i ⊖ x⁻)(Z_i ⊖ ẑ)ᵀ`,
/// `K = C Σ⁻¹`, `x = x⁻ ⊕ K (z ⊖ ẑ)`, and the Joseph-style covariance of the module
/// documentation. Prediction: sigma points of `(x, P)`, `x⁺ = Σ Wm_i f(χ_i)`,
/// `P⁺ = Σ Wc_i (f(χ_i) ⊖ x⁺)(…)ᵀ + Q` (x⁺ centred on f(χ_0) likewise). A step
/// allocates nothing.
///
/// ```
/// use kalman::DynDims;
/// use kalman::nonlinear::{FnModel, SigmaPoints, Ukf};
/// # fn main() -> Result<(), kalman::Error> {
/// let d = DynDims::new(2, 1, 0)?;
/// // Constant velocity, range to a point 1 m off the track measured.
/// let model = FnModel::new(
///     d,
///     |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
///         out[0] = x[0] + 0.1 * x[1];
///         out[1] = x[1];
///     },
///     |x: &[f64], _k: usize, out: &mut [f64]| out[0] = (x[0] * x[0] + 1.0).sqrt(),
///     &[[1e-6, 0.0], [0.0, 1e-4]],
///     &[[1e-4]],
/// )?;
/// let mut ukf = Ukf::new(d, model, &[1.0, 1.0], &[[0.01, 0.0], [0.0, 0.01]], SigmaPoints::Cubature)?;
/// for k in 0..20 {
///     let x = 1.0 + 0.1 * k as f64;
///     ukf.step(&[(x * x + 1.0f64).sqrt()], None)?;
/// }
/// assert!((ukf.state()[0] - 2.9).abs() < 0.01);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct Ukf<D: NlDims, M> {
    model: M,
    /// The sigma-point set (2n + 1 points for the symmetric sets) and its workspaces.
    pts: Unscented<D>,
    c: Core<D>,
    l: D::Nn,
    /// Reciprocals of the diagonals of the factors of P (`l`) and of Σ (in `sig`).
    linv: D::Nv,
    ht: D::Nm,
    rt: D::Mm,
    w: UpdateWork<D>,
}

impl<D: NlDims, M: NonlinearModel> Ukf<D, M> {
    /// A filter for `model` with prior mean `x0` (length n), covariance `P0` (n×n,
    /// symmetric PSD) and the sigma-point set `points`. All workspaces are allocated here.
    ///
    /// # Errors
    /// As [`crate::Filter::new`] for `x0` and `P0`; [`Error::InvalidOption`] from
    /// [`SigmaPoints::weights`].
    pub fn new(
        dims: D,
        model: M,
        x0: &[f64],
        P0: &impl MatrixInput,
        points: SigmaPoints,
    ) -> Result<Self, Error> {
        let c = Core::new(dims, &model, x0, P0)?;
        let (n, m) = (dims.n(), dims.m());
        Ok(Self {
            w: UpdateWork::new(n, m),
            model,
            pts: Unscented::new(points, n, m, dims.stored())?,
            c,
            l: D::Nn::zeros(n * n),
            linv: D::Nv::zeros(n),
            ht: D::Nm::zeros(n * m),
            rt: D::Mm::zeros(m * m),
        })
    }

    /// Step k: update with `z_k` (NaN entries are missing; all NaN is predict-only), then
    /// predict to k + 1 with the control `u_k` (passed to f).
    ///
    /// # Errors
    /// [`Error::Shape`] naming `z`; [`Error::ModelNonFinite`] naming the function and the
    /// step; [`Error::SigmaCovariance`]; [`Error::SingularInnovation`]. After an error the
    /// step counter has not advanced and the estimates may be partly written:
    /// [`Ukf::reset`] the filter.
    pub fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, Error> {
        self.run_step(z, u)
    }

    /// Sigma points of `(x, P)` into `chi` (and the factor of P into `l`).
    fn draw(&mut self, predicted: bool) -> Result<(), Error> {
        let (n, k, ns) = (self.c.dims.n(), self.c.k, self.c.dims.stored());
        let (x, P, name) = if predicted {
            (&self.c.xp, &self.c.pp, "P_{k|k-1}")
        } else {
            (&self.c.xf, &self.c.pf, "P_{k|k}")
        };
        let (x, P) = (&x.as_slice()[..ns], &P.as_slice()[..n * n]);
        let L = &mut self.l.as_mut_slice()[..n * n];
        let inv = &mut self.linv.as_mut_slice()[..n];
        psd_cholesky(P, n, L, inv, RANK_TOL, PSD_TOL).map_err(|pivot| Error::SigmaCovariance {
            name,
            step: k,
            n,
            pivot,
            tol: PSD_TOL,
        })?;
        self.pts
            .draw(&self.model, x, L, n, &mut self.w.dx.as_mut_slice()[..n]);
        Ok(())
    }
}

impl<D: NlDims, M: NonlinearModel> ObservedUpdate<D> for Ukf<D, M> {
    #[inline(always)]
    fn update_observed(&mut self, z: &[f64], mo: usize, info: StepInfo) -> Result<StepInfo, Error> {
        let (n, m, k) = (self.c.dims.n(), self.c.dims.m(), self.c.k);
        let ns = self.c.dims.stored();
        let s = self.pts.set.count;
        self.draw(true)?;
        // ẑ and the deviations dz (mo × s, observed rows), dchi = χ_i ⊖ x⁻ (n × s).
        self.pts.measure(&mut self.model, z, ns, m, mo, k)?;
        let wc = &self.pts.set.wc.as_slice()[..s];
        let chi = &self.pts.chi.as_slice()[..ns * s];
        let xp = &self.c.xp.as_slice()[..ns];
        let dz = &self.pts.dz.as_slice()[..mo * s];
        let dchi = &mut self.pts.dchi.as_mut_slice()[..n * s];
        for i in 0..s {
            self.model.state_residual(
                &chi[i * ns..(i + 1) * ns],
                xp,
                &mut dchi[i * n..(i + 1) * n],
            );
        }
        let sig = &mut self.w.sig.as_mut_slice()[..mo * mo];
        self.c.observed_r(z, mo, sig);
        let C = &mut self.w.gain.as_mut_slice()[..n * mo];
        C.fill(0.0);
        for i in 0..s {
            let d = &dz[i * mo..(i + 1) * mo];
            rank1_lower(sig, wc[i], d, mo);
            rank1(C, wc[i], &dchi[i * n..(i + 1) * n], d, n, mo);
        }
        mirror_lower(sig, mo);
        // With P = L Lᵀ and G = L⁻¹ C (a forward solve; zero pivots give zero rows, the
        // minimum-norm choice): H̃ L = Cᵀ L⁻ᵀ = Gᵀ and R̃ = Σ − Cᵀ P⁻¹ C = Σ − Gᵀ G,
        // formed before Σ is factored in place.
        let L = &self.l.as_slice()[..n * n];
        let G = &mut self.ht.as_mut_slice()[..n * mo];
        G.copy_from_slice(C);
        let linv = &self.linv.as_slice()[..n];
        for j in 0..mo {
            forward(L, linv, n, &mut G[j * n..(j + 1) * n]);
        }
        let rt = &mut self.rt.as_mut_slice()[..mo * mo];
        rt.copy_from_slice(sig);
        // The R_c workspace (R is copied straight into Σ) holds Gᵀ G.
        let gtg = &mut self.w.rc.as_mut_slice()[..mo * mo];
        mul_tn(gtg, G, G, mo, n, mo, false);
        for (r, v) in rt.iter_mut().zip(gtg.iter()) {
            *r -= v;
        }
        // Σ and Gᵀ G are symmetric: R̃ too, up to rounding; make it exact.
        mirror_lower(rt, mo);
        let sinv = &mut self.w.sinv.as_mut_slice()[..mo];
        if let Err(pivot) = pd_cholesky(sig, mo, sinv, RANK_TOL) {
            return Err(Error::SingularInnovation {
                filter: "UKF",
                step: k,
                m: mo,
                pivot,
                tol: RANK_TOL,
            });
        }
        let K = C;
        right_solve(sig, sinv, mo, K, n);
        let e = &mut self.w.e.as_mut_slice()[..mo];
        self.pts.innovation(&self.model, z, m, mo, e);
        let dx = &mut self.w.dx.as_mut_slice()[..n];
        mul(dx, K, e, n, mo, 1, false);
        self.model
            .state_add(xp, dx, &mut self.c.xf.as_mut_slice()[..ns]);
        // The Joseph form (I − K H̃) P (I − K H̃)ᵀ + K R̃ Kᵀ through the factor of P:
        // (I − K H̃) L = L − K Gᵀ.
        factored_joseph(
            L,
            K,
            G,
            rt,
            n,
            mo,
            &mut self.c.pf.as_mut_slice()[..n * n],
            &mut self.w.a.as_mut_slice()[..n * n],
            &mut self.w.kr.as_mut_slice()[..n * mo],
        );
        let nl = nis_logdet(sig, sinv, mo, e, &mut self.w.tmpm.as_mut_slice()[..mo]);
        Ok(observed_info(info, nl.0, nl.1, 1))
    }
}

impl<D: NlDims, M: NonlinearModel> Stages<D> for Ukf<D, M> {
    fn core(&mut self) -> &mut Core<D> {
        &mut self.c
    }

    fn update_stage(&mut self, z: &[f64]) -> Result<StepInfo, Error> {
        let info = self.c.open_update(&mut self.model, z)?;
        self.update_rows(z, info)
    }

    fn predict_stage(&mut self, u: Option<&[f64]>) -> Result<(), Error> {
        let (n, k, ns) = (self.c.dims.n(), self.c.k, self.c.dims.stored());
        let s = self.pts.set.count;
        self.c.load_q(&mut self.model)?;
        self.draw(false)?;
        self.pts.propagate(
            &mut self.model,
            u,
            (n, ns),
            k,
            &self.c.xf.as_slice()[..ns],
            &mut self.c.xp.as_mut_slice()[..ns],
            self.w.dx.as_mut_slice(),
        )?;
        let wc = &self.pts.set.wc.as_slice()[..s];
        let dy = &self.pts.dy.as_slice()[..n * s];
        let pp = &mut self.c.pp.as_mut_slice()[..n * n];
        pp.copy_from_slice(&self.c.q.as_slice()[..n * n]);
        // The cross-covariance C_k = Σ Wc_i dchi_i dy_iᵀ is formed only when a smoother asks
        // for it (`cross_covariance`, from the deviations kept until the next step).
        for i in 0..s {
            let d = &dy[i * n..(i + 1) * n];
            rank1_lower(pp, wc[i], d, n);
        }
        mirror_lower(pp, n);
        Ok(())
    }
}

impl<D: NlDims, M: NonlinearModel> Ukf<D, M> {
    /// Restarts from the prior `(x0, P0)` at step 0, keeping the model and workspaces.
    ///
    /// # Errors
    /// As [`Ukf::new`] for `x0` and `P0`.
    pub fn reset(&mut self, x0: &[f64], P0: &impl MatrixInput) -> Result<(), Error> {
        self.c.reset(&self.model, x0, P0)
    }
}

impl<D: NlDims, M> Ukf<D, M> {
    /// The sigma-point set.
    pub fn sigma_points(&self) -> SigmaPoints {
        self.pts.set.points
    }
    filter_accessors!();
}

impl<D: NlDims, M> super::ForwardPass for Ukf<D, M> {
    forward_pass_moments!();
    /// `C_k = Σ Wc_i (χ_i ⊖ x_{k|k})(f(χ_i) ⊖ x_{k+1|k})ᵀ` of the last prediction.
    fn cross_covariance(&self, out: &mut [f64]) {
        self.pts.cross_covariance(self.c.dims.n(), out);
    }
}
