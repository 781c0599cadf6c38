//! The Riccati benchmark collections of Benner, Laub and Mehrmann (CAREX, DAREX) as SciPy's
//! tests carry them, against SciPy's answers stored by `tests/data/riccati/make_benchmarks.py`
//! (the problems read from SciPy's own test module, its solutions and residuals), and the
//! filter DARE with an exact channel against the engine's own filter.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side, mat};
use kalman::riccati::{Care, Clqr, Dare, Dlqr};
use kalman::{CovarianceForm, DynDims, Filter, Model};
use serde_json::Value;

/// One stored problem in SciPy's control form.
pub struct Problem {
    pub name: String,
    pub a: Mat<f64>,
    pub b: Mat<f64>,
    pub q: Mat<f64>,
    pub r: Mat<f64>,
    pub known_failure: Option<String>,
    pub scipy_residual: Option<f64>,
    pub x: Option<Mat<f64>>,
}

fn sparse(v: &Value) -> Mat<f64> {
    let rows = v["rows"].as_u64().expect("rows") as usize;
    let cols = v["cols"].as_u64().expect("cols") as usize;
    let mut m = Mat::zeros(rows, cols);
    for e in v["entries"].as_array().expect("entries") {
        let i = e[0].as_u64().expect("i") as usize;
        let j = e[1].as_u64().expect("j") as usize;
        m[(i, j)] = e[2].as_f64().expect("value");
    }
    m
}

