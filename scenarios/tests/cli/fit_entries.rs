//! `scenarios fit --free` with single entries and the white-acceleration intensity:
//! statsmodels' SARIMAX(2,0,0) with measurement error on a record with gaps (stored by
//! `kalman/tests/golden/make_statsmodels_ar2.py` under `tests/data/sarimax/`), a
//! constant-velocity record, a named non-identified direction, and the refusals.

use std::path::{Path, PathBuf};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::common::{argv, fails, ok, read, run, scratch, write};

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&read(path)).expect("JSON")
}

fn sarimax(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/sarimax")
        .join(file)
}

fn num(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn sarimax_ar2_entries_through_the_cli_match_statsmodels() {
    let dir = scratch("fit_entries", "sarimax");
    let g = json(&sarimax("statsmodels.json"));
    let (model, data) = (sarimax("model.json"), sarimax("record.csv"));
    let (model, data) = (model.to_str().expect("path"), data.to_str().expect("path"));
    ok(
        &dir,
        &[
            "fit",
            "--model",
            model,
            "--data",
            data,
            "--free",
            "F[0,0]",
            "--free",
            "F[1,0]",
            "--free",
            "Q[0,0]",
            "--free",
            "R[0,0]",
            "--out",
            "fitted.json",
            "--summary",
            "s.json",
        ],
    );
    let s = json(&dir.join("s.json"));
    assert_eq!(s["converged"], serde_json::Value::Bool(true), "{s}");
    // Both optimisers stop on a gradient tolerance, where ln L is flat to second order.
    let (ll, llf) = (num(&s["loglik"]), num(&g["llf"]));
    assert!((ll - llf).abs() <= 1e-3, "ln L {ll} vs statsmodels {llf}");
    assert_eq!(s["n_params"], 4);
    let pairs = [
        ("F[0,0]", "ar.L1"),
        ("F[1,0]", "ar.L2"),
        ("Q[0,0]", "sigma2"),
        ("R[0,0]", "var.measurement_error"),
    ];
    for (ours, theirs) in pairs {
        let (est, se) = (num(&s["estimates"][ours]), num(&s["std_errors"][ours]));
        let (sm, oim) = (num(&g["params"][theirs]), num(&g["bse_oim"][theirs]));
        // Same optimum to 2 % of a standard error; standard errors within 10 % of Harvey's
        // OIM (which drops the terms of zero expectation: 6 % from the Hessian here).
        assert!(
            (est - sm).abs() <= 0.02 * oim,
            "{ours}: {est} vs {sm} (se {oim})"
        );
        assert!(
            (se - oim).abs() <= 0.10 * oim,
            "{ours}: se {se} vs OIM {oim}"
        );
    }
    // The correlation of the four, named in θ's order; φ1 and φ2 negatively correlated.
    let c = &s["correlation"];
    assert_eq!(
        c["names"],
        serde_json::json!(["F[0,0]", "F[1,0]", "Q[0,0]", "R[0,0]"])
    );
    assert!((num(&c["matrix"][0][0]) - 1.0).abs() < 1e-15);
    assert!(num(&c["matrix"][0][1]) < -0.3, "{c}");
    assert!((num(&c["matrix"][0][1]) - num(&c["matrix"][1][0])).abs() < 1e-15);
    assert_eq!(s["unidentified"], serde_json::json!([]));
    // The fitted file: the free entries replaced, every other entry exactly as given.
    let f = json(&dir.join("fitted.json"));
    assert!((num(&f["F"][0][0]) - num(&s["estimates"]["F[0,0]"])).abs() < 1e-15);
    assert!((num(&f["F"][1][0]) - num(&s["estimates"]["F[1,0]"])).abs() < 1e-15);
    assert!((num(&f["Q"][0][0]) - num(&s["estimates"]["Q[0,0]"])).abs() < 1e-15);
    assert_eq!(f["F"][0][1], serde_json::json!(1.0));
    assert_eq!(f["F"][1][1], serde_json::json!(0.0));
    assert_eq!(f["Q"][1][1], serde_json::json!(0.0));
    assert_eq!(f["Q"][0][1], serde_json::json!(0.0));
    assert_eq!(f["H"], serde_json::json!([[1.0, 0.0]]));
    assert_eq!(f["P0"], serde_json::json!([[4.0, 0.0], [0.0, 1.0]]));
}

/// A 2-D constant-velocity record: states (x, vx, y, vy), positions measured, white
/// acceleration of intensity `q` per axis.
fn cv_record(q: f64, r: [f64; 2], dt: f64, len: usize) -> String {
    let mut g = ChaCha8Rng::seed_from_u64(77);
    let mut n = || g.sample::<f64, _>(StandardNormal);
    // Cholesky factor of q·[dt³/3 dt²/2; dt²/2 dt].
    let l11 = (q * dt.powi(3) / 3.0).sqrt();
    let l21 = q * dt.powi(2) / 2.0 / l11;
    let l22 = (q * dt - l21 * l21).sqrt();
    let mut s = [0.0, 1.0, 0.0, -0.5];
    let mut csv = String::from("t,z1,z2\n");
    for k in 0..len {
        let (z1, z2) = (s[0] + r[0].sqrt() * n(), s[2] + r[1].sqrt() * n());
        csv.push_str(&format!("{},{z1},{z2}\n", k as f64 * dt));
        for a in [0, 2] {
            let (w1, w2) = (n(), n());
            s[a] += dt * s[a + 1] + l11 * w1;
            s[a + 1] += l21 * w1 + l22 * w2;
        }
    }
    csv
}

const CV_MODEL: &str = r#"{"dt": 0.1,
 "F": [[1, 0.1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 1]],
 "H": [[1, 0, 0, 0], [0, 0, 1, 0]],
 "Q": [[0.01, 0, 0, 0], [0, 0.01, 0, 0], [0, 0, 0.01, 0], [0, 0, 0, 0.01]],
 "R": [[1, 0], [0, 1]],
 "x0": [0, 1, 0, -0.5],
 "P0": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}"#;

