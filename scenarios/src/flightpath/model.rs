//! The filter's model of flight-path reconstruction: the kinematic equations driven by the
//! IMU, augmented with the instrument errors, as a `kalman::nonlinear::GenericModel` (f and
//! h generic over the scalar, so `AutoDiff` gives the EKF's Jacobians and the output-error
//! fit its sensitivities from the same code).
//!
//! **State** (n = 21; 9 when not augmented): body velocity `(u, v, w)` (m/s), Euler angles
//! `(φ, θ, ψ)` (rad), position `(x_N, y_E, h)` (m, altitude up), then the instrument
//! errors `b_a` (3, m/s²), `b_ω` (3, rad/s), `λ_V, b_V, λ_α, b_α, λ_β, b_β` (constant states).
//!
//! **Inputs**: the IMU's specific force `a_m` and body rates `ω_m`, corrected to
//! `a = a_m − b_a`, `(p, q, r) = ω_m − b_ω`. The kinematic equations (Klein & Morelli,
//! *Aircraft System Identification*, 2006, eqs. 10.1–10.3; Mulder et al., "Non-linear
//! aircraft flight path reconstruction review and new advances", Prog. Aerospace Sci. 35,
//! 1999, §2; Jategaonkar, *Flight Vehicle System Identification*, ch. 10):
//!
//! ```text
//! u̇ = r v − q w − g sin θ + a_x          φ̇ = p + tan θ (q sin φ + r cos φ)
//! v̇ = p w − r u + g cos θ sin φ + a_y     θ̇ = q cos φ − r sin φ
//! ẇ = q u − p v + g cos θ cos φ + a_z     ψ̇ = (q sin φ + r cos φ) / cos θ
//! (ẋ_N, ẏ_E, −ḣ) = C_nb(φ, θ, ψ) (u, v, w)
//! ```
//!
//! The filter's time grid is the union of every sensor's stamps; step k integrates over its
//! own `Δt_k = t_{k+1} − t_k` by one classical Runge–Kutta step with the IMU reading at
//! each stage time (t_k, the midpoint, t_{k+1}) from a cubic through the nearest samples
//! ([`super::data::FlightData::imu_at`]; the model holds the stamp table and the inputs and
//! indexes them by k, so the filters are called with `u = None`).
//!
//! **Outputs** (m = 9): `V_m = (1 + λ_V) V + b_V`, `α_m = (1 + λ_α) α + b_α`,
//! `β_m = (1 + λ_β) β + b_β` (`V = |(u, v, w)|`, `α = atan2(w, u)`, `β = asin(v/V)`), the
//! Euler angles (AHRS) and the position (GNSS). A sensor that did not sample at step k
//! has NaN in `z_k`; the ψ residual is wrapped to (−π, π].
//!
//! **Process noise**: the IMU's white noise enters through the inputs,
//! `Q_k = G(x̂) S G(x̂)ᵀ Δt_k` with `S = diag(σ²_a, σ²_ω)·Δt_imu` (the noise intensity of
//! samples of standard deviation σ at the IMU interval) and `G = ∂ẋ/∂(a, ω)` at the point
//! x̂ the driver sets before each step ([`FlightModel::set_point`]: the prediction).

use kalman::nonlinear::{GenericModel, Scalar};

pub use super::data::M;
use super::data::{Grid, Stages};
/// An angle wrapped to (−π, π] (NaN stays NaN), as the simulated AHRS wraps its heading.
pub use sensors::flight::wrap;

/// Gravity, m/s².
pub const GRAVITY: f64 = 9.806_65;
/// Kinematic states.
pub const N_KIN: usize = 9;
/// Instrument-error states.
pub const N_ERR: usize = 12;

/// The noise model the filter assumes, SI standard deviations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// IMU per-sample noise (a_x, a_y, a_z, p, q, r).
    pub imu: [f64; 6],
    /// Nominal IMU interval, s.
    pub imu_dt: f64,
    /// Measurement noise (V, α, β, φ, θ, ψ, x_N, y_E, h).
    pub r: [f64; M],
}

/// The kinematic model over one record's grid (see the module documentation).
#[derive(Debug, Clone)]
pub struct FlightModel {
    t: Vec<f64>,
    input: Vec<Stages>,
    augmented: bool,
    intensity: [f64; 6],
    r: [f64; M],
    point: [f64; 5],
}

impl FlightModel {
    /// The model over `grid` with the noise `noise`; `augmented` adds the instrument errors.
    pub fn new(grid: &Grid, noise: &Noise, augmented: bool) -> Self {
        Self {
            t: grid.t.clone(),
            input: grid.input.clone(),
            augmented,
            intensity: noise.imu.map(|s| s * s * noise.imu_dt),
            r: noise.r.map(|s| s * s),
            point: [100.0, 0.0, 0.0, 0.0, 0.0],
        }
    }

    /// The state dimension (21, or 9 without the instrument errors).
    pub fn n(&self) -> usize {
        if self.augmented { N_KIN + N_ERR } else { N_KIN }
    }

    /// Steps of the grid.
    pub fn steps(&self) -> usize {
        self.t.len()
    }

    /// Sets the point Q is evaluated at (the state about to be predicted from).
    pub fn set_point(&mut self, x: &[f64]) {
        self.point = [x[0], x[1], x[2], x[3], x[4]];
    }

