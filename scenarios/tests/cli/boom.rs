//! `scenarios boom` at reduced size through the built binary: the paper's conclusions
//! (direct inversion fails near 90°, WLS at γ = 10° holds both limits for both variants, WLS
//! at γ = 0 stays defined, the γ window contains 10°), the summary schema (the WLS family's
//! and the tracking filters' rows, the noise Monte Carlo), the units/weights verdict in the
//! report, shards that merge into the single run's files, and errors that name the key.

use crate::common::{argv, assert_same_files, fails, ok, read, run, scratch};

/// The full turn and all cases, with a coarse γ sweep (0, 5, …, 20°) and a small noise
/// Monte Carlo to keep it fast.
const SMALL: &str = "[sweep]\nstep_deg = 5.0\n[tracking]\nruns = 6\n";

fn case<'a>(
    s: &'a serde_json::Value,
    method: &str,
    gamma: f64,
    bias: &str,
) -> &'a serde_json::Value {
    s["cases"]
        .as_array()
        .expect("cases is a list")
        .iter()
        .find(|c| {
            c["method"] == method
                && (c["gamma_deg"].as_f64().expect("γ") - gamma).abs() < 1e-9
                && c["bias"] == bias
        })
        .unwrap_or_else(|| panic!("no case {method} γ={gamma} {bias}"))
}

/// The keys of the JSON object `v`, sorted.
fn sorted_keys(v: &serde_json::Value) -> Vec<&str> {
    let mut k: Vec<&str> = v
        .as_object()
        .expect("object")
        .keys()
        .map(String::as_str)
        .collect();
    k.sort_unstable();
    k
}

#[test]
fn the_papers_conclusions_hold() {
    let dir = scratch("boom", "accept");
    std::fs::write(dir.join("small.toml"), SMALL).expect("write config");
    ok(&dir, &argv("boom --config small.toml --out out"));
    let out = dir.join("out");
    let s: serde_json::Value =
        serde_json::from_str(&read(&out.join("summary.json"))).expect("JSON");
    assert_eq!(s["scenario"], "boom");
    assert_eq!(s["limits"]["alpha_deg"], 1.0);
    assert_eq!(s["limits"]["eps_deg_s2"], 0.5);
    // The summary's schema, exactly, for every case.
    let keys = [
        "bias",
        "first_violation_alpha_deg",
        "gamma_deg",
        "max_alpha_err_deg",
        "max_eps_err_deg_s2",
        "method",
        "undefined_from_alpha_deg",
    ];
    for c in s["cases"].as_array().expect("cases") {
        let k = sorted_keys(c);
        assert_eq!(k, keys);
    }
    // Six methods (three of the paper's, EKF, UKF, unscented RTS) × γ ∈ {0, 10} × {+, −}.
    assert_eq!(s["cases"].as_array().map(Vec::len), Some(24));
    for method in ["direct", "linear3", "wls", "ekf", "ukf", "urts"] {
        for gamma in [0.0, 10.0] {
            for bias in ["+", "-"] {
                let c = case(&s, method, gamma, bias);
                assert!(c["max_alpha_err_deg"].as_f64().is_some_and(f64::is_finite));
            }
        }
    }
    // The noise Monte Carlo: one row per method and γ, with its schema.
    let mc = s["noise_mc"].as_array().expect("noise_mc");
    assert_eq!(mc.len(), 8);
    for r in mc {
        let k = sorted_keys(r);
        assert_eq!(
            k,
            [
                "gamma_deg",
                "method",
                "rms_alpha_err_deg",
                "rms_eps_err_deg_s2",
                "runs"
            ]
        );
        assert_eq!(r["runs"], 6);
    }
    let mc_row = |method: &str, gamma: f64| {
        mc.iter()
            .find(|r| {
                r["method"] == method && (r["gamma_deg"].as_f64().expect("γ") - gamma).abs() < 1e-9
            })
            .unwrap_or_else(|| panic!("no noise_mc row {method} γ={gamma}"))
    };
    // The smoother conditions on the whole turn, the filter only on the past: over the same
    // noisy turns its RMS errors cannot be larger (the UKF's forward pass is its input).
    for gamma in [0.0, 10.0] {
        for what in ["rms_alpha_err_deg", "rms_eps_err_deg_s2"] {
            let smooth = mc_row("urts", gamma)[what].as_f64().expect("num");
            let filter = mc_row("ukf", gamma)[what].as_f64().expect("num");
            assert!(
                smooth <= filter,
                "γ={gamma} {what}: urts {smooth} > ukf {filter}"
            );
        }
    }
    // Direct inversion fails near 90° in both variants: over the limits (or undefined) from
    // somewhere in (80°, 90°), and nowhere before.
    for bias in ["+", "-"] {
        let c = case(&s, "direct", 0.0, bias);
        let from = c["first_violation_alpha_deg"]
            .as_f64()
            .expect("direct must fail");
        assert!(from > 80.0 && from < 90.0, "direct {bias}: {from}");
    }
    assert!(case(&s, "direct", 0.0, "+")["undefined_from_alpha_deg"].is_number());
    // WLS at γ = 10° holds both limits over the whole turn, both variants.
    for bias in ["+", "-"] {
        let c = case(&s, "wls", 10.0, bias);
        assert!(c["first_violation_alpha_deg"].is_null(), "{c}");
        assert!(c["undefined_from_alpha_deg"].is_null(), "{c}");
        assert!(c["max_alpha_err_deg"].as_f64().expect("num") <= 1.0);
        assert!(c["max_eps_err_deg_s2"].as_f64().expect("num") <= 0.5);
    }
    // WLS at γ = 0 stays defined in both variants.
    for bias in ["+", "-"] {
        assert!(case(&s, "wls", 0.0, bias)["undefined_from_alpha_deg"].is_null());
    }
    // The feasible window contains 10°; the sweep rows carry within_limits.
    let w = s["feasible_gamma_deg"].as_array().expect("a window");
    let (lo, hi) = (w[0].as_f64().expect("lo"), w[1].as_f64().expect("hi"));
    assert!(lo <= 10.0 && 10.0 <= hi, "{lo}..{hi}");
    let sweep = s["gamma_sweep"].as_array().expect("sweep");
    assert_eq!(sweep.len(), 5);
    assert!(sweep.iter().all(|r| r["within_limits"].is_boolean()));
    assert_eq!(
        sweep[0]["within_limits"], false,
        "γ = 0 must not be feasible"
    );
    // The report states which units/weights reproduce the paper and embeds the plots.
    let report = read(&out.join("report.md"));
    assert!(report.contains("Which units and weights reproduce the paper"));
    assert!(report.contains("**Verdict.**"));
    assert!(report.contains("Maxima exclude only the first cycle"));
    assert_eq!(s["alternative_verdicts"].as_array().map(Vec::len), Some(32));
    assert!(report.contains("## Nonlinear filters against WLS"));
    assert!(report.contains("**Comment.**"));
    for svg in [
        "tracking_gamma0_alpha.svg",
        "tracking_gamma0_eps.svg",
        "gamma_sweep.svg",
        "wls_gamma10_eps.svg",
        "direct_gamma0_alpha.svg",
    ] {
        assert!(report.contains(&format!("]({svg})")), "{svg}");
        assert!(read(&out.join(svg)).contains("</svg>"));
    }
}

