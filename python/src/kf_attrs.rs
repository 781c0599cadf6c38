//! The state of `launch_estimation.KalmanFilter` and its array attributes (the methods are in
//! `kf.rs`, FilterPy's other conveniences in `kf_compat.rs`).
//!
//! Attributes are copied into preallocated buffers when set (and checked once, there);
//! reading one returns a NumPy array that is then kept, so reading it again returns the same
//! object (as in FilterPy) and an in-place edit of it (`kf.x[0] = 1.0`, `kf.P *= 10`) is
//! noticed — by comparing it with the buffer, a few dozen loads — before the next call
//! uses it. A call that changes a quantity drops the kept array, so arrays already handed out
//! stay snapshots (`xs.append(kf.x)` works as in FilterPy). An array the user assigns is
//! kept as it is, whatever its real dtype (an integer or float32 array is read through the
//! one conversion, `convert::float_array`), so its in-place edits are seen as FilterPy sees
//! them. Each array attribute is an `ArrayAttribute` descriptor on the class, made from the
//! `DOCS` table at import, rather than a getter and a setter written out per attribute.
#![allow(non_snake_case)]

use numpy::{PyArrayDescrMethods, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::PyAttributeError;
use pyo3::prelude::*;
use pyo3::types::PyType;

use crate::convert::{
    check_covariance, float_array, matrix_out, read_matrix, read_vector, scalar, shape_str,
    type_error, type_name, value_error, vector_out,
};
use crate::guard;
use crate::kf_core::{Core, UpdateError};

/// The attributes a `KalmanFilter` keeps a returned array for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum A {
    X,
    P,
    F,
    Q,
    H,
    R,
    B,
    M,
    K,
    Y,
    S,
    SI,
    Z,
    XPrior,
    PPrior,
    XPost,
    PPost,
}

/// The inputs a user may edit in place, checked before every call.
pub(crate) const INPUTS: [A; 8] = [A::X, A::P, A::F, A::Q, A::H, A::R, A::B, A::M];
pub(crate) const N_ATTR: usize = 17;
/// The attributes a prediction changes.
pub(crate) const PREDICTED: [A; 4] = [A::X, A::P, A::XPrior, A::PPrior];
/// The attributes an update changes.
pub(crate) const UPDATED: [A; 9] = [
    A::X,
    A::P,
    A::K,
    A::Y,
    A::S,
    A::SI,
    A::Z,
    A::XPost,
    A::PPost,
];

/// A linear Kalman filter with FilterPy's `KalmanFilter` interface (n = dim_x states,
/// m = dim_z measurements, p = dim_u controls).
#[pyclass(module = "launch_estimation", subclass)]
#[derive(Debug)]
pub struct KalmanFilter {
    pub(crate) core: Core,
    pub(crate) dim_u: usize,
    /// Whether x is a (n, 1) column (FilterPy's default) rather than a (n,) vector.
    pub(crate) x_col: bool,
    pub(crate) cache: [Option<Py<PyAny>>; N_ATTR],
}

/// The docstring of each array attribute of the class.
const DOCS: [(A, &str); N_ATTR] = [
    (A::X, "State estimate, (dim_x, 1) (or (dim_x,) if set so)."),
    (A::P, "State covariance, (dim_x, dim_x); symmetric PSD."),
    (A::F, "State transition F, (dim_x, dim_x)."),
    (
        A::Q,
        "Process noise covariance Q, (dim_x, dim_x); symmetric PSD.",
    ),
    (A::H, "Measurement matrix H, (dim_z, dim_x)."),
    (
        A::R,
        "Measurement noise covariance R, (dim_z, dim_z); symmetric PSD.",
    ),
    (A::B, "Control matrix B, (dim_x, dim_u), or None."),
    (
        A::M,
        "Cross-covariance of the prior state error and the measurement noise, (dim_x, dim_z);\n\
         used by `update_correlated` only.",
    ),
    (A::K, "Kalman gain of the last update, (dim_x, dim_z)."),
    (
        A::Y,
        "Innovation (residual) of the last update, (dim_z, 1).",
    ),
    (
        A::S,
        "Innovation covariance of the last update, (dim_z, dim_z).",
    ),
    (
        A::SI,
        "Inverse of S (computed from its factorisation when read).",
    ),
    (
        A::Z,
        "Last measurement, (dim_z, 1); NaN where missing (FilterPy stores None).",
    ),
    (A::XPrior, "Prior (predicted) state after the last predict."),
    (A::PPrior, "Prior covariance after the last predict."),
    (A::XPost, "Posterior state after the last update."),
    (A::PPost, "Posterior covariance after the last update."),
];

