//! The shaping-filter map against the correlation functions in closed form, recovery of
//! known parameters from signals simulated by `sensors` (an independent exact generator),
//! and the Wald coverage of the irregular-rolling fit over 200 series.

use super::*;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use sensors::Process;

/// Autocovariance of the map's output at lag k from the system: H F^k P0 Hᵀ (+ r at 0).
fn model_autocovariance(sys: &System, k: usize) -> f64 {
    let n = sys.n();
    let mut m = sys.p0.clone();
    for _ in 0..k {
        m = &sys.f * &m;
    }
    let mut s = 0.0;
    for i in 0..n {
        for j in 0..n {
            s += sys.h[(0, i)] * m[(i, j)] * sys.h[(0, j)];
        }
    }
    s
}

#[test]
fn the_map_is_the_exact_discretisation_of_the_correlation_function() {
    let dt = 0.1;
    for (kind, p) in [
        (Kind::Exponential, vec![2.0, 0.05]),
        (Kind::IrregularRolling, vec![3.0, 0.08, 0.63]),
        (Kind::DampedCosine, vec![0.5, 0.05, 2.0]),
    ] {
        let map = ShapingMap {
            kind,
            dt,
            noise: Noise::Known(0.0),
        };
        let sys = map.system(&map.theta_of(&p, 1.0)).expect("valid");
        for k in [0usize, 1, 7, 50, 200] {
            let got = model_autocovariance(&sys, k);
            let exact = kind.correlation(&p, k as f64 * dt).expect("valid");
            // Van Loan's exponential and the Lyapunov solve: ~1e-12 relative; 1e-8 of D
            // leaves room for 200 products by F.
            assert!(
                (got - exact).abs() < 1e-8 * p[0],
                "{kind:?} lag {k}: {got} vs {exact}"
            );
        }
    }
    let map = ShapingMap {
        kind: Kind::Exponential,
        dt,
        noise: Noise::Free,
    };
    assert_eq!(map.n_params(), 3);
    assert!(matches!(
        map.system(&[0.0, 0.0]),
        Err(FitError::Parameters(_))
    ));
}

fn rng(seed: u64) -> rand_chacha::ChaCha8Rng {
    rand_chacha::ChaCha8Rng::seed_from_u64(seed)
}

/// `len` samples of an irregular rolling (σ, μ, period) at `dt` from `sensors`, plus white
/// noise of variance r.
fn rolling(p: &[f64], dt: f64, r: f64, len: usize, g: &mut rand_chacha::ChaCha8Rng) -> Vec<f64> {
    let cfg = sensors::IrregularRollingConfig {
        std_dev: p[0].sqrt(),
        irregularity_per_s: p[1],
        period_s: 2.0 * std::f64::consts::PI / p[2],
    };
    let mut proc = sensors::IrregularRollingProcess::new(&cfg, dt).expect("valid");
    observed(&mut proc, r, len, g)
}

/// `len` samples of `proc` plus white noise of variance r.
fn observed(
    proc: &mut impl Process,
    r: f64,
    len: usize,
    g: &mut rand_chacha::ChaCha8Rng,
) -> Vec<f64> {
    (0..len)
        .map(|_| {
            let v: f64 = StandardNormal.sample(g);
            proc.next(g) + r.sqrt() * v
        })
        .collect()
}

fn check_recovery(name: &str, fit: &ShapingFit, truth: &[f64]) {
    assert!(fit.converged, "{name}: {}", fit.message);
    let se = fit.std_errors.as_ref().expect("standard errors");
    for (i, t) in truth.iter().enumerate() {
        // 4 standard errors: a 6e-5 two-sided event per parameter for a Gaussian estimate.
        assert!(
            (fit.values[i] - t).abs() < 4.0 * se[i],
            "{name} parameter {i}: {} ± {} vs truth {t}",
            fit.values[i],
            se[i]
        );
        // The errors are informative: below the parameter itself.
        assert!(se[i] < t.abs(), "{name} parameter {i}: se {} vs {t}", se[i]);
    }
}

