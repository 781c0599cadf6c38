//! `scenarios uav` at reduced size through the built binary: the paper's claims (stable loop
//! and filter, white innovations, estimation RMS below measurement RMS, consistent
//! Kalman–Bucy and discrete gains), byte-identical files for any `--threads` and for
//! `--shard` + `merge`, duplicated or missing shards refused by name, and configuration
//! errors that name the key.

use crate::common::{
    argv, assert_same_files, fails, finish_then_merge, ok, read, run, scratch, summary,
};

/// 1024 steps per run (256 s: 25 Welch segments of 64), the SPEC's plant, noise and gains.
const SMALL: &str = "steps = 1024\nwelch_segment = 64\n";

#[test]
fn closed_loop_is_stable_white_and_better_than_the_sensor() {
    let dir = scratch("uav", "accept");
    std::fs::write(dir.join("small.toml"), SMALL).expect("write config");
    ok(&dir, &argv("uav --config small.toml --runs 8 --out out"));
    let out = dir.join("out");
    let s = summary(&out);
    let num = |k: &str| {
        s[k].as_f64()
            .unwrap_or_else(|| panic!("{k} is not a number"))
    };
    assert_eq!(s["scenario"], "uav");
    assert_eq!(s["runs"], 8);
    assert!(num("closed_loop_spectral_radius") < 1.0);
    assert!(num("filter_spectral_radius") < 1.0);
    assert_eq!(s["innovation_whiteness_pass"], true);
    let (est, meas) = (num("rms_estimation_error"), num("rms_measurement_error"));
    // R = 1: the measurement RMS is ≈ 1 (8 runs × ~1000 samples: ±2 %), and the filter
    // roughly halves it; demand a clear margin, not just "below".
    assert!((meas - 1.0).abs() < 0.05, "{meas}");
    assert!(est < 0.7 * meas, "estimate {est} vs measurement {meas}");
    assert_eq!(s["kalman_bucy"]["consistent"], true);
    // The position tracks the unit step.
    assert!((num("tracking_mean_last_quarter") - 1.0).abs() < 0.2);
    let nodes = s["psd_nodes"].as_array().expect("psd_nodes is a list");
    assert!(nodes.len() >= 4);
    for n in nodes {
        let csv = n["csv"].as_str().expect("csv name");
        assert!(n["name"].is_string());
        let text = read(&out.join(csv));
        assert!(text.starts_with("f_hz,"), "{csv}");
        // 64-sample segments: 33 one-sided bins plus the header.
        assert_eq!(text.lines().count(), 34, "{csv}");
        let svg = read(&out.join(n["svg"].as_str().expect("svg name")));
        assert!(svg.contains("</svg>"));
    }
    // White nodes sit at their theoretical level 2σ²/fs (25 segments × 31 bins: ±10 %).
    for n in nodes.iter().filter(|n| !n["white_level"].is_null()) {
        let ratio =
            n["mean_level"].as_f64().expect("level") / n["white_level"].as_f64().expect("w");
        assert!((ratio - 1.0).abs() < 0.15, "{}: {ratio}", n["name"]);
    }
    let report = read(&out.join("report.md"));
    assert!(report.contains("| paper | ours | comment |"));
    assert!(report.contains("![node 1](signal_node1_W.svg)"));
}

#[test]
fn threads_and_shards_give_the_same_files() {
    let dir = scratch("uav", "shards");
    std::fs::write(dir.join("small.toml"), SMALL).expect("write config");
    let base = argv("uav --config small.toml --runs 6 --seed 9");
    let with = |extra: &[&str]| -> Vec<String> {
        base.iter().chain(extra).map(|s| (*s).to_string()).collect()
    };
    let go = |extra: &[&str]| {
        let args = with(extra);
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        ok(&dir, &refs);
    };
    go(&argv("--threads 1 --out t1"));
    go(&argv("--threads 2 --out t2"));
    go(&argv("--shard 1/2 --out s1"));
    go(&argv("--shard 2/2 --out s2"));
    // Run 0's trace is the closing stage: a merge without it is refused by name and writes
    // nothing; with it, the merge only reads.
    finish_then_merge(&dir, &[]);
    let one = read(&dir.join("t1/summary.json"));
    assert_same_files(&dir.join("t1"), &dir.join("t2"));
    // Every file of the merge equals the single run's, `runs.csv` with all six runs included.
    assert_same_files(&dir.join("t1"), &dir.join("merged"));
    assert_eq!(read(&dir.join("merged/runs.csv")).lines().count(), 1 + 6);
    // A shard alone is not the whole campaign.
    assert_ne!(one, read(&dir.join("s1/summary.json")));
    // Merging one shard twice is refused (run duplicated).
    let err = fails(&dir, &argv("merge s1 s1 fin --out bad"));
    assert!(
        err.contains("run 0") && err.contains("more than one shard"),
        "{err}"
    );
    // A missing shard: the directories given and the runs none of them holds.
    let err = fails(&dir, &argv("merge s1 fin --out bad"));
    assert!(
        err.contains("s1") && err.contains("runs 3–5 of the 6") && err.contains("runs.csv"),
        "{err}"
    );
    assert!(!dir.join("bad").exists(), "a failed merge writes nothing");
}

#[test]
fn bad_configuration_is_named() {
    let dir = scratch("uav", "errors");
    std::fs::write(dir.join("bad.toml"), "dt_s = -0.25\n").expect("write");
    let out = run(&dir, &argv("uav --config bad.toml --out o"));
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("dt_s") && err.contains("bad.toml"), "{err}");
    std::fs::write(dir.join("typo.toml"), "stepz = 10\n").expect("write");
    let out = run(&dir, &argv("uav --config typo.toml --out o"));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("stepz"));
    assert!(!dir.join("o").join("summary.json").exists());
}
