//! Test models of the nonlinear filters: a linear model (against the linear engine), range
//! and bearing of a constant-velocity target, a pendulum, and the erector boom's
//! accelerometer; each with hand-written Jacobians and a scalar-generic form for AD.

use faer::Mat;
use kalman::nonlinear::{GenericModel, Jacobians, NonlinearModel, Scalar};
use kalman::strategies::FilterProblem;

fn col_major(a: &Mat<f64>) -> Vec<f64> {
    let mut v = Vec::with_capacity(a.nrows() * a.ncols());
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            v.push(a[(i, j)]);
        }
    }
    v
}

/// `x_{k+1} = F x + B u`, `z = H x` with the problem's Q and R.
#[derive(Clone, Debug)]
pub struct Linear {
    pub n: usize,
    pub m: usize,
    pub p: usize,
    pub F: Vec<f64>,
    pub H: Vec<f64>,
    pub B: Vec<f64>,
    pub Q: Vec<f64>,
    pub R: Vec<f64>,
}

impl Linear {
    pub fn new(p: &FilterProblem) -> Self {
        Self {
            n: p.system.n(),
            m: p.system.m(),
            p: p.system.p(),
            F: col_major(&p.system.f),
            H: col_major(&p.system.h),
            B: col_major(&p.system.b),
            Q: col_major(&p.system.q),
            R: col_major(&p.system.r),
        }
    }
}

impl NonlinearModel for Linear {
    fn f(&mut self, x: &[f64], u: Option<&[f64]>, _k: usize, out: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            out[i] = (0..n).map(|j| self.F[i + j * n] * x[j]).sum();
            if let Some(u) = u {
                out[i] += (0..self.p).map(|l| self.B[i + l * n] * u[l]).sum::<f64>();
            }
        }
    }
    fn h(&mut self, x: &[f64], _k: usize, out: &mut [f64]) {
        let (n, m) = (self.n, self.m);
        for i in 0..m {
            out[i] = (0..n).map(|j| self.H[i + j * m] * x[j]).sum();
        }
    }
    fn q(&mut self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&self.Q);
    }
    fn r(&mut self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&self.R);
    }
}

impl Jacobians for Linear {
    fn f_jacobian(&mut self, _x: &[f64], _u: Option<&[f64]>, _k: usize, jac: &mut [f64]) {
        jac.copy_from_slice(&self.F);
    }
    fn h_jacobian(&mut self, _x: &[f64], _k: usize, jac: &mut [f64]) {
        jac.copy_from_slice(&self.H);
    }
}

/// Wraps an angle to [−π, π): `(a + π) mod 2π − π`, FilterPy's formula. When `a + π`
/// already lies in [0, 2π) the remainder is `a + π` itself (exactly), so that case skips the
/// `fmod` call; the result is the same bit for bit.
pub fn wrap(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let t = a + PI;
    if (0.0..TAU).contains(&t) {
        t - PI
    } else {
        t.rem_euclid(TAU) - PI
    }
}

/// Constant velocity in the plane, x = (px, vx, py, vy); range and bearing from the origin
/// (the bearing residual wrapped). The golden script's `RangeBearing`.
#[derive(Clone, Debug)]
pub struct RangeBearing {
    pub dt: f64,
    pub q: f64,
    pub sr: f64,
    pub sb: f64,
}

impl Default for RangeBearing {
    fn default() -> Self {
        Self {
            dt: 1.0,
            q: 0.05,
            sr: 0.5,
            sb: 0.01,
        }
    }
}

impl RangeBearing {
    pub fn x0() -> [f64; 4] {
        [60.0, -1.0, -40.0, 1.5]
    }
    pub fn p0() -> [[f64; 4]; 4] {
        [
            [4.0, 0.0, 0.0, 0.0],
            [0.0, 0.25, 0.0, 0.0],
            [0.0, 0.0, 4.0, 0.0],
            [0.0, 0.0, 0.0, 0.25],
        ]
    }
    /// The hand-written ∂h/∂x (2×4, column-major).
    pub fn hjac(x: &[f64], jac: &mut [f64]) {
        let (px, py) = (x[0], x[2]);
        let r2 = px * px + py * py;
        let r = r2.sqrt();
        jac.fill(0.0);
        jac[0] = px / r;
        jac[1] = -py / r2;
        jac[4] = py / r;
        jac[5] = px / r2;
    }
}

impl GenericModel for RangeBearing {
    fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        out[0] = x[0] + x[1] * self.dt;
        out[1] = x[1];
        out[2] = x[2] + x[3] * self.dt;
        out[3] = x[3];
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = (x[0] * x[0] + x[2] * x[2]).sqrt();
        out[1] = x[2].atan2(x[0]);
    }
    fn q(&self, _k: usize, out: &mut [f64]) {
        let (dt, q) = (self.dt, self.q);
        out.fill(0.0);
        for b in [0, 2] {
            out[b + b * 4] = q * dt.powi(3) / 3.0;
            out[b + 1 + b * 4] = q * dt * dt / 2.0;
            out[b + (b + 1) * 4] = q * dt * dt / 2.0;
            out[b + 1 + (b + 1) * 4] = q * dt;
        }
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&[self.sr * self.sr, 0.0, 0.0, self.sb * self.sb]);
    }
    fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        out[0] = a[0] - b[0];
        out[1] = wrap(a[1] - b[1]);
    }
}

