//! Users' own models and recorded data through the engine: `filter`, `discretize` and
//! `steady-state`.
//!
//! Formats (see [`model_file`] and [`data`] for every rule):
//!
//! - **Discrete model** (`.json` or `.toml`): `dt`, `F` (n×n), `H` (m×n), `Q` (n×n), `R`
//!   (m×m), optional `B` (n×p), `D` (m×p), `S` (n×m, `E[w_k v_kᵀ]`), `x0` (n, default 0),
//!   `P0` (n×n, required by `filter`). Matrices are row-major nested arrays.
//! - **Continuous model**: `A` (n×n), `C` (m×n), optional `B` (n×p), `D` (m×p), `G` (n×q,
//!   default I), `Qc` (q×q noise intensity, default 0), `R` (m×m, covariance of one
//!   sample's measurement noise, copied to the discrete model), `x0`, `P0` (the prior at the
//!   first row; `filter` samples the model at the record's own intervals, [`timing`]).
//! - Either kind may name its channels: `channels` (m names, checked by [`model_file`]).
//! - **Data CSV**: header `t,z1,…,zm[,u1,…,up]` (or the channel names for the z columns); an
//!   empty or `NaN` z cell is missing; `t` never decreases. `u` on row k drives the
//!   transition from row k to row k + 1 (and `D u_k` enters z_k).
//! - **Estimates CSV**: `t,x1,…,xn,P1_1,…,Pn_n,nis` (every `Pi_j` with
//!   `--full-covariance`); row k is the posterior after the update with data row k; `nis` is
//!   `NaN` on a row without measurements.
//!
//! Memory: `filter` streams — one data row in, one estimates row out through a buffered
//! writer — so its peak memory does not depend on the CSV's length (6 MB for 10⁶ rows at
//! n = 7, m = 2); `filter --smooth` must keep the pass (about 2 kB per row at n = 7).
//!
//! Errors are [`Error::Invalid`] (exit code 2) naming the file and, for the CSV, the line
//! and column, or for a model the matrix and the rule broken. Every output is written to a
//! temporary name and renamed only on success ([`crate::output`]).
//!
//! The filtering, smoothing, Riccati and discretisation mathematics are the `kalman` and
//! `model` crates'; this module only parses, validates, streams and writes.
#![allow(non_snake_case)]

pub mod data;
pub mod diagnostics;
mod filtering;
pub mod model_file;
pub mod timing;

use std::path::{Path, PathBuf};

use faer::Mat;
use nalgebra::DMatrix;

use crate::error::{Error, Result, ValueError};
pub(crate) use filtering::engine_continuous;
pub use filtering::{FilterArgs, Form, filter};
use filtering::{engine_model, model_error};
use model_file::{DiscreteFile, to_rows};

/// Discretisation method of `discretize --method`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MethodArg {
    /// Zero-order hold.
    Zoh,
    /// Tustin (bilinear).
    Tustin,
    /// Tustin pre-warped at ω rad/s.
    TustinPrewarp(f64),
    /// Forward Euler.
    Euler,
    /// Backward Euler.
    BackwardEuler,
}

impl std::str::FromStr for MethodArg {
    type Err = ValueError;
    fn from_str(s: &str) -> std::result::Result<Self, ValueError> {
        match s {
            "zoh" => Ok(MethodArg::Zoh),
            "tustin" => Ok(MethodArg::Tustin),
            "euler" => Ok(MethodArg::Euler),
            "backward-euler" => Ok(MethodArg::BackwardEuler),
            _ => match s.strip_prefix("tustin-prewarp:") {
                Some(w) => match w.parse::<f64>() {
                    Ok(w) if w.is_finite() && w > 0.0 => Ok(MethodArg::TustinPrewarp(w)),
                    _ => Err(ValueError::Prewarp(w.to_string())),
                },
                None => Err(ValueError::UnknownMethod(s.to_string())),
            },
        }
    }
}

/// Process-noise convention of `discretize --noise`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum NoiseArg {
    /// Exact covariance of the integrated noise (Van Loan).
    VanLoan,
    /// The noise held over the step with variance Qc/Δt, entering through the method's
    /// input map (the papers' convention).
    IntensityOverDt,
}

