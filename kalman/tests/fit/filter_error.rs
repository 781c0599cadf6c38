//! The filter-error fit of a nonlinear model: its likelihood against the linear fit's and
//! the crate's EKF, its AD gradient against central differences, a pendulum's damping and
//! length recovered within their bounds, the bounds' coverage, and its errors.

use faer::Mat;
use kalman::DynDims;
use kalman::fit::{
    AtTheta, FitError, Free, Matrix, MleOptions, Param, ParametricModel, Series, StandardMap,
    System, Transform, ekf_log_likelihood, ekf_log_likelihood_gradient, filter_error,
    log_likelihood_gradient,
};
use kalman::nonlinear::{AutoDiff, Ekf, EkfUpdate, Scalar};
use rand::RngExt;
use rand_distr::StandardNormal;

use super::common::rng;

/// An AR(1) seen through noise, θ = (φ, ln q, ln r): the linear fit's model written as a
/// nonlinear one.
struct Ar1;

impl ParametricModel for Ar1 {
    fn dims(&self) -> (usize, usize, usize) {
        (1, 1, 3)
    }
    fn f<T: Scalar>(&self, th: &[T], x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        out[0] = th[0] * x[0];
    }
    fn h<T: Scalar>(&self, _th: &[T], x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0];
    }
    fn q<T: Scalar>(&self, th: &[T], _k: usize, out: &mut [T]) {
        out[0] = th[1].exp();
    }
    fn r<T: Scalar>(&self, th: &[T], _k: usize, out: &mut [T]) {
        out[0] = th[2].exp();
    }
    fn x0<T: Scalar>(&self, _th: &[T], out: &mut [T]) {
        out[0] = T::from(0.3);
    }
    fn p0<T: Scalar>(&self, _th: &[T], out: &mut [T]) {
        out[0] = T::from(2.0);
    }
}

fn ar1_record(len: usize, seed: u64) -> Vec<f64> {
    let mut g = rng(seed);
    let mut x = 0.0;
    (0..len)
        .map(|k| {
            x = 0.8 * x + 0.7 * g.sample::<f64, _>(StandardNormal);
            // every seventh sample missing: the marginal of the observed rows
            if k % 7 == 3 {
                f64::NAN
            } else {
                x + g.sample::<f64, _>(StandardNormal)
            }
        })
        .collect()
}

