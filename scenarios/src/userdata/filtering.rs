//! `scenarios filter`: a data CSV through the filter engine, one row at a time (read one
//! row ahead, since a step predicts over the interval to the next row), with the model of
//! each step from [`super::timing`]'s rule, the wild-point gate, the smoother and the
//! diagnostics.
#![allow(non_snake_case)]

use std::path::{Path, PathBuf};

use nalgebra::DMatrix;

use super::data::{self, DataReader, Row};
use super::diagnostics;
use super::model_file::{self, AnyModel, ContinuousModel, DiscreteModel};
use super::timing;
use crate::error::{Error, Result, ValueError};

/// Covariance-update form of `filter --form`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Form {
    /// `P⁺ = (I − KH) P (I − KH)ᵀ + K R Kᵀ` (the default).
    Joseph,
    /// `P⁺ = P − K Σ Kᵀ`, symmetrised.
    Standard,
    /// A square-root factor propagated by orthogonal triangularisation.
    Sqrt,
}

/// Options of `scenarios filter`.
#[derive(Debug, Clone, clap::Args)]
pub struct FilterArgs {
    /// Model (.json or .toml): continuous (A, C, R, P0 and optional B, D, G, Qc, x0; sampled
    /// at the record's own time stamps) or discrete (dt, F, H, Q, R, P0 and optional B, D, S,
    /// x0; the record's spacing must then be dt).
    #[arg(long, value_name = "MODEL")]
    pub model: PathBuf,
    /// Data CSV: header t,z1,…,zm[,u1,…,up] (or the model's channel names for z1…zm); an
    /// empty or NaN z cell is a missing value; t never decreases (two rows with one t are one
    /// instant).
    #[arg(long, value_name = "Z.csv")]
    pub data: PathBuf,
    /// Estimates CSV to write: t,x1,…,xn,P1_1,…,Pn_n,nis (`-`: standard output).
    #[arg(long, value_name = "EST.csv")]
    pub out: PathBuf,
    /// Reject wild points: each present z entry whose normalised innovation e_i²/Σ_ii
    /// exceeds the χ²(1) quantile of probability P (e.g. 0.9999) is dropped before the
    /// update, which uses the entries kept. The smoother and the diagnostics see the gated
    /// pass.
    #[arg(long, value_name = "P", allow_negative_numbers = true, value_parser = parse_probability)]
    pub gate: Option<f64>,
    /// Write every entry the gate rejected to this CSV: t,channel,value,nis (channel named
    /// as the data column, e.g. z2; nis = e_i²/Σ_ii).
    #[arg(long, value_name = "REJ.csv", requires = "gate")]
    pub rejected: Option<PathBuf>,
    /// Covariance-update form.
    #[arg(long, value_enum, default_value_t = Form::Joseph)]
    pub form: Form,
    /// Write RTS-smoothed estimates instead of streaming the filtered ones. Smoothing needs
    /// the whole forward pass, so it is kept in memory: about 2 kB per row at n = 7
    /// (0.5 kB at n = 2), i.e. 2 GB for 10⁶ rows.
    #[arg(long)]
    pub smooth: bool,
    /// Write every covariance entry Pi_j instead of the diagonal.
    #[arg(long)]
    pub full_covariance: bool,
    /// Also write innovation diagnostics (JSON) of the forward pass: the log-likelihood, the
    /// mean NIS with its χ² 95 % band, the fraction of steps whose NIS is outside its
    /// per-step 95 % band, and each channel's standardised-innovation autocorrelation with
    /// the Ljung–Box test (`-`: standard output, when --out is a file). Written only if the
    /// estimates are.
    #[arg(long, value_name = "DIAG.json")]
    pub diagnostics: Option<PathBuf>,
    /// Lags of the autocorrelation and the Ljung–Box test in --diagnostics.
    #[arg(long, value_name = "H", default_value_t = 20, requires = "diagnostics",
          value_parser = clap::value_parser!(u32).range(1..))]
    pub diagnostics_lags: u32,
}