#[test]
fn white_acceleration_intensity_and_r_are_recovered_within_their_bounds() {
    let dir = scratch("fit_entries", "white_acceleration");
    let (q, r) = (2.0, [0.04, 0.09]);
    write(&dir, "z.csv", &cv_record(q, r, 0.1, 800));
    write(&dir, "m.json", CV_MODEL);
    ok(
        &dir,
        &argv(
            "fit --model m.json --data z.csv --free Q:white-acceleration,R:diag --out f.json --summary s.json",
        ),
    );
    let s = json(&dir.join("s.json"));
    assert_eq!(s["n_params"], 3, "{s}");
    // Seeded, so deterministic; 3 standard errors leave a chance of 0.3 % per parameter
    // that another seed would fail, none for this one.
    let (est, se) = (
        num(&s["estimates"]["Q:white-acceleration"]),
        num(&s["std_errors"]["Q:white-acceleration"]),
    );
    assert!((est - q).abs() <= 3.0 * se, "q {est} ± {se} vs {q}");
    assert!(se < 0.5 * q, "se {se}: the record should pin q down");
    for (i, ri) in r.iter().enumerate() {
        let est_r = num(&json(&dir.join("f.json"))["R"][i][i]);
        let se_r = num(&s["std_errors"]["R"][i][i]);
        assert!(
            (est_r - ri).abs() <= 3.0 * se_r,
            "R[{i},{i}] {est_r} ± {se_r} vs {ri}"
        );
    }
    // Q is q·Q₁ with Q₁ = [dt³/3 dt²/2; dt²/2 dt] per axis, and nothing across the axes.
    let f = json(&dir.join("f.json"));
    let dt: f64 = 0.1;
    let want = [[dt.powi(3) / 3.0, dt.powi(2) / 2.0], [dt.powi(2) / 2.0, dt]];
    for a in [0, 2] {
        for i in 0..2 {
            for j in 0..2 {
                let v = num(&f["Q"][a + i][a + j]);
                assert!(
                    (v - est * want[i][j]).abs() <= 1e-12 * est,
                    "Q[{},{}] = {v}",
                    a + i,
                    a + j
                );
            }
        }
    }
    assert_eq!(f["Q"][0][2], serde_json::json!(0.0));
    assert_eq!(f["Q"][1][3], serde_json::json!(0.0));
    // EM updates the intensity in closed form (q = tr(Q₁⁻¹ S)/(n(N−1))): the same optimum,
    // ln L to 1e-3 (EM's checked stop leaves at most 5e-4 of gain).
    ok(
        &dir,
        &argv(
            "fit --model m.json --data z.csv --free Q:white-acceleration,R:diag --method em --out fe.json --summary se.json",
        ),
    );
    let e = json(&dir.join("se.json"));
    assert_eq!(e["converged"], serde_json::Value::Bool(true), "{e}");
    let (ll_mle, ll_em) = (num(&s["loglik"]), num(&e["loglik"]));
    assert!((ll_mle - ll_em).abs() <= 1e-3, "MLE {ll_mle} vs EM {ll_em}");
    let q_em = num(&e["estimates"]["Q:white-acceleration"]);
    assert!(
        (q_em - est).abs() <= 0.05 * se,
        "EM q {q_em} vs MLE {est} (se {se})"
    );
}

