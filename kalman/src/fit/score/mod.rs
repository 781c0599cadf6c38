//! The exact log-likelihood and its gradient by the score recursion: the prediction-error
//! filter differentiated analytically, one `(∂x, ∂P)` pair per parameter.

mod steady;

use super::dense::{gemm, lower_factor, solve_each_column, symmetrise};
use super::{Derivative, FitError, LN_2PI, ParamMap, Series, System, flat};
use steady::Steady;

/// Column-major copies of a system's matrices.
pub(crate) struct Flat {
    pub n: usize,
    pub m: usize,
    pub p: usize,
    pub F: Vec<f64>,
    pub H: Vec<f64>,
    pub Q: Vec<f64>,
    pub R: Vec<f64>,
    pub B: Vec<f64>,
    pub x0: Vec<f64>,
    pub P0: Vec<f64>,
}

impl Flat {
    /// `xn = F x + B u`; `u` is empty when the data have no input columns (u = 0, which a
    /// model with B accepts), else of length p.
    pub(crate) fn predict_mean(&self, xn: &mut [f64], x: &[f64], u: &[f64]) {
        let n = self.n;
        gemm(xn, n, 1, n, 1.0, &self.F, n, false, x, n, false, 0.0);
        if !u.is_empty() {
            gemm(
                xn, n, 1, self.p, 1.0, &self.B, n, false, u, self.p, false, 1.0,
            );
        }
    }

    pub(crate) fn new(s: &System) -> Self {
        Self {
            n: s.n(),
            m: s.m(),
            p: s.p(),
            F: flat(&s.f),
            H: flat(&s.h),
            Q: flat(&s.q),
            R: flat(&s.r),
            B: flat(&s.b),
            x0: s.x0.clone(),
            P0: flat(&s.p0),
        }
    }
}

struct FlatDeriv {
    F: Option<Vec<f64>>,
    B: Option<Vec<f64>>,
    H: Option<Vec<f64>>,
    Q: Option<Vec<f64>>,
    R: Option<Vec<f64>>,
    x0: Option<Vec<f64>>,
    P0: Option<Vec<f64>>,
}

impl FlatDeriv {
    fn new(d: &Derivative) -> Self {
        Self {
            F: d.f.as_ref().map(flat),
            B: d.b.as_ref().map(flat),
            H: d.h.as_ref().map(flat),
            Q: d.q.as_ref().map(flat),
            R: d.r.as_ref().map(flat),
            x0: d.x0.clone(),
            P0: d.p0.as_ref().map(flat),
        }
    }
}

/// The prediction's part of the state derivative, `dxn = F ∂x + ∂F x + ∂B u` (`u` empty
/// without inputs).
fn predict_dx(dxn: &mut [f64], s: &Flat, di: &FlatDeriv, dx: &[f64], x: &[f64], u: &[f64]) {
    let n = s.n;
    gemm(dxn, n, 1, n, 1.0, &s.F, n, false, dx, n, false, 0.0);
    if let Some(df) = &di.F {
        gemm(dxn, n, 1, n, 1.0, df, n, false, x, n, false, 1.0);
    }
    if let Some(db) = &di.B
        && !u.is_empty()
    {
        gemm(dxn, n, 1, s.p, 1.0, db, n, false, u, s.p, false, 1.0);
    }
}

/// The prediction's part of the covariance derivative, written to `dPn`:
/// F ∂P Fᵀ + ∂F P Fᵀ + F P ∂Fᵀ + ∂Q, with `FP` = F P (a filtered P) and `tn` an n×n scratch.
fn predict_dP(
    dPn: &mut [f64],
    tn: &mut [f64],
    F: &[f64],
    dP: &[f64],
    di: &FlatDeriv,
    FP: &[f64],
    n: usize,
) {
    gemm(tn, n, n, n, 1.0, F, n, false, dP, n, false, 0.0);
    gemm(dPn, n, n, n, 1.0, tn, n, false, F, n, true, 0.0);
    if let Some(df) = &di.F {
        gemm(tn, n, n, n, 1.0, df, n, false, FP, n, true, 0.0);
        for r in 0..n {
            for c in 0..n {
                dPn[r + c * n] += tn[r + c * n] + tn[c + r * n];
            }
        }
    }
    if let Some(dq) = &di.Q {
        for (a, b) in dPn.iter_mut().zip(dq) {
            *a += b;
        }
    }
}