/// A gate probability: a number strictly between 0 and 1.
fn parse_probability(s: &str) -> std::result::Result<f64, ValueError> {
    match s.trim().parse::<f64>() {
        Ok(p) if p > 0.0 && p < 1.0 => Ok(p),
        _ => Err(ValueError::NotProbability),
    }
}

/// A library error about the model in `path`, surfaced as an input error (exit code 2).
pub(super) fn model_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::invalid(path, format!("model: {e}"))
}

/// The engine's model built from a parsed file: symmetry, PSD of `Q`, `R`, `[[R, Sᵀ], [S,
/// Q]]` are checked here by `kalman`.
pub(super) fn engine_model(
    path: &Path,
    m: &DiscreteModel,
) -> Result<kalman::Model<kalman::DynDims>> {
    let dims = kalman::DynDims::new(m.n(), m.m(), m.p()).map_err(|e| model_error(path, e))?;
    let mut model =
        kalman::Model::new(dims, &m.F, &m.H, &m.Q, &m.R).map_err(|e| model_error(path, e))?;
    if m.p() > 0 {
        model = model.with_control(&m.B).map_err(|e| model_error(path, e))?;
    }
    if let Some(S) = &m.S {
        model = model
            .with_cross_covariance(S)
            .map_err(|e| model_error(path, e))?;
    }
    Ok(model)
}

/// Checks the data header against the model's m and p.
fn check_columns<R: std::io::Read>(
    model_path: &Path,
    m: usize,
    p: usize,
    reader: &DataReader<R>,
) -> Result<()> {
    if reader.m() != m {
        return Err(Error::invalid(
            reader.path(),
            format!(
                "line 1: the header has {} measurement columns (z1…z{}) but {} has m = {} (rows of H)",
                reader.m(),
                reader.m(),
                model_path.display(),
                m
            ),
        ));
    }
    if reader.p() != p {
        return Err(Error::invalid(
            reader.path(),
            format!(
                "line 1: the header has {} control columns (u…) but {} has p = {} (columns of B)",
                reader.p(),
                model_path.display(),
                p
            ),
        ));
    }
    Ok(())
}

/// Subtracts the feed-through `D u` from `z` (missing entries stay missing).
fn remove_feedthrough(D: &DMatrix<f64>, row: &mut Row) {
    if D.ncols() == 0 {
        return;
    }
    for (i, z) in row.z.iter_mut().enumerate() {
        let du: f64 = (0..D.ncols()).map(|j| D[(i, j)] * row.u[j]).sum();
        *z -= du;
    }
}

/// The engine's covariance form of `--form`.
fn engine_form(form: Form) -> kalman::CovarianceForm {
    match form {
        Form::Joseph => kalman::CovarianceForm::Joseph,
        Form::Standard => kalman::CovarianceForm::Standard,
        Form::Sqrt => kalman::CovarianceForm::SquareRoot,
    }
}

/// The refusal of a model file without `P0`.
fn missing_p0(path: &Path) -> Error {
    Error::invalid(
        path,
        "matrix P0 is missing (shape: filter needs the initial covariance P0, n×n)",
    )
}

/// The filter engine built from a parsed discrete model, with its prior.
fn engine_filter(
    path: &Path,
    m: &DiscreteModel,
    form: Form,
) -> Result<kalman::Filter<kalman::DynDims>> {
    let P0 = m.P0.as_ref().ok_or_else(|| missing_p0(path))?;
    kalman::Filter::new(
        engine_model(path, m)?,
        m.x0.as_slice(),
        P0,
        engine_form(form),
    )
    .map_err(|e| model_error(path, e))
}

