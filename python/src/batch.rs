//! The whole-series methods of `KalmanFilter` (`batch_filter`, `rts_smoother`): one call
//! into Rust that loops over the steps without returning to Python.
#![allow(non_snake_case)]

use numpy::{PyArray3, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::convert::{
    array3_out, copy_finite, float_array, read_vector, shape_str, type_error, type_name,
    value_error,
};
use crate::kf_core::{Core, rts};
use crate::linalg::add_mul_vec;

/// Reads a whole series of vectors (`zs`, `us`): an array (N, len), (N, len, 1), or (N,)
/// when len = 1, or a sequence whose items are vectors, scalars or None (missing).
pub(crate) fn read_series(
    obj: &Bound<'_, PyAny>,
    name: &str,
    len: usize,
    missing_ok: bool,
) -> PyResult<(usize, Vec<f64>)> {
    if let Ok(arr) = float_array(obj, name) {
        let ro = arr.readonly();
        let view = ro.as_array();
        let steps = match view.shape() {
            [s] if len == 1 => *s,
            [s, l] if *l == len => *s,
            [s, l, 1] if *l == len => *s,
            s => {
                return Err(value_error(format!(
                    "{name} has shape {}, expected (N, {len}){}",
                    shape_str(s),
                    if len == 1 { " or (N,)" } else { "" }
                )));
            }
        };
        let out: Vec<f64> = view.iter().copied().collect();
        for &v in &out {
            if v.is_infinite() || (v.is_nan() && !missing_ok) {
                return Err(value_error(format!(
                    "{name} has a non-finite entry ({v}){}",
                    if missing_ok {
                        "; NaN marks a missing entry, infinities are refused"
                    } else {
                        ""
                    }
                )));
            }
        }
        return Ok((steps, out));
    }
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(type_error(format!(
            "{name} must be a sequence or a numpy.ndarray, not str"
        )));
    }
    let items = obj.try_iter().map_err(|_| {
        type_error(format!(
            "{name} must be a sequence or a numpy.ndarray, not {}",
            type_name(obj)
        ))
    })?;
    let mut out = Vec::new();
    let mut steps = 0;
    for item in items {
        let item = item?;
        let mut buf = vec![f64::NAN; len];
        if !(item.is_none() && missing_ok) {
            read_vector(
                &item,
                &format!("{name}[{steps}]"),
                len,
                true,
                missing_ok,
                &mut buf,
            )?;
        }
        out.extend_from_slice(&buf);
        steps += 1;
    }
    Ok((steps, out))
}

/// `KalmanFilter.batch_filter` with the filter's own F, Q, H, R, B. The four outputs are
/// numpy arrays allocated once and written in place (numpy backs large arrays with huge
/// pages, so 10⁵ steps cost few page faults), and the loop runs with the GIL released.
pub(crate) fn batch_filter<'py>(
    core: &mut Core,
    x_col: bool,
    py: Python<'py>,
    zs: &Bound<'py, PyAny>,
    us: Option<&Bound<'py, PyAny>>,
    update_first: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    let (n, m) = (core.n, core.m);
    let (steps, z) = read_series(zs, "zs", m, true)?;
    let p = if core.B.is_some() { core.p } else { 0 };
    let u = match us {
        Some(us) if !us.is_none() && p > 0 => {
            let (k, u) = read_series(us, "us", p, false)?;
            if k != steps {
                return Err(value_error(format!("us has {k} steps but zs has {steps}")));
            }
            Some(u)
        }
        _ => None,
    };
    let mean_shape = if x_col {
        vec![steps, n, 1]
    } else {
        vec![steps, n]
    };
    let mean_array = || PyArrayDyn::<f64>::zeros(py, mean_shape.clone(), false);
    let (means, means_p) = (mean_array(), mean_array());
    let covs = PyArray3::<f64>::zeros(py, [steps, n, n], false);
    let covs_p = PyArray3::<f64>::zeros(py, [steps, n, n], false);
    {
        let mut mw = means
            .try_readwrite()
            .map_err(|e| value_error(e.to_string()))?;
        let mut mpw = means_p
            .try_readwrite()
            .map_err(|e| value_error(e.to_string()))?;
        let mut cw = covs
            .try_readwrite()
            .map_err(|e| value_error(e.to_string()))?;
        let mut cpw = covs_p
            .try_readwrite()
            .map_err(|e| value_error(e.to_string()))?;
        let out = Outputs {
            means: mw.as_slice_mut().map_err(|e| value_error(e.to_string()))?,
            covs: cw.as_slice_mut().map_err(|e| value_error(e.to_string()))?,
            means_p: mpw.as_slice_mut().map_err(|e| value_error(e.to_string()))?,
            covs_p: cpw.as_slice_mut().map_err(|e| value_error(e.to_string()))?,
        };
        let u = u.as_deref();
        py.detach(|| run(core, &z, u, update_first, out))
            .map_err(|k| {
                value_error(format!(
                    "batch_filter: S (the innovation covariance H P Hᵀ + R) is singular at \
                     step {k}"
                ))
            })?;
    }
    PyTuple::new(
        py,
        [
            means.into_any(),
            covs.into_any(),
            means_p.into_any(),
            covs_p.into_any(),
        ],
    )
}

