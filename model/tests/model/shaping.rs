//! Shaping filters: intensity ↔ variance, spectral density ↔ correlation function, discrete
//! stationary variance (Lyapunov), and a long seeded simulation's autocorrelation.

use model::{
    DampedCosineShaping, DiscreteSs, Discretization, ExponentialShaping, IrregularRollingShaping,
    NoiseConvention, ShapingFilter, noise_driven, psd_factor,
};
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

fn filters() -> Vec<(&'static str, Box<dyn ShapingFilter>)> {
    vec![
        (
            "exponential",
            Box::new(ExponentialShaping::new(2.0, 1.5).expect("valid")),
        ),
        (
            "rolling",
            Box::new(IrregularRollingShaping::new(0.5, 0.3, 2.0).expect("valid")),
        ),
        (
            "damped cosine",
            Box::new(DampedCosineShaping::new(1.2, 0.4, 3.0).expect("valid")),
        ),
    ]
}

/// (1/2π)∫S(ω)cos(ωτ)dω by the trapezoid rule on [−W, W] with W far in the tail. The
/// slowest tail is S ~ N/(T²ω²) (exponential, damped cosine): the tail mass beyond W is
/// ≈ N/(π T² W) — below 1e-4·D for W = 2e4 with these parameters.
fn correlation_from_spectrum(f: &dyn ShapingFilter, tau: f64) -> f64 {
    let (w_max, n) = (2.0e4, 2_000_000usize);
    let h = 2.0 * w_max / n as f64;
    let mut sum = 0.0;
    for i in 0..=n {
        let w = -w_max + i as f64 * h;
        let weight = if i == 0 || i == n { 0.5 } else { 1.0 };
        sum += weight * f.spectral_density(w) * (w * tau).cos();
    }
    sum * h / (2.0 * std::f64::consts::PI)
}

#[test]
fn spectral_density_is_the_transform_of_the_correlation() {
    for (name, f) in filters() {
        // The closed-form density equals N·|H(jω)|².
        for w in [0.0, 0.5, 2.0, 10.0] {
            let via_h = f.intensity() * f.transfer_function().freq_response(w).norm_sqr();
            assert!(
                (f.spectral_density(w) - via_h).abs() <= 1e-12 * via_h.max(1.0),
                "{name}: S({w})"
            );
        }
        // Its inverse transform gives back R(τ); the tolerance is the truncated tail above.
        for tau in [0.0, 0.3, 1.0] {
            let r = correlation_from_spectrum(f.as_ref(), tau);
            let want = f.correlation(tau);
            assert!(
                (r - want).abs() <= 2e-4 * f.variance(),
                "{name}: R({tau}) = {r} from S, {want} closed form"
            );
        }
        assert!((f.correlation(0.0) - f.variance()).abs() < 1e-15);
    }
}

/// Stationary output variance of a discrete filter by the Lyapunov equation.
fn lyapunov_variance(d: &DiscreteSs) -> f64 {
    d.stationary_output_covariance().expect("stable")[(0, 0)]
}

fn check_lyapunov(f: &dyn ShapingFilter, dt: f64) {
    let dv = f.variance();
    // Van Loan with ZOH is the exact sampled process: the variance is D up to rounding of
    // the exponential and the Lyapunov doubling.
    let exact = f
        .discretize(dt, Discretization::Zoh, NoiseConvention::VanLoan)
        .expect("ok");
    let v = lyapunov_variance(&exact);
    assert!((v - dv).abs() <= 1e-8 * dv, "ZOH/Van Loan: {v} vs {dv}");
    // The paper's convention (noise held over the step, variance N/Δt) through ZOH: within
    // 1 % of D once Δt ≤ (shortest time constant)/20 (the criterion).
    let held = f
        .discretize(dt, Discretization::Zoh, NoiseConvention::IntensityOverDt)
        .expect("ok");
    let v = lyapunov_variance(&held);
    assert!(
        (v - dv).abs() <= 0.01 * dv,
        "ZOH/N÷Δt: {v} vs {dv} at Δt = {dt}"
    );
}

