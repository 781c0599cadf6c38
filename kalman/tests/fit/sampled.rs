//! The noise of a continuous model fitted over a record's own time stamps
//! (`kalman::fit::SampledMap`): its likelihood against a hand-written filter with the
//! closed-form sampling of a constant-velocity model, its AD gradient against central
//! differences, the intensity and the sensor variance recovered within their bounds from an
//! irregular record with a dropout, and its errors.

use kalman::fit::{
    FitError, Matrix, MleOptions, Param, SampledMap, Series, Transform, ekf_log_likelihood,
    ekf_log_likelihood_gradient,
};
use kalman::sampling::ContinuousModel;
use nalgebra::{Matrix2, Vector2};
use rand::RngExt;
use rand_distr::StandardNormal;

use super::common::rng;

/// ẋ = [[0, 1], [0, 0]] x + [0, 1]ᵀ w (white acceleration of intensity q), z = position.
fn cv(r: f64) -> ContinuousModel {
    ContinuousModel::new(
        &[[0.0, 1.0], [0.0, 0.0]],
        &[[1.0, 0.0]],
        &[[0.0, 0.0], [0.0, 1.0]],
        &[[r]],
    )
    .expect("model")
}

/// The constant-velocity model's exact sampling at Δt: F = [[1, Δt], [0, 1]],
/// Q = q [[Δt³/3, Δt²/2], [Δt²/2, Δt]] (the integral of e^{Aτ} G q Gᵀ e^{Aᵀτ} in closed form).
fn closed_form(q: f64, dt: f64) -> (Matrix2<f64>, Matrix2<f64>) {
    (
        Matrix2::new(1.0, dt, 0.0, 1.0),
        q * Matrix2::new(dt.powi(3) / 3.0, dt.powi(2) / 2.0, dt.powi(2) / 2.0, dt),
    )
}

/// Stamps 0.05–0.3 s apart, a 4 s dropout after row 60 and two rows at one instant
/// (row 100 repeats row 99's stamp).
fn stamps(len: usize) -> Vec<f64> {
    let mut t = vec![0.0];
    for k in 1..len {
        let dt = match k {
            61 => 4.0,
            100 => 0.0,
            _ => 0.05 + 0.25 * (0.5 + 0.5 * (1.7 * k as f64).sin()),
        };
        t.push(t[k - 1] + dt);
    }
    t
}

/// A record of the model at the stamps (closed-form sampling, exact noise), from x0 = (0, 2).
fn simulate(t: &[f64], q: f64, r: f64, seed: u64) -> Vec<f64> {
    let mut g = rng(seed);
    let mut x = Vector2::new(0.0, 2.0);
    let mut z = Vec::with_capacity(t.len());
    for k in 0..t.len() {
        z.push(x[0] + r.sqrt() * g.sample::<f64, _>(StandardNormal));
        if let Some(next) = t.get(k + 1) {
            let (F, Q) = closed_form(q, next - t[k]);
            let L = Q.cholesky().map_or(Matrix2::zeros(), |c| c.l());
            let w = Vector2::new(
                g.sample::<f64, _>(StandardNormal),
                g.sample::<f64, _>(StandardNormal),
            );
            x = F * x + L * w;
        }
    }
    z
}

/// The Gaussian log-likelihood of `z` by a filter written out here with the closed form.
fn reference_loglik(t: &[f64], z: &[f64], q: f64, r: f64, p0: f64) -> f64 {
    reference_loglik_sampled(t, z, r, p0, |dt| closed_form(q, dt))
}

/// The same filter of a 2-state model measured in its first state, sampled at each interval
/// Δt by `sample(Δt) = (F, Q)`, from x0 = 0, P0 = p0·I.
fn reference_loglik_sampled(
    t: &[f64],
    z: &[f64],
    r: f64,
    p0: f64,
    sample: impl Fn(f64) -> (Matrix2<f64>, Matrix2<f64>),
) -> f64 {
    let H = nalgebra::RowVector2::new(1.0, 0.0);
    let (mut x, mut P) = (Vector2::new(0.0, 0.0), Matrix2::identity() * p0);
    let mut ll = 0.0;
    for k in 0..t.len() {
        let e = z[k] - (H * x)[0];
        let s = (H * P * H.transpose())[0] + r;
        ll -= 0.5 * (e * e / s + s.ln() + (2.0 * std::f64::consts::PI).ln());
        let K = P * H.transpose() / s;
        x += K * e;
        let IKH = Matrix2::identity() - K * H;
        P = IKH * P * IKH.transpose() + K * K.transpose() * r;
        if let Some(next) = t.get(k + 1) {
            let (F, Q) = sample(next - t[k]);
            x = F * x;
            P = F * P * F.transpose() + Q;
        }
    }
    ll
}

