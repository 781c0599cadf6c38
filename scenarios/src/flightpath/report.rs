//! The flightpath report: the paper-style comparison table, the Monte Carlo honesty of the
//! bounds, the trajectory section, the plots (ground track and altitude, residuals per
//! sensor, each error's filtered estimate with its ±2σ band, the Monte Carlo scatter of
//! normalised errors) and the verdict. Formatting only: every number comes from the summary.

use std::fmt::Write as _;
use std::path::Path;

use super::estimate::Estimates;
use super::model::{M, N_KIN};
use super::records::ERRORS;
use super::summary::{Computed, FlightPathSummary, ParameterRow, z95};
use crate::error::Result;
use crate::output;
use crate::plot::{Figure, Scale, Series, line_plot};

/// At most this many points per plotted curve (the record has ~18 000 steps).
const MAX_POINTS: usize = 1500;

fn stride(n: usize) -> usize {
    n.div_ceil(MAX_POINTS).max(1)
}

/// `1.234e-3`-style numbers with four significant digits.
fn num(v: f64) -> String {
    if !v.is_finite() {
        return "—".into();
    }
    if v == 0.0 || (1e-3..1e4).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

/// The comparison table (truth column when known).
pub fn table(rows: &[ParameterRow]) -> String {
    let truth = rows.iter().any(|r| r.truth.is_some());
    let mut s = String::new();
    if truth {
        s.push_str(
            "| error | unit | truth | filter–smoother | ±σ | (est − truth)/σ | output error | ±CRB | (est − truth)/CRB |\n|---|---|---|---|---|---|---|---|---|\n",
        );
    } else {
        s.push_str("| error | unit | filter–smoother | ±σ | output error | ±CRB |\n|---|---|---|---|---|---|\n");
    }
    for r in rows {
        let fs = r.filter_smoother;
        let oe = r.output_error;
        let oe_e = oe.map_or(f64::NAN, |o| o.estimate);
        let oe_s = oe.map_or(f64::NAN, |o| o.std);
        if let Some(t) = r.truth {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {:+.2} | {} | {} | {:+.2} |",
                r.name,
                r.unit,
                num(t),
                num(fs.estimate),
                num(fs.std),
                (fs.estimate - t) / fs.std,
                num(oe_e),
                num(oe_s),
                (oe_e - t) / oe_s
            );
        } else {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} |",
                r.name,
                r.unit,
                num(fs.estimate),
                num(fs.std),
                num(oe_e),
                num(oe_s)
            );
        }
    }
    s
}

