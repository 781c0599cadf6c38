//! The unscented filter's arithmetic for `UnscentedKalmanFilter`, as FilterPy 2.0.0 does it:
//! sigma points, the user's f and h over them (one call per point, or one call with all of
//! them in vectorised mode), the unscented transform, the cross-covariance, one prediction
//! and one update. Everything is read from the filter's attribute dict at the start of a call
//! and the results are returned, so a failed call (an exception in a callable, Ctrl-C, bad
//! input) leaves the filter as it was.
//!
//! Notation: n states, m measurements, N sigma points χ_i with weights Wm_i, Wc_i. The
//! transform of points γ_i: mean μ = Σ Wm_i γ_i (or the user's mean function), covariance
//! Σ Wc_i r_i r_iᵀ + noise with r_i = residual(γ_i, μ). The update: S the transform's
//! covariance of h(χ_i) with R, P_xz = Σ Wc_i (χ_i − x)(h_i − ẑ)ᵀ, K = P_xz S⁻¹ (solved),
//! x ← state_add(x, K y), y = residual_z(z, ẑ), P ← P − K S Kᵀ.
#![allow(non_snake_case)]

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::convert::{check_covariance, read_matrix, read_vector, scalar, value_error, zeros};
use crate::linalg::Factor;
use crate::sigma::{Rule, dict_of, item, native, np_attr};

/// A `(rows, cols)` float64 array taking `data`.
pub(crate) fn arr2<'py>(
    py: Python<'py>,
    data: Vec<f64>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let a = Array2::from_shape_vec((rows, cols), data).map_err(|e| value_error(e.to_string()))?;
    Ok(PyArray2::from_owned_array(py, a).into_any())
}

/// A `(len,)` float64 array copying `data`.
pub(crate) fn arr1<'py>(py: Python<'py>, data: &[f64]) -> Bound<'py, PyAny> {
    PyArray1::from_slice(py, data).into_any()
}

/// NumPy's `LinAlgError` (a `ValueError`) with `msg`, as NumPy's `inv` raises it.
pub(crate) fn linalg_error(py: Python<'_>, msg: &str) -> PyErr {
    match py
        .import("numpy.linalg")
        .and_then(|m| m.getattr("LinAlgError"))
        .and_then(|c| c.call1((msg,)))
    {
        Ok(e) => PyErr::from_value(e),
        Err(e) => e,
    }
}

/// `obj` as a `(rows, cols)` float matrix: anything NumPy converts (a list too).
pub(crate) fn read_mat(
    obj: &Bound<'_, PyAny>,
    name: &str,
    rows: usize,
    cols: usize,
) -> PyResult<Vec<f64>> {
    let mut out = zeros(entries(rows, cols, name)?, name)?;
    if let Some(r) = fast_read(obj, &[rows, cols], name, &mut out) {
        return r.map(|()| out);
    }
    if exact_shape(obj, &[rows, cols]) {
        read_matrix(obj, name, rows, cols, false, &mut out)?;
        return Ok(out);
    }
    let np = crate::sigma::numpy(obj.py())?;
    let a = np.call_method1("asarray", (obj, "float64")).map_err(|_| {
        crate::convert::type_error(format!("{name} must be an array of real numbers"))
    })?;
    let a = np.call_method1("atleast_2d", (a,))?;
    read_matrix(&a, name, rows, cols, false, &mut out)?;
    Ok(out)
}

/// Copies a C-contiguous float64 array of exactly `shape` into `out` (entries must be
/// finite); None when `obj` is anything else (the general readers take it). Reading through
/// `to_vec` skips rust-numpy's borrow tracking, a third of a small read's cost.
pub(crate) fn fast_read(
    obj: &Bound<'_, PyAny>,
    shape: &[usize],
    name: &str,
    out: &mut [f64],
) -> Option<PyResult<()>> {
    use numpy::{PyArrayMethods, PyUntypedArrayMethods};
    let a = obj.cast::<numpy::PyArrayDyn<f64>>().ok()?;
    if a.shape() != shape || !a.is_c_contiguous() {
        return None;
    }
    let v = a.to_vec().ok()?;
    if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
        return Some(Err(value_error(format!(
            "{name} has a non-finite entry ({bad}); every entry must be finite"
        ))));
    }
    out.copy_from_slice(&v);
    Some(Ok(()))
}

