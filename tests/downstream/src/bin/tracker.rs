//! Constant-velocity tracker with missing samples (NaN) and RTS smoothing, nalgebra in and out,
//! checked against the batch least-squares posterior of the whole track (information form).
//! Length: 29 code lines here, 30 in `filterpy/tracker.py` (FilterPy and NumPy), counted by
//! `tests/programs.rs` (rustfmt layout; blank and comment lines not counted).

use kalman::prelude::*;

fn main() -> Result<(), kalman::Error> {
    let (dt, nan) = (1.0_f64, f64::NAN);
    let (f, h) = (dmatrix![1.0, dt; 0.0, 1.0], dmatrix![1.0, 0.0]);
    let q = dmatrix![dt.powi(3) / 3.0, dt * dt / 2.0; dt * dt / 2.0, dt] * 0.01;
    let (r, p0) = (dmatrix![0.25], DMatrix::identity(2, 2) * 10.0);
    let zs = dvector![1.1, 2.0, nan, 3.9, 5.1, nan, nan, 8.0, 9.1, 9.9];
    let model = Model::from_matrices(&f, &h, &q, &r)?;
    let s = model.smooth(&[0.0, 0.0], &p0, &zs)?.to_nalgebra();
    // Independent check: the posterior of all states x = (x_0, …, x_{N−1}) given every
    // measurement. With D x stacking x_0 and x_{k+1} − F x_k (D = I − shift ⊗ F), weights
    // W = blockdiag(P0⁻¹, Q⁻¹, …), and the observed steps picked out by `seen`, its
    // information matrix is Λ = DᵀWD + seen ⊗ HᵀR⁻¹H and its information vector
    // η = z ⊗ HᵀR⁻¹ (missing z as 0).
    let n = zs.len();
    let inv = |m: &DMatrix<f64>| m.clone().cholesky().expect("SPD").inverse();
    let shift = DMatrix::from_fn(n, n, |i, j| f64::from(u8::from(i == j + 1)));
    let first = DMatrix::from_fn(n, n, |i, j| f64::from(u8::from(i + j == 0)));
    let seen = DMatrix::from_fn(n, n, |i, j| f64::from(u8::from(i == j && !zs[i].is_nan())));
    let d = DMatrix::identity(2 * n, 2 * n) - shift.kronecker(&f);
    let w = first.kronecker(&inv(&p0)) + (DMatrix::identity(n, n) - &first).kronecker(&inv(&q));
    let info = d.transpose() * w * &d + seen.kronecker(&(h.transpose() * inv(&r) * &h));
    let z0 = zs.map(|z| if z.is_nan() { 0.0 } else { z });
    let eta = z0.kronecker(&(h.transpose() * inv(&r)));
    let chol = info.cholesky().expect("the information matrix is SPD");
    let (batch_mean, batch_cov) = (chol.solve(&eta), chol.inverse());
    // Both are the same Gaussian posterior; Λ's condition number is about 1e4, so round-off
    // stays far below this tolerance.
    for (k, p) in s.covariances.iter().enumerate() {
        let x = s.means.column(k);
        println!("{k} {} {:?} {}", zs[k], x.as_slice(), p[(0, 0)]);
        assert!((x - batch_mean.rows(2 * k, 2)).norm() < 1e-9 * (1.0 + x.norm()));
        assert!((p - batch_cov.view((2 * k, 2 * k), (2, 2))).norm() < 1e-9 * p.norm());
    }
    Ok(())
}
