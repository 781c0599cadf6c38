//! SISO transfer functions in s and in z⁻¹, their controllable canonical realisations, and
//! the bilinear (Tustin) map between them, including Mazurenko's variant.

use nalgebra::{Complex, DMatrix};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::ss::{ContinuousSs, DiscreteSs};
use crate::validate;

/// A continuous SISO transfer function `N(s)/D(s)`.
///
/// Coefficients are in **ascending** powers of s: `num = [n0, n1, …]` means
/// `n0 + n1·s + …`, so the paper's `1/(b s² + a s + 1)` is `num = [1]`, `den = [1, a, b]`.
/// Trailing (highest-power) zeros are trimmed; the model must be proper
/// (deg N ≤ deg D).
///
/// # Example
/// ```
/// use model::ContinuousTf;
/// use model::nalgebra::Complex;
///
/// // 1/(s² + 0.2 s + 1) (ascending powers: den = [1, 0.2, 1]).
/// let h = ContinuousTf::new(vec![1.0], vec![1.0, 0.2, 1.0])?;
/// assert_eq!(h.order(), 2);
/// // At resonance ω = 1 the gain is 1/0.2 = 5.
/// assert!((h.freq_response(1.0).norm() - 5.0).abs() < 1e-12);
/// let _ = h.eval(Complex::new(0.0, 0.0));
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TfRaw")]
pub struct ContinuousTf {
    num: Vec<f64>,
    den: Vec<f64>,
}

deserialize_via! {
    ContinuousTf, TfRaw { num: Vec<f64>, den: Vec<f64> },
    |r| ContinuousTf::new(r.num, r.den)
}

fn check_poly(name: &'static str, p: &[f64]) -> Result<()> {
    if p.is_empty() {
        return Err(Error::InvalidPolynomial {
            name,
            rule: "it has no coefficients",
        });
    }
    if let Some(&v) = p.iter().find(|v| !v.is_finite()) {
        return Err(Error::InvalidParameter {
            name,
            value: v,
            rule: "every coefficient finite",
        });
    }
    Ok(())
}

fn trim_high(mut p: Vec<f64>) -> Vec<f64> {
    while p.len() > 1 && p.last().is_some_and(|v| *v == 0.0) {
        p.pop();
    }
    p
}

/// Product of two polynomials (coefficient convolution).
pub(crate) fn poly_mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

fn poly_pow(base: &[f64], k: usize) -> Vec<f64> {
    let mut out = vec![1.0];
    for _ in 0..k {
        out = poly_mul(&out, base);
    }
    out
}

fn poly_add_into(acc: &mut Vec<f64>, p: &[f64], scale: f64) {
    if acc.len() < p.len() {
        acc.resize(p.len(), 0.0);
    }
    for (a, v) in acc.iter_mut().zip(p) {
        *a += scale * v;
    }
}

fn eval_poly(p: &[f64], x: Complex<f64>) -> Complex<f64> {
    p.iter().rev().fold(Complex::new(0.0, 0.0), |acc, c| {
        acc * x + Complex::new(*c, 0.0)
    })
}

/// How Mazurenko's fuel-level paper replaces one `(1 + z⁻¹)` factor of a Tustin numerator. Both
/// keep the DC gain.
///
/// # Example
/// ```
/// use model::{ContinuousTf, PaperVariant};
///
/// let h = ContinuousTf::new(vec![1.0], vec![1.0, 0.5, 0.25])?;
/// let exact = h.tustin(0.1, None)?;
/// let paper = h.paper_tustin(0.1, PaperVariant::Delay)?;
/// // Both keep the DC gain 1.
/// for tf in [exact, paper] {
///     let dc: f64 = tf.num().iter().sum::<f64>() / tf.den().iter().sum::<f64>();
///     assert!((dc - 1.0).abs() < 1e-12);
/// }
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum PaperVariant {
    /// `(1 + z⁻¹) → 2z⁻¹`: used for the rolling filter; makes it strictly proper (no
    /// feed-through of the rolling noise).
    Delay,
    /// `(1 + z⁻¹) → 2`: used for the quantization-noise filter.
    Drop,
}

impl ContinuousTf {
    /// Builds `N(s)/D(s)` from ascending-power coefficients.
    ///
    /// # Errors
    /// [`Error::InvalidPolynomial`] for an empty or all-zero denominator or an empty
    /// numerator, [`Error::InvalidParameter`] for a non-finite coefficient,
    /// [`Error::Improper`] when deg N > deg D.
    pub fn new(num: Vec<f64>, den: Vec<f64>) -> Result<Self> {
        check_poly("numerator", &num)?;
        check_poly("denominator", &den)?;
        let num = trim_high(num);
        let den = trim_high(den);
        if den.iter().all(|v| *v == 0.0) {
            return Err(Error::InvalidPolynomial {
                name: "denominator",
                rule: "it is identically zero",
            });
        }
        if num.len() > den.len() && num.iter().any(|v| *v != 0.0) {
            return Err(Error::Improper {
                num_degree: num.len() - 1,
                den_degree: den.len() - 1,
            });
        }
        Ok(Self { num, den })
    }