#[test]
fn shards_merge_into_the_single_run() {
    let dir = scratch("boom", "merge");
    // The smallest useful campaign: one γ sweep point beyond 0 and no extras.
    std::fs::write(
        dir.join("tiny.toml"),
        "case_gammas_deg = [10.0]\n[sweep]\nfrom_deg = 8.0\nto_deg = 12.0\nstep_deg = 4.0\n[beyond]\nenabled = false\n[tracking]\nruns = 3\n",
    )
    .expect("write config");
    ok(&dir, &argv("boom --config tiny.toml --shard 1/2 --out a"));
    ok(&dir, &argv("boom --config tiny.toml --shard 2/2 --out b"));
    ok(&dir, &argv("merge a b --out m"));
    ok(&dir, &argv("boom --config tiny.toml --threads 1 --out t1"));
    ok(&dir, &argv("boom --config tiny.toml --threads 2 --out t2"));
    // Every file of the merge equals the single run's; shards differ only in saying so.
    assert_same_files(&dir.join("t1"), &dir.join("m"));
    assert_same_files(&dir.join("t1"), &dir.join("t2"));
    assert!(read(&dir.join("a/summary.json")).contains("\"shard\": \"1/2\""));
    // The Monte Carlo's runs are split between the shards (1 + 2 of 3) and merged whole.
    let rows = |d: &str| read(&dir.join(d).join("runs_noise.csv")).lines().count() - 1;
    assert_eq!((rows("a"), rows("b"), rows("m")), (1, 2, 3));
    // A shard of a differently configured campaign is refused.
    std::fs::write(dir.join("other.toml"), "case_gammas_deg = [5.0]\n[sweep]\nfrom_deg = 8.0\nto_deg = 12.0\nstep_deg = 4.0\n[beyond]\nenabled = false\n[tracking]\nruns = 3\n").expect("write");
    ok(&dir, &argv("boom --config other.toml --out c"));
    let err = fails(&dir, &argv("merge a c --out bad"));
    assert!(err.contains("another campaign"), "{err}");
    assert!(!dir.join("bad").exists(), "a failed merge writes nothing");
}

#[test]
fn bad_configuration_is_named() {
    let dir = scratch("boom", "errors");
    std::fs::write(dir.join("bad.toml"), "[limits]\nalpha_deg = 0.0\n").expect("write");
    let out = run(&dir, &argv("boom --config bad.toml --out o"));
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("limits.alpha_deg") && err.contains("bad.toml"),
        "{err}"
    );
    std::fs::write(dir.join("typo.toml"), "[estimator]\nunits = \"Degree\"\n").expect("write");
    let out = run(&dir, &argv("boom --config typo.toml --out o"));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("units"));
    assert!(!dir.join("o").exists());
}
