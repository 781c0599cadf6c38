//! Reading whole series into row-major buffers: the vectors of every step (`zs`, `us`), and
//! FilterPy's per-step model arguments of the whole-series methods (`Fs`, `Qs`, `Hs`, `Rs`,
//! `Bs` of `batch_filter`; `Fs`, `Qs` of `rts_smoother`), each None (the filter's own matrix
//! at every step) or one matrix per step, read and checked once into one buffer (step k's
//! matrix at `k · rows · cols`), with errors naming the argument and the step.

use numpy::{PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyString;

use crate::convert::{
    check_covariance, entries, float_array, read_matrix, read_vector, shape_str, type_error,
    type_name, value_error, zeros,
};

/// What a None item of a series stands for, and whether NaN entries pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Gaps {
    /// A None item is a missing vector, a NaN entry a missing entry (measurements).
    Missing,
    /// A None item is zero (FilterPy's `predict(u=None)`: no control); NaN is refused.
    Zero,
    /// Neither passes.
    Refused,
}

/// Reads a whole series of vectors (`zs`, `us`): an array (N, len), (N, len, 1), or (N,)
/// when len = 1, or a sequence whose items are vectors, scalars or None (missing).
pub(crate) fn read_series(
    obj: &Bound<'_, PyAny>,
    name: &str,
    len: usize,
    missing_ok: bool,
) -> PyResult<(usize, Vec<f64>)> {
    let gaps = if missing_ok {
        Gaps::Missing
    } else {
        Gaps::Refused
    };
    read_series_with(obj, name, len, gaps)
}

