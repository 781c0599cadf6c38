//! The plot style, checked from the geometry of every SVG the three scenarios write (at
//! reduced size: the same files `scenarios all` writes, from smaller campaigns): every data
//! element inside the frame of the data area, the legend an opaque box that no plotted point
//! or line crosses, both axes titled with a unit, log axes labelled across their range, no
//! text running off the page, undefined stretches named in a note, and the papers' figures
//! drawn on the headline plots. `SCENARIOS_PLOTS_DIR=<reports dir>` checks a full run's
//! plots as well (e.g. the output of `cargo xtask reproduce`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::common::{ok, read, scratch};

/// One element of an SVG file: tag, attributes, text content, enclosing group's class.
#[derive(Debug)]
struct Element {
    tag: String,
    attrs: HashMap<String, String>,
    text: String,
    group: String,
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// The elements of `svg` in document order (the subset of XML plotters and the plot module
/// write: no comments, no CDATA, attribute values in double quotes).
fn parse(svg: &str) -> Vec<Element> {
    let mut out: Vec<Element> = Vec::new();
    let mut groups: Vec<String> = Vec::new();
    let mut rest = svg;
    while let Some(open) = rest.find('<') {
        let close = rest[open..].find('>').expect("tag closed") + open;
        let tag_text = &rest[open + 1..close];
        let after = &rest[close + 1..];
        rest = after;
        if let Some(name) = tag_text.strip_prefix('/') {
            if name.trim() == "g" {
                groups.pop();
            } else if name.trim() == "text" {
                // Content was taken when the element opened.
            }
            continue;
        }
        let self_closing = tag_text.ends_with('/');
        let body = tag_text.trim_end_matches('/');
        let (tag, mut attr_text) = body.split_once(' ').unwrap_or((body, ""));
        let mut attrs = HashMap::new();
        while let Some(eq) = attr_text.find("=\"") {
            let key = attr_text[..eq].trim().to_string();
            let v_end = attr_text[eq + 2..].find('"').expect("quoted value") + eq + 2;
            attrs.insert(key, unescape(&attr_text[eq + 2..v_end]));
            attr_text = &attr_text[v_end + 1..];
        }
        if tag == "g" {
            groups.push(attrs.get("class").cloned().unwrap_or_default());
            continue;
        }
        let text = if tag == "text" && !self_closing {
            unescape(&after[..after.find("</text>").expect("text closed")])
        } else {
            String::new()
        };
        out.push(Element {
            tag: tag.to_string(),
            attrs,
            text,
            group: groups.last().cloned().unwrap_or_default(),
        });
    }
    out
}

fn num(e: &Element, key: &str) -> f64 {
    e.attrs
        .get(key)
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("<{}> without a numeric {key}: {:?}", e.tag, e.attrs))
}

/// A rectangle: x0, y0, x1, y1.
type Rect = (f64, f64, f64, f64);

fn rect_of(e: &Element) -> Rect {
    let (x, y) = (num(e, "x"), num(e, "y"));
    (x, y, x + num(e, "width"), y + num(e, "height"))
}

/// The vertices of a polyline or polygon.
fn vertices(e: &Element) -> Vec<(f64, f64)> {
    e.attrs["points"]
        .split_whitespace()
        .map(|p| {
            let (x, y) = p.split_once(',').expect("x,y");
            (x.parse().expect("x"), y.parse().expect("y"))
        })
        .collect()
}