/// Options of `scenarios discretize`.
#[derive(Debug, Clone, clap::Args)]
pub struct DiscretizeArgs {
    /// Continuous model (.json or .toml) with A, C and optional B, D, G, Qc, R.
    #[arg(long, value_name = "CONT")]
    pub model: PathBuf,
    /// Sampling interval in seconds.
    #[arg(long, allow_negative_numbers = true, value_parser = parse_dt)]
    pub dt: f64,
    /// zoh, tustin, tustin-prewarp:W (W in rad/s), euler (forward) or backward-euler.
    #[arg(long, value_parser = parse_method)]
    pub method: MethodArg,
    /// How the noise intensity Qc becomes the discrete Q.
    #[arg(long, value_enum, default_value_t = NoiseArg::VanLoan)]
    pub noise: NoiseArg,
    /// Discrete model to write (.json, or .toml; `-`: JSON on standard output).
    #[arg(long, value_name = "DISC.json")]
    pub out: PathBuf,
}

/// A sampling interval: a finite number > 0 (seconds).
fn parse_dt(s: &str) -> std::result::Result<f64, ValueError> {
    match s.trim().parse::<f64>() {
        Ok(dt) if dt.is_finite() && dt > 0.0 => Ok(dt),
        Ok(_) => Err(ValueError::NotPositiveSeconds),
        Err(_) => Err(ValueError::NotSeconds),
    }
}

fn parse_method(s: &str) -> std::result::Result<MethodArg, ValueError> {
    s.parse()
}

/// Options of `scenarios steady-state`.
#[derive(Debug, Clone, clap::Args)]
pub struct SteadyStateArgs {
    /// Model file (.json or .toml). Discrete (F, H, Q, R and optional S): the filter's
    /// steady state. Continuous (A, G, Qc, C, R): the Kalman–Bucy steady state, with R
    /// read as the measurement noise intensity.
    #[arg(long, value_name = "MODEL")]
    pub model: PathBuf,
    /// JSON file to write: {"P", "P_post", "K", "residual", …}, or {"P", "K", "residual",
    /// …} for a continuous model (`-`: standard output).
    #[arg(long, value_name = "SS.json")]
    pub out: PathBuf,
}

/// `scenarios discretize`: discretises a continuous model with `model::discretize` and
/// writes the discrete model file.
///
/// # Errors
/// [`Error::Usage`] for a bad `--dt`; [`Error::Invalid`] for a bad model (shape, NaN, `Qc`
/// not symmetric or not PSD, a singular `I − Aτ`); [`Error::Write`].
pub fn discretize(args: &DiscretizeArgs) -> Result<()> {
    if !(args.dt.is_finite() && args.dt > 0.0) {
        return Err(Error::Usage(format!(
            "--dt {} is invalid: it must be finite and > 0",
            args.dt
        )));
    }
    let path = args.model.as_path();
    let dest = crate::output::destination(&args.out, &[("--model", path)])?;
    let c = model_file::load_continuous(path)?;
    // The model crate calls the noise intensity W; the file calls it Qc.
    let err = |e: model::Error| model_error(path, e.to_string().replace("matrix W", "matrix Qc"));
    let sys = model::ContinuousSs::new(c.A.clone(), c.B.clone(), c.C.clone(), c.D.clone())
        .and_then(|s| s.with_noise(c.G.clone(), c.Qc.clone()))
        .map_err(err)?;
    let method = match args.method {
        MethodArg::Zoh => model::Discretization::Zoh,
        MethodArg::Tustin => model::Discretization::Tustin,
        MethodArg::TustinPrewarp(omega) => model::Discretization::TustinPrewarp { omega },
        MethodArg::Euler => model::Discretization::ForwardEuler,
        MethodArg::BackwardEuler => model::Discretization::BackwardEuler,
    };
    let noise = match args.noise {
        NoiseArg::VanLoan => model::NoiseConvention::VanLoan,
        NoiseArg::IntensityOverDt => model::NoiseConvention::IntensityOverDt,
    };
    let d = model::discretize(&sys, args.dt, method, noise).map_err(|e| match e {
        model::Error::InvalidParameter { .. } => Error::Usage(e.to_string()),
        model::Error::StepTooLarge { .. } => {
            Error::Usage(format!("--dt {}: {e} (A from {})", args.dt, path.display()))
        }
        e => err(e),
    })?;
    let mut file = discrete_file(&d, c.R.as_ref()).map_err(err)?;
    file.channels = c.channels.clone();
    // The prior carries over when the continuous file gives one.
    if let Some(P0) = &c.P0 {
        file.x0 = Some(c.x0.iter().copied().collect());
        file.P0 = Some(to_rows(P0));
    }
    write_model(&dest, &file)
}

