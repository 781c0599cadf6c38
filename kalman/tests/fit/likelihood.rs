//! The log-likelihood against the dense multivariate normal of the stacked series, and the
//! exact gradient against central differences.

use crate::FORMS;
use faer::Mat;
use kalman::fit::{
    Derivative, FnMap, Free, ParamMap, Series, StandardMap, Structure, System, log_likelihood,
    log_likelihood_gradient,
};
use nalgebra::{DMatrix, DVector};
use rand::RngExt;
use rand_distr::StandardNormal;

use super::common::rng;

/// A small random system: n = 3, m = 2, p = 1, full Q, R, P0.
fn small_system(seed: u64) -> System {
    let mut g = rng(seed);
    let mut randn =
        |r: usize, c: usize| Mat::from_fn(r, c, |_, _| g.sample::<f64, _>(StandardNormal));
    let F = randn(3, 3) * 0.4;
    let H = randn(2, 3);
    let a = randn(3, 3);
    let Q = &a * a.transpose() * 0.3 + Mat::<f64>::identity(3, 3) * 0.1;
    let b = randn(2, 2);
    let R = &b * b.transpose() * 0.5 + Mat::<f64>::identity(2, 2) * 0.2;
    let c = randn(3, 3);
    let P0 = &c * c.transpose() + Mat::<f64>::identity(3, 3) * 0.5;
    let B = randn(3, 1);
    let x0 = vec![0.3, -0.2, 0.5];
    System::new(&F, &H, &Q, &R, &x0, &P0)
        .and_then(|s| s.with_control(&B))
        .expect("valid system")
}

fn na(a: &Mat<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)])
}

/// The log-density of the observed entries of the stacked series as one multivariate normal:
/// mean `H E[x_k]`, covariance `H Cov(x_k, x_l) Hᵀ + δ_kl R`, with `Cov(x_k, x_l) =
/// F^{k−l} Π_l` for k ≥ l and `Π_{l+1} = F Π_l Fᵀ + Q`. Dense Cholesky by nalgebra.
fn dense_log_density(sys: &System, z: &[f64], u: &[f64]) -> f64 {
    let (n, m, p) = (sys.n(), sys.m(), sys.p());
    let len = z.len() / m;
    let (F, H, Q, R, B) = (na(&sys.f), na(&sys.h), na(&sys.q), na(&sys.r), na(&sys.b));
    let mut mean = vec![DVector::from_column_slice(&sys.x0)];
    let mut pi = vec![na(&sys.p0)];
    for k in 1..len {
        let uk = DVector::from_column_slice(&u[(k - 1) * p..k * p]);
        mean.push(&F * &mean[k - 1] + &B * uk);
        pi.push(&F * &pi[k - 1] * F.transpose() + &Q);
    }
    let idx: Vec<(usize, usize)> = (0..len)
        .flat_map(|k| (0..m).map(move |r| (k, r)))
        .filter(|&(k, r)| !z[k * m + r].is_nan())
        .collect();
    let d = idx.len();
    let mut cov = DMatrix::zeros(d, d);
    let mut resid = DVector::zeros(d);
    for (a, &(k, r)) in idx.iter().enumerate() {
        resid[a] = z[k * m + r] - (H.row(r) * &mean[k])[0];
        for (b, &(l, s)) in idx.iter().enumerate() {
            let (hi, lo) = if k >= l { (k, l) } else { (l, k) };
            let mut Fp = DMatrix::identity(n, n);
            for _ in lo..hi {
                Fp = &F * Fp;
            }
            let cxx = Fp * &pi[lo]; // Cov(x_hi, x_lo)
            let c = if k >= l {
                (H.row(r) * &cxx * H.row(s).transpose())[0]
            } else {
                (H.row(s) * &cxx * H.row(r).transpose())[0]
            };
            cov[(a, b)] = c + if k == l { R[(r, s)] } else { 0.0 };
        }
    }
    let chol = cov.clone().cholesky().expect("dense covariance SPD");
    let sol = chol.solve(&resid);
    let logdet: f64 = 2.0 * chol.l().diagonal().iter().map(|v| v.ln()).sum::<f64>();
    -0.5 * (resid.dot(&sol) + logdet + d as f64 * (2.0 * std::f64::consts::PI).ln())
}

fn series_data(seed: u64, len: usize, missing: bool) -> (Vec<f64>, Vec<f64>) {
    let mut g = rng(seed);
    let mut z: Vec<f64> = (0..2 * len)
        .map(|_| g.sample::<f64, _>(StandardNormal))
        .collect();
    let u: Vec<f64> = (0..len)
        .map(|_| g.sample::<f64, _>(StandardNormal))
        .collect();
    if missing {
        z[1] = f64::NAN; // partially missing z_0
        z[4] = f64::NAN; // fully missing z_2
        z[5] = f64::NAN;
        z[8] = f64::NAN; // partially missing z_4
    }
    (z, u)
}

#[test]
fn loglik_equals_dense_multivariate_normal() {
    // The dense and recursive values are two exact evaluations of the same number; both
    // accumulate round-off of order 1e-14·|ln L| over a 14-value stack, so 1e-10 is loose.
    for (seed, missing) in [(1, false), (2, true), (3, false), (4, true)] {
        let sys = small_system(seed);
        let (z, u) = series_data(seed + 100, 7, missing);
        let data = Series::new(&z, 2)
            .and_then(|s| s.with_inputs(&u, 1))
            .expect("series");
        let dense = dense_log_density(&sys, &z, &u);
        for form in FORMS {
            let ll = log_likelihood(&sys, &data, form).expect("loglik");
            assert!(
                (ll - dense).abs() <= 1e-10 * dense.abs().max(1.0),
                "{form:?}, missing {missing}: {ll} vs dense {dense}"
            );
        }
        // The score recursion's value is the same number.
        let map = FnMap::new(1, |_t: &[f64]| Ok(sys.clone()));
        let (ll, _) = log_likelihood_gradient(&map, &[0.0], &data).expect("score");
        assert!(
            (ll - dense).abs() <= 1e-10 * dense.abs().max(1.0),
            "score recursion, missing {missing}: {ll} vs {dense}"
        );
    }
}