/// The sampler of a continuous model file: `W = G Qc Gᵀ`, R required.
fn engine_sampler(path: &Path, c: &ContinuousModel) -> Result<kalman::sampling::Sampler> {
    let R = c.R.as_ref().ok_or_else(|| {
        Error::invalid(
            path,
            "matrix R is missing (shape: filter needs R, m×m, the covariance of one sample's \
             measurement noise)",
        )
    })?;
    let model = engine_continuous(path, c, R)?;
    kalman::sampling::Sampler::new(model, SAMPLER_CAPACITY)
        .map_err(|e| model_error(path, e.to_string()))
}

/// The engine's continuous model of a continuous model file with the measurement noise `R`:
/// `W = G Qc Gᵀ` and the control input `B`, every check naming the file's matrices.
pub(crate) fn engine_continuous(
    path: &Path,
    c: &ContinuousModel,
    R: &DMatrix<f64>,
) -> Result<kalman::sampling::ContinuousModel> {
    let W = &c.G * &c.Qc * c.G.transpose();
    let err = |e: kalman::Error| model_error(path, e.to_string().replace("matrix W", "G Qc Gᵀ"));
    let model = kalman::sampling::ContinuousModel::new(&c.A, &c.C, &W, R).map_err(err)?;
    if c.p() > 0 {
        model.with_control(&c.B).map_err(err)
    } else {
        Ok(model)
    }
}

/// Distinct intervals the continuous model's sampler keeps: a clock quantised to a few
/// hundred values pays once per value.
const SAMPLER_CAPACITY: usize = 256;

/// What `filter` runs: the model's sizes and feed-through, how each step's model is found,
/// and the filter.
struct Engine {
    n: usize,
    channels: Option<Vec<String>>,
    D: DMatrix<f64>,
    m: usize,
    p: usize,
    dynamics: Dynamics,
    kf: kalman::Filter<kalman::DynDims>,
}

/// How each step's model is found (see [`super::timing`]).
enum Dynamics {
    /// A discrete model: its own model at every step, the spacing checked against `dt`.
    Fixed(f64),
    /// A continuous model sampled at each interval.
    Sampled(Box<kalman::sampling::Sampler>),
}

fn engine(path: &Path, model: &AnyModel, form: Form) -> Result<Engine> {
    match model {
        AnyModel::Discrete(d) => Ok(Engine {
            n: d.n(),
            channels: d.channels.clone(),
            D: d.D.clone(),
            m: d.m(),
            p: d.p(),
            dynamics: Dynamics::Fixed(d.dt),
            kf: engine_filter(path, d, form)?,
        }),
        AnyModel::Continuous(c) => {
            let P0 = c.P0.as_ref().ok_or_else(|| missing_p0(path))?;
            let mut sampler = engine_sampler(path, c)?;
            let first = sampler.at(0.0).map_err(|e| model_error(path, e))?.clone();
            let kf = kalman::Filter::new(first, c.x0.as_slice(), P0, engine_form(form))
                .map_err(|e| model_error(path, e))?;
            Ok(Engine {
                n: c.n(),
                channels: c.channels.clone(),
                D: c.D.clone(),
                m: c.m(),
                p: c.p(),
                dynamics: Dynamics::Sampled(Box::new(sampler)),
                kf,
            })
        }
    }
}