fn check_deriv(d: &Derivative, s: &System) -> Result<(), FitError> {
    let (n, m) = (s.n(), s.m());
    let bad = |name: &'static str,
               a: &Option<faer::Mat<f64>>,
               r: usize,
               c: usize|
     -> Result<(), FitError> {
        if let Some(a) = a {
            crate::model::check_shape(name, a, r, c)?;
        }
        Ok(())
    };
    bad("dF", &d.f, n, n)?;
    bad("dB", &d.b, n, s.p())?;
    bad("dH", &d.h, m, n)?;
    bad("dQ", &d.q, n, n)?;
    bad("dR", &d.r, m, m)?;
    bad("dP0", &d.p0, n, n)?;
    if let Some(x) = &d.x0
        && x.len() != n
    {
        return Err(crate::Error::Shape {
            name: "dx0",
            rows: x.len(),
            cols: 1,
            expected_rows: n,
            expected_cols: 1,
        }
        .into());
    }
    Ok(())
}

/// The exact log-likelihood of `data` under `map.system(θ)` and its gradient with respect
/// to θ, by the score recursion. The value equals [`super::log_likelihood`] to round-off
/// (it needs every observed innovation covariance positive definite).
///
/// # Errors
/// [`FitError::NotPositiveDefinite`] if an innovation covariance is singular; the map's
/// errors; [`FitError::Data`] if the data's dimensions do not match.
///
/// # Example
/// ```
/// use kalman::fit::{Free, Series, StandardMap, Structure, System, log_likelihood_gradient};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[0.9]], &[[1.0]], &[[1.0]], &[[0.5]], &[0.0], &[[1.0]])?;
/// let map = StandardMap::new(base, Free { q: Structure::Scalar, ..Free::default() })?;
/// let data = [0.2, f64::NAN, -0.4, 0.1];
/// let (ll, grad) = log_likelihood_gradient(&map, &[0.0], &Series::new(&data, 1)?)?;
/// assert!(ll.is_finite() && grad.len() == 1);
/// # Ok(())
/// # }
/// ```
pub fn log_likelihood_gradient<M: ParamMap + ?Sized>(
    map: &M,
    theta: &[f64],
    data: &Series<'_>,
) -> Result<(f64, Vec<f64>), FitError> {
    let sys = map.system(theta)?;
    data.check(&sys)?;
    let d = map.derivatives(theta)?;
    if d.len() != theta.len() {
        return Err(FitError::Parameters(format!(
            "the map gave {} derivatives for {} parameters",
            d.len(),
            theta.len()
        )));
    }
    for di in &d {
        check_deriv(di, &sys)?;
    }
    let flat_d: Vec<FlatDeriv> = d.iter().map(FlatDeriv::new).collect();
    let mut grad = vec![0.0; theta.len()];
    let (ll, _) = score(&Flat::new(&sys), &flat_d, data, &mut grad, true)?;
    Ok((ll, grad))
}

/// One step's inputs to a data stage: the system, the parameters' derivatives, the
/// measurement (NaN for a missing row) and the input (empty without inputs).
#[derive(Clone, Copy)]
struct Observation<'a> {
    s: &'a Flat,
    d: &'a [FlatDeriv],
    z: &'a [f64],
    u: &'a [f64],
}

