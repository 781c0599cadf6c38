//! The engine's nonlinear filters from Python: `ekf` (Jacobians by central differences) and
//! `ukf` (Merwe or cubature sigma points) over Python callables f(x, u, k) and h(x, k), one
//! call for the whole series. An exception raised by a callable is re-raised as it is; a
//! return value of the wrong shape is a `ValueError` naming the callable.
#![allow(non_snake_case)]

use std::cell::RefCell;

use kalman::DynDims;
use kalman::StepInfo;
use kalman::faer::MatRef;
use kalman::nonlinear::{
    CentralDiff, Ekf, EkfUpdate, FnModel, ForwardPass, Manifold, Part, Product, SigmaPoints,
    SqrtUkf, Ukf,
};
use numpy::{PyArray1, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{
    FilterRecord, ensure_callable, float_array, mat, read_vector, shape_str, value_error,
};
use crate::guard;

/// Calls `func(*args)` and reads its result as a vector of length `len` into `out`; on any
/// failure (a pending signal included) keeps the first error in `slot` and writes NaN
/// (which the engine then refuses).
fn call_into<'py>(
    slot: &RefCell<Option<PyErr>>,
    name: &str,
    len: usize,
    out: &mut [f64],
    call: impl FnOnce() -> PyResult<Bound<'py, PyAny>>,
) {
    if slot.borrow().is_some() {
        out.fill(f64::NAN);
        return;
    }
    // A signal (Ctrl-C) that arrived while Rust was running is raised here, before the
    // next callable, and stops the filter like any exception from the callables.
    let res = Python::attach(|py| py.check_signals())
        .and_then(|()| call())
        .and_then(|v| read_vector(&v, name, len, true, false, out));
    if let Err(e) = res {
        *slot.borrow_mut() = Some(e);
        out.fill(f64::NAN);
    }
}

/// One filter's step: the measurement row and the optional input row in, the step's
/// diagnostics out.
type StepFn<F> = fn(&mut F, &[f64], Option<&[f64]>) -> Result<StepInfo, kalman::Error>;

/// A series for the nonlinear filters: its measurement (and input) rows, the slot where a
/// callable's first error is kept, and the record of the estimates.
struct Series<'a> {
    steps: usize,
    z: &'a [f64],
    u: Option<&'a [f64]>,
    slot: &'a RefCell<Option<PyErr>>,
    rec: FilterRecord,
}

impl Series<'_> {
    /// The series through one filter: its `step` at every row of `z` (and `u`), the
    /// estimates recorded. The first error a callable raised wins over the engine's own,
    /// which `err` converts.
    fn drive<F: ForwardPass>(
        &mut self,
        mut flt: F,
        step: StepFn<F>,
        err: impl Fn(kalman::Error) -> PyErr,
    ) -> PyResult<()> {
        // n from P (n×n): a mean on a manifold is a longer stored point.
        let n = flt.filtered().1.len().isqrt();
        let m = self.z.len() / self.steps.max(1);
        let p = self.u.map_or(0, |u| u.len() / self.steps.max(1));
        for k in 0..self.steps {
            let uk = self.u.map(|u| &u[k * p..(k + 1) * p]);
            let stepped = step(&mut flt, &self.z[k * m..(k + 1) * m], uk);
            if let Some(e) = self.slot.borrow_mut().take() {
                return Err(e);
            }
            let info = stepped.map_err(&err)?;
            let ((x, P), (xp, Pp)) = (flt.filtered(), flt.predicted());
            self.rec.set(
                k,
                x,
                MatRef::from_column_major_slice(P, n, n),
                xp,
                MatRef::from_column_major_slice(Pp, n, n),
                info.log_likelihood,
                info.nis,
            );
        }
        Ok(())
    }
}

/// Which nonlinear filter to run.
enum Kind {
    Ekf(EkfUpdate),
    Ukf(SigmaPoints),
    SqrtUkf(SigmaPoints),
}