#[test]
fn a_direction_the_data_do_not_identify_is_named_in_the_summary() {
    // B enters only through u, and u is zero on every row: B[0,0] is free of the data.
    let dir = scratch("fit_entries", "unidentified");
    let mut csv = String::from("t,z1,u1\n");
    let mut g = ChaCha8Rng::seed_from_u64(5);
    let mut x = 0.0;
    for k in 0..300 {
        let z = x + 0.7 * g.sample::<f64, _>(StandardNormal);
        csv.push_str(&format!("{k},{z},0\n"));
        x = 0.8 * x + g.sample::<f64, _>(StandardNormal);
    }
    write(&dir, "z.csv", &csv);
    write(
        &dir,
        "m.json",
        r#"{"dt": 1, "F": [[0.5]], "B": [[1]], "H": [[1]], "D": [[0]], "Q": [[1]], "R": [[1]], "x0": [0], "P0": [[1]]}"#,
    );
    ok(
        &dir,
        &argv(
            "fit --model m.json --data z.csv --free F[0,0],B[0,0],R[0,0] --out f.json --summary s.json",
        ),
    );
    let s = json(&dir.join("s.json"));
    assert_eq!(s["std_errors"], serde_json::Value::Null);
    assert_eq!(s["correlation"], serde_json::Value::Null);
    assert_eq!(
        s["unidentified"],
        serde_json::json!([{"B[0,0]": 1.0}]),
        "{s}"
    );
    let msg = s["message"].as_str().expect("message");
    assert!(
        msg.contains("do not identify") && msg.contains("B[0,0]"),
        "{msg}"
    );
}

#[test]
fn bad_entries_are_usage_errors_naming_them() {
    let dir = scratch("fit_entries", "bad");
    write(
        &dir,
        "z.csv",
        "t,z1\n0,1\n1,0.5\n2,0.7\n3,0.1\n4,0.3\n5,0.9\n",
    );
    write(
        &dir,
        "m.json",
        r#"{"dt": 1, "F": [[0.5]], "H": [[1]], "Q": [[1]], "R": [[1]], "x0": [0], "P0": [[1]]}"#,
    );
    let cases: [(&str, &str); 8] = [
        ("G[0,0]", "unknown matrix 'G'"),
        ("F[0]", "an entry takes two indices"),
        ("x0[0,0]", "x0 takes one index"),
        ("F[a,0]", "non-negative integers"),
        ("F[1,0]", "F[1,0] is outside the 1×1 matrix F"),
        ("Q:diag,Q[0,0]", "Q is already free as a whole"),
        ("F[0,0],F[0,0]", "F[0,0] is listed twice"),
        ("H:diag", "unknown free item 'H' with structure 'diag'"),
    ];
    for (free, want) in cases {
        let err = fails(
            &dir,
            &[
                "fit", "--model", "m.json", "--data", "z.csv", "--free", free, "--out", "o.json",
            ],
        );
        assert!(err.contains(want), "--free {free}: {err}");
    }
    // Repeated flags are merged, and a whole matrix given twice across them is refused.
    let err = fails(
        &dir,
        &argv("fit --model m.json --data z.csv --free R:diag --free R:scalar --out o.json"),
    );
    assert!(err.contains("R is listed twice"), "{err}");
    // EM has no closed-form M-step for an entry: refused, not left at its start.
    let err = fails(
        &dir,
        &argv("fit --model m.json --data z.csv --free F[0,0],R:diag --method em --out o.json"),
    );
    assert!(err.contains("F[0,0]") && err.contains("MLE"), "{err}");
    // White acceleration needs a chain of integrators.
    let err = fails(
        &dir,
        &argv("fit --model m.json --data z.csv --free Q:white-acceleration --out o.json"),
    );
    assert!(err.contains("chains of integrators"), "{err}");
    assert!(!dir.join("o.json").exists());
    let out = run(&dir, &argv("fit --help"));
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        help.contains("F[i,j]") && help.contains("white-acceleration"),
        "{help}"
    );
}
