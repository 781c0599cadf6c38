//! SVG line plots for the reports: one function, [`line_plot`], that every scenario uses, so
//! all figures share one style — axes and series drawn by plotters, the legend in its own box
//! below the data area (opaque, so it can never cover a point), every axis titled with its
//! unit, log axes labelled by 1-2-5 ticks across their whole range, undefined values drawn as
//! gaps shaded, marked × at its start and named in a note, intervals as error bars, and the
//! papers' figures as dashed lines or hollow diamonds.
//!
//! The file is grouped for whoever checks it: `<g class="axes">` (background, mesh and the
//! `<rect class="frame">` of the data area), `title`, `x-label`, `y-label`, `y-ticks` (a log
//! axis's labels, `data-scale="log"`), `data`, `undefined`, `legend` and `notes`.

use std::fmt::Write as _;
use std::path::Path;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::error::{Error, Result};
use svg::{body, dashes, hex, log_tick_text, log_ticks, text, text_width, wrap};

mod svg;
use crate::output;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A solid line; a non-finite y breaks it (a gap, marked as undefined).
    Line,
    /// Filled circles, no line.
    Points,
    /// A dashed line: a reference (a limit, a paper's curve or level).
    Dashed,
    /// A dashed vertical line over the whole y range at the first point's x (a reference
    /// abscissa, e.g. the angle where the paper says a method fails).
    Vertical,
    /// Hollow diamonds: a paper's figure at a point.
    Paper,
}

/// One curve of a plot.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label (empty: not in the legend).
    pub label: String,
    /// The points (x, y); a non-finite y is undefined (a gap in a line).
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub kind: Kind,
    /// Palette slot of the colour; `None` = the series' position (set it to give a curve and
    /// its fit the same colour).
    pub color: Option<usize>,
    /// Intervals `(lo, hi)` drawn as error bars, one per point (empty: none).
    pub errors: Vec<(f64, f64)>,
}

impl Series {
    fn new(label: impl Into<String>, points: Vec<(f64, f64)>, kind: Kind) -> Self {
        Series {
            label: label.into(),
            points,
            kind,
            color: None,
            errors: Vec::new(),
        }
    }

    /// A solid line.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self::new(label, points, Kind::Line)
    }

    /// Points with markers, no line.
    pub fn points(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self::new(label, points, Kind::Points)
    }

    /// A dashed reference line.
    pub fn dashed(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self::new(label, points, Kind::Dashed)
    }

    /// A dashed vertical reference line at `x`.
    pub fn vertical(label: impl Into<String>, x: f64) -> Self {
        Self::new(label, vec![(x, f64::NAN)], Kind::Vertical)
    }

    /// A paper's figures at points (hollow diamonds).
    pub fn paper(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self::new(label, points, Kind::Paper)
    }

    /// The same series drawn in palette slot `slot`.
    #[must_use]
    pub fn with_color(mut self, slot: usize) -> Self {
        self.color = Some(slot);
        self
    }

    /// The same series with an interval `(lo, hi)` per point, drawn as error bars.
    #[must_use]
    pub fn with_errors(mut self, errors: Vec<(f64, f64)>) -> Self {
        self.errors = errors;
        self
    }
}

/// Axis scale.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// Linear axis.
    Linear,
    /// Base-10 logarithmic axis (non-positive values are left out and counted in a note).
    Log,
}

/// What a figure shows.
#[derive(Debug, Clone)]
pub struct Figure<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// Label of the x axis with its unit in brackets: `t [s]`.
    pub x_label: &'a str,
    /// Label of the y axis with its unit in brackets.
    pub y_label: &'a str,
    /// Scale of the y axis.
    pub y_scale: Scale,
    /// Lines of text under the legend (what is clipped, where an interval comes from).
    pub notes: &'a [String],
}

