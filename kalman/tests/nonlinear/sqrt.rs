//! The square-root UKF: equal to the plain UKF to round-off where both run (range–bearing
//! tracker and pendulum, every sigma-point set, both storage paths), running where the plain
//! one fails its factorisation (badly scaled states, a measurement noise near zero) and
//! agreeing there with the closed-form scalar filters, and a typed error where a negative
//! centre weight makes the covariance indefinite; and the unscented RTS smoother in
//! square-root form over either filter, equal to the covariance form.

use kalman::nonlinear::{FnModel, NlDims, NonlinearRts, SigmaPoints, SqrtUkf, Ukf};
use kalman::{DynDims, Error, FixedDims};

use super::models::{RangeBearing, RangeBearingHand};

fn flat(m: faer::MatRef<'_, f64>) -> Vec<f64> {
    (0..m.ncols())
        .flat_map(|j| (0..m.nrows()).map(move |i| m[(i, j)]))
        .collect()
}

/// Measurement k of the 60-step range–bearing track (the target moves by (−1, 1.5) a step
/// from (60, −40); deterministic errors; every fifth bearing missing).
fn radar(k: usize) -> [f64; 2] {
    let (px, py) = (59.0 - k as f64, -38.5 + 1.5 * k as f64);
    let bearing = if k % 5 == 3 {
        f64::NAN
    } else {
        py.atan2(px) + 0.004 * ((k * 7 % 5) as f64 - 2.0)
    };
    [px.hypot(py) + 0.3 * ((k * 3 % 7) as f64 - 3.0), bearing]
}

/// Both filters over the same 60 range–bearing measurements (every fifth bearing missing):
/// x, P and NIS at every step. The two forms do the same statistical linearisation by
/// different arithmetic (a Joseph form through G = L⁻¹C against one Householder
/// triangularisation); over 60 steps of O(10²) states their round-off stays below 1e-11
/// of each quantity's scale (the plain UKF's own agreement with FilterPy is 1e-9).
fn agree<D: NlDims>(d: D, set: SigmaPoints) {
    let (x0, p0) = (RangeBearing::x0(), RangeBearing::p0());
    let mut plain = Ukf::new(d, RangeBearingHand::default(), &x0, &p0, set).expect("ukf");
    let mut sqrt = SqrtUkf::new(d, RangeBearingHand::default(), &x0, &p0, set).expect("sqrt");
    for k in 0..60 {
        let z = radar(k);
        let a = plain.step(&z, None).expect("plain step");
        let b = sqrt.step(&z, None).expect("square-root step");
        for (got, want, what) in [
            (sqrt.state().to_vec(), plain.state().to_vec(), "x_{k|k}"),
            (flat(sqrt.covariance()), flat(plain.covariance()), "P_{k|k}"),
            (
                flat(sqrt.predicted_covariance()),
                flat(plain.predicted_covariance()),
                "P_{k+1|k}",
            ),
        ] {
            let scale = want.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    (g - w).abs() <= 1e-11 * scale,
                    "{set:?} step {k} {what}: {g} vs plain {w}"
                );
            }
        }
        let (na, nb) = (a.nis.expect("nis"), b.nis.expect("nis"));
        assert!((na - nb).abs() <= 1e-11 * na.max(1.0), "step {k} nis");
        assert!((a.log_likelihood - b.log_likelihood).abs() <= 1e-11 * a.log_likelihood.abs());
        // The factor is the Cholesky factor of the covariance it reports.
        let s = sqrt.covariance_factor();
        let p = sqrt.covariance();
        for i in 0..4 {
            assert!(s[(i, i)] > 0.0);
            for j in 0..4 {
                let sst: f64 = (0..4).map(|c| s[(i, c)] * s[(j, c)]).sum();
                assert!((sst - p[(i, j)]).abs() <= 1e-13 * p[(0, 0)].abs().max(1.0));
                if j > i {
                    assert!(s[(i, j)].abs() <= 0.0, "upper triangle ({i}, {j})");
                }
            }
        }
    }
}

#[test]
fn square_root_ukf_equals_the_plain_ukf_to_round_off() {
    for set in [
        // (Merwe's α = 1e-3 makes |W_0| ≈ 1e6: the sums of either form then lose six
        // digits to cancellation, the scaled transform's cost, and agree only to 1e-10.)
        SigmaPoints::merwe(0.5, 2.0, -1.0),
        SigmaPoints::Cubature,
        SigmaPoints::julier(0.5),
        SigmaPoints::Simplex,
    ] {
        agree(FixedDims::<4, 2>::new(), set);
        agree(DynDims::new(4, 2, 0).expect("dims"), set);
    }
}

