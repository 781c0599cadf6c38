//! `scenarios fit`: learns the free parts of a discrete model file (Q, R as scalar, diagonal
//! or full; x0; a diagonal P0; single entries of F, B, H, Q, R, x0, P0; the intensity of a
//! constant-velocity or constant-acceleration model's Q) from a data CSV by maximum
//! likelihood or EM, and writes the fitted model file and a summary. The mathematics is
//! `kalman::fit`'s; this module parses, checks and writes.
//!
//! `--free` is repeatable and each value a comma-separated list of `Q:scalar|diag|full`,
//! `R:scalar|diag|full`, `x0`, `P0:diag`, entries named 0-based as the summary names them
//! (`F[0,0]`, `B[2,0]`, `H[1,0]`, `Q[0,0]`, `R[1,1]`, `P0[0,0]`, `x0[1]`; a diagonal entry
//! of a covariance is fitted through its logarithm, an off-diagonal one sets its mirror
//! too) and `Q:white-acceleration` (Q = q·∫₀^Δt e^{Aτ} G Gᵀ e^{Aᵀτ} dτ with A = log(F)/Δt a
//! chain of integrators and G the unit inputs of its last states: the one intensity q of
//! a constant-velocity or constant-acceleration model). Every entry not freed keeps its
//! value exactly.
//!
//! `FITTED` is a model file in the input's format with the free entries replaced, read by
//! `scenarios filter` as is. `--summary FIT.json` holds `loglik` (the exact Gaussian
//! log-likelihood of the data under the fitted model, with the `−½ m_k ln 2π` terms),
//! `method`, `iterations`, `converged`, `message`, `estimates` (each freed entry's value by
//! its name), `std_errors` (observed-information standard errors: in the shapes of the
//! matrices freed as a whole, and by name for each freed entry; `null` when the information
//! is not positive definite), `correlation` (`names` and the correlation `matrix` of the
//! parameters, `null` with the standard errors), `unidentified` (for a singular
//! information, each direction it does not identify as the parameters spanning it and
//! their weights), `boundary` (free variances at zero), `aic`, `bic`, `n_params`, `n_obs`.
//! A fit that does not converge is an error (exit code 1) unless `--allow-unconverged`.
#![allow(non_snake_case)]

/// The summary keys every fit writes, as a JSON object: `loglik`, `iterations`,
/// `converged`, `message`, `estimates`, `std_errors`, `correlation` (with the parameters'
/// `names`), `unidentified`, `aic`, `bic`, `n_params`, `n_obs`. `$fit` is the result of
/// either kind of fit (`kalman::fit::Fit` of a discrete model, `kalman::fit::ParametricFit`
/// of a continuous one), which hold these numbers under the same field names; the caller
/// inserts the keys of its own kind.
macro_rules! summary_keys {
    ($fit:expr, names: $names:expr, estimates: $estimates:expr, std_errors: $std_errors:expr) => {{
        let fit = $fit;
        let correlation = fit
            .uncertainty.correlation
            .as_ref()
            .map_or(serde_json::Value::Null, |c| {
                serde_json::json!({"names": $names, "matrix": $crate::fit::faer_rows(c)})
            });
        let mut keys = serde_json::Map::new();
        for (key, value) in [
            ("loglik", serde_json::json!(fit.loglik)),
            ("iterations", serde_json::json!(fit.iterations)),
            ("converged", serde_json::json!(fit.converged)),
            ("message", serde_json::json!(fit.message)),
            ("estimates", serde_json::json!($estimates)),
            ("std_errors", serde_json::json!($std_errors)),
            ("correlation", correlation),
            (
                "unidentified",
                serde_json::json!($crate::fit::unidentified_json(&fit.uncertainty.unidentified)),
            ),
            ("aic", serde_json::json!(fit.aic)),
            ("bic", serde_json::json!(fit.bic)),
            ("n_params", serde_json::json!(fit.theta.len())),
            ("n_obs", serde_json::json!(fit.n_obs)),
        ] {
            keys.insert(key.to_string(), value);
        }
        keys
    }};
}