/// Where the batch loop writes: x and P after each update and after each prediction.
struct Outputs<'a> {
    means: &'a mut [f64],
    covs: &'a mut [f64],
    means_p: &'a mut [f64],
    covs_p: &'a mut [f64],
}

/// A dimension known at compile time or at run time: the batch loop is compiled for each
/// small state dimension, so its loops over the state unroll and carry no bounds checks.
trait Dim: Copy + Send {
    fn get(self) -> usize;
}

#[derive(Clone, Copy)]
struct Const<const N: usize>;

impl<const N: usize> Dim for Const<N> {
    #[inline(always)]
    fn get(self) -> usize {
        N
    }
}

#[derive(Clone, Copy)]
struct Dyn(usize);

impl Dim for Dyn {
    #[inline(always)]
    fn get(self) -> usize {
        self.0
    }
}

/// Runs `$body` with `$d` bound to `Const::<N>` for the listed N equal to `$value`, or to
/// `Dyn($value)` for any other value: one compiled copy of the body per listed size.
macro_rules! with_dim {
    ($value:expr, [$($n:literal),+], |$d:ident| $body:expr) => {
        match $value {
            $($n => {
                let $d = Const::<$n>;
                $body
            })+
            v => {
                let $d = Dyn(v);
                $body
            }
        }
    };
}

/// The batch loop for the dimensions of `core`, compiled per state dimension up to 8 and
/// measurement dimension up to 3. `Err(k)`: S singular at step k.
fn run(
    core: &mut Core,
    z: &[f64],
    u: Option<&[f64]>,
    update_first: bool,
    out: Outputs<'_>,
) -> Result<(), usize> {
    with_dim!(core.n, [1, 2, 3, 4, 5, 6, 7, 8], |d| {
        with_dim!(core.m, [1, 2, 3], |e| run_dim(
            d,
            e,
            core,
            z,
            u,
            update_first,
            out
        ))
    })
}

