//! States on manifolds: a stored point with a `⊞`/`⊟` pair onto a tangent space of smaller
//! dimension (a unit quaternion: 4 stored, 3 tangent), and the unit-quaternion arithmetic an
//! attitude model is written with.
//!
//! The filters keep the mean as a stored point and the covariance (with Q and the
//! Jacobians) in the tangent space at the mean: the error-state ("multiplicative") form of
//! Markley, "Attitude error representations for Kalman filtering" (J. Guidance 26, 2003)
//! and of Hertzberg et al., "Integrating generic sensor fusion algorithms with sound state
//! representations through encapsulation of manifolds" (Information Fusion 14, 2013), whose
//! `⊞`/`⊟` axioms the implementations here satisfy:
//! `x ⊞ 0 = x`, `x ⊞ (y ⊟ x) = y`, `(x ⊞ δ) ⊟ x = δ` (for δ inside the chart's range: a
//! rotation by less than π).

/// A state manifold: points stored in [`Manifold::stored`] numbers, perturbed through a
/// tangent space of [`Manifold::dim`] dimensions.
///
/// ```
/// use kalman::nonlinear::{Manifold, Part, Product};
/// let s = Product::new([Part::Quaternion, Part::Vector(3)]);
/// assert_eq!((s.dim(), s.stored()), (6, 7));
/// let x = [1.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3];
/// let mut y = [0.0; 7];
/// s.boxplus(&x, &[0.0, 0.0, 0.5, 1.0, 1.0, 1.0], &mut y);
/// let mut d = [0.0; 6];
/// s.boxminus(&y, &x, &mut d);
/// assert!((d[2] - 0.5).abs() < 1e-15 && (d[3] - 1.0).abs() < 1e-15);
/// ```
pub trait Manifold {
    /// The tangent dimension: the filter's n, the size of P, Q and the Jacobians.
    fn dim(&self) -> usize;
    /// Numbers per stored point.
    fn stored(&self) -> usize;
    /// `out = x ⊞ δ` (`x`, `out` stored; `δ` tangent). Returns a point on the manifold
    /// (a quaternion of unit norm) for any finite input.
    fn boxplus(&self, x: &[f64], d: &[f64], out: &mut [f64]);
    /// `out = a ⊟ b`, the tangent vector at `b` that carries `b` to `a` (`a`, `b` stored;
    /// `out` tangent).
    fn boxminus(&self, a: &[f64], b: &[f64], out: &mut [f64]);
}

/// One factor of a [`Product`] manifold.
///
/// ```
/// use kalman::nonlinear::{Manifold, Part, Product};
/// // A heading wraps: 3 rad plus 0.5 rad is 3.5 − 2π.
/// let heading = Product::new([Part::Angle]);
/// let mut out = [0.0];
/// heading.boxplus(&[3.0], &[0.5], &mut out);
/// assert!((out[0] - (3.5 - 2.0 * std::f64::consts::PI)).abs() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Part {
    /// `k` entries of ℝᵏ: `⊞` is `+`, `⊟` is `−`.
    Vector(usize),
    /// An angle in radians, kept in [−π, π): `⊞` and `⊟` wrap.
    Angle,
    /// A unit quaternion `(w, x, y, z)`, scalar first, Hamilton product, perturbed on the
    /// right (in the body frame): `q ⊞ δθ = q ⊗ exp(δθ)` with `exp(δθ)` the rotation by
    /// `|δθ|` about `δθ/|δθ|`, the result renormalised; `a ⊟ b = log(b* ⊗ a)`, the
    /// rotation vector of the shorter of the two rotations (q and −q are one attitude).
    Quaternion,
}

impl Part {
    /// (tangent, stored) dimensions.
    fn dims(self) -> (usize, usize) {
        match self {
            Part::Vector(k) => (k, k),
            Part::Angle => (1, 1),
            Part::Quaternion => (3, 4),
        }
    }
}

/// A product of [`Part`]s, stored one after the other (its tangent likewise): a state
/// `(q, b)` of attitude and gyro bias is `Product::new([Part::Quaternion, Part::Vector(3)])`.
///
/// ```
/// use kalman::nonlinear::{Manifold, Part, Product, quaternion};
/// let s = Product::new([Part::Quaternion, Part::Vector(3)]);
/// assert!(s.is_curved() && s.parts().len() == 2);
/// // Turning the identity by a quarter turn about z in the tangent space, and back.
/// let x = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
/// let mut y = [0.0; 7];
/// s.boxplus(&x, &[0.0, 0.0, std::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0], &mut y);
/// let v = quaternion::rotate([y[0], y[1], y[2], y[3]], [1.0, 0.0, 0.0]);
/// assert!(v[0].abs() < 1e-15 && (v[1] - 1.0).abs() < 1e-15);
/// ```
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Product {
    parts: Vec<Part>,
    dim: usize,
    stored: usize,
}