/// The plots of one record's estimates (truth curves when given).
///
/// # Errors
/// [`crate::Error::Write`] or [`crate::Error::Plot`] naming the file.
pub fn record_plots(
    dir: &Path,
    t: &[f64],
    est: &Estimates,
    truth: Option<&[sensors::flight::TruthPoint]>,
    truth_errors: Option<&[f64; 12]>,
    sigma: &[f64; M],
) -> Result<Vec<(String, String)>> {
    let mut files = Vec::new();
    let st = stride(t.len());
    let idx: Vec<usize> = (0..t.len()).step_by(st).collect();
    let sm = &est.pass.smoothed;
    let no_notes: [String; 0] = [];
    // Ground track and altitude.
    let mut track = vec![Series::line(
        "smoothed",
        idx.iter().map(|&k| (sm[(7, k)], sm[(6, k)])).collect(),
    )];
    let mut alt = vec![Series::line(
        "smoothed",
        idx.iter().map(|&k| (t[k], sm[(8, k)])).collect(),
    )];
    let gnss: Vec<usize> = (0..t.len())
        .filter(|&k| est.pass.gated[k][6].is_finite())
        .collect();
    track.push(Series::points(
        "GNSS (gated)",
        gnss.iter()
            .step_by(stride(gnss.len()))
            .map(|&k| (est.pass.gated[k][7], est.pass.gated[k][6]))
            .collect(),
    ));
    alt.push(Series::points(
        "GNSS (gated)",
        gnss.iter()
            .step_by(stride(gnss.len()))
            .map(|&k| (t[k], est.pass.gated[k][8]))
            .collect(),
    ));
    if let Some(tr) = truth {
        track.push(Series::dashed(
            "truth",
            idx.iter()
                .map(|&k| (tr[k].position[1], tr[k].position[0]))
                .collect(),
        ));
        alt.push(Series::dashed(
            "truth",
            idx.iter().map(|&k| (t[k], tr[k].position[2])).collect(),
        ));
    }
    let fig = |title: &'static str, x: &'static str, y: &'static str| Figure {
        title,
        x_label: x,
        y_label: y,
        y_scale: Scale::Linear,
        notes: &no_notes,
    };
    line_plot(
        &dir.join("ground_track.svg"),
        &fig("Ground track", "east [m]", "north [m]"),
        &track,
    )?;
    files.push((
        "ground_track.svg".into(),
        "ground track (smoothed, GNSS, truth)".into(),
    ));
    line_plot(
        &dir.join("altitude.svg"),
        &fig("Altitude", "t [s]", "altitude [m]"),
        &alt,
    )?;
    files.push(("altitude.svg".into(), "altitude".into()));
    // Prediction residuals per sensor, in measurement standard deviations.
    for (name, file, off, labels) in [
        (
            "Air-data residuals",
            "residuals_air_data.svg",
            0,
            ["V", "α", "β"],
        ),
        ("AHRS residuals", "residuals_ahrs.svg", 3, ["φ", "θ", "ψ"]),
        (
            "GNSS residuals",
            "residuals_gnss.svg",
            6,
            ["north", "east", "altitude"],
        ),
    ] {
        let mut series = Vec::new();
        for (c, label) in labels.iter().enumerate() {
            let i = off + c;
            let pts: Vec<(f64, f64)> = (0..t.len())
                .filter(|&k| est.pass.residuals[k][i].is_finite())
                .map(|k| (t[k], est.pass.residuals[k][i] / sigma[i]))
                .collect();
            let s = stride(pts.len());
            series.push(Series::points(*label, pts.into_iter().step_by(s).collect()));
        }
        let notes = ["prediction residuals z − h(x_{k|k−1}) before the gate, divided by the measurement σ; wild points stand out".to_string()];
        let f = Figure {
            notes: &notes,
            ..Figure::over_time(name, "residual / σ [-]")
        };
        line_plot(&dir.join(file), &f, &series)?;
        files.push((file.into(), name.to_lowercase()));
    }
    // Each error's filtered estimate with its ±2σ band.
    for (j, (name, unit, f)) in ERRORS.iter().enumerate() {
        let i = N_KIN + j;
        let fx = &est.pass.filtered;
        let fv = &est.pass.filtered_var;
        let mut series = vec![
            Series::line(
                "filtered",
                idx.iter().map(|&k| (t[k], fx[(i, k)] * f)).collect(),
            ),
            Series::dashed(
                "+2σ",
                idx.iter()
                    .map(|&k| (t[k], (fx[(i, k)] + 2.0 * fv[(i, k)].sqrt()) * f))
                    .collect(),
            )
            .with_color(0),
            Series::dashed(
                "−2σ",
                idx.iter()
                    .map(|&k| (t[k], (fx[(i, k)] - 2.0 * fv[(i, k)].sqrt()) * f))
                    .collect(),
            )
            .with_color(0),
        ];
        // The first seconds' prior band dwarfs the rest: shown from 5 % of the record on.
        let from = t.len() / 20;
        if let Some(te) = truth_errors {
            series.push(Series::dashed(
                "truth",
                vec![(t[from], te[j] * f), (t[t.len() - 1], te[j] * f)],
            ));
        }
        let title = format!("{name}: filtered estimate and ±2σ");
        let y = format!("{name} [{unit}]");
        let file = format!("error_{name}.svg");
        for s in &mut series {
            s.points.retain(|p| p.0 >= t[from]);
        }
        let notes = [
            "from 5 % of the record on (the prior's band at the start would hide the rest)"
                .to_string(),
        ];
        line_plot(
            &dir.join(&file),
            &Figure {
                notes: &notes,
                ..Figure::over_time(&title, &y)
            },
            &series,
        )?;
        files.push((file, format!("{name}, filtered, ±2σ")));
    }
    Ok(files)
}