/// The loop itself. Steps whose z is complete take the fast kernels below; a step with a
/// missing entry, an S that is not positive definite (the general path then tries LU), and
/// the last step (so that K, y, S, the priors and posteriors the filter exposes afterwards
/// are those of the last step, as in FilterPy) take `Core`'s general update and predict.
fn run_dim<D: Dim, E: Dim>(
    d: D,
    e: E,
    core: &mut Core,
    z: &[f64],
    u: Option<&[f64]>,
    update_first: bool,
    out: Outputs<'_>,
) -> Result<(), usize> {
    let (n, m) = (d.get(), e.get());
    let nn = n * n;
    let steps = z.len() / m;
    let p = u.map_or(0, |u| u.len() / steps.max(1));
    let mut w = Work::new(core, n, m);
    // Every prediction leaves P exactly symmetric (its upper triangle mirrored); only the
    // first update of an update-first run sees the initial P.
    let symmetric_p0 =
        (0..n).all(|i| (0..i).all(|j| core.P[i * n + j].to_bits() == core.P[j * n + i].to_bits()));
    let Outputs {
        means,
        covs,
        means_p,
        covs_p,
    } = out;
    for k in 0..steps {
        let last = k + 1 == steps;
        let zk = &z[k * m..(k + 1) * m];
        let uk = u.map(|u| &u[k * p..(k + 1) * p]);
        let symmetric = k > 0 || !update_first || symmetric_p0;
        let mut upd = |core: &mut Core, w: &mut Work| -> Result<(), usize> {
            if last || zk.iter().any(|v| v.is_nan()) || !w.update(d, e, core, zk, symmetric) {
                core.update(zk, None, None, false).map_err(|_| k)?;
            }
            means[k * n..(k + 1) * n].copy_from_slice(&core.x[..n]);
            covs[k * nn..(k + 1) * nn].copy_from_slice(&core.P[..nn]);
            Ok(())
        };
        let mut pred = |core: &mut Core, w: &mut Work| {
            if last {
                core.predict(uk, None, None, None);
            } else {
                w.predict(d, core, uk);
            }
            means_p[k * n..(k + 1) * n].copy_from_slice(&core.x[..n]);
            covs_p[k * nn..(k + 1) * nn].copy_from_slice(&core.P[..nn]);
        };
        if update_first {
            upd(core, &mut w)?;
            pred(core, &mut w);
        } else {
            pred(core, &mut w);
            upd(core, &mut w)?;
        }
    }
    Ok(())
}

/// The model (copied from the filter) and the workspaces of the fast kernels, row-major.
struct Work {
    F: Vec<f64>,
    Q: Vec<f64>,
    H: Vec<f64>,
    R: Vec<f64>,
    B: Option<Vec<f64>>,
    alpha_sq: f64,
    tx: Vec<f64>,
    t: Vec<f64>,
    a: Vec<f64>,
    hp: Vec<f64>,
    pht: Vec<f64>,
    s: Vec<f64>,
    sinv: Vec<f64>,
    k: Vec<f64>,
    c: Vec<f64>,
    y: Vec<f64>,
}

impl Work {
    fn new(core: &Core, n: usize, m: usize) -> Self {
        Self {
            F: core.F.clone(),
            Q: core.Q.clone(),
            H: core.H.clone(),
            R: core.R.clone(),
            B: core.B.clone(),
            alpha_sq: core.alpha_sq,
            tx: vec![0.0; n],
            t: vec![0.0; n * n],
            a: vec![0.0; n * n],
            hp: vec![0.0; m * n],
            pht: vec![0.0; n * m],
            s: vec![0.0; m * m],
            sinv: vec![0.0; m],
            k: vec![0.0; n * m],
            c: vec![0.0; n * m],
            y: vec![0.0; m],
        }
    }

    /// `Core::predict` without the prior copies: x = F x + B u, P = α² F P Fᵀ + Q (the
    /// upper triangle of F P Fᵀ, mirrored).
    #[inline(always)]
    fn predict<D: Dim>(&mut self, d: D, core: &mut Core, u: Option<&[f64]>) {
        let n = d.get();
        let (F, Q) = (&self.F[..n * n], &self.Q[..n * n]);
        let (x, P) = (&mut core.x[..n], &mut core.P[..n * n]);
        let tx = &mut self.tx[..n];
        for i in 0..n {
            let mut s = 0.0;
            for j in 0..n {
                s += F[i * n + j] * x[j];
            }
            tx[i] = s;
        }
        if let (Some(B), Some(u)) = (self.B.as_deref(), u) {
            add_mul_vec(B, u, tx);
        }
        x.copy_from_slice(tx);
        // T = F P, row i = Σ_j F_ij P_j.
        let T = &mut self.t[..n * n];
        for i in 0..n {
            let row = &mut T[i * n..(i + 1) * n];
            row.fill(0.0);
            for j in 0..n {
                let f = F[i * n + j];
                for (r, v) in row.iter_mut().zip(&P[j * n..(j + 1) * n]) {
                    *r += f * v;
                }
            }
        }
        for i in 0..n {
            for j in i..n {
                let mut s = 0.0;
                for l in 0..n {
                    s += T[i * n + l] * F[j * n + l];
                }
                P[i * n + j] = self.alpha_sq * s + Q[i * n + j];
                P[j * n + i] = self.alpha_sq * s + Q[j * n + i];
            }
        }
    }