/// Whether the segment a–b meets the rectangle `r` (Liang–Barsky clipping).
fn segment_meets(a: (f64, f64), b: (f64, f64), r: Rect) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - r.0),
        (dx, r.2 - a.0),
        (-dy, a.1 - r.1),
        (dy, r.3 - a.1),
    ] {
        if p.abs() < 1e-12 {
            if q < 0.0 {
                return false;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    t0 <= t1
}

fn inside(p: (f64, f64), r: Rect, slack: f64) -> bool {
    p.0 >= r.0 - slack && p.0 <= r.2 + slack && p.1 >= r.1 - slack && p.1 <= r.3 + slack
}

/// The drawn geometry of a data element: its segments (a circle as its bounding box's
/// diagonals).
fn segments(e: &Element) -> Vec<((f64, f64), (f64, f64))> {
    match e.tag.as_str() {
        "polyline" | "polygon" => {
            let v = vertices(e);
            if v.len() == 1 {
                return vec![(v[0], v[0])];
            }
            v.windows(2).map(|w| (w[0], w[1])).collect()
        }
        "circle" => {
            let (x, y, r) = (num(e, "cx"), num(e, "cy"), num(e, "r"));
            vec![
                ((x - r, y - r), (x + r, y + r)),
                ((x - r, y + r), (x + r, y - r)),
            ]
        }
        "rect" => {
            let (x0, y0, x1, y1) = rect_of(e);
            vec![((x0, y0), (x1, y1)), ((x0, y1), (x1, y0))]
        }
        "text" => {
            let (x, y) = (num(e, "x"), num(e, "y"));
            vec![((x, y), (x, y))]
        }
        other => panic!("unexpected <{other}> among the data"),
    }
}

/// Estimated horizontal extent of a text element (the plot module's glyph estimate).
fn text_extent(e: &Element) -> (f64, f64) {
    let size: f64 = e
        .attrs
        .get("font-size")
        .map_or(14.0, |s| s.parse().expect("size"));
    let w = e.text.chars().count() as f64 * 0.55 * size;
    let x = num(e, "x");
    match e.attrs.get("text-anchor").map(String::as_str) {
        Some("middle") => (x - w / 2.0, x + w / 2.0),
        Some("end") => (x - w, x),
        _ => (x, x + w),
    }
}

/// A log tick label's value: `0.02`, `500`, `2e-5`.
fn tick_value(label: &str) -> f64 {
    label
        .parse()
        .unwrap_or_else(|_| panic!("log tick label {label:?} is not a number"))
}

/// Checks the style rules on one SVG file; returns the problems found.
pub(super) fn check(path: &Path) -> Vec<String> {
    let svg = read(path);
    let name = path.display();
    let els = parse(&svg);
    let mut problems = Vec::new();
    let root = els.first().expect("an <svg> element");
    let (width, height) = (num(root, "width"), num(root, "height"));
    let frames: Vec<&Element> = els
        .iter()
        .filter(|e| e.attrs.get("class").map(String::as_str) == Some("frame"))
        .collect();
    let [frame] = frames.as_slice() else {
        return vec![format!("{name}: {} frames, expected one", frames.len())];
    };
    let frame = rect_of(frame);
    // Every data element inside the data area (2 px for the stroke and pixel rounding).
    for e in in_group(&els, "data").chain(in_group(&els, "undefined")) {
        for (a, b) in segments(e) {
            if !inside(a, frame, 2.5) || !inside(b, frame, 2.5) {
                problems.push(format!(
                    "{name}: <{}> drawn outside the frame at {a:?}–{b:?}",
                    e.tag
                ));
                break;
            }
        }
    }
    // The legend: an opaque box outside the data area that no data element meets.
    let boxes: Vec<&Element> = in_group(&els, "legend")
        .filter(|e| e.tag == "rect")
        .collect();
    for b in &boxes {
        let r = rect_of(b);
        if b.attrs.get("fill").map(String::as_str) != Some("#FFFFFF")
            || b.attrs.get("opacity").map(String::as_str) != Some("1")
        {
            problems.push(format!("{name}: the legend box is not opaque white"));
        }
        let overlap = r.0 < frame.2 && frame.0 < r.2 && r.1 < frame.3 && frame.1 < r.3;
        if overlap {
            problems.push(format!(
                "{name}: the legend box {r:?} overlaps the data area {frame:?}"
            ));
        }
        for e in in_group(&els, "data").chain(in_group(&els, "undefined")) {
            if segments(e).into_iter().any(|(a, c)| segment_meets(a, c, r)) {
                problems.push(format!(
                    "{name}: a plotted <{}> crosses the legend box",
                    e.tag
                ));
                break;
            }
        }
    }
    if in_group(&els, "legend").any(|e| e.tag == "text") && boxes.is_empty() {
        problems.push(format!("{name}: legend entries without a box"));
    }
    // Both axes titled, with a unit in brackets.
    for axis in ["x-label", "y-label"] {
        let titled = in_group(&els, axis).any(|e| {
            e.text
                .split_once('[')
                .and_then(|(_, u)| u.split_once(']'))
                .is_some_and(|(unit, _)| !unit.trim().is_empty())
        });
        if !titled {
            problems.push(format!("{name}: the {axis} has no unit in brackets"));
        }
    }
    // No text off the page (horizontal text: estimated extent; rotated: its anchor).
    for e in els.iter().filter(|e| e.tag == "text") {
        let (x0, x1) = if e.attrs.contains_key("transform") {
            (num(e, "x"), num(e, "x"))
        } else {
            text_extent(e)
        };
        let y = num(e, "y");
        if x0 < 0.0 || x1 > width || y < 0.0 || y > height {
            problems.push(format!(
                "{name}: text {:?} runs off the page ({x0:.0}–{x1:.0} of {width})",
                e.text
            ));
        }
    }
    // A log axis is labelled across its range: labels in order, no gap (nor the stretch
    // from an end of the axis to the nearest label) longer than 40 % of the axis.
    let log_ticks: Vec<(f64, f64)> = in_group(&els, "y-ticks")
        .map(|e| (num(e, "y"), tick_value(&e.text)))
        .collect();
    if svg.contains("data-scale=\"log\"") {
        let mut t = log_ticks.clone();
        t.sort_by(|a, b| a.0.total_cmp(&b.0));
        let h = frame.3 - frame.1;
        let mut stops: Vec<f64> = vec![frame.1];
        stops.extend(t.iter().map(|p| p.0));
        stops.push(frame.3);
        let gap = stops.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
        if t.len() < 3 || gap > 0.4 * h {
            problems.push(format!(
                "{name}: log axis labels {:?} leave a gap of {:.0} % of the axis",
                t.iter().map(|p| p.1).collect::<Vec<_>>(),
                100.0 * gap / h
            ));
        }
        if t.windows(2).any(|w| w[1].1 >= w[0].1) {
            problems.push(format!("{name}: log axis labels do not fall down the page"));
        }
    }
    // An undefined stretch is named in a note.
    if in_group(&els, "undefined").next().is_some()
        && !in_group(&els, "notes").any(|e| e.text.contains("undefined"))
    {
        problems.push(format!(
            "{name}: undefined values marked but not named in a note"
        ));
    }
    problems
}

/// The elements of `els` inside the group of class `g`.
fn in_group<'a>(els: &'a [Element], g: &'a str) -> impl Iterator<Item = &'a Element> + 'a {
    els.iter().filter(move |e| e.group == g)
}

pub(super) fn svgs(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            out.extend(svgs(&path));
        } else if path.extension().is_some_and(|x| x == "svg") {
            out.push(path);
        }
    }
    out.sort();
    out
}