/// Writes `report.md`, `parameters.csv` and the plots.
///
/// # Errors
/// [`crate::Error::Write`] naming the file.
pub fn write_outputs(c: &Computed, dir: &Path) -> Result<()> {
    let s = &c.summary;
    let noise =
        super::simulation::noise_model(&s.params.flight.noise_si(), s.params.flight.imu.rate_hz);
    let truth_errors = s.params.flight.errors.si();
    let mut files = record_plots(
        dir,
        &c.t,
        &c.nominal,
        Some(&c.truth),
        Some(&truth_errors),
        &noise.r,
    )?;
    // Monte Carlo scatter of the normalised errors.
    let mut series = Vec::new();
    for (m, label) in ["filter–smoother", "output error"].iter().enumerate() {
        let pts = c.normalised[m]
            .iter()
            .flat_map(|r| {
                r.iter()
                    .enumerate()
                    .map(move |(j, z)| (j as f64 + if m == 0 { -0.15 } else { 0.15 }, *z))
            })
            .collect();
        series.push(Series::points(*label, pts));
    }
    let z = z95();
    series.push(Series::dashed("±1.96 (95 %)", vec![(-0.5, z), (11.5, z)]).with_color(2));
    series.push(Series::dashed("", vec![(-0.5, -z), (11.5, -z)]).with_color(2));
    let notes = [format!(
        "x: the error's index in the table (0 = {}, …, 11 = {}); y: (estimate − truth)/std per run",
        ERRORS[0].0, ERRORS[11].0
    )];
    line_plot(
        &dir.join("monte_carlo.svg"),
        &Figure {
            title: "Monte Carlo: normalised errors against the bounds",
            x_label: "instrument error [index]",
            y_label: "(estimate − truth)/σ [-]",
            y_scale: Scale::Linear,
            notes: &notes,
        },
        &series,
    )?;
    files.push((
        "monte_carlo.svg".into(),
        "Monte Carlo scatter against the bounds".into(),
    ));
    output::write_atomic(&dir.join("report.md"), report_text(s, &files).as_bytes())
}