#[test]
fn mle_recovers_an_irregular_rolling_with_its_noise() {
    // One 10-minute record at 10 Hz: σ = 1°, μ = 0.08 /s, 10 s period, noise 0.1° rms.
    let truth = [1.0, 0.08, 2.0 * std::f64::consts::PI / 10.0];
    let r = 0.01;
    let dt = 0.1;
    let z = rolling(&truth, dt, r, 6000, &mut rng(3));
    let map = ShapingMap {
        kind: Kind::IrregularRolling,
        dt,
        noise: Noise::Free,
    };
    // The classical estimate is the MLE's start.
    let start = fit_acf(map.kind, &z, dt, 150, &[0.5, 0.2, 0.5]).expect("acf fit");
    for (s, t) in start.iter().zip(&truth) {
        // Least squares on 150 lags of a 60-correlation-time record: within a factor 2.
        assert!(s / t > 0.5 && s / t < 2.0, "{start:?} vs {truth:?}");
    }
    let fit = fit_mle(&map, &z, &start, 0.05).expect("mle");
    let mut all = truth.to_vec();
    all.push(r);
    check_recovery("rolling", &fit, &all);
}

#[test]
fn mle_recovers_exponential_and_damped_cosine_filters() {
    let dt = 0.5;
    let mut g = rng(9);
    // Exponential: σ² = 4, μ = 0.1 (T = 10 s), 4000 samples = 200 T.
    let cfg = sensors::ExpCorrelatedConfig {
        std_dev: 2.0,
        correlation_time_s: 10.0,
    };
    let mut p = sensors::ExpCorrelated::new(&cfg, dt).expect("valid");
    let r: f64 = 0.1;
    let z = observed(&mut p, r, 4000, &mut g);
    let map = ShapingMap {
        kind: Kind::Exponential,
        dt,
        noise: Noise::Known(r),
    };
    let fit = fit_mle(&map, &z, &[1.0, 1.0], r).expect("mle");
    check_recovery("exponential", &fit, &[4.0, 0.1]);

    // Damped cosine: D = 1, ξ = 0.05, ω = 1 rad/s.
    let cfg = sensors::DampedCosineConfig {
        std_dev: 1.0,
        decay_per_s: 0.05,
        frequency_rad_s: 1.0,
    };
    let mut p = sensors::DampedCosineProcess::new(&cfg, dt).expect("valid");
    let z = observed(&mut p, r, 4000, &mut g);
    let map = ShapingMap {
        kind: Kind::DampedCosine,
        dt,
        noise: Noise::Known(r),
    };
    let start = fit_acf(map.kind, &z, dt, 60, &[0.5, 0.1, 0.8]).expect("acf fit");
    let fit = fit_mle(&map, &z, &start, r).expect("mle");
    check_recovery("damped cosine", &fit, &[1.0, 0.05, 1.0]);
}

/// The central 99.9 % band of Binomial(n, p).
fn binomial_band(n: usize, p: f64) -> (usize, usize) {
    let mut logpmf = vec![0.0; n + 1];
    logpmf[0] = n as f64 * (1.0 - p).ln();
    for k in 0..n {
        logpmf[k + 1] = logpmf[k] + ((n - k) as f64 / (k + 1) as f64).ln() + (p / (1.0 - p)).ln();
    }
    let pmf: Vec<f64> = logpmf.iter().map(|v| v.exp()).collect();
    let (mut lo, mut acc) = (0, 0.0);
    while acc + pmf[lo] < 0.0005 {
        acc += pmf[lo];
        lo += 1;
    }
    let (mut hi, mut acc) = (n, 0.0);
    while acc + pmf[hi] < 0.0005 {
        acc += pmf[hi];
        hi -= 1;
    }
    (lo, hi)
}

#[test]
fn wald_intervals_of_an_irregular_rolling_fit_cover_at_the_nominal_rate() {
    // 200 series of 1000 samples at Δt = 0.5 s (50 correlation times 1/μ each); r known.
    let truth = [1.0, 0.08, 2.0 * std::f64::consts::PI / 10.0];
    let (dt, r, runs) = (0.5, 0.05, 200);
    let map = ShapingMap {
        kind: Kind::IrregularRolling,
        dt,
        noise: Noise::Known(r),
    };
    let theta_true: Vec<f64> = truth.iter().map(|v| v.ln()).collect();
    let mut g = rng(17);
    let mut cover = [0usize; 3];
    for _ in 0..runs {
        let z = rolling(&truth, dt, r, 1000, &mut g);
        let fit = fit_mle(&map, &z, &[0.7, 0.12, 0.5], r).expect("mle");
        assert!(fit.converged, "{}", fit.message);
        let se = fit.std_errors.expect("standard errors");
        for i in 0..3 {
            // The interval on the log scale (where the estimate is closer to Gaussian):
            // ln p̂ ± 1.96·se(ln p̂), se(ln p̂) = se(p̂)/p̂.
            let (t, s) = (fit.values[i].ln(), se[i] / fit.values[i]);
            cover[i] += usize::from((t - theta_true[i]).abs() <= 1.959_964 * s);
        }
    }
    let (lo, hi) = binomial_band(runs, 0.95);
    for (name, c) in ["D", "μ", "β"].iter().zip(cover) {
        assert!(
            (lo..=hi).contains(&c),
            "{name}: {c}/{runs} intervals cover, band [{lo}, {hi}]"
        );
    }
}

