//! Resampling schemes (multinomial, stratified, systematic, residual) as functions of the
//! weights and the uniforms, the effective sample size, and log-weight normalisation.

use serde::{Deserialize, Serialize};

use crate::Error;

/// How a particle filter draws the ancestors of its next particles from the weights.
///
/// Each scheme maps the normalised weights `W_i` (i < N) and a few uniforms on [0, 1) to
/// `M` ancestor indices whose expected copy counts are `M W_i` (all four are unbiased).
/// With `C_j = W_0 + … + W_j` the cumulative weights, the index a position `p ∈ [0, 1)` picks is
/// the first `j` with `p < C_j` (the inverse distribution function; a particle of weight 0
/// is never picked):
///
/// | scheme | positions | uniforms |
/// |---|---|---|
/// | [`Multinomial`](Self::Multinomial) | `p_i = u_i`, in the order given | M |
/// | [`Stratified`](Self::Stratified) | `p_i = (i + u_i)/M` | M |
/// | [`Systematic`](Self::Systematic) | `p_i = (i + u)/M` | 1 |
/// | [`Residual`](Self::Residual) | `⌊M W_i⌋` copies of each `i` first, then the remaining `R = M − Σ⌊M W_i⌋` positions `u_r` drawn multinomially from the residual weights `(M W_i − ⌊M W_i⌋)/R` | R |
///
/// Stratified and systematic resampling keep every copy count within 2 (stratified) and 1
/// (systematic) of `M W_i`; residual keeps at least `⌊M W_i⌋`; multinomial has the largest
/// variance. The functions are those of FilterPy's `filterpy.monte_carlo` (same uniforms,
/// same indices; FilterPy 1.4.5's residual scheme differs in its random part, which draws
/// from `W_i − ⌊M W_i⌋` instead of `M W_i − ⌊M W_i⌋`).
///
/// References: J. S. Liu and R. Chen, *Sequential Monte Carlo methods for dynamic systems*,
/// 1998 (residual); G. Kitagawa, *Monte Carlo filter and smoother for non-Gaussian nonlinear
/// state space models*, 1996 (stratified, systematic); R. Douc, O. Cappé, E. Moulines,
/// *Comparison of resampling schemes for particle filtering*, 2005.
///
/// ```
/// use kalman::particle::Resampling;
/// # fn main() -> Result<(), kalman::Error> {
/// let weights = [0.1, 0.6, 0.3];
/// let mut out = [0; 3];
/// // Positions (0.5 + i)/3 = 1/6, 1/2, 5/6 against C = 0.1, 0.7, 1.0.
/// Resampling::Systematic.resample(&weights, &[0.5], &mut out)?;
/// assert_eq!(out, [1, 1, 2]);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Resampling {
    /// Independent draws from the weights (the "naive" roulette).
    Multinomial,
    /// One uniform per stratum `[i/M, (i+1)/M)`.
    Stratified,
    /// One uniform shared by all strata (the default: lowest variance of the four in
    /// practice, one uniform per resampling).
    #[default]
    Systematic,
    /// Deterministic copies of the integer parts, multinomial draws for the rest.
    Residual,
}

impl Resampling {
    /// The number of uniforms [`resample`](Self::resample) takes for `count` indices from
    /// `weights` (normalised internally): `count` for multinomial and stratified, 1 for
    /// systematic, `count − Σ⌊count·W_i⌋` for residual.
    ///
    /// # Errors
    /// [`Error::ParticleInput`] for invalid weights (see [`resample`](Self::resample)).
    pub fn uniforms_needed(self, weights: &[f64], count: usize) -> Result<usize, Error> {
        let total = check_weights(weights)?;
        Ok(match self {
            Self::Multinomial | Self::Stratified => count,
            Self::Systematic => 1,
            Self::Residual => count - deterministic_copies(weights, total, count),
        })
    }

