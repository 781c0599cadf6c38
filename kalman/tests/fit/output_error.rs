//! Output-error maximum likelihood (`kalman::fit::output_error`): the AD gradient against
//! central differences, a linear model against closed-form weighted least squares, a
//! nonlinear model's Monte Carlo calibration, R re-estimation, and the typed errors.

use kalman::DynDims;
use kalman::faer::Mat;
use kalman::fit::{FitError, OutputErrorFit, OutputErrorOptions, output_error, output_error_cost};
use kalman::nonlinear::{GenericModel, Scalar};
use nalgebra::{DMatrix, DVector};
use rand::RngExt;
use rand_distr::StandardNormal;

use super::common::{binomial_band, rng};
use super::pendulum::{Pendulum, START, TRUTH, torque};

const STEPS: usize = 200;

fn dims4() -> DynDims {
    DynDims::new(4, 2, 1).expect("valid dims")
}

/// The pendulum at Δt = 0.05 s with the sensors' true noise variances.
fn pendulum() -> Pendulum {
    Pendulum {
        dt: 0.05,
        r: [4e-4, 2.5e-3],
    }
}

/// The output-error fit of `model` from `x0`, all four initial-state entries free.
fn fit_all(
    model: &Pendulum,
    x0: &[f64],
    z: &Mat<f64>,
    u: &Mat<f64>,
    options: &OutputErrorOptions,
) -> OutputErrorFit {
    output_error(
        model,
        dims4(),
        x0,
        &[0, 1, 2, 3],
        z.as_ref(),
        Some(u.as_ref()),
        options,
    )
    .expect("fit")
}

/// The noise-free outputs of `model` from `x0` with inputs `u` (N×m).
pub fn outputs<G: GenericModel>(model: &G, x0: &[f64], u: &Mat<f64>, m: usize) -> Mat<f64> {
    let steps = u.nrows();
    let mut x = x0.to_vec();
    let mut next = x.clone();
    let mut y = vec![0.0; m];
    let mut out = Mat::zeros(steps, m);
    for k in 0..steps {
        model.h::<f64>(&x, k, &mut y);
        for i in 0..m {
            out[(k, i)] = y[i];
        }
        let uk: Vec<f64> = (0..u.ncols()).map(|j| u[(k, j)]).collect();
        model.f::<f64>(&x, Some(&uk), k, &mut next);
        std::mem::swap(&mut x, &mut next);
    }
    out
}

/// Outputs plus white noise of standard deviations `sd`.
fn noisy(y: &Mat<f64>, sd: &[f64], seed: u64) -> Mat<f64> {
    let mut g = rng(seed);
    let mut z = y.clone();
    for k in 0..y.nrows() {
        for i in 0..y.ncols() {
            z[(k, i)] += sd[i] * g.sample::<f64, _>(StandardNormal);
        }
    }
    z
}

#[test]
fn ad_gradient_equals_central_differences() {
    let model = pendulum();
    let u = torque(STEPS, model.dt);
    let z = noisy(&outputs(&model, &TRUTH, &u, 2), &[0.02, 0.05], 7);
    let free = [0, 1, 2, 3];
    // Away from the optimum, where the gradient is large and curvature matters.
    let at = START;
    let c =
        output_error_cost(&model, dims4(), &at, &free, z.as_ref(), Some(u.as_ref())).expect("cost");
    let cost = |x: &[f64]| {
        output_error_cost(&model, dims4(), x, &free, z.as_ref(), Some(u.as_ref()))
            .expect("cost")
            .cost
    };
    let gmax = c.gradient.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    for j in 0..4 {
        // h = 1e-5: the difference's round-off is about ε·J/h = 2.2e-16 · J / 1e-5 and its
        // truncation h²·J'''/6; with J ≈ 1e4 here and J''' of the order of J'' ≈ 1e5 (the
        // information), both are below 1e-3 while the gradient entries are ≈ 1e3–1e5, so
        // a relative agreement of 1e-6 of the largest entry is 10³ above the error budget
        // and 10⁻⁶ below any mistake in a sensitivity.
        let h = 1e-5;
        let mut xp = at;
        let mut xm = at;
        xp[j] += h;
        xm[j] -= h;
        let cd = (cost(&xp) - cost(&xm)) / (2.0 * h);
        assert!(
            (c.gradient[j] - cd).abs() <= 1e-6 * gmax,
            "∂J/∂θ_{j}: AD {} vs central difference {cd} (largest entry {gmax})",
            c.gradient[j]
        );
    }
    // The information is the Gauss–Newton matrix: symmetric, positive on its diagonal.
    for i in 0..4 {
        assert!(c.information[(i, i)] > 0.0);
        for j in 0..4 {
            assert!((c.information[(i, j)] - c.information[(j, i)]).abs() <= 1e-12 * gmax);
        }
    }
}