#[test]
fn the_shaping_maps_gradient_matches_central_differences() {
    // The score recursion's gradient through every shaping map (whose matrix derivatives
    // are central differences of the discretisation, step 1e-6 relative, error ≈ 1e-10
    // relative) against central differences of ln L itself at h = 1e-4, away from the
    // optimum. Their error is the truncation h²/6·∂³ln L, estimated from the same
    // differences at 2h (four times as large: |D(2h) − D(h)|/3), plus ln L's round-off
    // over h: a sum of N terms, at most N·ε·max(|ln L|, N) — the bound asserted, ×3.
    use kalman::fit::log_likelihood_gradient;
    let dt = 0.1;
    let z = rolling(
        &[1.0, 0.08, 2.0 * std::f64::consts::PI / 10.0],
        dt,
        0.01,
        500,
        &mut rng(21),
    );
    let data = Series::new(&z, 1).expect("series");
    let n = z.len() as f64;
    for (kind, p) in [
        (Kind::Exponential, vec![1.0, 0.1]),
        (Kind::IrregularRolling, vec![1.0, 0.08, 0.6]),
        (Kind::DampedCosine, vec![1.0, 0.1, 0.7]),
    ] {
        for noise in [Noise::Known(0.01), Noise::Free] {
            let map = ShapingMap { kind, dt, noise };
            let theta: Vec<f64> = map
                .theta_of(&p, 0.02)
                .iter()
                .enumerate()
                .map(|(i, t)| t + 0.2 * ((i + 1) as f64).sin())
                .collect();
            let (ll, g) = log_likelihood_gradient(&map, &theta, &data).expect("gradient");
            let lnl = |t: &[f64]| log_likelihood_gradient(&map, t, &data).expect("ln L").0;
            let central = |i: usize, h: f64| {
                let mut t = theta.clone();
                t[i] += h;
                let up = lnl(&t);
                t[i] -= 2.0 * h;
                (up - lnl(&t)) / (2.0 * h)
            };
            let h = 1e-4;
            let round_off = n * f64::EPSILON * ll.abs().max(n) / h;
            for i in 0..theta.len() {
                let (d1, d2) = (central(i, h), central(i, 2.0 * h));
                let truncation = (d2 - d1).abs() / 3.0;
                let err = (g[i] - d1).abs();
                assert!(
                    err <= 3.0 * (truncation + round_off),
                    "{kind:?} {noise:?} ∂/∂θ[{i}]: exact {} vs central {d1} (error {err:.2e}, \
                     truncation {truncation:.2e}, round-off {round_off:.2e})",
                    g[i]
                );
                // Not vacuous: the gradient is far from zero here, well above that error.
                assert!(
                    g[i].abs() > 1e3 * (truncation + round_off),
                    "{kind:?} θ[{i}]"
                );
            }
        }
    }
}

#[test]
fn autocorrelation_fit_of_a_short_signal_is_a_typed_error() {
    // 6 samples, one missing: 5 observed, and 4 lags need at least 6.
    let z = [1.0, -0.5, f64::NAN, 0.3, 0.2, -0.1];
    let e = fit_acf(Kind::Exponential, &z, 1.0, 4, &[1.0, 0.1]).expect_err("too short");
    assert!(
        matches!(
            e,
            Error::TooFewSamples {
                observed: 5,
                lags: 4
            }
        ),
        "{e:?}"
    );
    assert_eq!(e.exit_code(), 1);
    assert!(
        e.to_string().contains("5 observed samples for 4 lags"),
        "{e}"
    );
}
