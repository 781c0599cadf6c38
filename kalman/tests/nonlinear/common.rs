//! Checks shared by the nonlinear filters' tests.

use kalman::Error;

/// Asserts that `err` is the filter's refusal of a non-finite transition `f` at `step`.
pub fn assert_f_non_finite_at(err: &Error, step: usize) {
    assert!(
        matches!(err, Error::ModelNonFinite { function: "f", step: s, .. } if *s == step),
        "{err}"
    );
}
