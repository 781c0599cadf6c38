//! Steady-state Kalman gain (DARE) and discrete LQR for a double integrator, nalgebra in and
//! out, checked by the two Riccati residuals computed here and by both closed loops being
//! stable. 37 lines of code as rustfmt lays them out (blank and comment lines not counted); the
//! same program with SciPy (`filterpy/lqr.py`; FilterPy has no Riccati solver) is 20.

use kalman::ToNalgebra;
use kalman::riccati::{dare, dlqr};
use nalgebra::{DMatrix, dmatrix};

fn main() -> Result<(), kalman::Error> {
    let dt = 0.25_f64;
    let (a, b, h) = (
        dmatrix![1.0, dt; 0.0, 1.0],
        dmatrix![dt * dt / 2.0; dt],
        dmatrix![1.0, 0.0],
    );
    let (q, r) = (
        dmatrix![dt.powi(3) / 3.0, dt * dt / 2.0; dt * dt / 2.0, dt],
        dmatrix![0.5],
    );
    let (qx, ru) = (dmatrix![1.0, 0.0; 0.0, 0.1], dmatrix![1.0]);
    let filter = dare(&a, &h, &q, &r, None)?;
    let control = dlqr(&a, &b, &qx, &ru, None)?;
    let (p, k) = (filter.prior.to_nalgebra(), filter.gain.to_nalgebra());
    let (x, l) = (control.cost.to_nalgebra(), control.gain.to_nalgebra());
    println!("Kalman gain K = {k}LQR gain L = {l}");
    // Independent checks: P solves the filter DARE and X the control DARE (to round-off of a
    // well-conditioned 2×2 problem), and both closed loops are stable.
    let solve = |m: DMatrix<f64>, rhs: DMatrix<f64>| m.cholesky().expect("SPD").solve(&rhs);
    let dare_res = &a * &p * a.transpose() + &q
        - &a * &p * h.transpose() * solve(&h * &p * h.transpose() + &r, &h * &p * a.transpose())
        - &p;
    let lqr_res = a.transpose() * &x * &a + &qx
        - a.transpose() * &x * &b * solve(&ru + b.transpose() * &x * &b, b.transpose() * &x * &a)
        - &x;
    assert!(dare_res.norm() < 1e-10 * p.norm() && lqr_res.norm() < 1e-10 * x.norm());
    let rho = |m: DMatrix<f64>| {
        m.complex_eigenvalues()
            .iter()
            .map(|e| e.norm())
            .fold(0.0, f64::max)
    };
    assert!(rho((DMatrix::identity(2, 2) - &k * &h) * &a) < 1.0 && rho(&a - &b * &l) < 1.0);
    Ok(())
}