#[test]
fn lyapunov_variance_within_one_percent() {
    for (_, f) in filters() {
        let dt = f.shortest_time_constant() / 20.0;
        check_lyapunov(f.as_ref(), dt);
    }
}

#[test]
fn tustin_exponential_variance_closed_form() {
    // Tustin of 1/(Ts+1) with variance N/Δt has output variance D/(1 + Δt/(2T)) exactly:
    // the paper's discretisation under-states D by Δt/(2T) (0.25 % at its defaults).
    let f = ExponentialShaping::new(3.0, 20.0).expect("valid");
    for dt in [0.1, 1.0, 4.0] {
        let d = f.discretize_paper(dt).expect("ok");
        let v = lyapunov_variance(&d);
        let want = 3.0 / (1.0 + dt / 40.0);
        assert!((v - want).abs() <= 1e-10 * want, "{v} vs {want}");
    }
}

/// Simulates the exact sampled process (ZOH + Van Loan) from its stationary distribution.
fn simulate(d: &DiscreteSs, len: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = d.n_states();
    let l_q = psd_factor(&d.process_covariance()).expect("PSD");
    let l_p = psd_factor(&d.stationary_covariance().expect("stable")).expect("PSD");
    let draw = |rng: &mut ChaCha8Rng| {
        DVector::from_iterator(n, (0..n).map(|_| StandardNormal.sample(rng)))
    };
    let mut x = &l_p * draw(&mut rng);
    let mut out = Vec::with_capacity(len);
    for _ in 0..len {
        out.push((d.h() * &x)[0]);
        x = d.f() * x + &l_q * draw(&mut rng);
    }
    out
}