/// `scenarios filter`: streams the data CSV through the filter and the estimates to `--out`
/// (memory independent of the CSV's length), or with `--smooth` keeps the pass and writes
/// the RTS-smoothed estimates; with `--diagnostics` also the innovation diagnostics of the
/// forward pass ([`super::diagnostics`]; these keep one number per channel and row), and with
/// `--gate`/`--rejected` the wild points rejected. Each step's model follows [`super::timing`].
///
/// # Errors
/// [`Error::Invalid`] for a bad model or data file (nothing is written), [`Error::Read`] /
/// [`Error::Write`] for I/O.
pub fn filter(args: &FilterArgs) -> Result<()> {
    let (dest, [diag, rejected_dest]) = crate::output::destinations(
        ("--out", &args.out),
        [
            ("--diagnostics", args.diagnostics.as_deref()),
            ("--rejected", args.rejected.as_deref()),
        ],
        &[("--model", &args.model), ("--data", &args.data)],
    )?;
    let model = model_file::load_any(&args.model)?;
    let mut engine = engine(&args.model, &model, args.form)?;
    let mut acc = diag
        .as_ref()
        .map(|_| diagnostics::collector(engine.m))
        .transpose()?;
    let gate = args
        .gate
        .map(|p| kalman::gate::Gate::new(kalman::gate::GateRule::Entries, p, engine.kf.model()))
        .transpose()
        .map_err(|e| Error::Usage(format!("--gate: {e}")))?;
    let file = std::fs::File::open(&args.data).map_err(|source| Error::Read {
        path: args.data.clone(),
        source,
    })?;
    let mut reader = DataReader::with_channels(
        &args.data,
        std::io::BufReader::with_capacity(1 << 16, file),
        engine.channels.as_deref(),
    )?;
    check_columns(&args.model, engine.m, engine.p, &reader)?;
    let mut pass = Pass {
        args,
        dest: &dest,
        engine: &mut engine,
        reader: &mut reader,
        acc: acc.as_mut(),
        gate,
        rejected: Vec::new(),
        rts: args.smooth.then(kalman::smoother::RtsSmoother::new),
        ahead: Row::default(),
        ahead_line: 0,
        state: Ahead::NotRead,
    };
    let diag_text = if args.smooth {
        smooth(&mut pass)?
    } else {
        stream(&mut pass)?
    };
    // The estimates are in place; the diagnostics and the rejections follow, each whole or
    // not at all.
    if let (Some(d), Some(text)) = (diag, diag_text) {
        crate::output::write_bytes_to(&d, text.as_bytes())?;
    }
    match rejected_dest {
        Some(d) => {
            let text = rejected_csv(&pass.rejected, pass.reader);
            crate::output::write_bytes_to(&d, text.as_bytes())
        }
        None => Ok(()),
    }
}

/// One rejected entry: the row's time, the channel (0-based), the value and its e_i²/Σ_ii.
type RejectedEntry = (f64, usize, f64, f64);

/// The `--rejected` CSV: `t,channel,value,nis`, the channel named as the data header names
/// its column, numbers in their shortest round-trip form.
fn rejected_csv<R: std::io::Read>(rows: &[RejectedEntry], names: &DataReader<R>) -> String {
    let mut buf = zmij::Buffer::new();
    let mut text = String::from("t,channel,value,nis\n");
    for &(t, i, v, nis) in rows {
        text.push_str(buf.format(t));
        text.push(',');
        text.push_str(names.channel(i));
        text.push(',');
        text.push_str(buf.format(v));
        text.push(',');
        text.push_str(buf.format(nis));
        text.push('\n');
    }
    text
}

/// The diagnostics text of a collected pass (`None` without `--diagnostics`).
fn diagnostics_text(
    args: &FilterArgs,
    acc: Option<&mut kalman::diagnostics::Innovations>,
) -> Result<Option<String>> {
    acc.map(|a| diagnostics::json(a, args.diagnostics_lags as usize, &args.data))
        .transpose()
}

/// Whether the row after the current one has been read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ahead {
    /// Nothing read yet.
    NotRead,
    /// `ahead` holds the next row.
    Row,
    /// The data ended.
    End,
}

/// One forward pass of `filter`: the options, where the estimates go, the engine, the data
/// (read one row ahead, since a step predicts over the interval to the next row), and, as
/// asked, the innovation accumulator, the gate and its rejections, and the smoother.
struct Pass<'a, R: std::io::Read> {
    args: &'a FilterArgs,
    dest: &'a crate::output::Destination,
    engine: &'a mut Engine,
    reader: &'a mut DataReader<R>,
    acc: Option<&'a mut kalman::diagnostics::Innovations>,
    gate: Option<kalman::gate::Gate>,
    rejected: Vec<RejectedEntry>,
    rts: Option<kalman::smoother::RtsSmoother>,
    ahead: Row,
    ahead_line: u64,
    state: Ahead,
}

