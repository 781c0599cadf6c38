//! `scenarios fit` on a continuous model file: the intensity `Qc`, `R`, `x0` and `P0` fitted
//! by maximum likelihood over the record's own time stamps (`kalman::fit::SampledMap`: the
//! model sampled exactly at each distinct interval, the likelihood and its exact gradient
//! through the filter-error engine). The time rule is the one `filter` follows
//! ([`crate::userdata::timing`]); entries `A[i,j]` of the drift may be free too (each step
//! then samples its interval at θ); `B`, `C`, `D` and `G` stay fixed.

use std::path::Path;

use kalman::fit::{FitError, Matrix, MleOptions, Param, ParametricFit, SampledMap, Series};
use kalman::fit::{FreeSpec, Structure, Transform};
use nalgebra::DMatrix;
use serde_json::json;

use super::{FitArgs, FitMethod, fit_error};
use crate::error::{Error, Result};
use crate::userdata::data::{DataReader, Row};
use crate::userdata::model_file::ContinuousModel;

/// Fits the continuous model `model` (read from `args.model`) to `args.data`.
///
/// # Errors
/// [`Error::Usage`] for a free item a continuous model does not have (a whole `full`
/// covariance, the white-acceleration form, an entry of a fixed matrix) or `--method em`;
/// [`Error::Invalid`] for a model without `R` or `P0` and for bad data (naming the line);
/// [`Error::Fit`] / [`Error::FitNotConverged`] as the discrete fit; [`Error::Write`].
pub(super) fn fit(
    args: &FitArgs,
    spec: &FreeSpec,
    model: &ContinuousModel,
    outputs: &super::Outputs<'_>,
) -> Result<()> {
    let usage = |m: &str| Err(Error::Usage(format!("--free: {m}")));
    if spec.white_acceleration {
        return usage(
            "Q:white-acceleration is the discrete form; in a continuous model the one \
             white-acceleration intensity is Qc:scalar (the acceleration entering through G)",
        );
    }
    if spec.free.q == Structure::Full || spec.free.r == Structure::Full {
        return usage(
            "a continuous model's Qc and R are freed as scalar, diag or single entries \
             (Qc[i,j], R[i,j]), not full",
        );
    }
    if !args.diffuse.is_empty() {
        return Err(Error::Usage(
            "--diffuse applies to a discrete model; a continuous model's prior is its x0 and P0"
                .into(),
        ));
    }
    if args.method == FitMethod::Em {
        return Err(Error::Usage(
            "--method em needs a discrete model; a continuous model is fitted by mle over the \
             record's own time stamps"
                .into(),
        ));
    }
    let R = model.R.as_ref().ok_or_else(|| {
        Error::invalid(
            &args.model,
            "matrix R is missing (shape: fit needs R, m×m, the covariance of one sample's \
             measurement noise)",
        )
    })?;
    let P0 = model.P0.as_ref().ok_or_else(|| {
        Error::invalid(
            &args.model,
            "matrix P0 is missing (shape: fit needs P0, n×n, the covariance of the first \
             row's state)",
        )
    })?;
    let (t, z, u) = read_stamped(args, model)?;
    let params = params(spec, model);
    let mut starts = Starts {
        qc: model.Qc.clone(),
        r: R.clone(),
        p0: P0.clone(),
    };
    starts.fill(&params, &z, model.m());
    let engine = crate::userdata::engine_continuous(&args.model, model, &starts.r)?;
    let n = model.n();
    let fixed_g = DMatrix::<f64>::from_fn(n, model.G.ncols(), |i, j| model.G[(i, j)]);
    let map = SampledMap::with_noise_input(
        &engine,
        &fixed_g,
        &starts.qc,
        model.x0.as_slice(),
        &starts.p0,
        &t,
        params,
    )
    .map_err(|e| match e {
        FitError::Parameters(m) => Error::Usage(format!("--free: {m}")),
        e => Error::invalid(&args.model, e.to_string()),
    })?;
    let (m, p) = (model.m(), model.p());
    let series = Series::new(&z, m)
        .and_then(|s| if p > 0 { s.with_inputs(&u, p) } else { Ok(s) })
        .map_err(|e| fit_error(args, e))?;
    let mut opts = MleOptions::default();
    if let Some(k) = args.max_iter {
        opts.max_iter = k as u64;
    }
    let result = map.fit(&series, &opts).map_err(|e| fit_error(args, e))?;
    if !result.converged && !args.allow_unconverged {
        return Err(Error::FitNotConverged {
            message: result.message,
        });
    }
    let fitted = map
        .matrices(&result.theta)
        .map_err(|e| fit_error(args, e))?;
    let mut out = model.clone();
    out.A = dense(&fitted.a);
    out.Qc = dense(&fitted.w);
    out.R = Some(dense(&fitted.r));
    out.x0 = nalgebra::DVector::from_vec(fitted.x0.clone());
    out.P0 = Some(dense(&fitted.p0));
    let summary = summary(&map, &result, map.distinct_intervals())?;
    let text = crate::userdata::continuous_model_text(outputs.model, &out)?;
    outputs.write(&text, &summary)
}