/// Whether `obj` is a real NumPy array of exactly `shape` (read without NumPy's help).
fn exact_shape(obj: &Bound<'_, PyAny>, shape: &[usize]) -> bool {
    use numpy::{PyArrayDescrMethods, PyUntypedArrayMethods};
    obj.cast::<numpy::PyUntypedArray>()
        .is_ok_and(|a| a.shape() == shape && matches!(a.dtype().kind(), b'f' | b'i' | b'u'))
}

/// `rows × cols`, or a `MemoryError` naming `name`.
fn entries(rows: usize, cols: usize, name: &str) -> PyResult<usize> {
    crate::convert::entries(rows, cols, name)
}

/// A noise covariance as FilterPy adds it (`P += noise`): broadcast to dim × dim (a scalar s
/// adds s to every entry), then checked symmetric PSD.
pub(crate) fn read_noise(obj: &Bound<'_, PyAny>, name: &str, dim: usize) -> PyResult<Vec<f64>> {
    if let Some(v) = scalar(obj) {
        if !v.is_finite() {
            return Err(value_error(format!("{name} is {v}; it must be finite")));
        }
        let out = crate::convert::filled(entries(dim, dim, name)?, v, name)?;
        check_covariance(name, &out, dim)?;
        return Ok(out);
    }
    if exact_shape(obj, &[dim, dim]) {
        let mut out = zeros(entries(dim, dim, name)?, name)?;
        if let Some(r) = fast_read(obj, &[dim, dim], name, &mut out) {
            r?;
            check_covariance(name, &out, dim)?;
            return Ok(out);
        }
        read_matrix(obj, name, dim, dim, false, &mut out)?;
        check_covariance(name, &out, dim)?;
        return Ok(out);
    }
    let np = crate::sigma::numpy(obj.py())?;
    let a = np.call_method1("asarray", (obj, "float64")).map_err(|_| {
        crate::convert::type_error(format!("{name} must be an array of real numbers"))
    })?;
    let b = np
        .call_method1("broadcast_to", (&a, (dim, dim)))
        .map_err(|_| {
            value_error(format!(
                "{name} has shape {}, which does not broadcast to ({dim}, {dim})",
                a.getattr("shape")
                    .and_then(|s| s.repr())
                    .map(|s| s.to_string())
                    .unwrap_or_default()
            ))
        })?;
    let mut out = zeros(entries(dim, dim, name)?, name)?;
    read_matrix(&b, name, dim, dim, false, &mut out)?;
    check_covariance(name, &out, dim)?;
    Ok(out)
}

/// What one call needs of the filter: the sizes, the weights, the points object and the
/// user's functions (None where FilterPy's default is in place, so Rust does that part).
pub(crate) struct Ctx<'py> {
    pub py: Python<'py>,
    pub d: Bound<'py, PyDict>,
    pub n: usize,
    pub m: usize,
    pub N: usize,
    pub wm: Vec<f64>,
    pub wc: Vec<f64>,
    wm_obj: Bound<'py, PyAny>,
    wc_obj: Bound<'py, PyAny>,
    points: Bound<'py, PyAny>,
    rule: Option<(Rule, Bound<'py, PyDict>)>,
    pub vectorized: bool,
    pub residual_x: Option<Bound<'py, PyAny>>,
    pub residual_z: Option<Bound<'py, PyAny>>,
    pub state_add: Option<Bound<'py, PyAny>>,
    pub x_mean: Option<Bound<'py, PyAny>>,
    pub z_mean: Option<Bound<'py, PyAny>>,
    pub ut: Option<Bound<'py, PyAny>>,
}

/// `f` unless it is `default` or None.
fn custom<'py>(f: Bound<'py, PyAny>, default: &Bound<'py, PyAny>) -> Option<Bound<'py, PyAny>> {
    (!f.is_none() && !f.is(default)).then_some(f)
}