    /// Numerator coefficients, ascending powers of s.
    pub fn num(&self) -> &[f64] {
        &self.num
    }
    /// Denominator coefficients, ascending powers of s.
    pub fn den(&self) -> &[f64] {
        &self.den
    }
    /// Order n = degree of the denominator.
    pub fn order(&self) -> usize {
        self.den.len() - 1
    }

    /// Value at a complex `s`.
    pub fn eval(&self, s: Complex<f64>) -> Complex<f64> {
        eval_poly(&self.num, s) / eval_poly(&self.den, s)
    }

    /// Frequency response `H(jω)`.
    pub fn freq_response(&self, omega: f64) -> Complex<f64> {
        self.eval(Complex::new(0.0, omega))
    }

    /// Controllable canonical realisation: strictly proper part in companion form plus the
    /// feed-through `D = n_n / d_n` (the ratio of the highest-power coefficients).
    ///
    /// With the monic denominator `s^n + a_{n−1}s^{n−1} + … + a_0` the state matrix has ones on
    /// the super-diagonal and last row `[−a_0 … −a_{n−1}]`, `B = e_n`, and `C` holds the
    /// remainder coefficients `[r_0 … r_{n−1}]`.
    pub fn realize(&self) -> ContinuousSs {
        let n = self.order();
        let lead = self.den[n];
        let a_mon: Vec<f64> = self.den.iter().map(|v| v / lead).collect();
        let mut num = self.num.iter().map(|v| v / lead).collect::<Vec<_>>();
        num.resize(n + 1, 0.0);
        let d0 = num[n];
        let mut a = DMatrix::zeros(n, n);
        let mut b = DMatrix::zeros(n, 1);
        let mut c = DMatrix::zeros(1, n);
        for i in 0..n {
            if i + 1 < n {
                a[(i, i + 1)] = 1.0;
            }
            a[(n - 1, i)] = -a_mon[i];
            c[(0, i)] = num[i] - d0 * a_mon[i];
        }
        if n > 0 {
            b[(n - 1, 0)] = 1.0;
        }
        let d = DMatrix::from_element(1, 1, d0);
        ContinuousSs::from_parts_unchecked(a, b, c, d, DMatrix::zeros(n, 0), DMatrix::zeros(0, 0))
    }

    /// The bilinear (Tustin) map `s = κ(1 − z⁻¹)/(1 + z⁻¹)` with `κ = 2/Δt`, or, when
    /// `prewarp = Some(ω)`, `κ = ω / tan(ωΔt/2)` so the discrete response at ω equals the
    /// continuous one. Returns the transfer function in z⁻¹ (denominator normalised to
    /// `den[0] = 1`).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for `dt` ≤ 0 or a pre-warp frequency outside
    /// `(0, π/Δt)`; [`Error::Singular`] when the mapped denominator has a zero constant term
    /// (a pole at s = κ).
    pub fn tustin(&self, dt: f64, prewarp: Option<f64>) -> Result<DiscreteTf> {
        let kappa = tustin_kappa(dt, prewarp)?;
        let n = self.order();
        let (num, den) = self.bilinear_polys(kappa, n);
        DiscreteTf::normalized(num, den, dt)
    }

    /// Mazurenko's variant of Tustin: exact Tustin, then one `(1 + z⁻¹)` factor of the
    /// numerator is replaced as `variant` says. Needs a strictly proper model (deg N < deg D),
    /// so that the factor `(1 + z⁻¹)^{deg D − deg N}` is there to replace.
    ///
    /// # Errors
    /// As [`ContinuousTf::tustin`], plus [`Error::InvalidPolynomial`] when deg N = deg D.
    pub fn paper_tustin(&self, dt: f64, variant: PaperVariant) -> Result<DiscreteTf> {
        let kappa = tustin_kappa(dt, None)?;
        let n = self.order();
        let deg_num = trim_high(self.num.clone()).len() - 1;
        if deg_num >= n {
            return Err(Error::InvalidPolynomial {
                name: "numerator",
                rule: "the paper's Tustin variant needs deg N < deg D (strictly proper)",
            });
        }
        // Numerator mapped with one factor (1 + z⁻¹) fewer, then multiplied by the replacement.
        let (num_reduced, _) = self.bilinear_polys(kappa, n - 1);
        let replacement: &[f64] = match variant {
            PaperVariant::Delay => &[0.0, 2.0],
            PaperVariant::Drop => &[2.0],
        };
        let num = poly_mul(&num_reduced, replacement);
        let (_, den) = self.bilinear_polys(kappa, n);
        DiscreteTf::normalized(num, den, dt)
    }

