//! `launch_estimation.IMMEstimator`: FilterPy's interacting multiple model estimator over a
//! bank of filters with FilterPy's interface (`x`, `P`, `predict(u)`, `update(z)`,
//! `likelihood`): the module's `KalmanFilter`, `UnscentedKalmanFilter`, FilterPy's own
//! filters, or any object that behaves like them. Its attributes live in the instance
//! `__dict__`, as FilterPy keeps them, so `Saver`, `copy` and `pickle` see them and an
//! assignment acts on the next call. The mixing probabilities and the moment matching are
//! `kalman::imm`'s (the same functions as the Rust IMM), the latter in two passes about the
//! mean so a tight covariance far from the origin is not lost to cancellation.
//!
//! Differences from FilterPy 2.0.0, each a refusal or a better-conditioned number:
//! - the mode probabilities are formed from the filters' `log_likelihood` where they have
//!   one (`μ_j ∝ c̄_j e^{ℓ_j − max ℓ}`), so they do not collapse to `c̄` when every
//!   likelihood underflows; they agree with FilterPy's to rounding otherwise;
//! - `M` must be a transition matrix (finite, non-negative, rows summing to one within
//!   1e-9) and `mu` finite, non-negative with a positive sum (FilterPy takes anything);
//! - a filter whose predicted mode probability `c̄_j` is zero keeps its own estimate when
//!   mixing (FilterPy divides by zero);
//! - an update in which no filter gives `z` a positive finite likelihood is a `ValueError`
//!   (FilterPy's μ becomes NaN);
//! - a call that fails (a filter's error, Ctrl-C) leaves every filter and the estimator as
//!   they were before it.
#![allow(non_snake_case)]

use kalman::imm::{Moments, mixing_probabilities, probability_vector};
use numpy::{PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::convert::{
    entries, matrix_out, read_matrix, read_vector, type_error, type_name, value_error, vector_out,
    zeros,
};
use crate::guard;

/// FilterPy's `IMMEstimator(filters, mu, M)`.
#[pyclass(module = "launch_estimation", dict, subclass)]
#[derive(Debug, Default)]
pub struct IMMEstimator {}

/// The bank as one call sees it: the filters, their common state dimension, and whether
/// their `x` is a 2-d column (the estimator's `x` takes the first filter's shape).
struct Bank<'py> {
    filters: Vec<Bound<'py, PyAny>>,
    n: usize,
    column: bool,
}

