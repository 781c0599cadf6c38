//! The per-cycle erector-boom estimator (equations in [`crate::boom`]): direct inversion (2)–(3),
//! the linearised 3×3 solve (7) and the weighted least squares (9)–(10), on fixed-size matrices.
//!
//! The estimator works in the *sensor* frame: with the sensor mounted γ lower along the arc it
//! sees β = α − γ (a_x = g·sin β, a_y = g·cos β + ε·r), estimates β and reports α = β + γ.
//! The state carried between cycles is (s₀, c₀, ε₀) = (sin β, cos β, ε) of the previous cycle.
#![allow(non_snake_case)]

use nalgebra::{Matrix3, Vector3};

use crate::error::Result;
use crate::solver::check_finite_scalars;

use super::config::{
    AngleRecovery, AxWeightLaw, BoomConfig, BoomMethod, BoomSolver, Estimate, RateWeight,
};

/// The state carried between cycles.
#[derive(Debug, Clone, Copy, PartialEq)]
struct State {
    s: f64,
    c: f64,
    /// ε, rad/s².
    eps: f64,
    /// (ε₀ − ε₋₁)/dt, rad/s³.
    rate: f64,
}

/// The per-cycle boom estimator.
///
/// # Example
/// ```
/// use wls::boom::{BoomConfig, BoomEstimator};
///
/// let cfg = BoomConfig::default();
/// let (g, r) = (cfg.g, cfg.sensor_radius);
/// let mut est = BoomEstimator::new(cfg)?;
/// // α = 80°, ε = 0.005 rad/s²: exact readings a_x = g sin α, a_y = g cos α + ε r.
/// let (a, e) = (80f64.to_radians(), 0.005);
/// est.set_state(a, e)?;
/// let out = est.update(g * a.sin(), g * a.cos() + e * r, 0.0)?;
/// assert!((out.angle - a).abs() < 1e-8 && (out.angular_acceleration - e).abs() < 1e-8);
/// # Ok::<(), wls::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct BoomEstimator {
    config: BoomConfig,
    state: Option<State>,
}

/// The largest eigenvalue of a symmetric positive semidefinite 3×3 matrix: Newton on the
/// characteristic polynomial from the trace, which lies right of the largest root, so the
/// iterates fall monotonically onto it (quadratically when it is simple). No transcendental
/// functions. Accuracy: a few ulps for a simple largest eigenvalue; an m-fold one is an m-fold
/// root, determined only to ≈ ε^{1/m} relative (≈ 1e-8 double, 6e-6 triple) — enough for a
/// condition-number diagnostic.
fn lambda_max_spd3(G: &Matrix3<f64>) -> f64 {
    let c2 = G.trace();
    let c1 = G[(0, 0)] * G[(1, 1)] - G[(0, 1)] * G[(1, 0)] + G[(0, 0)] * G[(2, 2)]
        - G[(0, 2)] * G[(2, 0)]
        + G[(1, 1)] * G[(2, 2)]
        - G[(1, 2)] * G[(2, 1)];
    let c0 = G.determinant();
    let mut x = c2;
    for _ in 0..64 {
        let p = ((x - c2) * x + c1) * x - c0;
        let dp = (3.0 * x - 2.0 * c2) * x + c1;
        if dp <= 0.0 {
            break;
        }
        let step = p / dp;
        if step.is_nan() || step <= 4.0 * f64::EPSILON * x {
            // Converged, or rounding made p ≤ 0 at the root: stop without overshooting.
            if step > 0.0 {
                x -= step;
            }
            break;
        }
        x -= step;
    }
    x.max(0.0)
}

/// κ₂(M) = ‖M‖₂·‖M⁻¹‖₂ for a 3×3 M, each norm the square root of the largest eigenvalue of a
/// Gram matrix (largest eigenvalues are computed accurately, unlike σ_min² = λ_min(MᵀM)).
/// M⁻¹ comes from nalgebra's closed-form 3×3 inverse: this diagnostic needs the inverse's
/// norm itself, nothing is solved with it. ∞ if M is singular. Much cheaper than an
/// iterative 3×3 SVD.
fn cond3(M: &Matrix3<f64>) -> f64 {
    let Some(Minv) = M.try_inverse() else {
        return f64::INFINITY;
    };
    let n2 = lambda_max_spd3(&M.tr_mul(M));
    let i2 = lambda_max_spd3(&Minv.tr_mul(&Minv));
    let kappa = (n2 * i2).sqrt();
    if kappa.is_finite() {
        kappa.max(1.0)
    } else {
        f64::INFINITY
    }
}