#[test]
fn on_a_linear_model_it_is_the_linear_likelihood_and_its_score() {
    // Two independent derivations: the linear fit's filter and score recursion (analytic
    // ∂x, ∂P per parameter) against the generic EKF pass differentiated by AD. Both are a
    // few hundred flops per step of O(1) quantities summed over 400 steps: 1e-10 relative.
    let z = ar1_record(400, 5);
    let data = Series::new(&z, 1).expect("series");
    let theta = [0.6, -0.4, 0.2];
    let base = System::new(&[[0.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.3], &[[2.0]]).expect("sys");
    let params = vec![
        Param::entry(Matrix::F, 0, 0),
        Param::entry(Matrix::Q, 0, 0).transformed(Transform::Log),
        Param::entry(Matrix::R, 0, 0).transformed(Transform::Log),
    ];
    let map = StandardMap::with_params(base, Free::default(), params).expect("map");
    let (ll_lin, g_lin) = log_likelihood_gradient(&map, &theta, &data).expect("linear");
    let (ll, g) = ekf_log_likelihood_gradient(&Ar1, &theta, &data).expect("ekf");
    let v = ekf_log_likelihood(&Ar1, &theta, &data).expect("value");
    assert!(
        (ll - ll_lin).abs() <= 1e-10 * ll_lin.abs(),
        "{ll} vs {ll_lin}"
    );
    assert!(
        (v - ll).abs() <= 1e-12 * ll.abs(),
        "value pass {v} vs dual pass {ll}"
    );
    for i in 0..3 {
        assert!(
            (g[i] - g_lin[i]).abs() <= 1e-9 * g_lin[i].abs().max(1.0),
            "∂/∂θ{i}: {} vs {}",
            g[i],
            g_lin[i]
        );
    }
}

/// A damped pendulum: angle and rate, Euler steps of dt; the horizontal displacement
/// `L sin φ` measured. θ = (c, L): the damping and the length.
struct Pendulum {
    dt: f64,
}

const G: f64 = 9.81;
const Q_RATE: f64 = 1e-4;
const R_POS: f64 = 4e-4;

impl ParametricModel for Pendulum {
    fn dims(&self) -> (usize, usize, usize) {
        (2, 1, 2)
    }
    fn names(&self) -> Vec<String> {
        vec!["damping".into(), "length".into()]
    }
    fn f<T: Scalar>(&self, th: &[T], x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        let (c, l) = (th[0], th[1]);
        out[0] = x[0] + x[1] * self.dt;
        out[1] = x[1] - (x[0].sin() * G / l + x[1] * c) * self.dt;
    }
    fn h<T: Scalar>(&self, th: &[T], x: &[T], _k: usize, out: &mut [T]) {
        out[0] = th[1] * x[0].sin();
    }
    fn q<T: Scalar>(&self, _th: &[T], _k: usize, out: &mut [T]) {
        out.copy_from_slice(&[T::from(0.0), T::from(0.0), T::from(0.0), T::from(Q_RATE)]);
    }
    fn r<T: Scalar>(&self, _th: &[T], _k: usize, out: &mut [T]) {
        out[0] = T::from(R_POS);
    }
    fn x0<T: Scalar>(&self, _th: &[T], out: &mut [T]) {
        out.copy_from_slice(&[T::from(0.6), T::from(0.0)]);
    }
    fn p0<T: Scalar>(&self, _th: &[T], out: &mut [T]) {
        out.copy_from_slice(&[T::from(1e-3), T::from(0.0), T::from(0.0), T::from(1e-3)]);
    }
}

const TRUTH: [f64; 2] = [0.3, 1.5];

/// A record of the pendulum's own model (so the EKF's likelihood is the right one to
/// first order): x0 drawn from the prior, process noise on the rate.
fn pendulum_record(p: &Pendulum, len: usize, seed: u64) -> Vec<f64> {
    let mut g = rng(seed);
    let sd = 1e-3_f64.sqrt();
    let mut x = [
        0.6 + sd * g.sample::<f64, _>(StandardNormal),
        sd * g.sample::<f64, _>(StandardNormal),
    ];
    let mut out = [0.0; 2];
    (0..len)
        .map(|_| {
            let z = TRUTH[1] * x[0].sin() + R_POS.sqrt() * g.sample::<f64, _>(StandardNormal);
            p.f(&TRUTH, &x, None, 0, &mut out);
            x = [
                out[0],
                out[1] + Q_RATE.sqrt() * g.sample::<f64, _>(StandardNormal),
            ];
            z
        })
        .collect()
}

#[test]
fn the_gradient_is_central_differences_of_the_likelihood() {
    // Central differences with h = 1e-5 relative: truncation h²·|∂³ln L|/6 and round-off
    // ε·|ln L|/h ≈ 1e-16·1e3/1e-5 = 1e-8; both below 1e-5 of the gradient's scale.
    let p = Pendulum { dt: 0.02 };
    let z = pendulum_record(&p, 300, 3);
    let data = Series::new(&z, 1).expect("series");
    let theta = [0.5, 1.3];
    let (_, g) = ekf_log_likelihood_gradient(&p, &theta, &data).expect("gradient");
    let scale = g.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
    for j in 0..2 {
        let h = 1e-5 * theta[j].abs().max(1.0);
        let mut t = theta;
        t[j] += h;
        let up = ekf_log_likelihood(&p, &t, &data).expect("up");
        t[j] -= 2.0 * h;
        let down = ekf_log_likelihood(&p, &t, &data).expect("down");
        let cd = (up - down) / (2.0 * h);
        assert!(
            (g[j] - cd).abs() <= 1e-5 * scale,
            "∂/∂θ{j}: AD {} vs central {cd}",
            g[j]
        );
    }
}

#[test]
fn the_fitted_model_is_the_crates_ekf() {
    // AtTheta as a GenericModel through AutoDiff and the crate's EKF: the sum of its steps'
    // log-likelihoods is the fit's likelihood (same Joseph update, same linearisation
    // points; the two differ only in the order of a few sums: 1e-10 relative).
    let p = Pendulum { dt: 0.02 };
    let z = pendulum_record(&p, 200, 8);
    let data = Series::new(&z, 1).expect("series");
    let theta = [0.4, 1.4];
    let fixed = AtTheta::new(Pendulum { dt: 0.02 }, &theta).expect("fixed");
    let (x0, p0) = fixed.prior();
    let dims = DynDims::new(2, 1, 0).expect("dims");
    let p0 = Mat::from_fn(2, 2, |i, j| p0[i + 2 * j]);
    let mut ekf = Ekf::new(
        dims,
        AutoDiff::new(dims, fixed),
        &x0,
        &p0,
        EkfUpdate::Extended,
    )
    .expect("ekf");
    let mut total = 0.0;
    for zk in &z {
        total += ekf.step(&[*zk], None).expect("step").log_likelihood;
    }
    let ll = ekf_log_likelihood(&p, &theta, &data).expect("fit's pass");
    assert!((ll - total).abs() <= 1e-10 * ll.abs(), "{ll} vs {total}");
}

fn fit_pendulum(seed: u64, len: usize) -> kalman::fit::ParametricFit {
    let p = Pendulum { dt: 0.02 };
    let z = pendulum_record(&p, len, seed);
    let data = Series::new(&z, 1).expect("series");
    filter_error(&p, vec![0.1, 1.2], &[data], &MleOptions::default()).expect("fit")
}

#[test]
fn a_pendulums_damping_and_length_are_recovered_within_their_bounds() {
    let fit = fit_pendulum(21, 600);
    assert!(fit.converged, "{}", fit.message);
    let se = fit.uncertainty.std_errors.clone().expect("standard errors");
    for i in 0..2 {
        let z = (fit.theta[i] - TRUTH[i]) / se[i];
        assert!(
            z.abs() < 4.0,
            "{}: {} ± {} (z = {z})",
            fit.names[i],
            fit.theta[i],
            se[i]
        );
    }
    let corr = fit.uncertainty.correlation.expect("correlation");
    assert!((corr[(0, 1)] - corr[(1, 0)]).abs() < 1e-15 && corr[(0, 1)].abs() < 1.0);
}

#[test]
fn the_bounds_cover_at_their_rate() {
    // 60 records × 2 parameters: 120 intervals, 95 % each. The count of covering ones is
    // binomial(120, 0.95) (mean 114, sd 2.4) if the bounds are honest; the band 104–120
    // (86.7–100 %) is the mean minus four sd, and above it (the EKF's bias would show as
    // undercoverage, not over). The normalised errors' RMS must be near 1 (0.7–1.4: the
    // RMS of 120 standard normals has sd ≈ 0.065).
    let mut covered = 0;
    let mut sq = 0.0;
    let runs = 60;
    for seed in 0..runs {
        let fit = fit_pendulum(1000 + seed, 300);
        assert!(fit.converged, "seed {seed}: {}", fit.message);
        let se = fit.uncertainty.std_errors.expect("standard errors");
        for i in 0..2 {
            let z = (fit.theta[i] - TRUTH[i]) / se[i];
            sq += z * z;
            if z.abs() <= 1.959_964 {
                covered += 1;
            }
        }
    }
    let rms = (sq / (2 * runs) as f64).sqrt();
    assert!(
        (104..=120).contains(&covered),
        "{covered} of 120 intervals cover"
    );
    assert!((0.7..=1.4).contains(&rms), "RMS normalised error {rms}");
}

#[test]
fn bad_input_is_named() {
    let p = Pendulum { dt: 0.02 };
    let z = pendulum_record(&p, 50, 1);
    let data = Series::new(&z, 1).expect("series");
    let e = ekf_log_likelihood(&p, &[0.1], &data).expect_err("short θ");
    assert!(
        matches!(e, FitError::Parameters(ref s) if s.contains("2 parameters")),
        "{e}"
    );
    let e = ekf_log_likelihood(&p, &[f64::NAN, 1.0], &data).expect_err("NaN θ");
    assert!(e.to_string().contains("damping"), "{e}");
    let two = Series::new(&[1.0, 2.0, 3.0, 4.0], 2).expect("two rows");
    let e = ekf_log_likelihood(&p, &TRUTH, &two).expect_err("m = 2");
    assert!(matches!(e, FitError::Data(_)), "{e}");
    let e = filter_error(&p, TRUTH.to_vec(), &[], &MleOptions::default()).expect_err("none");
    assert!(matches!(e, FitError::Data(_)), "{e}");
    // A length of zero divides by zero in f: the state is infinite after the first step.
    let e = ekf_log_likelihood(&p, &[0.1, 0.0], &data).expect_err("L = 0");
    assert!(matches!(e, FitError::Diverged { step: 0, .. }), "{e}");
}

/// A model whose innovation covariance is zero at the first step: no prior spread, no
/// measurement noise.
struct Exact;

impl ParametricModel for Exact {
    fn dims(&self) -> (usize, usize, usize) {
        (1, 1, 1)
    }
    fn f<T: Scalar>(&self, th: &[T], x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        out[0] = th[0] * x[0];
    }
    fn h<T: Scalar>(&self, _th: &[T], x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0];
    }
    fn q<T: Scalar>(&self, _th: &[T], _k: usize, out: &mut [T]) {
        out[0] = T::from(1.0);
    }
    fn r<T: Scalar>(&self, _th: &[T], _k: usize, out: &mut [T]) {
        out[0] = T::from(0.0);
    }
    fn x0<T: Scalar>(&self, _th: &[T], out: &mut [T]) {
        out[0] = T::from(0.0);
    }
    fn p0<T: Scalar>(&self, _th: &[T], out: &mut [T]) {
        out[0] = T::from(0.0);
    }
}

#[test]
fn a_singular_innovation_is_an_error_at_its_step() {
    let data = Series::new(&[0.5, 1.0], 1).expect("series");
    let e = ekf_log_likelihood(&Exact, &[0.9], &data).expect_err("Σ = 0");
    assert_eq!(
        e,
        FitError::NotPositiveDefinite {
            name: "innovation covariance",
            step: 0
        }
    );
}
