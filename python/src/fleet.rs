//! `launch_estimation.filter_batch`: many independent series of one linear model filtered in
//! lockstep by `kalman::batch::BatchFilter` (the series eight at a time in vector
//! registers, groups of them on threads), with the GIL released. The series are taken in
//! chunks of a few megabytes of work each, so the engine's own buffers stay small, Ctrl-C
//! is seen between chunks, and the only large allocations are the output arrays, made by
//! NumPy (a size beyond memory is NumPy's `MemoryError`).
#![allow(non_snake_case)]

use kalman::batch::{BatchFilter, LANES};
use kalman::{DynDims, Model};
use numpy::PyArrayMethods;
use numpy::ndarray::{Axis, s};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{float_array, mat, np_zeros, shape_str, value_error};
use crate::guard;
use crate::pass::{covariance_form, engine};

/// Entries of work per chunk of series (inputs plus outputs): about 8 MB.
const CHUNK_ENTRIES: usize = 1 << 20;

/// filter_batch(F, H, Q, R, x0, P0, zs, form="joseph", covariances=False) → dict with
/// "x" (series, steps, n): x_{k|k} of every series; "P_last" (series, n, n): each
/// series' last P_{k|k}; "log_likelihood" (series,); and with covariances=True "P"
/// (series, steps, n, n). zs is (series, steps, m), or (series, steps) for m = 1, NaN
/// for a missing entry. Every series starts from the prior (x0, P0) of its first
/// measurement and is filtered as `filter` filters one (update with zs[s, k], then
/// predict), equal to it to round-off. The model takes no control input and no S; the
/// form is "joseph" or "standard".
#[pyfunction]
#[pyo3(signature = (F, H, Q, R, x0, P0, zs, form = "joseph", covariances = false))]
pub(crate) fn filter_batch<'py>(
    py: Python<'py>,
    F: &Bound<'py, PyAny>,
    H: &Bound<'py, PyAny>,
    Q: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    x0: &Bound<'py, PyAny>,
    P0: &Bound<'py, PyAny>,
    zs: &Bound<'py, PyAny>,
    form: &str,
    covariances: bool,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| run_batch(py, [F, H, Q, R, x0, P0, zs], form, covariances))
}

/// [`filter_batch`]'s work.
fn run_batch<'py>(
    py: Python<'py>,
    [F, H, Q, R, x0, P0, zs]: [&Bound<'py, PyAny>; 7],
    form: &str,
    covariances: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let err = engine("filter_batch");
    let form = covariance_form(form)?;
    let (F, H, Q, R) = (mat(F, "F")?, mat(H, "H")?, mat(Q, "Q")?, mat(R, "R")?);
    let (n, m) = (F.nrows(), H.nrows());
    let model = Model::new(DynDims::new(n, m, 0).map_err(&err)?, &F, &H, &Q, &R).map_err(&err)?;
    let batch = BatchFilter::new(&model, form)
        .map_err(&err)?
        .with_covariances(covariances);
    let mut x0v = vec![0.0; n];
    crate::convert::read_vector(x0, "x0", n, true, false, &mut x0v)?;
    let P0 = mat(P0, "P0")?;

    let zs = crate::imm::as_array(zs, "zs")?;
    let arr = float_array(&zs, "zs")?;
    let ro = arr.readonly();
    let view = ro.as_array();
    let view = match (view.ndim(), m) {
        (3, _) if view.shape()[2] == m => view,
        (2, 1) => view.insert_axis(Axis(2)),
        _ => {
            return Err(value_error(format!(
                "zs has shape {}, expected (series, steps, {m}){}",
                shape_str(view.shape()),
                if m == 1 { " or (series, steps)" } else { "" }
            )));
        }
    };
    let (series, steps) = (view.shape()[0], view.shape()[1]);

    let means = np_zeros(py, &[series, steps, n])?;
    let last = np_zeros(py, &[series, n, n])?;
    let ll = np_zeros(py, &[series])?;
    let covs = if covariances {
        Some(np_zeros(py, &[series, steps, n, n])?)
    } else {
        None
    };
    let per_series = steps
        .saturating_mul(m + n + if covariances { n * n } else { 0 })
        .max(1);
    let chunk = (CHUNK_ENTRIES / per_series).max(1).div_ceil(LANES) * LANES;
    let mut z = Vec::new();
    let mut start = 0;
    while start < series {
        py.check_signals()?;
        let end = (start + chunk).min(series);
        z.clear();
        z.extend(view.slice(s![start..end, .., ..]).iter().copied());
        let out = py
            .detach(|| batch.run(&x0v, &P0, &z, end - start))
            .map_err(|e| match e {
                kalman::Error::InSeries { series, error } => {
                    value_error(format!("filter_batch: series {}: {error}", start + series))
                }
                e => err(e),
            })?;
        let copy = |a: &Bound<'py, numpy::PyArrayDyn<f64>>, per: usize, src: &[f64]| {
            let mut w = a.readwrite();
            let dst = w
                .as_slice_mut()
                .map_err(|e| value_error(format!("filter_batch: output array: {e}")))?;
            dst[start * per..end * per].copy_from_slice(src);
            PyResult::Ok(())
        };
        copy(&means, steps * n, &out.means)?;
        copy(&last, n * n, &out.last_covariances)?;
        copy(&ll, 1, &out.log_likelihood)?;
        if let Some(c) = &covs {
            copy(c, steps * n * n, &out.covariances)?;
        }
        start = end;
    }
    let d = PyDict::new(py);
    d.set_item("x", means)?;
    d.set_item("P_last", last)?;
    d.set_item("log_likelihood", ll)?;
    if let Some(c) = covs {
        d.set_item("P", c)?;
    }
    Ok(d)
}
