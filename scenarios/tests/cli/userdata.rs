//! `filter`, `discretize` and `steady-state` driven through the built binary on small models,
//! against values computed independently here; every error class; and a property test that
//! feeds arbitrary bytes to the model and CSV parsers (in process) and to `filter`.
#![allow(non_snake_case)]

use std::path::{Path, PathBuf};
use std::process::Command;

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

use crate::common::{ok, run, scratch};

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write input");
    p
}

/// Runs a command that must fail with exit code 2 and exactly one line on stderr containing
/// every string of `expect`, leaving nothing in `dir` but the inputs (`inputs` files).
fn fails(dir: &Path, args: &[&str], expect: &[&str], inputs: usize) {
    let out = run(dir, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "one line on stderr: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: `{e}` not in: {err}");
    }
    let left = std::fs::read_dir(dir).map(|d| d.count()).unwrap_or(0);
    assert_eq!(
        left, inputs,
        "a failed run must leave no output or temporary file"
    );
}

/// Header and numeric rows of a CSV written by the program.
fn read_csv(path: &Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).expect("read output");
    let mut lines = text.lines();
    let header = lines.next().expect("header").to_string();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().expect("number"))
                .collect()
        })
        .collect();
    (header, rows)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn filter_scalar_by_hand() {
    // F = H = Q = R = P0 = 1, x0 = 0, z = 1, (missing), 2. By hand:
    // k=0: Σ = 2, K = 1/2, x = 1/2, P = 1/2, NIS = 1/2. Predict: P = 3/2.
    // k=1: missing: x = 1/2, P = 3/2, NIS = NaN. Predict: P = 5/2.
    // k=2: Σ = 7/2, K = 5/7, e = 3/2, x = 1/2 + 15/14, P = 5/7, NIS = (9/4)/(7/2) = 9/14.
    let dir = scratch("ud", "scalar");
    write(
        &dir,
        "m.toml",
        "dt = 1\nF = [[1]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\nx0 = [0]\nP0 = [[1]]\n",
    );
    write(&dir, "z.csv", "t,z1\n0,1\n1,\n2,2\n");
    let expected = [
        [0.0, 0.5, 0.5, 0.5],
        [1.0, 0.5, 1.5, f64::NAN],
        [2.0, 0.5 + 15.0 / 14.0, 5.0 / 7.0, 9.0 / 14.0],
    ];
    for form in ["joseph", "standard", "sqrt"] {
        ok(
            &dir,
            &[
                "filter", "--model", "m.toml", "--data", "z.csv", "--out", "est.csv", "--form",
                form,
            ],
        );
        let (header, rows) = read_csv(&dir.join("est.csv"));
        assert_eq!(header, "t,x1,P1_1,nis");
        assert_eq!(rows.len(), 3);
        for (r, e) in rows.iter().zip(&expected) {
            for (a, b) in r.iter().zip(e) {
                // Three scalar steps: round-off is a few ulps; 1e-12 is ample.
                assert!(close(*a, *b, 1e-12), "{form}: {r:?} vs {e:?}");
            }
        }
    }
}

/// One row of the reference filter's output.
struct RefRow {
    x: DVector<f64>,
    P: DMatrix<f64>,
    nis: f64,
}

/// A textbook filter with correlated noise, written independently of the engine (explicit
/// inverses, prior-based formulas): update with the observed entries of `z_k − D u_k`, then
/// `x⁺ = F x_{k|k} + B u_k + S_o Σ⁻¹ e` and `P⁺ = F P Fᵀ + Q − (F P H_oᵀ + S_o) Σ⁻¹ (…)ᵀ`.
#[allow(clippy::too_many_arguments)]
fn reference(
    F: &DMatrix<f64>,
    B: &DMatrix<f64>,
    H: &DMatrix<f64>,
    D: &DMatrix<f64>,
    Q: &DMatrix<f64>,
    R: &DMatrix<f64>,
    S: &DMatrix<f64>,
    x0: &DVector<f64>,
    P0: &DMatrix<f64>,
    data: &[(Vec<f64>, Vec<f64>)],
) -> Vec<RefRow> {
    let (mut x, mut P) = (x0.clone(), P0.clone());
    let mut out = Vec::new();
    for (z, u) in data {
        let u = DVector::from_column_slice(u);
        let zc = DVector::from_column_slice(z) - D * &u;
        let idx: Vec<usize> = (0..z.len()).filter(|&i| !z[i].is_nan()).collect();
        if idx.is_empty() {
            out.push(RefRow {
                x: x.clone(),
                P: P.clone(),
                nis: f64::NAN,
            });
            x = F * &x + B * &u;
            P = F * &P * F.transpose() + Q;
            continue;
        }
        let Ho = H.select_rows(&idx);
        let Ro = R.select_rows(&idx).select_columns(&idx);
        let So = S.select_columns(&idx);
        let e = zc.select_rows(&idx) - &Ho * &x;
        let sig = &Ho * &P * Ho.transpose() + Ro;
        let si = sig.clone().try_inverse().expect("invertible Σ");
        let K = &P * Ho.transpose() * &si;
        let xf = &x + &K * &e;
        let Pf = &P - &K * &sig * K.transpose();
        let nis = (e.transpose() * &si * &e)[(0, 0)];
        out.push(RefRow {
            x: xf.clone(),
            P: Pf.clone(),
            nis,
        });
        let M = F * &P * Ho.transpose() + &So;
        x = F * &xf + B * &u + &So * &si * &e;
        P = F * &P * F.transpose() + Q - &M * &si * M.transpose();
    }
    out
}

fn rows_json(m: &DMatrix<f64>) -> String {
    let rows: Vec<String> = m
        .row_iter()
        .map(|r| {
            let v: Vec<String> = r.iter().map(|x| format!("{x:?}")).collect();
            format!("[{}]", v.join(", "))
        })
        .collect();
    format!("[{}]", rows.join(", "))
}

#[test]
fn filter_two_state_with_control_feedthrough_cross_covariance_and_gaps() {
    let dir = scratch("ud", "twostate");
    let F = DMatrix::from_row_slice(2, 2, &[1.0, 0.1, -0.2, 0.9]);
    let B = DMatrix::from_row_slice(2, 1, &[0.0, 0.1]);
    let H = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.5, 1.0]);
    let D = DMatrix::from_row_slice(2, 1, &[0.0, 0.3]);
    let Q = DMatrix::from_row_slice(2, 2, &[0.02, 0.005, 0.005, 0.04]);
    let R = DMatrix::from_row_slice(2, 2, &[0.3, 0.05, 0.05, 0.2]);
    let S = DMatrix::from_row_slice(2, 2, &[0.01, 0.0, 0.0, 0.02]);
    let x0 = DVector::from_column_slice(&[0.5, -0.5]);
    let P0 = DMatrix::from_row_slice(2, 2, &[2.0, 0.3, 0.3, 1.0]);
    let model = format!(
        "{{\"dt\": 0.1, \"F\": {}, \"B\": {}, \"H\": {}, \"D\": {}, \"Q\": {}, \"R\": {}, \"S\": {}, \"x0\": [0.5, -0.5], \"P0\": {}}}",
        rows_json(&F),
        rows_json(&B),
        rows_json(&H),
        rows_json(&D),
        rows_json(&Q),
        rows_json(&R),
        rows_json(&S),
        rows_json(&P0)
    );
    write(&dir, "m.json", &model);
    let nan = f64::NAN;
    let data: Vec<(Vec<f64>, Vec<f64>)> = vec![
        (vec![0.7, -0.1], vec![1.0]),
        (vec![0.9, nan], vec![0.5]),
        (vec![nan, nan], vec![-1.0]),
        (vec![1.2, 0.4], vec![0.0]),
        (vec![nan, 0.8], vec![2.0]),
        (vec![1.1, 1.0], vec![0.3]),
    ];
    let mut csv = String::from("t,z1,z2,u1\n");
    for (k, (z, u)) in data.iter().enumerate() {
        let cell = |v: f64| {
            if v.is_nan() {
                String::new()
            } else {
                format!("{v:?}")
            }
        };
        csv.push_str(&format!(
            "{:?},{},{},{:?}\n",
            0.1 * k as f64,
            cell(z[0]),
            cell(z[1]),
            u[0]
        ));
    }
    write(&dir, "z.csv", &csv);
    let want = reference(&F, &B, &H, &D, &Q, &R, &S, &x0, &P0, &data);
    for form in ["joseph", "standard", "sqrt"] {
        ok(
            &dir,
            &[
                "filter",
                "--model",
                "m.json",
                "--data",
                "z.csv",
                "--out",
                "est.csv",
                "--form",
                form,
                "--full-covariance",
            ],
        );
        let (header, rows) = read_csv(&dir.join("est.csv"));
        assert_eq!(header, "t,x1,x2,P1_1,P1_2,P2_1,P2_2,nis");
        assert_eq!(rows.len(), data.len());
        for (k, (r, w)) in rows.iter().zip(&want).enumerate() {
            // Six steps of a well-conditioned 2-state problem: the reference's explicit
            // inverse and the engine's factorisations differ by round-off (~1e-15); 1e-10
            // relative leaves room without hiding a wrong formula (errors there are O(1e-2)).
            let got = [r[1], r[2], r[3], r[4], r[5], r[6], r[7]];
            let exp = [
                w.x[0],
                w.x[1],
                w.P[(0, 0)],
                w.P[(0, 1)],
                w.P[(1, 0)],
                w.P[(1, 1)],
                w.nis,
            ];
            for (a, b) in got.iter().zip(&exp) {
                assert!(close(*a, *b, 1e-10), "{form} row {k}: {got:?} vs {exp:?}");
            }
        }
    }
    // The diagonal-only layout holds the same numbers.
    ok(
        &dir,
        &[
            "filter", "--model", "m.json", "--data", "z.csv", "--out", "diag.csv",
        ],
    );
    let (header, rows) = read_csv(&dir.join("diag.csv"));
    assert_eq!(header, "t,x1,x2,P1_1,P2_2,nis");
    assert!(close(rows[5][4], want[5].P[(1, 1)], 1e-10));
}

