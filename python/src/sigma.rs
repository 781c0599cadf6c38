//! FilterPy's sigma-point classes — `MerweScaledSigmaPoints`, `JulierSigmaPoints`,
//! `SimplexSigmaPoints` — with their constructor arguments, attributes (`n`, `alpha`,
//! `beta`, `kappa`, `sqrt`, `subtract`, `Wm`, `Wc`) in an ordinary instance `__dict__` (so
//! they copy, pickle and edit as FilterPy's do) and `sigma_points` computed in Rust.
//!
//! Notation: n states, N sigma points (2n + 1, or n + 1 for the simplex), c the spread:
//! Merwe's λ + n = α²(n + κ), Julier's n + κ. With U the upper Cholesky factor of c·P
//! (Uᵀ U = c P, SciPy's `cholesky`, or `sqrt(c P)` of the user's `sqrt_method`), the points
//! are x, x + U[k], x − U[k] (rows k of U). The simplex rule takes U of P itself and the
//! points x + Uᵀ I*√n, with I* Moireau and Chapelle's n × (n + 1) unit simplex.
#![allow(non_snake_case)]

use numpy::ndarray::Array2;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use pyo3::{PyClass, PyClassInitializer};

use crate::convert::{read_matrix, read_vector, scalar, type_error, value_error, zeros};
use crate::guard;

/// Which rule a points object follows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Rule {
    Merwe,
    Julier,
    Simplex,
}

/// The instance dict of `obj` (the pyclasses here and the UKF are declared with `dict`).
pub(crate) fn dict_of<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    Ok(obj
        .getattr(pyo3::intern!(obj.py(), "__dict__"))?
        .cast_into::<PyDict>()?)
}

/// `d[key]`, or an `AttributeError` naming it (keys are interned strings on hot paths).
pub(crate) fn item<'py, K>(d: &Bound<'py, PyDict>, key: K) -> PyResult<Bound<'py, PyAny>>
where
    K: IntoPyObject<'py> + std::fmt::Display + Copy,
{
    d.get_item(key)?.ok_or_else(|| {
        pyo3::exceptions::PyAttributeError::new_err(format!("the attribute {key} was deleted"))
    })
}

/// `v` when it is given and not None, else `d[key]` (an argument that defaults to the
/// attribute).
pub(crate) fn item_or<'py, K>(
    v: Option<&Bound<'py, PyAny>>,
    d: &Bound<'py, PyDict>,
    key: K,
) -> PyResult<Bound<'py, PyAny>>
where
    K: IntoPyObject<'py> + std::fmt::Display + Copy,
{
    match v.filter(|v| !v.is_none()) {
        Some(v) => Ok(v.clone()),
        None => item(d, key),
    }
}

/// A real number attribute.
fn number<'py, K>(d: &Bound<'py, PyDict>, key: K) -> PyResult<f64>
where
    K: IntoPyObject<'py> + std::fmt::Display + Copy,
{
    let v = item(d, key)?;
    scalar(&v).ok_or_else(|| type_error(format!("{key} must be a real number")))
}

/// `numpy.subtract` (the default `subtract`/residual; the Rust paths are taken for it).
pub(crate) fn np_attr<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    numpy(py)?.getattr(name)
}