/// The record's time stamps, `z − D u` row-major and the inputs (the reader refuses a stamp
/// that is not finite or goes back, naming its line).
fn read_stamped(args: &FitArgs, model: &ContinuousModel) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let data: &Path = &args.data;
    let file = std::fs::File::open(data).map_err(|source| Error::Read {
        path: data.to_path_buf(),
        source,
    })?;
    let mut reader = DataReader::with_channels(
        data,
        std::io::BufReader::new(file),
        model.channels.as_deref(),
    )?;
    let (mut t, mut z, mut u) = (Vec::new(), Vec::new(), Vec::new());
    let mut row = Row::default();
    let mut first = true;
    while reader.read_row(&mut row)? {
        if first && (reader.m() != model.m() || reader.p() != model.p()) {
            return Err(Error::invalid(
                data,
                format!(
                    "the data have {} measurement and {} input columns, the model has m = {} \
                     and p = {}",
                    reader.m(),
                    reader.p(),
                    model.m(),
                    model.p()
                ),
            ));
        }
        first = false;
        t.push(row.t);
        for i in 0..model.m() {
            let du: f64 = (0..model.p()).map(|j| model.D[(i, j)] * row.u[j]).sum();
            z.push(row.z[i] - du);
        }
        u.extend_from_slice(&row.u);
    }
    Ok((t, z, u))
}

/// The free items as the library's parameters: `Qc` entries address the intensity (the
/// `Q` cells of [`SampledMap`]), named `Qc…`; `scalar` is one value on the whole diagonal.
fn params(spec: &FreeSpec, model: &ContinuousModel) -> Vec<Param> {
    let (n, m, q) = (model.n(), model.m(), model.G.ncols());
    let name = |matrix: Matrix, i: usize, j: usize| match matrix {
        Matrix::Q => format!("Qc[{i},{j}]"),
        Matrix::F => format!("A[{i},{j}]"),
        Matrix::X0 => format!("x0[{i}]"),
        other => format!("{}[{i},{j}]", other.name()),
    };
    let entry = |matrix: Matrix, i: usize, j: usize| {
        let transform = if matrix.is_covariance() && i == j {
            Transform::Log
        } else {
            Transform::Identity
        };
        Param::shared(name(matrix, i, j), transform).with(matrix, i, j, 1.0)
    };
    let mut out = Vec::new();
    for (matrix, structure, size, label) in [
        (Matrix::Q, spec.free.q, q, "Qc"),
        (Matrix::R, spec.free.r, m, "R"),
    ] {
        match structure {
            Structure::Scalar => out.push(
                (0..size).fold(Param::shared(label, Transform::Log), |p, i| {
                    p.with(matrix, i, i, 1.0)
                }),
            ),
            Structure::Diag => out.extend((0..size).map(|i| entry(matrix, i, i))),
            Structure::Full | Structure::Fixed => {}
        }
    }
    if spec.free.x0 {
        out.extend((0..n).map(|i| entry(Matrix::X0, i, 0)));
    }
    if spec.free.p0_diag {
        out.extend((0..n).map(|i| entry(Matrix::P0, i, i)));
    }
    out.extend(spec.entries.iter().map(|&(mx, i, j)| entry(mx, i, j)));
    out
}

/// The starting values: the file's, with a free variance the file sets to zero (or leaves
/// out) started at a scale the data give (half the variance of the channel's differences for
/// R, 1 for Qc and P0), so its log transform starts finite.
struct Starts {
    qc: DMatrix<f64>,
    r: DMatrix<f64>,
    p0: DMatrix<f64>,
}

impl Starts {
    fn fill(&mut self, params: &[Param], z: &[f64], m: usize) {
        for prm in params.iter().filter(|p| p.transform() == Transform::Log) {
            for e in prm.entries() {
                let (i, j) = (e.row, e.col);
                let (target, start) = match e.matrix {
                    Matrix::Q => (&mut self.qc, 1.0),
                    Matrix::R => (&mut self.r, difference_variance(z, m, i)),
                    Matrix::P0 => (&mut self.p0, 1.0),
                    _ => continue,
                };
                if i < target.nrows() && j < target.ncols() && target[(i, j)] <= 0.0 {
                    target[(i, j)] = start * e.coefficient;
                }
            }
        }
    }
}

/// Half the variance of the successive differences of channel `i` (a white noise of
/// variance σ² gives σ²), 1 when the channel has fewer than three values.
fn difference_variance(z: &[f64], m: usize, i: usize) -> f64 {
    let values: Vec<f64> = z
        .iter()
        .skip(i)
        .step_by(m)
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let d: Vec<f64> = values.windows(2).map(|w| w[1] - w[0]).collect();
    if d.len() < 2 {
        return 1.0;
    }
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (d.len() - 1) as f64;
    if var > 0.0 && var.is_finite() {
        0.5 * var
    } else {
        1.0
    }
}

fn dense(m: &faer::Mat<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

/// The summary JSON: the same keys as the discrete fit's, the standard errors by parameter
/// name, and the number of distinct intervals sampled.
fn summary(map: &SampledMap, fit: &ParametricFit, distinct: usize) -> Result<serde_json::Value> {
    let values = map.values(&fit.theta).map_err(|source| Error::Fit {
        context: "fit: the free entries' values",
        source,
    })?;
    let estimates: serde_json::Map<String, serde_json::Value> =
        values.iter().map(|(n, v)| (n.clone(), json!(v))).collect();
    // The standard error of v(θ) by the delta method: |dv/dθ|·σ_θ.
    let std_errors = fit
        .uncertainty
        .std_errors
        .as_ref()
        .map_or(serde_json::Value::Null, |se| {
            serde_json::Value::Object(
                map.params()
                    .iter()
                    .zip(&fit.theta)
                    .zip(se)
                    .map(|((p, &th), &s)| {
                        (
                            p.name().to_string(),
                            json!(p.transform().value(th).1.abs() * s),
                        )
                    })
                    .collect(),
            )
        });
    let mut summary = summary_keys!(
        fit,
        names: fit.names,
        estimates: estimates,
        std_errors: std_errors
    );
    summary.insert("method".into(), json!("mle"));
    summary.insert("time".into(), json!("continuous"));
    summary.insert("distinct_intervals".into(), json!(distinct));
    Ok(serde_json::Value::Object(summary))
}
