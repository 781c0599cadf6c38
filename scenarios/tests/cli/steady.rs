//! `steady-state` on a continuous model file: the Kalman–Bucy steady state (CARE) against
//! its closed form, and the one-line refusal of a continuous model without R.

use crate::common::{close, fails, mat, ok, read_json, with_model};

/// The double integrator ẋ₁ = x₂, ẋ₂ = w (intensity q), z = x₁ + v (intensity r): the CARE
/// A P + P Aᵀ − P Cᵀ C P / r + G Qc Gᵀ = 0 has the closed form P₁₂ = √(q r),
/// P₁₁ = √2 q^{1/4} r^{3/4}, P₂₂ = √2 q^{3/4} r^{1/4} (entry by entry from the three
/// scalar equations), and the gain K = P Cᵀ / r.
#[test]
fn continuous_model_gives_the_kalman_bucy_steady_state() {
    let (q, r) = (0.5f64, 0.2f64);
    let model = format!(
        r#"{{"A": [[0, 1], [0, 0]], "G": [[0], [1]], "Qc": [[{q}]], "C": [[1, 0]], "R": [[{r}]]}}"#
    );
    let dir = with_model("steady", "kalman-bucy", &model);
    ok(
        &dir,
        &["steady-state", "--model", "m.json", "--out", "ss.json"],
    );
    let out = read_json(&dir.join("ss.json"));
    let p = mat(&out["P"]);
    let k = mat(&out["K"]);
    let s2 = 2f64.sqrt();
    let want = [
        [s2 * q.powf(0.25) * r.powf(0.75), (q * r).sqrt()],
        [(q * r).sqrt(), s2 * q.powf(0.75) * r.powf(0.25)],
    ];
    // The solver returns the CARE solution to round-off (its residual below); 1e-12 relative
    // leaves room for the closed form's own rounding.
    for i in 0..2 {
        for j in 0..2 {
            assert!(
                close(p[i][j], want[i][j], 1e-12),
                "P[{i}][{j}] = {} vs {}",
                p[i][j],
                want[i][j]
            );
        }
        assert!(
            close(k[i][0], want[i][0] / r, 1e-12),
            "K[{i}] = {}",
            k[i][0]
        );
    }
    assert_eq!(out["time"], "continuous");
    let residual = out["residual"].as_f64().expect("residual");
    assert!(residual < 1e-14, "{residual:e}");
}

/// Without R the continuous model has no measurement noise intensity: one line naming R.
#[test]
fn continuous_model_without_r_is_refused() {
    let model = r#"{"A": [[-1]], "Qc": [[1]], "C": [[1]]}"#;
    let dir = with_model("steady", "no-r", model);
    let line = fails(
        &dir,
        &["steady-state", "--model", "m.json", "--out", "ss.json"],
    );
    assert!(line.contains("needs R"), "{line}");
    assert!(!dir.join("ss.json").exists());
}