impl<'a> Figure<'a> {
    /// A figure against time (`t [s]` on a linear x axis) with a linear y axis and no notes;
    /// struct-update syntax changes the rest: `Figure { notes: &notes, ..Figure::over_time(…) }`.
    pub fn over_time(title: &'a str, y_label: &'a str) -> Self {
        Figure {
            title,
            x_label: "t [s]",
            y_label,
            y_scale: Scale::Linear,
            notes: &[],
        }
    }
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

const WIDTH: u32 = 900;
/// Height of the title strip above the chart.
const TITLE_H: u32 = 40;
/// Height of the chart (data area, tick labels and the x-axis title).
const CHART_H: u32 = 480;
const FONT: &str = "sans-serif";
/// Average advance of a sans-serif glyph as a fraction of the font size (a generous
/// estimate, so the layout errs towards room).
pub const GLYPH_WIDTH: f64 = 0.6;
const LEGEND_FONT: f64 = 14.0;
const LEGEND_ROW: i32 = 22;
const NOTE_FONT: f64 = 13.0;
const NOTE_ROW: i32 = 18;
const MARGIN: i32 = 12;

/// Draws `series` into an SVG file at `path` (written whole or not at all).
///
/// # Errors
/// [`Error::Plot`] if plotters fails; [`Error::Write`] naming the file.
pub fn line_plot(path: &Path, figure: &Figure<'_>, series: &[Series]) -> Result<()> {
    let svg = render(path, figure, series)?;
    output::write_atomic(path, svg.as_bytes())
}

/// A series in plot coordinates (y as log10 on a log axis), split where it is undefined.
struct Prepared {
    kind: Kind,
    color: RGBColor,
    label: String,
    segments: Vec<Vec<(f64, f64)>>,
    /// (x, lo, hi).
    errors: Vec<(f64, f64, f64)>,
    /// Runs of undefined points: first and last x.
    undefined: Vec<(f64, f64)>,
    /// Points left out of a log axis because they are not positive.
    nonpositive: usize,
}

fn prepare(series: &[Series], log: bool) -> Vec<Prepared> {
    let ty = |y: f64| if log { y.log10() } else { y };
    series
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let mut p = Prepared {
                kind: s.kind,
                color: PALETTE[s.color.unwrap_or(i) % PALETTE.len()],
                label: s.label.clone(),
                segments: vec![Vec::new()],
                errors: Vec::new(),
                undefined: Vec::new(),
                nonpositive: 0,
            };
            let mut in_gap = false;
            for &(x, y) in s.points.iter().filter(|(x, _)| x.is_finite()) {
                if s.kind == Kind::Vertical {
                    p.segments[0].push((x, f64::NAN));
                    continue;
                }
                let defined = y.is_finite();
                if defined && (!log || y > 0.0) {
                    if let Some(seg) = p.segments.last_mut() {
                        seg.push((x, ty(y)));
                    }
                    in_gap = false;
                    continue;
                }
                if !defined {
                    match (in_gap, p.undefined.last_mut()) {
                        (true, Some(run)) => run.1 = x,
                        _ => p.undefined.push((x, x)),
                    }
                    in_gap = true;
                } else {
                    p.nonpositive += 1;
                }
                if p.segments.last().is_some_and(|seg| !seg.is_empty()) {
                    p.segments.push(Vec::new());
                }
            }
            p.segments.retain(|seg| !seg.is_empty());
            for (&(x, _), &(lo, hi)) in s.points.iter().zip(&s.errors) {
                if x.is_finite() && lo.is_finite() && hi.is_finite() && (!log || lo > 0.0) {
                    p.errors.push((x, ty(lo), ty(hi)));
                }
            }
            p
        })
        .collect()
}