impl<'py> Ctx<'py> {
    /// Reads the filter's dict (`UT`: the user's transform for this call, if any).
    pub(crate) fn new(slf: &Bound<'py, PyAny>, ut: Option<&Bound<'py, PyAny>>) -> PyResult<Self> {
        let py = slf.py();
        let d = dict_of(slf)?;
        let n: usize = item(&d, pyo3::intern!(d.py(), "_dim_x"))?.extract()?;
        let m: usize = item(&d, pyo3::intern!(d.py(), "_dim_z"))?.extract()?;
        let points = item(&d, pyo3::intern!(d.py(), "points_fn"))?;
        let N: usize = item(&d, pyo3::intern!(py, "_num_sigmas"))?.extract()?;
        let (wm_obj, wc_obj) = (
            item(&d, pyo3::intern!(d.py(), "Wm"))?,
            item(&d, pyo3::intern!(d.py(), "Wc"))?,
        );
        let mut wm = zeros(N, "Wm")?;
        match fast_read(&wm_obj, &[N], "Wm", &mut wm) {
            Some(r) => r?,
            None => read_vector(&wm_obj, "Wm", N, true, false, &mut wm)?,
        }
        let mut wc = zeros(N, "Wc")?;
        match fast_read(&wc_obj, &[N], "Wc", &mut wc) {
            Some(r) => r?,
            None => read_vector(&wc_obj, "Wc", N, true, false, &mut wc)?,
        }
        let rule = match native(&points) {
            Some(r) => Some((r, dict_of(&points)?)),
            None => None,
        };
        let (sub, add) = (np_attr(py, "subtract")?, np_attr(py, "add")?);
        Ok(Self {
            py,
            n,
            m,
            N,
            wm,
            wc,
            wm_obj,
            wc_obj,
            rule,
            points,
            vectorized: item(&d, pyo3::intern!(d.py(), "vectorized"))?.is_truthy()?,
            residual_x: custom(item(&d, pyo3::intern!(d.py(), "residual_x"))?, &sub),
            residual_z: custom(item(&d, pyo3::intern!(d.py(), "residual_z"))?, &sub),
            state_add: custom(item(&d, pyo3::intern!(d.py(), "state_add"))?, &add),
            x_mean: custom(
                item(&d, pyo3::intern!(d.py(), "x_mean"))?,
                &py.None().into_bound(py),
            ),
            z_mean: custom(
                item(&d, pyo3::intern!(d.py(), "z_mean"))?,
                &py.None().into_bound(py),
            ),
            ut: ut.filter(|u| !u.is_none()).cloned(),
            d,
        })
    }

    /// The sigma points (N × n) at (x, P).
    pub(crate) fn sigmas(&self, x: &[f64], P: &[f64]) -> PyResult<Vec<f64>> {
        let (n, N) = (self.n, self.N);
        if let Some((rule, pd)) = &self.rule {
            let pts = crate::sigma::draw(self.py, *rule, pd, x, P)?;
            if pts.len() == N * n {
                return Ok(pts);
            }
        }
        let r = self.points.call_method1(
            "sigma_points",
            (arr1(self.py, x), arr2(self.py, P.to_vec(), n, n)?),
        )?;
        read_mat(&r, "the value of points.sigma_points(x, P)", N, n)
    }