    /// `Core::update` (Joseph form) for a complete z when S is positive definite (factored
    /// by Cholesky from the same triangle `Core` reads); `false`, with nothing changed,
    /// otherwise. `symmetric`: P is exactly symmetric, so H P is read off P Hᵀ.
    #[inline(always)]
    fn update<D: Dim, E: Dim>(
        &mut self,
        d: D,
        e: E,
        core: &mut Core,
        z: &[f64],
        symmetric: bool,
    ) -> bool {
        let (n, m) = (d.get(), e.get());
        let (H, R) = (&self.H[..m * n], &self.R[..m * m]);
        let (x, P) = (&mut core.x[..n], &mut core.P[..n * n]);
        // y = z − H x; PHT = P Hᵀ (n×m); S = H PHT + R.
        let y = &mut self.y[..m];
        for a in 0..m {
            let mut s = 0.0;
            for j in 0..n {
                s += H[a * n + j] * x[j];
            }
            y[a] = z[a] - s;
        }
        let pht = &mut self.pht[..n * m];
        for i in 0..n {
            for a in 0..m {
                let mut s = 0.0;
                for j in 0..n {
                    s += P[i * n + j] * H[a * n + j];
                }
                pht[i * m + a] = s;
            }
        }
        let S = &mut self.s[..m * m];
        for a in 0..m {
            for b in 0..m {
                let mut s = 0.0;
                for j in 0..n {
                    s += H[a * n + j] * pht[j * m + b];
                }
                S[a * m + b] = s + R[a * m + b];
            }
        }
        // Cholesky of Sᵀ from its lower triangle (S's upper one), as `Core` factors it:
        // L_ab (a ≥ b) overwrites S_ba; `sinv` holds 1/L_aa.
        let sinv = &mut self.sinv[..m];
        for a in 0..m {
            let mut dg = S[a * m + a];
            for c in 0..a {
                dg -= S[c * m + a] * S[c * m + a];
            }
            if dg.is_nan() || dg <= 0.0 {
                return false;
            }
            let dg = dg.sqrt();
            S[a * m + a] = dg;
            sinv[a] = 1.0 / dg;
            for b in a + 1..m {
                let mut s = S[a * m + b];
                for c in 0..a {
                    s -= S[c * m + b] * S[c * m + a];
                }
                S[a * m + b] = s * sinv[a];
            }
        }
        // K = PHT S⁻¹, row by row: L Lᵀ kᵢ = phtᵢ.
        let K = &mut self.k[..n * m];
        K.copy_from_slice(pht);
        for i in 0..n {
            let r = &mut K[i * m..(i + 1) * m];
            for a in 0..m {
                let mut s = r[a];
                for c in 0..a {
                    s -= S[c * m + a] * r[c];
                }
                r[a] = s * sinv[a];
            }
            for a in (0..m).rev() {
                let mut s = r[a];
                for c in a + 1..m {
                    s -= S[a * m + c] * r[c];
                }
                r[a] = s * sinv[a];
            }
        }
        for i in 0..n {
            for a in 0..m {
                x[i] += K[i * m + a] * y[a];
            }
        }
        // Joseph form as `Core`: A = P − K (H P), P = A + (K R − A Hᵀ) Kᵀ.
        let hp = &mut self.hp[..m * n];
        if symmetric {
            // (P Hᵀ)ᵀ has the same products in the same order as H P when P = Pᵀ.
            for a in 0..m {
                for j in 0..n {
                    hp[a * n + j] = pht[j * m + a];
                }
            }
        } else {
            for a in 0..m {
                let row = &mut hp[a * n..(a + 1) * n];
                row.fill(0.0);
                for j in 0..n {
                    let h = H[a * n + j];
                    for (r, v) in row.iter_mut().zip(&P[j * n..(j + 1) * n]) {
                        *r += h * v;
                    }
                }
            }
        }
        let A = &mut self.a[..n * n];
        A.copy_from_slice(P);
        for i in 0..n {
            let row = &mut A[i * n..(i + 1) * n];
            for a in 0..m {
                let kk = K[i * m + a];
                for (r, v) in row.iter_mut().zip(&hp[a * n..(a + 1) * n]) {
                    *r -= kk * v;
                }
            }
        }
        let C = &mut self.c[..n * m];
        for i in 0..n {
            for a in 0..m {
                let mut kr = 0.0;
                for b in 0..m {
                    kr += K[i * m + b] * R[b * m + a];
                }
                let mut aht = 0.0;
                for j in 0..n {
                    aht += A[i * n + j] * H[a * n + j];
                }
                C[i * m + a] = kr - aht;
            }
        }
        P.copy_from_slice(A);
        for i in 0..n {
            let row = &mut P[i * n..(i + 1) * n];
            for a in 0..m {
                let c = C[i * m + a];
                for (j, r) in row.iter_mut().enumerate() {
                    *r += c * K[j * m + a];
                }
            }
        }
        true
    }
}

