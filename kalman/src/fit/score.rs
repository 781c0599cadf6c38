//! The exact log-likelihood and its gradient by the score recursion: the prediction-error
//! filter differentiated analytically, one `(∂x, ∂P)` pair per parameter.

use super::dense::{chol_solve, cholesky, gemm, symmetrise};
use super::{Derivative, FitError, LN_2PI, ParamMap, Series, System, flat};

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
            H: d.h.as_ref().map(flat),
            Q: d.q.as_ref().map(flat),
            R: d.r.as_ref().map(flat),
            x0: d.x0.clone(),
            P0: d.p0.as_ref().map(flat),
        }
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
    let ll = score(&Flat::new(&sys), &flat_d, data, &mut grad)?;
    Ok((ll, grad))
}

#[allow(clippy::too_many_lines)]
fn score(s: &Flat, d: &[FlatDeriv], data: &Series<'_>, grad: &mut [f64]) -> Result<f64, FitError> {
    let (n, m) = (s.n, s.m);
    let mut x = s.x0.clone();
    let mut P = s.P0.clone();
    symmetrise(&mut P, n);
    let mut dx: Vec<Vec<f64>> = d
        .iter()
        .map(|di| di.x0.clone().unwrap_or_else(|| vec![0.0; n]))
        .collect();
    let mut dP: Vec<Vec<f64>> = d
        .iter()
        .map(|di| di.P0.clone().unwrap_or_else(|| vec![0.0; n * n]))
        .collect();
    // workspaces (allocated once per evaluation, none per step)
    let mut dxb = dx.clone();
    let mut dPb = dP.clone();
    let mut obs = Vec::with_capacity(m);
    let mut Ho = vec![0.0; m * n];
    let mut e = vec![0.0; m];
    let mut sig = vec![0.0; m * m];
    let mut L = vec![0.0; m * m];
    let mut PHt = vec![0.0; n * m];
    let mut M = vec![0.0; n * m];
    let mut G = vec![0.0; n * m];
    let mut alpha = vec![0.0; m];
    let mut FP = vec![0.0; n * n];
    let mut xn = vec![0.0; n];
    let mut Pn = vec![0.0; n * n];
    let mut dHo = vec![0.0; m * n];
    let mut de = vec![0.0; m];
    let mut dsig = vec![0.0; m * m];
    let mut X = vec![0.0; m * m];
    let mut dM = vec![0.0; n * m];
    let mut tn = vec![0.0; n * n];
    let mut tm = vec![0.0; n * m];
    let mut dsa = vec![0.0; m];
    let mut ll = 0.0;
    for k in 0..data.len() {
        let z = data.z(k);
        obs.clear();
        obs.extend((0..m).filter(|&i| !z[i].is_nan()));
        let mo = obs.len();
        // FP = F P
        gemm(&mut FP, n, n, n, 1.0, &s.F, n, false, &P, n, false, 0.0);
        // xn = F x + B u
        s.predict_mean(&mut xn, &x, data.u(k));
        // Pn = F P Fᵀ + Q
        gemm(&mut Pn, n, n, n, 1.0, &FP, n, false, &s.F, n, true, 0.0);
        for (a, q) in Pn.iter_mut().zip(&s.Q) {
            *a += q;
        }
        if mo > 0 {
            for (r, &i) in obs.iter().enumerate() {
                for c in 0..n {
                    Ho[r + c * mo] = s.H[i + c * m];
                }
            }
            // e = z_o − Ho x
            for (r, &i) in obs.iter().enumerate() {
                e[r] = z[i] - (0..n).map(|c| Ho[r + c * mo] * x[c]).sum::<f64>();
            }
            // PHt = P Hoᵀ, Σ = Ho PHt + R_oo
            gemm(&mut PHt, n, mo, n, 1.0, &P, n, false, &Ho, mo, true, 0.0);
            gemm(
                &mut sig, mo, mo, n, 1.0, &Ho, mo, false, &PHt, n, false, 0.0,
            );
            for (c, &j) in obs.iter().enumerate() {
                for (r, &i) in obs.iter().enumerate() {
                    sig[r + c * mo] += s.R[i + j * m];
                }
            }
            symmetrise(&mut sig[..mo * mo], mo);
            L[..mo * mo].copy_from_slice(&sig[..mo * mo]);
            if !cholesky(&mut L[..mo * mo], mo) {
                return Err(FitError::NotPositiveDefinite {
                    name: "innovation covariance",
                    step: k,
                });
            }
            let logdet: f64 = (0..mo).map(|i| 2.0 * L[i + i * mo].ln()).sum();
            alpha[..mo].copy_from_slice(&e[..mo]);
            chol_solve(&L[..mo * mo], mo, &mut alpha[..mo], 1);
            let quad: f64 = (0..mo).map(|i| e[i] * alpha[i]).sum();
            ll -= 0.5 * (quad + logdet + mo as f64 * LN_2PI);
            // M = F P Hoᵀ, G = M Σ⁻¹ (solve Σ Gᵀ = Mᵀ)
            gemm(&mut M, n, mo, n, 1.0, &s.F, n, false, &PHt, n, false, 0.0);
            for r in 0..n {
                for c in 0..mo {
                    tm[c + r * mo] = M[r + c * n];
                }
            }
            chol_solve(&L[..mo * mo], mo, &mut tm[..mo * n], n);
            for r in 0..n {
                for c in 0..mo {
                    G[r + c * n] = tm[c + r * mo];
                }
            }
            // derivatives
            for (i, di) in d.iter().enumerate() {
                // dHo
                let has_dh = if let Some(dh) = &di.H {
                    for (r, &oi) in obs.iter().enumerate() {
                        for c in 0..n {
                            dHo[r + c * mo] = dh[oi + c * m];
                        }
                    }
                    true
                } else {
                    false
                };
                // de = −dHo x − Ho dx
                for r in 0..mo {
                    let mut v = -(0..n).map(|c| Ho[r + c * mo] * dx[i][c]).sum::<f64>();
                    if has_dh {
                        v -= (0..n).map(|c| dHo[r + c * mo] * x[c]).sum::<f64>();
                    }
                    de[r] = v;
                }
                // dΣ = Ho dP Hoᵀ + dHo PHt + (dHo PHt)ᵀ + dR_oo
                gemm(
                    &mut tm[..n * mo],
                    n,
                    mo,
                    n,
                    1.0,
                    &dP[i],
                    n,
                    false,
                    &Ho,
                    mo,
                    true,
                    0.0,
                );
                gemm(
                    &mut dsig[..mo * mo],
                    mo,
                    mo,
                    n,
                    1.0,
                    &Ho,
                    mo,
                    false,
                    &tm[..n * mo],
                    n,
                    false,
                    0.0,
                );
                if has_dh {
                    gemm(
                        &mut X[..mo * mo],
                        mo,
                        mo,
                        n,
                        1.0,
                        &dHo,
                        mo,
                        false,
                        &PHt,
                        n,
                        false,
                        0.0,
                    );
                    for c in 0..mo {
                        for r in 0..mo {
                            dsig[r + c * mo] += X[r + c * mo] + X[c + r * mo];
                        }
                    }
                }
                if let Some(dr) = &di.R {
                    for (c, &oj) in obs.iter().enumerate() {
                        for (r, &oi) in obs.iter().enumerate() {
                            dsig[r + c * mo] += dr[oi + oj * m];
                        }
                    }
                }
                // tr(Σ⁻¹ dΣ)
                X[..mo * mo].copy_from_slice(&dsig[..mo * mo]);
                chol_solve(&L[..mo * mo], mo, &mut X[..mo * mo], mo);
                let tr: f64 = (0..mo).map(|r| X[r + r * mo]).sum();
                // dΣ α
                for r in 0..mo {
                    dsa[r] = (0..mo).map(|c| dsig[r + c * mo] * alpha[c]).sum();
                }
                let a_ds_a: f64 = (0..mo).map(|r| alpha[r] * dsa[r]).sum();
                let a_de: f64 = (0..mo).map(|r| alpha[r] * de[r]).sum();
                grad[i] -= 0.5 * (tr - a_ds_a + 2.0 * a_de);
                // dM = dF P Hoᵀ + F dP Hoᵀ + F P dHoᵀ   (tm holds dP Hoᵀ)
                gemm(
                    &mut dM[..n * mo],
                    n,
                    mo,
                    n,
                    1.0,
                    &s.F,
                    n,
                    false,
                    &tm[..n * mo],
                    n,
                    false,
                    0.0,
                );
                if let Some(df) = &di.F {
                    gemm(
                        &mut dM[..n * mo],
                        n,
                        mo,
                        n,
                        1.0,
                        df,
                        n,
                        false,
                        &PHt,
                        n,
                        false,
                        1.0,
                    );
                }
                if has_dh {
                    gemm(
                        &mut dM[..n * mo],
                        n,
                        mo,
                        n,
                        1.0,
                        &FP,
                        n,
                        false,
                        &dHo,
                        mo,
                        true,
                        1.0,
                    );
                }
                // dx' = dF x + F dx + dM α − G dΣ α + G de
                let dxn = &mut dxb[i];
                gemm(dxn, n, 1, n, 1.0, &s.F, n, false, &dx[i], n, false, 0.0);
                if let Some(df) = &di.F {
                    gemm(dxn, n, 1, n, 1.0, df, n, false, &x, n, false, 1.0);
                }
                gemm(
                    dxn,
                    n,
                    1,
                    mo,
                    1.0,
                    &dM[..n * mo],
                    n,
                    false,
                    &alpha[..mo],
                    mo,
                    false,
                    1.0,
                );
                for r in 0..mo {
                    dsa[r] = de[r] - dsa[r];
                }
                gemm(
                    dxn,
                    n,
                    1,
                    mo,
                    1.0,
                    &G[..n * mo],
                    n,
                    false,
                    &dsa[..mo],
                    mo,
                    false,
                    1.0,
                );
                // dP' = dF P Fᵀ + F P dFᵀ + F dP Fᵀ + dQ − dM Gᵀ − G dMᵀ + G dΣ Gᵀ
                let dPn = &mut dPb[i];
                predict_dP(dPn, &mut tn, &s.F, &dP[i], di, &FP, n);
                gemm(
                    &mut tn,
                    n,
                    n,
                    mo,
                    1.0,
                    &dM[..n * mo],
                    n,
                    false,
                    &G[..n * mo],
                    n,
                    true,
                    0.0,
                );
                for r in 0..n {
                    for c in 0..n {
                        dPn[r + c * n] -= tn[r + c * n] + tn[c + r * n];
                    }
                }
                gemm(
                    &mut tm[..n * mo],
                    n,
                    mo,
                    mo,
                    1.0,
                    &G[..n * mo],
                    n,
                    false,
                    &dsig[..mo * mo],
                    mo,
                    false,
                    0.0,
                );
                gemm(
                    dPn,
                    n,
                    n,
                    mo,
                    1.0,
                    &tm[..n * mo],
                    n,
                    false,
                    &G[..n * mo],
                    n,
                    true,
                    1.0,
                );
                symmetrise(dPn, n);
            }
            // x' = F x + B u + G e, P' = F P Fᵀ + Q − G Mᵀ
            gemm(
                &mut xn,
                n,
                1,
                mo,
                1.0,
                &G[..n * mo],
                n,
                false,
                &e[..mo],
                mo,
                false,
                1.0,
            );
            gemm(
                &mut Pn,
                n,
                n,
                mo,
                -1.0,
                &G[..n * mo],
                n,
                false,
                &M[..n * mo],
                n,
                true,
                1.0,
            );
        } else {
            for (i, di) in d.iter().enumerate() {
                let dxn = &mut dxb[i];
                gemm(dxn, n, 1, n, 1.0, &s.F, n, false, &dx[i], n, false, 0.0);
                if let Some(df) = &di.F {
                    gemm(dxn, n, 1, n, 1.0, df, n, false, &x, n, false, 1.0);
                }
                let dPn = &mut dPb[i];
                predict_dP(dPn, &mut tn, &s.F, &dP[i], di, &FP, n);
            }
        }
        symmetrise(&mut Pn, n);
        std::mem::swap(&mut dx, &mut dxb);
        std::mem::swap(&mut dP, &mut dPb);
        std::mem::swap(&mut x, &mut xn);
        std::mem::swap(&mut P, &mut Pn);
    }
    Ok(ll)
}
