//! Steady-state Kalman gain (DARE) and discrete LQR for a double integrator, nalgebra in and
//! out, checked by the two Riccati residuals computed here and by both closed loops being
//! stable. Length: 20 code lines here, 20 in `filterpy/lqr.py` (SciPy; FilterPy has no Riccati
//! solver), counted by `tests/programs.rs` (rustfmt layout; blank and comment lines not counted).

use kalman::prelude::*;

type M = DMatrix<f64>;

/// ‖AᵀXA + Q − AᵀXB (R + BᵀXB)⁻¹ BᵀXA − X‖ / ‖X‖, the residual of the control-form DARE;
/// the filter DARE is its dual (A → Fᵀ, B → Hᵀ).
fn residual(a: &M, b: &M, q: &M, r: &M, x: &M) -> f64 {
    let gain = (r + b.transpose() * x * b).cholesky().expect("SPD").solve(&(b.transpose() * x * a));
    (a.transpose() * x * (a - b * gain) + q - x).norm() / x.norm()
}

fn main() -> Result<(), kalman::Error> {
    let (dt, r, ru) = (0.25_f64, dmatrix![0.5], dmatrix![1.0]);
    let (a, b) = (dmatrix![1.0, dt; 0.0, 1.0], dmatrix![dt * dt / 2.0; dt]);
    let (h, qx) = (dmatrix![1.0, 0.0], dmatrix![1.0, 0.0; 0.0, 0.1]);
    let q = dmatrix![dt.powi(3) / 3.0, dt * dt / 2.0; dt * dt / 2.0, dt];
    // The steady-state filter (gain K, prior covariance P) and the regulator (gain L, cost X).
    let kf = Dare::new(&a, &h, &q, &r)?.solve()?.to_nalgebra();
    let lqr = Dlqr::new(&a, &b, &qx, &ru)?.solve()?.to_nalgebra();
    println!("Kalman gain K = {}LQR gain L = {}", kf.gain, lqr.gain);
    // Independent checks: P solves the filter DARE and X the control DARE (to round-off of a
    // well-conditioned 2×2 problem), and both closed loops are stable.
    assert!(residual(&a.transpose(), &h.transpose(), &q, &r, &kf.prior) < 1e-10);
    assert!(residual(&a, &b, &qx, &ru, &lqr.cost) < 1e-10);
    let stable = |m: M| m.complex_eigenvalues().iter().all(|e| e.norm() < 1.0);
    assert!(stable((M::identity(2, 2) - &kf.gain * &h) * &a) && stable(&a - &b * &lqr.gain));
    Ok(())
}
