//! The square-root unscented Kalman filter: the UKF of [`super::Ukf`] propagating the
//! Cholesky factors of its covariances through orthogonal triangularisations.
#![allow(non_snake_case)]

use faer::MatRef;

use super::linalg::{downdate_rows, gram_lower, positive_pivots, psd_cholesky, rank1};
use super::sigma::SigmaPoints;
use super::unscented::Unscented;
use super::{Core, NlDims, NonlinearModel, ObservedUpdate, Stages, StepInfo, observed_info};
use crate::kernels::{dot, lq_rows};
use crate::storage::Buf;
use crate::{Error, MatrixInput, PSD_TOL, RANK_TOL};

/// The square-root unscented Kalman filter (additive noise) on the storage path `D`: the
/// filter of [`super::Ukf`] — the same sigma points, means and statistical linearisation,
/// equal to it to round-off where both run — with the lower Cholesky factors S of
/// `P_{k|k}` and `P_{k+1|k}` propagated instead of the covariances (Van der Merwe and Wan,
/// "The square-root unscented Kalman filter for state and parameter-estimation", in the
/// array form of the linear square-root filter). Nothing is ever factored from a formed
/// covariance, so what the plain filter loses to squaring (a Σ or P whose condition number
/// passes 10¹², from badly scaled states or a measurement noise near zero) the factors
/// keep.
///
/// Update with z_k: sigma points `χ_i = x⁻ ⊕ S⁻ ξ_i` (no factorisation: S⁻ is carried),
/// deviations `dz_i = h(χ_i) ⊖ ẑ`, the regression `G = Σ Wc_i ξ_i dz_iᵀ` (n×m; `C = S⁻ G`
/// is the cross-covariance and `H̃ = Gᵀ S⁻⁻¹` the statistically linearised h) and its
/// residuals `ε_i = dz_i − Gᵀ ξ_i`; then one Householder triangularisation of the pre-array
///
/// ```text
///   [ R^{1/2}  √Wc_i ε_i …  Gᵀ ]   m rows        [ Σ^{1/2}   0    0  ]
///   [   0          0        S⁻ ]   n rows   →    [   K̄       0    S⁺ ]
/// ```
///
/// gives `Σ^{1/2}`, `K̄ = K Σ^{1/2}` and the factor S⁺ of `P_{k|k}`, and
/// `x = x⁻ ⊕ K̄ Σ^{-1/2}(z ⊖ ẑ)`. The first two blocks, zero in the state rows, are
/// triangularised first on their own (to `L₀`, m × m), so the joint triangularisation runs
/// on `[[L₀, Gᵀ], [0, S⁻]]`, (m + n) × (m + n), whatever the number of points. The
/// pre-array's Gram matrix is exactly the plain filter's `[[Σ, Cᵀ], [C, P⁻]]`.
/// Prediction: `x⁺` as in the plain filter, and `S⁺` from the triangularisation of
/// `[√Wc_i (f(χ_i) ⊖ x⁺) …, Q^{1/2}]`. Every pivot is made positive, so where P is positive
/// definite S is its Cholesky factor and the sigma points are the plain filter's.
///
/// Only a negative centre weight `Wc_0` (Merwe's set with small α, Julier's with κ < 0)
/// needs a subtraction, a rank-one Cholesky downdate by `√|Wc_0|` times the centre
/// deviation after each triangularisation; when the difference is not positive
/// definite the step returns [`Error::SigmaCovariance`] (the plain filter's covariance
/// would be indefinite there too). The cubature, the simplex and Julier's set with κ ≥ 0
/// have no negative weight: their factors are products of orthogonal transformations
/// alone and cannot fail to exist.
///
/// An innovation row is singular when its pivot in `Σ^{1/2}` is at most
/// `√RANK_TOL` times that row's norm in the pre-array — a test on each measurement's own
/// scale, unchanged by a change of units of one channel — where the plain filter compares
/// the pivots of Σ with its largest diagonal entry. A step allocates nothing (the
/// pre-array is one buffer sized at construction, on both paths).
///
/// ```
/// use kalman::DynDims;
/// use kalman::nonlinear::{FnModel, SigmaPoints, SqrtUkf, Ukf};
/// # fn main() -> Result<(), kalman::Error> {
/// let d = DynDims::new(2, 1, 0)?;
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
/// let p0 = [[0.01, 0.0], [0.0, 0.01]];
/// let mut plain = Ukf::new(d, model.clone(), &[1.0, 1.0], &p0, SigmaPoints::Cubature)?;
/// let mut sqrt = SqrtUkf::new(d, model, &[1.0, 1.0], &p0, SigmaPoints::Cubature)?;
/// for k in 0..20 {
///     let x = 1.0 + 0.1 * k as f64;
///     let z = [(x * x + 1.0f64).sqrt()];
///     plain.step(&z, None)?;
///     sqrt.step(&z, None)?;
/// }
/// // The same filter: estimates agree to round-off.
/// assert!((sqrt.state()[0] - plain.state()[0]).abs() < 1e-12);
/// let s = sqrt.covariance_factor();
/// assert!((s[(0, 0)] * s[(0, 0)] - plain.covariance()[(0, 0)]).abs() < 1e-15);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct SqrtUkf<D: NlDims, M> {
    model: M,
    /// The sigma-point set and its workspaces.
    pts: Unscented<D>,
    c: Core<D>,
    /// Lower factors of `P_{k+1|k}` and `P_{k|k}` (column-major).
    sp: D::Nn,
    sf: D::Nn,
    /// G (n × m), the factors of Q and R and the reciprocals of their diagonals.
    g: D::Nm,
    qs: D::Nn,
    qinv: D::Nv,
    rc: D::Mm,
    rs: D::Mm,
    rinv: D::Mv,
    dx: D::Nv,
    xi: D::Nv,
    e: D::Mv,
    /// The Q and R last factored into `qs` and `rs`, and their orders (`None`: none yet,
    /// or the last factorisation failed).
    q_of: D::Nn,
    q_at: Option<usize>,
    r_of: D::Mm,
    r_at: Option<usize>,
    /// The pre-array (row-major), its pivots and the rows' squared norms.
    arr: Vec<f64>,
    /// The measurement rows' noise blocks before the joint array (row-major, m × (m + s)).
    pre: Vec<f64>,
    /// `√Wc_i` for the positive weights, 0 for a negative centre weight (s entries).
    swc: Vec<f64>,
    piv: Vec<Option<usize>>,
    rn: Vec<f64>,
    /// The downdate's vector (m + n).
    v: Vec<f64>,
}

