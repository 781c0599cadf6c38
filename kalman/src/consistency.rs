//! Consistency statistics: NEES with χ² bounds, and the χ² distribution itself
//! (regularised incomplete gamma function, quantiles by bisection).
#![allow(non_snake_case)]

use faer::Side;

use crate::model::{check, owned};
use crate::{Error, MatrixInput};

/// ln Γ(x) for x > 0 (Lanczos, g = 7, 9 terms; relative error below 1e-14).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection.
        let pi = core::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * core::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised lower incomplete gamma P(a, x) (series below a + 1, Lentz continued
/// fraction above; absolute error below 1e-14).
fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x < a + 1.0 {
        gamma_p_series(a, x)
    } else {
        (1.0 - gamma_q_fraction(a, x)).max(0.0)
    }
}

/// Regularised upper incomplete gamma Q(a, x) = 1 − P(a, x), by the continued fraction
/// directly above a + 1 so that a far tail keeps its relative precision.
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        (1.0 - gamma_p_series(a, x)).max(0.0)
    } else {
        gamma_q_fraction(a, x)
    }
}

/// Iteration cap of the series and the continued fraction: both need O(√a) terms, so
/// 10⁶ covers a χ² with ~10¹⁰ degrees of freedom.
const GAMMA_MAX_ITER: usize = 1_000_000;

/// P(a, x) by its power series (for x < a + 1).
fn gamma_p_series(a: f64, x: f64) -> f64 {
    let lnpre = a * x.ln() - x - ln_gamma(a);
    let mut sum = 1.0 / a;
    let mut term = sum;
    let mut ap = a;
    for _ in 0..GAMMA_MAX_ITER {
        ap += 1.0;
        term *= x / ap;
        sum += term;
        if term.abs() < sum.abs() * 1e-16 {
            break;
        }
    }
    (sum.ln() + lnpre).exp().min(1.0)
}

