//! `scenarios flightpath --data FLIGHT.csv`: both estimators on a user's recorded flight,
//! and the flight CSV format itself (read and written here, so a simulated flight written
//! to CSV and read back gives the very same record).
//!
//! **Format.** One CSV file with a header row. Column `t` is the time stamp in seconds
//! (strictly increasing); the channels are `ax, ay, az` (specific force, body axes, m/s²),
//! `p, q, r` (body rates, rad/s) — the IMU —, `V` (true airspeed, m/s), `alpha`, `beta`
//! (angle of attack and sideslip, rad) — air data —, `phi, theta, psi` (Euler angles, rad)
//! — AHRS —, and `north, east, alt` (position, m, altitude up) — GNSS. Every column must be
//! present, in any order. A row holds whatever sampled at that stamp: a sensor's cells are
//! all filled or all empty. The noise levels the estimators assume are the `[flight]`
//! table's of `--config` (the simulation's defaults otherwise).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::data::{FlightData, union_of_stamps};
use super::estimate::{self, Estimates};
use super::parameters::FlightPathParams;
use super::report::{record_plots, table};
use super::summary::{ParameterRow, parameter_rows};
use crate::campaign::ScenarioParams;
use crate::config;
use crate::error::{Error, Result};
use crate::output;

/// The columns, in the order the writer uses.
pub const COLUMNS: [&str; 16] = [
    "t", "ax", "ay", "az", "p", "q", "r", "V", "alpha", "beta", "phi", "theta", "psi", "north",
    "east", "alt",
];

/// The record as CSV text in the documented format (full precision: every value reads back
/// to the same bits).
pub fn flight_csv(data: &FlightData) -> String {
    let imu_t: Vec<f64> = data.imu.iter().map(|s| s.0).collect();
    let st = |c: &[(f64, [f64; 3])]| c.iter().map(|s| s.0).collect::<Vec<f64>>();
    let (a, e, g) = (st(&data.air), st(&data.ahrs), st(&data.gnss));
    let t = union_of_stamps(&[&imu_t, &a, &e, &g]);
    let mut s = COLUMNS.join(",");
    s.push('\n');
    let mut idx = [0usize; 4];
    for tk in t {
        let _ = write!(s, "{tk}");
        let cells = |i: &mut usize, vals: Option<&[f64]>, width: usize, s: &mut String| match vals {
            Some(v) => {
                for x in v {
                    let _ = write!(s, ",{x}");
                }
                *i += 1;
            }
            None => s.push_str(&",".repeat(width)),
        };
        let at6 = data
            .imu
            .get(idx[0])
            .filter(|x| x.0.to_bits() == tk.to_bits())
            .map(|x| &x.1[..]);
        cells(&mut idx[0], at6, 6, &mut s);
        for (n, c) in [&data.air, &data.ahrs, &data.gnss].iter().enumerate() {
            let at = c
                .get(idx[n + 1])
                .filter(|x| x.0.to_bits() == tk.to_bits())
                .map(|x| &x.1[..]);
            cells(&mut idx[n + 1], at, 3, &mut s);
        }
        s.push('\n');
    }
    s
}

/// Reads a flight CSV (see the module documentation).
///
/// # Errors
/// [`Error::Invalid`] naming the file and the line, column or rule.
pub fn read_flight(path: &Path) -> Result<FlightData> {
    let text = config::read_text(path)?;
    let mut lines = text.lines().enumerate();
    let Some((_, head)) = lines.next() else {
        return Err(Error::invalid(path, "empty file: expected a header row"));
    };
    let names: Vec<&str> = head.split(',').map(str::trim).collect();
    let mut col = [usize::MAX; 16];
    for (j, name) in names.iter().enumerate() {
        match COLUMNS.iter().position(|c| c == name) {
            Some(i) if col[i] == usize::MAX => col[i] = j,
            Some(_) => {
                return Err(Error::invalid(
                    path,
                    format!("line 1: column `{name}` appears twice"),
                ));
            }
            None => {
                return Err(Error::invalid(
                    path,
                    format!(
                        "line 1: unknown column `{name}` (expected {})",
                        COLUMNS.join(", ")
                    ),
                ));
            }
        }
    }
    if let Some(i) = col.iter().position(|&c| c == usize::MAX) {
        return Err(Error::invalid(
            path,
            format!("line 1: column `{}` is missing", COLUMNS[i]),
        ));
    }
    let mut data = FlightData::default();
    for (l, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(Error::invalid(
                path,
                format!(
                    "line {}: {} fields, expected {}",
                    l + 1,
                    cells.len(),
                    names.len()
                ),
            ));
        }
        let value = |i: usize| -> Result<Option<f64>> {
            let c = cells[col[i]];
            if c.is_empty() {
                return Ok(None);
            }
            match c.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                _ => Err(Error::invalid(
                    path,
                    format!(
                        "line {}, column `{}`: `{c}` is not a finite number",
                        l + 1,
                        COLUMNS[i]
                    ),
                )),
            }
        };
        let t = value(0)?
            .ok_or_else(|| Error::invalid(path, format!("line {}: `t` is empty", l + 1)))?;
        let group = |from: usize, width: usize| -> Result<Option<Vec<f64>>> {
            let v: Vec<Option<f64>> = (from..from + width).map(value).collect::<Result<_>>()?;
            match v.iter().filter(|x| x.is_some()).count() {
                0 => Ok(None),
                k if k == width => Ok(Some(v.into_iter().flatten().collect())),
                _ => Err(Error::invalid(
                    path,
                    format!(
                        "line {}: columns {} must be all filled or all empty",
                        l + 1,
                        COLUMNS[from..from + width].join(", ")
                    ),
                )),
            }
        };
        if let Some(v) = group(1, 6)? {
            data.imu.push((t, std::array::from_fn(|i| v[i])));
        }
        for (from, ch) in [
            (7, &mut data.air),
            (10, &mut data.ahrs),
            (13, &mut data.gnss),
        ] {
            if let Some(v) = group(from, 3)? {
                ch.push((t, [v[0], v[1], v[2]]));
            }
        }
    }
    data.check(&path.display().to_string())?;
    Ok(data)
}

