//! Residual diagnostics: is a filter's innovation sequence what its model says it is? The
//! FFT and Welch's power spectral density, the sample autocorrelation, the Ljung–Box
//! portmanteau test with its χ² p-value, and [`Innovations`], which collects a filter's
//! normalised innovation squared (NIS), per-channel standardised innovations and
//! log-likelihood step by step and summarises them ([`InnovationSummary`]).
//!
//! For a correct model the prior innovations `e_k = z_k − H x_{k|k−1}` are independent
//! `N(0, Σ_k)`: the NIS `e_kᵀ Σ_k⁺ e_k` is χ² with `rank Σ_k` degrees of freedom at every
//! step, so the sum over steps is χ² with the summed ranks, and each standardised channel
//! `e_{k,i}/√Σ_{k,ii}` is white with unit variance (Bar-Shalom, Li, Kirubarajan,
//! *Estimation with Applications to Tracking and Navigation*, 2001, §5.4; G. M. Ljung and
//! G. E. P. Box, *On a measure of lack of fit in time series models*, 1978).
//!
//! # Example
//! ```
//! use kalman::diagnostics::{autocorrelation, ljung_box_test};
//!
//! // An alternating sequence: ρ_k = (−1)^k (N − k)/N exactly, far from white.
//! let x: Vec<f64> = (0..100).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
//! let rho = autocorrelation(&x, 2);
//! assert!((rho[1] + 0.99).abs() < 1e-12 && (rho[2] - 0.98).abs() < 1e-12);
//! let lb = ljung_box_test(&x, 10, 0)?;
//! assert!(lb.p_value < 1e-10);
//! # Ok::<(), kalman::Error>(())
//! ```

mod spectrum;

pub use spectrum::{Psd, fft, welch};

use crate::{Dims, Error, Filter, StepInfo, chi2_quantile, chi2_sf};

/// Sample autocorrelation `ρ_k = c_k / c_0`, k = 0..=`max_lag`, of `x` about its mean, with
/// `c_k = Σ_i (x_i − x̄)(x_{i+k} − x̄)` (the biased estimator, so the sequence is positive
/// semidefinite). NaN entries are missing: the mean and `c_0` use the observed entries and
/// `c_k` the pairs with both ends observed. ρ₀ = 1; all zero for a constant signal, and 0
/// at lags beyond the signal.
///
/// # Example
/// ```
/// let rho = kalman::diagnostics::autocorrelation(&[1.0, 2.0, 3.0], 1);
/// // Deviations (−1, 0, 1): c0 = 2, c1 = 0.
/// assert!((rho[0] - 1.0).abs() < 1e-15 && rho[1].abs() < 1e-15);
/// ```
pub fn autocorrelation(x: &[f64], max_lag: usize) -> Vec<f64> {
    let n = x.len();
    let count = x.iter().filter(|v| !v.is_nan()).count();
    let mean = x.iter().filter(|v| !v.is_nan()).sum::<f64>() / count.max(1) as f64;
    let c0: f64 = x
        .iter()
        .filter(|v| !v.is_nan())
        .map(|v| (v - mean) * (v - mean))
        .sum();
    (0..=max_lag)
        .map(|k| {
            if c0.is_nan() || c0 <= 0.0 || k >= n {
                return 0.0;
            }
            let ck: f64 = (0..n - k)
                .map(|i| (x[i] - mean) * (x[i + k] - mean))
                .filter(|v| !v.is_nan())
                .sum();
            ck / c0
        })
        .collect()
}

/// The Ljung–Box statistic `Q = N(N+2)·Σ_{k=1}^{h} ρ_k²/(N−k)` over `lags` = h lags, N the
/// number of observed (non-NaN) entries: χ² with h degrees of freedom for a white sequence.
///
/// # Example
/// ```
/// // Two lags of a 4-sample sequence (deviations −1.5, −0.5, 0.5, 1.5: ρ₁ = 0.25, ρ₂ = −0.3).
/// let q = kalman::diagnostics::ljung_box(&[1.0, 2.0, 3.0, 4.0], 2);
/// assert!((q - 4.0 * 6.0 * (0.25f64.powi(2) / 3.0 + 0.3f64.powi(2) / 2.0)).abs() < 1e-12);
/// ```
pub fn ljung_box(x: &[f64], lags: usize) -> f64 {
    let n = x.iter().filter(|v| !v.is_nan()).count() as f64;
    let rho = autocorrelation(x, lags);
    n * (n + 2.0)
        * rho
            .iter()
            .enumerate()
            .skip(1)
            .map(|(k, r)| r * r / (n - k as f64))
            .sum::<f64>()
}