#[test]
fn filter_streams_a_long_csv() {
    // 20 000 rows through the binary: the estimates file has one row per data row and the
    // last covariance equals the scalar steady state P_post = P⁻R/(P⁻+R), P⁻ = (Q + √(Q²+4QR))/2
    // for F = H = 1 (Q = 1, R = 1: P⁻ = (1+√5)/2).
    let dir = scratch("ud", "long");
    write(
        &dir,
        "m.json",
        r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "P0": [[100]]}"#,
    );
    let mut csv = String::from("t,z1\n");
    for k in 0..20_000 {
        csv.push_str(&format!("{k},{}\n", (k % 7) as f64 * 0.1));
    }
    write(&dir, "z.csv", &csv);
    ok(
        &dir,
        &[
            "filter", "--model", "m.json", "--data", "z.csv", "--out", "est.csv",
        ],
    );
    let (_, rows) = read_csv(&dir.join("est.csv"));
    assert_eq!(rows.len(), 20_000);
    let pm = (1.0 + 5f64.sqrt()) / 2.0;
    let post = pm / (pm + 1.0);
    assert!(close(rows[19_999][2], post, 1e-12), "{}", rows[19_999][2]);
}

#[test]
fn smooth_against_textbook_rts() {
    // The 2-state model of `filter_two_state…` without S or D, with gaps and a control:
    // the reference runs the filter above, then J_k = P_{k|k} Fᵀ P_{k+1|k}⁻¹,
    // x_{k|N} = x_{k|k} + J_k (x_{k+1|N} − x_{k+1|k}), P_{k|N} = P_{k|k} + J_k (P_{k+1|N} − P_{k+1|k}) J_kᵀ.
    let dir = scratch("ud", "smooth");
    let F = DMatrix::from_row_slice(2, 2, &[1.0, 0.1, -0.2, 0.9]);
    let B = DMatrix::from_row_slice(2, 1, &[0.0, 0.1]);
    let H = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
    let D = DMatrix::zeros(1, 1);
    let Q = DMatrix::from_row_slice(2, 2, &[0.02, 0.005, 0.005, 0.04]);
    let R = DMatrix::from_row_slice(1, 1, &[0.3]);
    let S = DMatrix::zeros(2, 1);
    let x0 = DVector::from_column_slice(&[0.5, -0.5]);
    let P0 = DMatrix::from_row_slice(2, 2, &[2.0, 0.3, 0.3, 1.0]);
    write(
        &dir,
        "m.json",
        &format!(
            "{{\"dt\": 0.1, \"F\": {}, \"B\": {}, \"H\": {}, \"Q\": {}, \"R\": {}, \"x0\": [0.5, -0.5], \"P0\": {}}}",
            rows_json(&F),
            rows_json(&B),
            rows_json(&H),
            rows_json(&Q),
            rows_json(&R),
            rows_json(&P0)
        ),
    );
    let nan = f64::NAN;
    let zs = [0.7, 0.9, nan, 1.2, nan, 1.1, 0.8];
    let us = [1.0, 0.5, -1.0, 0.0, 2.0, 0.3, 0.0];
    let data: Vec<(Vec<f64>, Vec<f64>)> = zs
        .iter()
        .zip(&us)
        .map(|(z, u)| (vec![*z], vec![*u]))
        .collect();
    let mut csv = String::from("t,z1,u1\n");
    for (k, (z, u)) in zs.iter().zip(&us).enumerate() {
        let cell = if z.is_nan() {
            "NaN".to_string()
        } else {
            format!("{z:?}")
        };
        csv.push_str(&format!("{k},{cell},{u:?}\n"));
    }
    write(&dir, "z.csv", &csv);
    let filt = reference(&F, &B, &H, &D, &Q, &R, &S, &x0, &P0, &data);
    let N = filt.len();
    let mut xs = vec![filt[N - 1].x.clone()];
    let mut Ps = vec![filt[N - 1].P.clone()];
    for k in (0..N - 1).rev() {
        let (xf, Pf) = (&filt[k].x, &filt[k].P);
        let u = DVector::from_column_slice(&data[k].1);
        let xp = &F * xf + &B * &u;
        let Pp = &F * Pf * F.transpose() + &Q;
        let J = Pf * F.transpose() * Pp.clone().try_inverse().expect("invertible P_{k+1|k}");
        let (xn, Pn) = (&xs[0], &Ps[0]);
        let x = xf + &J * (xn - xp);
        let P = Pf + &J * (Pn - Pp) * J.transpose();
        xs.insert(0, x);
        Ps.insert(0, P);
    }
    for form in ["joseph", "sqrt"] {
        ok(
            &dir,
            &[
                "filter",
                "--model",
                "m.json",
                "--data",
                "z.csv",
                "--out",
                "s.csv",
                "--smooth",
                "--full-covariance",
                "--form",
                form,
            ],
        );
        let (header, rows) = read_csv(&dir.join("s.csv"));
        assert_eq!(header, "t,x1,x2,P1_1,P1_2,P2_1,P2_2,nis");
        assert_eq!(rows.len(), N);
        for k in 0..N {
            let r = &rows[k];
            let want = [
                xs[k][0],
                xs[k][1],
                Ps[k][(0, 0)],
                Ps[k][(0, 1)],
                Ps[k][(1, 0)],
                Ps[k][(1, 1)],
                filt[k].nis,
            ];
            // Seven steps forward and back on a well-conditioned 2-state model: round-off
            // ~1e-15; 1e-10 relative as in the filter test.
            for (a, b) in r[1..].iter().zip(&want) {
                assert!(close(*a, *b, 1e-10), "{form} row {k}: {r:?} vs {want:?}");
            }
        }
    }
    // Smoothing never increases the variance, and the last row is the filtered one.
    ok(
        &dir,
        &[
            "filter", "--model", "m.json", "--data", "z.csv", "--out", "f.csv",
        ],
    );
    ok(
        &dir,
        &[
            "filter", "--model", "m.json", "--data", "z.csv", "--out", "s.csv", "--smooth",
        ],
    );
    let (_, f) = read_csv(&dir.join("f.csv"));
    let (_, s) = read_csv(&dir.join("s.csv"));
    for (a, b) in f.iter().zip(&s) {
        assert!(b[3] <= a[3] * (1.0 + 1e-12) && b[4] <= a[4] * (1.0 + 1e-12));
    }
    assert!(close(f[N - 1][1], s[N - 1][1], 1e-12));
}