impl Product {
    /// The product of `parts`, in order.
    pub fn new(parts: impl IntoIterator<Item = Part>) -> Self {
        let parts: Vec<Part> = parts.into_iter().collect();
        let (dim, stored) = parts.iter().fold((0, 0), |(d, s), p| {
            let (pd, ps) = p.dims();
            (d + pd, s + ps)
        });
        Self { parts, dim, stored }
    }

    /// The factors.
    pub fn parts(&self) -> &[Part] {
        &self.parts
    }

    /// Whether any factor is stored redundantly (a quaternion) or wraps (an angle): false
    /// for a plain vector state.
    pub fn is_curved(&self) -> bool {
        self.parts.iter().any(|p| !matches!(p, Part::Vector(_)))
    }

    /// Visits the parts with their tangent and stored offsets.
    #[inline(always)]
    fn each(&self, mut visit: impl FnMut(Part, usize, usize)) {
        let (mut t, mut s) = (0, 0);
        for &p in &self.parts {
            visit(p, t, s);
            let (pd, ps) = p.dims();
            t += pd;
            s += ps;
        }
    }
}

impl Manifold for Product {
    fn dim(&self) -> usize {
        self.dim
    }
    fn stored(&self) -> usize {
        self.stored
    }
    fn boxplus(&self, x: &[f64], d: &[f64], out: &mut [f64]) {
        self.each(|p, t, s| match p {
            Part::Vector(k) => {
                for i in 0..k {
                    out[s + i] = x[s + i] + d[t + i];
                }
            }
            Part::Angle => out[s] = wrap(x[s] + d[t]),
            Part::Quaternion => {
                let q = [x[s], x[s + 1], x[s + 2], x[s + 3]];
                let r = quaternion::normalise(quaternion::mul(
                    q,
                    quaternion::exp([d[t], d[t + 1], d[t + 2]]),
                ));
                out[s..s + 4].copy_from_slice(&r);
            }
        });
    }
    fn boxminus(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        self.each(|p, t, s| match p {
            Part::Vector(k) => {
                for i in 0..k {
                    out[t + i] = a[s + i] - b[s + i];
                }
            }
            Part::Angle => out[t] = wrap(a[s] - b[s]),
            Part::Quaternion => {
                let qa = [a[s], a[s + 1], a[s + 2], a[s + 3]];
                let qb = [b[s], b[s + 1], b[s + 2], b[s + 3]];
                let v = quaternion::log(quaternion::mul(quaternion::conjugate(qb), qa));
                out[t..t + 3].copy_from_slice(&v);
            }
        });
    }
}

/// `a` wrapped into [−π, π).
#[inline]
fn wrap(a: f64) -> f64 {
    use core::f64::consts::PI;
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    // rem_euclid can return 2π for an input a hair below a multiple of 2π.
    if w >= PI { w - 2.0 * PI } else { w }
}

/// Unit-quaternion arithmetic, `(w, x, y, z)` scalar first, Hamilton convention: `q`
/// rotates body-frame vectors into the reference frame, `v_ref = q ⊗ v_body ⊗ q*`.
pub mod quaternion {
    /// The Hamilton product `a ⊗ b`.
    #[inline]
    pub fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        [
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        ]
    }

    /// The conjugate `q*` (the inverse of a unit quaternion).
    #[inline]
    pub fn conjugate(q: [f64; 4]) -> [f64; 4] {
        [q[0], -q[1], -q[2], -q[3]]
    }

    /// `q / |q|` (a zero or non-finite q gives non-finite entries, which the filters
    /// report as a non-finite state).
    #[inline]
    pub fn normalise(q: [f64; 4]) -> [f64; 4] {
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
    }

    /// The unit quaternion of the rotation vector `v` (angle `|v|` about `v/|v|`):
    /// `(cos(|v|/2), sin(|v|/2) v/|v|)`, by its Taylor series below `|v|` = 1e-4 (where
    /// the series' first omitted term is below 1e-18 relative).
    #[inline]
    pub fn exp(v: [f64; 3]) -> [f64; 4] {
        let t2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        let t = t2.sqrt();
        let (c, s) = if t < 1e-4 {
            // cos(t/2) = 1 − t²/8 + t⁴/384, sin(t/2)/t = 1/2 − t²/48 + t⁴/3840.
            (
                1.0 - t2 / 8.0 + t2 * t2 / 384.0,
                0.5 - t2 / 48.0 + t2 * t2 / 3840.0,
            )
        } else {
            let (sin, cos) = (0.5 * t).sin_cos();
            (cos, sin / t)
        };
        [c, s * v[0], s * v[1], s * v[2]]
    }

    /// The rotation vector of the unit quaternion `q` (the inverse of [`exp`]), for the
    /// shorter rotation: `q` and `−q` give the same vector, of length at most π.
    #[inline]
    pub fn log(q: [f64; 4]) -> [f64; 3] {
        let q = if q[0] < 0.0 {
            [-q[0], -q[1], -q[2], -q[3]]
        } else {
            q
        };
        let s = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        // angle = 2·atan2(s, w); the factor angle/s, by its series for small s
        // (2/w · (1 − s²/(3w²))), is finite at s = 0.
        let f = if s < 1e-8 {
            2.0 / q[0] * (1.0 - s * s / (3.0 * q[0] * q[0]))
        } else {
            2.0 * s.atan2(q[0]) / s
        };
        [f * q[1], f * q[2], f * q[3]]
    }

    /// `q ⊗ v ⊗ q*`: the body-frame vector `v` in the reference frame.
    #[inline]
    pub fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
        let r = mul(mul(q, [0.0, v[0], v[1], v[2]]), conjugate(q));
        [r[1], r[2], r[3]]
    }

    /// `q* ⊗ v ⊗ q`: the reference-frame vector `v` in the body frame.
    #[inline]
    pub fn rotate_inverse(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
        rotate(conjugate(q), v)
    }
}