/// The `numpy` module, imported once (an import per call costs microseconds).
pub(crate) fn numpy(py: Python<'_>) -> PyResult<&Bound<'_, pyo3::types::PyModule>> {
    static NP: pyo3::sync::PyOnceLock<Py<pyo3::types::PyModule>> = pyo3::sync::PyOnceLock::new();
    NP.get_or_try_init(py, || py.import("numpy").map(Bound::unbind))
        .map(|m| m.bind(py))
}

/// The dimension n: a positive integer (NumPy integers too).
fn dimension(n: &Bound<'_, PyAny>) -> PyResult<usize> {
    match n.extract::<usize>() {
        Ok(v) if v > 0 => Ok(v),
        _ => Err(value_error(format!(
            "n must be a positive integer, not {}",
            n.repr().map(|r| r.to_string()).unwrap_or_default()
        ))),
    }
}

/// (Wm, Wc) of a rule for n states, with its parameters read from `d`.
fn weights(rule: Rule, n: usize, d: &Bound<'_, PyDict>) -> PyResult<(Vec<f64>, Vec<f64>)> {
    let nf = n as f64;
    let count = if rule == Rule::Simplex {
        n + 1
    } else {
        2 * n + 1
    };
    let mut wm = zeros(count, "Wm")?;
    let mut wc = zeros(count, "Wc")?;
    match rule {
        Rule::Merwe => {
            let (alpha, beta, kappa) = (
                number(d, pyo3::intern!(d.py(), "alpha"))?,
                number(d, pyo3::intern!(d.py(), "beta"))?,
                number(d, pyo3::intern!(d.py(), "kappa"))?,
            );
            let lambda = alpha * alpha * (nf + kappa) - nf;
            let c = 0.5 / (nf + lambda);
            wm.fill(c);
            wc.fill(c);
            wm[0] = lambda / (nf + lambda);
            wc[0] = lambda / (nf + lambda) + (1.0 - alpha * alpha + beta);
        }
        Rule::Julier => {
            let kappa = number(d, pyo3::intern!(d.py(), "kappa"))?;
            wm.fill(0.5 / (nf + kappa));
            wm[0] = kappa / (nf + kappa);
            wc.copy_from_slice(&wm);
        }
        Rule::Simplex => {
            wm.fill(1.0 / (nf + 1.0));
            wc.copy_from_slice(&wm);
        }
    }
    Ok((wm, wc))
}

/// Sets `Wm` and `Wc` in `d` (Julier and simplex: one array for both, as FilterPy).
fn compute_weights(py: Python<'_>, rule: Rule, d: &Bound<'_, PyDict>) -> PyResult<()> {
    let n = dimension(&item(d, pyo3::intern!(d.py(), "n"))?)?;
    let (wm, wc) = weights(rule, n, d)?;
    let wm = PyArray1::from_vec(py, wm);
    d.set_item(pyo3::intern!(d.py(), "Wm"), &wm)?;
    if rule == Rule::Merwe {
        d.set_item(pyo3::intern!(d.py(), "Wc"), PyArray1::from_vec(py, wc))?;
    } else {
        d.set_item(pyo3::intern!(d.py(), "Wc"), &wm)?;
    }
    Ok(())
}

/// A new points object's dict: n, the rule's parameters, sqrt, subtract, the weights.
fn init(
    py: Python<'_>,
    rule: Rule,
    d: &Bound<'_, PyDict>,
    n: &Bound<'_, PyAny>,
    params: &[(&str, &Bound<'_, PyAny>)],
    sqrt_method: Option<&Bound<'_, PyAny>>,
    subtract: Option<&Bound<'_, PyAny>>,
) -> PyResult<()> {
    dimension(n)?;
    d.set_item(pyo3::intern!(d.py(), "n"), n)?;
    for (k, v) in params {
        if scalar(v).is_none() {
            return Err(type_error(format!("{k} must be a real number")));
        }
        d.set_item(*k, v)?;
    }
    d.set_item(
        pyo3::intern!(d.py(), "sqrt"),
        sqrt_method.filter(|s| !s.is_none()),
    )?;
    let subtract = match subtract.filter(|s| !s.is_none()) {
        Some(s) => s.clone(),
        None => np_attr(py, "subtract")?,
    };
    d.set_item(pyo3::intern!(d.py(), "subtract"), subtract)?;
    compute_weights(py, rule, d)
}

/// The rule of `points` if it is exactly one of this module's classes (the UKF then draws
/// its points in Rust, calling Python only for a user's `sqrt` or `subtract`).
pub(crate) fn native(points: &Bound<'_, PyAny>) -> Option<Rule> {
    let rule = if points.is_exact_instance_of::<MerweScaledSigmaPoints>() {
        Rule::Merwe
    } else if points.is_exact_instance_of::<JulierSigmaPoints>() {
        Rule::Julier
    } else if points.is_exact_instance_of::<SimplexSigmaPoints>() {
        Rule::Simplex
    } else {
        return None;
    };
    Some(rule)
}

/// The upper factor U (Uᵀ U = A, row-major) of the n×n matrix `a`, by Cholesky, or by
/// `sqrt(A)` when the user gave a square root; a matrix that is not positive definite is
/// NumPy's `LinAlgError` (a `ValueError`), as SciPy's `cholesky` raises it.
fn upper_factor(
    py: Python<'_>,
    sqrt: Option<&Bound<'_, PyAny>>,
    a: &[f64],
    n: usize,
) -> PyResult<Vec<f64>> {
    let mut u = zeros(n * n, "the square root of P")?;
    match sqrt {
        None => {
            let mut l = a.to_vec();
            // P is symmetric, so its row-major buffer is its column-major one: kalman's factor
            // leaves L in the column-major lower triangle, U = Lᵀ in the row-major upper one.
            if !kalman::dense::cholesky(&mut l, n, 0.0) {
                let err = py.import("numpy.linalg")?.getattr("LinAlgError")?;
                return Err(PyErr::from_value(err.call1((
                    "the scaled covariance is not positive definite: its Cholesky factor (the \
                     sigma points' square root) does not exist",
                ))?));
            }
            for i in 0..n {
                for j in 0..n {
                    u[i * n + j] = if j >= i { l[i * n + j] } else { 0.0 };
                }
            }
        }
        Some(f) => {
            let arr = Array2::from_shape_vec((n, n), a.to_vec())
                .map_err(|e| value_error(e.to_string()))?;
            let r = f.call1((PyArray2::from_owned_array(py, arr),))?;
            read_matrix(&r, "the value of sqrt_method(P)", n, n, false, &mut u)?;
        }
    }
    Ok(u)
}

/// The unit simplex I* of Moireau and Chapelle scaled by √n: n × (n + 1), row-major.
fn simplex(n: usize) -> PyResult<Vec<f64>> {
    let cols = n + 1;
    let mut s = zeros(n * cols, "the simplex")?;
    let lambda = n as f64 / (n as f64 + 1.0);
    let r = 1.0 / (2.0 * lambda).sqrt();
    s[0] = -r;
    s[1] = r;
    for d in 2..=n {
        let df = d as f64;
        let v = 1.0 / (lambda * df * (df + 1.0)).sqrt();
        let row = d - 1;
        for j in 0..d {
            s[row * cols + j] = v;
        }
        s[row * cols + d] = -df * v;
    }
    let sq = (n as f64).sqrt();
    s.iter_mut().for_each(|v| *v *= sq);
    Ok(s)
}

/// The sigma points (N × n, row-major) of `rule` at (x, P) with the parameters in `d`
/// (`sqrt` and `subtract` called if the user gave them).
pub(crate) fn draw(
    py: Python<'_>,
    rule: Rule,
    d: &Bound<'_, PyDict>,
    x: &[f64],
    P: &[f64],
) -> PyResult<Vec<f64>> {
    let n = x.len();
    let sqrt = item(d, pyo3::intern!(d.py(), "sqrt"))?;
    let sqrt = (!sqrt.is_none()).then_some(sqrt);
    let subtract = item(d, pyo3::intern!(d.py(), "subtract"))?;
    let plain = subtract.is(&np_attr(py, "subtract")?);
    let c = match rule {
        Rule::Merwe => {
            let (alpha, kappa) = (
                number(d, pyo3::intern!(d.py(), "alpha"))?,
                number(d, pyo3::intern!(d.py(), "kappa"))?,
            );
            alpha * alpha * (n as f64 + kappa)
        }
        Rule::Julier => n as f64 + number(d, pyo3::intern!(d.py(), "kappa"))?,
        Rule::Simplex => 1.0,
    };
    let scaled: Vec<f64> = P.iter().map(|v| c * v).collect();
    let U = upper_factor(py, sqrt.as_ref(), &scaled, n)?;
    if rule == Rule::Simplex {
        let cols = n + 1;
        let I = simplex(n)?;
        // scaled_unitary = Uᵀ I (n × (n + 1)); the points are its columns added to x.
        let mut su = zeros(n * cols, "the sigma points")?;
        for i in 0..n {
            for j in 0..cols {
                su[i * cols + j] = (0..n).map(|k| U[k * n + i] * I[k * cols + j]).sum();
            }
        }
        let mut out = zeros(cols * n, "the sigma points")?;
        if plain {
            for j in 0..cols {
                for i in 0..n {
                    out[j * n + i] = x[i] + su[i * cols + j];
                }
            }
        } else {
            let xa = PyArray2::from_owned_array(
                py,
                Array2::from_shape_vec((n, 1), x.to_vec())
                    .map_err(|e| value_error(e.to_string()))?,
            );
            let neg: Vec<f64> = su.iter().map(|v| -v).collect();
            let na =
                Array2::from_shape_vec((n, cols), neg).map_err(|e| value_error(e.to_string()))?;
            let r = subtract.call1((xa, PyArray2::from_owned_array(py, na)))?;
            let mut s = zeros(n * cols, "the sigma points")?;
            read_matrix(
                &r,
                "the value of subtract(x, -U.T @ I)",
                n,
                cols,
                false,
                &mut s,
            )?;
            for j in 0..cols {
                for i in 0..n {
                    out[j * n + i] = s[i * cols + j];
                }
            }
        }
        return Ok(out);
    }
    let mut out = zeros((2 * n + 1) * n, "the sigma points")?;
    out[..n].copy_from_slice(x);
    for k in 0..n {
        let row = &U[k * n..(k + 1) * n];
        if plain {
            for i in 0..n {
                out[(k + 1) * n + i] = x[i] + row[i];
                out[(n + k + 1) * n + i] = x[i] - row[i];
            }
        } else {
            let xa = PyArray1::from_slice(py, x);
            let neg: Vec<f64> = row.iter().map(|v| -v).collect();
            let a = subtract.call1((&xa, PyArray1::from_vec(py, neg)))?;
            read_vector(
                &a,
                "the value of subtract(x, -U[k])",
                n,
                true,
                false,
                &mut out[(k + 1) * n..(k + 2) * n],
            )?;
            let b = subtract.call1((&xa, PyArray1::from_slice(py, row)))?;
            let at = (n + k + 1) * n;
            read_vector(
                &b,
                "the value of subtract(x, U[k])",
                n,
                true,
                false,
                &mut out[at..at + n],
            )?;
        }
    }
    Ok(out)
}

/// Reads `sigma_points`' (x, P): x of n entries (a scalar when n = 1), P an n×n matrix or
/// a scalar s meaning s·I.
fn read_xp(n: usize, x: &Bound<'_, PyAny>, P: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, Vec<f64>)> {
    let size: usize = numpy(x.py())?.call_method1("size", (x,))?.extract()?;
    if size != n {
        return Err(value_error(format!(
            "expected size(x) {n}, but size is {size}"
        )));
    }
    let mut xv = zeros(n, "x")?;
    let flat = numpy(x.py())?
        .call_method1("asarray", (x, "float64"))?
        .call_method0("ravel")?;
    read_vector(&flat, "x", n, true, false, &mut xv)?;
    let mut Pv = zeros(n * n, "P")?;
    let P2 = if scalar(P).is_some() {
        P.clone()
    } else {
        numpy(P.py())?.call_method1("atleast_2d", (P,))?
    };
    read_matrix(&P2, "P", n, n, true, &mut Pv)?;
    Ok((xv, Pv))
}

/// `sigma_points(x, P)` of a points object with rule `rule`.
fn sigma_points_of<'py>(
    slf: &Bound<'py, PyAny>,
    rule: Rule,
    x: &Bound<'py, PyAny>,
    P: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let py = slf.py();
    let d = dict_of(slf)?;
    let n = dimension(&item(&d, pyo3::intern!(d.py(), "n"))?)?;
    let (xv, Pv) = read_xp(n, x, P)?;
    let pts = draw(py, rule, &d, &xv, &Pv)?;
    let count = pts.len() / n;
    let arr = Array2::from_shape_vec((count, n), pts).map_err(|e| value_error(e.to_string()))?;
    Ok(PyArray2::from_owned_array(py, arr))
}

/// `__repr__`: the class name and the attributes, one per line.
fn repr_of(slf: &Bound<'_, PyAny>, title: &str, keys: &[&str]) -> PyResult<String> {
    let d = dict_of(slf)?;
    let mut out = vec![title.to_string()];
    for k in keys {
        let v = match d.get_item(k)? {
            Some(v) => v.repr()?.to_string(),
            None => "<deleted>".into(),
        };
        out.push(format!("{k} = {v}"));
    }
    Ok(out.join("\n"))
}

/// `__reduce__`: the class, its constructor's positional arguments, the dict as state.
fn reduce_of<'py>(slf: &Bound<'py, PyAny>, args: &[&str]) -> PyResult<Bound<'py, PyTuple>> {
    let d = dict_of(slf)?;
    let vals: Vec<Bound<'py, PyAny>> = args.iter().map(|k| item(&d, k)).collect::<PyResult<_>>()?;
    let state = d.copy()?;
    (slf.get_type(), PyTuple::new(slf.py(), vals)?, state).into_pyobject(slf.py())
}