impl<'py> Bank<'py> {
    /// The filters of `filters` (any sequence), at least two, every `x` of one shape.
    fn read(filters: &Bound<'py, PyAny>) -> PyResult<Self> {
        let filters: Vec<_> = filters
            .try_iter()
            .map_err(|_| {
                type_error(format!(
                    "filters must be a sequence of filters, not {}",
                    type_name(filters)
                ))
            })?
            .collect::<PyResult<_>>()?;
        if filters.len() < 2 {
            return Err(value_error(format!(
                "filters has {} filter(s); an IMMEstimator needs at least two",
                filters.len()
            )));
        }
        let shape = |f: &Bound<'py, PyAny>, i: usize| -> PyResult<Vec<usize>> {
            let x = f.getattr("x").map_err(|_| {
                type_error(format!(
                    "filters[{i}] is a {} without an x: an IMMEstimator takes filters with \
                     FilterPy's interface (x, P, predict, update, likelihood)",
                    type_name(f)
                ))
            })?;
            let a = x.cast::<PyUntypedArray>().map_err(|_| {
                type_error(format!(
                    "filters[{i}].x must be a numpy.ndarray, not {}",
                    type_name(&x)
                ))
            })?;
            Ok(a.shape().to_vec())
        };
        let first = shape(&filters[0], 0)?;
        let (n, column) = match first[..] {
            [n] => (n, false),
            [n, 1] => (n, true),
            _ => {
                return Err(value_error(format!(
                    "filters[0].x has shape {first:?}; expected (dim_x, 1) or (dim_x,)"
                )));
            }
        };
        for (i, f) in filters.iter().enumerate().skip(1) {
            let s = shape(f, i)?;
            if s != first {
                return Err(value_error(format!(
                    "filters[{i}].x has shape {s:?} and filters[0].x {first:?}: every filter \
                     of an IMMEstimator has the same state dimension"
                )));
            }
        }
        Ok(Self { filters, n, column })
    }

    fn len(&self) -> usize {
        self.filters.len()
    }

    /// Every filter's `x` and `P` (row-major), checked.
    fn estimates(&self) -> PyResult<(Vec<f64>, Vec<f64>)> {
        let (n, r) = (self.n, self.len());
        let mut xs = zeros(entries(r, n, "the filters' states")?, "the filters' states")?;
        let nn = entries(n, n, "the filters' covariances")?;
        let mut ps = zeros(entries(r, nn, "the filters' covariances")?, "P")?;
        for (i, f) in self.filters.iter().enumerate() {
            let name = format!("filters[{i}].x");
            read_vector(
                &f.getattr("x")?,
                &name,
                n,
                true,
                false,
                &mut xs[i * n..][..n],
            )?;
            let name = format!("filters[{i}].P");
            read_matrix(
                &f.getattr("P")?,
                &name,
                n,
                n,
                false,
                &mut ps[i * nn..][..nn],
            )?;
        }
        Ok((xs, ps))
    }

    /// The mixture of the filters' estimates with weights `w[i]`, into `(x, P)`.
    fn mixture(&self, (xs, ps): (&[f64], &[f64]), w: &[f64], x: &mut [f64], P: &mut [f64]) {
        let n = self.n;
        Moments::clear(x, P);
        for (i, &wi) in w.iter().enumerate() {
            Moments::add_mean(wi, &xs[i * n..][..n], x);
        }
        for (i, &wi) in w.iter().enumerate() {
            Moments::add_spread(wi, (&xs[i * n..][..n], &ps[i * n * n..][..n * n]), x, P);
        }
        Moments::finish(P);
    }

    /// Each filter's state, to put back if a call fails part-way.
    fn snapshot(&self) -> PyResult<Vec<Option<Bound<'py, PyAny>>>> {
        let py = match self.filters.first() {
            Some(f) => f.py(),
            None => return Ok(Vec::new()),
        };
        let deepcopy = py.import("copy")?.getattr("deepcopy")?;
        self.filters
            .iter()
            .map(|f| {
                let rv = f.call_method1("__reduce_ex__", (4,))?;
                let state = match rv.cast::<PyTuple>() {
                    Ok(t) if t.len() > 2 => t.get_item(2)?,
                    _ => return Ok(None),
                };
                if state.is_none() {
                    return Ok(None);
                }
                Ok(Some(deepcopy.call1((state,))?))
            })
            .collect()
    }

    /// Puts back the states `snapshot` took (as `copy` rebuilds an object from its reduce
    /// value: `__setstate__` where the class has one, else the instance dict).
    fn restore(&self, states: &[Option<Bound<'py, PyAny>>]) -> PyResult<()> {
        for (f, state) in self.filters.iter().zip(states) {
            let Some(state) = state else { continue };
            if f.hasattr("__setstate__")? {
                f.call_method1("__setstate__", (state,))?;
                continue;
            }
            let (dict, slots) = match state.cast::<PyTuple>() {
                Ok(t) if t.len() == 2 => (t.get_item(0)?, Some(t.get_item(1)?)),
                _ => (state.clone(), None),
            };
            if let Ok(d) = dict.cast::<PyDict>() {
                let own = f.getattr("__dict__")?;
                own.call_method0("clear")?;
                own.call_method1("update", (d,))?;
            }
            if let Some(slots) = slots.filter(|s| !s.is_none()) {
                for (k, v) in slots.cast::<PyDict>()?.iter() {
                    f.setattr(k.str()?, v)?;
                }
            }
        }
        Ok(())
    }

    /// Runs `body` (which calls the filters); if it fails, every filter is put back as it
    /// was before and the error returned.
    fn guarded<T>(&self, body: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
        let states = self.snapshot()?;
        body().or_else(|e| {
            self.restore(&states)?;
            Err(e)
        })
    }

    /// The combined estimate of the bank under `mu`.
    fn combined(&self, mu: &[f64]) -> PyResult<(Vec<f64>, Vec<f64>)> {
        let n = self.n;
        let est = self.estimates()?;
        let (mut x, mut P) = (zeros(n, "x")?, zeros(entries(n, n, "P")?, "P")?);
        self.mixture((&est.0, &est.1), mu, &mut x, &mut P);
        Ok((x, P))
    }
}