/// x_{k+1} = F x_k + B u_k, y_k = H x_k, with a correlated R.
struct Linear;
const F: [[f64; 3]; 3] = [[0.9, 0.2, 0.0], [-0.1, 0.8, 0.1], [0.0, 0.0, 1.0]];
const H: [[f64; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]];
const B: [f64; 3] = [0.0, 0.1, 0.0];
/// R = [[1, 0.3], [0.3, 0.5]].
const R: [[f64; 2]; 2] = [[1.0, 0.3], [0.3, 0.5]];

impl GenericModel for Linear {
    fn f<T: Scalar>(&self, x: &[T], u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        let u = u.map_or(0.0, |u| u[0]);
        for i in 0..3 {
            out[i] = x[0] * F[i][0] + x[1] * F[i][1] + x[2] * F[i][2] + B[i] * u;
        }
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        for i in 0..2 {
            out[i] = x[0] * H[i][0] + x[1] * H[i][1] + x[2] * H[i][2];
        }
    }
    fn q(&self, _k: usize, out: &mut [f64]) {
        out.fill(0.0);
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&[R[0][0], R[1][0], R[0][1], R[1][1]]);
    }
}

#[test]
fn linear_model_equals_weighted_least_squares() {
    let steps = 40;
    let truth = [1.0, 0.7, -0.4];
    let u = Mat::from_fn(steps, 1, |k, _| (0.3 * k as f64).cos());
    let mut z = noisy(&outputs(&Linear, &truth, &u, 2), &[1.0, 0.7], 11);
    // Some entries not sampled: every fifth step misses channel 0, every seventh channel 1.
    for k in 0..steps {
        if k % 5 == 2 {
            z[(k, 0)] = f64::NAN;
        }
        if k % 7 == 3 {
            z[(k, 1)] = f64::NAN;
        }
    }
    // x0[1] is known (0.7); x0[0] and x0[2] are free, started far away.
    let free = [0, 2];
    let start = [10.0, 0.7, 5.0];
    let fit = output_error(
        &Linear,
        DynDims::new(3, 2, 1).expect("dims"),
        &start,
        &free,
        z.as_ref(),
        Some(u.as_ref()),
        &OutputErrorOptions::default(),
    )
    .expect("fit");
    assert!(fit.converged);
    // Independently: y_k = H F^k x0 + Σ_{j<k} H F^{k−1−j} B u_j. Φ_k = (H F^k) on the free
    // columns; the known part (the x0[1] column and the forced response) moves to z.
    let f = DMatrix::from_fn(3, 3, |i, j| F[i][j]);
    let h = DMatrix::from_fn(2, 3, |i, j| H[i][j]);
    let b = DVector::from_fn(3, |i, _| B[i]);
    let r = DMatrix::from_fn(2, 2, |i, j| R[i][j]);
    let mut power = DMatrix::<f64>::identity(3, 3); // F^k
    let mut forced = DVector::<f64>::zeros(3); // Σ_{j<k} F^{k−1−j} B u_j
    let mut info = DMatrix::<f64>::zeros(2, 2);
    let mut rhs = DVector::<f64>::zeros(2);
    for k in 0..steps {
        let hp = &h * &power;
        let obs: Vec<usize> = (0..2).filter(|&i| !z[(k, i)].is_nan()).collect();
        if !obs.is_empty() {
            let phi = DMatrix::from_fn(obs.len(), 2, |r, c| hp[(obs[r], free[c])]);
            let known = hp.column(1) * start[1] + &h * &forced;
            let zt = DVector::from_fn(obs.len(), |r, _| z[(k, obs[r])] - known[obs[r]]);
            let roo = DMatrix::from_fn(obs.len(), obs.len(), |a, c| r[(obs[a], obs[c])]);
            let w = roo.try_inverse().expect("R block invertible");
            info += phi.transpose() * &w * &phi;
            rhs += phi.transpose() * &w * zt;
        }
        forced = &f * forced + &b * u[(k, 0)];
        power = &f * power;
    }
    let cov = info.clone().try_inverse().expect("ΦᵀR⁻¹Φ invertible");
    let wls = &cov * rhs;
    for c in 0..2 {
        // One Gauss–Newton step solves the normal equations; the two computations differ by
        // the round-off of sums of 40 steps' products (cond(ΦᵀR⁻¹Φ) ≈ 10²): 1e-9 of a
        // standard error leaves room for that and nothing else.
        let se = cov[(c, c)].sqrt();
        assert!(
            (fit.estimate[c] - wls[c]).abs() <= 1e-9 * se,
            "θ_{c}: output error {} vs WLS {} (se {se})",
            fit.estimate[c],
            wls[c]
        );
        for d in 0..2 {
            assert!(
                (fit.covariance[(c, d)] - cov[(c, d)]).abs()
                    <= 1e-10 * cov[(c, c)].max(cov[(d, d)]),
                "covariance ({c}, {d}): {} vs {}",
                fit.covariance[(c, d)],
                cov[(c, d)]
            );
        }
    }
    assert!(
        (fit.covariance[(0, 1)] - fit.covariance[(1, 0)]).abs() <= 0.0,
        "the covariance is symmetric"
    );
    assert!(
        (fit.x0[1] - 0.7).abs() <= 0.0,
        "the fixed entry is untouched"
    );
    // 8 steps miss channel 0, 6 miss channel 1.
    assert_eq!(fit.n_obs, 2 * steps - 8 - 6);
}