impl Rule {
    /// FilterPy's name of the rule's class.
    fn class(self) -> &'static str {
        match self {
            Rule::Merwe => "MerweScaledSigmaPoints",
            Rule::Julier => "JulierSigmaPoints",
            Rule::Simplex => "SimplexSigmaPoints",
        }
    }

    /// The number of sigma points for n states.
    fn count(self, n: usize) -> usize {
        match self {
            Rule::Merwe | Rule::Julier => 2 * n + 1,
            Rule::Simplex => n + 1,
        }
    }

    /// The attributes `__repr__` shows, in FilterPy's order.
    fn shown(self) -> &'static [&'static str] {
        match self {
            Rule::Merwe => &[
                "n", "alpha", "beta", "kappa", "Wm", "Wc", "subtract", "sqrt",
            ],
            Rule::Julier => &["n", "kappa", "Wm", "Wc", "subtract", "sqrt"],
            Rule::Simplex => &["n", "alpha", "Wm", "Wc", "subtract", "sqrt"],
        }
    }

    /// The constructor's positional arguments, as `__reduce__` passes them back.
    fn arguments(self) -> &'static [&'static str] {
        match self {
            Rule::Merwe => &["n", "alpha", "beta", "kappa"],
            Rule::Julier => &["n", "kappa"],
            Rule::Simplex => &["n", "alpha"],
        }
    }
}

