//! The boom scenario's tracking outputs, formatted from its summary: the filters' error
//! curves next to the WLS's (CSV, and SVG at the low γ) and the report's "Nonlinear filters
//! against WLS" section (tables, plots, and the comment written from the summary's
//! conditions).

use std::fmt::Write as _;
use std::path::Path;

use wls::boom::TurnRun;

use super::findings::{fmt_num, table, yes};
use super::parameters::Method;
use super::report::{decimate, deg};
use super::summary::{BoomSummary, Computed};
use crate::error::Result;
use crate::output;
use crate::plot::{Figure, Scale, Series, line_plot};

/// Writes the filters' CSVs and plots into `dir` and returns the report section.
///
/// # Errors
/// [`crate::Error::Write`] naming the file.
pub fn write_outputs(c: &Computed, dir: &Path) -> Result<String> {
    let figures = tracking_outputs(c, dir)?;
    Ok(tracking_section(&c.summary, &figures))
}

/// The runs of `method` at γ among the case runs and the tracking runs.
fn runs_of(c: &Computed, method: Method, gamma: f64) -> Option<(&TurnRun, &TurnRun)> {
    c.case_runs
        .iter()
        .chain(&c.tracking_runs)
        .find(|r| r.0 == method && (r.1 - gamma).abs() < 1e-9)
        .map(|r| (&r.2, &r.3))
}

/// The filters' error curves (`tracking_gamma<γ>.csv`, WLS alongside) and, at the low γ of
/// the verdict, the δα and δε plots of WLS, UKF and the smoother (variant "+"). Returns the
/// plot files.
fn tracking_outputs(c: &Computed, dir: &Path) -> Result<Vec<String>> {
    let s = &c.summary;
    let lim = s.limits;
    let methods = [Method::Wls, Method::Ekf, Method::Ukf, Method::Urts];
    let mut files = Vec::new();
    for &gamma in &s.params.case_gammas_deg {
        let runs: Vec<(Method, &TurnRun, &TurnRun)> = methods
            .iter()
            .filter_map(|&m| runs_of(c, m, gamma).map(|(p, n)| (m, p, n)))
            .collect();
        let Some((_, first, _)) = runs.first() else {
            continue;
        };
        let mut header = vec!["t_s".to_string(), "alpha_nominal_deg".to_string()];
        for (m, _, _) in &runs {
            for what in [
                "alpha_err_plus_deg",
                "alpha_err_minus_deg",
                "eps_err_plus_deg_s2",
                "eps_err_minus_deg_s2",
            ] {
                header.push(format!("{}_{what}", m.name()));
            }
        }
        let rows: Vec<Vec<f64>> = (0..first.cycles.len())
            .map(|k| {
                let mut row = vec![first.cycles[k].t, deg(first.cycles[k].alpha)];
                for (_, p, n) in &runs {
                    row.extend([
                        deg(p.cycles[k].angle_error),
                        deg(n.cycles[k].angle_error),
                        deg(p.cycles[k].epsilon_error),
                        deg(n.cycles[k].epsilon_error),
                    ]);
                }
                row
            })
            .collect();
        let header_ref: Vec<&str> = header.iter().map(String::as_str).collect();
        output::write_csv(
            &dir.join(format!("tracking_gamma{}.csv", fmt_num(gamma))),
            &header_ref,
            &rows,
        )?;
        if (gamma - s.tracking_verdict.low_gamma_deg).abs() > 1e-9 {
            continue;
        }
        for (what, limit, unit, offset) in [
            ("alpha", lim.alpha_deg, "°", 0),
            ("eps", lim.eps_deg_s2, "°/s²", 2),
        ] {
            let sym = if what == "alpha" { "δα" } else { "δε" };
            let t_end = rows.last().map_or(1.0, |r| r[0]);
            let mut series = Vec::new();
            for (i, (m, _, _)) in runs.iter().enumerate() {
                if *m == Method::Ekf {
                    continue;
                }
                let col = 2 + 4 * i + offset;
                series.push(Series::line(
                    format!("{} {sym}⁺", m.name()),
                    decimate(&rows, col, 4).into_iter().skip(1).collect(),
                ));
            }
            series.push(
                Series::dashed(
                    format!("limit {limit} {unit} (paper)"),
                    vec![(0.0, limit), (t_end, limit)],
                )
                .with_color(7),
            );
            let file = format!("tracking_gamma{}_{what}.svg", fmt_num(gamma));
            let title = format!(
                "WLS, UKF and unscented RTS at γ = {}°, variant +: {sym} (log scale)",
                fmt_num(gamma)
            );
            let y_label = format!("{sym} [{unit}] (log)");
            line_plot(
                &dir.join(&file),
                &Figure {
                    y_scale: Scale::Log,
                    ..Figure::over_time(&title, &y_label)
                },
                &series,
            )?;
            files.push(file);
        }
    }
    Ok(files)
}