// The class attribute behind `kf.x`, `kf.K`, …: reading returns `KalmanFilter::get`'s array,
// assigning one of the `INPUTS` goes through `KalmanFilter::assign`, the others are
// read-only. One descriptor type serves every array attribute, with the errors a property
// gives; a plain comment, not a docstring, so that `__doc__` is the attribute's own.
#[pyclass(module = "launch_estimation", frozen)]
pub(crate) struct ArrayAttribute {
    a: A,
    doc: &'static str,
}

impl ArrayAttribute {
    /// Puts the descriptor of every array attribute on the class (once, at import).
    pub(crate) fn install(class: &Bound<'_, PyType>) -> PyResult<()> {
        for (a, doc) in DOCS {
            class.setattr(KalmanFilter::name(a), Self { a, doc })?;
        }
        Ok(())
    }

    fn read_only(&self) -> PyErr {
        PyAttributeError::new_err(format!(
            "attribute '{}' of 'launch_estimation.KalmanFilter' objects is not writable",
            KalmanFilter::name(self.a)
        ))
    }
}

#[pymethods]
impl ArrayAttribute {
    fn __get__(
        slf: &Bound<'_, Self>,
        obj: Option<&Bound<'_, PyAny>>,
        _owner: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        match obj.filter(|o| !o.is_none()) {
            Some(o) => Ok(o
                .cast::<KalmanFilter>()?
                .try_borrow_mut()?
                .get(o.py(), slf.get().a)),
            None => Ok(slf.clone().into_any().unbind()),
        }
    }

    fn __set__(&self, obj: &Bound<'_, PyAny>, value: &Bound<'_, PyAny>) -> PyResult<()> {
        if !INPUTS.contains(&self.a) {
            return Err(self.read_only());
        }
        let kf = obj.cast::<KalmanFilter>()?;
        guard(|| kf.try_borrow_mut()?.assign(self.a, value))
    }

    fn __delete__(&self, _obj: &Bound<'_, PyAny>) -> PyResult<()> {
        Err(if INPUTS.contains(&self.a) {
            PyAttributeError::new_err("property has no deleter")
        } else {
            self.read_only()
        })
    }

    #[getter]
    fn __doc__(&self) -> &'static str {
        self.doc
    }

    #[getter]
    fn __name__(&self) -> &'static str {
        KalmanFilter::name(self.a)
    }

    fn __repr__(&self) -> String {
        format!(
            "<attribute '{}' of 'launch_estimation.KalmanFilter' objects>",
            KalmanFilter::name(self.a)
        )
    }
}

