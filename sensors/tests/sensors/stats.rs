//! Estimators and their standard errors, derived from the run length and the theoretical
//! correlation function (Bartlett's formulas for a stationary Gaussian sequence).

/// Sample mean.
pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / len(x)
}

/// Sample auto-covariance at `lag` with the known (zero) mean: (1/(N−ℓ))·Σ x_k·x_{k+ℓ}.
pub fn autocov(x: &[f64], lag: usize) -> f64 {
    let n = x.len() - lag;
    let s: f64 = x[..n].iter().zip(&x[lag..]).map(|(a, b)| a * b).sum();
    #[allow(clippy::cast_precision_loss)]
    let n = n as f64;
    s / n
}

/// `x.len()` as f64.
pub fn len(x: &[f64]) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let n = x.len() as f64;
    n
}

/// Sums `f(j)` over |j| < `terms` (the correlation functions used decay exponentially; the
/// callers pick `terms` so the tail is below 1e-12 of the total).
fn sym_sum(terms: usize, f: impl Fn(f64) -> f64) -> f64 {
    let mut s = f(0.0);
    for j in 1..terms {
        #[allow(clippy::cast_precision_loss)]
        let j = j as f64;
        s += f(j) + f(-j);
    }
    s
}

/// Standard error of the sample mean of N samples of a stationary sequence with correlation
/// R(jΔt): √((1/N)·Σ_{|j|<N}(1 − |j|/N)·R(jΔt)).
pub fn se_mean(r: impl Fn(f64) -> f64, dt: f64, n: usize, terms: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let nf = n as f64;
    let v = sym_sum(terms.min(n), |j| (1.0 - j.abs() / nf) * r(j * dt)) / nf;
    v.max(0.0).sqrt()
}

/// Standard error of the (known-mean) sample auto-covariance at lag ℓ (Bartlett):
/// √((1/N)·Σ_j [R(j)² + R(j+ℓ)·R(j−ℓ)]).
pub fn se_autocov(r: impl Fn(f64) -> f64, dt: f64, lag: usize, n: usize, terms: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let (nf, l) = (n as f64, lag as f64);
    let v = sym_sum(terms, |j| {
        r(j * dt).powi(2) + r((j + l) * dt) * r((j - l) * dt)
    }) / nf;
    v.max(0.0).sqrt()
}

/// Kolmogorov–Smirnov statistic of `x` against the uniform law on [lo, hi).
pub fn ks_uniform(x: &mut [f64], lo: f64, hi: f64) -> f64 {
    x.sort_by(f64::total_cmp);
    let n = len(x);
    let mut d: f64 = 0.0;
    for (i, v) in x.iter().enumerate() {
        let f = ((v - lo) / (hi - lo)).clamp(0.0, 1.0);
        #[allow(clippy::cast_precision_loss)]
        let i = i as f64;
        d = d.max((i + 1.0) / n - f).max(f - i / n);
    }
    d
}

/// How many standard errors a seeded statistical check may deviate. With 5σ a Gaussian
/// estimator fails with probability 6e-7 per check, so a re-seeded run would not be flaky
/// either; the seeds are fixed anyway.
pub const Z: f64 = 5.0;