/// A Ljung–Box test's outcome.
///
/// # Example
/// ```
/// // A white sequence is rarely rejected: p-value well above 1 %.
/// let x: Vec<f64> = (0..200).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
/// let lb = kalman::diagnostics::ljung_box_test(&x, 5, 0)?;
/// assert_eq!((lb.lags, lb.dof), (5, 5));
/// assert!((lb.p_value - kalman::chi2_sf(lb.statistic, 5)).abs() < 1e-15);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct LjungBox {
    /// Lags h summed.
    pub lags: usize,
    /// The statistic Q.
    pub statistic: f64,
    /// Degrees of freedom of its χ² reference: h minus the parameters fitted to the series.
    pub dof: usize,
    /// P(χ²_dof ≥ Q): small values reject whiteness.
    pub p_value: f64,
}

/// The Ljung–Box test of whiteness over `lags` lags, with `fitted` parameters estimated
/// from the same series (the χ² reference then has `lags − fitted` degrees of freedom).
///
/// # Errors
/// [`Error::InvalidOption`] naming `lags` if it is 0 or not above `fitted`;
/// [`Error::Dimension`] naming `x` if it has no more observed entries than `lags`.
///
/// # Example
/// ```
/// // Q = 0 (no correlation at lag 1 of this sequence): p-value 1.
/// let lb = kalman::diagnostics::ljung_box_test(&[1.0, 2.0, 3.0], 1, 0)?;
/// assert!(lb.statistic.abs() < 1e-12 && (lb.p_value - 1.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub fn ljung_box_test(x: &[f64], lags: usize, fitted: usize) -> Result<LjungBox, Error> {
    if lags == 0 || lags <= fitted {
        return Err(Error::InvalidOption {
            name: "lags",
            value: lags as f64,
            rule: "the Ljung–Box test needs at least one lag more than the fitted parameters",
        });
    }
    let observed = x.iter().filter(|v| !v.is_nan()).count();
    if observed <= lags {
        return Err(Error::Dimension {
            name: "x",
            value: observed,
            rule: "the Ljung–Box test needs more observed values than lags",
        });
    }
    let statistic = ljung_box(x, lags);
    let dof = lags - fitted;
    Ok(LjungBox {
        lags,
        statistic,
        dof,
        p_value: chi2_sf(statistic, dof),
    })
}

/// Collects a filter's innovations step by step for [`Innovations::summary`]: the NIS and
/// its rank, the log-likelihood, and each channel's standardised innovation
/// `e_{k,i}/√Σ_{k,ii}` (stored: one number per channel and step). A channel whose
/// innovation variance is zero at a step (missing, or known exactly) counts as missing
/// there.
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
/// use kalman::diagnostics::Innovations;
/// # fn main() -> Result<(), kalman::Error> {
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[0.9]], &[[1.0]], &[[1.0]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
/// let mut acc = Innovations::new(1, 0.95)?;
/// for z in [0.3, -1.2, 0.8, f64::NAN, 1.9, 0.4, -0.7, 0.1] {
///     let info = filter.step(&[z], None)?;
///     acc.add(&filter, &info)?;
/// }
/// let s = acc.summary(2)?;
/// assert_eq!((s.steps, s.measured_steps), (8, 7));
/// assert!(s.nis_band.0 < s.nis_band.1 && s.channels[0].ljung_box.lags == 2);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct Innovations {
    m: usize,
    confidence: f64,
    /// Per-step NIS band by rank (index = rank, 0..=m).
    step_band: Vec<(f64, f64)>,
    steps: usize,
    measured: usize,
    nis_sum: f64,
    rank_sum: usize,
    outside: usize,
    log_likelihood: f64,
    /// Standardised innovations, step-major (`steps × m`), NaN where missing.
    standardised: Vec<f64>,
}