impl<D: NlDims, M: NonlinearModel> SqrtUkf<D, M> {
    /// A filter for `model` with prior mean `x0` (length n), covariance `P0` (n×n,
    /// symmetric PSD, factored once here) and the sigma-point set `points`. All workspaces
    /// are allocated here.
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
        let pts = Unscented::<D>::new(points, n, m, dims.stored())?;
        let s = pts.set.count;
        let swc: Vec<f64> = pts.set.wc.as_slice()[..s]
            .iter()
            .map(|&w| if w > 0.0 { w.sqrt() } else { 0.0 })
            .collect();
        // The joint (m + n)² update array, or the prediction's n × (s + n).
        let ld = ((m + n) * (m + n)).max(n * (s + n));
        let mut f = Self {
            model,
            pts,
            sp: D::Nn::zeros(n * n),
            sf: D::Nn::zeros(n * n),
            g: D::Nm::zeros(n * m),
            qs: D::Nn::zeros(n * n),
            qinv: D::Nv::zeros(n),
            rc: D::Mm::zeros(m * m),
            rs: D::Mm::zeros(m * m),
            rinv: D::Mv::zeros(m),
            q_of: D::Nn::zeros(n * n),
            q_at: None,
            r_of: D::Mm::zeros(m * m),
            r_at: None,
            dx: D::Nv::zeros(n),
            xi: D::Nv::zeros(n),
            e: D::Mv::zeros(m),
            arr: vec![0.0; ld],
            pre: vec![0.0; m * (m + s)],
            swc,
            piv: vec![None; m + n],
            rn: vec![0.0; m],
            v: vec![0.0; m + n],
            c,
        };
        f.factor_prior()?;
        Ok(f)
    }

    /// Step k: update with `z_k` (NaN entries are missing; all NaN is predict-only), then
    /// predict to k + 1 with the control `u_k` (passed to f).
    ///
    /// # Errors
    /// [`Error::Shape`] naming `z`; [`Error::ModelNonFinite`] naming the function and the
    /// step; [`Error::SigmaCovariance`] for an indefinite Q_k or R_k or a failed
    /// centre-weight downdate; [`Error::SingularInnovation`]. After an error the step
    /// counter has not advanced and the estimates may be partly written:
    /// [`SqrtUkf::reset`] the filter.
    pub fn step(&mut self, z: &[f64], u: Option<&[f64]>) -> Result<StepInfo, Error> {
        self.run_step(z, u)
    }
}