#[test]
fn steady_state_exists_when_only_off_circle_modes_are_unreached() {
    let dir = scratch("ud", "steady-exist");
    // F = 2, Q = 0, H = R = 1: the unstable mode gets no process noise, yet (F, H) is
    // detectable and the mode is off the unit circle, so the DARE has a stabilising
    // solution. P = 4P/(P + 1) gives P = 3 (the other root, 0, leaves F − KH = 2); then
    // K = P/(P + 1) = 0.75 and P_post = P − P²/(P + 1) = 0.75. Closed forms: 1e-12.
    write(
        &dir,
        "u.toml",
        "dt = 1\nF = [[2]]\nH = [[1]]\nQ = [[0]]\nR = [[1]]\n",
    );
    ok(
        &dir,
        &["steady-state", "--model", "u.toml", "--out", "ss.json"],
    );
    let ss = read_json(&dir.join("ss.json"));
    assert!(close(mat(&ss["P"])[0][0], 3.0, 1e-12), "{ss}");
    assert!(close(mat(&ss["K"])[0][0], 0.75, 1e-12), "{ss}");
    assert!(close(mat(&ss["P_post"])[0][0], 0.75, 1e-12), "{ss}");
    // F = 1 with Q = 0: the unreached mode sits on the unit circle, where no stabilising
    // solution exists (the gain decays like 1/k and never settles): refused by name.
    std::fs::remove_file(dir.join("ss.json")).expect("remove");
    write(
        &dir,
        "c.toml",
        "dt = 1\nF = [[1]]\nH = [[1]]\nQ = [[0]]\nR = [[1]]\n",
    );
    fails(
        &dir,
        &["steady-state", "--model", "c.toml", "--out", "ss.json"],
        &["c.toml", "is not stabilisable"],
        2,
    );
}

#[test]
fn steady_state_against_iterated_riccati() {
    let dir = scratch("ud", "steady");
    // Scalar random walk, q = r = 1: P = (1 + √5)/2, K = P/(P + 1), P_post = P/(P + 1).
    write(
        &dir,
        "rw.toml",
        "dt = 1\nF = [[1]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\n",
    );
    ok(
        &dir,
        &["steady-state", "--model", "rw.toml", "--out", "ss.json"],
    );
    let ss = read_json(&dir.join("ss.json"));
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    // A converged doubling solution agrees with the closed form to round-off: 1e-12.
    assert!(close(mat(&ss["P"])[0][0], p, 1e-12), "{ss}");
    assert!(close(mat(&ss["K"])[0][0], p / (p + 1.0), 1e-12));
    assert!(close(mat(&ss["P_post"])[0][0], p / (p + 1.0), 1e-12));
    assert!(ss["residual"].as_f64().expect("residual") < 1e-12);
    // A 2-state model with cross-covariance: iterate the correlated-noise Riccati recursion
    // P ← F P Fᵀ + Q − (F P Hᵀ + S)(H P Hᵀ + R)⁻¹(…)ᵀ here until it stops moving.
    let F = DMatrix::from_row_slice(2, 2, &[0.95, 0.1, -0.1, 0.9]);
    let H = DMatrix::from_row_slice(1, 2, &[1.0, 0.5]);
    let Q = DMatrix::from_row_slice(2, 2, &[0.1, 0.02, 0.02, 0.05]);
    let R = DMatrix::from_row_slice(1, 1, &[0.2]);
    let S = DMatrix::from_row_slice(2, 1, &[0.03, -0.01]);
    write(
        &dir,
        "m.json",
        &format!(
            "{{\"dt\": 0.5, \"F\": {}, \"H\": {}, \"Q\": {}, \"R\": {}, \"S\": {}}}",
            rows_json(&F),
            rows_json(&H),
            rows_json(&Q),
            rows_json(&R),
            rows_json(&S)
        ),
    );
    let mut P = DMatrix::<f64>::identity(2, 2);
    for _ in 0..5000 {
        let sig = &H * &P * H.transpose() + &R;
        let M = &F * &P * H.transpose() + &S;
        P = &F * &P * F.transpose() + &Q - &M * sig.try_inverse().expect("Σ") * M.transpose();
    }
    let sig = &H * &P * H.transpose() + &R;
    let K = &P * H.transpose() * sig.clone().try_inverse().expect("Σ");
    let Ppost = &P - &K * &sig * K.transpose();
    ok(
        &dir,
        &["steady-state", "--model", "m.json", "--out", "ss.json"],
    );
    let ss = read_json(&dir.join("ss.json"));
    let (gp, gk, gpp) = (mat(&ss["P"]), mat(&ss["K"]), mat(&ss["P_post"]));
    // The iteration contracts geometrically (closed-loop radius < 0.95): after 5000 steps
    // it is at its round-off floor; 1e-10 relative.
    for i in 0..2 {
        assert!(close(gk[i][0], K[(i, 0)], 1e-10), "K {gk:?} vs {K}");
        for j in 0..2 {
            assert!(close(gp[i][j], P[(i, j)], 1e-10), "P {gp:?} vs {P}");
            assert!(
                close(gpp[i][j], Ppost[(i, j)], 1e-10),
                "P_post {gpp:?} vs {Ppost}"
            );
        }
    }
    // Not detectable: an unstable mode H does not see.
    write(
        &dir,
        "nd.json",
        r#"{"dt": 1, "F": [[2, 0], [0, 0.5]], "H": [[0, 1]], "Q": [[1, 0], [0, 1]], "R": [[1]]}"#,
    );
    std::fs::remove_file(dir.join("ss.json")).expect("remove");
    fails(
        &dir,
        &["steady-state", "--model", "nd.json", "--out", "ss.json"],
        &["nd.json", "(F, H) is not detectable"],
        3,
    );
    // The model rules apply to steady-state too.
    write(
        &dir,
        "nd.json",
        r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[-1]], "R": [[1]]}"#,
    );
    fails(
        &dir,
        &["steady-state", "--model", "nd.json", "--out", "ss.json"],
        &["nd.json", "Q (1x1) is not positive semidefinite"],
        3,
    );
}

/// Peak resident memory (VmHWM, kB) of the program on `args`, sampled from /proc while it
/// runs (the high-water mark only grows, so the last sample is the peak up to then).
#[cfg(target_os = "linux")]
fn peak_rss_kb(dir: &Path, args: &[&str]) -> u64 {
    // A short run can exit before the first sample of /proc/<pid>/status; such a run says
    // nothing about memory, so it is repeated (a few times at most) until one is sampled.
    for _ in 0..20 {
        let peak = sample_peak_rss_kb(dir, args);
        if peak > 0 {
            return peak;
        }
    }
    panic!("{args:?}: the child never lived long enough to sample its memory");
}

