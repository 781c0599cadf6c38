//! `scenarios fit` on a continuous model file over an irregular record: the summary's
//! log-likelihood against a closed-form filter at the fitted values, the intensity and the
//! sensor variance recovered within their bounds, the fitted file filtering the same record,
//! and the refusals.

#![allow(non_snake_case)]

use std::path::Path;

use nalgebra::{Matrix2, RowVector2, Vector2};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::common::{argv, fails, mat, ok, read, refused, scratch, write};

/// A constant-velocity target, white acceleration of intensity Qc through G, position seen.
const CV: &str = r#"{"A": [[0, 1], [0, 0]], "G": [[0], [1]], "Qc": [[1]], "C": [[1, 0]],
"R": [[1]], "x0": [0, 0], "P0": [[10, 0], [0, 10]]}"#;

/// F = [[1, Δt], [0, 1]], Q = q [[Δt³/3, Δt²/2], [Δt²/2, Δt]]: the exact sampling.
fn closed_form(q: f64, dt: f64) -> (Matrix2<f64>, Matrix2<f64>) {
    (
        Matrix2::new(1.0, dt, 0.0, 1.0),
        q * Matrix2::new(dt.powi(3) / 3.0, dt.powi(2) / 2.0, dt.powi(2) / 2.0, dt),
    )
}

/// 500 rows 0.05–0.35 s apart with a 3 s dropout, q = 0.5, R = 0.04, seeded.
fn record() -> (Vec<f64>, Vec<f64>, String) {
    let mut g = ChaCha8Rng::seed_from_u64(11);
    let (mut t, mut z) = (vec![0.0], Vec::new());
    let mut x = Vector2::new(0.0, 2.0);
    let mut csv = String::from("t,z1\n");
    for k in 0..500 {
        let v = x[0] + 0.2 * g.sample::<f64, _>(StandardNormal);
        csv.push_str(&format!("{},{v}\n", t[k]));
        z.push(v);
        let dt = if k == 200 {
            3.0
        } else {
            0.05 + 0.3 * g.random::<f64>()
        };
        let (F, Q) = closed_form(0.5, dt);
        let L = Q.cholesky().expect("Q > 0").l();
        x = F * x
            + L * Vector2::new(
                g.sample::<f64, _>(StandardNormal),
                g.sample::<f64, _>(StandardNormal),
            );
        t.push(t[k] + dt);
    }
    t.pop();
    (t, z, csv)
}

/// The log-likelihood by a filter written out here (closed-form sampling), prior (0, 10 I).
fn reference_loglik(t: &[f64], z: &[f64], q: f64, r: f64) -> f64 {
    let H = RowVector2::new(1.0, 0.0);
    let (mut x, mut P) = (Vector2::zeros(), Matrix2::identity() * 10.0);
    let mut ll = 0.0;
    for k in 0..t.len() {
        let e = z[k] - (H * x)[0];
        let s = (H * P * H.transpose())[0] + r;
        ll -= 0.5 * (e * e / s + s.ln() + (2.0 * std::f64::consts::PI).ln());
        let K = P * H.transpose() / s;
        x += K * e;
        let IKH = Matrix2::identity() - K * H;
        P = IKH * P * IKH.transpose() + K * K.transpose() * r;
        if let Some(next) = t.get(k + 1) {
            let (F, Q) = closed_form(q, next - t[k]);
            x = F * x;
            P = F * P * F.transpose() + Q;
        }
    }
    ll
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&read(path)).expect("JSON")
}