/// The five fixed rows of (9) in reduced triangular form: min ‖A₅x − b₅‖ ≡ min ‖T x − q‖
/// up to a constant, with T upper triangular (R of a Householder QR of [A₅ | b₅], or Lᵀ and
/// L⁻¹H₅ᵀV₅z₅ from the Cholesky factor of the normal matrix).
#[derive(Debug, Clone, Copy)]
struct Reduced {
    T: Matrix3<f64>,
    q: Vector3<f64>,
}

impl Reduced {
    /// Adds the ε₀ row e = e₀ with weight v₆ and solves: (x, upper T with TᵀT = HᵀVH).
    fn with_eps_row(&self, v6: f64, e0: f64) -> Option<(Vector3<f64>, Matrix3<f64>)> {
        let (mut T, mut q) = (self.T, self.q);
        // The new whitened row is (0, 0, √v₆ | √v₆·e₀): one Givens rotation against the third
        // row of T zeroes it and touches only T₃₃ and q₃.
        let t = T[(2, 2)];
        // T₃₃ and √v₆ are O(1)–O(10³) here: no overflow guard (hypot) needed.
        let rho = (t * t + v6).sqrt();
        if rho > 0.0 {
            q[2] = (t * q[2] + v6 * e0) / rho;
            T[(2, 2)] = rho;
        }
        Some((T.solve_upper_triangular(&q)?, T))
    }
}

/// In-place Householder triangularisation of the M×3 block of `a` (the fourth column is the
/// right-hand side and is transformed with it): afterwards the upper 3×3 of `a` is R and
/// `a[0..3][3]` is the head of Qᵀb.
fn householder<const M: usize>(a: &mut [[f64; 4]; M]) {
    for j in 0..3 {
        let norm = (j..M).map(|i| a[i][j] * a[i][j]).sum::<f64>().sqrt();
        if norm <= 0.0 {
            continue;
        }
        // α against the sign of x₀, so v₀ = x₀ − α never cancels.
        let alpha = if a[j][j] > 0.0 { -norm } else { norm };
        // v = x − α·e₁, stored in a scratch column; β = 2/(vᵀv) = 1/(norm·(norm + |x₀|)).
        let mut v = [0.0; M];
        for i in j..M {
            v[i] = a[i][j];
        }
        v[j] -= alpha;
        let vtv = (j..M).map(|i| v[i] * v[i]).sum::<f64>();
        if vtv <= 0.0 {
            continue;
        }
        let beta = 2.0 / vtv;
        for col in j..4 {
            let dot = (j..M).map(|i| v[i] * a[i][col]).sum::<f64>() * beta;
            for i in j..M {
                a[i][col] -= dot * v[i];
            }
        }
    }
}

/// |s| may exceed 1 only by rounding for the angle to be defined.
const SIN_SLACK: f64 = 4.0 * f64::EPSILON;

/// The root of an increasing-through-zero h on the bracket [0, 1] (h(0) < 0 < h(1), given by
/// the caller), by Newton's method safeguarded by bisection: (root, evaluations of h).
///
/// `h` returns (h(x), h′(x)). A Newton step is taken only when it lands strictly inside the
/// current bracket; otherwise the bracket is halved. So every evaluation is strictly
/// inside (0, 1), where h means something, and never at a bracket end, whose sign is known.
/// The search stops once a step moves x by at most `tol / scale` or after `max_it` evaluations.
/// (A stop on the bracket's width would add nothing: x is an end of the updated bracket and the
/// next point lies inside it, so the step is never wider than the bracket.)
fn newton_in_unit_bracket(
    mut h: impl FnMut(f64) -> (f64, f64),
    x0: f64,
    scale: f64,
    tol: f64,
    max_it: u32,
) -> (f64, u32) {
    let (mut a, mut b) = (0.0, 1.0);
    let mut x = x0;
    let mut evaluations = 0;
    while evaluations < max_it {
        evaluations += 1;
        let (f, df) = h(x);
        if f < 0.0 {
            a = x;
        } else {
            b = x;
        }
        // x is now an end of the bracket, so a tangent with h′ ≤ 0 points out of it (or to ±∞,
        // or NaN at h′ = 0): the bounds alone reject every step but a Newton step of h′ > 0.
        let newton = x - f / df;
        let next = if newton > a && newton < b {
            newton
        } else {
            0.5 * (a + b)
        };
        let step = (next - x).abs();
        x = next;
        if step * scale <= tol {
            break;
        }
    }
    (x, evaluations)
}

