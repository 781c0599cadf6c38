//! `cargo xtask bench`: runs the criterion benchmarks, then prints each bench's ratio against
//! the baseline measured in the same run.
//!
//! Convention for every bench in the workspace: inside a criterion group, a function whose
//! name starts with `baseline` is the reference; every other function is compared with the
//! baseline that has the same parameter (or with the group's only baseline). The ratio is
//! `time(bench) / time(baseline)`, from criterion's mean point estimate.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result};

use crate::{cargo, known, root, run};

/// One measured benchmark, read back from criterion's output directory.
struct Measured {
    group: String,
    function: String,
    parameter: String,
    mean_ns: f64,
}

pub(crate) fn bench(args: &[String]) -> Result<()> {
    known(args, &["--quick"], &["--bench"])?;
    let quick = args.iter().any(|a| a == "--quick");
    let criterion_dir = root().join("target").join("criterion");
    // Old results would mix with new ones in the table: start clean.
    if criterion_dir.exists() {
        std::fs::remove_dir_all(&criterion_dir)
            .with_context(|| format!("clearing {}", criterion_dir.display()))?;
    }
    let mut cmd = cargo();
    // `--bench *`: only the criterion targets (libs and bins would reject criterion's flags).
    cmd.args(["bench", "--workspace", "--all-features", "--bench", "*"]);
    if let Some(i) = args.iter().position(|a| a == "--bench") {
        // One bench target instead of all (the last `--bench` wins).
        cmd.arg("--bench").arg(&args[i + 1]);
    }
    cmd.arg("--");
    if quick {
        cmd.args([
            "--warm-up-time",
            "0.5",
            "--measurement-time",
            "1",
            "--sample-size",
            "10",
        ]);
    }
    run(cmd)?;
    let measured = read_all(&criterion_dir)?;
    print!("{}", ratio_table(&measured));
    Ok(())
}

/// Reads every `new/estimates.json` with its `benchmark.json` below `dir`.
fn read_all(dir: &Path) -> Result<Vec<Measured>> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if !path.is_dir() {
                continue;
            }
            if path.file_name().is_some_and(|n| n == "new") {
                if let Some(m) = read_one(&path)? {
                    out.push(m);
                }
            } else if path
                .file_name()
                .is_none_or(|n| n != "base" && n != "report")
            {
                stack.push(path);
            }
        }
    }
    out.sort_by(|a, b| {
        (&a.group, &a.parameter, &a.function).cmp(&(&b.group, &b.parameter, &b.function))
    });
    Ok(out)
}

fn read_one(new_dir: &Path) -> Result<Option<Measured>> {
    let (Ok(bench), Ok(est)) = (
        std::fs::read_to_string(new_dir.join("benchmark.json")),
        std::fs::read_to_string(new_dir.join("estimates.json")),
    ) else {
        return Ok(None);
    };
    let bench: serde_json::Value = serde_json::from_str(&bench)
        .with_context(|| format!("parsing {}", new_dir.join("benchmark.json").display()))?;
    let est: serde_json::Value = serde_json::from_str(&est)
        .with_context(|| format!("parsing {}", new_dir.join("estimates.json").display()))?;
    let text = |v: &serde_json::Value| v.as_str().unwrap_or("").to_string();
    let Some(mean_ns) = est["mean"]["point_estimate"].as_f64() else {
        return Ok(None);
    };
    Ok(Some(Measured {
        group: text(&bench["group_id"]),
        function: text(&bench["function_id"]),
        parameter: text(&bench["value_str"]),
        mean_ns,
    }))
}

/// Formats the ratio of each bench against its baseline.
fn ratio_table(measured: &[Measured]) -> String {
    let mut baselines: BTreeMap<(&str, &str), Vec<&Measured>> = BTreeMap::new();
    for m in measured
        .iter()
        .filter(|m| m.function.starts_with("baseline"))
    {
        baselines
            .entry((&m.group, &m.parameter))
            .or_default()
            .push(m);
    }
    let mut by_group: BTreeMap<&str, Vec<&Measured>> = BTreeMap::new();
    for m in measured
        .iter()
        .filter(|m| m.function.starts_with("baseline"))
    {
        by_group.entry(&m.group).or_default().push(m);
    }
    let mut out = String::from("\nbench ratios (time / in-run baseline; < 1 is faster):\n");
    out.push_str(&format!(
        "{:<28} {:<28} {:<12} {:>12} {:>10}  baseline\n",
        "group", "bench", "param", "mean", "ratio"
    ));
    for m in measured {
        let base = baselines
            .get(&(m.group.as_str(), m.parameter.as_str()))
            .and_then(|b| b.first())
            .or_else(|| match by_group.get(m.group.as_str()) {
                Some(b) if b.len() == 1 => b.first(),
                _ => None,
            });
        let (ratio, base_name) = match base {
            Some(b) if !std::ptr::eq(*b, m) => {
                (format!("{:.3}", m.mean_ns / b.mean_ns), b.function.as_str())
            }
            Some(_) => ("1".to_string(), "(is baseline)"),
            None => ("-".to_string(), "(none)"),
        };
        out.push_str(&format!(
            "{:<28} {:<28} {:<12} {:>12} {:>10}  {}\n",
            m.group,
            m.function,
            m.parameter,
            human_time(m.mean_ns),
            ratio,
            base_name
        ));
    }
    out
}

fn human_time(ns: f64) -> String {
    if ns < 1e3 {
        format!("{ns:.1} ns")
    } else if ns < 1e6 {
        format!("{:.2} µs", ns / 1e3)
    } else if ns < 1e9 {
        format!("{:.2} ms", ns / 1e6)
    } else {
        format!("{:.2} s", ns / 1e9)
    }
}
