//! The resampling schemes against FilterPy 1.4.5's `filterpy.monte_carlo` on the same
//! uniforms (golden indices from `tests/golden/make_resampling.py`) and against their
//! definitions: copy counts within their bounds, and unbiased.

use kalman::particle::{Resampling, effective_sample_size};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

const SCHEMES: [Resampling; 4] = [
    Resampling::Multinomial,
    Resampling::Stratified,
    Resampling::Systematic,
    Resampling::Residual,
];

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

fn indices(v: &Value) -> Vec<usize> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| usize::try_from(x.as_u64().expect("index")).expect("small"))
        .collect()
}

#[test]
fn indices_equal_filterpy_on_the_same_uniforms() {
    // Indices are integers: equality, no tolerance. The positions are compared with the
    // cumulative sums in the same order of operations up to the division by N, so a position
    // within round-off of a boundary could differ; none of the stored cases has one.
    let golden: Value =
        serde_json::from_str(include_str!("../golden/filterpy_resampling.json")).expect("json");
    assert_eq!(golden["filterpy"], "1.4.5");
    let cases = golden["cases"].as_array().expect("cases");
    assert_eq!(cases.len(), 11);
    let mut residual_differs = 0;
    for (c, case) in cases.iter().enumerate() {
        let w = floats(&case["weights"]);
        for (scheme, key) in [
            (Resampling::Multinomial, "multinomial"),
            (Resampling::Stratified, "stratified"),
            (Resampling::Systematic, "systematic"),
            (Resampling::Residual, "residual_corrected"),
        ] {
            let u = floats(&case[key]["uniforms"]);
            let want = indices(&case[key]["indices"]);
            let mut got = vec![0; w.len()];
            scheme.resample(&w, &u, &mut got).expect("valid input");
            assert_eq!(got, want, "case {c}, {key}");
        }
        // FilterPy's own residual scheme: its deterministic copies are the definition's …
        let copies: usize = w
            .iter()
            .map(|x| (w.len() as f64 * x).floor() as usize)
            .sum();
        let theirs = indices(&case["residual"]["indices"]);
        let mut ours = vec![0; w.len()];
        let u = floats(&case["residual"]["uniforms"]);
        Resampling::Residual
            .resample(&w, &u, &mut ours)
            .expect("valid input");
        assert_eq!(
            ours[..copies],
            theirs[..copies],
            "case {c}: residual copies"
        );
        // … its random part draws from W_i − ⌊N W_i⌋ instead of N W_i − ⌊N W_i⌋.
        if ours[copies..] != theirs[copies..] {
            residual_differs += 1;
        }
    }
    assert!(
        residual_differs > 0,
        "FilterPy 1.4.5's residual draws were expected to differ somewhere"
    );
}

fn counts(indices: &[usize], n: usize) -> Vec<usize> {
    let mut c = vec![0; n];
    for &i in indices {
        c[i] += 1;
    }
    c
}

fn draw(scheme: Resampling, w: &[f64], rng: &mut ChaCha8Rng) -> Vec<usize> {
    let needed = scheme.uniforms_needed(w, w.len()).expect("valid weights");
    let u: Vec<f64> = (0..needed).map(|_| rng.random::<f64>()).collect();
    let mut out = vec![0; w.len()];
    scheme.resample(w, &u, &mut out).expect("valid input");
    out
}

#[test]
fn copy_counts_keep_each_schemes_bounds() {
    // Systematic: |c_i − N W_i| < 1; stratified: < 2; residual: c_i ≥ ⌊N W_i⌋; all: Σ c_i = N
    // and no copy of a zero weight. Exact statements, checked on 200 random weight vectors.
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    for trial in 0..200 {
        let n = 1 + trial % 37;
        let mut w: Vec<f64> = (0..n)
            .map(|_| (3.0 * rng.random::<f64>()).exp() - 1.0)
            .collect();
        if n > 3 {
            w[trial % n] = 0.0;
        }
        let total: f64 = w.iter().sum();
        for scheme in SCHEMES {
            let c = counts(&draw(scheme, &w, &mut rng), n);
            assert_eq!(c.iter().sum::<usize>(), n);
            for (i, (&ci, &wi)) in c.iter().zip(&w).enumerate() {
                let expected = n as f64 * wi / total;
                let d = ci as f64 - expected;
                let ok = match scheme {
                    Resampling::Systematic => d.abs() < 1.0,
                    Resampling::Stratified => d.abs() < 2.0,
                    Resampling::Residual => ci >= expected.floor() as usize,
                    _ => true,
                } && (wi > 0.0 || ci == 0);
                assert!(
                    ok,
                    "{scheme:?}, trial {trial}, particle {i}: {ci} copies for N W = {expected}"
                );
            }
        }
    }
}

#[test]
fn every_scheme_is_unbiased() {
    // E[c_i] = N W_i. Over R = 4000 resamplings of N = 20 weights, the mean count has a
    // standard error at most √(N W_i (1 − W_i)/R) (multinomial's; the others' are smaller):
    // five of those is the tolerance. A scheme off by one position (an index shifted by a
    // stratum) moves a mean by order N W_i, hundreds of standard errors.
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let n = 20;
    let w: Vec<f64> = (0..n).map(|i| 1.0 + (i * i % 7) as f64).collect();
    let total: f64 = w.iter().sum();
    let runs = 4000;
    for scheme in SCHEMES {
        let mut sums = vec![0usize; n];
        for _ in 0..runs {
            for (s, c) in sums.iter_mut().zip(counts(&draw(scheme, &w, &mut rng), n)) {
                *s += c;
            }
        }
        for i in 0..n {
            let p = w[i] / total;
            let mean = sums[i] as f64 / runs as f64;
            let se = (n as f64 * p * (1.0 - p) / runs as f64).sqrt();
            assert!(
                (mean - n as f64 * p).abs() < 5.0 * se,
                "{scheme:?}, particle {i}: {mean} vs {}",
                n as f64 * p
            );
        }
    }
}

#[test]
fn effective_sample_size_is_its_definition() {
    let ess = effective_sample_size(&[0.5, 0.25, 0.25]).expect("valid");
    assert!((ess - 1.0 / 0.375).abs() < 1e-14);
    assert!((effective_sample_size(&[2.0; 10]).expect("valid") - 10.0).abs() < 1e-12);
    assert!((effective_sample_size(&[0.0, 3.0, 0.0]).expect("valid") - 1.0).abs() < 1e-15);
    assert!(effective_sample_size(&[0.0, 0.0]).is_err());
}