/// The fit's ln L is the closed-form filter's at the fitted (q, R) to 1e-9 relative (two
/// implementations sharing nothing but the data, ~500 terms of order 1), each estimate lies
/// within three of its standard errors of the truth (a fixed seed), and the fitted file is a
/// continuous model `filter` runs over the same stamps.
#[test]
fn a_continuous_model_is_fitted_over_the_records_own_time_stamps() {
    let dir = scratch("fit", "continuous");
    let (t, z, csv) = record();
    write(&dir, "z.csv", &csv);
    write(&dir, "cv.json", CV);
    ok(
        &dir,
        &argv(
            "fit --model cv.json --data z.csv --free Qc:scalar,R:diag --out fitted.json \
             --summary fit.json",
        ),
    );
    let s = json(&dir.join("fit.json"));
    assert_eq!(s["time"], "continuous");
    assert_eq!(s["converged"], true, "{s}");
    let (q, r) = (
        s["estimates"]["Qc"].as_f64().expect("Qc"),
        s["estimates"]["R[0,0]"].as_f64().expect("R"),
    );
    let ll = s["loglik"].as_f64().expect("loglik");
    let want = reference_loglik(&t, &z, q, r);
    assert!((ll - want).abs() <= 1e-9 * want.abs(), "{ll} vs {want}");
    for (name, truth, est) in [("Qc", 0.5, q), ("R[0,0]", 0.04, r)] {
        let se = s["std_errors"][name].as_f64().expect("std error");
        assert!(
            (est - truth).abs() < 3.0 * se,
            "{name}: {est} ± {se} vs {truth}"
        );
    }
    let fitted = json(&dir.join("fitted.json"));
    assert_eq!(fitted["Qc"][0][0].as_f64(), Some(q));
    assert_eq!(mat(&fitted["A"]), [[0.0, 1.0], [0.0, 0.0]], "A stays fixed");
    ok(
        &dir,
        &argv("filter --model fitted.json --data z.csv --out est.csv"),
    );
    assert_eq!(read(&dir.join("est.csv")).lines().count(), 501);

    // A drift entry, A[1,1] (a velocity damping; the record's truth is 0), freed beside the
    // noise: its estimate lies within three standard errors of 0, named as the summary
    // names it, and the fitted file carries it in A.
    ok(
        &dir,
        &argv(
            "fit --model cv.json --data z.csv --free A[1,1],Qc:scalar,R:diag --out fitted_a.json \
             --summary fit_a.json",
        ),
    );
    let s = json(&dir.join("fit_a.json"));
    assert_eq!(s["converged"], true, "{s}");
    let a11 = s["estimates"]["A[1,1]"].as_f64().expect("A[1,1]");
    let se = s["std_errors"]["A[1,1]"].as_f64().expect("its std error");
    assert!(a11.abs() < 3.0 * se, "A[1,1] = {a11} ± {se}");
    // The same number written and read back: bit-equal.
    assert_eq!(
        mat(&json(&dir.join("fitted_a.json"))["A"])[1][1].to_bits(),
        a11.to_bits()
    );
}

/// What a continuous model's fit cannot do is refused in one line, with nothing written.
#[test]
fn the_continuous_fit_refuses_what_it_cannot_fit() {
    let dir = scratch("fit", "continuous_refused");
    let (_, _, csv) = record();
    write(&dir, "z.csv", &csv);
    write(&dir, "cv.json", CV);
    for (free, method, expect) in [
        ("H[0,0]", "mle", "H is fixed"),
        ("Qc:full", "mle", "not full"),
        ("Q:white-acceleration", "mle", "Qc:scalar"),
        ("Qc:scalar", "em", "needs a discrete model"),
    ] {
        refused(
            &dir,
            &[
                "fit",
                "--model",
                "cv.json",
                "--data",
                "z.csv",
                "--free",
                free,
                "--method",
                method,
                "--out",
                "fitted.json",
            ],
            &[expect],
            2,
        );
    }
    let back = csv.replacen("\n0.", "\n-5.", 1);
    write(&dir, "back.csv", &back);
    let err = fails(
        &dir,
        &argv("fit --model cv.json --data back.csv --free Qc:scalar --out fitted.json"),
    );
    assert!(err.contains("back.csv") && err.contains("line 3"), "{err}");
    write(&dir, "nan.csv", &csv.replacen("\n0.", "\nNaN,0.", 1));
    let err = fails(
        &dir,
        &argv("fit --model cv.json --data nan.csv --free Qc:scalar --out fitted.json"),
    );
    assert!(err.contains("nan.csv") && err.contains("line 3"), "{err}");
}