/// The base of the three sigma-point classes: the rule, and the methods they share
/// (`num_sigmas`, `sigma_points`, `_compute_weights`, `__repr__`, `__reduce__`); each class
/// adds its own `__init__`.
#[pyclass(module = "launch_estimation", name = "_SigmaPoints", dict, subclass)]
#[derive(Debug)]
pub struct SigmaPointsBase {
    rule: Rule,
}

impl SigmaPointsBase {
    /// A new object of the class of `rule` (its dict is filled by `__init__`).
    fn of<T: PyClass<BaseType = Self>>(rule: Rule, class: T) -> PyClassInitializer<T> {
        PyClassInitializer::from(Self { rule }).add_subclass(class)
    }
}

#[pymethods]
impl SigmaPointsBase {
    /// The number of sigma points.
    fn num_sigmas(slf: &Bound<'_, Self>) -> PyResult<usize> {
        guard(|| {
            let n = dimension(&item(&dict_of(slf.as_any())?, "n")?)?;
            Ok(slf.borrow().rule.count(n))
        })
    }

    /// sigma_points(x, P) → (N, n) array: the points of mean x and covariance P (P a scalar
    /// means P·I), in FilterPy's order.
    fn sigma_points<'py>(
        slf: &Bound<'py, Self>,
        x: &Bound<'py, PyAny>,
        P: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| sigma_points_of(slf.as_any(), slf.borrow().rule, x, P))
    }

    /// Recomputes Wm and Wc from the parameters.
    fn _compute_weights(slf: &Bound<'_, Self>) -> PyResult<()> {
        guard(|| compute_weights(slf.py(), slf.borrow().rule, &dict_of(slf.as_any())?))
    }

    fn __repr__(slf: &Bound<'_, Self>) -> PyResult<String> {
        let rule = slf.borrow().rule;
        repr_of(
            slf.as_any(),
            &format!("{} object", rule.class()),
            rule.shown(),
        )
    }

    /// Pickle and copy support: the constructor's arguments, then the dict.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| reduce_of(slf.as_any(), slf.borrow().rule.arguments()))
    }
}