/// Two uncoupled random walks on scales 10¹² apart: a ~ 1e6 m (P 1e8, R 1e4) and
/// b ~ 1e-6 m measured almost exactly (P 1e-12, R 1e-22). Σ = diag(1e8, 1e-12): its pivot
/// ratio 1e-20 is far below the relative pivot tolerance 1e-12, but both filters judge
/// each pivot against its own diagonal entry (row), so both run. With P diagonal the sigma
/// points never mix the two states, so each state is the scalar Kalman filter of its own
/// channel, computed here in closed form.
#[test]
fn both_ukfs_run_on_states_of_scales_far_apart() {
    let d = FixedDims::<2, 2>::new();
    let (qa, qb, ra, rb) = (1e2, 1e-22, 1e4, 1e-22);
    let model = FnModel::new(
        d,
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out.copy_from_slice(x),
        |x: &[f64], _k: usize, out: &mut [f64]| out.copy_from_slice(x),
        &[[qa, 0.0], [0.0, qb]],
        &[[ra, 0.0], [0.0, rb]],
    )
    .expect("model");
    let x0 = [1e6, 1e-6];
    let p0 = [[1e8, 0.0], [0.0, 1e-12]];
    let mut plain = Ukf::new(d, model.clone(), &x0, &p0, SigmaPoints::Cubature).expect("ukf");
    // The plain filter's P⁺ = P⁻ − K Σ Kᵀ cancels: ε·P⁻/P⁺ of relative round-off (2e-6 at
    // the first step of b), 64 times that bound as for the square-root one below.
    let mut worst_plain = 1e-10_f64;
    let mut sqrt = SqrtUkf::new(d, model, &x0, &p0, SigmaPoints::Cubature).expect("sqrt");
    // The scalar filters: x⁺ = x + p/(p + r)(z − x), p⁺ = p r/(p + r), then p += q.
    let (mut xa, mut pa, mut xb, mut pb) = (x0[0], p0[0][0], x0[1], p0[1][1]);
    let (mut worst_a, mut worst_b) = (1e-10_f64, 1e-10_f64);
    for k in 0..40 {
        let t = k as f64;
        let z = [1e6 + 50.0 * (0.3 * t).sin(), 1e-6 + 1e-9 * (0.7 * t).cos()];
        let info = sqrt.step(&z, None).expect("square-root step");
        assert_eq!(info.observed, 2);
        plain.step(&z, None).expect("plain step");
        // The plain filter's gain carries its covariance's round-off into the mean: at most
        // that relative error times the innovation.
        let innovation = [(z[0] - xa).abs(), (z[1] - xb).abs()];
        let prior_a = pa;
        xa += pa / (pa + ra) * (z[0] - xa);
        pa = pa * ra / (pa + ra);
        let prior_b = pb;
        xb += pb / (pb + rb) * (z[1] - xb);
        pb = pb * rb / (pb + rb);
        // Each state to a few ulps of its own scale (a handful of operations per step,
        // every one relative-accurate on diagonal data): 1e-13 relative. The posterior
        // factor of b is a remainder of O(√P⁻) numbers, so its variance carries
        // ε·√(P⁻/P⁺) of relative round-off (2e-11 at the first step, where P⁻/P⁺ = 1e10):
        // 64 times that bound for each variance.
        // The error made at one step is carried into the next ones: each tolerance is the
        // largest bound seen so far. Its floor, 1e-10: a sigma point's deviation
        // h(χ_i) − ẑ is a difference of numbers of the mean's size, so it carries
        // ε·|x|/σ of relative round-off (1e6/30 ≈ 3e4 ulps ≈ 7e-12 for a), squared into P
        // and summed over the points and steps.
        worst_a = worst_a.max(64.0 * f64::EPSILON * (prior_a / pa).sqrt());
        worst_b = worst_b.max(64.0 * f64::EPSILON * (prior_b / pb).sqrt());
        let (tol_a, tol_b) = (worst_a, worst_b);
        worst_plain = worst_plain
            .max(64.0 * f64::EPSILON * prior_a / pa)
            .max(64.0 * f64::EPSILON * prior_b / pb);
        let (xp, pq) = (plain.state(), plain.covariance());
        assert!(
            (xp[0] - xa).abs() <= 1e-13 * xa.abs() + worst_plain * innovation[0]
                && (xp[1] - xb).abs() <= 1e-13 * xb.abs() + worst_plain * innovation[1],
            "step {k} plain: {xp:?} vs ({xa}, {xb})"
        );
        assert!(
            (pq[(0, 0)] - pa).abs() <= worst_plain * pa
                && (pq[(1, 1)] - pb).abs() <= worst_plain * pb,
            "step {k} plain P: {pq:?} vs ({pa}, {pb})"
        );
        let (x, p) = (sqrt.state(), sqrt.covariance());
        assert!(
            (x[0] - xa).abs() <= 1e-13 * xa.abs(),
            "step {k} a: {} vs {xa}",
            x[0]
        );
        assert!(
            (x[1] - xb).abs() <= 1e-13 * xb.abs(),
            "step {k} b: {} vs {xb}",
            x[1]
        );
        assert!((p[(0, 0)] - pa).abs() <= tol_a * pa, "step {k} P_aa");
        assert!(
            (p[(1, 1)] - pb).abs() <= tol_b * pb,
            "step {k} P_bb {} vs {pb}",
            p[(1, 1)]
        );
        assert!(p[(0, 1)].abs() <= 0.0 && p[(1, 0)].abs() <= 0.0);
        pa += qa;
        pb += qb;
        let pp = sqrt.predicted_covariance();
        assert!(
            (pp[(1, 1)] - pb).abs() <= tol_b * pb,
            "step {k} predicted P_bb"
        );
    }
}