/// Per-evaluation buffers of the score recursion (allocated once, none per step).
///
/// The recursion splits each step into a *covariance stage* — P, ∂P and everything that
/// depends only on them and on which rows are observed (Σ and its factor, the gains, ∂Σ,
/// ∂M) — and a *data stage* that uses the stage's results with the data (innovation,
/// log-likelihood, gradient, ∂x). The covariance stage does not see the data, so once the
/// recursion of P and ∂P has converged on a fully observed model, its results serve every
/// later fully observed step (see [`score`]).
struct Work {
    x: Vec<f64>,
    xn: Vec<f64>,
    P: Vec<f64>,
    Pn: Vec<f64>,
    /// One entry per parameter.
    par: Vec<ParamWork>,
    obs: Vec<usize>,
    // the covariance stage's results (for the observed rows `obs`)
    Ho: Vec<f64>,
    L: Vec<f64>,
    logdet: f64,
    PHt: Vec<f64>,
    M: Vec<f64>,
    G: Vec<f64>,
    FP: Vec<f64>,
    // scratch
    sig: Vec<f64>,
    X: Vec<f64>,
    tn: Vec<f64>,
    tm: Vec<f64>,
    dHo: Vec<f64>,
    e: Vec<f64>,
    alpha: Vec<f64>,
    de: Vec<f64>,
    dsa: Vec<f64>,
}

/// The derivatives with respect to one parameter: ∂x and ∂P now and next, and the
/// covariance stage's ∂Σ, ∂M and tr(Σ⁻¹∂Σ).
struct ParamWork {
    dx: Vec<f64>,
    dxn: Vec<f64>,
    dP: Vec<f64>,
    dPn: Vec<f64>,
    dsig: Vec<f64>,
    dM: Vec<f64>,
    tr: f64,
}

impl Work {
    fn new(s: &Flat, d: &[FlatDeriv]) -> Self {
        let (n, m) = (s.n, s.m);
        let mut P = s.P0.clone();
        symmetrise(&mut P, n);
        let par = d
            .iter()
            .map(|di| {
                let dx = di.x0.clone().unwrap_or_else(|| vec![0.0; n]);
                let dP = di.P0.clone().unwrap_or_else(|| vec![0.0; n * n]);
                ParamWork {
                    dxn: dx.clone(),
                    dx,
                    dPn: dP.clone(),
                    dP,
                    dsig: vec![0.0; m * m],
                    dM: vec![0.0; n * m],
                    tr: 0.0,
                }
            })
            .collect();
        Self {
            x: s.x0.clone(),
            xn: vec![0.0; n],
            Pn: vec![0.0; n * n],
            P,
            par,
            obs: Vec::with_capacity(m),
            Ho: vec![0.0; m * n],
            L: vec![0.0; m * m],
            logdet: 0.0,
            PHt: vec![0.0; n * m],
            M: vec![0.0; n * m],
            G: vec![0.0; n * m],
            FP: vec![0.0; n * n],
            sig: vec![0.0; m * m],
            X: vec![0.0; m * m],
            tn: vec![0.0; n * n],
            tm: vec![0.0; n * m],
            dHo: vec![0.0; m * n],
            e: vec![0.0; m],
            alpha: vec![0.0; m],
            de: vec![0.0; m],
            dsa: vec![0.0; m],
        }
    }

    /// `dHo` = the observed rows of ∂H for one parameter; `false` when H does not move.
    fn observed_dH(&mut self, di: &FlatDeriv, n: usize, m: usize) -> bool {
        let Some(dh) = &di.H else { return false };
        let mo = self.obs.len();
        for (r, &oi) in self.obs.iter().enumerate() {
            for c in 0..n {
                self.dHo[r + c * mo] = dh[oi + c * m];
            }
        }
        true
    }