impl<D: NlDims, M: NonlinearModel> ObservedUpdate<D> for SqrtUkf<D, M> {
    #[inline(always)]
    fn update_observed(&mut self, z: &[f64], mo: usize, info: StepInfo) -> Result<StepInfo, Error> {
        let (n, m, k) = (self.c.dims.n(), self.c.dims.m(), self.c.k);
        let ns = self.c.dims.stored();
        let s = self.pts.set.count;
        let xp = &self.c.xp.as_slice()[..ns];
        let Sp = &self.sp.as_slice()[..n * n];
        self.pts
            .draw(&self.model, xp, Sp, n, self.dx.as_mut_slice());
        // ẑ and the deviations dz (mo × s), as in the plain filter.
        self.pts.measure(&mut self.model, z, ns, m, mo, k)?;
        let set = &self.pts.set;
        let wc = &set.wc.as_slice()[..s];
        let dz = &mut self.pts.dz.as_mut_slice()[..mo * s];
        // G = Σ Wc_i ξ_i dz_iᵀ, then the residuals ε_i = dz_i − Gᵀ ξ_i in place of dz_i.
        let G = &mut self.g.as_mut_slice()[..n * mo];
        G.fill(0.0);
        let xi = &mut self.xi.as_mut_slice()[..n];
        for i in 0..s {
            set.unit(n, i, xi);
            rank1(G, wc[i], xi, &dz[i * mo..(i + 1) * mo], n, mo);
        }
        for i in 0..s {
            set.unit(n, i, xi);
            let di = &mut dz[i * mo..(i + 1) * mo];
            for (a, d) in di.iter_mut().enumerate() {
                let g = &G[a * n..(a + 1) * n];
                *d -= g.iter().zip(xi.iter()).map(|(p, q)| p * q).sum::<f64>();
            }
        }
        // R^{1/2} of the observed block.
        let rc = &mut self.rc.as_mut_slice()[..mo * mo];
        self.c.observed_r(z, mo, rc);
        let Rs = &mut self.rs.as_mut_slice()[..mo * mo];
        let (last, rinv) = (self.r_of.as_mut_slice(), self.rinv.as_mut_slice());
        cached_factor(rc, mo, Rs, rinv, (last, &mut self.r_at), ("R_k", k))?;
        // The measurement rows' first two blocks, [R^{1/2}, √Wc ε] (mo rows of length
        // mo + s), triangularised alone to L₀ with L₀L₀ᵀ = R + Σ Wc εεᵀ: the state rows are
        // zero in those columns, so the joint pre-array needs only L₀ in their place.
        let lp = mo + s;
        let pre = &mut self.pre[..mo * lp];
        pre.fill(0.0);
        for a in 0..mo {
            let row = &mut pre[a * lp..(a + 1) * lp];
            for b in 0..=a {
                row[b] = Rs[a + b * mo];
            }
            for (i, w) in self.swc.iter().enumerate() {
                row[mo + i] = w * dz[a + i * mo];
            }
            let g = &G[a * n..(a + 1) * n];
            self.rn[a] = dot(row, row) + dot(g, g);
        }
        lq_rows(pre, lp, 0..mo, mo, 0, lp, 0.0, &mut self.piv[..mo]);
        // The joint pre-array [[L₀, Gᵀ], [0, S⁻]], rows of length ld = mo + n.
        let ld = mo + n;
        let rows = mo + n;
        let arr = &mut self.arr[..rows * ld];
        arr.fill(0.0);
        for a in 0..mo {
            let row = &mut arr[a * ld..(a + 1) * ld];
            row[..mo].copy_from_slice(&pre[a * lp..a * lp + mo]);
            for j in 0..n {
                row[mo + j] = G[j + a * n];
            }
        }
        for r in 0..n {
            let row = &mut arr[(mo + r) * ld..(mo + r + 1) * ld];
            for j in 0..=r {
                row[mo + j] = Sp[r + j * n];
            }
        }
        let piv = &mut self.piv[..rows];
        lq_rows(arr, ld, 0..mo, rows, 0, ld, 0.0, &mut piv[..mo]);
        for a in 0..mo {
            let d = match piv[a] {
                Some(c) if c == a => arr[a * ld + a] * arr[a * ld + a],
                _ => 0.0,
            };
            if d <= RANK_TOL * self.rn[a] {
                return Err(Error::SingularInnovation {
                    filter: "square-root UKF",
                    step: k,
                    m: mo,
                    pivot: d / self.rn[a],
                    tol: RANK_TOL,
                });
            }
        }
        positive_pivots(arr, ld, 0..mo, rows, &piv[..mo]);
        lq_rows(arr, ld, mo..rows, rows, mo, ld, 0.0, &mut piv[mo..]);
        positive_pivots(arr, ld, mo..rows, rows, &piv[mo..]);
        // A negative centre weight: downdate the joint factor by √|Wc_0| [ε_0; 0].
        if wc[0] < 0.0 {
            let v = &mut self.v[..rows];
            let w = (-wc[0]).sqrt();
            for (a, vi) in v.iter_mut().enumerate() {
                *vi = if a < mo { w * dz[a] } else { 0.0 };
            }
            downdate_rows(arr, ld, rows, v).map_err(|pivot| Error::SigmaCovariance {
                name: "P_{k|k} (centre-weight downdate)",
                step: k,
                n,
                pivot,
                tol: 0.0,
            })?;
        }
        // y = Σ^{-1/2} e, x = x⁻ ⊕ K̄ y.
        let e = &mut self.e.as_mut_slice()[..mo];
        self.pts.innovation(&self.model, z, m, mo, e);
        let mut logdet = 0.0;
        for a in 0..mo {
            let mut v = e[a];
            for b in 0..a {
                v -= arr[a * ld + b] * e[b];
            }
            let d = arr[a * ld + a];
            e[a] = v / d;
            logdet += 2.0 * d.ln();
        }
        let nis: f64 = e.iter().map(|v| v * v).sum();
        let dx = &mut self.dx.as_mut_slice()[..n];
        for r in 0..n {
            let row = &arr[(mo + r) * ld..(mo + r) * ld + mo];
            dx[r] = row.iter().zip(e.iter()).map(|(p, q)| p * q).sum();
        }
        self.model
            .state_add(xp, dx, &mut self.c.xf.as_mut_slice()[..ns]);
        let Sf = &mut self.sf.as_mut_slice()[..n * n];
        for r in 0..n {
            for j in 0..n {
                Sf[r + j * n] = if j <= r {
                    arr[(mo + r) * ld + mo + j]
                } else {
                    0.0
                };
            }
        }
        gram_lower(Sf, n, &mut self.c.pf.as_mut_slice()[..n * n]);
        Ok(observed_info(info, nis, logdet, 1))
    }
}