fn free_q_r() -> Vec<Param> {
    vec![Param::entry(Matrix::Q, 1, 1), Param::entry(Matrix::R, 0, 0)]
}

/// The constant-velocity model at the stamps `t`, from x0 = 0, P0 = 10·I, with `params` free.
fn cv_map(t: &[f64], params: Vec<Param>) -> SampledMap {
    SampledMap::new(
        &cv(1.0),
        &[0.0, 0.0],
        &[[10.0, 0.0], [0.0, 10.0]],
        t,
        params,
    )
    .expect("map")
}

/// The exact gradient at `theta` against central differences of the likelihood: step 1e-5
/// in each coordinate, 1e-6 relative (floor 1).
fn assert_gradient_is_the_slope<const N: usize>(map: &SampledMap, theta: [f64; N], data: &Series) {
    let (_, grad) = ekf_log_likelihood_gradient(map, &theta, data).expect("gradient");
    for j in 0..N {
        let h = 1e-5;
        let (mut up, mut down) = (theta, theta);
        up[j] += h;
        down[j] -= h;
        let fd = (ekf_log_likelihood(map, &up, data).expect("ll")
            - ekf_log_likelihood(map, &down, data).expect("ll"))
            / (2.0 * h);
        assert!(
            (grad[j] - fd).abs() <= 1e-6 * grad[j].abs().max(1.0),
            "θ{j}: {} vs {fd}",
            grad[j]
        );
    }
}

/// The map's likelihood is the closed-form filter's: the Van Loan blocks, their linear
/// combination in q and the filter pass all agree with an implementation that shares none of
/// them. Tolerance 1e-9 relative: both sum ~300 terms of order 1 whose inputs agree to a
/// few ulps (the exponential of a nilpotent generator is exact to round-off).
#[test]
fn the_likelihood_is_the_closed_form_filters_over_irregular_stamps() {
    let t = stamps(300);
    let z = simulate(&t, 0.5, 0.04, 3);
    let map = cv_map(&t, free_q_r());
    assert_eq!(map.len(), 300);
    assert!(
        map.distinct_intervals() < 300,
        "the repeated sine clock shares intervals"
    );
    let data = Series::new(&z, 1).expect("series");
    for (q, r) in [(0.5_f64, 0.04_f64), (2.0, 0.3), (0.01, 1.0)] {
        let theta = [q.ln(), r.ln()];
        let got = ekf_log_likelihood(&map, &theta, &data).expect("loglik");
        let want = reference_loglik(&t, &z, q, r, 10.0);
        assert!(
            (got - want).abs() <= 1e-9 * want.abs(),
            "q {q}, r {r}: {got} vs {want}"
        );
    }
}

/// The exact gradient against central differences of the likelihood: step 1e-5 in ln q, ln r
/// leaves a truncation error ~1e-10·|∂³ ln L| and a rounding error ~1e-16·|ln L|/1e-5; 1e-6
/// relative holds both.
#[test]
fn the_gradient_is_the_likelihoods_slope() {
    let t = stamps(120);
    let z = simulate(&t, 0.5, 0.04, 4);
    let map = cv_map(&t, free_q_r());
    let data = Series::new(&z, 1).expect("series");
    let theta = [0.2, -2.0];
    assert_gradient_is_the_slope(&map, theta, &data);
}

/// From a 600-row irregular record with a dropout, q and R come back within three of their
/// Cramér–Rao standard errors (a fixed seed: this fails only if the fit is biased or its
/// bounds too tight), and the fitted matrices carry the estimates into Q_c and R.
#[test]
fn the_intensity_and_the_sensor_variance_are_recovered() {
    let t = stamps(600);
    let (q, r) = (0.5, 0.04);
    let z = simulate(&t, q, r, 5);
    let map = cv_map(&t, free_q_r());
    let fit = map
        .fit(&Series::new(&z, 1).expect("series"), &MleOptions::default())
        .expect("fit");
    assert!(fit.converged, "{}", fit.message);
    let se = fit.uncertainty.std_errors.as_ref().expect("bounds");
    for (j, truth) in [(0, q), (1, r)] {
        let err = fit.theta[j] - f64::ln(truth);
        assert!(
            err.abs() < 3.0 * se[j],
            "{}: ln estimate {} vs ln truth {}, σ {}",
            fit.names[j],
            fit.theta[j],
            f64::ln(truth),
            se[j]
        );
    }
    let fitted = map.matrices(&fit.theta).expect("matrices");
    let (Qc, R) = (fitted.w, fitted.r);
    let values = map.values(&fit.theta).expect("values");
    assert_eq!(values[0].0, "Q[1,1]");
    // The same value written, not recomputed: bit-equal.
    assert_eq!(Qc[(1, 1)].to_bits(), values[0].1.to_bits());
    assert_eq!(
        Qc[(0, 0)].to_bits(),
        0f64.to_bits(),
        "a cell not freed keeps the base value"
    );
    assert_eq!(R[(0, 0)].to_bits(), values[1].1.to_bits());
}