/// The `manifold` argument: a sequence of "quaternion", "angle" and vector lengths k ≥ 1
/// (`None`: a vector state).
fn read_manifold(arg: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Product>> {
    let Some(arg) = arg.filter(|a| !a.is_none()) else {
        return Ok(None);
    };
    let bad = || {
        value_error(
            "manifold must be a sequence of \"quaternion\", \"angle\" and vector lengths \
             (ints >= 1), e.g. [\"quaternion\", 3]",
        )
    };
    if arg.is_instance_of::<pyo3::types::PyString>() {
        return Err(bad());
    }
    let mut parts = Vec::new();
    for item in arg.try_iter().map_err(|_| bad())? {
        let item = item?;
        let part = if let Ok(s) = item.extract::<String>() {
            match s.as_str() {
                "quaternion" => Part::Quaternion,
                "angle" => Part::Angle,
                _ => return Err(bad()),
            }
        } else if item.is_instance_of::<pyo3::types::PyBool>() {
            return Err(bad());
        } else {
            match item.extract::<usize>() {
                Ok(k) if k >= 1 => Part::Vector(k),
                _ => return Err(bad()),
            }
        };
        parts.push(part);
    }
    if parts.is_empty() {
        return Err(bad());
    }
    Ok(Some(Product::new(parts)))
}

/// The work of [`ekf`] and [`ukf`]: the arguments `(f, h, Q, R, x0, P0, zs)`, `us` and
/// `manifold` as the Python signature lists them.
fn run<'py>(
    kind: Kind,
    context: &str,
    py: Python<'py>,
    [f, h, Q, R, x0, P0, zs]: [&Bound<'py, PyAny>; 7],
    [us, manifold]: [Option<&Bound<'py, PyAny>>; 2],
) -> PyResult<Bound<'py, PyDict>> {
    for (name, c) in [("f", f), ("h", h)] {
        ensure_callable(c, name)?;
    }
    let (Q, R) = (mat(Q, "Q")?, mat(R, "R")?);
    let (n, m) = (Q.nrows(), R.nrows());
    let space = read_manifold(manifold)?;
    if let Some(s) = space.as_ref().filter(|s| s.dim() != n) {
        return Err(value_error(format!(
            "manifold has {} tangent dimensions but Q is {n}×{n}",
            s.dim()
        )));
    }
    let ns = space.as_ref().map_or(n, Manifold::stored);
    let mut x0v = vec![0.0; ns];
    read_vector(x0, "x0", ns, false, false, &mut x0v)?;
    let P0 = mat(P0, "P0")?;
    let (steps, z) = crate::series::read_series(zs, "zs", m, true)?;
    let (p, u) = match us {
        Some(us) if !us.is_none() => {
            let arr = float_array(us, "us")?;
            let p = match arr.shape() {
                [_, p] => *p,
                [_] => 1,
                s => {
                    return Err(value_error(format!(
                        "us has shape {}, expected (N, p)",
                        shape_str(s)
                    )));
                }
            };
            let (k, u) = crate::series::read_series(us, "us", p, false)?;
            if k != steps {
                return Err(value_error(format!("us has {k} steps but zs has {steps}")));
            }
            (p, Some(u))
        }
        _ => (0, None),
    };
    let err = |e: kalman::Error| value_error(format!("{context}: {e}"));
    let dims = DynDims::new(n, m, p)
        .and_then(|d| d.with_stored(ns))
        .map_err(err)?;
    let slot: RefCell<Option<PyErr>> = RefCell::new(None);
    let fcall = |x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]| {
        call_into(&slot, "the value of f(x, u, k)", ns, out, || {
            let xa = PyArray1::from_slice(py, x);
            let ua = u.map(|u| PyArray1::from_slice(py, u));
            f.call1((xa, ua, k))
        });
    };
    let hcall = |x: &[f64], k: usize, out: &mut [f64]| {
        call_into(&slot, "the value of h(x, k)", m, out, || {
            h.call1((PyArray1::from_slice(py, x), k))
        });
    };
    let mut model = FnModel::new(dims, fcall, hcall, &Q, &R).map_err(err)?;
    if let Some(space) = space {
        model = model.with_manifold(space).map_err(err)?;
    }
    let mut series = Series {
        steps,
        z: &z,
        u: u.as_deref(),
        slot: &slot,
        rec: FilterRecord::stored(steps, n, ns)?,
    };
    match kind {
        Kind::Ekf(update) => {
            let flt = Ekf::new(dims, CentralDiff::new(dims, model), &x0v, &P0, update);
            series.drive(flt.map_err(err)?, Ekf::step, err)?;
        }
        Kind::Ukf(points) => {
            let flt = Ukf::new(dims, model, &x0v, &P0, points).map_err(err)?;
            series.drive(flt, Ukf::step, err)?;
        }
        Kind::SqrtUkf(points) => {
            let flt = SqrtUkf::new(dims, model, &x0v, &P0, points).map_err(err)?;
            series.drive(flt, SqrtUkf::step, err)?;
        }
    }
    series.rec.into_dict(py)
}