impl<D: NlDims, M: NonlinearModel> Stages<D> for SqrtUkf<D, M> {
    fn core(&mut self) -> &mut Core<D> {
        &mut self.c
    }

    fn update_stage(&mut self, z: &[f64]) -> Result<StepInfo, Error> {
        let n = self.c.dims.n();
        let info = self.c.open_update(&mut self.model, z)?;
        if info.observed == 0 {
            self.sf.as_mut_slice()[..n * n].copy_from_slice(&self.sp.as_slice()[..n * n]);
        }
        self.update_rows(z, info)
    }

    fn predict_stage(&mut self, u: Option<&[f64]>) -> Result<(), Error> {
        let (n, k) = (self.c.dims.n(), self.c.k);
        let s = self.pts.set.count;
        self.c.load_q(&mut self.model)?;
        let Qs = &mut self.qs.as_mut_slice()[..n * n];
        let q = &self.c.q.as_slice()[..n * n];
        let (last, qinv) = (self.q_of.as_mut_slice(), self.qinv.as_mut_slice());
        cached_factor(q, n, Qs, qinv, (last, &mut self.q_at), ("Q_k", k))?;
        let ns = self.c.dims.stored();
        let xf = &self.c.xf.as_slice()[..ns];
        let dx = self.dx.as_mut_slice();
        self.pts
            .draw(&self.model, xf, &self.sf.as_slice()[..n * n], n, dx);
        // x⁺ and the deviations, as in the plain filter.
        let xp = &mut self.c.xp.as_mut_slice()[..ns];
        self.pts
            .propagate(&mut self.model, u, (n, ns), k, xf, xp, dx)?;
        let wc = &self.pts.set.wc.as_slice()[..s];
        let dy = &self.pts.dy.as_slice()[..n * s];
        // [√Wc_i dy_i …, Q^{1/2}] (n rows of length s + n), triangularised.
        let ld = s + n;
        let arr = &mut self.arr[..n * ld];
        for r in 0..n {
            let row = &mut arr[r * ld..(r + 1) * ld];
            for (i, w) in self.swc.iter().enumerate() {
                row[i] = w * dy[r + i * n];
            }
            for j in 0..n {
                row[s + j] = Qs[r + j * n];
            }
        }
        let piv = &mut self.piv[..n];
        lq_rows(arr, ld, 0..n, n, 0, ld, 0.0, piv);
        positive_pivots(arr, ld, 0..n, n, piv);
        if wc[0] < 0.0 {
            let v = &mut self.v[..n];
            let w = (-wc[0]).sqrt();
            for (r, vi) in v.iter_mut().enumerate() {
                *vi = w * dy[r];
            }
            downdate_rows(arr, ld, n, v).map_err(|pivot| Error::SigmaCovariance {
                name: "P_{k+1|k} (centre-weight downdate)",
                step: k,
                n,
                pivot,
                tol: 0.0,
            })?;
        }
        let Sp = &mut self.sp.as_mut_slice()[..n * n];
        for r in 0..n {
            for j in 0..n {
                Sp[r + j * n] = if j <= r { arr[r * ld + j] } else { 0.0 };
            }
        }
        gram_lower(Sp, n, &mut self.c.pp.as_mut_slice()[..n * n]);
        Ok(())
    }
}