/// The noise through an input matrix G: one shared parameter for a 2-D target's two axes
/// (Q_c = q·I₂ entering the velocities) gives the 1-D closed form on each axis, so its
/// likelihood is the sum of the two axes' closed-form likelihoods.
#[test]
fn a_shared_intensity_through_a_noise_input_is_the_sum_of_its_axes() {
    let t = stamps(150);
    let (zx, zy) = (simulate(&t, 0.5, 0.04, 6), simulate(&t, 0.5, 0.04, 7));
    let A = [
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
        [0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0],
    ];
    let H = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]];
    let model =
        ContinuousModel::new(&A, &H, &[[0.0; 4]; 4], &[[0.04, 0.0], [0.0, 0.04]]).expect("model");
    let G = [[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    let q = Param::shared("q", Transform::Log)
        .with(Matrix::Q, 0, 0, 1.0)
        .with(Matrix::Q, 1, 1, 1.0);
    let mut P0 = [[0.0; 4]; 4];
    (0..4).for_each(|i| P0[i][i] = 10.0);
    let map = SampledMap::with_noise_input(
        &model,
        &G,
        &[[1.0, 0.0], [0.0, 1.0]],
        &[0.0; 4],
        &P0,
        &t,
        vec![q],
    )
    .expect("map");
    let z: Vec<f64> = zx.iter().zip(&zy).flat_map(|(a, b)| [*a, *b]).collect();
    let got = ekf_log_likelihood(&map, &[0.3_f64.ln()], &Series::new(&z, 2).expect("series"))
        .expect("loglik");
    let want =
        reference_loglik(&t, &zx, 0.3, 0.04, 10.0) + reference_loglik(&t, &zy, 0.3, 0.04, 10.0);
    assert!((got - want).abs() <= 1e-9 * want.abs(), "{got} vs {want}");
}

/// Bad parameters, stamps and records are typed errors naming what is wrong.
#[test]
fn bad_parameters_stamps_and_records_are_named() {
    let t = stamps(20);
    let P0 = [[1.0, 0.0], [0.0, 1.0]];
    let err = |params: Vec<Param>, t: &[f64]| {
        SampledMap::new(&cv(1.0), &[0.0, 0.0], &P0, t, params).expect_err("refused")
    };
    // One free entry refused with a message containing `says`.
    let refused = |param: Param, says: &str| {
        let e = err(vec![param], &t);
        assert!(
            matches!(&e, FitError::Parameters(m) if m.contains(says)),
            "{e}"
        );
    };
    refused(Param::entry(Matrix::H, 0, 1), "H is fixed");
    refused(Param::entry(Matrix::F, 2, 0), "outside");
    refused(Param::entry(Matrix::R, 1, 1), "outside");
    let e = err(vec![Param::entry(Matrix::Q, 0, 0)], &t);
    assert!(
        matches!(&e, FitError::Parameters(m) if m.contains("cannot be reached")),
        "a zero base variance under the log: {e}"
    );
    let mut back = t.clone();
    back[7] = back[5];
    let e = err(free_q_r(), &back);
    assert!(
        matches!(&e, FitError::Data(m) if m.contains("goes back at row 7")),
        "{e}"
    );
    let mut nan = t.clone();
    nan[3] = f64::NAN;
    let e = err(free_q_r(), &nan);
    assert!(
        matches!(&e, FitError::Data(m) if m.contains("row 3")),
        "{e}"
    );
    let map = SampledMap::new(&cv(1.0), &[0.0, 0.0], &P0, &t, free_q_r()).expect("map");
    let short = vec![0.0; 19];
    let e = map
        .fit(
            &Series::new(&short, 1).expect("series"),
            &MleOptions::default(),
        )
        .expect_err("length");
    assert!(
        matches!(&e, FitError::Data(m) if m.contains("19 rows")),
        "{e}"
    );
}

/// ẋ = a x + w (intensity q), z = x + v: F = e^{aΔt}, Q = q (e^{2aΔt} − 1)/(2a).
fn ou_reference(t: &[f64], z: &[f64], a: f64, q: f64, r: f64) -> f64 {
    let (mut x, mut p) = (0.0, 4.0);
    let mut ll = 0.0;
    for k in 0..t.len() {
        let e = z[k] - x;
        let s = p + r;
        ll -= 0.5 * (e * e / s + s.ln() + (2.0 * std::f64::consts::PI).ln());
        let g = p / s;
        x += g * e;
        p = (1.0 - g) * p * (1.0 - g) + g * g * r;
        if let Some(next) = t.get(k + 1) {
            let dt = next - t[k];
            let f = (a * dt).exp();
            x *= f;
            p = f * p * f + q * ((2.0 * a * dt).exp() - 1.0) / (2.0 * a);
        }
    }
    ll
}

fn ou_record(t: &[f64], a: f64, q: f64, r: f64, seed: u64) -> Vec<f64> {
    let mut g = rng(seed);
    let mut x = 0.0;
    let mut z = Vec::with_capacity(t.len());
    for k in 0..t.len() {
        z.push(x + r.sqrt() * g.sample::<f64, _>(StandardNormal));
        if let Some(next) = t.get(k + 1) {
            let dt = next - t[k];
            let var = q * ((2.0 * a * dt).exp() - 1.0) / (2.0 * a);
            x = (a * dt).exp() * x + var.sqrt() * g.sample::<f64, _>(StandardNormal);
        }
    }
    z
}

/// A free entry of the drift A (addressed as `Matrix::F`): every interval sampled at θ
/// through the exponential over dual numbers. The likelihood is the closed-form
/// Ornstein–Uhlenbeck filter's (1e-9 relative, as above), the AD gradient its central
/// difference, and (a, q, R) come back within three standard errors from 500 rows.
#[test]
fn a_drift_entry_is_fitted_through_the_exponential() {
    let t = stamps(500);
    let (a, q, r) = (-0.8, 1.5, 0.05);
    let z = ou_record(&t, a, q, r, 8);
    let model = ContinuousModel::new(&[[-0.3]], &[[1.0]], &[[1.0]], &[[0.1]]).expect("model");
    let params = vec![
        Param::entry(Matrix::F, 0, 0),
        Param::entry(Matrix::Q, 0, 0),
        Param::entry(Matrix::R, 0, 0),
    ];
    let map = SampledMap::new(&model, &[0.0], &[[4.0]], &t, params).expect("map");
    let data = Series::new(&z, 1).expect("series");
    for (aa, qq, rr) in [(a, q, r), (-0.2_f64, 0.4_f64, 0.3_f64)] {
        let theta = [aa, qq.ln(), rr.ln()];
        let got = ekf_log_likelihood(&map, &theta, &data).expect("loglik");
        let want = ou_reference(&t, &z, aa, qq, rr);
        assert!(
            (got - want).abs() <= 1e-9 * want.abs(),
            "a {aa}: {got} vs {want}"
        );
    }
    let theta = [-0.5, 0.2, -2.0];
    assert_gradient_is_the_slope(&map, theta, &data);
    let fit = map.fit(&data, &MleOptions::default()).expect("fit");
    assert!(fit.converged, "{}", fit.message);
    let se = fit.uncertainty.std_errors.as_ref().expect("bounds");
    for (j, truth) in [(0, a), (1, q.ln()), (2, r.ln())] {
        assert!(
            (fit.theta[j] - truth).abs() < 3.0 * se[j],
            "{}: {} vs {truth} ± {}",
            fit.names[j],
            fit.theta[j],
            se[j]
        );
    }
    assert!((map.matrices(&fit.theta).expect("m").a[(0, 0)] - fit.theta[0]).abs() < 1e-15);
}

/// A 2-state drift entry: A = [[0, c], [0, 0]] with c free, so F = [[1, cΔt], [0, 1]] and
/// Q = q [[c²Δt³/3, cΔt²/2], [cΔt²/2, Δt]]; the likelihood at c = 1.3 is that closed form's
/// filter (1e-9 relative), which checks the transposes inside the Van Loan block.
#[test]
fn a_two_state_drift_entry_matches_its_closed_form() {
    let t = stamps(200);
    let z = simulate(&t, 0.5, 0.04, 9);
    let (c, q, r) = (1.3_f64, 0.7_f64, 0.05_f64);
    let params = vec![
        Param::entry(Matrix::F, 0, 1),
        Param::entry(Matrix::Q, 1, 1),
        Param::entry(Matrix::R, 0, 0),
    ];
    let map = cv_map(&t, params);
    let got = ekf_log_likelihood(&map, &[c, q.ln(), r.ln()], &Series::new(&z, 1).expect("z"))
        .expect("loglik");
    // The closed form with c: the position is c times the integrated velocity.
    let want = reference_loglik_sampled(&t, &z, r, 10.0, |dt| {
        let F = Matrix2::new(1.0, c * dt, 0.0, 1.0);
        let Q = q * Matrix2::new(
            c * c * dt.powi(3) / 3.0,
            c * dt.powi(2) / 2.0,
            c * dt.powi(2) / 2.0,
            dt,
        );
        (F, Q)
    });
    assert!((got - want).abs() <= 1e-9 * want.abs(), "{got} vs {want}");
}