#[cfg(test)]
mod tests {
    use super::quaternion::{exp, log, mul, normalise, rotate};
    use super::*;

    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn exp_and_log_are_inverse_across_the_series_switch_and_up_to_pi() {
        for t in [0.0, 1e-9, 9.9e-5, 1.01e-4, 0.3, 2.0, 3.1] {
            let v = [0.6 * t, -0.8 * t, 0.0];
            let q = exp(v);
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!((n - 1.0).abs() < 4e-16, "|exp| = {n} at {t}");
            // log's round-off near π grows as ε/sin(θ/2)·θ: 1e-15 absolute here.
            assert!(close(&log(q), &v, 1e-15), "{t}: {:?}", log(q));
        }
    }

    #[test]
    fn a_quarter_turn_about_z_takes_x_to_y() {
        let q = exp([0.0, 0.0, core::f64::consts::FRAC_PI_2]);
        let v = rotate(q, [1.0, 0.0, 0.0]);
        // Each component is a sum of products of entries of magnitude ≤ 1, as w² − z²
        // for x: a few units of ε.
        assert!(close(&v, &[0.0, 1.0, 0.0], 1e-15), "{v:?}");
    }

    #[test]
    fn boxplus_and_boxminus_satisfy_the_manifold_axioms() {
        let s = Product::new([Part::Quaternion, Part::Angle, Part::Vector(2)]);
        let x = {
            let q = normalise([0.3, -0.5, 0.7, 0.4]);
            [q[0], q[1], q[2], q[3], 3.0, 1.0, -2.0]
        };
        let d = [0.4, -1.2, 2.0, 0.5, 0.25, -0.5];
        let (mut y, mut back, mut e) = ([0.0; 7], [0.0; 7], [0.0; 6]);
        s.boxplus(&x, &[0.0; 6], &mut y);
        assert!(close(&y, &x, 1e-16), "x ⊞ 0 = x");
        s.boxplus(&x, &d, &mut y);
        s.boxminus(&y, &x, &mut e);
        // (x ⊞ δ) ⊟ x = δ: the angle 3 + 0.5 wrapped and unwrapped, the rotation of
        // |δθ| = 2.4 < π recovered.
        assert!(close(&e, &d, 4e-15), "{e:?}");
        s.boxplus(&x, &e, &mut back);
        assert!(close(&back, &y, 1e-15), "x ⊞ (y ⊟ x) = y");
        let q = &y[..4];
        assert!((q.iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 4e-16);
    }

    #[test]
    fn boxminus_takes_the_shorter_rotation_and_ignores_the_sign_of_q() {
        let s = Product::new([Part::Quaternion]);
        let a = exp([0.0, 0.0, 3.0]);
        let b = exp([0.0, 0.0, -3.0]);
        let mut d = [0.0; 3];
        s.boxminus(&a, &b, &mut d);
        // From −3 rad to +3 rad about z the short way is −(2π − 6) rad.
        assert!(
            (d[2] + (2.0 * core::f64::consts::PI - 6.0)).abs() < 1e-14,
            "{d:?}"
        );
        let neg = a.map(|v| -v);
        let mut d2 = [0.0; 3];
        s.boxminus(&neg, &b, &mut d2);
        assert!(close(&d, &d2, 1e-15));
        let _ = mul(a, b);
    }

    #[test]
    fn an_angle_wraps_into_minus_pi_to_pi() {
        use core::f64::consts::PI;
        for a in [PI, -PI, 3.0 * PI, 7.0, -7.0, 2.0 * PI - 1e-17] {
            let w = wrap(a);
            assert!((-PI..PI).contains(&w), "{a} → {w}");
            assert!(
                ((a - w) / (2.0 * PI)).fract().abs() < 1e-12
                    || ((a - w) / (2.0 * PI)).fract().abs() > 1.0 - 1e-12
            );
        }
    }
}
