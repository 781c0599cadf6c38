//! `UnscentedKalmanFilter.batch_filter` and `rts_smoother`: FilterPy's loops, run in Rust
//! over the arithmetic of `ukf_core.rs` (the user's fx and hx are still called, per point or
//! vectorised). Signals are checked at every step and around every callable.
//!
//! The smoother (Särkkä's unscented RTS, as FilterPy writes it), backwards from k = N − 2:
//! χ the points of (x_k, P_k), x̄, P̄ the transform of fx(χ, dt_k) with Q_k, C = Σ Wc_i
//! residual_x(χ_i, x_k) residual_x(f_i, x̄)ᵀ, K = C P̄⁻¹ (solved), x_k += K residual_x(x_{k+1}
//! smoothed, x̄), P_k += K (P_{k+1} smoothed − P̄) Kᵀ.
#![allow(non_snake_case)]

use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::convert::{array3_out, entries, scalar, type_error, value_error, zeros};
use crate::linalg::Factor;
use crate::sigma::item;
use crate::ukf_core::{Ctx, Predicted, Updated, arr1, arr2, linalg_error, read_noise, read_z};
use crate::ukf_state::{state, update_noise, write_no_update, write_predicted, write_updated};

/// `seq[i]`, or None when `seq` is None.
fn nth<'py>(seq: Option<&Bound<'py, PyAny>>, i: usize) -> PyResult<Option<Bound<'py, PyAny>>> {
    match seq.filter(|s| !s.is_none()) {
        None => Ok(None),
        Some(s) => Ok(Some(s.get_item(i)?)),
    }
}

/// The length of a per-step sequence `name`, which must be `steps` when given.
fn check_len(seq: Option<&Bound<'_, PyAny>>, name: &str, steps: usize) -> PyResult<()> {
    if let Some(s) = seq.filter(|s| !s.is_none() && scalar(s).is_none()) {
        let len = s.len()?;
        if len < steps {
            return Err(value_error(format!(
                "{name} has {len} entries but zs has {steps}"
            )));
        }
    }
    Ok(())
}

/// See `UnscentedKalmanFilter.batch_filter`.
pub(crate) fn batch_filter<'py>(
    c: &Ctx<'py>,
    zs: &Bound<'py, PyAny>,
    Rs: Option<&Bound<'py, PyAny>>,
    dts: Option<&Bound<'py, PyAny>>,
    saver: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let (py, n) = (c.py, c.n);
    let steps = zs.len().map_err(|_| type_error("zs must be list-like"))?;
    check_len(Rs, "Rs", steps)?;
    check_len(dts, "dts", steps)?;
    let saver = saver.filter(|s| !s.is_none());
    let column = item(&c.d, pyo3::intern!(c.d.py(), "x"))?
        .getattr("ndim")
        .and_then(|v| v.extract::<usize>())
        .unwrap_or(1)
        == 2;
    let mut means = zeros(entries(steps, n, "the means")?, "the means")?;
    let mut covs = zeros(entries(steps, n * n, "the covariances")?, "the covariances")?;
    let (mut x, mut P) = state(c)?;
    let Qo = item(&c.d, pyo3::intern!(c.d.py(), "Q"))?;
    let Q = read_noise(&Qo, "Q", n)?;
    let own_R = if Rs.is_none_or(|r| r.is_none()) {
        Some(update_noise(c, None)?)
    } else {
        None
    };
    let (fx, hx, dt0) = (
        item(&c.d, pyo3::intern!(c.d.py(), "fx"))?,
        item(&c.d, pyo3::intern!(c.d.py(), "hx"))?,
        item(&c.d, pyo3::intern!(c.d.py(), "_dt"))?,
    );
    let mut last_p: Option<Predicted> = None;
    let mut last_u: Option<Updated> = None;
    let mut updated_last = false;
    for k in 0..steps {
        py.check_signals()?;
        let dt = nth(dts, k)?.unwrap_or_else(|| dt0.clone());
        let p = crate::ukf_core::predict(c, &x, &P, (&Q, &Qo), &fx, &dt, None)?;
        x.copy_from_slice(&p.x);
        P.copy_from_slice(&p.P);
        let z = zs.get_item(k)?;
        if saver.is_some() {
            write_predicted(c, &p)?;
        }
        if z.is_none() {
            updated_last = false;
            if saver.is_some() {
                write_no_update(c)?;
            }
        } else {
            let zv = read_z(&z, c.m)?;
            let r = nth(Rs, k)?;
            let R = match (&own_R, r) {
                (Some(own), _) => (own.0.clone(), own.1.clone()),
                (None, r) => update_noise(c, r.as_ref())?,
            };
            let u = crate::ukf_core::update(c, &x, &P, &p.sigmas_f, zv, (&R.0, &R.1), &hx, None)?;
            x.copy_from_slice(&u.x);
            P.copy_from_slice(&u.P);
            if saver.is_some() {
                write_updated(c, &u)?;
            }
            last_u = Some(u);
            updated_last = true;
        }
        last_p = Some(p);
        means[k * n..(k + 1) * n].copy_from_slice(&x);
        covs[k * n * n..(k + 1) * n * n].copy_from_slice(&P);
        if let Some(s) = saver {
            s.call_method0("save")?;
        }
    }
    if saver.is_none() {
        if let Some(u) = &last_u {
            write_updated(c, u)?;
        }
        if let Some(p) = &last_p {
            write_predicted(c, p)?;
        }
        match (&last_u, updated_last) {
            (Some(u), true) => write_updated(c, u)?,
            _ if steps > 0 => write_no_update(c)?,
            _ => {}
        }
    }
    let means = if column {
        array3_out(py, means, steps, n, 1).into_any()
    } else {
        arr2(py, means, steps, n)?
    };
    let covs = array3_out(py, covs, steps, n, n).into_any();
    PyTuple::new(py, [means, covs])
}