/// The transition matrix `M` (r×r, row-major), checked.
fn transition(obj: &Bound<'_, PyAny>, r: usize) -> PyResult<Vec<f64>> {
    let arr = as_array(obj, "M")?;
    let mut pi = zeros(entries(r, r, "M")?, "M")?;
    read_matrix(&arr, "M", r, r, false, &mut pi)?;
    for (i, row) in pi.chunks(r).enumerate() {
        probability_vector("M", row).map_err(|e| value_error(format!("row {i} of {e}")))?;
    }
    Ok(pi)
}

/// `obj` as a NumPy array (a sequence converted), for reading.
pub(crate) fn as_array<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    if obj.cast::<PyUntypedArray>().is_ok() {
        return Ok(obj.clone());
    }
    obj.py()
        .import("numpy")?
        .call_method1("asarray", (obj, "float64"))
        .map_err(|_| {
            type_error(format!(
                "{name} must be an array of numbers, not {}",
                type_name(obj)
            ))
        })
}

/// Mode probabilities: r finite non-negative entries with a positive sum, normalised.
fn probabilities(obj: &Bound<'_, PyAny>, name: &str, r: usize) -> PyResult<Vec<f64>> {
    let mut mu = zeros(r, name)?;
    read_vector(obj, name, r, true, false, &mut mu)?;
    if let Some(v) = mu.iter().find(|v| **v < 0.0) {
        return Err(value_error(format!(
            "{name} has the entry {v}; probabilities must be non-negative"
        )));
    }
    let sum: f64 = mu.iter().sum();
    if !(sum > 0.0 && sum.is_finite()) {
        return Err(value_error(format!(
            "{name} sums to {sum}; it must have a positive finite sum"
        )));
    }
    mu.iter_mut().for_each(|v| *v /= sum);
    Ok(mu)
}

/// A row-major r×r array from the column-major `omega[i + j·r]`.
fn row_major(omega: &[f64], r: usize) -> Vec<f64> {
    (0..r * r).map(|k| omega[(k / r) + (k % r) * r]).collect()
}

impl IMMEstimator {
    /// `(x, P)` written as `x`, `P` and, for each of `what`, as `x_<what>`, `P_<what>`.
    fn write(
        slf: &Bound<'_, Self>,
        (x, P): (&[f64], &[f64]),
        column: bool,
        what: &[&str],
    ) -> PyResult<()> {
        let py = slf.py();
        let n = x.len();
        let o = slf.as_any();
        o.setattr("x", vector_out(py, x, column))?;
        o.setattr("P", matrix_out(py, P, n, n))?;
        for w in what {
            o.setattr(format!("x_{w}"), vector_out(py, x, column))?;
            o.setattr(format!("P_{w}"), matrix_out(py, P, n, n))?;
        }
        Ok(())
    }

    /// `cbar` and `omega` from `mu` and `M`, written as attributes.
    fn set_mixing(slf: &Bound<'_, Self>, pi: &[f64], mu: &[f64]) -> PyResult<()> {
        let py = slf.py();
        let r = mu.len();
        let (mut cbar, mut omega) = (zeros(r, "cbar")?, zeros(entries(r, r, "omega")?, "omega")?);
        mixing_probabilities(pi, mu, &mut cbar, &mut omega);
        let o = slf.as_any();
        o.setattr("cbar", vector_out(py, &cbar, false))?;
        o.setattr("omega", matrix_out(py, &row_major(&omega, r), r, r))?;
        Ok(())
    }