impl BoomEstimator {
    /// A new estimator; the first `update` is the start-up cycle.
    ///
    /// # Errors
    /// An invalid configuration (see [`BoomConfig::validate`]).
    pub fn new(config: BoomConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            state: None,
        })
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &BoomConfig {
        &self.config
    }

    /// Forgets the state; the next `update` is a start-up cycle again.
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// Seeds the state with a known boom angle α (rad) and ε (rad/s²) instead of a start-up
    /// cycle.
    ///
    /// # Errors
    /// Non-finite inputs.
    pub fn set_state(&mut self, angle: f64, angular_acceleration: f64) -> Result<()> {
        check_finite_scalars(&[
            ("angle", angle),
            ("angular_acceleration", angular_acceleration),
        ])?;
        let beta = angle - self.config.sensor_offset_angle;
        self.state = Some(State {
            s: beta.sin(),
            c: beta.cos(),
            eps: angular_acceleration,
            rate: 0.0,
        });
        Ok(())
    }

    /// The 3×3 H of eq. (7) for a given (s₀, c₀).
    fn h3(&self, s0: f64, c0: f64) -> Matrix3<f64> {
        let (g, r) = (self.config.g, self.config.sensor_radius);
        Matrix3::new(g, 0.0, 0.0, 0.0, g, r, s0, c0, 0.0)
    }

    /// Direct inversion (2)–(3): (s, c, ε, defined).
    fn direct(&self, ax: f64, ay: f64) -> (f64, f64, f64, bool) {
        let (g, r) = (self.config.g, self.config.sensor_radius);
        let q = g * g - ax * ax;
        if q >= 0.0 {
            let root = q.sqrt();
            (ax / g, root / g, (ay - root) / r, true)
        } else {
            (ax / g, f64::NAN, f64::NAN, false)
        }
    }

    /// v₆ = numerator/(1 + gain·|ε̇|)² with ε̇ given in rad/s³ and converted to the configured unit.
    fn v6(&self, rate: f64) -> f64 {
        let w = &self.config.weights;
        let rate_u = rate * self.config.epsilon_rate_unit.per_radian();
        w.eps_prior / (1.0 + w.eps_rate_gain * rate_u.abs()).powi(2)
    }

    /// Reduces the five rows of (9) that do not change within a cycle (a_x, a_y, the unit
    /// circle, s₀, c₀) to a 3×3 form; the ε₀ row is added per v₆ by [`Reduced::with_eps_row`].
    fn reduce(&self, st: &State, ax: f64, ay: f64) -> Option<Reduced> {
        let cfg = &self.config;
        let w = &cfg.weights;
        let (g, r) = (cfg.g, cfg.sensor_radius);
        let k = cfg.epsilon_unit.per_radian();
        let v1 = match w.ax_law {
            AxWeightLaw::CosPrevious => w.ax_scale * st.c.abs(),
            AxWeightLaw::Constant => w.ax_scale,
        };
        let (w1, w2, w3, w4, w5) = (
            v1.sqrt(),
            w.ay.sqrt(),
            w.unit_circle.sqrt(),
            w.sin_prior.sqrt(),
            w.cos_prior.sqrt(),
        );
        // Rows of the whitened [V^{1/2}H | V^{1/2}z] for eqs. (9), without the ε₀ row.
        let mut a = [
            [w1 * g, 0.0, 0.0, w1 * ax],
            [0.0, w2 * g, w2 * r / k, w2 * ay],
            [w3 * st.s, w3 * st.c, 0.0, w3],
            [w4, 0.0, 0.0, w4 * st.s],
            [0.0, w5, 0.0, w5 * st.c],
        ];
        match cfg.solver {
            BoomSolver::Qr => {
                householder(&mut a);
                let T = Matrix3::new(
                    a[0][0], a[0][1], a[0][2], 0.0, a[1][1], a[1][2], 0.0, 0.0, a[2][2],
                );
                Some(Reduced {
                    T,
                    q: Vector3::new(a[0][3], a[1][3], a[2][3]),
                })
            }
            BoomSolver::NormalEquations => {
                // The paper's (10): form HᵀVH and HᵀVz, factor N = L·Lᵀ. Needs the five fixed
                // rows to determine all three unknowns (a_y weight > 0).
                let mut N = Matrix3::zeros();
                let mut rhs = Vector3::zeros();
                for row in &a {
                    let h = Vector3::new(row[0], row[1], row[2]);
                    N += h * h.transpose();
                    rhs += h * row[3];
                }
                let L = N.cholesky()?.unpack();
                let q = L.solve_lower_triangular(&rhs)?;
                Some(Reduced {
                    T: L.transpose(),
                    q,
                })
            }
        }
    }

    /// The WLS cycle: (x with ε in rad/s², T with TᵀT = HᵀVH, v₆ evaluations made).
    fn wls_cycle(
        &self,
        prev: &State,
        ax: f64,
        ay: f64,
    ) -> Option<(Vector3<f64>, Matrix3<f64>, u32)> {
        let cfg = &self.config;
        let k = cfg.epsilon_unit.per_radian();
        let reduced = self.reduce(prev, ax, ay)?;
        let e0 = prev.eps * k;
        let solve = |rate: f64| {
            reduced
                .with_eps_row(self.v6(rate), e0)
                .map(|(x, T)| (Vector3::new(x[0], x[1], x[2] / k), T))
        };
        let (max_it, tol) = match cfg.rate_weight {
            RateWeight::PreviousCycle => {
                let (x, T) = solve(prev.rate)?;
                return Some((x, T, 1));
            }
            RateWeight::FixedPoint {
                max_iterations,
                tolerance,
            } => (max_iterations, tolerance),
        };
        // Only v₆ changes within the cycle, and in the reduced form the third unknown is a
        // closed-form function of v₆: e(v₆) = e₅ + θ·(e₀ − e₅) with θ = v₆/(T₃₃² + v₆) ∈ [0, 1).
        // The self-consistent v₆ is a root of h(θ) = θ − φ(θ), φ(θ) = θ of v₆ evaluated at the
        // ε̇ that θ implies. h(0) ≤ 0 ≤ h(1), so the root is bracketed; plain fixed-point
        // iteration θ ← φ(θ) converges slowly or oscillates when ε̇ is large (noisy readings),
        // so the root is found by the Illinois variant of regula falsi on [0, 1]. The full
        // solution is back-substituted once with the converged v₆.
        let t = reduced.T[(2, 2)];
        let (rate, iterations) = if t.abs() < f64::MIN_POSITIVE {
            // The five rows say nothing about ε: e = e₀ whatever v₆ > 0.
            (0.0, 0)
        } else {
            let e5 = reduced.q[2] / t;
            let d = e0 - e5;
            let rate_of = |theta: f64| ((e5 + theta * d) / k - prev.eps) / cfg.dt;
            let w = &cfg.weights;
            // ε̇(θ) in the configured rate unit is affine in θ: r(θ) = r₀ + θ·r₁.
            let unit = cfg.epsilon_rate_unit.per_radian();
            let (r0, r1) = (rate_of(0.0) * unit, d / k / cfg.dt * unit);
            let t2 = t * t;
            // h(θ) and h'(θ), with v₆ = a/u², u = 1 + b·|r(θ)|.
            let h = |theta: f64| {
                let r = r0 + theta * r1;
                let u = 1.0 + w.eps_rate_gain * r.abs();
                let v6 = w.eps_prior / (u * u);
                let dv6 = -2.0 * w.eps_prior * w.eps_rate_gain * r.signum() * r1 / (u * u * u);
                let den = t2 + v6;
                (theta - v6 / den, 1.0 - t2 * dv6 / (den * den))
            };
            let to_eps = d.abs() / k;
            let (root, iterations) = if w.eps_prior <= 0.0 || to_eps <= tol {
                // v₆ ≡ 0, or e₀ = e₅ and v₆ cannot move the answer.
                (0.0, 0)
            } else {
                // h(0) < 0 < h(1) as T₃₃ ≠ 0 and the numerator of v₆ is > 0. Started from the
                // one-solve answer with ε̇ of the previous cycle.
                let v_prev = self.v6(prev.rate);
                newton_in_unit_bracket(h, v_prev / (t2 + v_prev), to_eps, tol, max_it)
            };
            (rate_of(root), iterations)
        };
        let (x, T) = solve(rate)?;
        Some((x, T, iterations))
    }

    /// Processes one cycle's accelerometer reading (m/s², sensor axes).
    ///
    /// # Errors
    /// [`Error::NonFinite`](crate::Error::NonFinite) if any reading is NaN or infinite (the
    /// state is left unchanged).
    pub fn update(&mut self, a_x: f64, a_y: f64, a_z: f64) -> Result<Estimate> {
        check_finite_scalars(&[("a_x", a_x), ("a_y", a_y), ("a_z", a_z)])?;
        let cfg = &self.config;
        let gamma = cfg.sensor_offset_angle;
        let mounting_ok = a_z.abs() <= cfg.mounting_tolerance;
        let undefined = |s, c, kappa, iterations, startup| Estimate {
            angle: f64::NAN,
            angular_acceleration: f64::NAN,
            condition_number: kappa,
            defined: false,
            mounting_ok,
            sin_sensor: s,
            cos_sensor: c,
            iterations,
            startup,
        };
        let defined = |beta: f64, s, c, eps, kappa, iterations, startup| Estimate {
            angle: beta + gamma,
            angular_acceleration: eps,
            condition_number: kappa,
            defined: true,
            mounting_ok,
            sin_sensor: s,
            cos_sensor: c,
            iterations,
            startup,
        };
        let condition = |m: &Matrix3<f64>| {
            if cfg.compute_condition {
                cond3(m)
            } else {
                f64::NAN
            }
        };
        let prev = match (cfg.method, self.state) {
            (BoomMethod::Direct, _) | (_, None) => {
                let startup = self.state.is_none() && cfg.method != BoomMethod::Direct;
                let (s, c, eps, ok) = self.direct(a_x, a_y);
                if !ok {
                    return Ok(undefined(s, c, f64::INFINITY, 0, startup));
                }
                let kappa = condition(&self.h3(s, c));
                // No ε̇: a start-up cycle has no previous ε, and Direct never reads it.
                self.state = Some(State {
                    s,
                    c,
                    eps,
                    rate: 0.0,
                });
                return Ok(defined(s.asin(), s, c, eps, kappa, 0, startup));
            }
            (_, Some(p)) => p,
        };
        let (x, kappa, iterations) = if cfg.method == BoomMethod::Linear3 {
            let H = self.h3(prev.s, prev.c);
            match H.lu().solve(&Vector3::new(a_x, a_y, 1.0)) {
                Some(x) => (x, condition(&H), 0),
                None => return Ok(undefined(f64::NAN, f64::NAN, f64::INFINITY, 0, false)),
            }
        } else {
            match self.wls_cycle(&prev, a_x, a_y) {
                Some((x, T, iterations)) => (x, condition(&T), iterations),
                None => return Ok(undefined(f64::NAN, f64::NAN, f64::INFINITY, 0, false)),
            }
        };
        let (s, c, eps) = (x[0], x[1], x[2]);
        self.state = Some(State {
            s,
            c,
            eps,
            rate: (eps - prev.eps) / cfg.dt,
        });
        let beta = match cfg.angle_recovery {
            AngleRecovery::Arcsin if s.abs() <= 1.0 + SIN_SLACK => s.clamp(-1.0, 1.0).asin(),
            AngleRecovery::Arcsin => return Ok(undefined(s, c, kappa, iterations, false)),
            AngleRecovery::Atan2 => s.atan2(c),
        };
        Ok(defined(beta, s, c, eps, kappa, iterations, false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{SMatrix, SymmetricEigen};

    /// The Newton λ_max agrees with nalgebra's symmetric eigensolver, also with a (nearly)
    /// double largest eigenvalue where Newton converges only linearly.
    #[test]
    fn lambda_max_matches_symmetric_eigen() {
        let cases = [
            Matrix3::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 1.0),
            Matrix3::from_diagonal(&Vector3::new(2.0, 2.0, 1e-12)),
            Matrix3::from_diagonal(&Vector3::new(1.0, 1.0 - 1e-9, 0.5)),
            Matrix3::new(1e8, 3.0, 0.0, 3.0, 1.0, 0.0, 0.0, 0.0, 1e-8),
        ];
        for G in cases {
            let reference = SymmetricEigen::new(G).eigenvalues.max();
            // Linear convergence near a double root stops within ~1e-8 relative of it.
            assert!((lambda_max_spd3(&G) / reference - 1.0).abs() < 1e-8, "{G}");
        }
        // The stopping rule is relative to λ: a simple largest eigenvalue comes out to a few
        // ulps in any unit (1e-13 leaves the reference's own ε·‖G‖ and a margin).
        for s in [1e-12, 1.0, 1e12] {
            let G = cases[0] * s;
            let reference = SymmetricEigen::new(G).eigenvalues.max();
            assert!(
                (lambda_max_spd3(&G) / reference - 1.0).abs() < 1e-13,
                "unit {s}"
            );
        }
    }

    /// The hand-written Householder reduction gives the R of nalgebra's QR (up to row signs)
    /// and the same least-squares solution.
    /// The second case has columns almost along e₁ and e₂ (off-axis parts 1e-9): with the
    /// reflector's sign chosen against cancellation, v₀ = x₀ + ‖x‖ keeps every digit; the
    /// other sign would cancel x₀ − ‖x‖ to nothing and leave the column unreduced by 1e-9.
    #[test]
    fn householder_matches_nalgebra_qr() {
        for a in [
            [
                [9.8, 0.0, 0.0, 1.0],
                [0.0, 9.8, 0.43, 2.0],
                [5.0, 7.0, 0.0, 10.0],
                [1.0, 0.0, 0.0, 0.3],
                [0.0, 1.0, 0.0, 0.9],
            ],
            [
                [2.0, 0.5, 0.0, 1.0],
                [1e-9, 3.0, 0.25, 2.0],
                [1e-9, 1e-9, 1.0, 0.5],
                [0.0, 1e-9, 0.5, 0.3],
                [0.0, 0.0, 0.25, 0.9],
            ],
        ] {
            householder_case(a);
        }
    }

    fn householder_case(mut a: [[f64; 4]; 5]) {
        let A = SMatrix::<f64, 5, 3>::from_fn(|i, j| a[i][j]);
        let b = SMatrix::<f64, 5, 1>::from_fn(|i, _| a[i][3]);
        householder(&mut a);
        let R = A.qr().r();
        for i in 0..3 {
            for j in i..3 {
                assert!((a[i][j].abs() - R[(i, j)].abs()).abs() < 1e-12);
            }
        }
        let T = Matrix3::new(
            a[0][0], a[0][1], a[0][2], 0.0, a[1][1], a[1][2], 0.0, 0.0, a[2][2],
        );
        let x = T
            .solve_upper_triangular(&Vector3::new(a[0][3], a[1][3], a[2][3]))
            .expect("full rank");
        let reference = (A.transpose() * A)
            .cholesky()
            .expect("SPD")
            .solve(&(A.transpose() * b));
        assert!((x - reference).norm() < 1e-12);
    }

    #[test]
    fn condition_number_of_singular_matrix_is_infinite() {
        assert!(cond3(&Matrix3::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 0.0, 1.0)).is_infinite());
        // A triple eigenvalue is a triple root of the characteristic polynomial, known only to
        // ≈ ε^(1/3) ≈ 6e-6 relative: a diagnostic accuracy, documented on `lambda_max_spd3`.
        assert!((cond3(&Matrix3::identity()) - 1.0).abs() < 1e-4);
    }

    /// Runs the bracketed search on `h`, recording every point it evaluates.
    fn traced_search(
        h: impl Fn(f64) -> (f64, f64),
        x0: f64,
        scale: f64,
        tol: f64,
    ) -> (f64, u32, Vec<f64>) {
        let mut points = Vec::new();
        let (x, n) = newton_in_unit_bracket(
            |x| {
                points.push(x);
                h(x)
            },
            x0,
            scale,
            tol,
            200,
        );
        (x, n, points)
    }

    fn strictly_inside(points: &[f64]) -> bool {
        points.iter().all(|&x| x > 0.0 && x < 1.0)
    }

    /// arctan(20(x − 0.2)) is the classic function on which plain Newton diverges: from
    /// x₀ = 0.9 its first step lands near −14. The safeguard must bisect instead, stay inside the
    /// bracket, and still stop within `tol / scale` of the root.
    #[test]
    fn newton_steps_that_leave_the_bracket_are_replaced_by_bisection() {
        let h = |x: f64| {
            let u = 20.0 * (x - 0.2);
            (u.atan(), 20.0 / (1.0 + u * u))
        };
        assert!(
            0.9 - h(0.9).0 / h(0.9).1 < 0.0,
            "the plain Newton step leaves [0, 1]"
        );
        for scale in [1.0, 1e-3, 1e3] {
            let tol = 1e-10;
            let (x, n, points) = traced_search(h, 0.9, scale, tol);
            assert!(strictly_inside(&points), "{points:?}");
            assert_eq!(n as usize, points.len());
            // It stops at the first step of at most tol/scale, and not before.
            let mut steps: Vec<f64> = points.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
            steps.push((x - points[points.len() - 1]).abs());
            let (last, earlier) = steps.split_last().expect("at least one evaluation");
            assert!(last * scale <= tol, "scale {scale}: last step {last}");
            assert!(earlier.iter().all(|s| s * scale > tol), "{steps:?}");
            // Near the root Newton converges quadratically, so the last step (≤ tol/scale)
            // bounds the error to far below it; a factor 10 leaves room for round-off.
            assert!((x - 0.2).abs() <= 10.0 * tol / scale, "scale {scale}: {x}");
            assert!(n < 100, "{n} evaluations");
        }
    }

    /// A Newton step landing exactly on an end of the bracket is not taken: the end's sign is
    /// known, so evaluating there would waste the step (and at 0 or 1 the weight it stands for
    /// is degenerate). Both functions are piecewise linear, increasing, with the root at 0.5,
    /// and chosen so the first step is exact in binary.
    #[test]
    fn a_newton_step_onto_an_end_of_the_bracket_is_replaced_by_bisection() {
        // From 0.75, h = x/4: the tangent meets zero at exactly 0, the lower end.
        let onto_lower = |x: f64| {
            if x > 0.6 {
                (x / 4.0, 0.25)
            } else {
                (x - 0.5, 1.0)
            }
        };
        assert!((0.75 - onto_lower(0.75).0 / onto_lower(0.75).1).abs() <= 0.0);
        // From 0.25, h = x − 1: the tangent meets zero at exactly 1, the upper end.
        let onto_upper = |x: f64| {
            if x < 0.4 {
                (x - 1.0, 1.0)
            } else {
                (x - 0.5, 1.0)
            }
        };
        assert!((0.25 - onto_upper(0.25).0 / onto_upper(0.25).1 - 1.0).abs() <= 0.0);
        for (h, x0) in [
            (&onto_lower as &dyn Fn(f64) -> (f64, f64), 0.75),
            (&onto_upper, 0.25),
        ] {
            let (x, _, points) = traced_search(h, x0, 1.0, 1e-12);
            assert!(strictly_inside(&points), "{points:?}");
            // Once inside the linear piece around the root, one Newton step is exact.
            assert!((x - 0.5).abs() <= 1e-12, "{x}");
        }
    }
}