    /// The covariance stage of step `k` with `mo = obs.len() > 0` rows observed: `Pn`,
    /// every `dPn`, and Σ's factor, log-determinant, the gain `G = F P Hᵀ Σ⁻¹`, ∂Σ,
    /// tr(Σ⁻¹∂Σ) and ∂M for each parameter.
    fn covariance_stage(&mut self, s: &Flat, d: &[FlatDeriv], k: usize) -> Result<(), FitError> {
        let (n, m) = (s.n, s.m);
        let mo = self.obs.len();
        self.predict_P(s);
        for (r, &i) in self.obs.iter().enumerate() {
            for c in 0..n {
                self.Ho[r + c * mo] = s.H[i + c * m];
            }
        }
        // PHt = P Hoᵀ, Σ = Ho PHt + R_oo
        let (Ho, PHt, sig) = (
            &self.Ho[..mo * n],
            &mut self.PHt[..n * mo],
            &mut self.sig[..mo * mo],
        );
        gemm(PHt, n, mo, n, 1.0, &self.P, n, false, Ho, mo, true, 0.0);
        gemm(sig, mo, mo, n, 1.0, Ho, mo, false, PHt, n, false, 0.0);
        for (c, &j) in self.obs.iter().enumerate() {
            for (r, &i) in self.obs.iter().enumerate() {
                sig[r + c * mo] += s.R[i + j * m];
            }
        }
        symmetrise(sig, mo);
        let L = &mut self.L[..mo * mo];
        L.copy_from_slice(sig);
        if !lower_factor(L, mo) {
            return Err(FitError::NotPositiveDefinite {
                name: "innovation covariance",
                step: k,
            });
        }
        self.logdet = (0..mo).map(|i| 2.0 * L[i + i * mo].ln()).sum();
        // M = F P Hoᵀ, G = M Σ⁻¹ (solve Σ Gᵀ = Mᵀ)
        let (M, G, tm) = (
            &mut self.M[..n * mo],
            &mut self.G[..n * mo],
            &mut self.tm[..n * mo],
        );
        gemm(M, n, mo, n, 1.0, &s.F, n, false, PHt, n, false, 0.0);
        for r in 0..n {
            for c in 0..mo {
                tm[c + r * mo] = M[r + c * n];
            }
        }
        solve_each_column(L, mo, tm, n);
        for r in 0..n {
            for c in 0..mo {
                G[r + c * n] = tm[c + r * mo];
            }
        }
        for (i, di) in d.iter().enumerate() {
            let has_dh = self.observed_dH(di, n, m);
            let (Ho, dHo, PHt, L) = (
                &self.Ho[..mo * n],
                &self.dHo[..mo * n],
                &self.PHt[..n * mo],
                &self.L[..mo * mo],
            );
            let (G, tm, X) = (
                &self.G[..n * mo],
                &mut self.tm[..n * mo],
                &mut self.X[..mo * mo],
            );
            let ParamWork {
                dP,
                dPn,
                dsig,
                dM,
                tr,
                ..
            } = &mut self.par[i];
            let (dsig, dM) = (&mut dsig[..mo * mo], &mut dM[..n * mo]);
            // dΣ = Ho dP Hoᵀ + dHo PHt + (dHo PHt)ᵀ + dR_oo
            gemm(tm, n, mo, n, 1.0, dP, n, false, Ho, mo, true, 0.0);
            gemm(dsig, mo, mo, n, 1.0, Ho, mo, false, tm, n, false, 0.0);
            if has_dh {
                gemm(X, mo, mo, n, 1.0, dHo, mo, false, PHt, n, false, 0.0);
                for c in 0..mo {
                    for r in 0..mo {
                        dsig[r + c * mo] += X[r + c * mo] + X[c + r * mo];
                    }
                }
            }
            if let Some(dr) = &di.R {
                for (c, &oj) in self.obs.iter().enumerate() {
                    for (r, &oi) in self.obs.iter().enumerate() {
                        dsig[r + c * mo] += dr[oi + oj * m];
                    }
                }
            }
            // tr(Σ⁻¹ dΣ)
            X.copy_from_slice(dsig);
            solve_each_column(L, mo, X, mo);
            *tr = (0..mo).map(|r| X[r + r * mo]).sum();
            // dM = dF P Hoᵀ + F dP Hoᵀ + F P dHoᵀ   (tm holds dP Hoᵀ)
            gemm(dM, n, mo, n, 1.0, &s.F, n, false, tm, n, false, 0.0);
            if let Some(df) = &di.F {
                gemm(dM, n, mo, n, 1.0, df, n, false, PHt, n, false, 1.0);
            }
            if has_dh {
                gemm(dM, n, mo, n, 1.0, &self.FP, n, false, dHo, mo, true, 1.0);
            }
            // dP' = dF P Fᵀ + F P dFᵀ + F dP Fᵀ + dQ − dM Gᵀ − G dMᵀ + G dΣ Gᵀ
            predict_dP(dPn, &mut self.tn, &s.F, dP, di, &self.FP, n);
            gemm(&mut self.tn, n, n, mo, 1.0, dM, n, false, G, n, true, 0.0);
            for r in 0..n {
                for c in 0..n {
                    dPn[r + c * n] -= self.tn[r + c * n] + self.tn[c + r * n];
                }
            }
            gemm(tm, n, mo, mo, 1.0, G, n, false, dsig, mo, false, 0.0);
            gemm(dPn, n, n, mo, 1.0, tm, n, false, G, n, true, 1.0);
            symmetrise(dPn, n);
        }
        // P' = F P Fᵀ + Q − G Mᵀ
        let (G, M) = (&self.G[..n * mo], &self.M[..n * mo]);
        gemm(&mut self.Pn, n, n, mo, -1.0, G, n, false, M, n, true, 1.0);
        symmetrise(&mut self.Pn, n);
        Ok(())
    }