/// The discrete model file of a discretised system, its noise in filter form by
/// [`model::DiscreteSs::filter_noise`]: `Q = G Q Gᵀ`, `S = G Q Jᵀ` (written only when
/// non-zero) and `R = R_c + J Q Jᵀ` (written when `R_c` is given or `J ≠ 0`).
fn discrete_file(d: &model::DiscreteSs, R: Option<&DMatrix<f64>>) -> model::Result<DiscreteFile> {
    let noise = d.filter_noise(R)?;
    let written = R.is_some() || noise.r.iter().any(|v| v.abs() > 0.0);
    let p = d.n_inputs();
    Ok(DiscreteFile {
        dt: d.dt(),
        F: to_rows(d.f()),
        B: (p > 0).then(|| to_rows(d.b())),
        H: to_rows(d.h()),
        D: (p > 0).then(|| to_rows(d.d())),
        Q: to_rows(&noise.q),
        R: written.then(|| to_rows(&noise.r)),
        S: noise.s.as_ref().map(to_rows),
        x0: None,
        P0: None,
        channels: None,
    })
}

/// Writes a discrete model as JSON, or TOML when the destination's name ends in `.toml`.
pub(crate) fn write_model(dest: &crate::output::Destination, file: &DiscreteFile) -> Result<()> {
    crate::output::write_bytes_to(dest, model_text(dest, file)?.as_bytes())
}

/// Whether a destination's name ends in `.toml` (case-insensitive; standard output gets
/// JSON).
fn is_toml(dest: &crate::output::Destination) -> bool {
    match dest {
        crate::output::Destination::File(path) => path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("toml")),
        crate::output::Destination::Stdout => false,
    }
}

/// The text [`write_model`] writes to `dest`.
pub(crate) fn model_text(dest: &crate::output::Destination, file: &DiscreteFile) -> Result<String> {
    if is_toml(dest) {
        toml::to_string(file).map_err(|source| Error::SerialiseToml {
            dest: dest.to_string(),
            source,
        })
    } else {
        Ok(model_json(file))
    }
}

/// The text of a continuous model file (what `fit` writes for a continuous model, read back
/// by `filter`, `fit` and `discretize`): JSON, or TOML for a `.toml` destination.
pub(crate) fn continuous_model_text(
    dest: &crate::output::Destination,
    m: &model_file::ContinuousModel,
) -> Result<String> {
    use serde_json::json;
    let rows = |a: &DMatrix<f64>| json!(to_rows(a));
    let p = m.p();
    let fields = [
        ("A", Some(rows(&m.A))),
        ("B", (p > 0).then(|| rows(&m.B))),
        ("G", Some(rows(&m.G))),
        ("Qc", Some(rows(&m.Qc))),
        ("C", Some(rows(&m.C))),
        ("D", (p > 0).then(|| rows(&m.D))),
        ("R", m.R.as_ref().map(rows)),
        ("x0", Some(json!(m.x0.as_slice()))),
        ("P0", m.P0.as_ref().map(rows)),
        ("channels", m.channels.as_ref().map(|c| json!(c))),
    ];
    if is_toml(dest) {
        let table: serde_json::Map<String, serde_json::Value> = fields
            .into_iter()
            .filter_map(|(k, v)| v.map(|v| (k.to_string(), v)))
            .collect();
        toml::to_string(&table).map_err(|source| Error::SerialiseToml {
            dest: dest.to_string(),
            source,
        })
    } else {
        Ok(json_object(&fields))
    }
}

/// A JSON object with the fields in the given order, one matrix row per line (readable
/// and diff-friendly); `None` fields are left out.
fn json_object(fields: &[(&str, Option<serde_json::Value>)]) -> String {
    let body: Vec<String> = fields
        .iter()
        .filter_map(|(name, v)| v.as_ref().map(|v| (name, v)))
        .map(|(name, v)| match v.as_array() {
            Some(rows) if !rows.is_empty() && rows.iter().all(serde_json::Value::is_array) => {
                let lines: Vec<String> = rows.iter().map(ToString::to_string).collect();
                format!("  \"{name}\": [\n    {}\n  ]", lines.join(",\n    "))
            }
            _ => format!("  \"{name}\": {v}"),
        })
        .collect();
    format!("{{\n{}\n}}\n", body.join(",\n"))
}

/// A discrete model file as JSON (fields in the documented order).
fn model_json(f: &DiscreteFile) -> String {
    use serde_json::json;
    let opt = |m: &Option<model_file::Rows>| m.as_ref().map(|m| json!(m));
    json_object(&[
        ("dt", Some(json!(f.dt))),
        ("F", Some(json!(f.F))),
        ("B", opt(&f.B)),
        ("H", Some(json!(f.H))),
        ("D", opt(&f.D)),
        ("Q", Some(json!(f.Q))),
        ("R", opt(&f.R)),
        ("S", opt(&f.S)),
        ("x0", f.x0.as_ref().map(|x| json!(x))),
        ("P0", opt(&f.P0)),
        ("channels", f.channels.as_ref().map(|c| json!(c))),
    ])
}