/// Reads a dimension argument: a non-negative int (a Python int, a NumPy integer scalar or a
/// 0-d integer array, as FilterPy takes them; not a bool); `positive` refuses 0.
pub(crate) fn dim(obj: &Bound<'_, PyAny>, name: &str, positive: bool) -> PyResult<usize> {
    let integer = obj.is_instance_of::<pyo3::types::PyInt>()
        || obj
            .cast::<PyUntypedArray>()
            .is_ok_and(|a| a.ndim() == 0 && matches!(a.dtype().kind(), b'i' | b'u'))
        || (type_name(obj).starts_with("int") || type_name(obj).starts_with("uint"))
            && obj.hasattr("__index__").unwrap_or(false);
    if obj.is_instance_of::<pyo3::types::PyBool>() || !integer {
        return Err(type_error(format!(
            "{name} must be an int, not {}",
            type_name(obj)
        )));
    }
    let v: i64 = obj
        .call_method0("__index__")
        .or_else(|_| obj.call_method0("item"))
        .and_then(|i| i.extract())
        .map_err(|_| value_error(format!("{name} is out of range")))?;
    if v < 0 || (positive && v == 0) || v > 10_000 {
        return Err(value_error(format!(
            "{name} = {v}; it must be {} and at most 10000",
            if positive { "≥ 1" } else { "≥ 0" }
        )));
    }
    Ok(v as usize)
}

impl KalmanFilter {
    /// A filter with FilterPy's defaults, from the constructor's arguments.
    pub(crate) fn build(
        dim_x: &Bound<'_, PyAny>,
        dim_z: &Bound<'_, PyAny>,
        dim_u: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let n = dim(dim_x, "dim_x", true)?;
        let m = dim(dim_z, "dim_z", true)?;
        let p = match dim_u {
            Some(u) => dim(u, "dim_u", false)?,
            None => 0,
        };
        Ok(Self {
            core: Core::new(n, m, p)?,
            dim_u: p,
            x_col: true,
            cache: Default::default(),
        })
    }

    pub(crate) fn shape(&self, a: A) -> (usize, usize) {
        let (n, m) = (self.core.n, self.core.m);
        match a {
            A::X | A::XPrior | A::XPost => (n, 1),
            A::P | A::F | A::Q | A::PPrior | A::PPost => (n, n),
            A::H => (m, n),
            A::R | A::S | A::SI => (m, m),
            A::B => (n, self.core.p),
            A::M | A::K => (n, m),
            A::Y | A::Z => (m, 1),
        }
    }

    pub(crate) fn buffer(&self, a: A) -> Option<&[f64]> {
        let c = &self.core;
        Some(match a {
            A::X => &c.x,
            A::P => &c.P,
            A::F => &c.F,
            A::Q => &c.Q,
            A::H => &c.H,
            A::R => &c.R,
            A::B => return c.B.as_deref(),
            A::M => &c.M,
            A::K => &c.K,
            A::Y => &c.y,
            A::S => &c.S,
            A::Z => &c.z,
            A::XPrior => &c.x_prior,
            A::PPrior => &c.P_prior,
            A::XPost => &c.x_post,
            A::PPost => &c.P_post,
            A::SI => return None,
        })
    }

