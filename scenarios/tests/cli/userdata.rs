//! `filter`, `discretize` and `steady-state` driven through the built binary on small models,
//! against values computed independently here (their input errors are in `input_errors.rs`,
//! what they do to the files around them in `output_safety.rs`).
#![allow(non_snake_case)]

use std::path::Path;
use std::process::Command;

use nalgebra::{DMatrix, DVector};

use crate::common::*;

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
            &argv_with(
                "filter --model m.toml --data z.csv --out est.csv --form {}",
                &[form],
            ),
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
            &argv_with(
                "filter --model m.json --data z.csv --out est.csv --form {} --full-covariance",
                &[form],
            ),
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
        &argv("filter --model m.json --data z.csv --out diag.csv"),
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
    let dir = with_model(
        "ud",
        "long",
        r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "P0": [[100]]}"#,
    );
    let mut csv = String::from("t,z1\n");
    for k in 0..20_000 {
        csv.push_str(&format!("{k},{}\n", (k % 7) as f64 * 0.1));
    }
    write(&dir, "z.csv", &csv);
    ok(
        &dir,
        &argv("filter --model m.json --data z.csv --out est.csv"),
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
            "{{\"dt\": 1, \"F\": {}, \"B\": {}, \"H\": {}, \"Q\": {}, \"R\": {}, \"x0\": [0.5, -0.5], \"P0\": {}}}",
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
            &argv_with(
                "filter --model m.json --data z.csv --out s.csv --smooth --full-covariance --form {}",
                &[form],
            ),
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
        &argv("filter --model m.json --data z.csv --out f.csv"),
    );
    ok(
        &dir,
        &argv("filter --model m.json --data z.csv --out s.csv --smooth"),
    );
    let (_, f) = read_csv(&dir.join("f.csv"));
    let (_, s) = read_csv(&dir.join("s.csv"));
    for (a, b) in f.iter().zip(&s) {
        assert!(b[3] <= a[3] * (1.0 + 1e-12) && b[4] <= a[4] * (1.0 + 1e-12));
    }
    assert!(close(f[N - 1][1], s[N - 1][1], 1e-12));
}

/// The scalar model x' = f x + w, z = x + v with var w = q, var v = 1, Δt = 1, as TOML.
fn scalar_toml(f: f64, q: f64) -> String {
    format!("dt = 1\nF = [[{f}]]\nH = [[1]]\nQ = [[{q}]]\nR = [[1]]\n")
}

/// Runs `steady-state` on the scalar model file `name` into `ss.json` and checks its P, K
/// and P_post against the closed forms `expect`: a converged doubling solution agrees with
/// them to round-off, 1e-12. Returns the file read.
fn steady_scalar(dir: &Path, name: &str, expect: [f64; 3]) -> serde_json::Value {
    ok(
        dir,
        &argv_with("steady-state --model {} --out ss.json", &[name]),
    );
    let ss = read_json(&dir.join("ss.json"));
    for (key, want) in ["P", "K", "P_post"].into_iter().zip(expect) {
        assert!(close(mat(&ss[key])[0][0], want, 1e-12), "{key}: {ss}");
    }
    ss
}

#[test]
fn steady_state_exists_when_only_off_circle_modes_are_unreached() {
    let dir = scratch("ud", "steady-exist");
    // F = 2, Q = 0, H = R = 1: the unstable mode gets no process noise, yet (F, H) is
    // detectable and the mode is off the unit circle, so the DARE has a stabilising
    // solution. P = 4P/(P + 1) gives P = 3 (the other root, 0, leaves F − KH = 2); then
    // K = P/(P + 1) = 0.75 and P_post = P − P²/(P + 1) = 0.75. Closed forms: 1e-12.
    write(&dir, "u.toml", &scalar_toml(2.0, 0.0));
    steady_scalar(&dir, "u.toml", [3.0, 0.75, 0.75]);
    // F = 1 with Q = 0: the unreached mode sits on the unit circle, where no stabilising
    // solution exists (the gain decays like 1/k and never settles): refused by name.
    std::fs::remove_file(dir.join("ss.json")).expect("remove");
    write(&dir, "c.toml", &scalar_toml(1.0, 0.0));
    refused(
        &dir,
        &argv("steady-state --model c.toml --out ss.json"),
        &["c.toml", "is not stabilisable"],
        2,
    );
}

#[test]
fn steady_state_against_iterated_riccati() {
    let dir = scratch("ud", "steady");
    // Scalar random walk, q = r = 1: P = (1 + √5)/2, K = P/(P + 1), P_post = P/(P + 1).
    write(&dir, "rw.toml", &scalar_toml(1.0, 1.0));
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    let ss = steady_scalar(&dir, "rw.toml", [p, p / (p + 1.0), p / (p + 1.0)]);
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
    ok(&dir, &argv("steady-state --model m.json --out ss.json"));
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
    refused(
        &dir,
        &argv("steady-state --model nd.json --out ss.json"),
        &["nd.json", "(F, H) is not detectable"],
        3,
    );
    // The model rules apply to steady-state too.
    write(
        &dir,
        "nd.json",
        r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[-1]], "R": [[1]]}"#,
    );
    refused(
        &dir,
        &argv("steady-state --model nd.json --out ss.json"),
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
    let dir = with_model(
        "ud",
        "memory",
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
        let mut a = argv_with("filter --model m.json --data {} --out est.csv", &[data]);
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
        &argv("discretize --model di.json --dt 0.2 --method zoh --out d.json"),
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
        &argv("filter --model d0.json --data z.csv --out e.csv"),
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
            &argv_with(
                "discretize --model lag.toml --dt 0.2 --method {} --noise {} --out l.json",
                &[method, noise],
            ),
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