/// `KalmanFilter.rts_smoother` with the filter's own F and Q.
pub(crate) fn rts_smoother<'py>(
    core: &Core,
    py: Python<'py>,
    Xs: &Bound<'py, PyAny>,
    Ps: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyTuple>> {
    let n = core.n;
    let xa = float_array(Xs, "Xs")?;
    let pa = float_array(Ps, "Ps")?;
    let xs_shape = xa.shape().to_vec();
    let steps = match xs_shape.as_slice() {
        [s, l] if *l == n => *s,
        [s, l, 1] if *l == n => *s,
        s => {
            return Err(value_error(format!(
                "Xs has shape {}, expected (N, {n}, 1) or (N, {n})",
                shape_str(s)
            )));
        }
    };
    if pa.shape() != [steps, n, n] {
        return Err(value_error(format!(
            "Ps has shape {}, expected ({steps}, {n}, {n}) to match Xs",
            shape_str(pa.shape())
        )));
    }
    let mut xs = vec![0.0; steps * n];
    copy_finite(&xa.readonly().as_array(), "Xs", &mut xs)?;
    let mut ps = vec![0.0; steps * n * n];
    copy_finite(&pa.readonly().as_array(), "Ps", &mut ps)?;
    let (x, P, K, Pp) = rts(&xs, &ps, steps, n, &core.F, &core.Q).map_err(|k| {
        value_error(format!(
            "rts_smoother: the predicted covariance F Ps[{k}] Fᵀ + Q is singular"
        ))
    })?;
    let x_out = if xs_shape.len() == 3 {
        array3_out(py, x, steps, n, 1).into_any()
    } else {
        let arr = numpy::ndarray::Array2::from_shape_vec((steps, n), x)
            .unwrap_or_else(|_| numpy::ndarray::Array2::zeros((steps, n)));
        numpy::PyArray2::from_owned_array(py, arr).into_any()
    };
    PyTuple::new(
        py,
        [
            x_out,
            array3_out(py, P, steps, n, n).into_any(),
            array3_out(py, K, steps, n, n).into_any(),
            array3_out(py, Pp, steps, n, n).into_any(),
        ],
    )
}