mod continuous;
pub mod shaping;

use std::path::{Path, PathBuf};

use faer::Mat;
use kalman::fit::{EmOptions, Fit, FitError, Free, MleOptions, Series, StandardMap, System};
use nalgebra::DMatrix;
use serde_json::json;

use crate::error::{Error, Result};
use crate::userdata::data::{DataReader, Row};
use crate::userdata::model_file::{AnyModel, DiscreteFile, DiscreteModel, load_any, to_rows};

/// Estimator of `fit --method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FitMethod {
    /// Maximum likelihood: L-BFGS with the exact gradient (Nelder–Mead fallback).
    Mle,
    /// Expectation–maximisation (Shumway–Stoffer).
    Em,
}

/// Options of `scenarios fit`.
#[derive(Debug, Clone, clap::Args)]
pub struct FitArgs {
    /// Model (.json or .toml), discrete (dt, F, H, Q, R; a regular record) or continuous (A,
    /// C, G, Qc, R, x0, P0; over the record's own time stamps): the fixed parts and the
    /// starting values of the free ones.
    #[arg(long, value_name = "MODEL")]
    pub model: PathBuf,
    /// Data CSV: header t,z1,…,zm[,u1,…,up]; an empty or NaN z cell is a missing value.
    #[arg(long, value_name = "Z.csv")]
    pub data: PathBuf,
    /// What to fit (`fit --help` lists the items): the matrices freed whole, the single
    /// entries and the white-acceleration intensity, one [`FreeSpec`] per `--free`.
    #[arg(
        long,
        value_name = "LIST",
        value_parser = parse_free,
        allow_hyphen_values = true,
        required = true,
        help = "What to fit, comma-separated and repeatable: Q:scalar|diag|full, R:scalar|diag|full \
                (scalar is σ²·I), x0, P0:diag; single entries, 0-based: F[i,j], B[i,j], H[i,j], \
                Q[i,j], R[i,j], P0[i,j], x0[i] (the rest keeps its value exactly); \
                Q:white-acceleration (the one intensity of a constant-velocity or -acceleration Q); \
                a continuous model frees Qc:scalar|diag, R:scalar|diag, x0, P0:diag and the entries \
                A[i,j], Qc[i,j], R[i,j], P0[i,j], x0[i]"
    )]
    pub free: Vec<FreeSpec>,
    /// Estimator.
    #[arg(long, value_enum, default_value_t = FitMethod::Mle)]
    pub method: FitMethod,
    /// Fitted model file to write (.json, or .toml); `-` for standard output (JSON).
    #[arg(long, value_name = "FITTED")]
    pub out: PathBuf,
    /// Summary JSON to write (log-likelihood, standard errors, AIC/BIC, convergence); `-`
    /// for standard output.
    #[arg(long, value_name = "FIT.json")]
    pub summary: Option<PathBuf>,
    /// Write the result even if the estimator did not converge.
    #[arg(long)]
    pub allow_unconverged: bool,
    /// Iteration cap: L-BFGS iterations for mle (default 500; the Nelder–Mead fallback gets
    /// 20 times as many), E/M cycles for em (default 10000).
    #[arg(long, value_name = "N")]
    pub max_iter: Option<usize>,
    /// States with no prior (0-based, comma-separated): the exact diffuse initialisation
    /// (their x0 and P0 ignored), the summary's loglik the diffuse log-likelihood. Discrete
    /// models, mle only.
    #[arg(long, value_name = "STATES", value_delimiter = ',')]
    pub diffuse: Vec<usize>,
}

/// One `--free` value: [`kalman::fit::FreeSpec`], whose parser the command line shares
/// with the Python module.
pub use kalman::fit::FreeSpec;