/// Julier's set with κ < 0 and f(x) = (|x|², x_2, …): the unscented variance of |x|² is
/// n·κ < 0 times P's scale (the centre weight κ/(n + κ) is negative), so the predicted
/// covariance is indefinite; the square-root filter's downdate refuses it with the typed
/// error naming the step and the covariance, as the plain filter's next factorisation does.
#[test]
fn an_indefinite_unscented_covariance_is_a_typed_error() {
    let d = DynDims::new(4, 1, 0).expect("dims");
    let q = [
        [0.01, 0.0, 0.0, 0.0],
        [0.0, 0.01, 0.0, 0.0],
        [0.0, 0.0, 0.01, 0.0],
        [0.0, 0.0, 0.0, 0.01],
    ];
    let model = FnModel::new(
        d,
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
            out.copy_from_slice(x);
            out[0] = x.iter().map(|v| v * v).sum();
        },
        |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[1],
        &q,
        &[[1.0]],
    )
    .expect("model");
    let p0 = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let set = SigmaPoints::julier(-1.0);
    let mut sqrt = SqrtUkf::new(d, model.clone(), &[0.0; 4], &p0, set).expect("sqrt");
    let e = sqrt.step(&[f64::NAN], None).expect_err("indefinite");
    assert!(
        matches!(
            e,
            Error::SigmaCovariance {
                name: "P_{k+1|k} (centre-weight downdate)",
                step: 0,
                n: 4,
                ..
            }
        ),
        "{e}"
    );
    assert_eq!(sqrt.steps(), 0);
    let mut plain = Ukf::new(d, model, &[0.0; 4], &p0, set).expect("ukf");
    plain
        .step(&[f64::NAN], None)
        .expect("the plain prediction forms P");
    assert!(plain.predicted_covariance()[(0, 0)] < 0.0);
    let e = plain.step(&[0.0], None).expect_err("indefinite");
    assert!(matches!(e, Error::SigmaCovariance { step: 1, .. }), "{e}");
}

/// Construction checks what the plain filter checks, and an indefinite R_k is named.
#[test]
fn bad_inputs_are_typed_errors() {
    let d = DynDims::new(1, 1, 0).expect("dims");
    let model = |r: f64| {
        FnModel::new(
            d,
            |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| out[0] = x[0],
            |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0],
            &[[1.0]],
            &[[r]],
        )
    };
    let ok = model(1.0).expect("model");
    assert!(matches!(
        SqrtUkf::new(d, ok.clone(), &[0.0], &[[-1.0]], SigmaPoints::Cubature),
        Err(Error::NotPositiveSemidefinite { .. })
    ));
    assert!(matches!(
        SqrtUkf::new(d, ok.clone(), &[0.0], &[[1.0]], SigmaPoints::julier(-1.0)),
        Err(Error::InvalidOption { name: "kappa", .. })
    ));
    let mut f = SqrtUkf::new(d, ok, &[0.0], &[[1.0]], SigmaPoints::Cubature).expect("sqrt");
    assert!(matches!(
        f.step(&[0.0, 1.0], None),
        Err(Error::Shape { name: "z", .. })
    ));
    f.reset(&[2.0], &[[4.0]]).expect("reset");
    assert!((f.covariance_factor()[(0, 0)] - 2.0).abs() <= 0.0);
    assert_eq!(f.sigma_points(), SigmaPoints::Cubature);
}