    /// The bank, `M` and the attribute `name` read as probabilities, for one call.
    fn state<'py>(slf: &Bound<'py, Self>, name: &str) -> PyResult<(Bank<'py>, Vec<f64>, Vec<f64>)> {
        let o = slf.as_any();
        let bank = Bank::read(&o.getattr("filters")?)?;
        let r = bank.len();
        let pi = transition(&o.getattr("M")?, r)?;
        let w = probabilities(&o.getattr(name)?, name, r)?;
        Ok((bank, pi, w))
    }
}

#[pymethods]
impl IMMEstimator {
    #[new]
    #[pyo3(signature = (*_args, **_kwargs))]
    fn new(_args: &Bound<'_, PyTuple>, _kwargs: Option<&Bound<'_, PyDict>>) -> Self {
        Self {}
    }

    /// IMMEstimator(filters, mu, M): `filters` a sequence of at least two filters whose `x`
    /// have one shape, `mu` the initial mode probabilities (normalised), `M[i, j]` the
    /// probability of switching from filter i to filter j (rows sum to one). The initial
    /// estimate is the mixture of the filters' x and P under mu.
    fn __init__(
        slf: &Bound<'_, Self>,
        filters: &Bound<'_, PyAny>,
        mu: &Bound<'_, PyAny>,
        M: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guard(|| {
            let py = slf.py();
            let bank = Bank::read(filters)?;
            let r = bank.len();
            let pi = transition(M, r)?;
            let mu = probabilities(mu, "mu", r)?;
            let o = slf.as_any();
            o.setattr("filters", filters)?;
            o.setattr("M", M)?;
            o.setattr("N", r)?;
            o.setattr("mu", vector_out(py, &mu, false))?;
            o.setattr(
                "likelihood",
                vector_out(py, &zeros(r, "likelihood")?, false),
            )?;
            Self::set_mixing(slf, &pi, &mu)?;
            let (x, P) = bank.combined(&mu)?;
            Self::write(slf, (&x, &P), bank.column, &["prior", "post"])
        })
    }

