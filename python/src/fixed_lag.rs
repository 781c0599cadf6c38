//! `launch_estimation.FixedLagSmoother`: FilterPy's `FixedLagSmoother` API, its attributes in
//! the instance `__dict__` as FilterPy keeps them (assignment and in-place edits act on the
//! next call). Each step is FilterPy's predict and Joseph-form update (`kf_core::Core`, the
//! `KalmanFilter`'s arithmetic); the smoothed window is `kalman::nonlinear::FixedLag`'s
//! Rauch–Tung–Striebel pass, so after step k the entries k − N … k of `xSmooth` are the
//! smoothed estimates x_{j|k}, and at a lag of at least the number of steps the output is
//! the fixed-interval RTS smoother's. The filter's quantities (x, P, y, S, `xhat`) are
//! FilterPy's, and K is the last gain (FilterPy leaves K at its default). FilterPy's
//! smoothed numbers are not reproduced: its lag 0 returns the predictions, a lag of at least
//! the number of steps returns the filter, and between them its gains come from the updated
//! covariance, so they are not the smoothed estimates.
#![allow(non_snake_case)]

use kalman::nonlinear::{FixedLag, ForwardPass};
use numpy::{PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat, PyList, PyTuple};

use crate::convert::{
    array3_out, entries, matrix_out, memory_error, read_matrix, read_vector, rows_2d, scalar,
    type_error, type_name, value_error, vector_out, zeros,
};
use crate::guard;
use crate::kf_attrs::dim;
use crate::kf_core::Core;
use crate::series::{Gaps, read_series_with};

/// FilterPy's `FixedLagSmoother(dim_x, dim_z, N=None)`.
#[pyclass(module = "launch_estimation", dict, subclass)]
#[derive(Debug)]
pub struct FixedLagSmoother {
    n: usize,
    m: usize,
    /// The filter and the smoother of the steps so far (None before the first `smooth`).
    run: Option<Run>,
}

/// The streaming state between calls: the filter's arithmetic and the steps recorded.
#[derive(Debug, Clone)]
struct Run {
    core: Core,
    lag: FixedLag,
}

/// One step of the forward pass as `FixedLag` records it (n×n blocks column-major).
struct Record {
    xf: Vec<f64>,
    pf: Vec<f64>,
    xp: Vec<f64>,
    pp: Vec<f64>,
    ct: Vec<f64>,
}

impl ForwardPass for Record {
    fn filtered(&self) -> (&[f64], &[f64]) {
        (&self.xf, &self.pf)
    }
    fn predicted(&self) -> (&[f64], &[f64]) {
        (&self.xp, &self.pp)
    }
    fn cross_covariance(&self, out: &mut [f64]) {
        out.copy_from_slice(&self.ct);
    }
}

/// The model, read from the attributes (row-major, shapes checked).
struct Model {
    x: Vec<f64>,
    P: Vec<f64>,
    F: Vec<f64>,
    H: Vec<f64>,
    Q: Vec<f64>,
    R: Vec<f64>,
    /// n×p, or None when B is a scalar (B u = b u, u of length n) kept as (b, None).
    B: (f64, Option<(usize, Vec<f64>)>),
    /// Whether x is a 2-d column (the outputs follow its shape, as FilterPy's do).
    column: bool,
}

impl Model {
    /// The number of control inputs u takes.
    fn controls(&self, n: usize) -> usize {
        self.B.1.as_ref().map_or(n, |(p, _)| *p)
    }

    /// B as the n×p matrix the core multiplies by.
    fn b_matrix(&self, n: usize) -> Vec<f64> {
        match &self.B {
            (_, Some((_, b))) => b.clone(),
            (b, None) => {
                let mut e = vec![0.0; n * n];
                (0..n).for_each(|i| e[i * n + i] = *b);
                e
            }
        }
    }

    /// A core holding this model, x and P.
    fn core(&self, n: usize, m: usize) -> PyResult<Core> {
        let mut core = Core::new(n, m, 0)?;
        self.load(&mut core, n);
        Ok(core)
    }

    fn load(&self, core: &mut Core, n: usize) {
        core.x.copy_from_slice(&self.x);
        core.P.copy_from_slice(&self.P);
        core.F.copy_from_slice(&self.F);
        core.H.copy_from_slice(&self.H);
        core.Q.copy_from_slice(&self.Q);
        core.R.copy_from_slice(&self.R);
        core.B = Some(self.b_matrix(n));
    }
}

