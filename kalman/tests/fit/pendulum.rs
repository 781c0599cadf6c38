//! The pendulum of the output-error tests and bench: its model, truth, starting guess and
//! torque input.

use kalman::faer::Mat;
use kalman::nonlinear::{GenericModel, Scalar};

/// A damped pendulum driven by a known torque `u`, integrated by symplectic Euler:
/// x = (φ, ω, b, s); the displacement sensor reads `sin φ + b`, the rate gyro `(1 + s) ω`.
pub struct Pendulum {
    /// Step, s.
    pub dt: f64,
    /// Noise variances of the two sensors.
    pub r: [f64; 2],
}

impl GenericModel for Pendulum {
    fn f<T: Scalar>(&self, x: &[T], u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        let torque = u.map_or(0.0, |u| u[0]);
        let w = x[1] + (x[0].sin() * -9.81 - x[1] * 0.1 + torque) * self.dt;
        out[0] = x[0] + w * self.dt;
        out[1] = w;
        out[2] = x[2];
        out[3] = x[3];
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0].sin() + x[2];
        out[1] = x[1] * (x[3] + 1.0);
    }
    fn q(&self, _k: usize, out: &mut [f64]) {
        out.fill(0.0);
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&[self.r[0], 0.0, 0.0, self.r[1]]);
    }
}

/// The pendulum's truth: φ0 = 0.5 rad, ω0 = 0, bias 0.05, scale factor 2 %.
pub const TRUTH: [f64; 4] = [0.5, 0.0, 0.05, 0.02];
/// The starting guess of the fits.
pub const START: [f64; 4] = [0.3, 0.2, 0.0, 0.0];

/// The torque input (N×1).
pub fn torque(steps: usize, dt: f64) -> Mat<f64> {
    Mat::from_fn(steps, 1, |k, _| 0.3 * (0.5 * k as f64 * dt).sin())
}