/// Central differences of `ln L` with step h: truncation `h²/6·|∂³ ln L|` plus round-off
/// `ε|ln L|/h`; at h = 1e-5 both are ≲ 1e-9 here, so the gradient must agree to 1e-6
/// relative (a wrong term would be off at order 1).
fn check_gradient<M: ParamMap>(map: &M, theta: &[f64], data: &Series<'_>, label: &str) {
    let (_, g) = log_likelihood_gradient(map, theta, data).expect("gradient");
    let mut t = theta.to_vec();
    for i in 0..theta.len() {
        let h = 1e-5;
        t[i] = theta[i] + h;
        let (lp, _) = log_likelihood_gradient(map, &t, data).expect("ll+");
        t[i] = theta[i] - h;
        let (lm, _) = log_likelihood_gradient(map, &t, data).expect("ll-");
        t[i] = theta[i];
        let fd = (lp - lm) / (2.0 * h);
        assert!(
            (g[i] - fd).abs() <= 1e-6 * (1.0 + g[i].abs()),
            "{label}: ∂/∂θ[{i}] exact {} vs central {fd}",
            g[i]
        );
    }
}

#[test]
fn gradient_matches_central_differences_standard_map() {
    for missing in [false, true] {
        let sys = small_system(7);
        let (z, u) = series_data(8, 9, missing);
        let data = Series::new(&z, 2)
            .and_then(|s| s.with_inputs(&u, 1))
            .expect("series");
        let free = Free {
            q: Structure::Full,
            r: Structure::Full,
            x0: true,
            p0_diag: true,
        };
        let map = StandardMap::new(sys.clone(), free).expect("map");
        let theta: Vec<f64> = map
            .theta_of(&sys, None)
            .iter()
            .enumerate()
            .map(|(i, v)| v + 0.05 * (i as f64).sin())
            .collect();
        check_gradient(&map, &theta, &data, "full Q, R, x0, P0");
        for (q, r) in [
            (Structure::Diag, Structure::Scalar),
            (Structure::Scalar, Structure::Diag),
        ] {
            let map = StandardMap::new(
                sys.clone(),
                Free {
                    q,
                    r,
                    ..Free::default()
                },
            )
            .expect("map");
            let theta = map.theta_of(&sys, None);
            check_gradient(&map, &theta, &data, "diag/scalar");
        }
    }
}

#[test]
fn gradient_matches_central_differences_for_f_and_h() {
    // θ enters F and H (exact derivatives given) and Q: exercises the ∂F, ∂H terms.
    let build = build_from(small_system(11));
    let deriv = |t: &[f64]| {
        let z3 = |f: &dyn Fn(usize, usize) -> f64| Mat::from_fn(3, 3, f);
        Ok(vec![
            Derivative {
                f: Some(z3(&|i, j| {
                    if (i, j) == (0, 0) {
                        1.0
                    } else if (i, j) == (1, 2) {
                        t[1]
                    } else {
                        0.0
                    }
                })),
                ..Derivative::default()
            },
            Derivative {
                f: Some(z3(&|i, j| if (i, j) == (1, 2) { t[0] } else { 0.0 })),
                h: Some(Mat::from_fn(
                    2,
                    3,
                    |i, j| if (i, j) == (1, 0) { 1.0 } else { 0.0 },
                )),
                ..Derivative::default()
            },
            Derivative {
                q: Some(z3(&|i, j| if (i, j) == (2, 2) { t[2].exp() } else { 0.0 })),
                ..Derivative::default()
            },
        ])
    };
    let map = FnMap::with_derivatives(3, build, deriv);
    for missing in [false, true] {
        let (z, u) = series_data(12, 9, missing);
        let data = Series::new(&z, 2)
            .and_then(|s| s.with_inputs(&u, 1))
            .expect("series");
        check_gradient(&map, &[0.3, -0.4, -1.0], &data, "F, H");
    }
    // The central-difference fallback of FnMap::new agrees with the exact derivatives to
    // its own truncation (1e-12 relative on the matrices) — far inside 1e-6.
    let fallback = FnMap::new(3, build_from(small_system(11)));
    let (z, u) = series_data(12, 9, true);
    let data = Series::new(&z, 2)
        .and_then(|s| s.with_inputs(&u, 1))
        .expect("series");
    let (_, ge) = log_likelihood_gradient(&map, &[0.3, -0.4, -1.0], &data).expect("exact");
    let (_, gf) = log_likelihood_gradient(&fallback, &[0.3, -0.4, -1.0], &data).expect("fallback");
    for (a, b) in ge.iter().zip(&gf) {
        assert!((a - b).abs() <= 1e-6 * (1.0 + a.abs()), "{a} vs {b}");
    }
}

/// The system of θ for the F, H test: F₀₀ = θ₀, F₁₂ = θ₀θ₁, H₁₀ = θ₁, Q₂₂ = e^θ₂ in `sys0`.
fn build_from(sys0: System) -> impl Fn(&[f64]) -> Result<System, kalman::fit::FitError> {
    move |t: &[f64]| {
        let mut s = sys0.clone();
        s.f[(0, 0)] = t[0];
        s.f[(1, 2)] = t[0] * t[1];
        s.h[(1, 0)] = t[1];
        s.q[(2, 2)] = t[2].exp();
        Ok(s)
    }
}
