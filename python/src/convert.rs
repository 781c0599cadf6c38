//! Conversions between Python objects and the row-major buffers the filters keep, with the
//! checks that turn bad input into a one-line `ValueError`/`TypeError` naming the argument.

use numpy::ndarray::{Array1, Array2, Array3, ArrayViewD};
use numpy::{
    PyArray1, PyArray2, PyArray3, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyMemoryError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt};

/// A `ValueError` with a one-line message.
pub(crate) fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(one_line(msg.into()))
}

/// A `TypeError` with a one-line message.
pub(crate) fn type_error(msg: impl Into<String>) -> PyErr {
    PyTypeError::new_err(one_line(msg.into()))
}

/// Joins the lines of a message, so every error the module raises is one line.
fn one_line(msg: String) -> String {
    if msg.contains('\n') {
        msg.split_whitespace().collect::<Vec<_>>().join(" ")
    } else {
        msg
    }
}

/// A `MemoryError` for a buffer of `len` floats (`what` names it) that cannot be allocated.
pub(crate) fn memory_error(len: usize, what: &str) -> PyErr {
    PyMemoryError::new_err(format!(
        "cannot allocate {what}: {len} floats ({:.3e} bytes)",
        len as f64 * 8.0
    ))
}

/// `rows × cols` entries, or a `MemoryError` naming `what` if the count overflows.
pub(crate) fn entries(rows: usize, cols: usize, what: &str) -> PyResult<usize> {
    rows.checked_mul(cols)
        .filter(|&len| len <= isize::MAX as usize / 8)
        .ok_or_else(|| memory_error(usize::MAX, what))
}

/// A buffer of `len` copies of `value`, allocated fallibly: a size the user chose (a
/// dimension, a number of steps) that cannot be allocated is a `MemoryError` naming `what`,
/// never an abort of the interpreter.
pub(crate) fn filled(len: usize, value: f64, what: &str) -> PyResult<Vec<f64>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| memory_error(len, what))?;
    if value.to_bits() == 0 {
        // Zeros: the reservation showed the room is there; `vec!` then takes zeroed pages
        // from the system (calloc) instead of writing every one of them.
        drop(v);
        return Ok(vec![0.0; len]);
    }
    v.resize(len, value);
    Ok(v)
}

/// [`filled`] with zeros.
pub(crate) fn zeros(len: usize, what: &str) -> PyResult<Vec<f64>> {
    filled(len, 0.0, what)
}

/// A new float64 array of zeros of `shape`, made by `numpy.zeros`, so that a shape too large
/// for memory raises NumPy's `MemoryError`.
pub(crate) fn np_zeros<'py>(
    py: Python<'py>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let arr = py
        .import("numpy")?
        .call_method1("zeros", (pyo3::types::PyTuple::new(py, shape)?,))?;
    Ok(arr.cast_into::<PyArrayDyn<f64>>()?)
}

/// The Python type name of `obj`, for messages.
pub(crate) fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// Refuses a callable argument `name` that cannot be called (a `TypeError` naming it).
pub(crate) fn ensure_callable(f: &Bound<'_, PyAny>, name: &str) -> PyResult<()> {
    if f.is_callable() {
        Ok(())
    } else {
        Err(type_error(format!(
            "{name} must be callable, not {}",
            type_name(f)
        )))
    }
}

/// `obj` as a float64 NumPy array (integer arrays are converted; every other dtype, and
/// anything that is not an `ndarray`, is a `TypeError` naming `name`).
pub(crate) fn float_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    if let Ok(a) = obj.cast::<PyArrayDyn<f64>>() {
        return Ok(a.clone());
    }
    let Ok(untyped) = obj.cast::<PyUntypedArray>() else {
        return Err(type_error(format!(
            "{name} must be a numpy.ndarray of floats, not {}",
            type_name(obj)
        )));
    };
    let kind = untyped.dtype().kind();
    if matches!(kind, b'i' | b'u' | b'f') {
        let converted = obj.call_method1("astype", ("float64",))?;
        if let Ok(a) = converted.cast::<PyArrayDyn<f64>>() {
            return Ok(a.clone());
        }
    }
    Err(type_error(format!(
        "{name} must be a numpy.ndarray of real numbers, not of dtype {}",
        untyped
            .dtype()
            .str()
            .map(|s| s.to_string())
            .unwrap_or_else(|_| "?".into())
    )))
}