/// Streams the filtered estimates to `dest`; returns the diagnostics text, computed before
/// the estimates file is renamed into place, so that a too-short record for the
/// diagnostics writes neither file.
fn stream<R: std::io::Read>(pass: &mut Pass<'_, R>) -> Result<Option<String>> {
    let n = pass.engine.n;
    let (dest, full) = (pass.dest, pass.args.full_covariance);
    write_estimates(dest, n, full, |w, out| {
        let mut row = Row::default();
        let mut P = vec![0.0; n * n];
        while let Some(info) = pass.next(&mut row)? {
            let kf = &pass.engine.kf;
            copy_col_major(kf.covariance(), &mut P);
            // No measurement, no NIS: written as NaN.
            let nis = info.nis.unwrap_or(f64::NAN);
            data::write_estimate(w, out, row.t, kf.state(), &P, full, nis)?;
        }
        diagnostics_text(pass.args, pass.acc.as_deref_mut())
    })
}

impl<R: std::io::Read> Pass<'_, R> {
    /// Reads the next data row into `row` and runs the filter step on it: the gate (if
    /// any), the update, the prediction over the interval to the row after it, and the
    /// diagnostics and the smoother's record of the step. `None` at the end of the data.
    fn next(&mut self, row: &mut Row) -> Result<Option<kalman::StepInfo>> {
        if self.state == Ahead::NotRead {
            self.read_ahead()?;
        }
        if self.state == Ahead::End {
            return Ok(None);
        }
        std::mem::swap(row, &mut self.ahead);
        let line = self.ahead_line;
        self.read_ahead()?;
        remove_feedthrough(&self.engine.D, row);
        let next_t = (self.state == Ahead::Row).then_some(self.ahead.t);
        let (data, ahead_line) = (self.reader.path(), self.ahead_line);
        let engine = &mut *self.engine;
        let model = match &mut engine.dynamics {
            Dynamics::Fixed(dt) => {
                if let Some(t) = next_t {
                    timing::check_regular(data, ahead_line, &self.args.model, *dt, row.t, t)?;
                }
                None
            }
            Dynamics::Sampled(sampler) => {
                let dt = next_t.map_or(0.0, |t| t - row.t);
                let at = if next_t.is_some() { ahead_line } else { line };
                Some(timing::sample(sampler, data, at, dt)?)
            }
        };
        let kf = &mut engine.kf;
        let z: &[f64] = match &mut self.gate {
            Some(gate) => {
                gate.screen(kf, model.unwrap_or(kf.model()), &row.z)
                    .map_err(|e| step_error(data, line, &e))?;
                self.rejected.extend(
                    gate.rejected()
                        .iter()
                        .map(|r| (row.t, r.entry, r.value, r.nis)),
                );
                gate.kept()
            }
            None => &row.z,
        };
        let u = (!row.u.is_empty()).then_some(row.u.as_slice());
        let info = match model {
            Some(model) => kf.step_with(model, z, u),
            None => kf.step(z, u),
        }
        .map_err(|e| step_error(data, line, &e))?;
        check_finite(kf, data, line)?;
        if let Some(a) = self.acc.as_deref_mut() {
            collect(a, kf, &info)?;
        }
        if let Some(rts) = &mut self.rts {
            rts.record_with(kf, model.unwrap_or(kf.model()))
                .map_err(smoother_error)?;
        }
        Ok(Some(info))
    }

    /// Reads the row after the current one into `ahead`.
    fn read_ahead(&mut self) -> Result<()> {
        self.state = if self.reader.read_row(&mut self.ahead)? {
            self.ahead_line = self.reader.line();
            Ahead::Row
        } else {
            Ahead::End
        };
        Ok(())
    }
}

