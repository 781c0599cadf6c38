//! SVG line plots for the reports (plotters' SVG backend): one function, [`line_plot`], that
//! every scenario uses, so all figures share axes, colours and labelling.

use std::path::Path;

use plotters::prelude::*;

use crate::error::{Error, Result};
use crate::output;

/// One curve of a plot.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label (empty: not in the legend).
    pub label: String,
    /// The points (x, y); non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Draw as a dashed-looking marker line (points only) rather than a solid line.
    pub markers: bool,
    /// Palette slot of the colour; `None` = the series' position (set it to give a curve and
    /// its fit the same colour).
    pub color: Option<usize>,
}

impl Series {
    /// A solid line.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series {
            label: label.into(),
            points,
            markers: false,
            color: None,
        }
    }

    /// Points with markers, no line.
    pub fn points(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Series {
            label: label.into(),
            points,
            markers: true,
            color: None,
        }
    }

    /// The same series drawn in palette slot `slot`.
    #[must_use]
    pub fn with_color(mut self, slot: usize) -> Self {
        self.color = Some(slot);
        self
    }
}

/// Axis scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Linear axis.
    Linear,
    /// Base-10 logarithmic axis (non-positive values are skipped).
    Log,
}

/// What a figure shows.
#[derive(Debug, Clone)]
pub struct Figure<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// Label of the x axis, with units.
    pub x_label: &'a str,
    /// Label of the y axis, with units.
    pub y_label: &'a str,
    /// Scale of the y axis.
    pub y_scale: Scale,
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Draws `series` into an SVG file at `path` (written whole or not at all).
pub fn line_plot(path: &Path, figure: &Figure<'_>, series: &[Series]) -> Result<()> {
    let svg = render(path, figure, series)?;
    output::write_atomic(path, svg.as_bytes())
}

fn render(path: &Path, figure: &Figure<'_>, series: &[Series]) -> Result<String> {
    let drawn = |e: &dyn std::fmt::Display| Error::Plot {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let log = figure.y_scale == Scale::Log;
    let keep = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite() && (!log || y > 0.0);
    let all = series
        .iter()
        .flat_map(|s| s.points.iter().copied().filter(keep));
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (x, y) in all {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0.is_finite() && y0.is_finite()) {
        (x0, x1, y0, y1) = (
            0.0,
            1.0,
            if log { 1.0 } else { 0.0 },
            if log { 10.0 } else { 1.0 },
        );
    }
    // Pad degenerate ranges so a constant curve still gets a readable axis.
    if x1 - x0 <= f64::EPSILON * x0.abs().max(1.0) {
        x0 -= 0.5;
        x1 += 0.5;
    }
    if log {
        y0 /= 1.5;
        y1 *= 1.5;
    } else {
        let pad = if y1 - y0 > f64::EPSILON * y0.abs().max(1.0) {
            0.05 * (y1 - y0)
        } else {
            0.5 * y0.abs().max(1.0)
        };
        y0 -= pad;
        y1 += pad;
    }

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 560)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| drawn(&e))?;
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(figure.title, ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(80);
        macro_rules! draw {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(figure.x_label)
                    .y_desc(figure.y_label)
                    .label_style(("sans-serif", 14))
                    .draw()
                    .map_err(|e| drawn(&e))?;
                for (i, s) in series.iter().enumerate() {
                    let color = PALETTE[s.color.unwrap_or(i) % PALETTE.len()];
                    let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(keep).collect();
                    let anno = if s.markers {
                        chart
                            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                            .map_err(|e| drawn(&e))?
                    } else {
                        chart
                            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                            .map_err(|e| drawn(&e))?
                    };
                    // An empty label keeps the series out of the legend (e.g. the data
                    // points drawn beside their labelled fit line).
                    if !s.label.is_empty() {
                        anno.label(s.label.clone()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3))
                        });
                    }
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 14))
                    .draw()
                    .map_err(|e| drawn(&e))?;
            }};
        }
        if log {
            draw!(
                builder
                    .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                    .map_err(|e| drawn(&e))?
            );
        } else {
            draw!(
                builder
                    .build_cartesian_2d(x0..x1, y0..y1)
                    .map_err(|e| drawn(&e))?
            );
        }
        root.present().map_err(|e| drawn(&e))?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_linear_and_log_plots() {
        let fig = Figure {
            title: "t",
            x_label: "x [s]",
            y_label: "y [m]",
            y_scale: Scale::Linear,
        };
        let s = vec![
            Series::line(
                "a",
                (0..50)
                    .map(|i| (i as f64, (i as f64 * 0.2).sin()))
                    .collect(),
            ),
            Series::points("b", vec![(1.0, 0.5), (2.0, f64::NAN)]),
        ];
        let svg = render(Path::new("t.svg"), &fig, &s).expect("renders");
        assert!(svg.starts_with("<svg") && svg.contains("</svg>"));
        let log = Figure {
            y_scale: Scale::Log,
            ..fig
        };
        let svg = render(
            Path::new("t.svg"),
            &log,
            &[Series::line(
                "p",
                vec![(0.0, 1e-3), (1.0, 10.0), (2.0, 0.0)],
            )],
        )
        .expect("renders");
        assert!(svg.contains("</svg>"));
        // An empty figure still renders (axes only) rather than failing.
        assert!(render(Path::new("t.svg"), &log, &[]).is_ok());
    }
}