/// One run of the program with its peak resident set (VmHWM) polled from /proc; 0 if the
/// child exited before it could be sampled.
fn sample_peak_rss_kb(dir: &Path, args: &[&str]) -> u64 {
    let mut child = Command::new(env!("CARGO_BIN_EXE_scenarios"))
        .current_dir(dir)
        .args(args)
        .spawn()
        .expect("spawn scenarios");
    let status = format!("/proc/{}/status", child.id());
    let mut peak = 0;
    loop {
        if let Ok(text) = std::fs::read_to_string(&status)
            && let Some(kb) = text
                .lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        {
            peak = peak.max(kb);
        }
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    assert!(child.wait().expect("wait").success(), "{args:?} failed");
    peak
}

#[cfg(target_os = "linux")]
#[test]
fn filter_memory_does_not_grow_with_the_csv() {
    // 20 000 against 100 000 rows: streaming keeps the peak at the program's own few MB; `--smooth`, which
    // must keep the pass (≥ 100 bytes a row for n = 2), shows what growth looks like — so
    // the first assertion is known to be able to fail.
    let dir = scratch("ud", "memory");
    write(
        &dir,
        "m.json",
        r#"{"dt": 1, "F": [[1, 1], [0, 1]], "H": [[1, 0]], "Q": [[0.01, 0], [0, 0.01]], "R": [[1]], "P0": [[1, 0], [0, 1]]}"#,
    );
    let rows = |n: usize| {
        let mut csv = String::with_capacity(n * 16);
        csv.push_str("t,z1\n");
        for k in 0..n {
            csv.push_str(&format!("{k},{}\n", k % 13));
        }
        csv
    };
    write(&dir, "small.csv", &rows(20_000));
    write(&dir, "big.csv", &rows(100_000));
    let args = |data: &'static str, smooth: bool| {
        let mut a = vec![
            "filter", "--model", "m.json", "--data", data, "--out", "est.csv",
        ];
        if smooth {
            a.push("--smooth");
        }
        a
    };
    // The small run is short: the best of three samplings stands for its peak, so an early
    // sample cannot make the streaming run look as if it grew.
    let small = (0..3)
        .map(|_| peak_rss_kb(&dir, &args("small.csv", false)))
        .max()
        .unwrap_or(0);
    let big = peak_rss_kb(&dir, &args("big.csv", false));
    let smooth = peak_rss_kb(&dir, &args("big.csv", true));
    // Allocator noise is well under 4 MB; the smoother keeps ≥ 30 MB here.
    assert!(
        big <= small + 4_096,
        "streaming peak grew: {small} kB → {big} kB"
    );
    assert!(
        smooth >= big + 20_000,
        "smoothing should store the pass: {big} kB vs {smooth} kB"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Reads a JSON file written by the program.
fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("JSON")
}

fn mat(v: &serde_json::Value) -> Vec<Vec<f64>> {
    v.as_array()
        .expect("matrix")
        .iter()
        .map(|r| {
            r.as_array()
                .expect("row")
                .iter()
                .map(|x| x.as_f64().expect("number"))
                .collect()
        })
        .collect()
}

#[test]
fn discretize_against_closed_forms() {
    let dir = scratch("ud", "discretize");
    // Double integrator with white acceleration of intensity q = 2 (Van Loan, ZOH):
    // F = [[1, Δt], [0, 1]], Q = q·[[Δt³/3, Δt²/2], [Δt²/2, Δt]].
    write(
        &dir,
        "di.json",
        r#"{"A": [[0, 1], [0, 0]], "B": [[0], [1]], "C": [[1, 0]], "Qc": [[0, 0], [0, 2]], "R": [[0.5]]}"#,
    );
    let dt: f64 = 0.2;
    ok(
        &dir,
        &[
            "discretize",
            "--model",
            "di.json",
            "--dt",
            "0.2",
            "--method",
            "zoh",
            "--out",
            "d.json",
        ],
    );
    let d = read_json(&dir.join("d.json"));
    let q = 2.0;
    let want_q = [
        [q * dt.powi(3) / 3.0, q * dt * dt / 2.0],
        [q * dt * dt / 2.0, q * dt],
    ];
    let got_q = mat(&d["Q"]);
    let got_f = mat(&d["F"]);
    let got_b = mat(&d["B"]);
    // Matrix exponentials of nilpotent matrices: exact up to round-off; 1e-12 relative.
    for i in 0..2 {
        for j in 0..2 {
            assert!(close(got_q[i][j], want_q[i][j], 1e-12), "Q {got_q:?}");
        }
    }
    assert!(close(got_f[0][1], dt, 1e-12) && close(got_f[1][1], 1.0, 1e-12));
    assert!(close(got_b[0][0], dt * dt / 2.0, 1e-12) && close(got_b[1][0], dt, 1e-12));
    assert!(close(mat(&d["R"])[0][0], 0.5, 0.0));
    assert!(d.get("S").is_none());
    // The output is a discrete model that reads back (with a P0 added) and filters.
    let mut m: serde_json::Map<String, serde_json::Value> =
        serde_json::from_value(d).expect("object");
    m.insert("P0".into(), serde_json::json!([[1, 0], [0, 1]]));
    write(&dir, "d0.json", &serde_json::Value::Object(m).to_string());
    write(&dir, "z.csv", "t,z1,u1\n0,1,0\n0.2,1.1,0\n");
    ok(
        &dir,
        &[
            "filter", "--model", "d0.json", "--data", "z.csv", "--out", "e.csv",
        ],
    );

    // First-order lag ẋ = −a x + w: Tustin F = (1 − aΔt/2)/(1 + aΔt/2); pre-warped at ω:
    // Δt → T = 2 tan(ωΔt/2)/ω; forward Euler F = 1 − aΔt and, with the Qc/Δt convention,
    // Q = (Δt·G)² · Qc/Δt = Qc·Δt.
    let a = 3.0;
    let qc = 0.7;
    write(
        &dir,
        "lag.toml",
        &format!("A = [[{}]]\nC = [[1]]\nQc = [[{qc}]]\n", -a),
    );
    let f_of = |method: &str, noise: &str| {
        ok(
            &dir,
            &[
                "discretize",
                "--model",
                "lag.toml",
                "--dt",
                "0.2",
                "--method",
                method,
                "--noise",
                noise,
                "--out",
                "l.json",
            ],
        );
        let d = read_json(&dir.join("l.json"));
        (mat(&d["F"])[0][0], mat(&d["Q"])[0][0], d)
    };
    let (f, q, _) = f_of("zoh", "van-loan");
    assert!(close(f, (-a * dt).exp(), 1e-12));
    assert!(close(
        q,
        qc * (1.0 - (-2.0 * a * dt).exp()) / (2.0 * a),
        1e-12
    ));
    let (f, _, _) = f_of("tustin", "van-loan");
    assert!(close(f, (1.0 - a * dt / 2.0) / (1.0 + a * dt / 2.0), 1e-12));
    let w = 4.0;
    let t = 2.0 * (w * dt / 2.0).tan() / w;
    let (f, _, _) = f_of(&format!("tustin-prewarp:{w}"), "van-loan");
    assert!(close(f, (1.0 - a * t / 2.0) / (1.0 + a * t / 2.0), 1e-12));
    let (f, q, d) = f_of("euler", "intensity-over-dt");
    assert!(close(f, 1.0 - a * dt, 1e-12) && close(q, qc * dt, 1e-12));
    assert!(
        d.get("R").is_none(),
        "no R given and no noise feed-through: none written"
    );
    // Tustin with the Qc/Δt convention gives the noise a feed-through J = C·M·G·Δt/2 with
    // M = 1/(1 + aΔt/2): S = G_d (Qc/Δt) J and R = J² Qc/Δt appear.
    let (_, _, d) = f_of("tustin", "intensity-over-dt");
    let m = 1.0 / (1.0 + a * dt / 2.0);
    let (gd, j) = (m * dt, m * dt / 2.0);
    assert!(close(mat(&d["S"])[0][0], gd * qc / dt * j, 1e-12), "{d}");
    assert!(close(mat(&d["R"])[0][0], j * j * qc / dt, 1e-12), "{d}");
}

#[test]
fn csv_errors_name_file_line_and_column() {
    let dir = scratch("ud", "csverr");
    write(
        &dir,
        "m.json",
        r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "P0": [[1]]}"#,
    );
    let filter = [
        "filter", "--model", "m.json", "--data", "z.csv", "--out", "est.csv",
    ];
    write(&dir, "z.csv", "t,z1\n0,1\n1,x2\n");
    fails(
        &dir,
        &filter,
        &["z.csv: line 3, column 2 (z1): `x2` is not a number"],
        2,
    );
    write(&dir, "z.csv", "t,z1\n0,1\n1\n");
    fails(
        &dir,
        &filter,
        &["z.csv: line 3, column 2 (z1): missing field"],
        2,
    );
    write(&dir, "z.csv", "t,z1\n0,1\n1,2,3\n");
    fails(&dir, &filter, &["z.csv: line 3, column 3: extra field"], 2);
    write(&dir, "z.csv", "t,z1\n1,1\n0,2\n");
    fails(
        &dir,
        &filter,
        &["z.csv: line 3, column 1 (t)", "must increase"],
        2,
    );
    write(&dir, "z.csv", "t,y1\n");
    fails(
        &dir,
        &filter,
        &["z.csv: line 1, column 2", "expected `z1`"],
        2,
    );
    write(&dir, "z.csv", "t,z1,z2\n0,1,2\n");
    fails(
        &dir,
        &filter,
        &["z.csv: line 1", "2 measurement columns", "m = 1"],
        2,
    );
    write(&dir, "z.csv", "t,z1,u1\n0,1,2\n");
    fails(
        &dir,
        &filter,
        &["z.csv: line 1", "control columns", "p = 0"],
        2,
    );
    // An error far into the file, after thousands of estimates were streamed out: the
    // output file must still not appear (whole or nothing).
    let mut csv = String::from("t,z1\n");
    for k in 0..5000 {
        csv.push_str(&format!("{k},1\n"));
    }
    csv.push_str("5000,1e999\n");
    write(&dir, "z.csv", &csv);
    fails(
        &dir,
        &filter,
        &["z.csv: line 5002, column 2 (z1): `1e999` is not finite"],
        2,
    );
    // A data file that does not exist.
    std::fs::remove_file(dir.join("z.csv")).expect("remove");
    fails(&dir, &filter, &["z.csv", "cannot read"], 1);
}