fn legend_texts(path: &Path) -> Vec<String> {
    parse(&read(path))
        .into_iter()
        .filter(|e| e.group == "legend" && e.tag == "text")
        .map(|e| e.text)
        .collect()
}

#[test]
fn every_plot_keeps_the_style() {
    let dir = scratch("plots", "style");
    let fueling = "calibration.search = \"off\"\namplitudes_deg = [0.0, 0.5, 1.0]\n\
                   periods_s = [6.0, 10.0]\nfill_rates_mm_s = [10.0, 20.0]\n\
                   damper_times_s = [1.0, 2.0]\ninvariance_amplitudes_deg = [1.0]\n\
                   invariance_periods_s = [6.0]\nsteps_mm = [5.0, 10.0]\n\
                   runs_per_point = 40\nsweep_runs_per_point = 20\n";
    for (name, config, runs) in [
        ("fueling", fueling, "20"),
        ("uav", "steps = 1024\nwelch_segment = 64\n", "4"),
        (
            "boom",
            "[sweep]\nstep_deg = 5.0\n[tracking]\nruns = 4\n",
            "4",
        ),
    ] {
        std::fs::write(dir.join(format!("{name}.toml")), config).expect("write config");
        let cfg = format!("{name}.toml");
        let out = format!("out/{name}");
        ok(
            &dir,
            &[name, "--config", &cfg, "--runs", runs, "--out", &out],
        );
    }
    let files = svgs(&dir.join("out"));
    // The files `scenarios all` writes: 6 fueling, 9 uav, 18 boom plots.
    assert_eq!(files.len(), 33, "{files:?}");
    let mut problems: Vec<String> = files.iter().flat_map(|f| check(f)).collect();
    if let Some(extra) = std::env::var_os("SCENARIOS_PLOTS_DIR") {
        let full = svgs(Path::new(&extra));
        assert!(
            !full.is_empty(),
            "no SVG under {}",
            Path::new(&extra).display()
        );
        problems.extend(full.iter().flat_map(|f| check(f)));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));

    // The papers' figures on the headline plots, labelled "paper".
    let out = dir.join("out");
    for file in [
        "fueling/amplitude_std.svg",
        "fueling/period_std.svg",
        "boom/gamma_sweep.svg",
        "boom/direct_gamma0_alpha.svg",
        "boom/wls_gamma0_eps.svg",
        "boom/wls_gamma10_alpha.svg",
        "uav/psd_1_noise_generator_W.svg",
        "uav/psd_2_sensor_output_z.svg",
        "uav/psd_4_error_signal.svg",
    ] {
        let labels = legend_texts(&out.join(file));
        assert!(
            labels.iter().any(|l| l.contains("paper")),
            "{file}: no legend entry names the paper: {labels:?}"
        );
    }
    // Direct inversion at γ = 0 is undefined past ≈ 86° in variant "+": a gap, not a value.
    let direct = read(&out.join("boom/direct_gamma0_alpha.svg"));
    assert!(direct.contains("δα⁺ (variant +): undefined (no value) for t"));
    let d = parse(&direct);
    assert!(d.iter().any(|e| e.group == "undefined"));
}