    /// Numerator and denominator of `H(κ(1−z⁻¹)/(1+z⁻¹))·(1+z⁻¹)^k`… multiplied through by
    /// `(1+z⁻¹)^{n_num}` for the numerator and `(1+z⁻¹)^n` for the denominator, where the
    /// numerator is multiplied by `(1+z⁻¹)^{k − j}` per term `s^j` (k = `num_power`).
    fn bilinear_polys(&self, kappa: f64, num_power: usize) -> (Vec<f64>, Vec<f64>) {
        let n = self.order();
        let minus = [1.0, -1.0];
        let plus = [1.0, 1.0];
        let map = |p: &[f64], power: usize| {
            let mut acc = vec![0.0];
            for (j, c) in p.iter().enumerate() {
                if *c == 0.0 {
                    continue;
                }
                let term = poly_mul(&poly_pow(&minus, j), &poly_pow(&plus, power - j));
                poly_add_into(&mut acc, &term, c * kappa.powi(j as i32));
            }
            acc
        };
        let num = trim_high(self.num.clone());
        (map(&num, num_power), map(&self.den, n))
    }
}

/// κ of the bilinear map: 2/Δt, or ω/tan(ωΔt/2) with pre-warping.
pub(crate) fn tustin_kappa(dt: f64, prewarp: Option<f64>) -> Result<f64> {
    validate::positive("dt", dt)?;
    match prewarp {
        None => Ok(2.0 / dt),
        Some(w) => {
            if !(w.is_finite() && w > 0.0 && w * dt < std::f64::consts::PI) {
                return Err(Error::InvalidParameter {
                    name: "prewarp_frequency",
                    value: w,
                    rule: "finite, > 0 and below the Nyquist frequency π/dt",
                });
            }
            Ok(w / (w * dt / 2.0).tan())
        }
    }
}

/// A discrete SISO transfer function in z⁻¹ with sampling interval `dt`.
///
/// `num = [n0, n1, …]` means `n0 + n1·z⁻¹ + …`; `den = [d0, d1, …]` likewise with `d0 ≠ 0`
/// (causal). The constructor normalises to `d0 = 1`.
///
/// # Example
/// ```
/// use model::DiscreteTf;
///
/// // A moving average (1 + z⁻¹)/2: impulse response 0.5, 0.5, 0, …
/// let ma = DiscreteTf::new(vec![0.5, 0.5], vec![1.0], 0.1)?;
/// let h = ma.impulse_response(3);
/// assert!(h.iter().zip([0.5, 0.5, 0.0]).all(|(a, b)| (a - b).abs() < 1e-15));
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DiscreteTfRaw")]
pub struct DiscreteTf {
    num: Vec<f64>,
    den: Vec<f64>,
    dt: f64,
}

deserialize_via! {
    DiscreteTf, DiscreteTfRaw { num: Vec<f64>, den: Vec<f64>, dt: f64 },
    |r| DiscreteTf::new(r.num, r.den, r.dt)
}

impl DiscreteTf {
    /// Builds `N(z⁻¹)/D(z⁻¹)` and normalises `den[0]` to 1.
    ///
    /// # Errors
    /// [`Error::InvalidPolynomial`] for an empty polynomial or `den[0] = 0`,
    /// [`Error::InvalidParameter`] for non-finite coefficients or `dt` ≤ 0.
    pub fn new(num: Vec<f64>, den: Vec<f64>, dt: f64) -> Result<Self> {
        validate::positive("dt", dt)?;
        check_poly("numerator", &num)?;
        check_poly("denominator", &den)?;
        Self::normalized(num, den, dt)
    }

    fn normalized(num: Vec<f64>, den: Vec<f64>, dt: f64) -> Result<Self> {
        let d0 = den[0];
        if d0 == 0.0 || !d0.is_finite() {
            return Err(Error::InvalidPolynomial {
                name: "denominator",
                rule: "its z⁰ coefficient must be finite and non-zero (causal model)",
            });
        }
        let num = trim_high(num.iter().map(|v| v / d0).collect());
        let den = trim_high(den.iter().map(|v| v / d0).collect());
        Ok(Self { num, den, dt })
    }

    /// Numerator coefficients, ascending powers of z⁻¹.
    pub fn num(&self) -> &[f64] {
        &self.num
    }
    /// Denominator coefficients, ascending powers of z⁻¹ (`den[0] = 1`).
    pub fn den(&self) -> &[f64] {
        &self.den
    }
    /// Sampling interval.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Value at a complex `z`.
    pub fn eval(&self, z: Complex<f64>) -> Complex<f64> {
        let zi = Complex::new(1.0, 0.0) / z;
        eval_poly(&self.num, zi) / eval_poly(&self.den, zi)
    }