    /// Draws `out.len()` ancestor indices from `weights` with the given uniforms (see the
    /// table above; [`uniforms_needed`](Self::uniforms_needed) says how many). The weights
    /// need not be normalised.
    ///
    /// # Errors
    /// [`Error::ParticleInput`] naming `weights` (empty, negative, non-finite or all zero),
    /// `uniforms` (a count other than the scheme needs, an entry outside [0, 1)) or `out`
    /// (empty).
    pub fn resample(
        self,
        weights: &[f64],
        uniforms: &[f64],
        out: &mut [usize],
    ) -> Result<(), Error> {
        let total = check_weights(weights)?;
        if out.is_empty() {
            return Err(Error::ParticleInput {
                name: "out",
                rule: "at least one index must be drawn".into(),
            });
        }
        let needed = self.uniforms_needed(weights, out.len())?;
        if uniforms.len() != needed {
            return Err(Error::ParticleInput {
                name: "uniforms",
                rule: format!(
                    "{self:?} resampling of {} indices needs {needed} uniforms, got {}",
                    out.len(),
                    uniforms.len()
                ),
            });
        }
        if let Some((i, u)) = uniforms
            .iter()
            .enumerate()
            .find(|(_, u)| !(0.0..1.0).contains(*u))
        {
            return Err(Error::ParticleInput {
                name: "uniforms",
                rule: format!("entry {i} = {u} is outside [0, 1)"),
            });
        }
        let mut cumulative = vec![0.0; weights.len()];
        self.draw(weights, total, uniforms, &mut cumulative, out);
        Ok(())
    }

    /// The kernel behind [`resample`](Self::resample), on checked input: `total` the sum of
    /// the weights, `cumulative` a scratch of `weights.len()`, `uniforms` exactly as many as
    /// needed.
    pub(crate) fn draw(
        self,
        weights: &[f64],
        total: f64,
        uniforms: &[f64],
        cumulative: &mut [f64],
        out: &mut [usize],
    ) {
        let count = out.len();
        match self {
            Self::Multinomial => {
                cumulate(weights.iter().map(|w| w / total), cumulative);
                for (o, &u) in out.iter_mut().zip(uniforms) {
                    *o = search(cumulative, u);
                }
            }
            Self::Stratified | Self::Systematic => {
                cumulate(weights.iter().map(|w| w / total), cumulative);
                let last = last_positive(cumulative);
                let m = count as f64;
                let mut j = 0;
                for (i, o) in out.iter_mut().enumerate() {
                    let u = if self == Self::Stratified {
                        uniforms[i]
                    } else {
                        uniforms[0]
                    };
                    let p = (i as f64 + u) / m;
                    while j < last && cumulative[j] <= p {
                        j += 1;
                    }
                    *o = j;
                }
            }
            Self::Residual => {
                let m = count as f64;
                let mut k = 0;
                for (i, w) in weights.iter().enumerate() {
                    let copies = (m * w / total).floor() as usize;
                    for _ in 0..copies.min(count - k) {
                        out[k] = i;
                        k += 1;
                    }
                }
                if k < count {
                    let fractional = weights.iter().map(|w| {
                        let x = m * w / total;
                        x - x.floor()
                    });
                    cumulate(fractional, cumulative);
                    let mut rest = cumulative[cumulative.len() - 1];
                    if rest <= 0.0 {
                        // Only round-off left a position over: draw it from the weights.
                        cumulate(weights.iter().copied(), cumulative);
                        rest = total;
                    }
                    for c in cumulative.iter_mut() {
                        *c /= rest;
                    }
                    for (o, &u) in out[k..].iter_mut().zip(uniforms) {
                        *o = search(cumulative, u);
                    }
                }
            }
        }
    }
}

/// Running sums of `values` into `out`.
fn cumulate(values: impl Iterator<Item = f64>, out: &mut [f64]) {
    let mut s = 0.0;
    for (o, v) in out.iter_mut().zip(values) {
        s += v;
        *o = s;
    }
}

/// The last index whose cumulative weight rises (the last particle of positive weight).
fn last_positive(cumulative: &[f64]) -> usize {
    let n = cumulative.len();
    (1..n)
        .rev()
        .find(|&j| cumulative[j] > cumulative[j - 1])
        .unwrap_or(0)
}

/// The first `j` with `u < C_j`; a `u` at or above the last sum (round-off) picks the last
/// particle of positive weight.
fn search(cumulative: &[f64], u: f64) -> usize {
    let j = cumulative.partition_point(|&c| c <= u);
    if j >= cumulative.len() {
        last_positive(cumulative)
    } else {
        j
    }
}

/// `Σ⌊count·W_i⌋`, at most `count`.
pub(crate) fn deterministic_copies(weights: &[f64], total: f64, count: usize) -> usize {
    let m = count as f64;
    let copies: usize = weights
        .iter()
        .map(|w| (m * w / total).floor() as usize)
        .sum();
    copies.min(count)
}