    /// The data stage of a step with `obs.len() > 0` rows observed, on the covariance
    /// stage's results: the step's log-likelihood term (returned), the gradient's terms
    /// (added to `grad`), `xn` and every `dxn`.
    fn data_stage(&mut self, at: &Observation<'_>, grad: &mut [f64]) -> f64 {
        let Observation { s, d, z, u } = *at;
        let (n, m) = (s.n, s.m);
        let mo = self.obs.len();
        s.predict_mean(&mut self.xn, &self.x, u);
        let (Ho, L) = (&self.Ho[..mo * n], &self.L[..mo * mo]);
        let (e, alpha) = (&mut self.e[..mo], &mut self.alpha[..mo]);
        // e = z_o − Ho x
        for (r, &i) in self.obs.iter().enumerate() {
            e[r] = z[i] - (0..n).map(|c| Ho[r + c * mo] * self.x[c]).sum::<f64>();
        }
        alpha.copy_from_slice(e);
        solve_each_column(L, mo, alpha, 1);
        let quad: f64 = (0..mo).map(|i| e[i] * alpha[i]).sum();
        let term = -0.5 * (quad + self.logdet + mo as f64 * LN_2PI);
        for (i, di) in d.iter().enumerate() {
            let has_dh = self.observed_dH(di, n, m);
            let (Ho, dHo, G) = (&self.Ho[..mo * n], &self.dHo[..mo * n], &self.G[..n * mo]);
            let alpha = &self.alpha[..mo];
            let (de, dsa) = (&mut self.de[..mo], &mut self.dsa[..mo]);
            let ParamWork {
                dx,
                dxn,
                dsig,
                dM,
                tr,
                ..
            } = &mut self.par[i];
            let (dsig, dM) = (&dsig[..mo * mo], &dM[..n * mo]);
            // de = −dHo x − Ho dx
            for r in 0..mo {
                let mut v = -(0..n).map(|c| Ho[r + c * mo] * dx[c]).sum::<f64>();
                if has_dh {
                    v -= (0..n).map(|c| dHo[r + c * mo] * self.x[c]).sum::<f64>();
                }
                de[r] = v;
            }
            // dΣ α
            for r in 0..mo {
                dsa[r] = (0..mo).map(|c| dsig[r + c * mo] * alpha[c]).sum();
            }
            let a_ds_a: f64 = (0..mo).map(|r| alpha[r] * dsa[r]).sum();
            let a_de: f64 = (0..mo).map(|r| alpha[r] * de[r]).sum();
            grad[i] -= 0.5 * (*tr - a_ds_a + 2.0 * a_de);
            // dx' = dF x + F dx + dM α − G dΣ α + G de
            predict_dx(dxn, s, di, dx, &self.x, u);
            gemm(dxn, n, 1, mo, 1.0, dM, n, false, alpha, mo, false, 1.0);
            for r in 0..mo {
                dsa[r] = de[r] - dsa[r];
            }
            gemm(dxn, n, 1, mo, 1.0, G, n, false, dsa, mo, false, 1.0);
        }
        // x' = F x + B u + G e
        let (G, e) = (&self.G[..n * mo], &self.e[..mo]);
        gemm(&mut self.xn, n, 1, mo, 1.0, G, n, false, e, mo, false, 1.0);
        term
    }