/// The data ranges, padded, in plot coordinates.
fn ranges(prepared: &[Prepared], log: bool) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in prepared {
        let errs = p.errors.iter().flat_map(|&(x, lo, hi)| [(x, lo), (x, hi)]);
        for (x, y) in p.segments.iter().flatten().copied().chain(errs) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            if y.is_finite() {
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
        for &(a, b) in &p.undefined {
            x0 = x0.min(a);
            x1 = x1.max(b);
        }
    }
    if !x0.is_finite() {
        (x0, x1) = (0.0, 1.0);
    }
    if !y0.is_finite() {
        (y0, y1) = (0.0, 1.0);
    }
    // Pad degenerate ranges so a constant curve still gets a readable axis.
    if x1 - x0 <= f64::EPSILON * x0.abs().max(1.0) {
        x0 -= 0.5;
        x1 += 0.5;
    } else if prepared
        .iter()
        .any(|p| matches!(p.kind, Kind::Points | Kind::Paper) || !p.errors.is_empty())
    {
        // Room for markers and error bars at the ends of the axis.
        let pad = 0.03 * (x1 - x0);
        x0 -= pad;
        x1 += pad;
    }
    let span = y1 - y0;
    let pad = if log {
        (0.05 * span).max(0.15)
    } else if span > f64::EPSILON * y0.abs().max(1.0) {
        0.05 * span
    } else {
        0.5 * y0.abs().max(1.0)
    };
    (x0, x1, y0 - pad, y1 + pad)
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The chart of the figure on the root area `root` (the same layout on every pass).
fn chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
) -> std::result::Result<Chart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    ChartBuilder::on(root)
        .margin_top(TITLE_H)
        .margin_left(MARGIN as u32)
        .margin_right(40)
        .x_label_area_size(56)
        .y_label_area_size(92)
        .build_cartesian_2d(x0..x1, y0..y1)
}