    /// f applied to every row of `rows` (N × dim_in): `f(row, *lead, **kwargs)` per row,
    /// or `f(rows, *lead, **kwargs)` once in vectorised mode (returning N × dim_out, or N
    /// values when dim_out is 1). A pending signal is raised before every call.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn apply(
        &self,
        f: &Bound<'py, PyAny>,
        name: &str,
        rows: &[f64],
        dim_in: usize,
        dim_out: usize,
        lead: &[Bound<'py, PyAny>],
        kwargs: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Vec<f64>> {
        let py = self.py;
        let N = rows.len() / dim_in.max(1);
        let mut out = zeros(entries(N, dim_out, name)?, name)?;
        let call = |arg: Bound<'py, PyAny>| -> PyResult<Bound<'py, PyAny>> {
            py.check_signals()?;
            let all: Vec<Bound<'py, PyAny>> =
                std::iter::once(arg).chain(lead.iter().cloned()).collect();
            let args = PyTuple::new(py, all)?;
            let r = f.call(args, kwargs)?;
            py.check_signals()?;
            Ok(r)
        };
        if self.vectorized {
            let r = call(arr2(py, rows.to_vec(), N, dim_in)?)?;
            let label = format!("the value of {name} (vectorised: an ({N}, {dim_out}) array)");
            if let Some(res) = fast_read(&r, &[N, dim_out], &label, &mut out).or_else(|| {
                (dim_out == 1)
                    .then(|| fast_read(&r, &[N], &label, &mut out))
                    .flatten()
            }) {
                return res.map(|()| out);
            }
            if dim_out == 1 && exact_shape(&r, &[N]) {
                read_vector(&r, &label, N, false, false, &mut out)?;
                return Ok(out);
            }
            let a = if exact_shape(&r, &[N, dim_out]) {
                r
            } else {
                let np = crate::sigma::numpy(py)?;
                let a = np.call_method1("asarray", (&r, "float64"))?;
                if dim_out == 1 && a.getattr("ndim")?.extract::<usize>()? == 1 {
                    a.call_method1("reshape", (N, 1))?
                } else {
                    a
                }
            };
            read_matrix(&a, &label, N, dim_out, false, &mut out)?;
        } else {
            let label = format!("the value of {name}");
            for i in 0..N {
                let r = call(arr1(py, &rows[i * dim_in..(i + 1) * dim_in]))?;
                let row = &mut out[i * dim_out..(i + 1) * dim_out];
                match fast_read(&r, &[dim_out], &label, row) {
                    Some(res) => res?,
                    None => read_vector(&r, &label, dim_out, true, false, row)?,
                }
            }
        }
        Ok(out)
    }

    /// The residuals of the rows of `a` (N × dim) from `b`: a_i − b, or `f(a_i, b)` (one
    /// call with all rows in vectorised mode).
    pub(crate) fn residuals(
        &self,
        f: Option<&Bound<'py, PyAny>>,
        name: &str,
        a: &[f64],
        b: &[f64],
        dim: usize,
    ) -> PyResult<Vec<f64>> {
        match f {
            None => Ok(a
                .chunks_exact(dim.max(1))
                .flat_map(|row| row.iter().zip(b).map(|(x, y)| x - y))
                .collect()),
            Some(f) => {
                let b = [arr1(self.py, b)];
                self.apply(f, name, a, dim, dim, &b, None)
            }
        }
    }

    /// The unscented transform of `sigmas` (N × dim) with `noise` added: (mean, covariance).
    pub(crate) fn transform(
        &self,
        sigmas: &[f64],
        dim: usize,
        noise: &[f64],
        noise_obj: &Bound<'py, PyAny>,
        measurement: bool,
    ) -> PyResult<(Vec<f64>, Vec<f64>)> {
        let py = self.py;
        let N = self.N;
        let (mean_fn, residual, rname) = if measurement {
            (self.z_mean.as_ref(), self.residual_z.as_ref(), "residual_z")
        } else {
            (self.x_mean.as_ref(), self.residual_x.as_ref(), "residual_x")
        };
        if let Some(ut) = &self.ut {
            py.check_signals()?;
            let sub = np_attr(py, "subtract")?;
            let none = py.None().into_bound(py);
            let r = ut.call1((
                arr2(py, sigmas.to_vec(), N, dim)?,
                &self.wm_obj,
                &self.wc_obj,
                noise_obj,
                mean_fn.unwrap_or(&none),
                residual.unwrap_or(&sub),
            ))?;
            let (mu, cov): (Bound<'py, PyAny>, Bound<'py, PyAny>) = r.extract()?;
            let mut mean = zeros(dim, "the mean")?;
            read_vector(&mu, "the mean UT returned", dim, true, false, &mut mean)?;
            return Ok((
                mean,
                read_mat(&cov, "the covariance UT returned", dim, dim)?,
            ));
        }
        let mut mean = zeros(dim, "the mean")?;
        match mean_fn {
            Some(f) => {
                py.check_signals()?;
                let r = f.call1((arr2(py, sigmas.to_vec(), N, dim)?, &self.wm_obj))?;
                let label = if measurement {
                    "the value of z_mean_fn"
                } else {
                    "the value of x_mean_fn"
                };
                read_vector(&r, label, dim, true, false, &mut mean)?;
            }
            None => {
                for (w, row) in self.wm.iter().zip(sigmas.chunks_exact(dim)) {
                    for (m, v) in mean.iter_mut().zip(row) {
                        *m += w * v;
                    }
                }
            }
        }
        let y = self.residuals(residual, rname, sigmas, &mean, dim)?;
        let mut cov = noise.to_vec();
        weighted_outer(&self.wc, &y, &y, dim, dim, &mut cov);
        Ok((mean, cov))
    }

    /// P_xz = Σ Wc_i residual_x(χ_i, x) residual_z(h_i, ẑ)ᵀ (n × m).
    pub(crate) fn cross(
        &self,
        x: &[f64],
        zp: &[f64],
        sf: &[f64],
        sh: &[f64],
    ) -> PyResult<Vec<f64>> {
        let (n, m) = (self.n, self.m);
        let dx = self.residuals(self.residual_x.as_ref(), "residual_x", sf, x, n)?;
        let dz = self.residuals(self.residual_z.as_ref(), "residual_z", sh, zp, m)?;
        let mut out = zeros(entries(n, m, "Pxz")?, "Pxz")?;
        weighted_outer(&self.wc, &dx, &dz, n, m, &mut out);
        Ok(out)
    }
}

/// out += Σ_i w_i a_i b_iᵀ for the rows a_i (of `ra` entries) and b_i (of `rb`).
pub(crate) fn weighted_outer(
    w: &[f64],
    a: &[f64],
    b: &[f64],
    ra: usize,
    rb: usize,
    out: &mut [f64],
) {
    for (i, wi) in w.iter().enumerate() {
        let ai = &a[i * ra..(i + 1) * ra];
        let bi = &b[i * rb..(i + 1) * rb];
        for (r, av) in ai.iter().enumerate() {
            let s = wi * av;
            for (o, bv) in out[r * rb..(r + 1) * rb].iter_mut().zip(bi) {
                *o += s * bv;
            }
        }
    }
}

/// The result of one prediction.
pub(crate) struct Predicted {
    pub x: Vec<f64>,
    pub P: Vec<f64>,
    pub sigmas_f: Vec<f64>,
}

/// One prediction from (x, P): the points, f over them, the transform with Q, and the points
/// redrawn at the prior (FilterPy 2.0.0's `sigmas_f` for the update).
pub(crate) fn predict<'py>(
    c: &Ctx<'py>,
    x: &[f64],
    P: &[f64],
    Q: (&[f64], &Bound<'py, PyAny>),
    fx: &Bound<'py, PyAny>,
    dt: &Bound<'py, PyAny>,
    kwargs: Option<&Bound<'py, PyDict>>,
) -> PyResult<Predicted> {
    let n = c.n;
    let sig = c.sigmas(x, P)?;
    let sf = c.apply(fx, "fx", &sig, n, n, std::slice::from_ref(dt), kwargs)?;
    let (xp, Pp) = c.transform(&sf, n, Q.0, Q.1, false)?;
    let sigmas_f = c.sigmas(&xp, &Pp)?;
    Ok(Predicted {
        x: xp,
        P: Pp,
        sigmas_f,
    })
}

/// The result of one update.
pub(crate) struct Updated {
    pub x: Vec<f64>,
    pub P: Vec<f64>,
    pub z: Vec<f64>,
    pub sigmas_h: Vec<f64>,
    pub S: Vec<f64>,
    pub SI: Vec<f64>,
    pub K: Vec<f64>,
    pub y: Vec<f64>,
}

/// One update of (x, P) with the prior's points `sf` and the measurement `z` (m entries).
#[allow(clippy::too_many_arguments)]
pub(crate) fn update<'py>(
    c: &Ctx<'py>,
    x: &[f64],
    P: &[f64],
    sf: &[f64],
    z: Vec<f64>,
    R: (&[f64], &Bound<'py, PyAny>),
    hx: &Bound<'py, PyAny>,
    kwargs: Option<&Bound<'py, PyDict>>,
) -> PyResult<Updated> {
    let (py, n, m) = (c.py, c.n, c.m);
    let sh = c.apply(hx, "hx", sf, n, m, &[], kwargs)?;
    let (zp, S) = c.transform(&sh, m, R.0, R.1, true)?;
    let mut f = Factor::try_new(m).ok_or_else(|| crate::convert::memory_error(m * m, "S"))?;
    if !f.factor(&S, m) {
        return Err(linalg_error(
            py,
            "S (the innovation covariance) is singular",
        ));
    }
    let mut SI = zeros(entries(m, m, "SI")?, "SI")?;
    for i in 0..m {
        SI[i * m + i] = 1.0;
    }
    f.solve(&mut SI, m);
    let Pxz = c.cross(x, &zp, sf, &sh)?;
    // Kᵀ = S⁻¹ P_xzᵀ (S symmetric): solve for the n columns at once.
    let mut Kt = zeros(entries(m, n, "K")?, "K")?;
    for i in 0..n {
        for j in 0..m {
            Kt[j * n + i] = Pxz[i * m + j];
        }
    }
    f.solve(&mut Kt, n);
    let mut K = zeros(n * m, "K")?;
    for i in 0..n {
        for j in 0..m {
            K[i * m + j] = Kt[j * n + i];
        }
    }
    let y = match &c.residual_z {
        None => z.iter().zip(&zp).map(|(a, b)| a - b).collect(),
        Some(r) => {
            py.check_signals()?;
            let v = r.call1((arr1(py, &z), arr1(py, &zp)))?;
            let mut y = zeros(m, "y")?;
            read_vector(&v, "the value of residual_z(z, zp)", m, true, false, &mut y)?;
            y
        }
    };
    let Ky: Vec<f64> = (0..n)
        .map(|i| (0..m).map(|j| K[i * m + j] * y[j]).sum())
        .collect();
    let xn = match &c.state_add {
        None => x.iter().zip(&Ky).map(|(a, b)| a + b).collect(),
        Some(add) => {
            py.check_signals()?;
            let v = add.call1((arr1(py, x), arr1(py, &Ky)))?;
            let mut xn = zeros(n, "x")?;
            read_vector(
                &v,
                "the value of state_add(x, K y)",
                n,
                true,
                false,
                &mut xn,
            )?;
            xn
        }
    };
    // P − K S Kᵀ, with K S = P_xz.
    let mut Pn = P.to_vec();
    for i in 0..n {
        for j in 0..n {
            let s: f64 = (0..m).map(|k| Pxz[i * m + k] * K[j * m + k]).sum();
            Pn[i * n + j] -= s;
        }
    }
    Ok(Updated {
        x: xn,
        P: Pn,
        z,
        sigmas_h: sh,
        S,
        SI,
        K,
        y,
    })
}

/// A measurement of m entries (a scalar when m = 1; a list, a (m,), (m, 1) or (1, m) array).
pub(crate) fn read_z(z: &Bound<'_, PyAny>, m: usize) -> PyResult<Vec<f64>> {
    let mut out = zeros(m, "z")?;
    if m == 1
        && let Some(s) = scalar(z)
    {
        if !s.is_finite() {
            return Err(value_error(format!("z is {s}; it must be finite")));
        }
        out[0] = s;
        return Ok(out);
    }
    if exact_shape(z, &[m]) || exact_shape(z, &[m, 1]) {
        read_vector(z, "z", m, true, false, &mut out)?;
        return Ok(out);
    }
    let np = crate::sigma::numpy(z.py())?;
    let a = np.call_method1("asarray", (z, "float64")).map_err(|_| {
        crate::convert::type_error("z must be a number or an array of real numbers")
    })?;
    let size: usize = a.getattr("size")?.extract()?;
    if size != m {
        return Err(value_error(format!(
            "z has {size} entries, expected dim_z = {m}"
        )));
    }
    let flat = a.call_method0("ravel")?;
    read_vector(&flat, "z", m, true, false, &mut out)?;
    Ok(out)
}