#[test]
fn model_errors_name_matrix_and_rule() {
    let dir = scratch("ud", "modelerr");
    write(&dir, "z.csv", "t,z1\n0,1\n");
    let inputs = 2;
    let filter = [
        "filter", "--model", "m.toml", "--data", "z.csv", "--out", "est.csv",
    ];
    let base = "dt = 1\nF = [[1, 0], [0, 1]]\nH = [[1, 0]]\nQ = [[1, 0], [0, 1]]\nR = [[1]]\nP0 = [[1, 0], [0, 1]]\n";
    let case = |text: String, expect: &[&str]| {
        write(&dir, "m.toml", &text);
        fails(&dir, &filter, expect, inputs);
    };
    // Shape.
    case(
        base.replace("H = [[1, 0]]", "H = [[1, 0, 0]]"),
        &["m.toml", "matrix H is 1×3, expected 1×2", "shape"],
    );
    case(
        base.replace("R = [[1]]", "R = [[1], [2]]"),
        &["matrix R is 2×1, expected 1×1", "shape"],
    );
    case(
        base.replace("F = [[1, 0], [0, 1]]", "F = [[1, 0], [0]]"),
        &["matrix F: row 2 has 1 entries", "shape"],
    );
    // NaN.
    case(
        base.replace("Q = [[1, 0], [0, 1]]", "Q = [[1, 0], [0, nan]]"),
        &["matrix Q has NaN at row 2, column 2", "NaN"],
    );
    // Not symmetric (checked by the engine, which names the matrix).
    case(
        base.replace("Q = [[1, 0], [0, 1]]", "Q = [[1, 0.5], [0, 1]]"),
        &["m.toml", "Q (2x2) is not symmetric"],
    );
    case(
        base.replace("P0 = [[1, 0], [0, 1]]", "P0 = [[1, 0.5], [0, 1]]"),
        &["P0 (2x2) is not symmetric"],
    );
    // Not PSD.
    case(
        base.replace("R = [[1]]", "R = [[-1]]"),
        &["m.toml", "R (1x1) is not positive semidefinite"],
    );
    case(
        base.replace("Q = [[1, 0], [0, 1]]", "Q = [[1, 2], [2, 1]]"),
        &["Q (2x2) is not positive semidefinite"],
    );
    // Syntax (with line and column), unknown keys, a missing P0, an unknown extension.
    case(
        base.replace("R = [[1]]", "R = [[1,,]]"),
        &["m.toml", "invalid TOML model at line 5"],
    );
    case(format!("{base}Rr = 1\n"), &["unknown field `Rr`", "line 7"]);
    case(
        base.replace("P0 = [[1, 0], [0, 1]]\n", ""),
        &["matrix P0 is missing"],
    );
    write(&dir, "m.yaml", base);
    fails(
        &dir,
        &[
            "filter", "--model", "m.yaml", "--data", "z.csv", "--out", "est.csv",
        ],
        &["m.yaml", ".json or .toml"],
        3,
    );
    std::fs::remove_file(dir.join("m.yaml")).expect("remove");
    // JSON syntax errors carry line and column too.
    std::fs::remove_file(dir.join("m.toml")).expect("remove");
    write(&dir, "m.json", "{\"dt\": 1,\n \"F\": [[1, ]]}");
    fails(
        &dir,
        &[
            "filter", "--model", "m.json", "--data", "z.csv", "--out", "est.csv",
        ],
        &["m.json", "invalid JSON model", "line 2 column"],
        2,
    );
    // Continuous models: shape, NaN, Qc not symmetric / not PSD, a singular Tustin map.
    let disc = |m: &'static str| {
        [
            "discretize",
            "--model",
            m,
            "--dt",
            "0.5",
            "--method",
            "tustin",
            "--out",
            "d.json",
        ]
    };
    let cont = |text: &str, expect: &[&str]| {
        write(&dir, "c.json", text);
        fails(&dir, &disc("c.json"), expect, 3);
    };
    cont(
        r#"{"A": [[0, 1]], "C": [[1, 0]]}"#,
        &["c.json", "matrix A is 1×2, expected 1×1", "shape"],
    );
    cont(
        r#"{"A": [[-1]], "C": [[1, 0]]}"#,
        &["matrix C is 1×2, expected 1×1"],
    );
    cont(
        r#"{"A": [[-1, 0], [0, -1]], "C": [[1, 0]], "Qc": [[1, 1], [0, 1]]}"#,
        &["c.json", "matrix Qc", "symmetric"],
    );
    cont(
        r#"{"A": [[-1, 0], [0, -1]], "C": [[1, 0]], "Qc": [[1, 2], [2, 1]]}"#,
        &["c.json", "matrix Qc", "positive semi-definite"],
    );
    cont(r#"{"A": [[4]], "C": [[1]]}"#, &["c.json", "singular"]);
    cont(
        r#"{"A": [[-1]], "C": [[1]], "G": [[1], [1]]}"#,
        &["c.json", "matrix G is 2×1, expected 1×1"],
    );
    // A bad --dt is a usage error (exit code 2).
    write(&dir, "c.json", r#"{"A": [[-1]], "C": [[1]]}"#);
    fails(
        &dir,
        &[
            "discretize",
            "--model",
            "c.json",
            "--dt=-1",
            "--method",
            "zoh",
            "--out",
            "d.json",
        ],
        &["--dt -1"],
        3,
    );
}

/// A small valid model for the property tests (n = 2, m = 2, p = 1).
const PROP_MODEL: &str = r#"{"dt": 0.1, "F": [[1, 0.1], [0, 1]], "B": [[0], [0.1]],
  "H": [[1, 0], [0, 1]], "Q": [[0.01, 0], [0, 0.01]], "R": [[1, 0], [0, 1]],
  "P0": [[1, 0], [0, 1]]}"#;

