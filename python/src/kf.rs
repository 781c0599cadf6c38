//! `launch_estimation.KalmanFilter`: FilterPy's `KalmanFilter` API over state kept in Rust.
//! The state and the attribute plumbing (the array attributes x, P, …, one descriptor each,
//! put on the class at import) are in `kf_attrs.rs`; copying, pickling, the `__dict__` view
//! and FilterPy's other conveniences in `kf_compat.rs`.
#![allow(non_snake_case)]

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::batch::PerStepArgs;
use crate::convert::{scalar, type_error, type_name, value_error};
use crate::guard;
pub(crate) use crate::kf_attrs::KalmanFilter;
use crate::kf_attrs::{PREDICTED, UPDATED};

#[pymethods]
impl KalmanFilter {
    /// update(z, R=None, H=None): FilterPy's update (Joseph form). `z = None` skips the
    /// update; NaN entries of z skip their rows; z may be a (dim_z, 1) column, a (dim_z,)
    /// vector, a (1, dim_z) row, a sequence, or a scalar (a 0-d array too) when dim_z = 1.
    #[pyo3(signature = (z, R = None, H = None))]
    fn update(
        &mut self,
        py: Python<'_>,
        z: &Bound<'_, PyAny>,
        R: Option<&Bound<'_, PyAny>>,
        H: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| self.do_update(py, z, R, H, false))
    }

    /// update_correlated(z, R=None, H=None): the update with M, the cross-covariance of
    /// the prior state error and the measurement noise.
    #[pyo3(signature = (z, R = None, H = None))]
    fn update_correlated(
        &mut self,
        py: Python<'_>,
        z: &Bound<'_, PyAny>,
        R: Option<&Bound<'_, PyAny>>,
        H: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| self.do_update(py, z, R, H, true))
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
        guard(|| Self::build(dim_x, dim_z, dim_u))
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
    /// update_first=False, saver=None) → (means, covariances, means_p, covariances_p), as
    /// FilterPy's: step k runs predict(u=us[k], B=Bs[k], F=Fs[k], Q=Qs[k]) and update(zs[k],
    /// R=Rs[k], H=Hs[k]) (the update first with update_first). Each of Fs, Qs, Hs, Rs, Bs is
    /// None (the filter's own at every step) or one matrix per step (a sequence or a 3-d
    /// array of len(zs)); a None item is the filter's own at that step. us acts only where
    /// there is a B; a None item of us is no control. A per-step list of another length, a
    /// step of another shape, a non-finite entry or a Q/R that is not symmetric PSD raises
    /// ValueError naming the argument and the step. Without a saver the whole series runs in
    /// one call into Rust; with one, FilterPy's loop runs step by step through predict and
    /// update and calls saver.save() after each step.
    #[pyo3(signature = (zs, Fs = None, Qs = None, Hs = None, Rs = None, Bs = None, us = None, update_first = false, saver = None))]
    fn batch_filter<'py>(
        slf: &Bound<'py, Self>,
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
            let py = slf.py();
            let per_step = PerStepArgs { Fs, Qs, Hs, Rs, Bs };
            if let Some(saver) = saver.filter(|s| !s.is_none()) {
                return crate::kf_compat::batch_with_saver(
                    slf,
                    zs,
                    per_step,
                    us,
                    update_first,
                    saver,
                );
            }
            let mut me = slf.try_borrow_mut()?;
            me.sync(py)?;
            let x_col = me.x_col;
            let out =
                crate::batch::batch_filter(&mut me.core, x_col, py, zs, per_step, us, update_first);
            me.invalidate(&PREDICTED);
            me.invalidate(&UPDATED);
            out
        })
    }

    /// update_sequential(start, z_i, R_i=None, H_i=None): FilterPy's update with the rows
    /// start, start + 1, … of the measurement only (R_i and H_i default to those rows of R
    /// and H; a scalar R_i is R_i·I).
    #[pyo3(signature = (start, z_i, R_i = None, H_i = None))]
    fn update_sequential(
        &mut self,
        py: Python<'_>,
        start: &Bound<'_, PyAny>,
        z_i: &Bound<'_, PyAny>,
        R_i: Option<&Bound<'_, PyAny>>,
        H_i: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| self.sequential(py, start, z_i, [R_i, H_i]))
    }

    /// test_matrix_dimensions(z=None, H=None, R=None, F=None, Q=None): FilterPy's shape
    /// assertions (AssertionError) on the filter's arrays or the ones given.
    #[pyo3(signature = (z = None, H = None, R = None, F = None, Q = None))]
    fn test_matrix_dimensions(
        &mut self,
        py: Python<'_>,
        z: Option<&Bound<'_, PyAny>>,
        H: Option<&Bound<'_, PyAny>>,
        R: Option<&Bound<'_, PyAny>>,
        F: Option<&Bound<'_, PyAny>>,
        Q: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| self.check_dimensions(py, [z, H, R, F, Q]))
    }

    /// A view of the attributes as a new dict (what FilterPy's Saver deep-copies).
    #[getter(__dict__)]
    fn dict_attr<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| self.dict_view(py))
    }

    /// An independent copy of the same class (the arrays are copied too).
    fn __copy__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| crate::kf_compat::copy_of(slf))
    }

    /// An independent copy of the same class.
    fn __deepcopy__<'py>(
        slf: &Bound<'py, Self>,
        _memo: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        guard(|| crate::kf_compat::copy_of(slf))
    }

    /// Pickle support: KalmanFilter(dim_x, dim_z, dim_u) then __setstate__(state).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let py = slf.py();
            let mut me = slf.try_borrow_mut()?;
            let args = (me.core.n, me.core.m, me.dim_u);
            let state = me.state(py)?;
            (slf.get_type(), args, state).into_pyobject(py)
        })
    }

    /// The pickled state (a dict).
    fn __getstate__<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| self.state(py))
    }

    /// Restores a pickled state.
    fn __setstate__(&mut self, state: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| self.restore(state))
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