#[test]
fn simulated_autocorrelation_follows_the_correlation_function() {
    const LEN: usize = 200_000;
    for (seed, (name, f)) in filters().into_iter().enumerate() {
        let dt = f.shortest_time_constant() / 10.0;
        let d = f
            .discretize(dt, Discretization::Zoh, NoiseConvention::VanLoan)
            .expect("ok");
        let y = simulate(&d, LEN, 17 + seed as u64);
        // Bartlett: var ĉ(k) ≈ (1/N)Σ_j [R(j)² + R(j+k)R(j−k)] ≤ (2/N)Σ_j R(j)² (Cauchy–
        // Schwarz). Tolerance: 5 standard deviations of that bound (each check fails by
        // chance with probability < 1e-6; the seed is fixed anyway).
        let sum_r2: f64 = (-20_000i64..=20_000)
            .map(|j| f.correlation(j as f64 * dt).powi(2))
            .sum();
        let tol = 5.0 * (2.0 * sum_r2 / LEN as f64).sqrt();
        for lag in [0usize, 3, 7, 15, 30] {
            let c: f64 = y[..LEN - lag]
                .iter()
                .zip(&y[lag..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / (LEN - lag) as f64;
            let want = f.correlation(lag as f64 * dt);
            assert!(
                (c - want).abs() <= tol,
                "{name}: lag {lag}: sample {c:.5}, R = {want:.5}, tol {tol:.5}"
            );
        }
    }
}

#[test]
fn paper_discretisations_of_the_filters() {
    // The paper's rolling filter has no feed-through; its quantization filter keeps d0.
    let roll = IrregularRollingShaping::new(1.0, 0.08, 0.628).expect("valid");
    let d = roll.discretize_paper(0.1).expect("ok");
    assert!(d.j().amax() < 1e-300);
    assert!((d.q()[(0, 0)] - roll.intensity() / 0.1).abs() < 1e-15);
    let q = DampedCosineShaping::new(1e-4 / 12.0, 0.05, 6.0).expect("valid");
    let d = q.discretize_paper(0.1).expect("ok");
    assert!(d.j()[(0, 0)] > 0.0);
    // Its rule (1 + z⁻¹) → 2 removes exact Tustin's zero at z = −1 (the Nyquist frequency)
    // and keeps the gain at z = 1 (both factors are 2 there), which is N(0)/D(0) = 1.
    let gain = |s: &DiscreteSs, z: f64| {
        let n = s.f().nrows();
        let x = (DMatrix::identity(n, n) * z - s.f())
            .lu()
            .solve(s.g())
            .expect("z is not a pole");
        (s.h() * x + s.j())[(0, 0)]
    };
    let tustin =
        noise_driven(&q.transfer_function().tustin(0.1, None).expect("ok"), 1.0).expect("ok");
    // Round-off of a 2-state solve with entries ≤ 1e3: 1e-12.
    assert!(
        gain(&tustin, -1.0).abs() <= 1e-12,
        "{}",
        gain(&tustin, -1.0)
    );
    assert!(gain(&d, -1.0).abs() > 1e-3, "{}", gain(&d, -1.0));
    for s in [&d, &tustin] {
        assert!((gain(s, 1.0) - 1.0).abs() <= 1e-12, "{}", gain(s, 1.0));
    }
    // At Δt ≤ (shortest time constant)/20 the paper's discretisation of each filter stays
    // within 5 % of D (Tustin with N/Δt under-states the variance by about Δt/(2T)).
    for (name, f) in filters() {
        let dt = f.shortest_time_constant() / 20.0;
        let v = lyapunov_variance(&f.discretize_paper(dt).expect("ok"));
        assert!(
            (v - f.variance()).abs() <= 0.05 * f.variance(),
            "{name}: {v}"
        );
    }
}

#[cfg(feature = "proptest")]
mod props {
    use super::check_lyapunov;
    use model::{DampedCosineShaping, ExponentialShaping, IrregularRollingShaping, ShapingFilter};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(super::super::support::config())]

        #[test]
        fn lyapunov_within_one_percent_random(
            var in 1e-6..1e3f64,
            t in 0.05..50.0f64,
            mu in 0.01..2.0f64,
            beta in 0.05..10.0f64,
            frac in 0.05..1.0f64,
        ) {
            let fs: [Box<dyn ShapingFilter>; 3] = [
                Box::new(ExponentialShaping::new(var, t).expect("valid")),
                Box::new(IrregularRollingShaping::new(var, mu, beta).expect("valid")),
                Box::new(DampedCosineShaping::new(var, mu, beta).expect("valid")),
            ];
            for f in &fs {
                check_lyapunov(f.as_ref(), frac * f.shortest_time_constant() / 20.0);
            }
        }
    }
}

/// The parameters read back are the ones given, for values on both sides of 1 (so no constant
/// can stand in for them), and the rolling filter's coefficients are the paper's closed form
/// in them: a = 2μ/(μ² + β²), b = 1/(μ² + β²) (the damped cosine's c, d likewise in ξ, ω).
#[test]
fn parameters_read_back_as_given() {
    for (x, y) in [(0.08, 0.63), (2.5, 0.2), (1.0, 3.0)] {
        let e = ExponentialShaping::new(1.0, x).expect("valid");
        assert!((e.time_constant() - x).abs() <= 0.0);
        assert!((e.shortest_time_constant() - x).abs() <= 0.0);
        let r = IrregularRollingShaping::new(1.0, x, y).expect("valid");
        assert!((r.mu() - x).abs() <= 0.0 && (r.beta() - y).abs() <= 0.0);
        let (a, b) = r.coefficients();
        let s = x * x + y * y;
        // Two roundings each: 1e-15 relative.
        assert!((a - 2.0 * x / s).abs() <= 1e-15 * a && (b - 1.0 / s).abs() <= 1e-15 * b);
        let d = DampedCosineShaping::new(1.0, x, y).expect("valid");
        assert!((d.xi() - x).abs() <= 0.0 && (d.omega() - y).abs() <= 0.0);
        let (c, dd) = d.coefficients();
        assert!((c - 2.0 * x / s).abs() <= 1e-15 * c && (dd - 1.0 / s).abs() <= 1e-15 * dd);
    }
}