/// Fits `records` noisy pendulum records; returns the normalised errors (θ̂ − θ)/σ̂ by
/// parameter and the 1.96σ̂ coverage counts.
fn pendulum_monte_carlo(records: usize) -> (Vec<Vec<f64>>, Vec<usize>) {
    let model = pendulum();
    let u = torque(STEPS, model.dt);
    let y = outputs(&model, &TRUTH, &u, 2);
    let mut normalised: Vec<Vec<f64>> = (0..4).map(|_| Vec::with_capacity(records)).collect();
    let mut covered = vec![0; 4];
    for run in 0..records {
        let z = noisy(&y, &[0.02, 0.05], 1000 + run as u64);
        let fit = fit_all(&model, &START, &z, &u, &OutputErrorOptions::default());
        assert!(fit.converged, "run {run} did not converge");
        for j in 0..4 {
            let e = (fit.estimate[j] - TRUTH[j]) / fit.std[j];
            normalised[j].push(e);
            covered[j] += usize::from(e.abs() <= 1.959_964);
        }
    }
    (normalised, covered)
}

#[test]
fn nonlinear_bounds_are_calibrated() {
    let records = 100;
    let (normalised, covered) = pendulum_monte_carlo(records);
    // Σ e² over 100 records is χ²(100) when the bounds are right: its central 99.9 % band
    // is [χ²_{0.0005}, χ²_{0.9995}] = [63.1, 149.4], so the RMS lies in [0.79, 1.22].
    let lo = (kalman::chi2_quantile(0.0005, records) / records as f64).sqrt();
    let hi = (kalman::chi2_quantile(0.9995, records) / records as f64).sqrt();
    let (clo, chi) = binomial_band(records, 0.95);
    for j in 0..4 {
        let rms = (normalised[j].iter().map(|e| e * e).sum::<f64>() / records as f64).sqrt();
        eprintln!(
            "parameter {j}: RMS {rms:.3}, 95 % coverage {}/{records}",
            covered[j]
        );
        assert!(
            (lo..=hi).contains(&rms),
            "parameter {j}: RMS of the normalised errors {rms:.3} outside [{lo:.3}, {hi:.3}]"
        );
        assert!(
            (clo..=chi).contains(&covered[j]),
            "parameter {j}: 95 % intervals cover {} of {records}, band [{clo}, {chi}]",
            covered[j]
        );
    }
}