/// The transpose of the n×n row-major `a` (the column-major layout `FixedLag` reads).
fn col_major(a: &[f64], n: usize) -> Vec<f64> {
    (0..n * n).map(|i| a[(i % n) * n + i / n]).collect()
}

/// One step: FilterPy's predict from `core.x`, `core.P` (x_{k−1|k−1}, P_{k−1|k−1}) and its
/// update with z. Step k − 1, whose prediction is now known, goes into `lag` when k > 0; the
/// record of step k is returned, its prediction a placeholder the backward pass does not
/// read while the step is the newest.
fn step(
    core: &mut Core,
    lag: &mut FixedLag,
    k: usize,
    z: &[f64],
    u: Option<&[f64]>,
) -> Result<Record, String> {
    let n = core.n;
    let (x0, P0) = (core.x.clone(), core.P.clone());
    core.predict(u, None, None, None);
    if k > 0 {
        // C_{k−1} = P_{k−1|k−1} Fᵀ.
        let mut ct = vec![0.0; n * n];
        for c in 0..n {
            for r in 0..n {
                ct[r + c * n] = (0..n).map(|i| P0[r * n + i] * core.F[c * n + i]).sum();
            }
        }
        let rec = Record {
            xf: x0,
            pf: col_major(&P0, n),
            xp: core.x.clone(),
            pp: col_major(&core.P, n),
            ct,
        };
        lag.record(&rec).map_err(|e| format!("step {k}: {e}"))?;
    }
    core.update(z, None, None, false)
        .map_err(|_| format!("step {k}: S = H P Hᵀ + R is singular"))?;
    Ok(Record {
        xf: core.x.clone(),
        pf: col_major(&core.P, n),
        xp: core.x.clone(),
        pp: col_major(&core.P, n),
        ct: vec![0.0; n * n],
    })
}

/// A fixed-lag smoother of lag `lag` for n states, its buffers checked against memory first.
fn fixed_lag(n: usize, lag: usize) -> PyResult<FixedLag> {
    let what = "the fixed-lag smoother's window";
    let len = entries(
        lag.saturating_add(1),
        entries(7, entries(n, n, what)?, what)?,
        what,
    )?;
    Vec::<f64>::new()
        .try_reserve_exact(len)
        .map_err(|_| memory_error(len, what))?;
    FixedLag::new(n, lag).map_err(|e| value_error(e.to_string()))
}

/// The lag N: a non-negative int (a float, even a whole one, is refused as FilterPy's
/// `range(N)` refuses it).
fn lag_arg(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    if obj.is_instance_of::<PyFloat>() || type_name(obj).starts_with("float") {
        return Err(value_error(format!(
            "N = {}; the lag must be a non-negative int",
            obj.repr().map(|r| r.to_string()).unwrap_or_default()
        )));
    }
    dim(obj, "N", false)
}

impl FixedLagSmoother {
    /// The attribute `name` of the instance.
    fn attr<'py>(slf: &Bound<'py, Self>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        slf.as_any().getattr(name)
    }

    /// Reads x, P, F, H, Q, R and B from the attributes, checking their shapes.
    fn model(slf: &Bound<'_, Self>) -> PyResult<Model> {
        let (n, m) = {
            let s = slf.borrow();
            (s.n, s.m)
        };
        let read = |name: &str, r: usize, c: usize| -> PyResult<Vec<f64>> {
            let mut out = zeros(entries(r, c, name)?, name)?;
            read_matrix(&Self::attr(slf, name)?, name, r, c, r == c, &mut out)?;
            Ok(out)
        };
        let xo = Self::attr(slf, "x")?;
        let mut x = zeros(n, "x")?;
        read_vector(&xo, "x", n, false, false, &mut x)?;
        let column = xo.cast::<PyUntypedArray>().is_ok_and(|a| a.ndim() == 2);
        let bo = Self::attr(slf, "B")?;
        let B = match scalar(&bo) {
            Some(b) if b.is_finite() => (b, None),
            Some(b) => return Err(value_error(format!("B is {b}; it must be finite"))),
            None if bo.is_none() => (0.0, None),
            None => {
                let (r, c, buf) = rows_2d(&bo, "B")?;
                if r != n {
                    return Err(value_error(format!(
                        "B has shape ({r}, {c}), expected ({n}, dim_u) or a scalar"
                    )));
                }
                (0.0, Some((c, buf)))
            }
        };
        Ok(Model {
            x,
            P: read("P", n, n)?,
            F: read("F", n, n)?,
            H: read("H", m, n)?,
            Q: read("Q", n, n)?,
            R: read("R", m, m)?,
            B,
            column,
        })
    }
}