    /// Frequency response at ω rad/s: `H(e^{jωΔt})`.
    pub fn freq_response(&self, omega: f64) -> Complex<f64> {
        self.eval(Complex::from_polar(1.0, omega * self.dt))
    }

    /// First `len` samples of the impulse response, by the difference equation.
    pub fn impulse_response(&self, len: usize) -> Vec<f64> {
        let mut h = vec![0.0; len];
        for k in 0..len {
            let mut v = self.num.get(k).copied().unwrap_or(0.0);
            for (i, a) in self.den.iter().enumerate().skip(1) {
                if i <= k {
                    v -= a * h[k - i];
                }
            }
            h[k] = v;
        }
        h
    }

    /// Controllable canonical realisation.
    ///
    /// With `N = max(deg num, deg den)`, state `x_k = [w_{k−N}, …, w_{k−1}]` of the auxiliary
    /// signal `w_k = u_k − a_1 w_{k−1} − … − a_N w_{k−N}`: `F` shifts up and has last row
    /// `[−a_N … −a_1]`, `B = e_N`, `H_{N−i} = n_i − n_0 a_i`, `D = n_0`. The paper's blocks
    /// (its rows 3–4 and 6–7 of A) are exactly this form.
    pub fn realize(&self) -> DiscreteSs {
        let big_n = (self.num.len().max(self.den.len())).saturating_sub(1);
        let mut num = self.num.clone();
        num.resize(big_n + 1, 0.0);
        let mut den = self.den.clone();
        den.resize(big_n + 1, 0.0);
        let n0 = num[0];
        let mut f = DMatrix::zeros(big_n, big_n);
        let mut b = DMatrix::zeros(big_n, 1);
        let mut h = DMatrix::zeros(1, big_n);
        for i in 0..big_n {
            if i + 1 < big_n {
                f[(i, i + 1)] = 1.0;
            }
        }
        for i in 1..=big_n {
            f[(big_n - 1, big_n - i)] = -den[i];
            h[(0, big_n - i)] = num[i] - n0 * den[i];
        }
        if big_n > 0 {
            b[(big_n - 1, 0)] = 1.0;
        }
        let d = DMatrix::from_element(1, 1, n0);
        DiscreteSs::from_parts_unchecked(
            f,
            b,
            h,
            d,
            DMatrix::zeros(big_n, 0),
            DMatrix::zeros(1, 0),
            DMatrix::zeros(0, 0),
            self.dt,
        )
    }
}

impl ContinuousTf {
    /// For coefficient lists built from already-validated parameters (no checks).
    pub(crate) fn from_validated(num: Vec<f64>, den: Vec<f64>) -> Self {
        Self { num, den }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomial_helpers() {
        assert_eq!(poly_mul(&[1.0, 1.0], &[1.0, -1.0]), vec![1.0, 0.0, -1.0]);
        assert_eq!(poly_pow(&[1.0, 1.0], 3), vec![1.0, 3.0, 3.0, 1.0]);
        assert_eq!(trim_high(vec![1.0, 2.0, 0.0, 0.0]), vec![1.0, 2.0]);
        assert_eq!(trim_high(vec![0.0]), vec![0.0]);
    }

    #[test]
    fn tustin_of_integrator_is_trapezoid() {
        let int = ContinuousTf::new(vec![1.0], vec![0.0, 1.0]).expect("valid");
        let d = int.tustin(0.2, None).expect("ok");
        // (Δt/2)(1 + z⁻¹)/(1 − z⁻¹)
        assert!((d.num()[0] - 0.1).abs() < 1e-15 && (d.num()[1] - 0.1).abs() < 1e-15);
        assert!((d.den()[1] + 1.0).abs() < 1e-15);
        let r = d.realize();
        assert!((r.h()[(0, 0)] - 0.2).abs() < 1e-15, "H = Δt");
        assert!((r.d()[(0, 0)] - 0.1).abs() < 1e-15, "D = Δt/2");
    }

    #[test]
    fn static_gain_realises_without_states() {
        let g = ContinuousTf::new(vec![3.0], vec![2.0]).expect("valid");
        let r = g.realize();
        assert_eq!(r.n_states(), 0);
        assert!((r.d()[(0, 0)] - 1.5).abs() < 1e-15);
    }

    #[test]
    fn kappa_with_and_without_prewarp() {
        assert!((tustin_kappa(0.1, None).expect("ok") - 20.0).abs() < 1e-12);
        // Small ωΔt: pre-warped κ → 2/Δt.
        let k = tustin_kappa(0.1, Some(1e-3)).expect("ok");
        assert!((k - 20.0).abs() < 1e-5);
        assert!(tustin_kappa(0.1, Some(std::f64::consts::PI / 0.1)).is_err());
    }
}