/// [`read_series`] with the meaning of None items and NaN entries spelled out.
pub(crate) fn read_series_with(
    obj: &Bound<'_, PyAny>,
    name: &str,
    len: usize,
    gaps: Gaps,
) -> PyResult<(usize, Vec<f64>)> {
    let missing_ok = gaps == Gaps::Missing;
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
        let mut out = zeros(view.len(), name)?;
        match view.as_slice() {
            Some(contiguous) => out.copy_from_slice(contiguous),
            None => out.iter_mut().zip(view.iter()).for_each(|(o, v)| *o = *v),
        }
        for (i, &v) in out.iter().enumerate() {
            if v.is_infinite() || (v.is_nan() && !missing_ok) {
                return Err(value_error(format!(
                    "{name}[{}] has a non-finite entry ({v}){}",
                    i / len.max(1),
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
        let fill = if gaps == Gaps::Zero { 0.0 } else { f64::NAN };
        let mut buf = vec![fill; len];
        if !(item.is_none() && gaps != Gaps::Refused) {
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

/// What a step's matrix must be besides finite and of its shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Rule {
    /// Any matrix (F, H); a real scalar s stands for s·I when the matrix is square, as the
    /// filter's own attributes and FilterPy's `predict`/`update` take it.
    Matrix,
    /// A control matrix B: an array only, as `predict(B=…)` takes it.
    Control,
    /// A symmetric positive semi-definite covariance (Q, R); a scalar s is s·I.
    Covariance,
}

/// One per-step argument: its name, the shape of each step's matrix, the rule it follows,
/// and the matrix a `None` item stands for (FilterPy passes the item on to `predict` or
/// `update`, which read None as the filter's own; `None` here: zeros, i.e. no control).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Spec<'a> {
    pub name: &'a str,
    pub rows: usize,
    pub cols: usize,
    pub rule: Rule,
    pub own: Option<&'a [f64]>,
}

/// The series a per-step argument runs along (for messages): its name and number of steps.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Along<'a> {
    pub name: &'a str,
    pub steps: usize,
}

/// Reads a per-step argument: `None` (or Python's None) → `Ok(None)`, the filter's own matrix
/// at every step; else an array (steps, rows, cols), or a sequence of `steps` items each a
/// matrix of that shape (a scalar s·I for a square one, except B) or None. Refused, with
/// the argument and the step named: a length other than `along.steps`, a step of another
/// shape, a non-finite entry, and for Q and R a matrix that is not symmetric PSD.
pub(crate) fn read_steps(
    obj: Option<&Bound<'_, PyAny>>,
    spec: &Spec<'_>,
    along: Along<'_>,
) -> PyResult<Option<Vec<f64>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let Spec {
        name, rows, cols, ..
    } = *spec;
    if let Ok(arr) = obj.cast::<PyUntypedArray>() {
        match arr.ndim() {
            3 => return read_array(obj, spec, along).map(Some),
            1 => {} // an object array of matrices, or scalars: item by item below
            _ => {
                return Err(value_error(format!(
                    "{name} has shape {}, expected one ({rows}, {cols}) matrix per step: an \
                     array ({}, {rows}, {cols}) or a sequence of {} matrices",
                    shape_str(arr.shape()),
                    along.steps,
                    along.steps
                )));
            }
        }
    }
    if obj.is_instance_of::<PyString>() {
        return Err(type_error(format!(
            "{name} must be None or a sequence of one ({rows}, {cols}) matrix per step, not str"
        )));
    }
    if let Ok(len) = obj.len() {
        check_length(name, len, along)?;
    }
    let items = obj.try_iter().map_err(|_| {
        type_error(format!(
            "{name} must be None or a sequence of one ({rows}, {cols}) matrix per step, not {}",
            type_name(obj)
        ))
    })?;
    let size = rows * cols;
    let mut out = zeros(entries(along.steps, size, name)?, name)?;
    out.clear(); // the capacity stays: one fallible allocation for every step
    let mut buf = vec![0.0; size];
    let mut k = 0;
    for item in items {
        let item = item?;
        if k == along.steps {
            // A sequence without a length (a generator) that runs past the last step.
            return Err(length_error(name, k + 1, along));
        }
        if item.is_none() {
            match spec.own {
                Some(own) => out.extend_from_slice(own),
                None => out.resize(out.len() + size, 0.0),
            }
        } else {
            let step = format!("{name}[{k}]");
            let scalar_identity = rows == cols && spec.rule != Rule::Control;
            read_matrix(&item, &step, rows, cols, scalar_identity, &mut buf)?;
            if spec.rule == Rule::Covariance {
                check_covariance(&step, &buf, rows)?;
            }
            out.extend_from_slice(&buf);
        }
        k += 1;
    }
    check_length(name, k, along)?;
    Ok(Some(out))
}

/// Reads a per-step argument given as one 3-d array (steps, rows, cols).
fn read_array(obj: &Bound<'_, PyAny>, spec: &Spec<'_>, along: Along<'_>) -> PyResult<Vec<f64>> {
    let Spec {
        name, rows, cols, ..
    } = *spec;
    let arr = float_array(obj, name)?;
    let ro = arr.readonly();
    let view = ro.as_array();
    let shape = view.shape();
    check_length(name, shape[0], along)?;
    if shape[1..] != [rows, cols] {
        return Err(value_error(format!(
            "{name}[0] has shape ({}, {}), expected ({rows}, {cols}) ({name} is an array of \
             shape {}, one matrix per step)",
            shape[1],
            shape[2],
            shape_str(shape)
        )));
    }
    let size = rows * cols;
    let mut out = zeros(entries(along.steps, size, name)?, name)?;
    for (k, (chunk, step)) in out
        .chunks_exact_mut(size)
        .zip(view.outer_iter())
        .enumerate()
    {
        for (o, &v) in chunk.iter_mut().zip(step.iter()) {
            if !v.is_finite() {
                return Err(value_error(format!(
                    "{name}[{k}] has a non-finite entry ({v}); every entry must be finite"
                )));
            }
            *o = v;
        }
        if spec.rule == Rule::Covariance {
            check_covariance(&format!("{name}[{k}]"), chunk, rows)?;
        }
    }
    Ok(out)
}

/// Refuses a per-step argument of `len` items for a series of `along.steps` steps.
fn check_length(name: &str, len: usize, along: Along<'_>) -> PyResult<()> {
    if len == along.steps {
        Ok(())
    } else {
        Err(length_error(name, len, along))
    }
}

fn length_error(name: &str, len: usize, along: Along<'_>) -> PyErr {
    let steps = along.steps;
    let which = if len < steps {
        format!("{name}[{len}] is missing")
    } else {
        format!("{name}[{steps}] is past the last step")
    };
    value_error(format!(
        "{name} has {len} {} but {} has {steps} steps ({which}): give one per step, or None \
         for the filter's own",
        if len == 1 { "matrix" } else { "matrices" },
        along.name
    ))
}

/// `obj` itself if it is None, an array or a sequence with a length; else (a generator,
/// say) a list of its items, so that it can be read twice ([`control_columns`] peeks).
pub(crate) fn reusable<'py>(
    obj: Option<&Bound<'py, PyAny>>,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let Some(obj) = obj else {
        return Ok(None);
    };
    if obj.is_none() || obj.len().is_ok() || obj.try_iter().is_err() {
        return Ok(Some(obj.clone()));
    }
    Ok(Some(
        pyo3::types::PyList::new(obj.py(), obj.try_iter()?.collect::<PyResult<Vec<_>>>()?)?
            .into_any(),
    ))
}

/// The number of controls p that a `Bs` argument implies: the columns of its first matrix
/// that is not None (`None`: `Bs` is None or every item is). An item whose shape tells
/// nothing (not a 2-d array) gives 1; reading it then refuses it, naming it.
pub(crate) fn control_columns(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    if let Ok(arr) = obj.cast::<PyUntypedArray>()
        && arr.ndim() != 1
    {
        return Ok(Some(if arr.ndim() == 3 { arr.shape()[2] } else { 1 }));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(Some(1));
    }
    let Ok(items) = obj.try_iter() else {
        return Ok(Some(1)); // refused by `read_steps`
    };
    for item in items {
        let item = item?;
        if item.is_none() {
            continue;
        }
        return Ok(Some(match item.cast::<PyUntypedArray>() {
            Ok(a) if a.ndim() == 2 => a.shape()[1],
            _ => 1,
        }));
    }
    Ok(None)
}