    pub(crate) fn name(a: A) -> &'static str {
        match a {
            A::X => "x",
            A::P => "P",
            A::F => "F",
            A::Q => "Q",
            A::H => "H",
            A::R => "R",
            A::B => "B",
            A::M => "M",
            A::K => "K",
            A::Y => "y",
            A::S => "S",
            A::SI => "SI",
            A::Z => "z",
            A::XPrior => "x_prior",
            A::PPrior => "P_prior",
            A::XPost => "x_post",
            A::PPost => "P_post",
        }
    }

    /// The array for attribute `a`, made from the buffer on first read and then kept.
    pub(crate) fn get(&mut self, py: Python<'_>, a: A) -> Py<PyAny> {
        if let Some(obj) = &self.cache[a as usize] {
            return obj.clone_ref(py);
        }
        let (r, c) = self.shape(a);
        let obj: Bound<'_, PyAny> = match a {
            A::B if self.core.B.is_none() => py.None().into_bound(py),
            A::SI => matrix_out(py, &self.core.si(), r, c).into_any(),
            A::X | A::XPrior | A::XPost | A::Y | A::Z => {
                vector_out(py, self.buffer(a).unwrap_or(&[]), self.x_col)
            }
            _ => matrix_out(py, self.buffer(a).unwrap_or(&[]), r, c).into_any(),
        };
        let obj = obj.unbind();
        self.cache[a as usize] = Some(obj.clone_ref(py));
        obj
    }

    /// Drops the kept arrays of the quantities a call changed.
    pub(crate) fn invalidate(&mut self, which: &[A]) {
        for &a in which {
            self.cache[a as usize] = None;
        }
    }

    /// Checks and stores a new value of input `a` (the setter), keeping `value` itself as the
    /// attribute's array when it is a NumPy array of any real dtype (so later in-place edits
    /// are seen, as FilterPy sees them).
    pub(crate) fn assign(&mut self, a: A, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let (n, m) = (self.core.n, self.core.m);
        let name = Self::name(a);
        match a {
            A::X => {
                let mut x = vec![0.0; n];
                read_vector(value, name, n, false, false, &mut x)?;
                // A 0-d x, like a scalar, becomes a (1, 1) column at FilterPy's first predict.
                if let Ok(arr) = value.cast::<PyUntypedArray>() {
                    self.x_col = arr.ndim() != 1;
                }
                self.core.x = x;
            }
            A::B => {
                if value.is_none() {
                    self.core.B = None;
                    if self.dim_u == 0 {
                        self.core.p = 0;
                    }
                } else {
                    let arr = float_array(value, name)?;
                    let cols = match arr.shape() {
                        [r, c] if *r == n && (self.dim_u == 0 || *c == self.dim_u) => *c,
                        s => {
                            let want = if self.dim_u == 0 {
                                format!("({n}, p)")
                            } else {
                                format!("({n}, {})", self.dim_u)
                            };
                            return Err(value_error(format!(
                                "B has shape {}, expected {want}",
                                shape_str(s)
                            )));
                        }
                    };
                    let mut b = vec![0.0; n * cols];
                    read_matrix(value, name, n, cols, false, &mut b)?;
                    self.core.p = cols;
                    self.core.B = Some(b);
                }
            }
            _ => {
                let (r, c) = self.shape(a);
                let mut buf = vec![0.0; r * c];
                let square = r == c && a != A::M;
                read_matrix(value, name, r, c, square, &mut buf)?;
                if matches!(a, A::P | A::Q | A::R) {
                    check_covariance(name, &buf, r)?;
                }
                match a {
                    A::P => self.core.P = buf,
                    A::F => self.core.F = buf,
                    A::Q => self.core.Q = buf,
                    A::H => self.core.H = buf,
                    A::R => self.core.R = buf,
                    A::M => self.core.M = buf,
                    _ => unreachable!("assign is only called for inputs"),
                }
                let _ = m;
            }
        }
        self.cache[a as usize] = value
            .cast::<PyUntypedArray>()
            .is_ok_and(|v| v.ndim() > 0)
            .then(|| value.clone().unbind());
        Ok(())
    }

    /// Adopts in-place edits of the input arrays handed out (or set) since they last changed.
    pub(crate) fn sync(&mut self, py: Python<'_>) -> PyResult<()> {
        for a in INPUTS {
            let Some(obj) = self.cache[a as usize].as_ref().map(|o| o.clone_ref(py)) else {
                continue;
            };
            let obj = obj.bind(py);
            if obj.cast::<PyUntypedArray>().is_err() {
                continue; // B = None
            }
            // A float64 array is the array itself; another dtype is converted afresh.
            let arr = float_array(obj, Self::name(a))?;
            let changed = {
                let ro = arr
                    .try_readonly()
                    .map_err(|e| value_error(format!("{} cannot be read: {e}", Self::name(a))))?;
                let view = ro.as_array();
                let (r, c) = self.shape(a);
                let same_shape = view.len() == r * c;
                match self.buffer(a) {
                    Some(buf) if same_shape => view
                        .iter()
                        .zip(buf)
                        .any(|(v, b)| v.to_bits() != b.to_bits()),
                    _ => true,
                }
            };
            if changed {
                self.assign(a, obj)?;
            }
        }
        Ok(())
    }

    /// Reads an optional per-call override of a matrix (`None` → the filter's own).
    pub(crate) fn override_matrix(
        &self,
        obj: Option<&Bound<'_, PyAny>>,
        name: &str,
        r: usize,
        c: usize,
        psd: bool,
    ) -> PyResult<Option<Vec<f64>>> {
        match obj {
            Some(o) if !o.is_none() => {
                let mut buf = vec![0.0; r * c];
                read_matrix(o, name, r, c, r == c, &mut buf)?;
                if psd {
                    check_covariance(name, &buf, r)?;
                }
                Ok(Some(buf))
            }
            _ => Ok(None),
        }
    }

    /// Reads `predict`'s optional B (n×p, any p) with the number of controls p it implies
    /// (`None` → the filter's own B and p, or p = 0 without one).
    pub(crate) fn override_B(
        &self,
        B: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<(Option<Vec<f64>>, usize)> {
        let n = self.core.n;
        match B {
            Some(b) if !b.is_none() => {
                let arr = float_array(b, "B")?;
                let p = match arr.shape() {
                    [r, c] if *r == n => *c,
                    s => {
                        return Err(value_error(format!(
                            "B has shape {}, expected ({n}, p)",
                            shape_str(s)
                        )));
                    }
                };
                let mut buf = vec![0.0; n * p];
                read_matrix(b, "B", n, p, false, &mut buf)?;
                Ok((Some(buf), p))
            }
            _ => Ok((None, self.controls())),
        }
    }

    /// The number of controls p of the filter's own B (0 without one).
    pub(crate) fn controls(&self) -> usize {
        if self.core.B.is_some() {
            self.core.p
        } else {
            0
        }
    }

    /// Reads a control input u of length p (`None` → no control).
    pub(crate) fn read_u(
        &self,
        u: Option<&Bound<'_, PyAny>>,
        p: usize,
    ) -> PyResult<Option<Vec<f64>>> {
        match u {
            Some(u) if !u.is_none() => {
                if p == 0 {
                    // FilterPy ignores u when there is no B.
                    return Ok(None);
                }
                let mut buf = vec![0.0; p];
                if let Some(s) = scalar(u)
                    && p > 1
                    && s == 0.0
                {
                    return Ok(Some(buf)); // FilterPy's batch_filter passes u = 0
                }
                read_vector(u, "u", p, true, false, &mut buf)?;
                Ok(Some(buf))
            }
            _ => Ok(None),
        }
    }

    /// Reads a measurement (`None` → all missing).
    pub(crate) fn read_z(&self, z: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f64>> {
        let mut buf = vec![f64::NAN; self.core.m];
        if !z.is_none() {
            read_vector(z, name, self.core.m, true, true, &mut buf)?;
        }
        Ok(buf)
    }

    pub(crate) fn do_update(
        &mut self,
        py: Python<'_>,
        z: &Bound<'_, PyAny>,
        R: Option<&Bound<'_, PyAny>>,
        H: Option<&Bound<'_, PyAny>>,
        correlated: bool,
    ) -> PyResult<()> {
        self.sync(py)?;
        let (n, m) = (self.core.n, self.core.m);
        let zv = self.read_z(z, "z")?;
        let R = self.override_matrix(R, "R", m, m, true)?;
        let H = self.override_matrix(H, "H", m, n, false)?;
        self.core
            .update(&zv, R.as_deref(), H.as_deref(), correlated)
            .map_err(|UpdateError::SingularS| {
                value_error(
                    "S (the innovation covariance H P Hᵀ + R) is singular for this update; \
                     check R and P",
                )
            })?;
        self.invalidate(&UPDATED);
        Ok(())
    }
}
