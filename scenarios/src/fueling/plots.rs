//! The fueling scenario's plots: error against amplitude (points with 95 % intervals, the
//! straight-line fits, the paper's ratios) and the random error along each other sweep.

use std::path::Path;

use super::records::STRATEGY_LABELS;
use super::summary::{Stat, Summary};
use crate::error::Result;
use crate::plot::{Figure, Scale, Series, line_plot};

/// 95 % normal-theory intervals of a sample's mean and standard deviation over `n` runs:
/// mean ± 1.96·s/√n and s·(1 ± 1.96/√(2(n − 1))) (the large-sample standard errors; the
/// runs are independent, so a point's interval is honest whatever its neighbours do).
fn intervals(s: &Stat, n: usize) -> ((f64, f64), (f64, f64)) {
    let n = n.max(2) as f64;
    let m = 1.96 * s.std_mm / n.sqrt();
    let d = 1.96 / (2.0 * (n - 1.0)).sqrt();
    (
        (s.mean_mm - m, s.mean_mm + m),
        (s.std_mm * (1.0 - d).max(0.0), s.std_mm * (1.0 + d)),
    )
}

fn interval_note(n: usize) -> String {
    format!(
        "Error bars: 95 % intervals over the {n} runs of a point (mean ± 1.96·s/√n, std \
         s·(1 ± 1.96/√(2(n − 1))))."
    )
}

pub(super) fn write_plots(summary: &Summary, dir: &Path) -> Result<()> {
    let amp = &summary.amplitude_sweep;
    let xs: Vec<f64> = amp.iter().map(|e| e.at["amplitude_deg"]).collect();
    let (x0, x1) = (
        xs.iter().copied().fold(f64::INFINITY, f64::min),
        xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    let r = &summary.at_max_amplitude;
    // The paper's ratios at the largest amplitude, applied to our relay logic's error there.
    let relay_top = amp
        .iter()
        .find(|e| (e.at["amplitude_deg"] - r.amplitude_deg).abs() < 1e-12)
        .map_or(f64::NAN, |e| e.stats.relay.std_mm);
    let paper_kf2 = r.paper_kf2 * relay_top;
    let paper_flat = |from: f64, to: f64| {
        Series::dashed(
            format!(
                "paper: two-channel = {:.2} × relay at {}°, invariant",
                r.paper_kf2, r.amplitude_deg
            ),
            vec![(from, paper_kf2), (to, paper_kf2)],
        )
        .with_color(2)
    };
    let n = summary.runs_per_point;
    for (what, title, pick) in [
        (
            "std",
            "Random fuelling error vs tilt amplitude (points: Monte Carlo; lines: fits)",
            (|s: &Stat| s.std_mm) as fn(&Stat) -> f64,
        ),
        (
            "mean",
            "Systematic fuelling error vs tilt amplitude (points: Monte Carlo; lines: fits)",
            |s: &Stat| s.mean_mm,
        ),
    ] {
        let mut series = Vec::new();
        for (i, label) in STRATEGY_LABELS.iter().enumerate() {
            let f = summary.amplitude_fits.get(i);
            let l = if what == "std" { f.std } else { f.mean };
            let line = |x: f64| l.intercept_mm + l.slope_mm_per_deg * x;
            series.push(Series::line(*label, vec![(x0, line(x0)), (x1, line(x1))]).with_color(i));
            let stats = amp.iter().map(|e| *e.stats.get(i));
            series.push(
                Series::points(
                    "",
                    xs.iter()
                        .zip(stats.clone())
                        .map(|(x, st)| (*x, pick(&st)))
                        .collect(),
                )
                .with_errors(
                    stats
                        .map(|st| {
                            let (m, s) = intervals(&st, n);
                            if what == "std" { s } else { m }
                        })
                        .collect(),
                )
                .with_color(i),
            );
        }
        if what == "std" {
            series.push(paper_flat(x0, x1));
            series.push(
                Series::paper(
                    format!(
                        "paper: one-channel = {:.2} × relay at {}°",
                        r.paper_kf1, r.amplitude_deg
                    ),
                    vec![(r.amplitude_deg, r.paper_kf1 * relay_top)],
                )
                .with_color(1),
            );
        }
        let y_label = format!("{what} of the fuelling error [mm]");
        let notes = [interval_note(n)];
        line_plot(
            &dir.join(format!("amplitude_{what}.svg")),
            &Figure {
                title,
                x_label: "maximum tilt amplitude A_max [°]",
                y_label: &y_label,
                y_scale: Scale::Linear,
                notes: &notes,
            },
            &series,
        )?;
    }
    let sweeps = [
        (
            "period",
            "rolling_period_s",
            "dominant rolling period [s]",
            &summary.period_sweep,
        ),
        (
            "fill_rate",
            "fill_rate_mm_s",
            "mean fill rate V_c [mm/s]",
            &summary.fill_rate_sweep,
        ),
        (
            "damper",
            "damper_time_s",
            "hydro-damper time constant T_y [s]",
            &summary.damper_sweep,
        ),
        (
            "step",
            "step_mm",
            "quantization step δ [mm]",
            &summary.step_sweep,
        ),
    ];
    let n = summary.sweep_runs_per_point;
    for (id, key, x_label, entries) in sweeps {
        let mut series: Vec<Series> = STRATEGY_LABELS
            .iter()
            .enumerate()
            .map(|(i, label)| {
                Series::line(
                    *label,
                    entries
                        .iter()
                        .map(|e| (e.at[key], e.stats.get(i).std_mm))
                        .collect(),
                )
                .with_errors(
                    entries
                        .iter()
                        .map(|e| intervals(e.stats.get(i), n).1)
                        .collect(),
                )
            })
            .collect();
        if id == "period" {
            let (lo, hi) = range(entries.iter().map(|e| e.at[key]));
            series.push(paper_flat(lo, hi));
        }
        let title = format!(
            "Random fuelling error vs {} (A_max = {}°)",
            x_label.split(" [").next().unwrap_or(x_label),
            summary.params.max_amplitude_deg
        );
        let notes = [interval_note(n)];
        line_plot(
            &dir.join(format!("{id}_std.svg")),
            &Figure {
                title: &title,
                x_label,
                y_label: "std of the fuelling error [mm]",
                y_scale: Scale::Linear,
                notes: &notes,
            },
            &series,
        )?;
    }
    Ok(())
}

pub(super) fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    })
}
