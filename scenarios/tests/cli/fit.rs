//! `scenarios fit`: the round trip fit → filter, the summary against the library, EM
//! against MLE, and every bad input through the binary.

use std::path::{Path, PathBuf};

use kalman::CovarianceForm;
use kalman::fit::{Series, System, log_likelihood};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::common::{argv, argv_with, fails, ok, read, run, scratch, snapshot};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write input");
    p
}

/// 300 steps of a local level (σ²: level 0.5, measurement 4), seeded.
fn llt_csv() -> (String, Vec<f64>) {
    let mut g = ChaCha8Rng::seed_from_u64(3);
    let mut level = 0.0;
    let mut csv = String::from("t,z1\n");
    let mut z = Vec::new();
    for k in 0..300 {
        let v = level + 2.0 * g.sample::<f64, _>(StandardNormal);
        csv.push_str(&format!("{k},{v}\n"));
        z.push(v);
        level += 0.5f64.sqrt() * g.sample::<f64, _>(StandardNormal);
    }
    (csv, z)
}

const LLT_MODEL: &str =
    r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "x0": [0], "P0": [[100]]}"#;

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&read(path)).expect("JSON")
}

#[test]
fn fit_then_filter_round_trip_and_the_summary_matches_the_library() {
    let dir = scratch("fit", "round_trip");
    let (csv, z) = llt_csv();
    write(&dir, "z.csv", &csv);
    write(&dir, "m.json", LLT_MODEL);
    let mut ll = [0.0; 2];
    for (i, method) in ["mle", "em"].iter().enumerate() {
        let (out, summary) = (
            format!("fitted-{method}.json"),
            format!("fit-{method}.json"),
        );
        ok(
            &dir,
            &argv_with(
                "fit --model m.json --data z.csv --free Q:scalar,R:diag --method {} --out {} --summary {}",
                &[method, &out, &summary],
            ),
        );
        let s = json(&dir.join(&summary));
        assert_eq!(s["converged"], serde_json::Value::Bool(true), "{s}");
        assert_eq!(s["method"], serde_json::Value::String((*method).into()));
        let loglik = s["loglik"].as_f64().expect("loglik");
        // The fitted file is a model file `filter` reads as is …
        ok(
            &dir,
            &argv_with("filter --model {} --data z.csv --out est.csv", &[&out]),
        );
        // … and the summary's log-likelihood is the library's on the fitted model.
        let m =
            scenarios::userdata::model_file::load_discrete(&dir.join(&out)).expect("fitted model");
        let f =
            |a: &nalgebra::DMatrix<f64>| faer::Mat::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)]);
        let x0: Vec<f64> = m.x0.iter().copied().collect();
        let sys = System::new(
            &f(&m.F),
            &f(&m.H),
            &f(&m.Q),
            &f(&m.R),
            &x0,
            &f(m.P0.as_ref().expect("P0")),
        )
        .expect("system");
        let lib = log_likelihood(
            &sys,
            &Series::new(&z, 1).expect("series"),
            CovarianceForm::Joseph,
        )
        .expect("ll");
        assert!(
            (lib - loglik).abs() <= 1e-9 * lib.abs(),
            "{method}: summary {loglik} vs library {lib}"
        );
        // AIC, BIC from the log-likelihood and the 2 free parameters; standard errors in the
        // shapes of the free matrices.
        assert!((s["aic"].as_f64().expect("aic") - (4.0 - 2.0 * loglik)).abs() < 1e-9);
        assert!(
            (s["bic"].as_f64().expect("bic") - (2.0 * 300f64.ln() - 2.0 * loglik)).abs() < 1e-9
        );
        let se = &s["std_errors"];
        assert_eq!(se["Q"][0].as_array().map(|r| r.len()), Some(1), "{se}");
        assert_eq!(se["R"][0].as_array().map(|r| r.len()), Some(1), "{se}");
        assert!(se["R"][0][0].as_f64().expect("se") > 0.0);
        ll[i] = loglik;
    }
    assert!(
        (ll[0] - ll[1]).abs() < 1e-3,
        "MLE {} vs EM {}",
        ll[0],
        ll[1]
    );
}