/// The unscented RTS smoother over the plain and the square-root UKF, each backward pass in
/// both forms (`smooth`, `smooth_sqrt`): the four smoothed trajectories agree to 1e-9 of
/// each quantity's scale (the filters agree to 1e-11, `agree`; the backward passes add the
/// round-off of one Cholesky solve or one triangularisation per step over 60 steps).
#[test]
fn the_unscented_smoother_in_square_root_form_equals_the_covariance_form() {
    let d = DynDims::new(4, 2, 0).expect("dims");
    let set = SigmaPoints::merwe(0.5, 2.0, -1.0);
    let (x0, p0) = (RangeBearing::x0(), RangeBearing::p0());
    let mut plain = Ukf::new(d, RangeBearingHand::default(), &x0, &p0, set).expect("ukf");
    let mut sqrt = SqrtUkf::new(d, RangeBearingHand::default(), &x0, &p0, set).expect("sqrt");
    let (mut rp, mut rs) = (NonlinearRts::new(), NonlinearRts::new());
    for k in 0..60 {
        let z = radar(k);
        plain.step(&z, None).expect("plain step");
        sqrt.step(&z, None).expect("square-root step");
        rp.record(&plain).expect("record");
        rs.record(&sqrt).expect("record");
    }
    let want = rp.smooth().expect("covariance form");
    for got in [
        rp.smooth_sqrt().expect("square-root form"),
        rs.smooth_sqrt()
            .expect("square-root form over the square-root UKF"),
    ] {
        for k in 0..60 {
            let (P, W) = (got.covariance(k).expect("a step"), &want.covariances[k]);
            let scale = flat(W.as_ref()).iter().fold(1.0_f64, |s, v| s.max(v.abs()));
            for i in 0..4 {
                let xs = want.means[(i, k)].abs().max(1.0);
                assert!(
                    (got.means[(i, k)] - want.means[(i, k)]).abs() <= 1e-9 * xs,
                    "x {k},{i}"
                );
                for j in 0..4 {
                    assert!(
                        (P[(i, j)] - W[(i, j)]).abs() <= 1e-9 * scale,
                        "P {k},{i},{j}"
                    );
                }
            }
        }
    }
    let cov = rs
        .smooth()
        .expect("covariance form over the square-root UKF");
    for k in 0..60 {
        for i in 0..4 {
            let xs = want.means[(i, k)].abs().max(1.0);
            assert!((cov.means[(i, k)] - want.means[(i, k)]).abs() <= 1e-9 * xs);
        }
    }
}

/// A model whose Q and R change from step to step (and whose observed block of R changes
/// with a missing entry): the square-root filter factors each Q and R it has not factored
/// before, so it still equals the plain UKF to round-off, step by step. A factor kept from
/// an earlier step would be off by the noise change itself (a factor of 2 to 10).
#[derive(Clone, Debug)]
struct VaryingNoise;

impl kalman::nonlinear::NonlinearModel for VaryingNoise {
    fn f(&mut self, x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]) {
        out[0] = x[0] + 0.1 * x[1];
        out[1] = 0.95 * x[1];
    }
    fn h(&mut self, x: &[f64], _k: usize, out: &mut [f64]) {
        out[0] = (x[0] * x[0] + 1.0).sqrt();
        out[1] = x[1];
    }
    fn q(&mut self, k: usize, out: &mut [f64]) {
        let s = 1.0 + (k % 3) as f64;
        out.copy_from_slice(&[1e-4 * s, 1e-5, 1e-5, 1e-3 * s]);
    }
    fn r(&mut self, k: usize, out: &mut [f64]) {
        let s = if k % 4 == 0 { 10.0 } else { 1.0 };
        out.copy_from_slice(&[1e-2 * s, 0.0, 0.0, 1e-3 * (2.0 - s / 10.0)]);
    }
}

#[test]
fn step_varying_noise_is_factored_at_every_step() {
    let d = DynDims::new(2, 2, 0).expect("dims");
    let (x0, p0) = ([1.0, 0.5], [[0.1, 0.0], [0.0, 0.1]]);
    let set = SigmaPoints::merwe(0.5, 2.0, 0.0);
    let mut plain = Ukf::new(d, VaryingNoise, &x0, &p0, set).expect("ukf");
    let mut sqrt = SqrtUkf::new(d, VaryingNoise, &x0, &p0, set).expect("sqrt");
    for k in 0..40 {
        let x = 1.0 + 0.05 * k as f64;
        let v = 0.5 * 0.95_f64.powi(k);
        let second = if k % 5 == 2 { f64::NAN } else { v + 0.01 };
        let z = [
            (x * x + 1.0f64).sqrt() + 0.02 * ((k % 3) as f64 - 1.0),
            second,
        ];
        plain.step(&z, None).expect("plain step");
        sqrt.step(&z, None).expect("square-root step");
        for (got, want) in [
            (sqrt.state().to_vec(), plain.state().to_vec()),
            (flat(sqrt.covariance()), flat(plain.covariance())),
            (
                flat(sqrt.predicted_covariance()),
                flat(plain.predicted_covariance()),
            ),
        ] {
            let scale = want.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
            for (g, w) in got.iter().zip(&want) {
                assert!((g - w).abs() <= 1e-11 * scale, "step {k}: {g} vs plain {w}");
            }
        }
    }
}