proptest! {
    // Every outcome is Ok or a clean error; a panic fails the test.
    #[test]
    fn parsers_never_panic_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        use scenarios::userdata::{data, model_file};
        let text = String::from_utf8_lossy(&bytes);
        for name in ["m.json", "m.toml"] {
            let _ = model_file::parse_discrete(Path::new(name), &text);
            let _ = model_file::parse_continuous(Path::new(name), &text);
        }
        let _ = data::parse_data(Path::new("z.csv"), &bytes);
    }

    // Near-valid inputs reach deeper than random bytes: tokens of the formats' alphabets.
    #[test]
    fn parsers_never_panic_on_format_like_text(
        model in "[\\[\\]{}\",:= \\n0-9.eE+\\-a-zA-Z_]{0,200}",
        csv in "(t,z1(,z2)?(,u1)?\\n)?([0-9.eE+\\-,\" naNifINF]{0,12}\\n){0,12}",
    ) {
        use scenarios::userdata::{data, model_file};
        for name in ["m.json", "m.toml"] {
            let _ = model_file::parse_discrete(Path::new(name), &model);
            let _ = model_file::parse_continuous(Path::new(name), &model);
        }
        let _ = data::parse_data(Path::new("z.csv"), csv.as_bytes());
    }

    // Any well-shaped model written as JSON or TOML reads back to the same matrices.
    #[test]
    fn model_files_round_trip(
        (n, m, p) in (1usize..=5, 1usize..=3, 0usize..=2),
        seed in any::<u64>(),
        toml_format in any::<bool>(),
    ) {
        use scenarios::userdata::model_file::{parse_discrete, DiscreteFile};
        let mut state = seed | 1;
        let mut next = move || {
            // xorshift64: a seeded stream of values in [-10, 10) with up to 17 digits.
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0
        };
        let mut rows = |r: usize, c: usize| -> Vec<Vec<f64>> {
            (0..r).map(|_| (0..c).map(|_| next()).collect()).collect()
        };
        let file = DiscreteFile {
            dt: 0.25,
            F: rows(n, n),
            B: (p > 0).then(|| rows(n, p)),
            H: rows(m, n),
            D: (p > 0).then(|| rows(m, p)),
            Q: rows(n, n),
            R: Some(rows(m, m)),
            S: Some(rows(n, m)),
            x0: Some(rows(1, n).remove(0)),
            P0: Some(rows(n, n)),
        };
        let (name, text) = if toml_format {
            ("m.toml", toml::to_string(&file).expect("toml"))
        } else {
            ("m.json", serde_json::to_string(&file).expect("json"))
        };
        let parsed = parse_discrete(Path::new(name), &text).expect("a well-shaped model parses");
        let back = |m: &DMatrix<f64>| -> Vec<Vec<f64>> {
            m.row_iter().map(|r| r.iter().copied().collect()).collect()
        };
        prop_assert_eq!(back(&parsed.F), file.F.clone());
        prop_assert_eq!(back(&parsed.H), file.H.clone());
        prop_assert_eq!(Some(back(&parsed.R)), file.R.clone());
        prop_assert_eq!(parsed.S.as_ref().map(back), file.S.clone());
        prop_assert_eq!(parsed.P0.as_ref().map(back), file.P0.clone());
        prop_assert_eq!(parsed.x0.as_slice(), file.x0.as_deref().unwrap_or_default());
        prop_assert_eq!((parsed.p(), back(&parsed.D).concat()), (p, file.D.clone().unwrap_or_default().concat()));
    }

    // The whole `filter` command in process, on a valid model and arbitrary CSV rows
    // (numbers of any size, gaps, garbage): Ok, or an error that names the data file.
    #[test]
    fn filter_never_panics_on_arbitrary_rows(
        rows in proptest::collection::vec(
            (any::<f64>(), prop_oneof![Just(String::new()), "[0-9.eE+\\-na]{1,8}"], any::<f64>()),
            0..20,
        ),
    ) {
        let dir = std::env::temp_dir().join(format!("scenarios-ud-prop-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        std::fs::write(dir.join("m.json"), PROP_MODEL).expect("model");
        let mut csv = String::from("t,z1,z2,u1\n");
        for (k, (z1, z2, u)) in rows.iter().enumerate() {
            csv.push_str(&format!("{k},{z1:e},{z2},{u:e}\n"));
        }
        std::fs::write(dir.join("z.csv"), &csv).expect("csv");
        let args = scenarios::userdata::FilterArgs {
            model: dir.join("m.json"),
            data: dir.join("z.csv"),
            out: dir.join("est.csv"),
            form: scenarios::userdata::Form::Joseph,
            smooth: false,
            full_covariance: false,
        };
        let _ = std::fs::remove_file(&args.out);
        match scenarios::userdata::filter(&args) {
            Ok(()) => prop_assert!(args.out.exists()),
            Err(e) => {
                prop_assert!(e.to_string().contains("z.csv"), "{}", e);
                prop_assert_eq!(e.exit_code(), 2);
                prop_assert!(!args.out.exists());
            }
        }
    }
}

/// Every file in `dir` (following links) with its bytes, to show a failed run touched none.
fn snapshot(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .expect("list dir")
        .map(|e| {
            let e = e.expect("entry");
            let bytes = std::fs::read(e.path()).unwrap_or_default();
            (e.file_name().to_string_lossy().into_owned(), bytes)
        })
        .collect()
}

/// A scalar random walk with a prior, and a discrete JSON and a continuous model beside it.
const WALK_TOML: &str =
    "dt = 1\nF = [[1]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\nx0 = [0]\nP0 = [[1]]\n";
const WALK_JSON: &str =
    r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "x0": [0], "P0": [[1]]}"#;
const CONT_JSON: &str = r#"{"A": [[-1]], "C": [[1]], "Qc": [[2]], "R": [[1]]}"#;

#[test]
fn out_that_is_an_input_is_refused() {
    let dir = scratch("ud", "out-is-input");
    write(&dir, "m.toml", WALK_TOML);
    write(&dir, "m.json", WALK_JSON);
    write(&dir, "c.json", CONT_JSON);
    write(&dir, "track.csv", "t,z1\n0,1\n1,2\n");
    std::os::unix::fs::symlink("track.csv", dir.join("link.csv")).expect("symlink");
    std::fs::hard_link(dir.join("track.csv"), dir.join("hard.csv")).expect("hard link");
    let before = snapshot(&dir);
    let filter = |out: &'static str, smooth: bool| {
        let mut a = vec![
            "filter",
            "--model",
            "m.toml",
            "--data",
            "track.csv",
            "--out",
            out,
        ];
        if smooth {
            a.push("--smooth");
        }
        a
    };
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (filter("track.csv", false), "--data track.csv"),
        (filter("track.csv", true), "--data track.csv"),
        (filter("./track.csv", false), "--data track.csv"),
        (filter("link.csv", true), "--data track.csv"),
        (filter("hard.csv", false), "--data track.csv"),
        (filter("m.toml", false), "--model m.toml"),
        (
            vec!["steady-state", "--model", "m.json", "--out", "m.json"],
            "--model m.json",
        ),
        (
            vec![
                "discretize",
                "--model",
                "c.json",
                "--dt",
                "0.1",
                "--method",
                "zoh",
                "--out",
                "./c.json",
            ],
            "--model c.json",
        ),
    ];
    for (args, input) in cases {
        fails(
            &dir,
            &args,
            &["--out ", "is the same file as", input, "refusing"],
            before.len(),
        );
        assert_eq!(snapshot(&dir), before, "{args:?} changed an input");
    }
}

#[test]
fn device_nodes_links_and_standard_output_as_out() {
    use std::os::unix::fs::FileTypeExt;
    let dir = scratch("ud", "out-devices");
    write(&dir, "m.toml", WALK_TOML);
    write(&dir, "c.json", CONT_JSON);
    write(&dir, "z.csv", "t,z1\n0,1\n1,2\n");
    let filter = |out: &str| {
        run(
            &dir,
            &[
                "filter", "--model", "m.toml", "--data", "z.csv", "--out", out,
            ],
        )
    };
    // Device nodes made here (copies of /dev/null and /dev/full), never the system's own: a
    // regression that replaced them must not break the machine. Without the right to mknod,
    // links to the real ones, which such a user cannot replace anyway.
    for (name, minor) in [("null", "3"), ("full", "7")] {
        let made = Command::new("mknod")
            .arg(dir.join(name))
            .args(["c", "1", minor])
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if !made {
            std::os::unix::fs::symlink(format!("/dev/{name}"), dir.join(name)).expect("link");
        }
    }
    let status = Command::new("mkfifo")
        .arg(dir.join("fifo"))
        .status()
        .expect("mkfifo");
    assert!(status.success());
    // Like /dev/stdout when stdout is a pipe: a link to a FIFO.
    std::os::unix::fs::symlink("fifo", dir.join("stdout")).expect("link");
    for (dev, what) in [
        ("null", "character device"),
        ("full", "character device"),
        ("fifo", "a FIFO"),
        ("stdout", "symbolic link to a FIFO"),
    ] {
        let out = filter(dev);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{dev}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.contains(&format!("--out {dev}")) && err.contains(what),
            "{err}"
        );
        assert!(out.stdout.is_empty());
    }
    for dev in ["null", "full"] {
        let t = std::fs::metadata(dir.join(dev))
            .expect("device")
            .file_type();
        assert!(t.is_char_device(), "{dev} must stay a device");
    }
    let t = std::fs::metadata(dir.join("stdout"))
        .expect("fifo")
        .file_type();
    assert!(t.is_fifo(), "the FIFO must stay a FIFO");
    for name in ["null", "full", "stdout"] {
        std::fs::remove_file(dir.join(name)).expect("remove");
    }
    std::fs::remove_file(dir.join("fifo")).expect("remove fifo");
    // The reference output, to a plain new file.
    ok(
        &dir,
        &[
            "filter",
            "--model",
            "m.toml",
            "--data",
            "z.csv",
            "--out",
            "plain.csv",
        ],
    );
    let plain = std::fs::read(dir.join("plain.csv")).expect("plain");
    // A link to a regular file: the file is replaced whole, the link stays a link.
    write(&dir, "real.csv", "old contents\n");
    std::os::unix::fs::symlink("real.csv", dir.join("link.csv")).expect("symlink");
    let out = filter("link.csv");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let link = std::fs::symlink_metadata(dir.join("link.csv")).expect("link");
    assert!(link.file_type().is_symlink(), "the link must stay a link");
    assert_eq!(std::fs::read(dir.join("real.csv")).expect("real"), plain);
    // `-` is standard output: the same bytes, and no file named `-`.
    let out = filter("-");
    assert!(out.status.success());
    assert_eq!(out.stdout, plain);
    for args in [
        vec!["steady-state", "--model", "m.toml", "--out"],
        vec![
            "discretize",
            "--model",
            "c.json",
            "--dt",
            "0.1",
            "--method",
            "zoh",
            "--out",
        ],
    ] {
        let mut to_file = args.clone();
        to_file.push("file.json");
        ok(&dir, &to_file);
        let mut to_stdout = args.clone();
        to_stdout.push("-");
        let out = run(&dir, &to_stdout);
        assert!(out.status.success(), "{to_stdout:?}");
        assert_eq!(
            out.stdout,
            std::fs::read(dir.join("file.json")).expect("file"),
            "{to_stdout:?}"
        );
    }
    assert!(
        !dir.join("-").exists(),
        "`--out -` must not create a file named -"
    );
}