fn render(path: &Path, figure: &Figure<'_>, series: &[Series]) -> Result<String> {
    let drawn = |e: &dyn std::fmt::Display| Error::Plot {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let log = figure.y_scale == Scale::Log;
    let prepared = prepare(series, log);
    let range = ranges(&prepared, log);
    let (_, _, y0, y1) = range;

    // Notes: the figure's own, then one per series with undefined or left-out values.
    let (x_name, x_unit) = figure
        .x_label
        .split_once(" [")
        .map_or((figure.x_label, ""), |(n, u)| (n, u.trim_end_matches(']')));
    let mut notes: Vec<String> = figure.notes.to_vec();
    for p in &prepared {
        let name = if p.label.is_empty() {
            "a curve"
        } else {
            &p.label
        };
        for &(a, b) in &p.undefined {
            notes.push(format!(
                "{name}: undefined (no value) for {x_name} = {a:.4}–{b:.4} {x_unit}: drawn as \
                 a gap, shaded, marked × at its start"
            ));
        }
        if p.nonpositive > 0 {
            notes.push(format!(
                "{name}: {} values ≤ 0 left out of the log axis",
                p.nonpositive
            ));
        }
    }
    let note_lines = wrap(
        &notes,
        (f64::from(WIDTH) - 2.0 * f64::from(MARGIN)) / (GLYPH_WIDTH * NOTE_FONT),
    );

    // Legend layout: equal columns, as many as fit.
    let entries: Vec<&Prepared> = prepared.iter().filter(|p| !p.label.is_empty()).collect();
    // Column widths for `cols` columns filled row by row; the most columns that fit.
    let widths = |cols: usize| -> Vec<f64> {
        let mut w = vec![0.0f64; cols];
        for (k, p) in entries.iter().enumerate() {
            w[k % cols] = w[k % cols].max(36.0 + text_width(&p.label, LEGEND_FONT) + 18.0);
        }
        w
    };
    let inner = f64::from(WIDTH) - 2.0 * f64::from(MARGIN) - 16.0;
    let cols = (1..=entries.len().max(1))
        .rev()
        .find(|&c| widths(c).iter().sum::<f64>() <= inner)
        .unwrap_or(1);
    let col_x: Vec<f64> = widths(cols)
        .iter()
        .scan(0.0, |acc, w| {
            let x = *acc;
            *acc += w;
            Some(x)
        })
        .collect();
    let rows = entries.len().div_ceil(cols) as i32;
    let legend_top = (TITLE_H + CHART_H) as i32 + 6;
    let legend_h = if rows > 0 { rows * LEGEND_ROW + 12 } else { 0 };
    let notes_top = legend_top + legend_h + 8;
    let height = (notes_top + note_lines.len() as i32 * NOTE_ROW + MARGIN)
        .max((TITLE_H + CHART_H) as i32 + MARGIN) as u32;

    // Pass 1: background and mesh (plotters), and the frame of the data area.
    let mut axes = String::new();
    let frame;
    {
        let root = SVGBackend::with_string(&mut axes, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| drawn(&e))?;
        let chart_area = root.split_vertically(TITLE_H + CHART_H).0;
        let mut c = chart(&chart_area, range).map_err(|e| drawn(&e))?;
        let mut mesh = c.configure_mesh();
        mesh.label_style((FONT, 14)).x_labels(10);
        if log {
            mesh.y_labels(0).disable_y_mesh();
        }
        mesh.draw().map_err(|e| drawn(&e))?;
        frame = c.plotting_area().get_pixel_range();
        if log {
            let grid = RGBColor(220, 220, 220);
            for v in log_ticks(y0, y1) {
                let (_, py) = c.backend_coord(&(range.0, v));
                root.draw(&PathElement::new(
                    vec![(frame.0.start, py), (frame.0.end, py)],
                    grid.stroke_width(1),
                ))
                .map_err(|e| drawn(&e))?;
            }
        }
        root.present().map_err(|e| drawn(&e))?;
    }
    let (fx, fy) = (frame.0.clone(), frame.1.clone());

    // Pass 2: the data (plotters), in pixel coordinates of the same chart.
    let mut data = String::new();
    let mut ticks = String::new();
    let mut undefined = String::new();
    {
        let root = SVGBackend::with_string(&mut data, (WIDTH, height)).into_drawing_area();
        let chart_area = root.split_vertically(TITLE_H + CHART_H).0;
        let c = chart(&chart_area, range).map_err(|e| drawn(&e))?;
        let px = |x: f64, y: f64| c.backend_coord(&(x, y));
        if log {
            for v in log_ticks(y0, y1) {
                let (_, py) = px(range.0, v);
                ticks.push_str(&text(
                    f64::from(fx.start - 6),
                    f64::from(py),
                    "end",
                    14.0,
                    &log_tick_text(v),
                    "",
                ));
            }
        }
        // Error bars of different series at the same x are set side by side, 4 px apart.
        let with_bars = prepared.iter().filter(|p| !p.errors.is_empty()).count() as i32;
        let mut bar_slot = 0;
        for p in &prepared {
            let style = p.color.stroke_width(2);
            let dodge = if p.errors.is_empty() {
                0
            } else {
                bar_slot += 1;
                4 * (bar_slot - 1) - 2 * (with_bars - 1)
            };
            for seg in &p.segments {
                let pix: Vec<(i32, i32)> = seg.iter().map(|&(x, y)| px(x, y)).collect();
                let draw_path = |v: Vec<(i32, i32)>| {
                    root.draw(&PathElement::new(v, style))
                        .map_err(|e| drawn(&e))
                };
                match p.kind {
                    Kind::Line => draw_path(pix)?,
                    Kind::Dashed => {
                        for d in dashes(&pix) {
                            draw_path(d)?;
                        }
                    }
                    Kind::Vertical => {
                        for &(x, _) in seg {
                            let (top, bottom) = (px(x, y1), px(x, y0));
                            for d in dashes(&[top, bottom]) {
                                draw_path(d)?;
                            }
                        }
                    }
                    Kind::Points => {
                        for q in pix {
                            root.draw(&Circle::new(q, 3, p.color.filled()))
                                .map_err(|e| drawn(&e))?;
                        }
                    }
                    Kind::Paper => {
                        for (x, y) in pix {
                            draw_path(vec![
                                (x, y - 7),
                                (x + 7, y),
                                (x, y + 7),
                                (x - 7, y),
                                (x, y - 7),
                            ])?;
                        }
                    }
                }
            }
            for &(x, lo, hi) in &p.errors {
                let ((bx, blo), (_, bhi)) = (px(x, lo), px(x, hi));
                let bx = bx + dodge;
                let thin = p.color.stroke_width(1);
                for v in [
                    vec![(bx, blo), (bx, bhi)],
                    vec![(bx - 4, blo), (bx + 4, blo)],
                    vec![(bx - 4, bhi), (bx + 4, bhi)],
                ] {
                    root.draw(&PathElement::new(v, thin))
                        .map_err(|e| drawn(&e))?;
                }
            }
            for &(a, b) in &p.undefined {
                // A pale band over the undefined stretch, × at its start on the top edge.
                let (xa, xb) = (px(a, y1).0, px(b, y1).0);
                let c = hex(p.color);
                let _ = writeln!(
                    undefined,
                    "<rect x=\"{xa}\" y=\"{}\" width=\"{}\" height=\"{}\" opacity=\"0.12\" fill=\"{c}\" stroke=\"none\"/>",
                    fy.start,
                    (xb - xa).max(2),
                    fy.end - fy.start
                );
                let mark = text(
                    f64::from(xa),
                    f64::from(fy.start + 9),
                    "middle",
                    18.0,
                    "×",
                    "",
                );
                undefined.push_str(&mark.replacen("#000000", &c, 1));
            }
        }
        root.present().map_err(|e| drawn(&e))?;
    }

    // Legend: an opaque box below the chart, so it never covers the data.
    let mut legend = String::new();
    if rows > 0 {
        let (lx, lw) = (MARGIN, WIDTH as i32 - 2 * MARGIN);
        let _ = writeln!(
            legend,
            "<rect x=\"{lx}\" y=\"{legend_top}\" width=\"{lw}\" height=\"{legend_h}\" opacity=\"1\" fill=\"#FFFFFF\" stroke=\"#000000\"/>"
        );
        for (k, p) in entries.iter().enumerate() {
            let row = (k / cols) as i32;
            let x = f64::from(lx) + 8.0 + col_x[k % cols];
            let y = f64::from(legend_top + 6 + row * LEGEND_ROW + LEGEND_ROW / 2);
            let c = hex(p.color);
            let line = |dash: &str| {
                format!(
                    "<polyline fill=\"none\" stroke=\"{c}\" stroke-width=\"3\"{dash} points=\"{:.1},{y:.1} {:.1},{y:.1} \"/>\n",
                    x,
                    x + 28.0
                )
            };
            legend.push_str(&match p.kind {
                Kind::Line => line(""),
                Kind::Dashed => line(" stroke-dasharray=\"8 5\""),
                Kind::Vertical => format!(
                    "<polyline fill=\"none\" stroke=\"{c}\" stroke-width=\"3\" stroke-dasharray=\"4 3\" points=\"{:.1},{:.1} {:.1},{:.1} \"/>\n",
                    x + 14.0,
                    y - 8.0,
                    x + 14.0,
                    y + 8.0
                ),
                Kind::Points => format!(
                    "<circle cx=\"{:.1}\" cy=\"{y:.1}\" r=\"4\" fill=\"{c}\" stroke=\"none\"/>\n",
                    x + 14.0
                ),
                Kind::Paper => format!(
                    "<polyline fill=\"none\" stroke=\"{c}\" stroke-width=\"2\" points=\"{0:.1},{1:.1} {2:.1},{y:.1} {0:.1},{3:.1} {4:.1},{y:.1} {0:.1},{1:.1} \"/>\n",
                    x + 14.0,
                    y - 7.0,
                    x + 21.0,
                    y + 7.0,
                    x + 7.0
                ),
            });
            legend.push_str(&text(x + 36.0, y, "start", LEGEND_FONT, &p.label, ""));
        }
    }
    let mut note_text = String::new();
    for (k, l) in note_lines.iter().enumerate() {
        let y = f64::from(notes_top + k as i32 * NOTE_ROW + NOTE_ROW / 2);
        note_text.push_str(&text(f64::from(MARGIN), y, "start", NOTE_FONT, l, ""));
    }

    let (cx, cy) = (
        f64::from(fx.start + fx.end) / 2.0,
        f64::from(fy.start + fy.end) / 2.0,
    );
    let mut svg = format!(
        "<svg width=\"{WIDTH}\" height=\"{height}\" viewBox=\"0 0 {WIDTH} {height}\" xmlns=\"http://www.w3.org/2000/svg\">\n"
    );
    let _ = write!(
        svg,
        "<g class=\"axes\">\n{}<rect class=\"frame\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#000000\"/>\n</g>\n",
        body(&axes),
        fx.start,
        fy.start,
        fx.end - fx.start,
        fy.end - fy.start
    );
    let _ = write!(
        svg,
        "<g class=\"title\">\n{}</g>\n<g class=\"x-label\">\n{}</g>\n<g class=\"y-label\">\n{}</g>\n",
        text(
            f64::from(WIDTH) / 2.0,
            f64::from(TITLE_H) / 2.0 + 4.0,
            "middle",
            // A long title gets a smaller font rather than running off the page.
            (f64::from(WIDTH - 24)
                / (1.1 * GLYPH_WIDTH * figure.title.chars().count().max(1) as f64))
                .clamp(10.0, 20.0)
                .floor(),
            figure.title,
            " font-weight=\"bold\""
        ),
        text(
            cx,
            f64::from(fy.end + 40),
            "middle",
            15.0,
            figure.x_label,
            ""
        ),
        text(
            22.0,
            cy,
            "middle",
            15.0,
            figure.y_label,
            &format!(" transform=\"rotate(-90, 22, {cy:.1})\"")
        ),
    );
    if log {
        let _ = write!(
            svg,
            "<g class=\"y-ticks\" data-scale=\"log\">\n{ticks}</g>\n"
        );
    }
    let _ = write!(
        svg,
        "<g class=\"data\">\n{}</g>\n<g class=\"undefined\">\n{undefined}</g>\n<g class=\"legend\">\n{legend}</g>\n<g class=\"notes\">\n{note_text}</g>\n</svg>\n",
        body(&data)
    );
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fig<'a>(scale: Scale, notes: &'a [String]) -> Figure<'a> {
        Figure {
            title: "t",
            x_label: "x [s]",
            y_label: "y [m]",
            y_scale: scale,
            notes,
        }
    }

    #[test]
    fn draws_linear_and_log_plots() {
        let s = vec![
            Series::line(
                "a",
                (0..50)
                    .map(|i| (i as f64, (i as f64 * 0.2).sin()))
                    .collect(),
            ),
            Series::points("b", vec![(1.0, 0.5), (2.0, f64::NAN)]),
        ];
        let svg = render(Path::new("t.svg"), &fig(Scale::Linear, &[]), &s).expect("renders");
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
        let log = fig(Scale::Log, &[]);
        let svg = render(
            Path::new("t.svg"),
            &log,
            &[Series::line(
                "p",
                vec![(0.0, 1e-3), (1.0, 10.0), (2.0, 0.0)],
            )],
        )
        .expect("renders");
        assert!(svg.contains("data-scale=\"log\"") && svg.contains("values ≤ 0 left out"));
        // An empty figure still renders (axes only) rather than failing.
        assert!(render(Path::new("t.svg"), &log, &[]).is_ok());
    }

    #[test]
    fn undefined_values_are_gaps_with_a_note() {
        let pts = vec![
            (0.0, 1.0),
            (1.0, f64::INFINITY),
            (2.0, f64::NAN),
            (3.0, 2.0),
        ];
        let p = prepare(&[Series::line("c", pts)], false);
        assert_eq!(p[0].segments.len(), 2);
        assert_eq!(p[0].undefined, vec![(1.0, 2.0)]);
        let svg = render(
            Path::new("t.svg"),
            &fig(Scale::Linear, &[]),
            &[Series::line(
                "c",
                vec![(0.0, 1.0), (1.0, f64::NAN), (3.0, 2.0)],
            )],
        )
        .expect("renders");
        assert!(svg.contains("c: undefined (no value) for x = 1.0000–1.0000 s"));
    }
}