/// Writes the estimates to `dest`, whole or not at all: the header of an n-state model,
/// then the rows `rows` writes (given the writer and the file's name for its errors).
fn write_estimates<T>(
    dest: &crate::output::Destination,
    n: usize,
    full_covariance: bool,
    rows: impl FnOnce(&mut dyn std::io::Write, &Path) -> Result<T>,
) -> Result<T> {
    let out = PathBuf::from(dest.to_string());
    crate::output::write_to(dest, |w| {
        writeln!(w, "{}", data::estimates_header(n, full_covariance)).map_err(|source| {
            Error::Write {
                path: out.clone(),
                source,
            }
        })?;
        rows(w, &out)
    })
}

/// Adds a step to the diagnostics.
fn collect(
    acc: &mut kalman::diagnostics::Innovations,
    kf: &kalman::Filter<kalman::DynDims>,
    info: &kalman::StepInfo,
) -> Result<()> {
    acc.add(kf, info).map_err(diagnostics::diagnostics_error)
}

/// The library's refusal of a smoother step or of the backward pass.
fn smoother_error(source: kalman::Error) -> Error {
    Error::Kalman {
        context: "smoother",
        source,
    }
}

/// The engine's refusal of the row at `line`.
fn step_error(data: &Path, line: u64, e: &kalman::Error) -> Error {
    Error::invalid(
        data,
        format!("line {line}: the filter rejected the row: {e}"),
    )
}

/// A step after which the filtered or predicted state or covariance is no longer finite is
/// an error naming the row: nothing is written rather than `inf`/`NaN` estimates.
fn check_finite(kf: &kalman::Filter<kalman::DynDims>, data: &Path, line: u64) -> Result<()> {
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    let finite_mat = |m: faer::MatRef<'_, f64>| {
        (0..m.ncols()).all(|j| (0..m.nrows()).all(|i| m[(i, j)].is_finite()))
    };
    if finite(kf.state())
        && finite(kf.predicted_state())
        && finite_mat(kf.covariance())
        && finite_mat(kf.predicted_covariance())
    {
        return Ok(());
    }
    Err(Error::invalid(
        data,
        format!(
            "line {line}: the filter diverged at this row: its state or covariance overflowed \
             (F grows a direction the measurements do not observe, or the data is far from \
             the model)"
        ),
    ))
}

fn copy_col_major(m: faer::MatRef<'_, f64>, out: &mut [f64]) {
    let r = m.nrows();
    for j in 0..m.ncols() {
        for i in 0..r {
            out[i + j * r] = m[(i, j)];
        }
    }
}

/// `filter --smooth`: runs the whole forward pass, recording it in `kalman`'s RTS smoother
/// (3n² + 2n numbers per row, plus the smoothed n×n covariance and mean per row: measured
/// 2 kB per row at n = 7), then the backward pass, then writes. The `nis` column is the
/// forward pass's.
fn smooth<R: std::io::Read>(pass: &mut Pass<'_, R>) -> Result<Option<String>> {
    let n = pass.engine.n;
    let mut times = Vec::new();
    let mut nis = Vec::new();
    let mut row = Row::default();
    while let Some(info) = pass.next(&mut row)? {
        times.push(row.t);
        nis.push(info.nis.unwrap_or(f64::NAN));
    }
    let rts = pass.rts.take().unwrap_or_default();
    let smoothed = if times.is_empty() {
        None
    } else {
        Some(rts.smooth().map_err(smoother_error)?)
    };
    drop(rts);
    let text = diagnostics_text(pass.args, pass.acc.as_deref_mut())?;
    let full = pass.args.full_covariance;
    write_estimates(pass.dest, n, full, |w, out| {
        let Some(s) = &smoothed else {
            return Ok(text);
        };
        let mut x = vec![0.0; n];
        let mut P = vec![0.0; n * n];
        for (k, (&t, &nis)) in times.iter().zip(&nis).enumerate() {
            for (i, xi) in x.iter_mut().enumerate() {
                *xi = s.means[(i, k)];
            }
            copy_col_major(s.covariances[k].as_ref(), &mut P);
            data::write_estimate(w, out, t, &x, &P, full, nis)?;
        }
        Ok(text)
    })
}
