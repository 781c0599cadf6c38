//! `launch_estimation.KalmanFilter`: FilterPy's `KalmanFilter` API over state kept in Rust.
//!
//! Attributes are copied into preallocated buffers when set (and checked once, there);
//! reading one returns a NumPy array that is then kept, so reading it again returns the same
//! object (as in FilterPy) and an in-place edit of it (`kf.x[0] = 1.0`, `kf.P *= 10`) is
//! noticed — by comparing it with the buffer, a few dozen loads — before the next call
//! uses it. A call that changes a quantity drops the kept array, so arrays already handed out
//! stay snapshots (`xs.append(kf.x)` works as in FilterPy).
#![allow(non_snake_case)]

use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::batch::PerStepArgs;
use crate::convert::{
    check_psd, float_array, matrix_out, read_matrix, read_vector, scalar, shape_str, type_error,
    type_name, value_error, vector_out,
};
use crate::guard;
use crate::kf_core::{Core, UpdateError};

/// The attributes a `KalmanFilter` keeps a returned array for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum A {
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
const INPUTS: [A; 8] = [A::X, A::P, A::F, A::Q, A::H, A::R, A::B, A::M];
const N_ATTR: usize = 17;
/// The attributes a prediction changes.
const PREDICTED: [A; 4] = [A::X, A::P, A::XPrior, A::PPrior];
/// The attributes an update changes.
const UPDATED: [A; 9] = [
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
#[pyclass(module = "launch_estimation")]
#[derive(Debug)]
pub struct KalmanFilter {
    core: Core,
    dim_u: usize,
    /// Whether x is a (n, 1) column (FilterPy's default) rather than a (n,) vector.
    x_col: bool,
    cache: [Option<Py<PyAny>>; N_ATTR],
}

/// Reads a dimension argument (a non-negative int; `positive` refuses 0).
fn dim(obj: &Bound<'_, PyAny>, name: &str, positive: bool) -> PyResult<usize> {
    if obj.is_instance_of::<pyo3::types::PyBool>() || !obj.is_instance_of::<pyo3::types::PyInt>() {
        return Err(type_error(format!(
            "{name} must be an int, not {}",
            type_name(obj)
        )));
    }
    let v: i64 = obj
        .extract()
        .map_err(|_| value_error(format!("{name} is out of range")))?;
    if v < 0 || (positive && v == 0) || v > 10_000 {
        return Err(value_error(format!(
            "{name} = {v}; it must be {} and at most 10000",
            if positive { "≥ 1" } else { "≥ 0" }
        )));
    }
    Ok(v as usize)
}

/// Refuses the FilterPy arguments a whole-series method does not support: a `TypeError`
/// "`method`: `name` is not supported; `instead`" for the first one given (not None).
fn unsupported<const N: usize>(
    method: &str,
    args: [(&str, Option<&Bound<'_, PyAny>>); N],
    instead: &str,
) -> PyResult<()> {
    match args.iter().find(|(_, v)| v.is_some_and(|v| !v.is_none())) {
        Some((name, _)) => Err(type_error(format!(
            "{method}: {name} is not supported; {instead}"
        ))),
        None => Ok(()),
    }
}

impl KalmanFilter {
    fn shape(&self, a: A) -> (usize, usize) {
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

    fn buffer(&self, a: A) -> Option<&[f64]> {
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

    fn name(a: A) -> &'static str {
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
    fn get(&mut self, py: Python<'_>, a: A) -> Py<PyAny> {
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
    fn invalidate(&mut self, which: &[A]) {
        for &a in which {
            self.cache[a as usize] = None;
        }
    }

    /// Checks and stores a new value of input `a` (the setter), keeping `value` itself as the
    /// attribute's array when it is a float64 array (so later in-place edits are seen).
    fn assign(&mut self, a: A, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let (n, m) = (self.core.n, self.core.m);
        let name = Self::name(a);
        match a {
            A::X => {
                let mut x = vec![0.0; n];
                read_vector(value, name, n, false, false, &mut x)?;
                if let Ok(arr) = value.cast::<PyArrayDyn<f64>>() {
                    self.x_col = arr.ndim() == 2;
                } else if float_array(value, name).is_ok_and(|arr| arr.ndim() == 1) {
                    self.x_col = false;
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
                    check_psd(name, &buf, r)?;
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
            .cast::<PyArrayDyn<f64>>()
            .ok()
            .map(|v| v.clone().into_any().unbind());
        Ok(())
    }

    /// Adopts in-place edits of the input arrays handed out (or set) since they last changed.
    fn sync(&mut self, py: Python<'_>) -> PyResult<()> {
        for a in INPUTS {
            let Some(obj) = self.cache[a as usize].as_ref().map(|o| o.clone_ref(py)) else {
                continue;
            };
            let obj = obj.bind(py);
            let Ok(arr) = obj.cast::<PyArrayDyn<f64>>() else {
                continue; // B = None
            };
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
    fn override_matrix(
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
                    check_psd(name, &buf, r)?;
                }
                Ok(Some(buf))
            }
            _ => Ok(None),
        }
    }

    /// Reads `predict`'s optional B (n×p, any p) with the number of controls p it implies
    /// (`None` → the filter's own B and p, or p = 0 without one).
    fn override_B(&self, B: Option<&Bound<'_, PyAny>>) -> PyResult<(Option<Vec<f64>>, usize)> {
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
            _ => Ok((
                None,
                if self.core.B.is_some() {
                    self.core.p
                } else {
                    0
                },
            )),
        }
    }

    /// Reads a control input u of length p (`None` → no control).
    fn read_u(&self, u: Option<&Bound<'_, PyAny>>, p: usize) -> PyResult<Option<Vec<f64>>> {
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
    fn read_z(&self, z: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f64>> {
        let mut buf = vec![f64::NAN; self.core.m];
        if !z.is_none() {
            read_vector(z, name, self.core.m, true, true, &mut buf)?;
        }
        Ok(buf)
    }

    fn do_update(
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

/// Writes `KalmanFilter`'s `#[pymethods]` block (PyO3 takes one, and does not expand macros
/// inside it) from two tables and the other methods: a getter for each array attribute, and a
/// setter for those that name one (the inputs), both through [`KalmanFilter::get`] and
/// [`KalmanFilter::assign`] with the attribute's [`A`]; the two updates, `(z, R=None,
/// H=None)` each, through [`KalmanFilter::do_update`] (`true`: correlated); then the methods
/// that follow the tables.
macro_rules! pymethods_with_attributes {
    (
        attributes {
            $($(#[doc = $doc:literal])+ $get:ident $(/ $set:ident)? = $a:ident;)+
        }
        updates {
            $($(#[doc = $udoc:literal])+ $update:ident = $correlated:literal;)+
        }
        $($methods:tt)*
    ) => {
        #[pymethods]
        impl KalmanFilter {
            $(
                $(#[doc = $doc])+
                #[getter]
                fn $get(&mut self, py: Python<'_>) -> PyResult<Py<PyAny>> {
                    guard(|| Ok(self.get(py, A::$a)))
                }
                $(
                    #[setter]
                    fn $set(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
                        guard(|| self.assign(A::$a, value))
                    }
                )?
            )+
            $(
                $(#[doc = $udoc])+
                #[pyo3(signature = (z, R = None, H = None))]
                fn $update(
                    &mut self,
                    py: Python<'_>,
                    z: &Bound<'_, PyAny>,
                    R: Option<&Bound<'_, PyAny>>,
                    H: Option<&Bound<'_, PyAny>>,
                ) -> PyResult<()> {
                    guard(|| self.do_update(py, z, R, H, $correlated))
                }
            )+
            $($methods)*
        }
    };
}

pymethods_with_attributes! {
    attributes {
        /// State estimate, (dim_x, 1) (or (dim_x,) if set so).
        x / set_x = X;
        /// State covariance, (dim_x, dim_x); symmetric PSD.
        P / set_P = P;
        /// State transition F, (dim_x, dim_x).
        F / set_F = F;
        /// Process noise covariance Q, (dim_x, dim_x); symmetric PSD.
        Q / set_Q = Q;
        /// Measurement matrix H, (dim_z, dim_x).
        H / set_H = H;
        /// Measurement noise covariance R, (dim_z, dim_z); symmetric PSD.
        R / set_R = R;
        /// Control matrix B, (dim_x, dim_u), or None.
        B / set_B = B;
        /// Cross-covariance of the prior state error and the measurement noise, (dim_x, dim_z);
        /// used by `update_correlated` only.
        M / set_M = M;
        /// Kalman gain of the last update, (dim_x, dim_z).
        K = K;
        /// Innovation (residual) of the last update, (dim_z, 1).
        y = Y;
        /// Innovation covariance of the last update, (dim_z, dim_z).
        S = S;
        /// Inverse of S (computed from its factorisation when read).
        SI = SI;
        /// Last measurement, (dim_z, 1); NaN where missing (FilterPy stores None).
        z = Z;
        /// Prior (predicted) state after the last predict.
        x_prior = XPrior;
        /// Prior covariance after the last predict.
        P_prior = PPrior;
        /// Posterior state after the last update.
        x_post = XPost;
        /// Posterior covariance after the last update.
        P_post = PPost;
    }
    updates {
        /// update(z, R=None, H=None): FilterPy's update (Joseph form). `z = None` skips the
        /// update; NaN entries of z skip their rows.
        update = false;
        /// update_correlated(z, R=None, H=None): the update with M, the cross-covariance of
        /// the prior state error and the measurement noise.
        update_correlated = true;
    }

    /// KalmanFilter(dim_x, dim_z, dim_u=0): FilterPy's defaults (x = 0, P = F = Q = I,
    /// H = 0, R = I, B = None, M = 0).
    #[new]
    #[pyo3(signature = (dim_x, dim_z, dim_u = None))]
    fn new(
        dim_x: &Bound<'_, PyAny>,
        dim_z: &Bound<'_, PyAny>,
        dim_u: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guard(|| {
            let n = dim(dim_x, "dim_x", true)?;
            let m = dim(dim_z, "dim_z", true)?;
            let p = match dim_u {
                Some(u) => dim(u, "dim_u", false)?,
                None => 0,
            };
            Ok(Self {
                core: Core::new(n, m, p),
                dim_u: p,
                x_col: true,
                cache: Default::default(),
            })
        })
    }

    /// Number of states n.
    #[getter]
    fn dim_x(&self) -> usize {
        self.core.n
    }
    /// Number of measurements m.
    #[getter]
    fn dim_z(&self) -> usize {
        self.core.m
    }
    /// Number of control inputs p.
    #[getter]
    fn dim_u(&self) -> usize {
        self.dim_u
    }

    /// Fading-memory factor α ≥ 1 (P ← α² F P Fᵀ + Q).
    #[getter]
    fn get_alpha(&self) -> f64 {
        self.core.alpha_sq.sqrt()
    }
    #[setter]
    fn set_alpha(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
        match scalar(value) {
            Some(a) if a.is_finite() && a >= 1.0 => {
                self.core.alpha_sq = a * a;
                Ok(())
            }
            Some(a) => Err(value_error(format!(
                "alpha = {a}; it must be a finite float ≥ 1"
            ))),
            None => Err(type_error(format!(
                "alpha must be a float, not {}",
                type_name(value)
            ))),
        }
    }

    /// log N(y; 0, S) of the last update (over its present rows).
    #[getter]
    fn log_likelihood(&self) -> f64 {
        self.core
            .log_likelihood()
            .unwrap_or_else(|| f64::MIN_POSITIVE.ln())
    }
    /// exp(log_likelihood), never below the smallest positive normal float (FilterPy).
    #[getter]
    fn likelihood(&self) -> f64 {
        let l = self.log_likelihood().exp();
        if l > 0.0 { l } else { f64::MIN_POSITIVE }
    }
    /// sqrt(yᵀ S⁻¹ y) of the last update.
    #[getter]
    fn mahalanobis(&self) -> f64 {
        self.core.mahalanobis().unwrap_or(0.0)
    }

    /// predict(u=None, B=None, F=None, Q=None): x ← F x + B u, P ← α² F P Fᵀ + Q.
    #[pyo3(signature = (u = None, B = None, F = None, Q = None))]
    fn predict(
        &mut self,
        py: Python<'_>,
        u: Option<&Bound<'_, PyAny>>,
        B: Option<&Bound<'_, PyAny>>,
        F: Option<&Bound<'_, PyAny>>,
        Q: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            self.sync(py)?;
            let n = self.core.n;
            let F = self.override_matrix(F, "F", n, n, false)?;
            let Q = self.override_matrix(Q, "Q", n, n, true)?;
            let (B, p) = self.override_B(B)?;
            let u = self.read_u(u, p)?;
            self.core
                .predict(u.as_deref(), F.as_deref(), Q.as_deref(), B.as_deref());
            self.invalidate(&PREDICTED);
            Ok(())
        })
    }

    /// batch_filter(zs, Fs=None, Qs=None, Hs=None, Rs=None, Bs=None, us=None,
    /// update_first=False, saver=None) → (means, covariances, means_p, covariances_p), in one
    /// call into Rust, as FilterPy's: step k runs predict(u=us[k], B=Bs[k], F=Fs[k],
    /// Q=Qs[k]) and update(zs[k], R=Rs[k], H=Hs[k]) (the update first with update_first).
    /// Each of Fs, Qs, Hs, Rs, Bs is None (the filter's own at every step) or one matrix per
    /// step (a sequence or a 3-d array of len(zs)); a None item is the filter's own at that
    /// step. us acts only where there is a B; a None item of us is no control. A per-step
    /// list of another length, a step of another shape, a non-finite entry or a Q/R that is
    /// not symmetric PSD raises ValueError naming the argument and the step. saver is not
    /// supported (TypeError).
    #[pyo3(signature = (zs, Fs = None, Qs = None, Hs = None, Rs = None, Bs = None, us = None, update_first = false, saver = None))]
    fn batch_filter<'py>(
        &mut self,
        py: Python<'py>,
        zs: &Bound<'py, PyAny>,
        Fs: Option<&Bound<'py, PyAny>>,
        Qs: Option<&Bound<'py, PyAny>>,
        Hs: Option<&Bound<'py, PyAny>>,
        Rs: Option<&Bound<'py, PyAny>>,
        Bs: Option<&Bound<'py, PyAny>>,
        us: Option<&Bound<'py, PyAny>>,
        update_first: bool,
        saver: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            unsupported(
                "batch_filter",
                [("saver", saver)],
                "call predict/update in a loop and save after each step",
            )?;
            self.sync(py)?;
            let per_step = PerStepArgs { Fs, Qs, Hs, Rs, Bs };
            let out = crate::batch::batch_filter(
                &mut self.core,
                self.x_col,
                py,
                zs,
                per_step,
                us,
                update_first,
            );
            self.invalidate(&PREDICTED);
            self.invalidate(&UPDATED);
            out
        })
    }

    /// rts_smoother(Xs, Ps, Fs=None, Qs=None, inv=numpy.linalg.inv) → (x, P, K, Pp): the RTS
    /// smoother over batch_filter's output, as FilterPy's: the step from k to k + 1 uses
    /// Fs[k + 1] and Qs[k + 1] (Fs[0] and Qs[0] are not used), each None for the filter's
    /// own F and Q. K[k] = P[k] Fᵀ Pp[k]⁻¹ is solved rather than formed with inv: only
    /// numpy.linalg.inv (the default) is accepted, another inv raises TypeError.
    #[pyo3(signature = (Xs, Ps, Fs = None, Qs = None, inv = None))]
    fn rts_smoother<'py>(
        &mut self,
        py: Python<'py>,
        Xs: &Bound<'py, PyAny>,
        Ps: &Bound<'py, PyAny>,
        Fs: Option<&Bound<'py, PyAny>>,
        Qs: Option<&Bound<'py, PyAny>>,
        inv: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            if let Some(inv) = inv.filter(|i| !i.is_none()) {
                let numpy_inv = py.import("numpy.linalg")?.getattr("inv")?;
                if !inv.is(&numpy_inv) {
                    return Err(type_error(format!(
                        "rts_smoother: inv = {} is not supported; the gain is solved with a \
                         factorisation of Pp[k] (numpy.linalg.inv's result up to rounding)",
                        inv.getattr("__name__")
                            .and_then(|n| n.str())
                            .map_or_else(|_| type_name(inv), |n| n.to_string())
                    )));
                }
            }
            self.sync(py)?;
            crate::batch::rts_smoother(&self.core, py, Xs, Ps, Fs, Qs)
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "KalmanFilter(dim_x={}, dim_z={}, dim_u={}, x={:?})",
            self.core.n, self.core.m, self.dim_u, self.core.x
        )
    }
}