/// FilterPy's `MerweScaledSigmaPoints(n, alpha, beta, kappa, sqrt_method=None,
/// subtract=None)`: 2n + 1 points, Van der Merwe's scaled rule. `sqrt` is None for the
/// built-in Cholesky factor (SciPy's `cholesky`, upper triangular).
#[pyclass(module = "launch_estimation", extends = SigmaPointsBase, subclass)]
#[derive(Debug)]
pub struct MerweScaledSigmaPoints {}

#[pymethods]
impl MerweScaledSigmaPoints {
    /// The object; `__init__` fills its dict.
    #[new]
    #[pyo3(signature = (*_args, **_kwargs))]
    fn new(
        _args: &Bound<'_, PyTuple>,
        _kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyClassInitializer<Self> {
        SigmaPointsBase::of(Rule::Merwe, Self {})
    }

    #[pyo3(signature = (n, alpha, beta, kappa, sqrt_method = None, subtract = None))]
    fn __init__(
        slf: &Bound<'_, Self>,
        n: &Bound<'_, PyAny>,
        alpha: &Bound<'_, PyAny>,
        beta: &Bound<'_, PyAny>,
        kappa: &Bound<'_, PyAny>,
        sqrt_method: Option<&Bound<'_, PyAny>>,
        subtract: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let d = dict_of(slf.as_any())?;
            let params = [("alpha", alpha), ("beta", beta), ("kappa", kappa)];
            init(slf.py(), Rule::Merwe, &d, n, &params, sqrt_method, subtract)
        })
    }
}