    /// Δt of step k (0 for the last).
    fn dt(&self, k: usize) -> f64 {
        match (self.t.get(k), self.t.get(k + 1)) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }

    /// The kinematic derivative at `x` (9 states) with the corrected inputs.
    fn rates<T: Scalar>(x: &[T], a: &[T; 3], w: &[T; 3]) -> [T; N_KIN] {
        let (u, v, wv) = (x[0], x[1], x[2]);
        let (sf, cf) = x[3].sin_cos();
        let (st, ct) = x[4].sin_cos();
        let (sp, cp) = x[5].sin_cos();
        let (p, q, r) = (w[0], w[1], w[2]);
        let qs_rc = q * sf + r * cf;
        [
            r * v - q * wv - st * GRAVITY + a[0],
            p * wv - r * u + ct * sf * GRAVITY + a[1],
            q * u - p * v + ct * cf * GRAVITY + a[2],
            p + st / ct * qs_rc,
            q * cf - r * sf,
            qs_rc / ct,
            u * ct * cp + v * (sf * st * cp - cf * sp) + wv * (cf * st * cp + sf * sp),
            u * ct * sp + v * (sf * st * sp + cf * cp) + wv * (cf * st * sp - sf * cp),
            u * st - v * sf * ct - wv * cf * ct,
        ]
    }
}

impl GenericModel for FlightModel {
    fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, k: usize, out: &mut [T]) {
        out.copy_from_slice(x);
        let dt = self.dt(k);
        if dt <= 0.0 {
            return;
        }
        let stages = self.input.get(k).copied().unwrap_or([[0.0; 6]; 3]);
        // The corrected inputs (a, ω) at one stage.
        let corrected = |m: &[f64; 6]| {
            let mut a: [T; 3] = std::array::from_fn(|i| T::from(m[i]));
            let mut w: [T; 3] = std::array::from_fn(|i| T::from(m[3 + i]));
            if self.augmented {
                for i in 0..3 {
                    a[i] -= x[N_KIN + i];
                    w[i] -= x[N_KIN + 3 + i];
                }
            }
            (a, w)
        };
        let (a0, w0) = corrected(&stages[0]);
        let (a1, w1) = corrected(&stages[1]);
        let (a2, w2) = corrected(&stages[2]);
        let mut stage = [x[0]; N_KIN];
        let k1 = Self::rates(x, &a0, &w0);
        for i in 0..N_KIN {
            stage[i] = x[i] + k1[i] * (0.5 * dt);
        }
        let k2 = Self::rates(&stage, &a1, &w1);
        for i in 0..N_KIN {
            stage[i] = x[i] + k2[i] * (0.5 * dt);
        }
        let k3 = Self::rates(&stage, &a1, &w1);
        for i in 0..N_KIN {
            stage[i] = x[i] + k3[i] * dt;
        }
        let k4 = Self::rates(&stage, &a2, &w2);
        for i in 0..N_KIN {
            out[i] = x[i] + (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * (dt / 6.0);
        }
    }

    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        let (u, v, w) = (x[0], x[1], x[2]);
        let speed = (u * u + v * v + w * w).sqrt();
        let alpha = w.atan2(u);
        let beta = (v / speed).asin();
        if self.augmented {
            let e = &x[N_KIN..];
            out[0] = speed * (e[6] + 1.0) + e[7];
            out[1] = alpha * (e[8] + 1.0) + e[9];
            out[2] = beta * (e[10] + 1.0) + e[11];
        } else {
            out[0] = speed;
            out[1] = alpha;
            out[2] = beta;
        }
        out[3..9].copy_from_slice(&x[3..9]);
    }

    fn q(&self, k: usize, out: &mut [f64]) {
        let n = self.n();
        out.fill(0.0);
        let dt = self.dt(k);
        let [u, v, w, phi, theta] = self.point;
        let (sf, cf) = phi.sin_cos();
        let (st, ct) = theta.sin_cos();
        // G = ∂ẋ/∂(a, ω) (9×6, row-major), the noise entering with the inputs' sign.
        let mut g = [[0.0; 6]; N_KIN];
        for i in 0..3 {
            g[i][i] = 1.0;
        }
        // ∂(ω × … ) terms of the velocity equations.
        g[0][4] = -w;
        g[0][5] = v;
        g[1][3] = w;
        g[1][5] = -u;
        g[2][3] = -v;
        g[2][4] = u;
        // Euler-angle rates.
        g[3][3] = 1.0;
        g[3][4] = st / ct * sf;
        g[3][5] = st / ct * cf;
        g[4][4] = cf;
        g[4][5] = -sf;
        g[5][4] = sf / ct;
        g[5][5] = cf / ct;
        for i in 0..N_KIN {
            for j in 0..N_KIN {
                let s: f64 = (0..6).map(|l| g[i][l] * self.intensity[l] * g[j][l]).sum();
                out[i + j * n] = s * dt;
            }
        }
    }

    fn r(&self, _k: usize, out: &mut [f64]) {
        out.fill(0.0);
        for i in 0..M {
            out[i + i * M] = self.r[i];
        }
    }

    fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
            *o = x - y;
        }
        out[5] = wrap(out[5]);
    }
}