/// Checks that the weights are finite, non-negative and not all zero; returns their sum.
fn check_weights(weights: &[f64]) -> Result<f64, Error> {
    if weights.is_empty() {
        return Err(Error::ParticleInput {
            name: "weights",
            rule: "at least one weight is needed".into(),
        });
    }
    if let Some((i, w)) = weights
        .iter()
        .enumerate()
        .find(|(_, w)| !w.is_finite() || **w < 0.0)
    {
        return Err(Error::ParticleInput {
            name: "weights",
            rule: format!("entry {i} = {w} is not a finite non-negative number"),
        });
    }
    let total: f64 = weights.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return Err(Error::ParticleInput {
            name: "weights",
            rule: format!("the weights sum to {total}, not a positive finite number"),
        });
    }
    Ok(total)
}

/// The effective sample size `1 / Σ W_i²` of normalised weights `W` (N for equal weights, 1
/// when one particle holds all the weight); the weights are normalised here, so any positive
/// multiple gives the same value.
///
/// # Errors
/// [`Error::ParticleInput`] for weights that are empty, negative, non-finite or all zero.
///
/// ```
/// let ess = kalman::particle::effective_sample_size(&[1.0, 1.0, 2.0])?;
/// assert!((ess - 16.0 / 6.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub fn effective_sample_size(weights: &[f64]) -> Result<f64, Error> {
    let total = check_weights(weights)?;
    let squares: f64 = weights.iter().map(|w| (w / total) * (w / total)).sum();
    Ok(1.0 / squares)
}

/// Normalises log-weights in place and writes their exponentials into `linear` (one `exp`
/// per particle); returns `ln Σ exp(v_i)`, −∞ (and nothing written) when every entry is −∞.
pub(crate) fn normalise(log: &mut [f64], linear: &mut [f64]) -> f64 {
    let max = log.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return max;
    }
    let mut s = 0.0;
    for (l, v) in linear.iter_mut().zip(log.iter()) {
        *l = (v - max).exp();
        s += *l;
    }
    let log_sum = max + s.ln();
    for (l, v) in linear.iter_mut().zip(log.iter_mut()) {
        *l /= s;
        *v -= log_sum;
    }
    log_sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_weight_particles_are_never_picked() {
        let w = [0.0, 0.5, 0.0, 0.5, 0.0];
        let mut out = [0; 5];
        for scheme in [Resampling::Multinomial, Resampling::Stratified] {
            scheme
                .resample(&w, &[0.0, 0.2, 0.5, 0.999_999, 0.0], &mut out)
                .expect("valid");
            assert!(out.iter().all(|&i| i == 1 || i == 3), "{scheme:?}: {out:?}");
        }
        Resampling::Systematic
            .resample(&w, &[0.999_999_999], &mut out)
            .expect("valid");
        assert_eq!(out, [1, 1, 3, 3, 3]);
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let mut out = [0; 2];
        let e = Resampling::Systematic.resample(&[1.0, f64::NAN], &[0.5], &mut out);
        assert!(matches!(
            e,
            Err(Error::ParticleInput {
                name: "weights",
                ..
            })
        ));
        let e = Resampling::Systematic.resample(&[0.0, 0.0], &[0.5], &mut out);
        assert!(matches!(
            e,
            Err(Error::ParticleInput {
                name: "weights",
                ..
            })
        ));
        let e = Resampling::Systematic.resample(&[1.0, 1.0], &[1.0], &mut out);
        assert!(matches!(
            e,
            Err(Error::ParticleInput {
                name: "uniforms",
                ..
            })
        ));
        let e = Resampling::Stratified.resample(&[1.0, 1.0], &[0.5], &mut out);
        assert!(matches!(
            e,
            Err(Error::ParticleInput {
                name: "uniforms",
                ..
            })
        ));
        let e = Resampling::Residual.resample(&[1.0, 1.0], &[], &mut []);
        assert!(matches!(e, Err(Error::ParticleInput { name: "out", .. })));
    }

    #[test]
    fn normalise_is_exact_on_small_cases() {
        let mut linear = [0.0; 2];
        let mut log = [0.0, 0.0];
        assert!((normalise(&mut log, &mut linear) - 2f64.ln()).abs() < 1e-15);
        assert!(linear.iter().all(|w| (w - 0.5).abs() < 1e-15));
        // 1000 + ln 3 is stored to ulp(1000) = 1.1e-13, and that rounding is in the
        // exponent of the first weight: 0.25 to about 3e-14, so 1e-13.
        let mut log = [1000.0, 1000.0 + 3f64.ln()];
        assert!((normalise(&mut log, &mut linear) - (1000.0 + 4f64.ln())).abs() < 1e-12);
        assert!((linear[0] - 0.25).abs() < 1e-13 && (log[0] - 0.25f64.ln()).abs() < 1e-12);
        let mut log = [f64::NEG_INFINITY; 2];
        assert!(normalise(&mut log, &mut linear).is_infinite());
    }
}