    /// `FP = F P` and the predicted `Pn = F P Fᵀ + Q`.
    fn predict_P(&mut self, s: &Flat) {
        let n = s.n;
        gemm(
            &mut self.FP,
            n,
            n,
            n,
            1.0,
            &s.F,
            n,
            false,
            &self.P,
            n,
            false,
            0.0,
        );
        gemm(
            &mut self.Pn,
            n,
            n,
            n,
            1.0,
            &self.FP,
            n,
            false,
            &s.F,
            n,
            true,
            0.0,
        );
        for (a, q) in self.Pn.iter_mut().zip(&s.Q) {
            *a += q;
        }
    }

    /// A step with every row missing: prediction only.
    fn predict_only(&mut self, s: &Flat, d: &[FlatDeriv], u: &[f64]) {
        let n = s.n;
        self.predict_P(s);
        s.predict_mean(&mut self.xn, &self.x, u);
        for (w, di) in self.par.iter_mut().zip(d) {
            predict_dx(&mut w.dxn, s, di, &w.dx, &self.x, u);
            predict_dP(&mut w.dPn, &mut self.tn, &s.F, &w.dP, di, &self.FP, n);
        }
        symmetrise(&mut self.Pn, n);
    }

    /// Whether the covariance recursion has reached its fixed point in the step just
    /// computed: `Pn` and every `dPn` differ from `P` and `dP` by at most
    /// [`FIXED_POINT_TOL`] of their own largest entry (exact equality for a zero matrix).
    fn at_fixed_point(&self) -> bool {
        let still = |old: &[f64], new: &[f64]| {
            let scale = old.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            old.iter()
                .zip(new)
                .all(|(u, v)| (u - v).abs() <= FIXED_POINT_TOL * scale)
        };
        still(&self.P, &self.Pn) && self.par.iter().all(|w| still(&w.dP, &w.dPn))
    }
}

/// The covariance recursion counts as converged when a step moves P and every ∂P by at
/// most 16ε of their largest entry. In floating point the recursion does not settle on one
/// bit pattern: it wanders within a few ulps of its fixed point (measured on a local linear
/// trend: 1.9e-16 relative in P, up to 6.8e-16 in ∂P, step after step; on an AR(2)-plus-noise
/// fit, a cycle of period four through steps of up to 4.6ε in one ∂P), so a bitwise test
/// would never fire, and one at 4ε misses such a cycle for the whole record. Stopping at a
/// step of 16ε leaves the iterate within 16ε·ρ/(1−ρ) of the fixed point (ρ the recursion's
/// contraction rate) — the same order as the round-off ε/(1−ρ) the full recursion carries
/// itself, so the reuse changes the result only at round-off level.
const FIXED_POINT_TOL: f64 = 16.0 * f64::EPSILON;