/// A real scalar (a Python int or float, a NumPy integer or float scalar, or a 0-d array
/// of such a dtype; not a bool), if `obj` is one.
pub(crate) fn scalar(obj: &Bound<'_, PyAny>) -> Option<f64> {
    if obj.is_instance_of::<PyBool>() {
        return None;
    }
    if obj.is_instance_of::<PyFloat>() || obj.is_instance_of::<PyInt>() {
        return obj.extract::<f64>().ok();
    }
    if let Ok(arr) = obj.cast::<PyUntypedArray>() {
        if arr.ndim() != 0 || !matches!(arr.dtype().kind(), b'i' | b'u' | b'f') {
            return None;
        }
        return obj.call_method0("item").ok()?.extract::<f64>().ok();
    }
    // NumPy scalars (np.float64 is a float subclass; np.int64 is not an int subclass).
    let ty = type_name(obj);
    if ty.starts_with("float") || ty.starts_with("int") || ty.starts_with("uint") {
        return obj.extract::<f64>().ok();
    }
    None
}

/// The shape of a view, rendered like NumPy's `(2, 1)`.
pub(crate) fn shape_str(shape: &[usize]) -> String {
    match shape {
        [a] => format!("({a},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Copies `view` (any strides) into `out` in row-major order, refusing non-finite entries.
pub(crate) fn copy_finite(view: &ArrayViewD<'_, f64>, name: &str, out: &mut [f64]) -> PyResult<()> {
    for (o, v) in out.iter_mut().zip(view.iter()) {
        if !v.is_finite() {
            return Err(value_error(format!(
                "{name} has a non-finite entry ({v}); every entry must be finite"
            )));
        }
        *o = *v;
    }
    Ok(())
}

/// Reads a `rows × cols` matrix argument into `out` (row-major): a float or integer array
/// of exactly that shape, or — for a square matrix when `scalar_identity` — a real scalar
/// s meaning s·I. Entries must be finite.
pub(crate) fn read_matrix(
    obj: &Bound<'_, PyAny>,
    name: &str,
    rows: usize,
    cols: usize,
    scalar_identity: bool,
    out: &mut [f64],
) -> PyResult<()> {
    if scalar_identity
        && rows == cols
        && let Some(s) = scalar(obj)
    {
        if !s.is_finite() {
            return Err(value_error(format!("{name} is {s}; it must be finite")));
        }
        out.fill(0.0);
        for i in 0..rows {
            out[i * cols + i] = s;
        }
        return Ok(());
    }
    let arr = float_array(obj, name)?;
    let ro = arr.readonly();
    let view = ro.as_array();
    if view.shape() != [rows, cols] {
        return Err(value_error(format!(
            "{name} has shape {}, expected ({rows}, {cols})",
            shape_str(view.shape())
        )));
    }
    copy_finite(&view, name, out)
}

/// Reads a vector of length `len` given as a `(len, 1)` column, a `(len,)` array, a real
/// scalar (a 0-d array included) when `len == 1`, or — when `allow_sequence` — any sequence
/// NumPy converts to floats. `missing_ok` marks a measurement: NaN passes (a missing entry)
/// and a `(1, len)` row is taken too, as FilterPy's `reshape_z` takes it; infinities never
/// pass.
pub(crate) fn read_vector(
    obj: &Bound<'_, PyAny>,
    name: &str,
    len: usize,
    allow_sequence: bool,
    missing_ok: bool,
    out: &mut [f64],
) -> PyResult<()> {
    if let Some(s) = scalar(obj) {
        if len != 1 {
            return Err(value_error(format!(
                "{name} is a scalar but must have {len} entries"
            )));
        }
        out[0] = s;
        return check_entries(name, out, missing_ok);
    }
    let owned;
    let source = if obj.cast::<PyUntypedArray>().is_err() && allow_sequence {
        if obj.is_instance_of::<pyo3::types::PyString>() || obj.is_none() {
            return Err(type_error(format!(
                "{name} must be a number, a sequence of numbers or a numpy.ndarray, not {}",
                type_name(obj)
            )));
        }
        let np = obj.py().import("numpy")?;
        owned = np.call_method1("asarray", (obj, "float64")).map_err(|_| {
            type_error(format!(
                "{name} must be a number, a sequence of numbers or a numpy.ndarray, not {}",
                type_name(obj)
            ))
        })?;
        &owned
    } else {
        obj
    };
    let arr = float_array(source, name)?;
    let ro = arr.readonly();
    let view = ro.as_array();
    let ok = matches!(view.shape(), [l] if *l == len)
        || matches!(view.shape(), [l, 1] if *l == len)
        || (missing_ok && matches!(view.shape(), [1, l] if *l == len));
    if !ok {
        return Err(value_error(format!(
            "{name} has shape {}, expected ({len}, 1) or ({len},){}",
            shape_str(view.shape()),
            if missing_ok && len != 1 {
                format!(" or (1, {len})")
            } else {
                String::new()
            }
        )));
    }
    for (o, v) in out.iter_mut().zip(view.iter()) {
        *o = *v;
    }
    check_entries(name, out, missing_ok)
}

/// Refuses infinities, and NaN unless it marks a missing entry.
fn check_entries(name: &str, v: &[f64], missing_ok: bool) -> PyResult<()> {
    for &x in v {
        if x.is_infinite() || (x.is_nan() && !missing_ok) {
            return Err(value_error(format!(
                "{name} has a non-finite entry ({x}); {}",
                if missing_ok {
                    "NaN marks a missing entry, infinities are refused"
                } else {
                    "every entry must be finite"
                }
            )));
        }
    }
    Ok(())
}

/// Refuses a matrix that is not symmetric positive semi-definite by the workspace's rule
/// ([`kalman::dense::check_covariance`]: symmetric within `SYMMETRY_TOL` of its largest
/// entry, no eigenvalue below `−PSD_TOL` of its largest one, so the verdict does not depend
/// on units).
pub(crate) fn check_covariance(name: &str, a: &[f64], n: usize) -> PyResult<()> {
    // The workspace's one rule (kalman's tolerances), on the row-major buffer read
    // column-major: a symmetric matrix reads the same, and the worst pair is swapped back.
    match kalman::dense::check_covariance("A", a, n) {
        Ok(()) => Ok(()),
        Err(kalman::Error::NotSymmetric { row, col, .. }) => {
            let (i, j) = (col, row);
            let (u, l) = (a[i * n + j], a[j * n + i]);
            Err(value_error(format!(
                "{name} is not symmetric: {name}[{i}, {j}] = {u} but {name}[{j}, {i}] = {l}"
            )))
        }
        Err(kalman::Error::NotPositiveSemidefinite {
            min_eigenvalue,
            tol,
            ..
        }) => Err(value_error(format!(
            "{name} is not positive semi-definite: its smallest eigenvalue {min_eigenvalue:.3e} \
             is below −{tol:.3e}"
        ))),
        Err(e) => Err(value_error(format!("{name} could not be checked: {e}"))),
    }
}

/// A new `(rows, cols)` float64 array holding a copy of `data` (row-major).
pub(crate) fn matrix_out<'py>(
    py: Python<'py>,
    data: &[f64],
    rows: usize,
    cols: usize,
) -> Bound<'py, PyArray2<f64>> {
    let arr = Array2::from_shape_vec((rows, cols), data.to_vec())
        .unwrap_or_else(|_| Array2::zeros((rows, cols)));
    PyArray2::from_owned_array(py, arr)
}

/// A new vector array: `(len, 1)` when `column`, else `(len,)`.
pub(crate) fn vector_out<'py>(py: Python<'py>, data: &[f64], column: bool) -> Bound<'py, PyAny> {
    if column {
        matrix_out(py, data, data.len(), 1).into_any()
    } else {
        PyArray1::from_owned_array(py, Array1::from_vec(data.to_vec())).into_any()
    }
}