/// The problems of `file` (`carex.json` or `darex.json`).
pub fn load(file: &str) -> Vec<Problem> {
    let path = format!("{}/tests/data/riccati/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect("stored benchmark file");
    let doc: Value = serde_json::from_str(&text).expect("benchmark JSON");
    doc["problems"]
        .as_array()
        .expect("problems")
        .iter()
        .map(|p| {
            let n = p["n"].as_u64().expect("n") as usize;
            Problem {
                name: p["name"].as_str().expect("name").to_owned(),
                a: sparse(&p["a"]),
                b: sparse(&p["b"]),
                q: sparse(&p["q"]),
                r: sparse(&p["r"]),
                known_failure: p["known_failure"].as_str().map(str::to_owned),
                scipy_residual: p["scipy_residual"].as_f64(),
                x: p["x"]
                    .as_array()
                    .map(|x| Mat::from_fn(n, n, |i, j| x[i * n + j].as_f64().expect("x"))),
            }
        })
        .collect()
}

/// SciPy's CARE residual X A + AᵀX − X B R⁻¹ Bᵀ X + Q, relative to ‖X‖_F: the same formula
/// as the generator script's, written here on faer (not the solver's own residual).
fn care_residual(p: &Problem, X: &Mat<f64>) -> f64 {
    let XB = X * &p.b;
    let corr = &XB * p.r.llt(Side::Lower).expect("R > 0").solve(XB.transpose());
    let res = X * &p.a + p.a.transpose() * X - corr + &p.q;
    res.norm_l2() / X.norm_l2()
}

/// SciPy's DARE residual AᵀXA − X + Q − AᵀXB (R + BᵀXB)⁻¹ BᵀXA, relative to ‖X‖_F (an LU
/// solve as SciPy's `solve`: R + BᵀXB need not be factored by Cholesky here).
fn dare_residual(p: &Problem, X: &Mat<f64>) -> f64 {
    let (XA, XB) = (X * &p.a, X * &p.b);
    let sigma = &p.r + p.b.transpose() * &XB;
    let gain = sigma.partial_piv_lu().solve(XB.transpose() * &p.a);
    let res = p.a.transpose() * &XA - X + &p.q - p.a.transpose() * &XB * gain;
    res.norm_l2() / X.norm_l2()
}

/// One collection: every problem SciPy solves is solved to 10× SciPy's relative residual or
/// better and to SciPy's stabilising solution; a refusal is one line, and only of a problem
/// SciPy marks as a known failure. Prints the table of `docs/steady-state.md`
/// (`--nocapture`).
fn collection(file: &str, discrete: bool) {
    eprintln!("| problem | n | m | SciPy | this crate | ‖X − X_SciPy‖/‖X_SciPy‖ |");
    eprintln!("|---|---|---|---|---|---|");
    for p in load(file) {
        let (n, m) = (p.a.nrows(), p.b.ncols());
        let solved = if discrete {
            Dlqr::new(&p.a, &p.b, &p.q, &p.r).and_then(|d| d.solve())
        } else {
            Clqr::new(&p.a, &p.b, &p.q, &p.r).and_then(|c| c.solve())
        };
        let scipy = p
            .scipy_residual
            .map_or("raised".to_owned(), |r| format!("{r:.1e}"));
        let scipy = match &p.known_failure {
            Some(_) => format!("{scipy} (known failure)"),
            None => scipy,
        };
        match solved {
            Ok(l) => {
                let ours = if discrete {
                    dare_residual(&p, &l.cost)
                } else {
                    care_residual(&p, &l.cost)
                };
                let diff = p.x.as_ref().map(|x| (&l.cost - x).norm_l2() / x.norm_l2());
                let shown = diff.map_or("—".to_owned(), |d| format!("{d:.1e}"));
                eprintln!(
                    "| {} | {n} | {m} | {scipy} | {ours:.1e} | {shown} |",
                    p.name
                );
                assert!(ours.is_finite(), "{}: residual {ours:e}", p.name);
                if p.known_failure.is_none() {
                    let theirs = p.scipy_residual.expect("SciPy solved it");
                    // 10× SciPy's relative residual, with ε as the floor of a relative
                    // residual (SciPy's DAREX #3 is an exact 0).
                    let bound = 10.0 * theirs.max(f64::EPSILON);
                    assert!(
                        ours <= bound,
                        "{}: {ours:e} against SciPy's {theirs:e}",
                        p.name
                    );
                }
                if let (Some(d), Some(x)) = (diff, &p.x) {
                    let tol = agreement(&p, x, discrete);
                    assert!(
                        d < tol,
                        "{}: differs from SciPy's by {d:e} (allowed {tol:e})",
                        p.name
                    );
                }
            }
            Err(e) => {
                let line = e.to_string();
                eprintln!("| {} | {n} | {m} | {scipy} | refused: {line} | — |", p.name);
                assert!(!line.contains('\n'), "{}: {line}", p.name);
                assert!(
                    p.known_failure.is_some(),
                    "{}: refused a problem SciPy solves: {line}",
                    p.name
                );
            }
        }
    }
}

/// How closely two good answers must agree. The stabilising solution is unique: another
/// solution of the equation differs from it at O(1). Two answers with residuals at
/// round-off agree to ε times the Riccati operator's condition number, which is about
/// 1/(2 sep) with sep the closed loop's distance to the stability boundary relative to its
/// eigenvalues' size (the Lyapunov operator's inverse for a normal closed loop). So: 1e-6,
/// or 100 ε/sep where the closed loop of SciPy's X is that close to the boundary (CAREX #14:
/// sep = 5·10⁻¹³, its answers differ by 10⁻³).
fn agreement(p: &Problem, x: &Mat<f64>, discrete: bool) -> f64 {
    let XB = x * &p.b;
    let cl = if discrete {
        let sigma = &p.r + p.b.transpose() * &XB;
        &p.a - &p.b * sigma.partial_piv_lu().solve(XB.transpose() * &p.a)
    } else {
        &p.a - &p.b * p.r.llt(Side::Lower).expect("R > 0").solve(XB.transpose())
    };
    let sep = cl
        .eigenvalues()
        .expect("closed loop eigenvalues")
        .iter()
        .map(|l| {
            let d = if discrete { 1.0 - l.norm() } else { -l.re };
            d / l.norm().max(1.0)
        })
        .fold(f64::INFINITY, f64::min);
    1e-6f64.max(100.0 * f64::EPSILON / sep)
}

#[test]
fn darex_collection_matches_scipy() {
    collection("darex.json", true);
}

/// CAREX #20 (n = 421) included: its closed loop is the matrix on which faer's default
/// eigenvalue routine does not return; this test finishing is the check that every loop
/// of the solver is bounded.
#[test]
fn carex_collection_matches_scipy() {
    collection("carex.json", false);
}

/// The filter form of the CAREX problems SciPy solves (A → Aᵀ, B → H = Bᵀ, Q a
/// covariance): the same P as the LQR form, where Q is positive semidefinite.
#[test]
fn carex_filter_form_is_the_dual() {
    for p in load("carex.json") {
        let Some(x) = &p.x else { continue };
        let q_psd =
            p.q.self_adjoint_eigen(Side::Lower)
                .map(|e| {
                    e.S()
                        .column_vector()
                        .iter()
                        .all(|&s| s >= -1e-12 * p.q.norm_l2())
                })
                .unwrap_or(false);
        if !q_psd {
            continue;
        }
        let ss = Care::new(p.a.transpose(), p.b.transpose(), &p.q, &p.r)
            .and_then(|c| c.solve())
            .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        let d = (&ss.covariance - x).norm_l2() / x.norm_l2();
        // As in the LQR form (see `agreement`).
        let tol = agreement(&p, x, false);
        assert!(d < tol, "{}: {d:e} (allowed {tol:e})", p.name);
    }
}

/// A constant-velocity track with the position measured exactly (R = diag(0, 1)): R is
/// singular, H P Hᵀ + R is not. The DARE's steady state must be the limit of the engine's
/// own filter, which handles the exact channel by its pseudo-inverse path.
#[test]
fn exact_channel_steady_state_is_the_filter_limit() {
    let dt = 0.5;
    let F = mat![[1.0, dt, 0.0], [0.0, 1.0, dt], [0.0, 0.0, 0.9]];
    let H = mat![[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    let Q = mat![[0.01, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.5]];
    let R = mat![[0.0, 0.0], [0.0, 1.0]];
    let ss = Dare::new(&F, &H, &Q, &R)
        .and_then(|d| d.solve())
        .expect("exact channel");
    let model = Model::new(DynDims::new(3, 2, 0).expect("dims"), &F, &H, &Q, &R).expect("model");
    let P0 = Mat::<f64>::identity(3, 3);
    let mut f = Filter::new(model, &[0.0; 3], &P0, CovarianceForm::Joseph).expect("filter");
    let mut prev = P0;
    for _ in 0..5_000 {
        f.step(&[0.0, 0.0], None).expect("step");
        let P = f.predicted_covariance().to_owned();
        let settled = (&P - &prev).norm_l2() <= 1e-15 * P.norm_l2();
        prev = P;
        if settled {
            break;
        }
    }
    // The filter's recursion contracts at the closed loop's rate, so its limit and the DARE
    // solution agree to the rounding of each (1e-12 relative, P's entries being O(0.1–1)).
    let d = (&ss.prior - &prev).norm_l2() / prev.norm_l2();
    assert!(d < 1e-12, "DARE {:?} vs filter {:?}: {d:e}", ss.prior, prev);
    // The exact channel: the posterior variance of the position is 0.
    assert!(ss.posterior[(0, 0)].abs() < 1e-12 * ss.prior.norm_l2());
}

/// DAREX #3 and #4 (R singular) in the filter form too: the dual DARE (F = Aᵀ, H = Bᵀ) of
/// the stored problems gives SciPy's solution.
#[test]
fn singular_r_darex_in_filter_form() {
    for p in load("darex.json") {
        if !(p.name == "DAREX #3" || p.name == "DAREX #4") {
            continue;
        }
        assert!(p.r.llt(Side::Lower).is_err(), "{}: R is singular", p.name);
        let ss = Dare::new(p.a.transpose(), p.b.transpose(), &p.q, &p.r)
            .and_then(|d| d.solve())
            .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        let x = p.x.as_ref().expect("stored");
        let d = (&ss.prior - x).norm_l2() / x.norm_l2();
        // Both residuals are at round-off (SciPy's 0 and 2e-15): the solutions agree to ε·κ.
        assert!(d < 1e-12, "{}: {d:e}", p.name);
    }
}