fn report_text(s: &FlightPathSummary, files: &[(String, String)]) -> String {
    let mut r = String::new();
    let _ = writeln!(
        r,
        "# Flight-path reconstruction and data-compatibility checking\n\n\
         A {} s simulated flight (pitch and roll doublets, a level turn, a speed change) \
         recorded by an IMU at {} Hz, air data at {} Hz, an AHRS at {} Hz and GNSS at {} Hz, \
         each with jittered stamps, dropouts and wild points. Two estimators of the twelve \
         instrument errors side by side, as Mulder et al. (1999) and Klein & Morelli (2006, \
         ch. 10) compare them: the **filter–smoother** (EKF with the errors as augmented \
         constant states, exact AD Jacobians, measurements gated on their innovations, then \
         the extended RTS smoother, iterated once on the model linearised about its smoothed \
         trajectory) and **output error** (maximum likelihood of the errors \
         and the initial state with the IMU integrated deterministically, Gauss–Newton with \
         exact AD sensitivities, Cramér–Rao bounds).\n",
        s.params.flight.duration_s,
        s.params.flight.imu.rate_hz,
        s.params.flight.air_data.rate_hz,
        s.params.flight.ahrs.rate_hz,
        s.params.flight.gnss.rate_hz,
    );
    let _ = writeln!(r, "**Verdict.** {}\n", s.verdict.text);
    let _ = writeln!(r, "## The nominal run (run 0)\n\n{}", table(&s.parameters));
    let _ = writeln!(
        r,
        "Gated entries: air data {}, AHRS {}, GNSS {} (each wild point spoils three entries). \
         Output-error Gauss–Newton iterations: {}.\n",
        s.nominal_rejected[0],
        s.nominal_rejected[1],
        s.nominal_rejected[2],
        s.nominal_output_error_iterations
    );
    let mc = &s.monte_carlo;
    let _ = writeln!(
        r,
        "## Are the bounds honest? ({} runs)\n\nRMS of (estimate − truth)/σ (1 for honest \
         bounds; accepted in [0.6, 1.6]) and the fraction of runs whose 95 % interval covers \
         the truth.\n\n| error | filter–smoother RMS | coverage | output error RMS | coverage |\n|---|---|---|---|---|",
        mc.runs
    );
    for (a, b) in mc.filter_smoother.iter().zip(&mc.output_error) {
        let _ = writeln!(
            r,
            "| {} | {:.2} | {:.2} | {:.2} | {:.2} |",
            a.name, a.rms_normalised_error, a.coverage95, b.rms_normalised_error, b.coverage95
        );
    }
    let (pf, po) = (mc.pooled.filter_smoother, mc.pooled.output_error);
    let _ = writeln!(
        r,
        "| **pooled** | {:.2} | {:.3} | {:.2} | {:.3} |\n",
        pf.rms_normalised_error, pf.coverage95, po.rms_normalised_error, po.coverage95
    );
    let tr = &s.trajectory;
    let _ = writeln!(
        r,
        "## Trajectory\n\nRMS error over every step and run.\n\n| group | filtered | smoothed |\n|---|---|---|"
    );
    for (name, g) in [
        ("position", tr.position),
        ("velocity", tr.velocity),
        ("attitude", tr.attitude),
    ] {
        let _ = writeln!(
            r,
            "| {name} [{}] | {} | {} |",
            g.unit,
            num(g.filtered_rms),
            num(g.smoothed_rms)
        );
    }
    let n = tr.nees_smoothed;
    let _ = writeln!(
        r,
        "\nSmoothed NEES of the whole {}-state at mid-record, mean over runs: {:.2} (χ² 95 % \
         band [{:.2}, {:.2}]).\n",
        n.dof, n.mean, n.band[0], n.band[1]
    );
    let u = &s.nominal_unscented;
    let _ = writeln!(
        r,
        "## The unscented filter–smoother\n\nThe same gated pass with the unscented filter \
         (cubature points) and the unscented RTS smoother, in one pass, on the nominal run: \
         the sigma points linearise the air-data outputs over the state's spread, not at the \
         running estimate where a single extended pass linearises them and becomes \
         over-confident.\n\n\
         | group | filtered | smoothed | iterated extended, smoothed |\n|---|---|---|---|"
    );
    for (i, name) in ["position [m]", "velocity [m/s]", "attitude [deg]"]
        .iter()
        .enumerate()
    {
        let _ = writeln!(
            r,
            "| {name} | {} | {} | {} |",
            num(u.filtered_rms[i]),
            num(u.smoothed_rms[i]),
            num(u.extended_smoothed_rms[i])
        );
    }
    let _ = writeln!(
        r,
        "\nInstrument errors within {:.1} σ of the truth; smoothed NEES at mid-record {:.2} \
         (one run's χ² 95 % band [{:.2}, {:.2}]).\n",
        u.max_normalised_error, u.nees_mid, u.nees_band[0], u.nees_band[1]
    );
    let _ = writeln!(r, "## Plots\n");
    for (f, what) in files {
        let _ = writeln!(r, "- [{what}]({f})");
    }
    r
}