#[test]
fn estimate_r_recovers_the_noise_variance() {
    // The model's R is wrong by 100× on one channel and 1/100 on the other; estimated from
    // the residuals it comes back to the truth. A mean of N squared normals has relative
    // standard deviation √(2/N) = 3.2 % at N = 2000; the ML estimate is low by p/N of the
    // 4 parameters (0.1 %, negligible), so 4√(2/N) bounds it.
    let steps = 2000;
    let model = Pendulum {
        dt: 0.05,
        r: [4e-2, 2.5e-5],
    };
    let u = torque(steps, model.dt);
    let sd = [0.02, 0.05];
    let z = noisy(&outputs(&model, &TRUTH, &u, 2), &sd, 5);
    let options = OutputErrorOptions {
        estimate_r: true,
        ..OutputErrorOptions::default()
    };
    let fit = fit_all(&model, &START, &z, &u, &options);
    assert!(fit.converged);
    let band = 4.0 * (2.0 / steps as f64).sqrt();
    for i in 0..2 {
        let ratio = fit.r[i] / (sd[i] * sd[i]);
        assert!(
            (ratio - 1.0).abs() <= band,
            "R[{i},{i}] / σ² = {ratio:.4}, band ±{band:.4}"
        );
    }
    // With R estimated, J = ½ Σ e²/R̂ = ½ n_obs exactly (R̂ is the residuals' mean square).
    assert!((fit.cost - 0.5 * fit.n_obs as f64).abs() <= 1e-9 * fit.cost);
    for j in 0..4 {
        assert!(((fit.estimate[j] - TRUTH[j]) / fit.std[j]).abs() < 4.0);
    }
}

/// `x_{k+1} = a·x_k`, `y_k = (x_k[0] + c·x_k[1], x_k[1])` with `c` chosen by the test.
struct Scaled {
    a: f64,
    c: f64,
    r01: f64,
}

impl GenericModel for Scaled {
    fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        out[0] = x[0] * self.a;
        out[1] = x[1] * self.a;
        out[2] = x[2];
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0] + x[1] * self.c;
        out[1] = x[1] * 0.0 + x[0] * 0.0;
    }
    fn q(&self, _k: usize, out: &mut [f64]) {
        out.fill(0.0);
    }
    fn r(&self, k: usize, out: &mut [f64]) {
        // Indefinite at step 3 when r01 > 1.
        let off = if k == 3 { self.r01 } else { 0.0 };
        out.copy_from_slice(&[1.0, off, off, 1.0]);
    }
}

/// The name, rows and columns of `e` if it is the model's shape error.
fn shape_of(e: &FitError) -> Option<(&'static str, usize, usize)> {
    match e {
        FitError::Model(kalman::Error::Shape {
            name, rows, cols, ..
        }) => Some((*name, *rows, *cols)),
        _ => None,
    }
}

