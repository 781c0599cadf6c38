//! The plot module's drawing pieces: a log axis's ticks and labels, raw SVG text, dashes
//! in pixel space, line wrapping of the notes.

use plotters::style::RGBColor;

use super::{FONT, GLYPH_WIDTH};

/// Tick positions (log10 values) of a log axis over `[y0, y1]`: 1-2-5 (or 1-2-3-5) per
/// decade on a short axis, decades on a long one, every k-th decade on a very long one, so
/// the labels span the range at most about a third of the axis apart.
pub(super) fn log_ticks(y0: f64, y1: f64) -> Vec<f64> {
    let span = y1 - y0;
    let mantissas: &[f64] = if span <= 0.6 {
        &[1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
    } else if span <= 1.3 {
        &[1.0, 2.0, 3.0, 5.0]
    } else if span <= 3.5 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let step = if span > 10.0 {
        (span / 8.0).ceil() as i64
    } else {
        1
    };
    let (d0, d1) = (y0.floor() as i64, y1.ceil() as i64);
    let mut ticks = Vec::new();
    for d in (d0..=d1).filter(|d| d.rem_euclid(step) == 0) {
        for m in mantissas {
            let v = d as f64 + m.log10();
            if (y0..=y1).contains(&v) {
                ticks.push(v);
            }
        }
    }
    ticks
}

/// The label of the log tick at log10 value `v`: `0.02`, `500`, `2e-5`.
pub(super) fn log_tick_text(v: f64) -> String {
    let d = v.floor();
    let m = (10f64.powf(v - d) * 10.0).round() / 10.0;
    let d = d as i32;
    let m_text = if (m - m.round()).abs() < 1e-9 {
        format!("{}", m.round())
    } else {
        format!("{m}")
    };
    match d {
        0..=4 => {
            let value = m * 10f64.powi(d);
            if (value - value.round()).abs() < 1e-9 {
                format!("{}", value.round())
            } else {
                format!("{value}")
            }
        }
        -4..=-1 => {
            let digits = (-d) as usize + usize::from(m_text.contains('.'));
            format!("{:.digits$}", m * 10f64.powi(d))
        }
        _ => format!("{m_text}e{d}"),
    }
}

/// XML-escaped text.
pub(super) fn esc(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '&' => s.push_str("&amp;"),
            '"' => s.push_str("&quot;"),
            other => s.push(other),
        }
    }
    s
}

pub(super) fn hex(c: RGBColor) -> String {
    format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
}

/// A `<text>` element.
pub(super) fn text(x: f64, y: f64, anchor: &str, size: f64, content: &str, extra: &str) -> String {
    format!(
        "<text x=\"{x:.1}\" y=\"{y:.1}\" dy=\"0.35em\" text-anchor=\"{anchor}\" \
         font-family=\"{FONT}\" font-size=\"{size}\" fill=\"#000000\"{extra}>{}</text>\n",
        esc(content)
    )
}

/// Estimated width of `content` at font size `size`, pixels.
pub(super) fn text_width(content: &str, size: f64) -> f64 {
    content.chars().count() as f64 * GLYPH_WIDTH * size
}

/// Pieces of a pixel polyline, 8 px drawn and 5 px left out in turn.
pub(super) fn dashes(pts: &[(i32, i32)]) -> Vec<Vec<(i32, i32)>> {
    const ON: f64 = 8.0;
    const PERIOD: f64 = 13.0;
    let mut out = Vec::new();
    let mut phase = 0.0f64;
    for w in pts.windows(2) {
        let (a, b) = (
            (f64::from(w[0].0), f64::from(w[0].1)),
            (f64::from(w[1].0), f64::from(w[1].1)),
        );
        let len = (b.0 - a.0).hypot(b.1 - a.1);
        let at = |t: f64| {
            let f = if len > 0.0 { t / len } else { 0.0 };
            (
                (a.0 + f * (b.0 - a.0)).round() as i32,
                (a.1 + f * (b.1 - a.1)).round() as i32,
            )
        };
        let mut t = 0.0;
        while t < len {
            let in_period = phase.rem_euclid(PERIOD);
            if in_period < ON {
                let end = (t + ON - in_period).min(len);
                out.push(vec![at(t), at(end)]);
                phase += end - t;
                t = end;
            } else {
                let end = (t + PERIOD - in_period).min(len);
                phase += end - t;
                t = end;
            }
        }
    }
    out
}

/// The body of a plotters SVG document (between `<svg …>` and `</svg>`).
pub(super) fn body(svg: &str) -> &str {
    let start = svg.find(">\n").map_or(0, |i| i + 2);
    let end = svg.rfind("</svg>").unwrap_or(svg.len());
    svg.get(start..end).unwrap_or("")
}

/// `notes` broken into lines of at most `width` characters, at spaces.
pub(super) fn wrap(notes: &[String], width: f64) -> Vec<String> {
    let width = width.max(20.0) as usize;
    let mut lines = Vec::new();
    for note in notes {
        let mut line = String::new();
        for word in note.split(' ') {
            if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
                lines.push(std::mem::take(&mut line));
                line.push_str("  ");
            } else if !line.is_empty() {
                line.push(' ');
            }
            line.push_str(word);
        }
        lines.push(line);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_span_the_range() {
        // 0.01 … 6: decades and the 2s and 5s between them, up to 5.
        let t = log_ticks(-2.0, 6f64.log10());
        let labels: Vec<String> = t.iter().map(|&v| log_tick_text(v)).collect();
        assert_eq!(
            labels,
            ["0.01", "0.02", "0.05", "0.1", "0.2", "0.5", "1", "2", "5"]
        );
        // Ten decades: every decade; the largest gap is a decade, a tenth of the axis.
        let t = log_ticks(-9.0, 1.0);
        assert_eq!(t.len(), 11);
        assert_eq!(log_tick_text(-7.0), "1e-7");
        assert_eq!(log_tick_text(2f64.log10() - 5.0), "2e-5");
        assert_eq!(log_tick_text(3.0), "1000");
        // A short axis still gets several labels.
        assert!(log_ticks(0.1, 0.5).len() >= 3);
    }

    #[test]
    fn dashes_alternate_along_the_line() {
        let d = dashes(&[(0, 0), (26, 0)]);
        assert_eq!(d, vec![vec![(0, 0), (8, 0)], vec![(13, 0), (21, 0)]]);
    }
}