/// Q(a, x) by Lentz's continued fraction (for x ≥ a + 1).
fn gamma_q_fraction(a: f64, x: f64) -> f64 {
    let lnpre = a * x.ln() - x - ln_gamma(a);
    let tiny = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..GAMMA_MAX_ITER {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < tiny {
            d = tiny;
        }
        c = b + an / c;
        if c.abs() < tiny {
            c = tiny;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-16 {
            break;
        }
    }
    lnpre.exp() * h
}

/// CDF of the χ² distribution with `dof` degrees of freedom at `x`.
///
/// # Example
/// ```
/// // χ² with 2 degrees of freedom is exponential: F(x) = 1 − e^{−x/2}.
/// assert!((kalman::chi2_cdf(2.0, 2) - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
/// ```
pub fn chi2_cdf(x: f64, dof: usize) -> f64 {
    if dof == 0 {
        return 1.0;
    }
    gamma_p(0.5 * dof as f64, 0.5 * x)
}

/// Survival function of the χ² distribution, `P(χ²_dof ≥ x) = 1 − chi2_cdf(x, dof)`,
/// computed directly in the upper tail so that small p-values keep their relative
/// precision. `dof = 0` (a point mass at 0) gives 0 for x > 0 and 1 otherwise.
///
/// # Example
/// ```
/// // χ² with 2 degrees of freedom: P(χ² ≥ x) = e^{−x/2}, even far in the tail.
/// assert!((kalman::chi2_sf(200.0, 2) / (-100.0f64).exp() - 1.0).abs() < 1e-12);
/// ```
pub fn chi2_sf(x: f64, dof: usize) -> f64 {
    if dof == 0 {
        return if x > 0.0 { 0.0 } else { 1.0 };
    }
    gamma_q(0.5 * dof as f64, 0.5 * x)
}

/// Quantile of the χ² distribution: the `x` with `chi2_cdf(x, dof) = prob` (bisection to
/// relative precision 1e-13). `prob` is clamped to [0, 1]; `dof = 0` gives 0.
///
/// # Example
/// ```
/// // The 95 % point of χ²₁ is 1.96².
/// assert!((kalman::chi2_quantile(0.95, 1) - 1.959_964f64.powi(2)).abs() < 1e-4);
/// let x = kalman::chi2_quantile(0.3, 5);
/// assert!((kalman::chi2_cdf(x, 5) - 0.3).abs() < 1e-10);
/// ```
pub fn chi2_quantile(prob: f64, dof: usize) -> f64 {
    if dof == 0 || prob <= 0.0 {
        return 0.0;
    }
    let k = dof as f64;
    let mut hi = k + 20.0 * (2.0 * k).sqrt() + 100.0;
    if prob >= 1.0 {
        return f64::INFINITY;
    }
    while chi2_cdf(hi, dof) < prob {
        hi *= 2.0;
    }
    let mut lo = 0.0;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi2_cdf(mid, dof) < prob {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-13 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// Normalised estimation error squared `(x − x̂)ᵀ P⁻¹ (x − x̂)` (by a Cholesky solve).
///
/// # Errors
/// [`Error::Shape`] naming `x_est` or `P`; [`Error::NotPositiveSemidefinite`] naming `P`
/// if it is not positive definite.
///
/// `P` is any [`MatrixInput`]: an array, a faer matrix or view (the filter's
/// `covariance()`), or with the feature `nalgebra` a nalgebra matrix.
///
/// # Example
/// ```
/// // Error (1, 2) against P = diag(1, 4): 1²/1 + 2²/4 = 2.
/// let e = kalman::nees(&[1.0, 2.0], &[0.0, 0.0], [[1.0, 0.0], [0.0, 4.0]])?;
/// assert!((e - 2.0).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
pub fn nees(x_true: &[f64], x_est: &[f64], P: impl MatrixInput) -> Result<f64, Error> {
    let n = x_true.len();
    if x_est.len() != n {
        return Err(Error::Shape {
            name: "x_est",
            rows: x_est.len(),
            cols: 1,
            expected_rows: n,
            expected_cols: 1,
        });
    }
    check("P", &P, n, n)?;
    let P = owned(&P);
    let llt = P
        .llt(Side::Lower)
        .map_err(|_| Error::NotPositiveSemidefinite {
            name: "P",
            n,
            min_eigenvalue: f64::NAN,
            tol: 0.0,
        })?;
    let L = llt.L();
    let mut y = vec![0.0; n];
    let mut s2 = 0.0;
    for i in 0..n {
        let mut s = x_true[i] - x_est[i];
        for l in 0..i {
            s -= L[(i, l)] * y[l];
        }
        y[i] = s / L[(i, i)];
        s2 += y[i] * y[i];
    }
    Ok(s2)
}

/// Running average NEES over independent runs (or steps) with its two-sided χ² band:
/// for a consistent filter `runs·mean` is χ² with `n·runs` degrees of freedom.
///
/// # Example
/// ```
/// use faer::mat;
///
/// let p = mat![[1.0]];
/// let mut acc = kalman::Nees::new(1);
/// for e in [-1.0, 0.5, 1.2, -0.3, 0.9, -1.1] {
///     acc.add(&[e], &[0.0], p.as_ref())?;
/// }
/// let (lo, hi) = acc.band(0.95);
/// assert!(lo < acc.mean() && acc.mean() < hi && acc.is_consistent(0.95));
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Debug, Default)]
pub struct Nees {
    n: usize,
    sum: f64,
    count: usize,
}

impl Nees {
    /// An empty accumulator for n-dimensional states.
    pub fn new(n: usize) -> Self {
        Nees {
            n,
            sum: 0.0,
            count: 0,
        }
    }
    /// Adds one sample; returns its NEES.
    ///
    /// # Errors
    /// As [`nees`].
    pub fn add(
        &mut self,
        x_true: &[f64],
        x_est: &[f64],
        P: impl MatrixInput,
    ) -> Result<f64, Error> {
        if x_true.len() != self.n {
            return Err(Error::Shape {
                name: "x_true",
                rows: x_true.len(),
                cols: 1,
                expected_rows: self.n,
                expected_cols: 1,
            });
        }
        let v = nees(x_true, x_est, P)?;
        self.sum += v;
        self.count += 1;
        Ok(v)
    }
    /// Mean NEES so far (NaN if empty).
    pub fn mean(&self) -> f64 {
        self.sum / self.count as f64
    }
    /// Number of samples.
    pub fn count(&self) -> usize {
        self.count
    }
    /// The two-sided `confidence` band of the mean NEES of a consistent filter:
    /// `χ²_{nN}((1 ∓ c)/2) / N`.
    pub fn band(&self, confidence: f64) -> (f64, f64) {
        let dof = self.n * self.count;
        let c = self.count.max(1) as f64;
        (
            chi2_quantile(0.5 * (1.0 - confidence), dof) / c,
            chi2_quantile(0.5 * (1.0 + confidence), dof) / c,
        )
    }
    /// Whether the mean lies in the `confidence` band.
    pub fn is_consistent(&self, confidence: f64) -> bool {
        let (lo, hi) = self.band(confidence);
        let m = self.mean();
        m >= lo && m <= hi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantiles_match_tables() {
        // Reference values from standard χ² tables (5 significant digits), so 1e-4
        // relative is the table's own precision.
        for (p, k, q) in [
            (0.975, 1, 5.0239),
            (0.975, 2, 7.3778),
            (0.975, 10, 20.483),
            (0.025, 10, 3.2470),
            (0.95, 3, 7.8147),
            (0.05, 100, 77.929),
            (0.025, 1, 0.00098207),
        ] {
            let got = chi2_quantile(p, k);
            assert!((got - q).abs() <= 1e-4 * q, "p={p} k={k}: {got} vs {q}");
            assert!((chi2_cdf(got, k) - p).abs() < 1e-10);
        }
    }

    #[test]
    fn nees_of_identity_is_squared_norm() {
        let P = faer::Mat::<f64>::identity(3, 3);
        let v = nees(&[1.0, 2.0, 2.0], &[0.0; 3], P.as_ref());
        assert!(matches!(v, Ok(x) if (x - 9.0).abs() < 1e-12));
        let bad = faer::Mat::<f64>::zeros(3, 3);
        assert!(matches!(
            nees(&[1.0; 3], &[0.0; 3], bad.as_ref()),
            Err(Error::NotPositiveSemidefinite { name: "P", .. })
        ));
    }

    #[test]
    fn nees_takes_arrays_and_names_a_wrong_shape() {
        // P = [[2, 1], [1, 2]], e = (1, −1): P e = e, so eᵀP⁻¹e = eᵀe = 2 exactly.
        let v = nees(&[1.0, -1.0], &[0.0, 0.0], [[2.0, 1.0], [1.0, 2.0]]);
        assert!(matches!(v, Ok(x) if (x - 2.0).abs() < 1e-12));
        assert!(matches!(
            nees(&[1.0, -1.0], &[0.0, 0.0], [[1.0]]),
            Err(Error::Shape {
                name: "P",
                rows: 1,
                expected_rows: 2,
                ..
            })
        ));
    }

    #[cfg(feature = "nalgebra")]
    #[test]
    fn nees_takes_nalgebra_and_agrees_with_an_explicit_solve() {
        let p = nalgebra::dmatrix![4.0, 1.0, 0.0; 1.0, 3.0, 0.5; 0.0, 0.5, 2.0];
        let e = nalgebra::dvector![0.3, -1.2, 0.7];
        // Independent: eᵀ (P⁻¹ e) by nalgebra's LU, not the Cholesky path under test.
        let expected = e.dot(&p.clone().lu().solve(&e).expect("nonsingular"));
        let got = nees(e.as_slice(), &[0.0; 3], &p).expect("SPD");
        assert!((got - expected).abs() < 1e-12 * expected);
    }
}