#[pymethods]
impl FixedLagSmoother {
    #[new]
    #[pyo3(signature = (*_args, **_kwargs))]
    fn new(_args: &Bound<'_, PyTuple>, _kwargs: Option<&Bound<'_, PyDict>>) -> Self {
        Self {
            n: 0,
            m: 0,
            run: None,
        }
    }

    /// FixedLagSmoother(dim_x, dim_z, N=None): FilterPy's defaults (x = x_s = 0, P = Q = F =
    /// I, H = eye(dim_z, dim_x), R = I, K = 0, y = 0, S = 0, B = 0., xSmooth = []).
    #[pyo3(signature = (dim_x, dim_z, N = None))]
    fn __init__(
        slf: &Bound<'_, Self>,
        dim_x: &Bound<'_, PyAny>,
        dim_z: &Bound<'_, PyAny>,
        N: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let py = slf.py();
            let (n, m) = (dim(dim_x, "dim_x", true)?, dim(dim_z, "dim_z", true)?);
            let N = N.filter(|v| !v.is_none()).map(lag_arg).transpose()?;
            let what = "the FixedLagSmoother's defaults";
            let eye = |r: usize, c: usize, one: f64| -> PyResult<Bound<'_, PyAny>> {
                let mut e = zeros(entries(r, c, what)?, what)?;
                (0..r.min(c)).for_each(|i| e[i * c + i] = one);
                Ok(matrix_out(py, &e, r, c).into_any())
            };
            let o = slf.as_any();
            o.setattr("dim_x", n)?;
            o.setattr("dim_z", m)?;
            o.setattr("N", N)?;
            o.setattr("x", eye(n, 1, 0.0)?)?;
            o.setattr("x_s", eye(n, 1, 0.0)?)?;
            o.setattr("P", eye(n, n, 1.0)?)?;
            o.setattr("Q", eye(n, n, 1.0)?)?;
            o.setattr("F", eye(n, n, 1.0)?)?;
            o.setattr("H", eye(m, n, 1.0)?)?;
            o.setattr("R", eye(m, m, 1.0)?)?;
            o.setattr("K", eye(n, 1, 0.0)?)?;
            o.setattr("y", eye(m, 1, 0.0)?)?;
            o.setattr("B", 0.0)?;
            o.setattr("S", eye(m, m, 0.0)?)?;
            o.setattr("count", 0)?;
            o.setattr("xSmooth", PyList::empty(py))?;
            *slf.borrow_mut() = Self { n, m, run: None };
            Ok(())
        })
    }

    /// smooth(z, u=None): one step of the filter (predict, then the Joseph-form update with
    /// z; B u added when u is given) and of the smoother: `xSmooth` gains the step, and its
    /// last N + 1 entries become the smoothed estimates given the data so far. x, P, K, y, S
    /// are the filter's; x_s is the fixed-lag estimate of step count − N (the oldest of the
    /// window before N steps). Nothing changes when it fails.
    #[pyo3(signature = (z, u = None))]
    fn smooth(
        slf: &Bound<'_, Self>,
        z: &Bound<'_, PyAny>,
        u: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let py = slf.py();
            let (n, m) = {
                let s = slf.borrow();
                (s.n, s.m)
            };
            let N = Self::attr(slf, "N")?;
            if N.is_none() {
                return Err(value_error(
                    "N is None; smooth() needs the lag N (FixedLagSmoother(dim_x, dim_z, N))",
                ));
            }
            let N = lag_arg(&N)?;
            let model = Self::model(slf)?;
            let mut zv = zeros(m, "z")?;
            read_vector(z, "z", m, true, false, &mut zv)?;
            let uv = match u.filter(|u| !u.is_none()) {
                Some(u) => {
                    let mut v = zeros(model.controls(n), "u")?;
                    read_vector(u, "u", v.len(), true, false, &mut v)?;
                    Some(v)
                }
                None => None,
            };
            let count: usize = Self::attr(slf, "count")?
                .extract()
                .map_err(|_| type_error("count must be a non-negative int"))?;
            let list = Self::attr(slf, "xSmooth")?;
            let list = list.cast::<PyList>().map_err(|_| {
                type_error(format!("xSmooth must be a list, not {}", type_name(&list)))
            })?;
            if list.len() != count {
                return Err(value_error(format!(
                    "xSmooth has {} entries but count is {count}; they must agree",
                    list.len()
                )));
            }
            let mut run = if count == 0 {
                Run {
                    core: model.core(n, m)?,
                    lag: fixed_lag(n, N)?,
                }
            } else {
                match &slf.borrow().run {
                    Some(run) if run.lag.steps() + 1 == count => {
                        if run.lag.lag() != N {
                            return Err(value_error(format!(
                                "N = {N} but the smoother began with N = {}; a new lag needs \
                                 a new FixedLagSmoother",
                                run.lag.lag()
                            )));
                        }
                        run.clone()
                    }
                    _ => {
                        return Err(value_error(format!(
                            "count = {count} does not match the steps this smoother has taken"
                        )));
                    }
                }
            };
            model.load(&mut run.core, n);
            let rec = step(&mut run.core, &mut run.lag, count, &zv, uv.as_deref())
                .map_err(value_error)?;
            let mut window = run.lag.clone();
            window
                .record(&rec)
                .map_err(|e| value_error(e.to_string()))?;
            let c = &run.core;
            list.append(vector_out(py, &c.x, model.column))?;
            for back in 0..window.window() {
                if let Some((j, x, _)) = window.smoothed(back) {
                    list.set_item(j, vector_out(py, x, model.column))?;
                }
            }
            if let Some((_, x, _)) = window.smoothed(window.window() - 1) {
                slf.as_any()
                    .setattr("x_s", vector_out(py, x, model.column))?;
            }
            slf.as_any()
                .setattr("x", vector_out(py, &c.x, model.column))?;
            slf.as_any().setattr("P", matrix_out(py, &c.P, n, n))?;
            slf.as_any().setattr("K", matrix_out(py, &c.K, n, m))?;
            slf.as_any()
                .setattr("y", vector_out(py, &c.y, model.column))?;
            slf.as_any().setattr("S", matrix_out(py, &c.S, m, m))?;
            slf.as_any().setattr("count", count + 1)?;
            slf.borrow_mut().run = Some(run);
            Ok(())
        })
    }

    /// Copy and pickle support: the class rebuilt without `__init__`, then
    /// `__setstate__((dict, window))`, the window being the smoother's steps so far (None
    /// before the first `smooth`). A shallow copy shares the attribute arrays, as FilterPy's
    /// does; the window is always copied.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let py = slf.py();
            let newobj = py.import("copyreg")?.getattr("__newobj__")?;
            let d = slf.as_any().getattr("__dict__")?.cast_into::<PyDict>()?;
            let window = match &slf.borrow().run {
                None => py.None().into_bound(py),
                Some(run) => {
                    let st = run.lag.state();
                    let w = PyDict::new(py);
                    w.set_item("n", st.n)?;
                    w.set_item("lag", st.lag)?;
                    w.set_item("steps", st.steps)?;
                    for (k, v) in [
                        ("xf", &st.xf),
                        ("pf", &st.pf),
                        ("xp", &st.xp),
                        ("pp", &st.pp),
                        ("ct", &st.ct),
                        ("xs", &st.xs),
                        ("ps", &st.ps),
                    ] {
                        w.set_item(k, v)?;
                    }
                    w.into_any()
                }
            };
            let state = (d.copy()?, window).into_pyobject(py)?;
            (newobj, (slf.get_type(),), state).into_pyobject(py)
        })
    }

    /// Restores what `__reduce__` saved: `(dict, window)`.
    fn __setstate__(slf: &Bound<'_, Self>, state: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            let bad = || type_error("FixedLagSmoother state must be (dict, window or None)");
            let t = state.cast::<PyTuple>().map_err(|_| bad())?;
            if t.len() != 2 {
                return Err(bad());
            }
            let d = t.get_item(0)?;
            let d = d.cast::<PyDict>().map_err(|_| bad())?;
            let get = |k: &str| -> PyResult<Bound<'_, PyAny>> {
                d.get_item(k)?
                    .ok_or_else(|| value_error(format!("FixedLagSmoother state has no {k}")))
            };
            let (n, m) = (
                dim(&get("dim_x")?, "dim_x", true)?,
                dim(&get("dim_z")?, "dim_z", true)?,
            );
            let window = t.get_item(1)?;
            let run = if window.is_none() {
                None
            } else {
                let w = window.cast::<PyDict>().map_err(|_| bad())?;
                let item = |k: &str| -> PyResult<Bound<'_, PyAny>> {
                    w.get_item(k)?.ok_or_else(|| {
                        value_error(format!("FixedLagSmoother state: the window has no {k}"))
                    })
                };
                let list = |k: &str| -> PyResult<Vec<f64>> {
                    item(k)?.extract().map_err(|_| {
                        type_error(format!("FixedLagSmoother state: window {k} must be floats"))
                    })
                };
                let count = |k: &str| -> PyResult<usize> {
                    item(k)?.extract().map_err(|_| {
                        type_error(format!("FixedLagSmoother state: window {k} must be an int"))
                    })
                };
                let states = count("n")?;
                let st = kalman::nonlinear::FixedLagState {
                    n: states,
                    stored: states,
                    lag: count("lag")?,
                    steps: count("steps")?,
                    xf: list("xf")?,
                    pf: list("pf")?,
                    xp: list("xp")?,
                    pp: list("pp")?,
                    ct: list("ct")?,
                    xs: list("xs")?,
                    ps: list("ps")?,
                };
                if st.n != n {
                    return Err(value_error(format!(
                        "FixedLagSmoother state: the window has {} states but dim_x is {n}",
                        st.n
                    )));
                }
                let lag = FixedLag::from_state(st)
                    .map_err(|e| value_error(format!("FixedLagSmoother state: {e}")))?;
                Some(Run {
                    core: Core::new(n, m, 0)?,
                    lag,
                })
            };
            let own = slf.as_any().getattr("__dict__")?;
            own.call_method1("update", (d,))?;
            *slf.borrow_mut() = Self { n, m, run };
            Ok(())
        })
    }

    /// smooth_batch(zs, N, us=None) -> (xhat_smooth, xhat): the lag-N smoothed estimates
    /// x_{k|min(k+N, last)} and the filter's x_{k|k} over zs, from the attributes, which are
    /// left unchanged; (steps, dim_x, 1) arrays when x is a column, else (steps, dim_x).
    #[pyo3(signature = (zs, N, us = None))]
    fn smooth_batch<'py>(
        slf: &Bound<'py, Self>,
        zs: &Bound<'py, PyAny>,
        N: &Bound<'py, PyAny>,
        us: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let py = slf.py();
            let (n, m) = {
                let s = slf.borrow();
                (s.n, s.m)
            };
            let N = lag_arg(N)?;
            let model = Self::model(slf)?;
            let (steps, z) = read_series_with(zs, "zs", m, Gaps::Refused)?;
            let p = model.controls(n);
            let u = match us.filter(|u| !u.is_none()) {
                Some(us) => {
                    let (s, u) = read_series_with(us, "us", p, Gaps::Zero)?;
                    if s != steps {
                        return Err(value_error(format!(
                            "us has {s} steps but zs has {steps}; they must agree"
                        )));
                    }
                    Some(u)
                }
                None => None,
            };
            let mut core = model.core(n, m)?;
            let mut lag = fixed_lag(n, N.min(steps.saturating_sub(1)))?;
            let what = "smooth_batch's outputs";
            let (mut xs, mut xh) = (
                zeros(entries(steps, n, what)?, what)?,
                zeros(entries(steps, n, what)?, what)?,
            );
            py.detach(|| -> Result<(), String> {
                let mut last = None;
                for k in 0..steps {
                    let uk = u.as_deref().map(|u| &u[k * p..(k + 1) * p]);
                    let rec = step(&mut core, &mut lag, k, &z[k * m..(k + 1) * m], uk)?;
                    if let Some((j, x, _)) = lag.lagged() {
                        xs[j * n..(j + 1) * n].copy_from_slice(x);
                    }
                    xh[k * n..(k + 1) * n].copy_from_slice(&rec.xf);
                    last = Some(rec);
                }
                if let Some(rec) = last {
                    lag.record(&rec).map_err(|e| e.to_string())?;
                    for back in 0..lag.window() {
                        if let Some((j, x, _)) = lag.smoothed(back) {
                            xs[j * n..(j + 1) * n].copy_from_slice(x);
                        }
                    }
                }
                Ok(())
            })
            .map_err(|e| value_error(format!("smooth_batch: {e}")))?;
            let out = |data: Vec<f64>| -> Bound<'py, PyAny> {
                if model.column {
                    array3_out(py, data, steps, n, 1).into_any()
                } else {
                    let arr = numpy::ndarray::Array2::from_shape_vec((steps, n), data)
                        .unwrap_or_else(|_| numpy::ndarray::Array2::zeros((steps, n)));
                    numpy::PyArray2::from_owned_array(py, arr).into_any()
                }
            };
            PyTuple::new(py, [out(xs), out(xh)])
        })
    }
}