/// A new `(a, b, c)` float64 array taking `data` (row-major).
pub(crate) fn array3_out(
    py: Python<'_>,
    data: Vec<f64>,
    a: usize,
    b: usize,
    c: usize,
) -> Bound<'_, PyArray3<f64>> {
    let arr = Array3::from_shape_vec((a, b, c), data).unwrap_or_else(|_| Array3::zeros((a, b, c)));
    PyArray3::from_owned_array(py, arr)
}

/// A 2-d float array argument as a faer matrix: any shape, finite entries (the engine checks
/// shapes and the rest, naming the matrix).
pub(crate) fn mat(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<kalman::faer::Mat<f64>> {
    let (r, c, buf) = rows_2d(obj, name)?;
    Ok(kalman::faer::Mat::from_fn(r, c, |i, j| buf[i * c + j]))
}

/// [`mat`], or a real scalar s as the 1×1 matrix [s] (a noise variance given as a number).
pub(crate) fn mat_or_scalar(
    obj: &Bound<'_, PyAny>,
    name: &str,
) -> PyResult<kalman::faer::Mat<f64>> {
    match scalar(obj) {
        Some(s) if !s.is_finite() => Err(value_error(format!("{name} is {s}; it must be finite"))),
        Some(s) => Ok(kalman::faer::Mat::from_fn(1, 1, |_, _| s)),
        None => mat(obj, name),
    }
}

/// A 2-d float array argument with finite entries as (rows, columns, row-major entries):
/// what [`mat`] and the nalgebra readers build their matrices from.
pub(crate) fn rows_2d(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<(usize, usize, Vec<f64>)> {
    let arr = float_array(obj, name)?;
    let ro = arr.readonly();
    let view = ro.as_array();
    let [r, c] = view.shape() else {
        return Err(value_error(format!(
            "{name} has shape {}, expected a 2-d array",
            shape_str(view.shape())
        )));
    };
    let (r, c) = (*r, *c);
    let mut buf = zeros(entries(r, c, name)?, name)?;
    copy_finite(&view, name, &mut buf)?;
    Ok((r, c, buf))
}

/// A faer matrix as a new (r, c) array.
pub(crate) fn faer_out<'py>(
    py: Python<'py>,
    m: kalman::faer::MatRef<'_, f64>,
) -> Bound<'py, numpy::PyArray2<f64>> {
    numpy::PyArray2::from_owned_array(
        py,
        numpy::ndarray::Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]),
    )
}

