//! Steady-state Kalman gain (DARE) and discrete LQR for a double integrator, nalgebra in and
//! out, checked by the two Riccati residuals computed here and by both closed loops being
//! stable. Length: 23 code lines here, 20 in `filterpy/lqr.py` (SciPy; FilterPy has no Riccati
//! solver), counted by `tests/programs.rs` (rustfmt layout; blank and comment lines not counted).

use kalman::prelude::*;

type M = DMatrix<f64>;

/// ‖AᵀXA + Q − AᵀXB (R + BᵀXB)⁻¹ BᵀXA − X‖ / ‖X‖, the residual of the control-form DARE;
/// the filter DARE is its dual (A → Fᵀ, B → Hᵀ).
fn residual(a: &M, b: &M, q: &M, r: &M, x: &M) -> f64 {
    let s = (r + b.transpose() * x * b).cholesky().expect("SPD");
    let gain = s.solve(&(b.transpose() * x * a));
    (a.transpose() * x * (a - b * gain) + q - x).norm() / x.norm()
}

fn main() -> Result<(), kalman::Error> {
    let dt = 0.25_f64;
    let a = dmatrix![1.0, dt; 0.0, 1.0];
    let (b, h) = (dmatrix![dt * dt / 2.0; dt], dmatrix![1.0, 0.0]);
    let q = dmatrix![dt.powi(3) / 3.0, dt * dt / 2.0; dt * dt / 2.0, dt];
    let (r, qx, ru) = (dmatrix![0.5], dmatrix![1.0, 0.0; 0.0, 0.1], dmatrix![1.0]);
    let filter = Dare::new(&a, &h, &q, &r)?.solve()?.to_nalgebra();
    let control = Dlqr::new(&a, &b, &qx, &ru)?.solve()?.to_nalgebra();
    let (k, l) = (&filter.gain, &control.gain);
    println!("Kalman gain K = {k}LQR gain L = {l}");
    // Independent checks: P solves the filter DARE and X the control DARE (to round-off of a
    // well-conditioned 2×2 problem), and both closed loops are stable.
    assert!(residual(&a.transpose(), &h.transpose(), &q, &r, &filter.prior) < 1e-10);
    assert!(residual(&a, &b, &qx, &ru, &control.cost) < 1e-10);
    let stable = |m: M| m.complex_eigenvalues().iter().all(|e| e.norm() < 1.0);
    assert!(stable((DMatrix::identity(2, 2) - k * &h) * &a) && stable(&a - &b * l));
    Ok(())
}