#[test]
fn output_error_errors_name_what_is_wrong() {
    let ok = Scaled {
        a: 0.9,
        c: 2.0,
        r01: 0.0,
    };
    let dims = DynDims::new(3, 2, 0).expect("dims");
    let z = Mat::from_fn(6, 2, |k, i| (k + i) as f64 * 0.1);
    let o = OutputErrorOptions::default();
    let fit = |m: &Scaled, x0: &[f64], free: &[usize], z: &Mat<f64>, u: Option<&Mat<f64>>| {
        output_error(m, dims, x0, free, z.as_ref(), u.map(|u| u.as_ref()), &o)
    };
    // Shapes of x0, z and u against the dimensions.
    let e = fit(&ok, &[1.0, 0.0], &[0], &z, None).expect_err("refused");
    assert!(matches!(shape_of(&e), Some(("x0", 2, _))), "{e}");
    let e = fit(&ok, &[1.0, 0.0, 0.0], &[0], &Mat::zeros(6, 3), None).expect_err("refused");
    assert!(matches!(shape_of(&e), Some(("z", _, 3))), "{e}");
    let e = fit(&ok, &[1.0, 0.0, 0.0], &[0], &z, Some(&Mat::zeros(6, 1))).expect_err("refused");
    assert!(matches!(shape_of(&e), Some(("u", _, _))), "{e}");
    let e = output_error(
        &ok,
        DynDims::new(3, 2, 1).expect("dims"),
        &[1.0, 0.0, 0.0],
        &[0],
        z.as_ref(),
        None,
        &o,
    )
    .expect_err("refused");
    assert!(matches!(shape_of(&e), Some(("u", 0, _))), "{e}");
    let e = fit(&ok, &[1.0, f64::NAN, 0.0], &[0], &z, None).expect_err("refused");
    assert!(
        matches!(
            e,
            FitError::Model(kalman::Error::NonFinite {
                name: "x0",
                row: 1,
                ..
            })
        ),
        "{e}"
    );
    // Free indices out of range, repeated, none.
    let e = fit(&ok, &[1.0, 0.0, 0.0], &[0, 3], &z, None).expect_err("refused");
    assert!(
        matches!(&e, FitError::Parameters(s) if s.contains("free index 3") && s.contains("n = 3")),
        "{e}"
    );
    let e = fit(&ok, &[1.0, 0.0, 0.0], &[1, 0, 1], &z, None).expect_err("refused");
    assert!(
        matches!(&e, FitError::Parameters(s) if s.contains("free index 1 is repeated")),
        "{e}"
    );
    assert_eq!(
        fit(&ok, &[1.0, 0.0, 0.0], &[], &z, None).expect_err("refused"),
        FitError::NothingFree
    );
    // A record with no finite measurement; an infinite one.
    let e = fit(
        &ok,
        &[1.0, 0.0, 0.0],
        &[0],
        &Mat::from_fn(6, 2, |_, _| f64::NAN),
        None,
    )
    .expect_err("refused");
    assert_eq!(e, FitError::NoMeasurements);
    let mut zi = z.clone();
    zi[(4, 1)] = f64::INFINITY;
    let e = fit(&ok, &[1.0, 0.0, 0.0], &[0], &zi, None).expect_err("refused");
    assert!(
        matches!(&e, FitError::Data(s) if s.contains("step 4, row 1")),
        "{e}"
    );
    // R_3 indefinite on the rows observed at step 3.
    let bad_r = Scaled { r01: 2.0, ..ok };
    let e = fit(&bad_r, &[1.0, 0.0, 0.0], &[0], &z, None).expect_err("refused");
    assert_eq!(e, FitError::NotPositiveDefinite { name: "R", step: 3 });
    // With channel 1 missing at step 3 the block is [1]: no error.
    let mut zm = z.clone();
    zm[(3, 1)] = f64::NAN;
    assert!(fit(&bad_r, &[1.0, 0.0, 0.0], &[0], &zm, None).is_ok());
    // A diverging integration: x_{k+1} = 1e100 x_k from 1 overflows at the prediction of
    // step 3 (x_3 = 1e300 is finite, x_4 = 1e300 · 1e100 is not).
    let wild = Scaled { a: 1e100, ..ok };
    let e = fit(&wild, &[1.0, 1.0, 0.0], &[0], &z, None).expect_err("refused");
    assert!(
        matches!(
            e,
            FitError::Model(kalman::Error::Diverged {
                step: 3,
                what: "the predicted state f(x_k, u_k, k)",
                ..
            })
        ),
        "{e}"
    );
    // Not identified: y depends on x0[0] + 2·x0[1] only (channel 1 is blind), and x0[2] on
    // nothing at all.
    let e = fit(&ok, &[1.0, 0.0, 0.0], &[0, 1], &z, None).expect_err("refused");
    match &e {
        FitError::NotIdentifiable { what, why } => {
            assert_eq!(what, "x0[0], x0[1]", "{e}");
            assert!(why.contains("Fisher information is singular"), "{e}");
        }
        other => panic!("expected NotIdentifiable, got {other}"),
    }
    let e = fit(&ok, &[1.0, 0.0, 0.0], &[0, 2], &z, None).expect_err("refused");
    assert!(
        matches!(&e, FitError::NotIdentifiable { what, .. } if what == "x0[2]"),
        "{e}"
    );
    // With only x0[0] free the same model fits.
    let f = fit(&ok, &[1.0, 0.0, 0.0], &[0], &z, None).expect("identified");
    assert!(f.converged && f.std[0] > 0.0);
}