/// The lower factor of the PSD `a` (n×n) into `L` (reciprocal pivots in `inv`), unless `a`
/// equals, entry for entry, the matrix `last.0` of the previous call (of order `last.1`),
/// whose factor `L` still holds: a constant Q or R is factored once.
fn cached_factor(
    a: &[f64],
    n: usize,
    L: &mut [f64],
    inv: &mut [f64],
    last: (&mut [f64], &mut Option<usize>),
    (name, step): (&'static str, usize),
) -> Result<(), Error> {
    let (of, at) = last;
    let (a, of) = (&a[..n * n], &mut of[..n * n]);
    if *at == Some(n) && a == &of[..] {
        return Ok(());
    }
    *at = None;
    psd_cholesky(a, n, L, &mut inv[..n], 0.0, PSD_TOL).map_err(|pivot| Error::SigmaCovariance {
        name,
        step,
        n,
        pivot,
        tol: PSD_TOL,
    })?;
    of.copy_from_slice(a);
    *at = Some(n);
    Ok(())
}

impl<D: NlDims, M: NonlinearModel> SqrtUkf<D, M> {
    /// Restarts from the prior `(x0, P0)` at step 0, keeping the model and workspaces.
    ///
    /// # Errors
    /// As [`SqrtUkf::new`] for `x0` and `P0`.
    pub fn reset(&mut self, x0: &[f64], P0: &impl MatrixInput) -> Result<(), Error> {
        self.c.reset(&self.model, x0, P0)?;
        self.factor_prior()
    }
}

impl<D: NlDims, M> SqrtUkf<D, M> {
    /// The factor of the prior `P0` (held in `c.pp`) into `sp` and `sf`.
    fn factor_prior(&mut self) -> Result<(), Error> {
        let n = self.c.dims.n();
        let Sp = &mut self.sp.as_mut_slice()[..n * n];
        psd_cholesky(
            &self.c.pp.as_slice()[..n * n],
            n,
            Sp,
            &mut self.qinv.as_mut_slice()[..n],
            0.0,
            PSD_TOL,
        )
        .map_err(|pivot| Error::SigmaCovariance {
            name: "P0",
            step: 0,
            n,
            pivot,
            tol: PSD_TOL,
        })?;
        self.sf.as_mut_slice()[..n * n].copy_from_slice(Sp);
        Ok(())
    }

    /// The sigma-point set.
    pub fn sigma_points(&self) -> SigmaPoints {
        self.pts.set.points
    }
    /// The lower factor S of `P_{k|k}` (`S Sᵀ = P_{k|k}`; its Cholesky factor where P is
    /// positive definite).
    pub fn covariance_factor(&self) -> MatRef<'_, f64> {
        let n = self.c.dims.n();
        MatRef::from_column_major_slice(&self.sf.as_slice()[..n * n], n, n)
    }
    /// The lower factor of `P_{k+1|k}`.
    pub fn predicted_covariance_factor(&self) -> MatRef<'_, f64> {
        let n = self.c.dims.n();
        MatRef::from_column_major_slice(&self.sp.as_slice()[..n * n], n, n)
    }
    filter_accessors!();
}

impl<D: NlDims, M> super::ForwardPass for SqrtUkf<D, M> {
    forward_pass_moments!();
    /// `C_k = Σ Wc_i (χ_i ⊖ x_{k|k})(f(χ_i) ⊖ x_{k+1|k})ᵀ` of the last prediction.
    fn cross_covariance(&self, out: &mut [f64]) {
        self.pts.cross_covariance(self.c.dims.n(), out);
    }
}