/// `summary.json` of a recorded flight.
#[derive(Debug, Clone, Serialize)]
pub struct DataSummary {
    /// Always "flightpath-data".
    pub scenario: &'static str,
    /// The record read.
    pub data: String,
    /// The parameters used (the noise levels and priors).
    pub params: FlightPathParams,
    /// One row per instrument error (no truth).
    pub parameters: Vec<ParameterRow>,
    /// Gated entries (air data, AHRS, GNSS).
    pub rejected: [usize; 3],
    /// Output-error iterations.
    pub output_error_iterations: usize,
    /// Whether the output-error fit converged.
    pub output_error_converged: bool,
}

/// Both estimators on one record with the parameters `p`.
///
/// # Errors
/// As [`estimate::both`].
pub fn estimate_record(data: &FlightData, p: &FlightPathParams) -> Result<Estimates> {
    let grid = data.grid();
    let noise = super::simulation::noise_model(&p.flight.noise_si(), p.flight.imu.rate_hz);
    estimate::both(data, &grid, &noise, p, &[])
}

/// Runs `flightpath --data`: reads the record, estimates, writes the report into `out`
/// (default `reports/flightpath-data`).
///
/// # Errors
/// A bad file (exit code 2, naming it), an estimator failure, a write error.
pub fn run(data_path: &Path, config_path: Option<&Path>, out: Option<&Path>) -> Result<()> {
    let p: FlightPathParams = config::load_or_default(config_path)?;
    p.validate(config_path.unwrap_or(Path::new("<defaults>")))?;
    let data = read_flight(data_path)?;
    let est = estimate_record(&data, &p)?;
    let dir: PathBuf = out.map_or_else(
        || Path::new("reports").join("flightpath-data"),
        Path::to_path_buf,
    );
    let t = data.grid().t;
    let noise = super::simulation::noise_model(&p.flight.noise_si(), p.flight.imu.rate_hz);
    let files = record_plots(&dir, &t, &est, None, None, &noise.r)?;
    let oe = est.output_error.as_ref();
    let summary = DataSummary {
        scenario: "flightpath-data",
        data: data_path.display().to_string(),
        params: p,
        parameters: parameter_rows(&est, None),
        rejected: est.pass.rejected,
        output_error_iterations: oe.map_or(0, |o| o.iterations),
        output_error_converged: oe.is_some_and(|o| o.converged),
    };
    let mut r = format!(
        "# Flight-path reconstruction of {}\n\nThe instrument errors by the filter–smoother \
         (EKF with augmented error states, gated, extended RTS smoother) and by output error \
         (maximum likelihood, Cramér–Rao bounds) on the recorded flight.\n\n{}\n\
         Gated entries: air data {}, AHRS {}, GNSS {}. Output error: {} iterations, {}.\n\n",
        summary.data,
        table(&summary.parameters),
        summary.rejected[0],
        summary.rejected[1],
        summary.rejected[2],
        summary.output_error_iterations,
        if summary.output_error_converged {
            "converged"
        } else {
            "NOT converged"
        },
    );
    r.push_str(&agreement(&summary.parameters));
    r.push_str("\n## Plots\n\n");
    for (f, what) in &files {
        let _ = writeln!(r, "- [{what}]({f})");
    }
    output::write_atomic(&dir.join("report.md"), r.as_bytes())?;
    output::write_json(&dir.join("summary.json"), &summary)
}

/// The verdict without truth: do the two methods agree within their combined bounds?
fn agreement(rows: &[ParameterRow]) -> String {
    let worst = rows
        .iter()
        .filter_map(|r| {
            r.output_error.map(|o| {
                let fs = r.filter_smoother;
                (
                    (fs.estimate - o.estimate).abs() / (fs.std * fs.std + o.std * o.std).sqrt(),
                    r.name,
                )
            })
        })
        .fold((0.0, ""), |a, b| if b.0 > a.0 { b } else { a });
    format!(
        "**Verdict.** The two methods {} (largest difference {:.1} combined σ, on `{}`).\n",
        if worst.0 <= 3.0 {
            "agree on every instrument error"
        } else {
            "DISAGREE: check the record and the noise levels"
        },
        worst.0,
        worst.1
    )
}