/// ekf(f, h, Q, R, x0, P0, zs, us=None, iterations=0, tolerance=1e-9, manifold=None) →
/// dict as `filter`: the extended Kalman filter with Jacobians by central differences;
/// f(x, u, k) returns the next state (u is None without us), h(x, k) the predicted
/// measurement. iterations > 0 selects the iterated EKF (Gauss–Newton updates, at most that
/// many). manifold (e.g. ["quaternion", 3]) puts the state on a product of unit quaternions
/// (w, x, y, z), angles and vectors: x0, f's argument and value and the returned means are
/// stored points, Q, P0 and the returned covariances tangent.
#[pyfunction]
#[pyo3(signature = (f, h, Q, R, x0, P0, zs, us = None, iterations = 0, tolerance = 1e-9, manifold = None))]
pub(crate) fn ekf<'py>(
    py: Python<'py>,
    f: &Bound<'py, PyAny>,
    h: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    P0: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    us: Option<&Bound<'py, PyAny>>,
    iterations: usize,
    tolerance: f64,
    manifold: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_ekf(
            py,
            [f, h, Q, R, x0, P0, zs],
            [us, manifold],
            iterations,
            tolerance,
        )
    })
}

/// [`ekf`]'s work.
fn run_ekf<'py>(
    py: Python<'py>,
    args: [&Bound<'py, PyAny>; 7],
    options: [Option<&Bound<'py, PyAny>>; 2],
    iterations: usize,
    tolerance: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let update = if iterations == 0 {
        EkfUpdate::Extended
    } else {
        EkfUpdate::Iterated {
            max_iterations: iterations,
            tolerance,
        }
    };
    run(Kind::Ekf(update), "ekf", py, args, options)
}

/// ukf(f, h, Q, R, x0, P0, zs, us=None, points="merwe", alpha=1e-3, beta=2.0, kappa=0.0,
/// form="plain", manifold=None) → dict as `filter`: the unscented Kalman filter with
/// Merwe's scaled sigma points or the cubature rule (points="cubature"); form="sqrt" runs
/// the square-root UKF (the same filter carrying Cholesky factors, for covariances too
/// ill-conditioned to form and factor); manifold as in `ekf` (sigma points drawn in the
/// tangent space).
#[pyfunction]
#[pyo3(signature = (f, h, Q, R, x0, P0, zs, us = None, points = "merwe", alpha = 1e-3, beta = 2.0, kappa = 0.0, form = "plain", manifold = None))]
pub(crate) fn ukf<'py>(
    py: Python<'py>,
    f: &Bound<'py, PyAny>,
    h: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    P0: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    us: Option<&Bound<'py, PyAny>>,
    points: &str,
    alpha: f64,
    beta: f64,
    kappa: f64,
    form: &str,
    manifold: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        run_ukf(
            py,
            [f, h, Q, R, x0, P0, zs],
            [us, manifold],
            points,
            alpha,
            beta,
            kappa,
            form,
        )
    })
}

/// [`ukf`]'s work.
fn run_ukf<'py>(
    py: Python<'py>,
    args: [&Bound<'py, PyAny>; 7],
    options: [Option<&Bound<'py, PyAny>>; 2],
    points: &str,
    alpha: f64,
    beta: f64,
    kappa: f64,
    form: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let points = match points {
        "merwe" => SigmaPoints::Merwe { alpha, beta, kappa },
        "cubature" => SigmaPoints::Cubature,
        other => {
            return Err(value_error(format!(
                "points = {other:?}; expected \"merwe\" or \"cubature\""
            )));
        }
    };
    let kind = match form {
        "plain" => Kind::Ukf(points),
        "sqrt" => Kind::SqrtUkf(points),
        other => {
            return Err(value_error(format!(
                "form = {other:?}; expected \"plain\" or \"sqrt\""
            )));
        }
    };
    run(kind, "ukf", py, args, options)
}