/// A scalar-generic model with hand-written Jacobians (the reference for AD): the model's
/// own f, h, Q, R, residual and state addition, and the Jacobians of its `impl Jacobians`.
#[derive(Clone, Debug, Default)]
pub struct Hand<M>(pub M);

/// Range and bearing with hand-written Jacobians.
pub type RangeBearingHand = Hand<RangeBearing>;

/// The pendulum with hand-written Jacobians.
pub type PendulumHand = Hand<Pendulum>;

impl<M: GenericModel> NonlinearModel for Hand<M> {
    fn f(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]) {
        self.0.f(x, u, k, out);
    }
    fn h(&mut self, x: &[f64], k: usize, out: &mut [f64]) {
        self.0.h(x, k, out);
    }
    fn q(&mut self, k: usize, out: &mut [f64]) {
        GenericModel::q(&self.0, k, out);
    }
    fn r(&mut self, k: usize, out: &mut [f64]) {
        GenericModel::r(&self.0, k, out);
    }
    fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        GenericModel::residual(&self.0, a, b, out);
    }
    fn state_add(&self, x: &[f64], dx: &[f64], out: &mut [f64]) {
        GenericModel::state_add(&self.0, x, dx, out);
    }
    fn state_residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        GenericModel::state_residual(&self.0, a, b, out);
    }
}

impl Jacobians for RangeBearingHand {
    fn f_jacobian(&mut self, _x: &[f64], _u: Option<&[f64]>, _k: usize, jac: &mut [f64]) {
        jac.fill(0.0);
        for i in 0..4 {
            jac[i + i * 4] = 1.0;
        }
        jac[4] = self.0.dt; // (0, 1)
        jac[2 + 3 * 4] = self.0.dt; // (2, 3)
    }
    fn h_jacobian(&mut self, x: &[f64], _k: usize, jac: &mut [f64]) {
        RangeBearing::hjac(x, jac);
    }
}

/// x = (θ, ω), Euler step of θ'' = −(g/L) sin θ; z = L sin θ. The golden script's
/// `Pendulum`.
#[derive(Clone, Debug)]
pub struct Pendulum {
    pub dt: f64,
    pub g: f64,
    pub l: f64,
}

impl Default for Pendulum {
    fn default() -> Self {
        Self {
            dt: 0.05,
            g: 9.81,
            l: 2.0,
        }
    }
}

impl GenericModel for Pendulum {
    fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        out[0] = x[0] + x[1] * self.dt;
        out[1] = x[1] - x[0].sin() * (self.dt * self.g / self.l);
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0].sin() * self.l;
    }
    fn q(&self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&[1e-6, 0.0, 0.0, 1e-3]);
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out[0] = 1e-4;
    }
}

impl Jacobians for PendulumHand {
    fn f_jacobian(&mut self, x: &[f64], _u: Option<&[f64]>, _k: usize, jac: &mut [f64]) {
        let p = &self.0;
        jac.copy_from_slice(&[1.0, -p.dt * p.g / p.l * x[0].cos(), p.dt, 1.0]);
    }
    fn h_jacobian(&mut self, x: &[f64], _k: usize, jac: &mut [f64]) {
        jac.copy_from_slice(&[self.0.l * x[0].cos(), 0.0]);
    }
}

/// The erector boom's accelerometer (radial and tangential axes) at offset angle γ with
/// the centripetal term, state (α, ω, ε), ε a random walk.
#[derive(Clone, Debug)]
pub struct Boom {
    pub dt: f64,
    pub g: f64,
    pub r: f64,
    pub gamma: f64,
}

impl GenericModel for Boom {
    fn f<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _k: usize, out: &mut [T]) {
        let dt = self.dt;
        out[0] = x[0] + x[1] * dt + x[2] * (0.5 * dt * dt);
        out[1] = x[1] + x[2] * dt;
        out[2] = x[2];
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        let a = x[0] - self.gamma;
        out[0] = a.sin() * self.g - x[1] * x[1] * self.r;
        out[1] = a.cos() * self.g + x[2] * self.r;
    }
    fn q(&self, _k: usize, out: &mut [f64]) {
        out.fill(0.0);
        out[8] = 1e-4;
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out.copy_from_slice(&[4e-4, 0.0, 0.0, 4e-4]);
    }
}

impl Boom {
    /// The hand-written ∂h/∂x (2×3, column-major).
    pub fn hjac(&self, x: &[f64], jac: &mut [f64]) {
        let (s, c) = (x[0] - self.gamma).sin_cos();
        jac.copy_from_slice(&[
            self.g * c,
            -self.g * s,
            -2.0 * x[1] * self.r,
            0.0,
            0.0,
            self.r,
        ]);
    }
}