/// The score recursion: `ln L` (returned) and `∇ ln L` (into `grad`), and the number of
/// steps that reused a covariance stage.
///
/// The covariance stage (P, ∂P, Σ, gains, ∂Σ, ∂M) does not depend on the data, only on the
/// previous P, ∂P and on which rows are observed. Once a fully observed step leaves P and
/// every ∂P where they were (to [`FIXED_POINT_TOL`]; a stable time-invariant model gets
/// there within a hundred steps or so), later fully observed steps would compute the same
/// stage again to round-off, so with `reuse` it is skipped until a step with a missing row
/// (the steady-state shortcut other state-space codes take too). `reuse = false` runs
/// every stage (the reference the tests compare with).
fn score(
    s: &Flat,
    d: &[FlatDeriv],
    data: &Series<'_>,
    grad: &mut [f64],
    reuse: bool,
) -> Result<(f64, usize), FitError> {
    let m = s.m;
    let mut w = Work::new(s, d);
    let mut st = Steady::new(s.n, m, d.len());
    let mut ll = 0.0;
    let mut steady = false;
    let mut reused = 0;
    for k in 0..data.len() {
        let z = data.z(k);
        w.obs.clear();
        w.obs.extend((0..m).filter(|&i| !z[i].is_nan()));
        let mo = w.obs.len();
        let reuse_stage = steady && mo == m;
        if !reuse_stage && st.active() {
            st.leave(&mut w, grad);
        }
        if mo == 0 {
            w.predict_only(s, d, data.u(k));
        } else if reuse_stage {
            reused += 1;
            if !st.active() {
                st.enter(&w, s, d);
            }
            ll += st.step(
                &mut w,
                &Observation {
                    s,
                    d,
                    z,
                    u: data.u(k),
                },
                grad,
            );
        } else {
            w.covariance_stage(s, d, k)?;
            ll += w.data_stage(
                &Observation {
                    s,
                    d,
                    z,
                    u: data.u(k),
                },
                grad,
            );
        }
        // a reused stage stays steady; a fresh one is steady once the recursion stood still
        steady = reuse_stage || (reuse && mo == m && w.at_fixed_point());
        std::mem::swap(&mut w.x, &mut w.xn);
        if !reuse_stage {
            for p in &mut w.par {
                std::mem::swap(&mut p.dx, &mut p.dxn);
                std::mem::swap(&mut p.dP, &mut p.dPn);
            }
            std::mem::swap(&mut w.P, &mut w.Pn);
        }
    }
    if st.active() {
        st.leave(&mut w, grad);
    }
    Ok((ll, reused))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::{Free, StandardMap, Structure};

    /// A local linear trend observed with gaps: 600 samples, the middle ones and a run near
    /// the end missing, so the recursion reaches its fixed point, leaves it and comes back.
    fn llt_with_gaps() -> (StandardMap, Vec<f64>) {
        let base = System::new(
            &[[1.0, 1.0], [0.0, 1.0]],
            &[[1.0, 0.0]],
            &[[0.5, 0.0], [0.0, 0.01]],
            &[[4.0]],
            &[0.0, 0.0],
            &[[10.0, 0.0], [0.0, 1.0]],
        )
        .expect("system");
        let free = Free {
            q: Structure::Diag,
            r: Structure::Diag,
            ..Free::default()
        };
        let z = (0..600)
            .map(|k| {
                let t = k as f64;
                if (300..310).contains(&k) || (540..545).contains(&k) {
                    f64::NAN
                } else {
                    0.05 * t + (0.37 * t).sin() + 0.8 * (1.3 * t).cos()
                }
            })
            .collect();
        (StandardMap::new(base, free).expect("map"), z)
    }

    /// Runs the score recursion with and without the reuse of the covariance stage and
    /// asserts that they agree to 1e-10 in ln L and in every gradient entry (the bound is
    /// argued at each caller); returns how many steps reused the stage.
    fn agrees_with_the_full_recursion<M: ParamMap>(
        map: &M,
        theta: &[f64],
        data: &Series<'_>,
    ) -> usize {
        let sys = map.system(theta).expect("system");
        let d: Vec<FlatDeriv> = map
            .derivatives(theta)
            .expect("derivatives")
            .iter()
            .map(FlatDeriv::new)
            .collect();
        let flat = Flat::new(&sys);
        let mut g_ref = vec![0.0; theta.len()];
        let (ll_ref, none) = score(&flat, &d, data, &mut g_ref, false).expect("reference");
        let mut g = vec![0.0; theta.len()];
        let (ll, reused) = score(&flat, &d, data, &mut g, true).expect("reuse");
        assert_eq!(none, 0);
        assert!((ll - ll_ref).abs() <= 1e-10, "{ll} vs {ll_ref}");
        for (a, b) in g.iter().zip(&g_ref) {
            assert!((a - b).abs() <= 1e-10, "{a} vs {b}");
        }
        reused
    }

    #[test]
    fn reusing_the_covariance_stage_changes_only_round_off() {
        // Skipping the stage at the converged recursion must agree with the full recursion
        // to round-off. Bound: the reused stage is within ~16ε·ρ/(1−ρ) ≈ 27ε (ρ ≈ 0.63 here)
        // of the recomputed one, each of the 600 terms of ln L (|term| ≲ 5) moves by at most
        // that times a sensitivity of order one: ≲ 600·27ε·5 ≈ 2e-11; asserted with margin
        // 1e-10 on ln L ≈ −1e3 and on gradient entries of order 1–100. The shortcut must
        // also actually be taken, on both sides of the gaps, else the test would compare the
        // reference with itself.
        let (map, z) = llt_with_gaps();
        let data = Series::new(&z, 1).expect("series");
        let reused = agrees_with_the_full_recursion(&map, &[0.1, -3.0, 1.2], &data);
        assert!(reused > 300, "only {reused} of 600 steps reused the stage");
    }

    #[test]
    fn the_steady_stage_agrees_with_the_full_recursion_for_entries_of_f_b_and_h() {
        // The steady data stage folds ∂F, ∂H and ∂B into its own matrices (C = ∂F − G ∂H,
        // K = ∂M − G ∂Σ), a path the Q/R test above does not reach. An AR(2) state driven by
        // an input and seen by two channels, one parameter per moved matrix, 600 steps with
        // a gap of missing rows in the middle: the same bound as above (2e-11, asserted at
        // 1e-10 on ln L ≈ −1e3 and the gradient), and the shortcut taken on both sides.
        use crate::fit::{Matrix, Param};
        let base = System::new(
            &[[0.5, 1.0], [0.3, 0.0]],
            &[[1.0, 0.0], [0.5, 0.2]],
            &[[0.3, 0.0], [0.0, 0.05]],
            &[[0.2, 0.0], [0.0, 0.6]],
            &[0.0, 0.0],
            &[[1.0, 0.0], [0.0, 1.0]],
        )
        .and_then(|s| s.with_control(&[[1.0], [0.0]]))
        .expect("system");
        let params = vec![
            Param::entry(Matrix::F, 1, 0),
            Param::entry(Matrix::B, 0, 0),
            Param::entry(Matrix::H, 1, 1),
            Param::entry(Matrix::Q, 0, 0),
        ];
        let map = StandardMap::with_params(
            base,
            Free {
                r: Structure::Fixed,
                ..Free::default()
            },
            params,
        )
        .expect("map");
        let z: Vec<f64> = (0..600)
            .flat_map(|k| {
                let t = k as f64;
                let a = if (280..290).contains(&k) {
                    f64::NAN
                } else {
                    (0.21 * t).cos()
                };
                [a, 0.4 * (0.07 * t).sin() - 0.2 * (1.1 * t).cos()]
            })
            .collect();
        let u: Vec<f64> = (0..600).map(|k| (0.03 * k as f64).sin()).collect();
        let data = Series::new(&z, 2)
            .and_then(|d| d.with_inputs(&u, 1))
            .expect("series");
        let theta = [0.3, 1.0, 0.2, 0.3_f64.ln()];
        let d = map.derivatives(&theta).expect("derivatives");
        assert!(d.iter().any(|di| di.f.is_some()));
        assert!(d.iter().any(|di| di.h.is_some()));
        assert!(d.iter().any(|di| di.b.is_some()));
        let reused = agrees_with_the_full_recursion(&map, &theta, &data);
        assert!(reused > 400, "only {reused} of 600 steps reused the stage");
    }
}