/// FilterPy's `JulierSigmaPoints(n, kappa=0.0, sqrt_method=None, subtract=None)`: 2n + 1
/// points, Julier and Uhlmann's rule.
#[pyclass(module = "launch_estimation", extends = SigmaPointsBase, subclass)]
#[derive(Debug)]
pub struct JulierSigmaPoints {}

#[pymethods]
impl JulierSigmaPoints {
    /// The object; `__init__` fills its dict.
    #[new]
    #[pyo3(signature = (*_args, **_kwargs))]
    fn new(
        _args: &Bound<'_, PyTuple>,
        _kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyClassInitializer<Self> {
        SigmaPointsBase::of(Rule::Julier, Self {})
    }

    #[pyo3(signature = (n, kappa = None, sqrt_method = None, subtract = None))]
    fn __init__(
        slf: &Bound<'_, Self>,
        n: &Bound<'_, PyAny>,
        kappa: Option<&Bound<'_, PyAny>>,
        sqrt_method: Option<&Bound<'_, PyAny>>,
        subtract: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let d = dict_of(slf.as_any())?;
            let zero = pyo3::types::PyFloat::new(slf.py(), 0.0).into_any();
            let params = [("kappa", kappa.unwrap_or(&zero))];
            init(
                slf.py(),
                Rule::Julier,
                &d,
                n,
                &params,
                sqrt_method,
                subtract,
            )
        })
    }
}

/// FilterPy's `SimplexSigmaPoints(n, alpha=1, sqrt_method=None, subtract=None)`: n + 1
/// points on a simplex (Moireau and Chapelle); alpha is kept but, as in FilterPy, unused.
#[pyclass(module = "launch_estimation", extends = SigmaPointsBase, subclass)]
#[derive(Debug)]
pub struct SimplexSigmaPoints {}

#[pymethods]
impl SimplexSigmaPoints {
    /// The object; `__init__` fills its dict.
    #[new]
    #[pyo3(signature = (*_args, **_kwargs))]
    fn new(
        _args: &Bound<'_, PyTuple>,
        _kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyClassInitializer<Self> {
        SigmaPointsBase::of(Rule::Simplex, Self {})
    }

    #[pyo3(signature = (n, alpha = None, sqrt_method = None, subtract = None))]
    fn __init__(
        slf: &Bound<'_, Self>,
        n: &Bound<'_, PyAny>,
        alpha: Option<&Bound<'_, PyAny>>,
        sqrt_method: Option<&Bound<'_, PyAny>>,
        subtract: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let d = dict_of(slf.as_any())?;
            let one = pyo3::types::PyInt::new(slf.py(), 1).into_any();
            let params = [("alpha", alpha.unwrap_or(&one))];
            init(
                slf.py(),
                Rule::Simplex,
                &d,
                n,
                &params,
                sqrt_method,
                subtract,
            )
        })
    }
}