#[test]
fn pendulum_agrees_with_scipy_least_squares() {
    // SciPy's MINPACK LM with a complex-step Jacobian on the same model and record
    // (`kalman/tests/golden/make_output_error.py`).
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/golden/output_error_pendulum.json"
    );
    let text = std::fs::read_to_string(path).expect("golden file");
    let g: serde_json::Value = serde_json::from_str(&text).expect("json");
    let vec = |key: &str| -> Vec<f64> {
        g[key]
            .as_array()
            .expect(key)
            .iter()
            .map(|v| v.as_f64().expect("number"))
            .collect()
    };
    let rows = |key: &str| -> Vec<Vec<f64>> {
        g[key]
            .as_array()
            .expect(key)
            .iter()
            .map(|r| {
                r.as_array()
                    .expect("row")
                    .iter()
                    .map(|v| v.as_f64().expect("number"))
                    .collect()
            })
            .collect()
    };
    let r = vec("r");
    let model = Pendulum {
        dt: g["dt"].as_f64().expect("dt"),
        r: [r[0], r[1]],
    };
    let uv = vec("u");
    let zr = rows("z");
    let u = Mat::from_fn(uv.len(), 1, |k, _| uv[k]);
    let z = Mat::from_fn(zr.len(), 2, |k, i| zr[k][i]);
    let start = vec("start");
    let options = OutputErrorOptions {
        tolerance: 1e-10,
        ..OutputErrorOptions::default()
    };
    let fit = fit_all(&model, &start, &z, &u, &options);
    assert!(fit.converged);
    let est = vec("estimate");
    let cov = rows("covariance");
    for j in 0..4 {
        // Both land on the optimum to round-off: measured 1e-13 σ apart (a stopping rule of
        // ours that stopped where J no longer resolved a step, ½d² < 1e-12·J, left up to
        // 9e-7 σ; now such steps are taken and the fit stops at a step below 1e-10 σ).
        // 1e-9 σ leaves 10⁴ for the round-off of the sums elsewhere.
        let se = cov[j][j].sqrt();
        eprintln!(
            "θ_{j}: {:e} σ from SciPy's, σ ratio {:.3e} − 1",
            (fit.estimate[j] - est[j]) / se,
            fit.std[j] / se - 1.0
        );
        assert!(
            (fit.estimate[j] - est[j]).abs() <= 1e-9 * se,
            "θ_{j}: {} vs SciPy {} (σ {se})",
            fit.estimate[j],
            est[j]
        );
        for i in 0..4 {
            // The information at the same optimum from AD and from the complex step, both
            // exact to round-off (the standard errors agree to 2e-15): 1e-9 of the
            // diagonal scale.
            let scale = (cov[i][i] * cov[j][j]).sqrt();
            assert!(
                (fit.covariance[(i, j)] - cov[i][j]).abs() <= 1e-9 * scale,
                "cov ({i}, {j}): {} vs SciPy {}",
                fit.covariance[(i, j)],
                cov[i][j]
            );
        }
    }
    let cost = g["cost"].as_f64().expect("cost");
    assert!(
        (fit.cost - cost).abs() <= 1e-9 * cost,
        "J {} vs SciPy {cost}",
        fit.cost
    );
}