/// Copies a faer matrix into `out`, row-major.
pub(crate) fn copy_mat(out: &mut [f64], m: kalman::faer::MatRef<'_, f64>) {
    let c = m.ncols();
    for (i, row) in out.chunks_exact_mut(c).enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = m[(i, j)];
        }
    }
}

/// What `filter`, `ekf` and `ukf` return for a series of `steps` steps of an n-state
/// filter, filled step by step: x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k} (row-major), the
/// log-likelihood and the NIS (NaN with no measurement).
pub(crate) struct FilterRecord {
    steps: usize,
    n: usize,
    /// Numbers per mean (n, or more for a state on a manifold).
    stored: usize,
    xs: Vec<f64>,
    ps: Vec<f64>,
    xp: Vec<f64>,
    pp: Vec<f64>,
    ll: Vec<f64>,
    nis: Vec<f64>,
}

impl FilterRecord {
    /// An empty record of `steps` steps of an n-state filter (a `MemoryError` if it does not
    /// fit in memory).
    pub(crate) fn new(steps: usize, n: usize) -> PyResult<Self> {
        Self::stored(steps, n, n)
    }

    /// [`FilterRecord::new`] for means stored in `stored` numbers (a state on a manifold;
    /// the covariances stay n×n).
    pub(crate) fn stored(steps: usize, n: usize, stored: usize) -> PyResult<Self> {
        let what = "the filtered record";
        let (sn, snn) = (
            entries(steps, stored, what)?,
            entries(steps, entries(n, n, what)?, what)?,
        );
        Ok(Self {
            steps,
            n,
            stored,
            xs: zeros(sn, what)?,
            ps: zeros(snn, what)?,
            xp: zeros(sn, what)?,
            pp: zeros(snn, what)?,
            ll: zeros(steps, what)?,
            nis: filled(steps, f64::NAN, what)?,
        })
    }

    /// Stores step k: the filtered and predicted means and covariances, the step's
    /// log-likelihood and its NIS (`None`: no measurement).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn set(
        &mut self,
        k: usize,
        x: &[f64],
        p: kalman::faer::MatRef<'_, f64>,
        x_pred: &[f64],
        p_pred: kalman::faer::MatRef<'_, f64>,
        log_likelihood: f64,
        nis: Option<f64>,
    ) {
        let (s, nn) = (self.stored, self.n * self.n);
        self.xs[k * s..(k + 1) * s].copy_from_slice(x);
        self.xp[k * s..(k + 1) * s].copy_from_slice(x_pred);
        copy_mat(&mut self.ps[k * nn..(k + 1) * nn], p);
        copy_mat(&mut self.pp[k * nn..(k + 1) * nn], p_pred);
        self.ll[k] = log_likelihood;
        self.nis[k] = nis.unwrap_or(f64::NAN);
    }

    /// The dict "x" (N, stored), "P" (N, n, n), "x_pred", "P_pred", "log_likelihood" (N,),
    /// "nis" (N,).
    pub(crate) fn into_dict(self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let (steps, n, s) = (self.steps, self.n, self.stored);
        let out = PyDict::new(py);
        let v2 = |v: Vec<f64>| {
            PyArray2::from_owned_array(
                py,
                Array2::from_shape_vec((steps, s), v).unwrap_or_else(|_| Array2::zeros((0, s))),
            )
        };
        out.set_item("x", v2(self.xs))?;
        out.set_item("P", array3_out(py, self.ps, steps, n, n))?;
        out.set_item("x_pred", v2(self.xp))?;
        out.set_item("P_pred", array3_out(py, self.pp, steps, n, n))?;
        out.set_item(
            "log_likelihood",
            PyArray1::from_owned_array(py, Array1::from_vec(self.ll)),
        )?;
        out.set_item(
            "nis",
            PyArray1::from_owned_array(py, Array1::from_vec(self.nis)),
        )?;
        Ok(out)
    }
}