/// The "Nonlinear filters against WLS" section: the tables, the plots and the comment, all
/// from the summary's numbers and conditions.
fn tracking_section(s: &BoomSummary, figures: &[String]) -> String {
    let t = &s.tracking;
    let v = &s.tracking_verdict;
    let mut r = String::new();
    let _ = writeln!(
        r,
        "\n## Nonlinear filters against WLS\n\n\
         Beyond the paper: the turn as a tracking problem. State (α, ω, ε), ε driven by white \
         jerk of intensity q = {:.4} (°/s²)²/s (derived from the nominal turn's ramps: the \
         model's one-sigma spread of ε over one second equals the largest change of ε the \
         turn makes in one second), exact discretisation (Van Loan); the measurement is the \
         `sensors` accelerometer (γ, g·sin/cos(α − γ), ε·r) without the bias; R = {} (m/s²)² \
         per axis (the limiting error Δa as noise), {:.4}² with the Monte Carlo's white \
         noise. EKF (Jacobian of the sensor code by central differences), UKF ({}) and the \
         unscented Rauch–Tung–Striebel smoother (`urts`) over the UKF's forward pass, on the \
         very readings the WLS sees. Start: direct inversion of the first reading, ω = 0; \
         the start-up cycle is excluded as for the WLS. A filter is *undefined* from the \
         first step the library refuses (never on these turns); *over the limits from* is \
         the WLS's rule.\n",
        t.jerk_psd_deg2_s5,
        fmt_sq(t.r_std_cases_mps2),
        t.r_std_noise_mps2,
        match s.params.tracking.sigma_points {
            kalman::nonlinear::SigmaPoints::Cubature => "cubature points".to_string(),
            kalman::nonlinear::SigmaPoints::Merwe { alpha, beta, kappa } =>
                format!("Merwe points α = {alpha}, β = {beta}, κ = {kappa}"),
            kalman::nonlinear::SigmaPoints::Julier { kappa } =>
                format!("Julier points κ = {kappa}"),
            kalman::nonlinear::SigmaPoints::Simplex => "simplex points".to_string(),
        }
    );
    table(
        &mut r,
        &[
            "method",
            "γ",
            "no bias: max δα, °",
            "±Δa: max δα, °",
            "±Δa: max δε, °/s²",
            "worst δα at α",
            "within limits",
        ],
        &v.bias_effects,
        |b| {
            format!(
                "{} | {}° | {:.4} | {:.4} | {:.4} | {:.2}° | {}",
                b.method.name(),
                fmt_num(b.gamma_deg),
                b.bias_free_alpha_deg,
                b.with_bias_alpha_deg,
                b.with_bias_eps_deg_s2,
                b.alpha_at_worst_deg,
                yes(b.within_limits)
            )
        },
    );
    let runs = s.noise_mc.first().map_or(0, |m| m.runs);
    let _ = write!(
        r,
        "\nNoise Monte Carlo: white noise σ = {} m/s² per axis on top of ±Δa, {runs} runs per γ \
         (each a \"+\" and a \"−\" turn with the same draws; records in `runs_noise.csv`):\n\n",
        t.noise_std_mps2
    );
    table(
        &mut r,
        &["method", "γ", "runs", "RMS δα, °", "RMS δε, °/s²"],
        &s.noise_mc,
        |m| {
            format!(
                "{} | {}° | {} | {:.4} | {:.4}",
                m.method.name(),
                fmt_num(m.gamma_deg),
                m.runs,
                m.rms_alpha_err_deg,
                m.rms_eps_err_deg_s2
            )
        },
    );
    let _ = writeln!(r, "\n{}\n", tracking_comment(s));
    for f in figures {
        let _ = writeln!(r, "![{f}]({f})\n");
    }
    r
}

