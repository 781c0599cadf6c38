//! `filter --diagnostics` through the built binary: every number of the file against an
//! independent scalar filter written here (innovations, NIS, autocorrelation, Ljung–Box with
//! the closed-form χ² tail for even degrees of freedom) and against
//! `kalman::fit::log_likelihood`; a wrong model flagged; and the refusals (inputs, the same
//! destination as `--out`, too short a record, lags without the option) leaving no file.

use std::path::Path;

use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

use crate::common::{argv, argv_with, fails, ok, read, run, scratch};

const MODEL: &str =
    "dt = 1\nF = [[0.95]]\nH = [[1]]\nQ = [[0.5]]\nR = [[2]]\nx0 = [0]\nP0 = [[4]]\n";
const N: usize = 600;
const LAGS: usize = 10;

/// A scalar AR(1) (φ = 0.95, q = 0.5) observed in noise (r = 2), seeded, with row 17
/// missing.
fn simulate(dir: &Path) -> Vec<f64> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
    let mut g = || -> f64 { StandardNormal.sample(&mut rng) };
    let mut x = 2.0 * g();
    let mut csv = String::from("t,z1\n");
    let mut z = Vec::with_capacity(N);
    for k in 0..N {
        let zk = if k == 17 {
            f64::NAN
        } else {
            x + 2f64.sqrt() * g()
        };
        z.push(zk);
        if zk.is_nan() {
            csv.push_str(&format!("{k},\n"));
        } else {
            csv.push_str(&format!("{k},{zk}\n"));
        }
        x = 0.95 * x + 0.5f64.sqrt() * g();
    }
    std::fs::write(dir.join("m.toml"), MODEL).expect("model");
    std::fs::write(dir.join("z.csv"), csv).expect("data");
    z
}

/// The scalar filter by hand: standardised prior innovations (NaN where missing) and NIS.
fn by_hand(z: &[f64], f: f64, q: f64, r: f64) -> (Vec<f64>, Vec<f64>, f64) {
    let (mut x, mut p) = (0.0, 4.0);
    let (mut nu, mut nis, mut ll) = (Vec::new(), Vec::new(), 0.0);
    for zk in z {
        if zk.is_nan() {
            nu.push(f64::NAN);
        } else {
            let s = p + r;
            let e = zk - x;
            nu.push(e / s.sqrt());
            nis.push(e * e / s);
            ll += -0.5 * (e * e / s + s.ln() + (2.0 * std::f64::consts::PI).ln());
            x += p / s * e;
            p -= p * p / s;
        }
        x *= f;
        p = f * f * p + q;
    }
    (nu, nis, ll)
}

/// e^{−x/2} Σ_{i<k/2} (x/2)^i/i!: P(χ²_k ≥ x) for even k.
fn chi2_tail_even(x: f64, k: usize) -> f64 {
    let (mut term, mut sum) = (1.0, 0.0);
    for i in 0..k / 2 {
        if i > 0 {
            term *= 0.5 * x / i as f64;
        }
        sum += term;
    }
    (-0.5 * x).exp() * sum
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&read(path)).expect("diagnostics are JSON")
}

fn num(v: &serde_json::Value) -> f64 {
    v.as_f64().expect("a number")
}

