//! An ill-conditioned least-squares fit (a degree-7 polynomial on [0, 1]) solved plainly and
//! with Tikhonov regularisation, nalgebra in and out, checked against the closed form
//! x_λ = (HᵀH + λI)⁻¹Hᵀz. Length: 17 code lines here, 17 in `filterpy/wls_tikhonov.py`
//! (NumPy), counted by `tests/programs.rs` (rustfmt layout; blank and comment lines not counted).

use wls::prelude::*;

fn main() -> Result<(), wls::Error> {
    let h = DMatrix::from_fn(40, 8, |i, j| (i as f64 / 39.0).powi(j as i32));
    let truth = DVector::from_fn(8, |j, _| 1.0 / (1.0 + j as f64));
    let z = &h * &truth + DVector::from_fn(40, |i, _| 1e-4 * ((7 * i) % 11) as f64 - 5e-4);
    let plain = solve(&h, &z, &Weights::Identity, &SolveOptions::default())?;
    let lambda = 1e-6;
    let regularised = solve(&h, &z, &Weights::Identity, &SolveOptions::ridge(lambda))?;
    let (e_plain, e_reg) = ((&plain.x - &truth).norm(), (&regularised.x - &truth).norm());
    // The condition number of the system each solve factorised (κ₂ of H, then of [H; √λ I]).
    println!("condition {:.2e} -> {:.2e}", plain.condition_solved, regularised.condition_solved);
    println!("coefficient error {e_plain:.2e} -> {e_reg:.2e}");
    // Independent check: the regularised normal equations, whose matrix has condition number
    // at most ‖HᵀH‖/λ ≈ 1e8, so their Cholesky solution is good to about 1e-8 relative.
    let normal = h.transpose() * &h + DMatrix::identity(8, 8) * lambda;
    let closed_form = normal.cholesky().expect("SPD").solve(&(h.transpose() * &z));
    assert!((&regularised.x - &closed_form).norm() < 1e-6 * closed_form.norm());
    assert!(regularised.condition_solved < plain.condition_solved && e_reg < e_plain);
    Ok(())
}