/// `0.0004` for σ = 0.02.
fn fmt_sq(x: f64) -> String {
    let v = format!("{:.6}", x * x);
    v.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The comment of the section, from the verdict's conditions.
fn tracking_comment(s: &BoomSummary) -> String {
    let v = &s.tracking_verdict;
    let g0 = fmt_num(v.low_gamma_deg);
    let mut t = String::from("**Comment.** ");
    let _ = write!(
        t,
        "On exact readings (no bias, no noise) at γ = {g0}° the filters' worst errors are \
         δα = {:.4}°, δε = {:.4} °/s² against the WLS's {:.4}°, {:.4} °/s²: ",
        v.filters_bias_free_alpha_deg,
        v.filters_bias_free_eps_deg_s2,
        v.wls_bias_free_alpha_deg,
        v.wls_bias_free_eps_deg_s2
    );
    if v.state_cures_conditioning {
        t.push_str(
            "carrying (α, ω, ε) through time does cure the ill-conditioning near 90° that the \
             paper cures with γ — where a_x loses its sensitivity to α, the kinematic model \
             carries α across, so no offset is needed for the conditioning itself. ",
        );
    } else {
        t.push_str(
            "carrying the state through time does NOT by itself cure the ill-conditioning \
             near 90° here. ",
        );
    }
    let effect = |m: Method, g: f64| {
        v.bias_effects
            .iter()
            .find(|b| b.method == m && (b.gamma_deg - g).abs() < 1e-9)
    };
    let gammas = &s.params.case_gammas_deg;
    let describe = |m: Method| -> String {
        gammas
            .iter()
            .filter_map(|&g| effect(m, g))
            .map(|b| {
                format!(
                    "γ = {}°: δα {:.3}° (worst at α = {:.1}°; {:.4}° without bias), δε {:.3} °/s², {}",
                    fmt_num(b.gamma_deg),
                    b.with_bias_alpha_deg,
                    b.alpha_at_worst_deg,
                    b.bias_free_alpha_deg,
                    b.with_bias_eps_deg_s2,
                    if b.within_limits { "within the limits" } else { "over the limits" }
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    let _ = write!(
        t,
        "A constant ±Δa: WLS — {}. UKF — {}. ",
        describe(Method::Wls),
        describe(Method::Ukf)
    );
    // Does the bias hurt the filters more than the WLS, and does it grow along the turn?
    let worse: Vec<String> = gammas
        .iter()
        .filter(|&&g| {
            matches!((effect(Method::Ukf, g), effect(Method::Wls, g)),
                (Some(u), Some(w)) if u.with_bias_alpha_deg > w.with_bias_alpha_deg)
        })
        .map(|&g| format!("{}°", fmt_num(g)))
        .collect();
    let late = gammas
        .iter()
        .all(|&g| effect(Method::Ukf, g).is_some_and(|b| b.alpha_at_worst_deg > 60.0));
    if !worse.is_empty() {
        let _ = write!(
            t,
            "The bias costs the filters more than the WLS (at γ = {}): a filter reads the a_y \
             bias as an angular acceleration (Δa/r = {:.3} °/s²) and its kinematic model \
             integrates that twice into α{}, while the WLS maps the bias into errors cycle by \
             cycle (eq. 4) and never accumulates it; a filter would need the bias in its state \
             (not tried here). ",
            worse.join(", "),
            (s.params.limiting_error_mps2 / s.params.sensor_radius_m).to_degrees(),
            if late {
                "; a_x pulls α back only while it is sensitive to α, so the error peaks late in the turn"
            } else {
                ""
            }
        );
    } else {
        t.push_str("The bias costs the filters no more than the WLS. ");
    }
    let within = |m: Method| -> Vec<String> {
        gammas
            .iter()
            .filter(|&&g| effect(m, g).is_some_and(|b| b.within_limits))
            .map(|&g| format!("{}°", fmt_num(g)))
            .collect()
    };
    let (wls_ok, ukf_ok) = (within(Method::Wls), within(Method::Ukf));
    let at = |v: &[String]| {
        if v.is_empty() {
            "at no case γ".to_string()
        } else {
            format!("at γ = {}", v.join(", "))
        }
    };
    let _ = write!(
        t,
        "Under ±Δa the WLS holds both limits {}, the UKF {}: {}. ",
        at(&wls_ok),
        at(&ukf_ok),
        match (wls_ok.is_empty(), ukf_ok.is_empty()) {
            (false, true) =>
                "the paper's cure, the offset γ, is still what makes the estimate usable under its error model",
            (true, false) => "here the filter is what makes the estimate usable",
            (false, false) => "both are usable at some case angle",
            (true, true) => "neither is usable at the case angles",
        }
    );
    if let (Some(f), Some(sm)) = (
        effect(Method::Ukf, v.low_gamma_deg),
        effect(Method::Urts, v.low_gamma_deg),
    ) {
        if sm.with_bias_alpha_deg < 0.99 * f.with_bias_alpha_deg {
            let _ = write!(
                t,
                "The smoother, using the whole turn, brings the UKF's worst δα at γ = {g0}° \
                 from {:.3}° to {:.3}°. ",
                f.with_bias_alpha_deg, sm.with_bias_alpha_deg
            );
        } else {
            let _ = write!(
                t,
                "The smoother does not lower the UKF's worst δα at γ = {g0}° ({:.3}° at α = \
                 {:.1}°): the worst error is at the end of the turn, where the smoothed \
                 estimate is the filtered one. ",
                sm.with_bias_alpha_deg, sm.alpha_at_worst_deg
            );
        }
    }
    let _ = write!(
        t,
        "In the noise Monte Carlo the smoother's RMS errors are {} the UKF's at every γ.",
        if v.smoother_not_worse {
            "at most"
        } else {
            "NOT always below"
        }
    );
    t
}