fn faer_rows(m: faer::MatRef<'_, f64>) -> model_file::Rows {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

/// The Kalman–Bucy steady state of a continuous model (the filter CARE
/// A P + P Aᵀ − P Cᵀ R⁻¹ C P + G Qc Gᵀ = 0, R the measurement noise intensity) as the
/// JSON text `steady-state` writes: {"P", "K": P Cᵀ R⁻¹, "residual", "iterations",
/// "time": "continuous"}.
fn continuous_steady_state(path: &Path, model: &model_file::ContinuousModel) -> Result<String> {
    let R = model.R.as_ref().ok_or_else(|| Error::Invalid {
        path: path.to_path_buf(),
        message: "the continuous steady state needs R, the measurement noise intensity (m×m)"
            .to_owned(),
    })?;
    let W = &model.G * &model.Qc * model.G.transpose();
    let ss = kalman::riccati::Care::new(&model.A, &model.C, &W, R)
        .and_then(|c| c.solve())
        .map_err(|e| solver_error(path, e))?;
    let m = |a: &Mat<f64>| Some(serde_json::json!(faer_rows(a.as_ref())));
    Ok(json_object(&[
        ("P", m(&ss.covariance)),
        ("K", m(&ss.gain)),
        ("residual", Some(serde_json::json!(ss.relative_residual))),
        ("iterations", Some(serde_json::json!(ss.iterations))),
        ("time", Some(serde_json::json!("continuous"))),
    ]))
}

/// A Riccati solver's error on the model file at `path`: a solve that did not converge or
/// failed its check is a computation failure ([`Error::KalmanOnFile`], exit 1), anything
/// else a problem with the model ([`model_error`]).
fn solver_error(path: &Path, e: kalman::Error) -> Error {
    match e {
        kalman::Error::RiccatiNoConvergence { .. } | kalman::Error::RiccatiCheck { .. } => {
            Error::KalmanOnFile {
                path: path.to_path_buf(),
                context: "steady state",
                source: e,
            }
        }
        e => model_error(path, e),
    }
}

/// `scenarios steady-state`: the steady state of a discrete model's filter, from `kalman`'s
/// DARE solver (structured doubling with PBH detectability / stabilisability checks), or
/// of a continuous model's Kalman–Bucy filter from its CARE solver (see
/// `continuous_steady_state`).
///
/// Writes `{"P": prior covariance (the DARE solution), "P_post": posterior covariance,
/// "K": gain P Hᵀ Σ⁻¹, "residual": ‖DARE residual‖_F / ‖P‖_F, "predictor_gain":
/// (F P Hᵀ + S) Σ⁻¹, "innovation_covariance": Σ = H P Hᵀ + R, "iterations": doubling steps}`.
///
/// # Errors
/// [`Error::Invalid`] for a bad model, or one that has no steady state (not detectable, not
/// stabilisable, R not positive definite); [`Error::KalmanOnFile`] (context "steady state")
/// if the solver does not converge or its residual check fails; [`Error::Write`].
pub fn steady_state(args: &SteadyStateArgs) -> Result<()> {
    let path = args.model.as_path();
    let dest = crate::output::destination(&args.out, &[("--model", path)])?;
    let model = match model_file::load_any(path)? {
        model_file::AnyModel::Discrete(model) => model,
        model_file::AnyModel::Continuous(model) => {
            let text = continuous_steady_state(path, &model)?;
            return crate::output::write_bytes_to(&dest, text.as_bytes());
        }
    };
    // The engine's model checks symmetry and PSD of Q, R and the joint noise covariance.
    engine_model(path, &model)?;
    let dare = kalman::riccati::Dare::new(&model.F, &model.H, &model.Q, &model.R);
    let dare = match &model.S {
        Some(S) => dare.and_then(|d| d.cross_covariance(S)),
        None => dare,
    };
    let ss = dare
        .and_then(|d| d.solve())
        .map_err(|e| solver_error(path, e))?;
    let m = |a: &Mat<f64>| Some(serde_json::json!(faer_rows(a.as_ref())));
    let text = json_object(&[
        ("P", m(&ss.prior)),
        ("P_post", m(&ss.posterior)),
        ("K", m(&ss.gain)),
        ("residual", Some(serde_json::json!(ss.relative_residual))),
        ("predictor_gain", m(&ss.predictor_gain)),
        ("innovation_covariance", m(&ss.innovation_cov)),
        ("iterations", Some(serde_json::json!(ss.iterations))),
    ]);
    crate::output::write_bytes_to(&dest, text.as_bytes())
}