/// Whiteness of one standardised innovation channel.
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
/// use kalman::diagnostics::Innovations;
/// # fn main() -> Result<(), kalman::Error> {
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[0.5]], &[[1.0]], &[[1.0]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
/// let mut acc = Innovations::new(1, 0.95)?;
/// for z in [0.3, -1.2, 0.8, 1.9, 0.4, -0.7, 0.1, -0.2] {
///     let info = filter.step(&[z], None)?;
///     acc.add(&filter, &info)?;
/// }
/// let ch = &acc.summary(3)?.channels[0];
/// assert_eq!((ch.observed, ch.acf.len()), (8, 4));
/// assert!((ch.acf[0] - 1.0).abs() < 1e-15 && (ch.acf_bound - 1.959_964 / 8f64.sqrt()).abs() < 1e-5);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelWhiteness {
    /// Steps at which the channel was observed.
    pub observed: usize,
    /// Sample autocorrelation ρ_0 … ρ_h ([`autocorrelation`]).
    pub acf: Vec<f64>,
    /// The approximate two-sided band `±z/√N` inside which a white sequence's ρ_k lies
    /// with the summary's confidence (z the normal quantile).
    pub acf_bound: f64,
    /// Ljung–Box over the h lags, no fitted parameters.
    pub ljung_box: LjungBox,
}

/// What [`Innovations::summary`] finds.
///
/// # Example
/// ```
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
/// use kalman::diagnostics::Innovations;
/// # fn main() -> Result<(), kalman::Error> {
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.1]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph)?;
/// let mut acc = Innovations::new(1, 0.95)?;
/// let mut nis = 0.0;
/// for z in [0.3, -1.2, 0.8, 1.9, 0.4, -0.7] {
///     let info = filter.step(&[z], None)?;
///     nis += info.nis.unwrap_or(0.0);
///     acc.add(&filter, &info)?;
/// }
/// let s = acc.summary(2)?;
/// // The mean NIS over the 6 measured steps, and a band around the χ²₆/6 mean of 1.
/// assert!((s.nis_mean - nis / 6.0).abs() < 1e-12 && s.nis_dof == 6);
/// assert!(s.nis_band.0 < 1.0 && 1.0 < s.nis_band.1);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct InnovationSummary {
    /// Steps added.
    pub steps: usize,
    /// Steps with at least one observed measurement (the NIS is defined there).
    pub measured_steps: usize,
    /// Σ of the steps' log-likelihoods: the exact Gaussian log-likelihood of the data.
    pub log_likelihood: f64,
    /// The confidence of the bands.
    pub confidence: f64,
    /// Mean NIS over the measured steps.
    pub nis_mean: f64,
    /// Degrees of freedom of the summed NIS (Σ ranks).
    pub nis_dof: usize,
    /// Two-sided band of the mean NIS of a consistent filter: `χ²_D((1 ∓ c)/2)/N_measured`.
    pub nis_band: (f64, f64),
    /// Fraction of measured steps whose NIS lies outside its own two-sided per-step band
    /// `χ²_rank((1 ∓ c)/2)` (about 1 − c for a consistent filter).
    pub nis_outside_fraction: f64,
    /// One entry per measurement channel.
    pub channels: Vec<ChannelWhiteness>,
}

impl InnovationSummary {
    /// Whether the mean NIS lies in its band.
    pub fn nis_mean_in_band(&self) -> bool {
        self.nis_mean >= self.nis_band.0 && self.nis_mean <= self.nis_band.1
    }
}

/// Two-sided `confidence` band of χ²_dof.
fn chi2_band(dof: usize, confidence: f64) -> (f64, f64) {
    (
        chi2_quantile(0.5 * (1.0 - confidence), dof),
        chi2_quantile(0.5 * (1.0 + confidence), dof),
    )
}

/// The standard normal quantile at `p` ∈ (0, 1), from χ²₁: z_p = sign(p − ½)·√χ²₁(|2p − 1|).
fn normal_quantile(p: f64) -> f64 {
    let q = chi2_quantile((2.0 * p - 1.0).abs(), 1).sqrt();
    if p < 0.5 { -q } else { q }
}

impl Innovations {
    /// An empty collector for `m` measurement channels; bands at `confidence` ∈ (0, 1).
    ///
    /// # Errors
    /// [`Error::Dimension`] naming `m` if it is 0; [`Error::InvalidOption`] naming
    /// `confidence` outside (0, 1).
    pub fn new(m: usize, confidence: f64) -> Result<Self, Error> {
        if m == 0 {
            return Err(Error::Dimension {
                name: "m",
                value: 0,
                rule: "must be at least 1",
            });
        }
        if !(confidence > 0.0 && confidence < 1.0) {
            return Err(Error::InvalidOption {
                name: "confidence",
                value: confidence,
                rule: "must lie strictly between 0 and 1",
            });
        }
        Ok(Self {
            m,
            confidence,
            step_band: (0..=m).map(|r| chi2_band(r, confidence)).collect(),
            steps: 0,
            measured: 0,
            nis_sum: 0.0,
            rank_sum: 0,
            outside: 0,
            log_likelihood: 0.0,
            standardised: Vec::new(),
        })
    }