#[test]
fn fit_bad_inputs_are_one_line_errors() {
    let dir = scratch("fit", "bad");
    let (csv, _) = llt_csv();
    write(&dir, "z.csv", &csv);
    write(&dir, "m.json", LLT_MODEL);
    // Nothing free.
    let err = fails(
        &dir,
        &[
            "fit", "--model", "m.json", "--data", "z.csv", "--free", "", "--out", "o.json",
        ],
    );
    assert!(err.contains("nothing is free"), "{err}");
    // An unknown item (a usage error reported by the argument parser).
    let out = run(
        &dir,
        &argv("fit --model m.json --data z.csv --free F:diag --out o.json"),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("unknown free item 'F'"), "{err}");
    // A free R entry whose channel is never observed.
    write(
        &dir,
        "m2.json",
        r#"{"dt": 1, "F": [[1]], "H": [[1], [1]], "Q": [[1]], "R": [[1, 0], [0, 1]], "P0": [[1]]}"#,
    );
    write(&dir, "z2.csv", "t,z1,z2\n0,1,\n1,2,\n2,1.5,\n3,2.5,\n");
    let err = fails(
        &dir,
        &argv("fit --model m2.json --data z2.csv --free R:diag --out o.json"),
    );
    assert!(
        err.contains("cannot be identified") && err.contains("channel 1"),
        "{err}"
    );
    // No measurement at all.
    write(&dir, "z3.csv", "t,z1\n0,\n1,NaN\n2,\n");
    let err = fails(
        &dir,
        &argv("fit --model m.json --data z3.csv --free Q:diag --out o.json"),
    );
    assert!(err.contains("no measurement"), "{err}");
    // Not converged: exit code 1, one line saying what to try; nothing written.
    let out = run(
        &dir,
        &argv(
            "fit --model m.json --data z.csv --free Q:scalar,R:diag --method em --max-iter 2 --out o.json",
        ),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("not converged") && err.contains("--allow-unconverged"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(!dir.join("o.json").exists());
    // The same run through the library: a typed error a caller can match, with the
    // optimiser's reason.
    let args = scenarios::fit::FitArgs {
        model: dir.join("m.json"),
        data: dir.join("z.csv"),
        free: vec![scenarios::fit::parse_free("Q:scalar,R:diag").expect("free")],
        method: scenarios::fit::FitMethod::Em,
        out: dir.join("o.json"),
        summary: None,
        allow_unconverged: false,
        max_iter: Some(2),
        diffuse: Vec::new(),
    };
    match scenarios::fit::fit(&args) {
        Err(e @ scenarios::error::Error::FitNotConverged { .. }) => assert_eq!(e.exit_code(), 1),
        other => panic!("expected FitNotConverged, got {other:?}"),
    }
    assert!(!dir.join("o.json").exists());
    // … unless allowed.
    ok(
        &dir,
        &argv(
            "fit --model m.json --data z.csv --free Q:scalar,R:diag --method em --max-iter 2 --allow-unconverged --out o.json --summary s.json",
        ),
    );
    assert_eq!(
        json(&dir.join("s.json"))["converged"],
        serde_json::Value::Bool(false)
    );
}

/// `--diffuse 0`: the local level's level has no prior; the summary's ln L is the library's
/// exact diffuse likelihood at the fitted variances (to the 1e-12 of a JSON round trip of the
/// estimates), and the same model with P0 = 1e12 — a prior the first update cannot keep
/// digits against — is refused in one line that points to `--diffuse`.
#[test]
fn a_diffuse_level_is_fitted_and_a_swamping_prior_is_refused() {
    let dir = scratch("fit", "diffuse");
    let (csv, z) = llt_csv();
    write(&dir, "z.csv", &csv);
    write(&dir, "m.json", LLT_MODEL);
    ok(
        &dir,
        &argv(
            "fit --model m.json --data z.csv --free Q:diag,R:diag --diffuse 0 --out d.json --summary s.json",
        ),
    );
    let s = json(&dir.join("s.json"));
    assert_eq!(s["diffuse"], serde_json::json!([0]));
    let fitted = json(&dir.join("d.json"));
    let (q, r) = (
        fitted["Q"][0][0].as_f64().expect("Q"),
        fitted["R"][0][0].as_f64().expect("R"),
    );
    let sys = System::new(&[[1.0]], &[[1.0]], &[[q]], &[[r]], &[0.0], &[[100.0]]).expect("system");
    let series = Series::new(&z, 1).expect("series");
    let want = kalman::fit::diffuse_log_likelihood(&sys, &[0], &series).expect("ll");
    let got = s["loglik"].as_f64().expect("loglik");
    assert!((got - want).abs() <= 1e-9 * want.abs(), "{got} vs {want}");
    write(&dir, "wide.json", &LLT_MODEL.replace("[[100]]", "[[1e12]]"));
    let err = fails(
        &dir,
        &argv("fit --model wide.json --data z.csv --free Q:diag,R:diag --out w.json"),
    );
    assert!(
        err.contains("wide.json") && err.contains("--diffuse"),
        "{err}"
    );
    let err = fails(
        &dir,
        &argv("fit --model m.json --data z.csv --free Q:diag --diffuse 0 --method em --out w.json"),
    );
    assert!(err.contains("--diffuse needs --method mle"), "{err}");
}

/// `--summary` is an output like `--out`: refused before any work when it names an input
/// or the same destination as `--out` (a new file under two spellings, an existing one,
/// standard output twice), with every file in the directory left as it was; `-` sends it to
/// standard output.
#[test]
fn the_summary_never_overwrites_an_input_or_the_fitted_model() {
    let dir = scratch("fit", "summary_destination");
    let (csv, _) = llt_csv();
    write(&dir, "z.csv", &csv);
    write(&dir, "m.json", LLT_MODEL);
    let line = |outputs: &str| {
        format!("fit --model m.json --data z.csv --free Q:scalar,R:scalar {outputs}")
    };
    let words = |line: &str| line.split(' ').map(str::to_owned).collect::<Vec<String>>();
    let refuse = |outputs: &str| {
        let w = words(&line(outputs));
        let args: Vec<&str> = w.iter().map(String::as_str).collect();
        fails(&dir, &args)
    };
    for (outputs, expect) in [
        (
            "--out f.json --summary z.csv",
            "--summary z.csv: is the same file as --data z.csv",
        ),
        (
            "--out f.json --summary m.json",
            "--summary m.json: is the same file as --model m.json",
        ),
        (
            "--out f.json --summary ./f.json",
            "--summary ./f.json: is the same destination as --out f.json",
        ),
        (
            "--out - --summary -",
            "--summary -: is the same destination as --out -",
        ),
    ] {
        let before = snapshot(&dir);
        let err = refuse(outputs);
        assert!(err.contains(expect), "{outputs}: {err}");
        assert_eq!(snapshot(&dir), before, "{outputs} touched a file");
    }
    let w = words(&line("--out f.json --summary s.json"));
    ok(&dir, &w.iter().map(String::as_str).collect::<Vec<_>>());
    let before = snapshot(&dir);
    let err = refuse("--out f.json --summary f.json");
    assert!(err.contains("same destination as --out"), "{err}");
    assert_eq!(snapshot(&dir), before, "a refusal touched a file");
    let w = words(&line("--out f2.json --summary -"));
    let out = run(&dir, &w.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).expect("summary JSON");
    assert_eq!(printed["loglik"], json(&dir.join("s.json"))["loglik"]);
}