/// Xs as (N, n) (an (N, n, 1) stack of columns too) and Ps as (N, n, n).
fn read_stack(
    c: &Ctx<'_>,
    Xs: &Bound<'_, PyAny>,
    Ps: &Bound<'_, PyAny>,
) -> PyResult<(usize, Vec<f64>, Vec<f64>)> {
    let n = c.n;
    let np = crate::sigma::numpy(c.py)?;
    let xa = np
        .call_method1("asarray", (Xs, "float64"))
        .map_err(|_| type_error("Xs must be an array of real numbers"))?;
    let pa = np
        .call_method1("asarray", (Ps, "float64"))
        .map_err(|_| type_error("Ps must be an array of real numbers"))?;
    let xs_shape: Vec<usize> = xa.getattr("shape")?.extract()?;
    let ps_shape: Vec<usize> = pa.getattr("shape")?.extract()?;
    let N = match xs_shape.as_slice() {
        [N, d] | [N, d, 1] if *d == n => *N,
        s => {
            return Err(value_error(format!(
                "Xs has shape {}, expected (N, {n})",
                crate::convert::shape_str(s)
            )));
        }
    };
    if ps_shape.first() != Some(&N) {
        return Err(value_error("Xs and Ps must have the same length"));
    }
    if ps_shape != [N, n, n] {
        return Err(value_error(format!(
            "Ps has shape {}, expected ({N}, {n}, {n})",
            crate::convert::shape_str(&ps_shape)
        )));
    }
    let mut xs = zeros(entries(N, n, "Xs")?, "Xs")?;
    let flat = xa.call_method1("reshape", (N * n,))?;
    crate::convert::read_vector(&flat, "Xs", N * n, false, false, &mut xs)?;
    let mut ps = zeros(entries(N, n * n, "Ps")?, "Ps")?;
    let flat = pa.call_method1("reshape", (N * n * n,))?;
    crate::convert::read_vector(&flat, "Ps", N * n * n, false, false, &mut ps)?;
    Ok((N, xs, ps))
}