    /// update(z): every filter updates with z; the mode probabilities μ_j ∝ c̄_j L_j, the
    /// mixing probabilities for the next prediction and the combined estimate (x, P,
    /// x_post, P_post) follow. Nothing changes when it fails.
    fn update(slf: &Bound<'_, Self>, z: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            let py = slf.py();
            let (bank, pi, _) = Self::state(slf, "mu")?;
            let r = bank.len();
            let cbar = probabilities(&slf.as_any().getattr("cbar")?, "cbar", r)?;
            let (lik, mu, (x, P)) = bank.guarded(|| {
                let (mut lik, mut ll) = (zeros(r, "likelihood")?, zeros(r, "likelihood")?);
                for (i, f) in bank.filters.iter().enumerate() {
                    py.check_signals()?;
                    f.call_method1("update", (z,))?;
                    lik[i] = f.getattr("likelihood")?.extract::<f64>().map_err(|_| {
                        type_error(format!("filters[{i}].likelihood must be a number"))
                    })?;
                    ll[i] = match f.getattr("log_likelihood") {
                        Ok(v) if !v.is_none() => v.extract::<f64>().unwrap_or(f64::NAN),
                        _ => f64::NAN,
                    };
                    if ll[i].is_nan() {
                        ll[i] = lik[i].ln();
                    }
                }
                // μ_j ∝ c̄_j e^{ℓ_j}, in logarithms.
                let top = (0..r)
                    .filter(|&j| cbar[j] > 0.0)
                    .map(|j| ll[j])
                    .fold(f64::NEG_INFINITY, f64::max);
                let mut mu = zeros(r, "mu")?;
                for j in 0..r {
                    mu[j] = if cbar[j] > 0.0 {
                        cbar[j] * (ll[j] - top).exp()
                    } else {
                        0.0
                    };
                }
                let sum: f64 = mu.iter().sum();
                if !(top.is_finite() && sum > 0.0 && sum.is_finite()) {
                    return Err(value_error(format!(
                        "no filter gives z a positive finite likelihood (likelihoods {lik:?})"
                    )));
                }
                mu.iter_mut().for_each(|v| *v /= sum);
                let combined = bank.combined(&mu)?;
                Ok((lik, mu, combined))
            })?;
            let o = slf.as_any();
            o.setattr("likelihood", vector_out(py, &lik, false))?;
            o.setattr("mu", vector_out(py, &mu, false))?;
            Self::write(slf, (&x, &P), bank.column, &["post"])?;
            Self::set_mixing(slf, &pi, &mu)
        })
    }

    /// predict(u=None): each filter j starts from the mixture of the bank's estimates with
    /// weights omega[:, j] (its own estimate if c̄_j = 0) and predicts with
    /// `predict(u)`; the combined prior (x, P, x_prior, P_prior) follows. Nothing changes
    /// when it fails.
    #[pyo3(signature = (u = None))]
    fn predict(slf: &Bound<'_, Self>, u: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        guard(|| {
            let py = slf.py();
            let (bank, _, mu) = Self::state(slf, "mu")?;
            let (r, n) = (bank.len(), bank.n);
            let o = slf.as_any();
            let mut omega = zeros(entries(r, r, "omega")?, "omega")?;
            read_matrix(
                &as_array(&o.getattr("omega")?, "omega")?,
                "omega",
                r,
                r,
                false,
                &mut omega,
            )?;
            let est = bank.estimates()?;
            let mut mixed = Vec::with_capacity(r);
            let mut w = zeros(r, "omega")?;
            for j in 0..r {
                (0..r).for_each(|i| w[i] = omega[i * r + j]);
                let (mut x, mut P) = (zeros(n, "x")?, zeros(entries(n, n, "P")?, "P")?);
                if w.iter().sum::<f64>() > 0.0 {
                    bank.mixture((&est.0, &est.1), &w, &mut x, &mut P);
                } else {
                    x.copy_from_slice(&est.0[j * n..][..n]);
                    P.copy_from_slice(&est.1[j * n * n..][..n * n]);
                }
                mixed.push((x, P));
            }
            let u = u.map_or_else(|| py.None().into_bound(py), |u| u.clone());
            let (x, P) = bank.guarded(|| {
                for (f, (x, P)) in bank.filters.iter().zip(&mixed) {
                    py.check_signals()?;
                    f.setattr("x", vector_out(py, x, bank.column))?;
                    f.setattr("P", matrix_out(py, P, n, n))?;
                    f.call_method1("predict", (&u,))?;
                }
                bank.combined(&mu)
            })?;
            Self::write(slf, (&x, &P), bank.column, &["prior"])
        })
    }

    /// Copy and pickle support: the class rebuilt without `__init__`, then its dict (a
    /// shallow copy shares the filters, as FilterPy's does).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyTuple>> {
        guard(|| {
            let py = slf.py();
            let newobj = py.import("copyreg")?.getattr("__newobj__")?;
            let d = slf.as_any().getattr("__dict__")?.cast_into::<PyDict>()?;
            (newobj, (slf.get_type(),), d.copy()?).into_pyobject(py)
        })
    }

    fn __repr__(slf: &Bound<'_, Self>) -> PyResult<String> {
        guard(|| {
            let d = slf.as_any().getattr("__dict__")?.cast_into::<PyDict>()?;
            let mut out = vec!["IMMEstimator object".to_string()];
            for k in [
                "x",
                "P",
                "x_prior",
                "P_prior",
                "x_post",
                "P_post",
                "N",
                "mu",
                "M",
                "cbar",
                "likelihood",
                "omega",
            ] {
                if let Some(v) = d.get_item(k)? {
                    out.push(format!("{k} = {}", v.repr()?));
                }
            }
            Ok(out.join("\n"))
        })
    }
}