/// Parses one `--free` value ([`FreeSpec::parse`]); an empty list parses (and is rejected
/// by `fit` as "nothing is free").
///
/// # Errors
/// [`Error::Usage`] naming the malformed item.
pub fn parse_free(s: &str) -> Result<FreeSpec> {
    FreeSpec::parse(&[s]).map_err(free_error)
}

/// `--free: …` for a parse or parameterisation error of the free items.
fn free_error(e: FitError) -> Error {
    match e {
        FitError::Parameters(m) => Error::Usage(format!("--free: {m}")),
        e => Error::Usage(format!("--free: {e}")),
    }
}

fn to_faer(m: &DMatrix<f64>) -> Mat<f64> {
    Mat::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

/// The summary's `unidentified`: each direction the data do not identify, parameter name →
/// weight.
fn unidentified_json(directions: &[Vec<(String, f64)>]) -> Vec<serde_json::Value> {
    directions
        .iter()
        .map(|d| serde_json::Value::Object(d.iter().map(|(n, w)| (n.clone(), json!(w))).collect()))
        .collect()
}

fn faer_rows(m: &Mat<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

/// The engine's system of a model file (P0 defaults to I when it is free and absent).
fn system_of(path: &Path, model: &DiscreteModel, free: Free) -> Result<System> {
    let n = model.n();
    let P0 = match (&model.P0, free.p0_diag) {
        (Some(p), _) => to_faer(p),
        (None, true) => Mat::identity(n, n),
        (None, false) => {
            return Err(Error::invalid(
                path,
                "matrix P0 is missing (fit needs the prior of the first state, or P0:diag free)",
            ));
        }
    };
    let x0: Vec<f64> = model.x0.iter().copied().collect();
    let sys = System::new(
        &to_faer(&model.F),
        &to_faer(&model.H),
        &to_faer(&model.Q),
        &to_faer(&model.R),
        &x0,
        &P0,
    )
    .and_then(|s| {
        if model.p() > 0 {
            s.with_control(&to_faer(&model.B))
        } else {
            Ok(s)
        }
    })
    .map_err(|e| Error::invalid(path, e.to_string()))?;
    sys.model()
        .map_err(|e| Error::invalid(path, e.to_string()))?;
    Ok(sys)
}

fn fit_error(args: &FitArgs, e: FitError) -> Error {
    match e {
        FitError::NothingFree => Error::Usage(
            "--free: nothing is free; list at least one of Q:…, R:…, x0, P0:diag or an entry such as F[0,0]".into(),
        ),
        FitError::Unsupported(m) => Error::Usage(format!("--method: {m}")),
        FitError::NoMeasurements | FitError::NotIdentifiable { .. } | FitError::Data(_) => {
            Error::invalid(&args.data, e.to_string())
        }
        FitError::Model(_) => Error::invalid(&args.model, e.to_string()),
        source => Error::Fit {
            context: "fit",
            source,
        },
    }
}

/// The fitted model file: the input with F, B, H, Q, R, x0, P0 from the fit.
fn fitted_file(model: &DiscreteModel, sys: &System) -> DiscreteFile {
    let p = model.p();
    DiscreteFile {
        dt: model.dt,
        F: faer_rows(&sys.f),
        B: (p > 0).then(|| faer_rows(&sys.b)),
        H: faer_rows(&sys.h),
        D: (p > 0).then(|| to_rows(&model.D)),
        Q: faer_rows(&sys.q),
        R: Some(faer_rows(&sys.r)),
        S: None,
        x0: Some(sys.x0.clone()),
        P0: Some(faer_rows(&sys.p0)),
        channels: model.channels.clone(),
    }
}

fn summary_json(args: &FitArgs, map: &StandardMap, fit: &Fit) -> Result<serde_json::Value> {
    let std_errors = match &fit.uncertainty.covariance {
        Some(cov) => {
            let se = map
                .matrix_std_errors(&fit.theta, cov)
                .map_err(|source| Error::Fit {
                    context: "fit: standard errors of the matrices",
                    source,
                })?;
            let n = map.base().n();
            let p0 = se.p0.map(|d| {
                (0..n)
                    .map(|i| {
                        (0..n)
                            .map(|j| if i == j { d[i] } else { 0.0 })
                            .collect::<Vec<_>>()
                    })
                    .collect::<Vec<_>>()
            });
            let mut o = serde_json::Map::new();
            if let Some(q) = se.q {
                o.insert("Q".into(), json!(faer_rows(&q)));
            }
            if let Some(r) = se.r {
                o.insert("R".into(), json!(faer_rows(&r)));
            }
            if let Some(x) = se.x0 {
                o.insert("x0".into(), json!(x));
            }
            if let Some(p) = p0 {
                o.insert("P0".into(), json!(p));
            }
            for (name, v) in se.params {
                o.insert(name, json!(v));
            }
            serde_json::Value::Object(o)
        }
        None => serde_json::Value::Null,
    };
    let estimates: serde_json::Map<String, serde_json::Value> = map
        .param_values(&fit.theta)
        .map_err(|source| Error::Fit {
            context: "fit: the free entries' values",
            source,
        })?
        .into_iter()
        .map(|(n, v)| (n, json!(v)))
        .collect();
    let mut summary = summary_keys!(
        fit,
        names: kalman::fit::ParamMap::names(map),
        estimates: estimates,
        std_errors: std_errors
    );
    summary.insert(
        "method".into(),
        json!(match args.method {
            FitMethod::Mle => "mle",
            FitMethod::Em => "em",
        }),
    );
    summary.insert("boundary".into(), json!(fit.boundary));
    summary.insert("diffuse".into(), json!(args.diffuse));
    Ok(serde_json::Value::Object(summary))
}

/// The rows of the data CSV `data`, each spaced `dt` after the one before (the discrete
/// model `model`'s interval; [`crate::userdata::timing::check_regular`]).
fn read_regular(
    data: &Path,
    model: &Path,
    dt: f64,
    channels: Option<&[String]>,
) -> Result<(usize, usize, Vec<Row>)> {
    let file = std::fs::File::open(data).map_err(|source| Error::Read {
        path: data.to_path_buf(),
        source,
    })?;
    let mut reader = DataReader::with_channels(data, std::io::BufReader::new(file), channels)?;
    let mut rows: Vec<Row> = Vec::new();
    let mut row = Row::default();
    while reader.read_row(&mut row)? {
        if let Some(last) = rows.last() {
            crate::userdata::timing::check_regular(data, reader.line(), model, dt, last.t, row.t)?;
        }
        rows.push(row.clone());
    }
    Ok((reader.m(), reader.p(), rows))
}

/// `scenarios fit`.
///
/// # Errors
/// [`Error::Usage`] for an empty `--free`; [`Error::Invalid`] for a bad model or data file,
/// a model with `S`, no measurement, a free matrix the data cannot identify;
/// [`Error::Fit`] for a fit that fails, [`Error::FitNotConverged`] for one that (without
/// `--allow-unconverged`) does not converge; [`Error::Write`].
pub fn fit(args: &FitArgs) -> Result<()> {
    let spec = FreeSpec::merge(&args.free).map_err(free_error)?;
    if spec.is_empty() {
        return Err(fit_error(args, FitError::NothingFree));
    }
    let (dest, [summary_dest]) = crate::output::destinations(
        ("--out", &args.out),
        [("--summary", args.summary.as_deref())],
        &[("--model", &args.model), ("--data", &args.data)],
    )?;
    let outputs = Outputs {
        model: &dest,
        summary: summary_dest.as_ref(),
    };
    let model = match load_any(&args.model)? {
        AnyModel::Discrete(d) => d,
        AnyModel::Continuous(c) => return continuous::fit(args, &spec, &c, &outputs),
    };
    if model.S.is_some() {
        return Err(Error::invalid(
            &args.model,
            "fit does not handle the cross-covariance S (remove S, or fit without it)",
        ));
    }
    let (m, p, rows) = read_regular(&args.data, &args.model, model.dt, model.channels.as_deref())?;
    if m != model.m() || p != model.p() {
        return Err(Error::invalid(
            &args.data,
            format!(
                "the data have {m} measurement and {p} input columns, the model has m = {} and p = {}",
                model.m(),
                model.p()
            ),
        ));
    }
    // z − D u: the feed-through is known, so it leaves the likelihood unchanged when removed.
    let mut z = Vec::with_capacity(rows.len() * m);
    let mut u = Vec::with_capacity(rows.len() * p);
    for row in &rows {
        for i in 0..m {
            let du: f64 = (0..p).map(|j| model.D[(i, j)] * row.u[j]).sum();
            z.push(row.z[i] - du);
        }
        u.extend_from_slice(&row.u);
    }
    let series = Series::new(&z, m)
        .and_then(|s| if p > 0 { s.with_inputs(&u, p) } else { Ok(s) })
        .map_err(|e| fit_error(args, e))?;
    let base = system_of(&args.model, &model, spec.free)?;
    let map = spec.map(base, Some(model.dt)).map_err(|e| match e {
        FitError::Parameters(_) => free_error(e),
        e => fit_error(args, e),
    })?;
    let base = map.base().clone();
    let result = match args.method {
        FitMethod::Mle => {
            let mut opts = MleOptions::default();
            if let Some(k) = args.max_iter {
                opts.max_iter = k as u64;
            }
            kalman::fit::check_identifiable(&map, &series).map_err(|e| fit_error(args, e))?;
            let theta0 = map.theta_of(&base, Some(&series));
            if args.diffuse.is_empty() {
                kalman::fit::mle(&map, theta0, &series, &opts)
            } else {
                kalman::fit::mle_diffuse(&map, theta0, &args.diffuse, &series, &opts)
            }
        }
        FitMethod::Em if !args.diffuse.is_empty() => {
            return Err(Error::Usage(
                "--diffuse needs --method mle (EM has no exact diffuse initialisation here)".into(),
            ));
        }
        FitMethod::Em => {
            let mut opts = EmOptions::default();
            if let Some(k) = args.max_iter {
                opts.max_iter = k;
            }
            // A long fit shows where it is, every 2 s on standard error.
            let mut last = std::time::Instant::now();
            let mut report = |k: usize, ll: f64| {
                if last.elapsed() >= std::time::Duration::from_secs(2) {
                    eprintln!(
                        "fit: EM iteration {k} of at most {}, ln L = {ll:.6}",
                        opts.max_iter
                    );
                    last = std::time::Instant::now();
                }
            };
            kalman::fit::em_with_progress(&map, &series, &opts, &mut report)
        }
    }
    .map_err(|e| fit_error(args, e))?;
    if !result.converged && !args.allow_unconverged {
        return Err(Error::FitNotConverged {
            message: result.message,
        });
    }
    let summary = summary_json(args, &map, &result)?;
    let text = crate::userdata::model_text(&dest, &fitted_file(&model, &result.system))?;
    outputs.write(&text, &summary)
}

/// Where a fit's results go: the fitted model (`--out`) and the optional summary
/// (`--summary`), checked against the inputs and each other before the fit runs.
pub(crate) struct Outputs<'a> {
    pub model: &'a crate::output::Destination,
    pub summary: Option<&'a crate::output::Destination>,
}

impl Outputs<'_> {
    /// Writes the fitted model's text and, when asked, the summary: each whole or not at
    /// all, both at once ([`crate::output::write_files`]).
    fn write(&self, model_text: &str, summary: &serde_json::Value) -> Result<()> {
        let Some(dest) = self.summary else {
            return crate::output::write_files(&[(self.model, model_text.as_bytes())]);
        };
        let summary_text = crate::output::json_text(Path::new(&dest.to_string()), summary)?;
        crate::output::write_files(&[
            (self.model, model_text.as_bytes()),
            (dest, summary_text.as_bytes()),
        ])
    }
}