    /// Adds the step the filter has just taken (`info` is what its `step` returned).
    ///
    /// # Errors
    /// [`Error::Shape`] naming `z` if the filter's m is not the collector's.
    pub fn add<D: Dims>(&mut self, filter: &Filter<D>, info: &StepInfo) -> Result<(), Error> {
        let e = filter.innovation();
        if e.len() != self.m {
            return Err(Error::Shape {
                name: "z",
                rows: e.len(),
                cols: 1,
                expected_rows: self.m,
                expected_cols: 1,
            });
        }
        let sig = filter.innovation_covariance();
        for (i, ei) in e.iter().enumerate() {
            let s = sig[(i, i)];
            self.standardised
                .push(if s > 0.0 { ei / s.sqrt() } else { f64::NAN });
        }
        self.steps += 1;
        self.log_likelihood += info.log_likelihood;
        if let Some(nis) = info.nis {
            self.measured += 1;
            self.nis_sum += nis;
            self.rank_sum += info.rank;
            let (lo, hi) = self.step_band[info.rank.min(self.m)];
            if nis < lo || nis > hi {
                self.outside += 1;
            }
        }
        Ok(())
    }

    /// Steps added so far.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The summary with `lags` lags of autocorrelation and Ljung–Box per channel.
    ///
    /// # Errors
    /// [`Error::InvalidOption`] naming `lags` if it is 0; [`Error::Dimension`] naming `x`
    /// if a channel has no more observed steps than `lags` (too short a record for the test).
    pub fn summary(&self, lags: usize) -> Result<InnovationSummary, Error> {
        let z = normal_quantile(0.5 * (1.0 + self.confidence));
        let channels = (0..self.m)
            .map(|i| {
                let x: Vec<f64> = self
                    .standardised
                    .iter()
                    .skip(i)
                    .step_by(self.m)
                    .copied()
                    .collect();
                let ljung_box = ljung_box_test(&x, lags, 0)?;
                let observed = x.iter().filter(|v| !v.is_nan()).count();
                Ok(ChannelWhiteness {
                    observed,
                    acf: autocorrelation(&x, lags),
                    acf_bound: z / (observed as f64).sqrt(),
                    ljung_box,
                })
            })
            .collect::<Result<Vec<_>, Error>>()?;
        let count = self.measured.max(1) as f64;
        let (lo, hi) = chi2_band(self.rank_sum, self.confidence);
        Ok(InnovationSummary {
            steps: self.steps,
            measured_steps: self.measured,
            log_likelihood: self.log_likelihood,
            confidence: self.confidence,
            nis_mean: self.nis_sum / count,
            nis_dof: self.rank_sum,
            nis_band: (lo / count, hi / count),
            nis_outside_fraction: self.outside as f64 / count,
            channels,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CovarianceForm, DynDims, Model};
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// `n` independent N(0, σ²) samples from a generator seeded with `seed` (shared with
    /// the spectrum tests).
    pub(super) fn white(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| sigma * Distribution::<f64>::sample(&StandardNormal, &mut rng))
            .collect::<Vec<f64>>()
    }

    #[test]
    fn autocorrelation_closed_forms() {
        // Alternating ±1, N = 10: mean 0, c0 = N, c_k = (−1)^k (N − k).
        let x: Vec<f64> = (0..10)
            .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let rho = autocorrelation(&x, 12);
        for (k, r) in rho.iter().enumerate().take(10) {
            let exact = if k % 2 == 0 { 1.0 } else { -1.0 } * (10 - k) as f64 / 10.0;
            // A handful of exact ±1 products: round-off only.
            assert!((r - exact).abs() < 1e-14, "lag {k}: {r} vs {exact}");
        }
        assert!(rho[10].abs() < 1e-15 && rho[11].abs() < 1e-15);
        // Missing entries: x = (1, NaN, 3, 5), observed mean 3, deviations (−2, ·, 0, 2),
        // c0 = 8; lag 1 pairs (3,5) only: 0·2 = 0; lag 2 pairs (1,3), (NaN,5): −2·0 = 0;
        // lag 3 pair (1,5): −4; ρ = (1, 0, 0, −0.5).
        let rho = autocorrelation(&[1.0, f64::NAN, 3.0, 5.0], 3);
        for (r, e) in rho.iter().zip([1.0, 0.0, 0.0, -0.5]) {
            assert!((r - e).abs() < 1e-15, "{rho:?}");
        }
        let rho = autocorrelation(&[2.0; 10], 3);
        assert!(rho.iter().all(|r| r.abs() < 1e-15));
    }

    #[test]
    fn autocorrelation_of_ar1_is_geometric() {
        let phi: f64 = 0.7;
        let n = 20_000;
        let w = white(n + 200, 1.0, 11);
        let mut x = vec![0.0; n + 200];
        for i in 1..x.len() {
            x[i] = phi * x[i - 1] + w[i];
        }
        let x = &x[200..]; // the start-up transient is φ^200 ≈ 1e-31
        let rho = autocorrelation(x, 10);
        for (k, r) in rho.iter().enumerate().skip(1) {
            let exact = phi.powi(k as i32);
            // Bartlett's variance of ρ̂_k for an AR(1):
            // [(1 + φ²)(1 − φ^{2k})/(1 − φ²) − 2kφ^{2k}]/N; 5 standard errors.
            let p2k = phi.powi(2 * k as i32);
            let var = ((1.0 + phi * phi) * (1.0 - p2k) / (1.0 - phi * phi) - 2.0 * k as f64 * p2k)
                / n as f64;
            assert!(
                (r - exact).abs() < 5.0 * var.sqrt(),
                "lag {k}: {r} vs {exact} (sd {})",
                var.sqrt()
            );
        }
    }

    /// The χ² survival function for even degrees of freedom 2j in closed form:
    /// e^{−x/2} Σ_{i<j} (x/2)^i / i!.
    fn chi2_sf_even(x: f64, dof: usize) -> f64 {
        let h = 0.5 * x;
        let mut term = 1.0;
        let mut sum = 0.0;
        for i in 0..dof / 2 {
            if i > 0 {
                term *= h / i as f64;
            }
            sum += term;
        }
        (-h).exp() * sum
    }

    #[test]
    fn ljung_box_p_value_is_the_chi2_tail() {
        for (lags, seed) in [(2, 1), (4, 2), (10, 3), (20, 4)] {
            let mut x = white(300, 1.0, seed);
            // Mix in some correlation so that the statistics spread over the tail too.
            for i in (1..x.len()).rev() {
                x[i] += 0.1 * seed as f64 * x[i - 1];
            }
            let lb = ljung_box_test(&x, lags, 0).expect("valid");
            assert_eq!(lb.dof, lags);
            assert!((lb.statistic - ljung_box(&x, lags)).abs() < 1e-12);
            let exact = chi2_sf_even(lb.statistic, lags);
            // The incomplete-gamma evaluation is accurate to ~1e-14 relative; 1e-10 leaves
            // room for the lanczos ln Γ.
            assert!(
                (lb.p_value - exact).abs() <= 1e-10 * exact,
                "lags {lags}: Q = {}, p {} vs {exact}",
                lb.statistic,
                lb.p_value
            );
        }
        // Fitted parameters reduce the degrees of freedom.
        let x = white(100, 1.0, 5);
        let lb = ljung_box_test(&x, 6, 2).expect("valid");
        assert_eq!(lb.dof, 4);
        assert!((lb.p_value - chi2_sf_even(lb.statistic, 4)).abs() < 1e-12);
        assert!(matches!(
            ljung_box_test(&x, 0, 0),
            Err(Error::InvalidOption { name: "lags", .. })
        ));
        assert!(matches!(
            ljung_box_test(&x, 3, 3),
            Err(Error::InvalidOption { name: "lags", .. })
        ));
        assert!(matches!(
            ljung_box_test(&x[..5], 5, 0),
            Err(Error::Dimension { name: "x", .. })
        ));
    }

    #[test]
    fn ljung_box_separates_white_from_correlated() {
        let x = white(4000, 1.0, 3);
        let q_white = ljung_box(&x, 20);
        // χ²₂₀: 99.9 % quantile 45.3.
        assert!(q_white < 45.3, "{q_white}");
        let mut y = vec![0.0; 4000];
        for i in 1..4000 {
            y[i] = 0.5 * y[i - 1] + x[i];
        }
        assert!(ljung_box(&y, 20) > 500.0);
    }

    #[test]
    fn normal_quantile_matches_tables() {
        // Standard normal table values to 6 digits.
        for (p, z) in [(0.975, 1.959_964), (0.5, 0.0), (0.05, -1.644_854)] {
            assert!((normal_quantile(p) - z).abs() < 1e-5, "{p}");
        }
    }

    /// A local level observed in noise, simulated; the filter with the true model, with R
    /// four times too large, and with a too-small Q.
    fn run(q: f64, r: f64, data: &[f64]) -> (InnovationSummary, f64) {
        let model = Model::new(
            DynDims::new(1, 1, 0).expect("dims"),
            &[[1.0]],
            &[[1.0]],
            &[[q]],
            &[[r]],
        )
        .expect("model");
        let mut f = Filter::new(model, &[0.0], &[[10.0]], CovarianceForm::Joseph).expect("filter");
        let mut acc = Innovations::new(1, 0.95).expect("valid");
        for z in data {
            let info = f.step(&[*z], None).expect("step");
            acc.add(&f, &info).expect("same m");
        }
        let sys = crate::fit::System::new(&[[1.0]], &[[1.0]], &[[q]], &[[r]], &[0.0], &[[10.0]])
            .expect("system");
        let ll = crate::fit::log_likelihood(
            &sys,
            &crate::fit::Series::new(data, 1).expect("series"),
            CovarianceForm::Joseph,
        )
        .expect("ll");
        (acc.summary(10).expect("long enough"), ll)
    }

    #[test]
    fn innovations_of_a_consistent_filter_pass_and_of_a_wrong_one_fail() {
        let (q, r, n) = (0.5f64, 2.0f64, 2000);
        let w = white(n, q.sqrt(), 21);
        let v = white(n, r.sqrt(), 22);
        let mut level = 0.0;
        let mut z = Vec::with_capacity(n);
        for k in 0..n {
            z.push(level + v[k]);
            level += w[k];
        }
        z[17] = f64::NAN;
        let (good, ll) = run(q, r, &z);
        assert_eq!((good.steps, good.measured_steps), (n, n - 1));
        // The same number as the fit module's likelihood: the same steps summed in order.
        assert!((good.log_likelihood - ll).abs() <= 1e-12 * ll.abs());
        assert!(good.nis_mean_in_band(), "{good:?}");
        // About 5 % of the steps fall outside their band: a binomial(1999, 0.05) count has
        // sd ≈ 9.7 steps; ±5 sd is ±2.4 % of the steps.
        assert!((good.nis_outside_fraction - 0.05).abs() < 0.024, "{good:?}");
        // Reject whiteness at p < 1e-3 for a white sequence: a 1-in-1000 event.
        assert!(good.channels[0].ljung_box.p_value > 1e-3, "{good:?}");
        assert_eq!(good.channels[0].observed, n - 1);

        // R four times too large: innovations still white but NIS far too small.
        let (big_r, _) = run(q, 4.0 * r, &z);
        assert!(big_r.nis_mean < big_r.nis_band.0, "{big_r:?}");
        // Q a hundred times too small: the filter lags, its innovations are correlated.
        let (small_q, _) = run(q / 100.0, r, &z);
        assert!(small_q.channels[0].ljung_box.p_value < 1e-6, "{small_q:?}");
        assert!(small_q.nis_mean > small_q.nis_band.1, "{small_q:?}");
    }

    #[test]
    fn innovations_reject_bad_input() {
        assert!(matches!(
            Innovations::new(0, 0.95),
            Err(Error::Dimension { name: "m", .. })
        ));
        assert!(matches!(
            Innovations::new(1, 1.0),
            Err(Error::InvalidOption {
                name: "confidence",
                ..
            })
        ));
        let model = Model::new(
            DynDims::new(1, 2, 0).expect("dims"),
            &[[1.0]],
            &[[1.0], [1.0]],
            &[[1.0]],
            &[[1.0, 0.0], [0.0, 1.0]],
        )
        .expect("model");
        let mut f = Filter::new(model, &[0.0], &[[1.0]], CovarianceForm::Joseph).expect("filter");
        let info = f.step(&[1.0, 2.0], None).expect("step");
        let mut acc = Innovations::new(1, 0.95).expect("valid");
        assert!(matches!(
            acc.add(&f, &info),
            Err(Error::Shape { name: "z", .. })
        ));
        let mut acc = Innovations::new(2, 0.95).expect("valid");
        acc.add(&f, &info).expect("same m");
        assert!(matches!(
            acc.summary(3),
            Err(Error::Dimension { name: "x", .. })
        ));
    }
}