/// See `UnscentedKalmanFilter.rts_smoother`.
pub(crate) fn rts_smoother<'py>(
    c: &Ctx<'py>,
    Xs: &Bound<'py, PyAny>,
    Ps: &Bound<'py, PyAny>,
    Qs: Option<&Bound<'py, PyAny>>,
    dts: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let (py, n) = (c.py, c.n);
    let (N, mut xs, mut ps) = read_stack(c, Xs, Ps)?;
    let xs0 = xs.clone();
    let dts = dts.filter(|d| !d.is_none());
    let dt_all = match dts {
        None => Some(item(&c.d, pyo3::intern!(c.d.py(), "_dt"))?),
        Some(d) if scalar(d).is_some() => Some(d.clone()),
        Some(_) => None,
    };
    if dt_all.is_none() {
        check_len(dts, "dts", N)?;
    }
    check_len(Qs, "Qs", N)?;
    let Qo = item(&c.d, pyo3::intern!(c.d.py(), "Q"))?;
    let own_Q = read_noise(&Qo, "Q", n)?;
    let fx = item(&c.d, pyo3::intern!(c.d.py(), "fx"))?;
    let mut Ks = zeros(entries(N, n * n, "Ks")?, "Ks")?;
    let mut f = Factor::try_new(n).ok_or_else(|| crate::convert::memory_error(n * n, "Pb"))?;
    for k in (0..N.saturating_sub(1)).rev() {
        py.check_signals()?;
        let dt = match &dt_all {
            Some(d) => d.clone(),
            None => nth(dts, k)?.unwrap_or_else(|| py.None().into_bound(py)),
        };
        let (Q, Qobj) = match nth(Qs, k)?.filter(|q| !q.is_none()) {
            Some(q) => (read_noise(&q, "Qs[k]", n)?, q),
            None => (own_Q.clone(), Qo.clone()),
        };
        let xk = &xs[k * n..(k + 1) * n];
        let Pk = &ps[k * n * n..(k + 1) * n * n];
        let sig = c.sigmas(xk, Pk)?;
        let sf = c.apply(&fx, "fx", &sig, n, n, std::slice::from_ref(&dt), None)?;
        let (xb, Pb) = c.transform(&sf, n, &Q, &Qobj, false)?;
        let dz = c.residuals(
            c.residual_x.as_ref(),
            "residual_x",
            &sig,
            &xs0[k * n..(k + 1) * n],
            n,
        )?;
        let dy = c.residuals(c.residual_x.as_ref(), "residual_x", &sf, &xb, n)?;
        let mut Pxb = zeros(n * n, "Pxb")?;
        crate::ukf_core::weighted_outer(&c.wc, &dz, &dy, n, n, &mut Pxb);
        if !f.factor(&Pb, n) {
            return Err(linalg_error(
                py,
                "the predicted covariance of the smoother is singular",
            ));
        }
        // Kᵀ = Pb⁻¹ Pxbᵀ (Pb symmetric).
        let mut Kt = zeros(n * n, "K")?;
        for i in 0..n {
            for j in 0..n {
                Kt[j * n + i] = Pxb[i * n + j];
            }
        }
        f.solve(&mut Kt, n);
        let K: Vec<f64> = (0..n * n).map(|ij| Kt[(ij % n) * n + ij / n]).collect();
        let next = xs[(k + 1) * n..(k + 2) * n].to_vec();
        let r = match &c.residual_x {
            None => next
                .iter()
                .zip(&xb)
                .map(|(a, b)| a - b)
                .collect::<Vec<f64>>(),
            Some(res) => {
                let v = res.call1((arr1(py, &next), arr1(py, &xb)))?;
                let mut r = zeros(n, "the residual")?;
                crate::convert::read_vector(&v, "the value of residual_x", n, true, false, &mut r)?;
                r
            }
        };
        for i in 0..n {
            xs[k * n + i] += (0..n).map(|j| K[i * n + j] * r[j]).sum::<f64>();
        }
        // P_k += K (P_{k+1} − P̄) Kᵀ.
        let D: Vec<f64> = (0..n * n)
            .map(|ij| ps[(k + 1) * n * n + ij] - Pb[ij])
            .collect();
        let mut KD = zeros(n * n, "K D")?;
        crate::linalg::mul(&K, &D, n, n, n, &mut KD);
        let mut KDK = zeros(n * n, "K D Kᵀ")?;
        crate::linalg::mul_bt(&KD, &K, n, n, n, &mut KDK);
        for (p, v) in ps[k * n * n..(k + 1) * n * n].iter_mut().zip(&KDK) {
            *p += v;
        }
        Ks[k * n * n..(k + 1) * n * n].copy_from_slice(&K);
    }
    let xs = arr2(py, xs, N, n)?;
    let ps = array3_out(py, ps, N, n, n).into_any();
    let ks = array3_out(py, Ks, N, n, n).into_any();
    PyTuple::new(py, [xs, ps, ks])
}