#[test]
fn the_checker_sees_a_legend_over_the_data() {
    // A hand-made file with the legend box across a plotted line must fail, and the same
    // file with the box moved below the frame must pass.
    let dir = scratch("plots", "checker");
    let svg = |legend_y: u32| {
        format!(
            "<svg width=\"400\" height=\"300\" viewBox=\"0 0 400 300\" xmlns=\"http://www.w3.org/2000/svg\">\n\
             <g class=\"axes\">\n<rect class=\"frame\" x=\"50\" y=\"20\" width=\"300\" height=\"200\" fill=\"none\" stroke=\"#000000\"/>\n</g>\n\
             <g class=\"x-label\">\n<text x=\"200\" y=\"250\" text-anchor=\"middle\" font-size=\"12\">t [s]</text>\n</g>\n\
             <g class=\"y-label\">\n<text x=\"20\" y=\"120\" transform=\"rotate(-90, 20, 120)\" font-size=\"12\">y [m]</text>\n</g>\n\
             <g class=\"data\">\n<polyline fill=\"none\" stroke=\"#1F77B4\" stroke-width=\"2\" points=\"50,200 350,40 \"/>\n</g>\n\
             <g class=\"legend\">\n<rect x=\"200\" y=\"{legend_y}\" width=\"100\" height=\"30\" opacity=\"1\" fill=\"#FFFFFF\" stroke=\"#000000\"/>\n\
             <text x=\"210\" y=\"{}\" font-size=\"12\">a</text>\n</g>\n</svg>\n",
            legend_y + 15
        )
    };
    let bad = dir.join("bad.svg");
    std::fs::write(&bad, svg(100)).expect("write");
    let found = check(&bad);
    assert!(
        found.iter().any(|p| p.contains("crosses the legend box")),
        "{found:?}"
    );
    assert!(
        found.iter().any(|p| p.contains("overlaps the data area")),
        "{found:?}"
    );
    let good = dir.join("good.svg");
    std::fs::write(&good, svg(260)).expect("write");
    assert_eq!(check(&good), Vec::<String>::new());
    // A log axis labelled only at its lower half fails.
    let log = svg(260).replace(
        "<g class=\"data\">",
        "<g class=\"y-ticks\" data-scale=\"log\">\n<text x=\"45\" y=\"220\" text-anchor=\"end\" font-size=\"12\">0.01</text>\n\
         <text x=\"45\" y=\"180\" text-anchor=\"end\" font-size=\"12\">0.1</text>\n\
         <text x=\"45\" y=\"140\" text-anchor=\"end\" font-size=\"12\">1</text>\n</g>\n<g class=\"data\">",
    );
    let log_file = dir.join("log.svg");
    std::fs::write(&log_file, log).expect("write");
    assert!(
        check(&log_file)
            .iter()
            .any(|p| p.contains("log axis labels"))
    );
}