/// Starts `filter` reading its data from a FIFO that the test holds open after a few rows,
/// so the run is certainly mid-write; sends `signal`; checks that nothing is left.
fn interrupt_mid_write(signal: &str) {
    use std::io::Write as _;
    let dir = scratch("ud", &format!("interrupt-{signal}"));
    write(&dir, "m.toml", WALK_TOML);
    let status = Command::new("mkfifo")
        .arg(dir.join("z.csv"))
        .status()
        .expect("mkfifo");
    assert!(status.success());
    let child = Command::new(env!("CARGO_BIN_EXE_scenarios"))
        .current_dir(&dir)
        .args([
            "filter",
            "--model",
            "m.toml",
            "--data",
            "z.csv",
            "--out",
            "sub/est.csv",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    // Opening the FIFO for writing waits for the program to open it for reading.
    let mut fifo = std::fs::OpenOptions::new()
        .write(true)
        .open(dir.join("z.csv"))
        .expect("open fifo");
    fifo.write_all(b"t,z1\n0,1\n1,2\n").expect("rows");
    fifo.flush().expect("flush");
    // Wait for the temporary file to appear (the program then blocks on the next row).
    let partial = || {
        std::fs::read_dir(dir.join("sub"))
            .map(|d| d.count())
            .unwrap_or(0)
    };
    let start = std::time::Instant::now();
    while partial() == 0 {
        assert!(
            start.elapsed() < std::time::Duration::from_secs(60),
            "no temporary file appeared"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let pid = child.id().to_string();
    // The shell's own `kill`, so the test needs no separate kill program.
    let status = Command::new("sh")
        .args(["-c", &format!("kill -s {signal} {pid}")])
        .status()
        .expect("kill");
    assert!(status.success());
    let out = child.wait_with_output().expect("wait");
    drop(fifo);
    assert_eq!(out.status.code(), Some(130), "{signal}: {out:?}");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(
        left.len(),
        2,
        "{signal}: only the inputs may remain (no partial file, no created directory): {left:?}"
    );
}

#[test]
fn interrupt_removes_the_partial_file() {
    interrupt_mid_write("INT");
    interrupt_mid_write("TERM");
}

#[test]
fn failing_run_leaves_no_directory() {
    let dir = scratch("ud", "no-dir");
    write(&dir, "m.toml", WALK_TOML);
    // Fails after rows were streamed into the temporary file in new/sub/.
    write(&dir, "bad.csv", "t,z1\n0,1\n1,2\n2,x\n");
    for out in ["new/sub/est.csv", "new/est.csv"] {
        fails(
            &dir,
            &[
                "filter", "--model", "m.toml", "--data", "bad.csv", "--out", out,
            ],
            &["bad.csv: line 4"],
            2,
        );
    }
    // Fails before writing (a bad model): no directory either.
    write(&dir, "good.csv", "t,z1\n0,1\n");
    write(&dir, "bad.toml", "dt = 1\n");
    fails(
        &dir,
        &[
            "filter",
            "--model",
            "bad.toml",
            "--data",
            "good.csv",
            "--out",
            "new/est.csv",
        ],
        &["bad.toml"],
        4,
    );
    // A successful run creates it.
    ok(
        &dir,
        &[
            "filter",
            "--model",
            "m.toml",
            "--data",
            "good.csv",
            "--out",
            "new/sub/est.csv",
        ],
    );
    assert!(dir.join("new/sub/est.csv").is_file());
}

/// Runs `args` expecting exit code 2, nothing on stdout and exactly `expect` as stderr.
fn usage_error(dir: &Path, args: &[&str], expect: &str) {
    let out = run(dir, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(out.stdout.is_empty(), "{args:?}");
    assert_eq!(err, format!("scenarios: {expect}\n"), "{args:?}");
}

#[test]
fn argument_errors_are_one_line_naming_the_argument() {
    let dir = scratch("ud", "args");
    write(&dir, "c.json", CONT_JSON);
    let disc = |dt: &'static str| {
        [
            "discretize",
            "--model",
            "c.json",
            "--dt",
            dt,
            "--method",
            "zoh",
            "--out",
            "d.json",
        ]
    };
    usage_error(
        &dir,
        &["fueling", "--shard", "5/4", "--out", "r"],
        "--shard 5/4: K must be between 1 and N",
    );
    usage_error(
        &dir,
        &disc("-1"),
        "--dt -1: must be finite and > 0 (seconds)",
    );
    usage_error(&dir, &disc("0"), "--dt 0: must be finite and > 0 (seconds)");
    usage_error(
        &dir,
        &disc("1e400"),
        "--dt 1e400: must be finite and > 0 (seconds)",
    );
    usage_error(
        &dir,
        &disc("abc"),
        "--dt abc: not a number (seconds, finite and > 0)",
    );
    usage_error(
        &dir,
        &["fueling", "--runs", "-3", "--out", "r"],
        "--runs -3: expected a whole number",
    );
    usage_error(
        &dir,
        &["fueling", "--threads", "0", "--out", "r"],
        "--threads 0: must be at least 1",
    );
    usage_error(
        &dir,
        &[
            "filter", "--model", "m.json", "--data", "z.csv", "--out", "e.csv", "--form", "bad",
        ],
        "--form bad: expected joseph, standard or sqrt",
    );
    usage_error(
        &dir,
        &["filter", "--frm", "sqrt"],
        "unknown argument --frm (did you mean --form?)",
    );
    usage_error(
        &dir,
        &["filter", "--model", "m.json"],
        "--data and --out: required but not given",
    );
    usage_error(
        &dir,
        &["filtr"],
        "unknown command filtr: expected fueling, uav, boom, all, merge, filter, discretize, \
         steady-state or fit (did you mean fit or filter?)",
    );
    usage_error(
        &dir,
        &[],
        "a command is required: fueling, uav, boom, all, merge, filter, discretize, \
         steady-state or fit (see scenarios --help)",
    );
    usage_error(
        &dir,
        &["uav", "--out", "-"],
        "--out -: uav writes a directory of files; standard output (-) is only for filter, \
         discretize and steady-state",
    );
    // Help still goes to stdout with exit code 0.
    let out = run(&dir, &["filter", "--help"]);
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("--model"));
    assert_eq!(
        std::fs::read_dir(&dir).expect("dir").count(),
        1,
        "nothing written"
    );
}

#[test]
fn shard_out_of_range_is_refused() {
    let dir = scratch("ud", "shard");
    for (shard, why) in [
        (
            "18446744073709551615/18446744073709551615",
            "N must be between 1 and 1000000",
        ),
        ("1/18446744073709551616", "N must be between 1 and 1000000"),
        ("1/1000001", "N must be between 1 and 1000000"),
        ("18446744073709551616/2", "K must be between 1 and N"),
        ("0/4", "K must be between 1 and N"),
        ("1/0", "N must be between 1 and 1000000"),
        ("-1/2", "K must be a whole number"),
        ("1/two", "N must be a whole number"),
        ("3", "expected K/N, slice K of N (for example 2/8)"),
    ] {
        usage_error(
            &dir,
            &["fueling", "--shard", shard, "--out", "r"],
            &format!("--shard {shard}: {why}"),
        );
    }
    assert!(!dir.join("r").exists(), "no output directory");
}

#[test]
fn json_model_errors_name_the_key_path_and_a_bom_is_accepted() {
    let dir = scratch("ud", "json");
    write(&dir, "z.csv", "t,z1\n0,1\n1,2\n");
    let filter = [
        "filter", "--model", "m.json", "--data", "z.csv", "--out", "est.csv",
    ];
    // As Python's json.dump writes non-finite floats.
    for (bad, key, token) in [
        (r#""Q": [[NaN]]"#, "key Q[0][0]", "NaN"),
        (r#""R": [[Infinity]]"#, "key R[0][0]", "Infinity"),
        (r#""P0": [[-Infinity]]"#, "key P0[0][0]", "-Infinity"),
    ] {
        let name = bad.split('"').nth(1).expect("key");
        let text = WALK_JSON.replace(&format!(r#""{name}": [[1]]"#), bad);
        assert_ne!(text, WALK_JSON, "{bad}");
        write(&dir, "m.json", &text);
        fails(
            &dir,
            &filter,
            &[
                "m.json: invalid JSON model",
                key,
                &format!("{token} is not a JSON number"),
            ],
            2,
        );
    }
    write(
        &dir,
        "m.json",
        &WALK_JSON.replace(r#""H": [[1]]"#, r#""H": [["1"]]"#),
    );
    fails(&dir, &filter, &["key H[0][0]", "invalid type: string"], 2);
    // A byte-order mark is accepted, and gives the same estimates.
    write(&dir, "m.json", WALK_JSON);
    ok(&dir, &filter);
    let plain = std::fs::read(dir.join("est.csv")).expect("est");
    std::fs::remove_file(dir.join("est.csv")).expect("remove");
    write(&dir, "m.json", &format!("\u{feff}{WALK_JSON}"));
    ok(&dir, &filter);
    assert_eq!(std::fs::read(dir.join("est.csv")).expect("est"), plain);
}

#[test]
fn discretize_computes_only_what_is_asked() {
    // ẋ = 1000 x: e^{1000·dt} overflows f64 for dt = 1 (e^{709.8} is the largest f64).
    let dir = scratch("ud", "disc-only");
    write(&dir, "c.json", r#"{"A": [[1000]], "C": [[1]]}"#);
    let disc = |dt: &'static str, method: &'static str| {
        [
            "discretize",
            "--model",
            "c.json",
            "--dt",
            dt,
            "--method",
            method,
            "--out",
            "d.json",
        ]
    };
    // Forward Euler with no noise needs no exponential: F = 1 + A·dt, Q = 0.
    ok(&dir, &disc("1", "euler"));
    let d = read_json(&dir.join("d.json"));
    assert_eq!(mat(&d["F"]), vec![vec![1001.0]]);
    assert_eq!(mat(&d["Q"]), vec![vec![0.0]]);
    std::fs::remove_file(dir.join("d.json")).expect("remove");
    // ZOH does need e^{A·dt}: the message names --dt as the culprit.
    fails(
        &dir,
        &disc("1", "zoh"),
        &[
            "--dt 1: dt = 1 is too large for this A",
            "overflows",
            "c.json",
        ],
        1,
    );
    // A step 1000 times smaller is fine: F = e^{1}.
    ok(&dir, &disc("0.001", "zoh"));
    let f = mat(&read_json(&dir.join("d.json"))["F"])[0][0];
    assert!((f - 1f64.exp()).abs() < 4.0 * f64::EPSILON * f, "{f}");
}

#[test]
fn csv_truncated_last_line_and_unbalanced_quote_are_one_line_errors() {
    let dir = scratch("ud", "csv-trunc");
    write(&dir, "m.toml", WALK_TOML);
    let filter = [
        "filter", "--model", "m.toml", "--data", "z.csv", "--out", "est.csv",
    ];
    // `4,5.25` cut to `4,5.` would read as 5: a last line with no newline is refused.
    write(&dir, "z.csv", "t,z1\n0,1\n4,5.");
    fails(
        &dir,
        &filter,
        &["z.csv: line 3: the last line has no final newline"],
        2,
    );
    write(&dir, "z.csv", "t,z1");
    fails(
        &dir,
        &filter,
        &["z.csv: line 1: the last line has no final newline"],
        2,
    );
    write(&dir, "z.csv", "t,z1\n0,\"1\n1,2\n2,3\n");
    fails(
        &dir,
        &filter,
        &["z.csv: line 2, column 2 (z1): unbalanced quote"],
        2,
    );
    // CRLF endings and a final blank line are whole files.
    write(&dir, "z.csv", "t,z1\r\n0,1\r\n4,5\r\n\r\n");
    ok(&dir, &filter);
}

#[test]
fn io_failures_exit_with_code_one() {
    // /proc takes no new files, even for root: an I/O failure, not the user's input.
    let dir = scratch("ud", "io");
    write(&dir, "m.toml", WALK_TOML);
    write(&dir, "z.csv", "t,z1\n0,1\n");
    let out = run(
        &dir,
        &[
            "filter",
            "--model",
            "m.toml",
            "--data",
            "z.csv",
            "--out",
            "/proc/est.csv",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("/proc/est.csv: cannot write"), "{err}");
}

#[test]
fn diverging_filter_is_refused_naming_the_row() {
    // x1 is unmeasured with F11 = 1e10: its variance grows by 1e20 a step from P0 = 1, so it
    // overflows f64 (1.8e308) around step 16 and every estimate after it, even the measured,
    // stable x2 (F22 = 0.5), would be inf or NaN. The run must stop at a row in that range,
    // name it, and write nothing.
    let dir = scratch("ud", "diverge");
    write(
        &dir,
        "m.json",
        r#"{"dt": 1, "F": [[1e10, 0], [0, 0.5]], "H": [[0, 1]], "Q": [[1, 0], [0, 1]],
            "R": [[1]], "P0": [[1, 0], [0, 1]]}"#,
    );
    let mut csv = String::from("t,z1\n");
    for k in 0..40 {
        csv.push_str(&format!("{k},{}\n", 0.5f64.powi(k)));
    }
    write(&dir, "z.csv", &csv);
    for extra in [
        &["--form", "joseph"][..],
        &["--form", "standard"],
        &["--form", "sqrt"],
        &["--smooth"],
    ] {
        let mut args = vec![
            "filter", "--model", "m.json", "--data", "z.csv", "--out", "est.csv",
        ];
        args.extend_from_slice(extra);
        let out = run(&dir, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        let line: u64 = err
            .split("z.csv: line ")
            .nth(1)
            .and_then(|rest| rest.split(':').next())
            .and_then(|l| l.parse().ok())
            .unwrap_or_else(|| panic!("{extra:?}: no data line named: {err}"));
        // Data row k (from 0) is on line k + 2 and ends with prediction k + 1; P11 after j
        // predictions is about (1e10)^(2j) = 1e20^j: 1e300 after 15, past f64 after 16
        // (row 15, line 17). A check that flags an overflow a little before the infinity
        // may name a slightly earlier row.
        assert!((14..=20).contains(&line), "{extra:?}: line {line}: {err}");
        assert_eq!(
            std::fs::read_dir(&dir).expect("dir").count(),
            2,
            "{extra:?}: no output file"
        );
    }
}