#[test]
fn diagnostics_match_an_independent_filter_and_the_likelihood() {
    let dir = scratch("diag", "match");
    let z = simulate(&dir);
    let lags = LAGS.to_string();
    let args = argv_with(
        "filter --model m.toml --data z.csv --out est.csv --diagnostics d.json --diagnostics-lags {}",
        &[&lags],
    );
    ok(&dir, &args);
    let d = json(&dir.join("d.json"));
    let (nu, nis, ll_hand) = by_hand(&z, 0.95, 0.5, 2.0);

    assert_eq!(d["steps"], N);
    assert_eq!(d["measured_steps"], N - 1);
    // The log-likelihood is the fit module's, to round-off (same steps, same order).
    let sys = kalman::fit::System::new(&[[0.95]], &[[1.0]], &[[0.5]], &[[2.0]], &[0.0], &[[4.0]])
        .expect("system");
    let series = kalman::fit::Series::new(&z, 1).expect("series");
    let ll_fit = kalman::fit::log_likelihood(&sys, &series, kalman::CovarianceForm::Joseph)
        .expect("likelihood");
    let ll = num(&d["log_likelihood"]);
    assert!(
        (ll - ll_fit).abs() <= 1e-12 * ll_fit.abs(),
        "{ll} vs {ll_fit}"
    );
    // … and the scalar recursion's (600 steps of O(1) terms: round-off ~1e-13 relative).
    assert!(
        (ll - ll_hand).abs() <= 1e-10 * ll_hand.abs(),
        "{ll} vs {ll_hand}"
    );

    // NIS mean, and its band: χ²_D/D with D = 599 by Wilson–Hilferty,
    // D·(1 − 2/(9D) ± 1.96·√(2/(9D)))³, whose relative error at D ≈ 600 is below 1e-4.
    let mean = nis.iter().sum::<f64>() / nis.len() as f64;
    assert!((num(&d["nis"]["mean"]) - mean).abs() < 1e-12 * mean);
    let dof = (N - 1) as f64;
    let c = 2.0 / (9.0 * dof);
    let wh = |zq: f64| (1.0 - c + zq * c.sqrt()).powi(3);
    let band = &d["nis"]["band"];
    assert!(
        (num(&band[0]) / wh(-1.959_964) - 1.0).abs() < 1e-3,
        "{band}"
    );
    assert!((num(&band[1]) / wh(1.959_964) - 1.0).abs() < 1e-3, "{band}");
    assert_eq!(d["nis"]["mean_in_band"], true, "{d}");
    // Per-step band of χ²₁ at 95 % from tables: [0.000982069, 5.023886].
    let outside = nis
        .iter()
        .filter(|v| **v < 0.000_982_069 || **v > 5.023_886)
        .count() as f64
        / nis.len() as f64;
    let got = num(&d["nis"]["outside_step_band_fraction"]);
    assert!((got - outside).abs() < 1e-12, "{got} vs {outside}");

    // Autocorrelation of the standardised innovations (pairs with a missing end skipped)
    // and the Ljung–Box statistic and p-value.
    let ch = &d["innovations"][0];
    assert_eq!(ch["observed"], N - 1);
    let obs: Vec<f64> = nu.iter().copied().filter(|v| !v.is_nan()).collect();
    let m = obs.iter().sum::<f64>() / obs.len() as f64;
    let c0: f64 = obs.iter().map(|v| (v - m) * (v - m)).sum();
    let n = obs.len() as f64;
    let mut q = 0.0;
    for k in 0..=LAGS {
        let ck: f64 = (0..N - k)
            .filter(|&i| !nu[i].is_nan() && !nu[i + k].is_nan())
            .map(|i| (nu[i] - m) * (nu[i + k] - m))
            .sum();
        let rho = ck / c0;
        // Same data, different summation order: round-off.
        assert!((num(&ch["acf"][k]) - rho).abs() < 1e-12, "lag {k}");
        if k > 0 {
            q += rho * rho / (n - k as f64);
        }
    }
    q *= n * (n + 2.0);
    let lb = &ch["ljung_box"];
    assert!((num(&lb["statistic"]) - q).abs() < 1e-9 * q, "{lb} vs {q}");
    let p = chi2_tail_even(q, LAGS);
    assert!((num(&lb["p_value"]) - p).abs() < 1e-9 * p, "{lb} vs {p}");
    assert_eq!(lb["dof"], LAGS);
    assert!((num(&ch["acf_bound"]) - 1.959_964 / n.sqrt()).abs() < 1e-6);

    // --smooth reports the same forward pass.
    let mut smooth_args = args.to_vec();
    smooth_args[8] = "d2.json";
    smooth_args.push("--smooth");
    ok(&dir, &smooth_args);
    assert_eq!(read(&dir.join("d.json")), read(&dir.join("d2.json")));

    // Standard output, when --out is a file.
    let mut stdout_args = args.to_vec();
    stdout_args[8] = "-";
    let out = run(&dir, &stdout_args);
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        read(&dir.join("d.json"))
    );
}

#[test]
fn a_wrong_model_is_flagged() {
    let dir = scratch("diag", "wrong");
    simulate(&dir);
    // Q a hundred times too small: the filter lags, the innovations are too large and
    // correlated.
    std::fs::write(
        dir.join("small_q.toml"),
        MODEL.replace("Q = [[0.5]]", "Q = [[0.005]]"),
    )
    .expect("model");
    ok(
        &dir,
        &argv("filter --model small_q.toml --data z.csv --out est.csv --diagnostics d.json"),
    );
    let d = json(&dir.join("d.json"));
    assert_eq!(d["nis"]["mean_in_band"], false, "{d}");
    assert!(num(&d["nis"]["mean"]) > num(&d["nis"]["band"][1]), "{d}");
    assert!(
        num(&d["innovations"][0]["ljung_box"]["p_value"]) < 1e-6,
        "{d}"
    );
    assert_eq!(d["innovations"][0]["ljung_box"]["lags"], 20);
}

/// The files in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn refusals_leave_no_file() {
    let dir = scratch("diag", "refuse");
    simulate(&dir);
    let before = listing(&dir);
    let base = argv("filter --model m.toml --data z.csv --out est.csv");
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        base.iter().chain(extra).copied().collect()
    };
    for (extra, expect) in [
        (
            &["--diagnostics", "z.csv"][..],
            "--diagnostics z.csv: is the same file as --data",
        ),
        (
            &["--diagnostics", "m.toml"][..],
            "--diagnostics m.toml: is the same file as --model",
        ),
        (
            &["--diagnostics", "est.csv"][..],
            "same destination as --out",
        ),
        (&["--diagnostics", "."][..], "--diagnostics ."),
        (&["--diagnostics-lags", "3"][..], "--diagnostics"),
        (
            &argv("--diagnostics d.json --diagnostics-lags 0")[..],
            "--diagnostics-lags",
        ),
        (
            &argv("--diagnostics d.json --diagnostics-lags 600")[..],
            "599 observed",
        ),
    ] {
        let err = fails(&dir, &with(extra));
        assert!(err.contains(expect), "{extra:?}: {err}");
        assert_eq!(listing(&dir), before, "{extra:?} left a file");
    }
    // An existing --out given again as --diagnostics (same inode) is refused too.
    ok(&dir, &base);
    let err = fails(&dir, &with(&["--diagnostics", "./est.csv"]));
    assert!(err.contains("same destination as --out"), "{err}");
    // Both on standard output would interleave.
    let err = fails(
        &dir,
        &argv("filter --model m.toml --data z.csv --out - --diagnostics -"),
    );
    assert!(err.contains("same destination as --out"), "{err}");
    // A data error writes neither file.
    std::fs::write(dir.join("bad.csv"), "t,z1\n0,1\n1,x\n").expect("bad data");
    let err = fails(
        &dir,
        &argv("filter --model m.toml --data bad.csv --out e2.csv --diagnostics d2.json"),
    );
    assert!(err.contains("bad.csv"), "{err}");
    assert!(!dir.join("e2.csv").exists() && !dir.join("d2.json").exists());
}
