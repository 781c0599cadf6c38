//! Shared helpers for the integration tests: tolerant matrix comparison, convolution.

use nalgebra::DMatrix;

/// Asserts |a − e| ≤ tol·max(1, |e|) entrywise, naming the entry on failure.
pub fn assert_close(what: &str, a: &DMatrix<f64>, e: &DMatrix<f64>, tol: f64) {
    assert_eq!(a.shape(), e.shape(), "{what}: shape");
    for i in 0..a.nrows() {
        for j in 0..a.ncols() {
            let (x, y) = (a[(i, j)], e[(i, j)]);
            assert!(
                (x - y).abs() <= tol * y.abs().max(1.0),
                "{what}[{i},{j}] = {x:e}, expected {y:e} (tol {tol:e})"
            );
        }
    }
}

/// Asserts |a − e| ≤ tol·scale entrywise where scale = max(1, max|e|) (for responses whose
/// entries span many magnitudes).
pub fn assert_close_scaled(what: &str, a: &[f64], e: &[f64], tol: f64) {
    assert_eq!(a.len(), e.len(), "{what}: length");
    let scale = e
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    for (k, (x, y)) in a.iter().zip(e).enumerate() {
        assert!(
            (x - y).abs() <= tol * scale,
            "{what}[{k}] = {x:e}, expected {y:e} (tol {tol:e} × {scale:e})"
        );
    }
}

/// Scalar closeness with a relative tolerance (absolute below 1).
pub fn close(x: f64, y: f64, tol: f64) -> bool {
    (x - y).abs() <= tol * y.abs().max(1.0)
}

/// First `len` terms of the convolution of two sequences.
pub fn convolve(a: &[f64], b: &[f64], len: usize) -> Vec<f64> {
    (0..len)
        .map(|k| {
            (0..=k)
                .map(|i| a.get(i).copied().unwrap_or(0.0) * b.get(k - i).copied().unwrap_or(0.0))
                .sum()
        })
        .collect()
}

/// The PROPTEST_CASES-aware config used by the property tests.
#[cfg(feature = "proptest")]
pub fn config() -> proptest::test_runner::Config {
    proptest::test_runner::Config::default()
}
