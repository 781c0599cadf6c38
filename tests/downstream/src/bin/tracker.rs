//! Constant-velocity tracker with missing samples (NaN) and RTS smoothing, nalgebra in and out,
//! checked against the batch least-squares posterior of the whole track (information form).
//! 68 lines of code as rustfmt lays them out (blank and comment lines not counted); the same
//! program with FilterPy and NumPy (`filterpy/tracker.py`) is 35.

use kalman::{CovarianceForm::Joseph, DynDims, Filter, Model, ToNalgebra};
use nalgebra::{DMatrix, DVector, dmatrix};

fn main() -> Result<(), kalman::Error> {
    let dt = 1.0_f64;
    let (f, h) = (dmatrix![1.0, dt; 0.0, 1.0], dmatrix![1.0, 0.0]);
    let q = dmatrix![dt.powi(3) / 3.0, dt * dt / 2.0; dt * dt / 2.0, dt] * 0.01;
    let (r, p0) = (dmatrix![0.25], DMatrix::identity(2, 2) * 10.0);
    let model = Model::new(DynDims::new(2, 1, 0)?, &f, &h, &q, &r)?;
    let mut filter = Filter::new(model, &[0.0, 0.0], &p0, Joseph)?;
    let zs = [
        1.1,
        2.0,
        f64::NAN,
        3.9,
        5.1,
        f64::NAN,
        f64::NAN,
        8.0,
        9.1,
        9.9,
    ];
    let smoothed = filter.run_smoothed(zs.map(|z| [z]))?;
    let (means, covs) = (
        smoothed.means.to_nalgebra(),
        smoothed.covariances.to_nalgebra(),
    );
    for (k, z) in zs.iter().enumerate() {
        println!(
            "{k} z = {z:4.1}  x = {:7.3} {:6.3}  var = {:.4}",
            means[(0, k)],
            means[(1, k)],
            covs[k][(0, 0)]
        );
    }
    // Independent check: the posterior of all states x_0..x_{N−1} given every measurement, from
    // its information matrix Λ (prior, dynamics and measurement terms) and vector η.
    let n = zs.len();
    let inv = |m: &DMatrix<f64>| m.clone().cholesky().expect("SPD").inverse();
    let (qi, ri) = (inv(&q), inv(&r));
    let (mut info, mut eta) = (
        DMatrix::<f64>::zeros(2 * n, 2 * n),
        DVector::<f64>::zeros(2 * n),
    );
    let mut add = |i: usize, j: usize, m: &DMatrix<f64>| {
        let mut block = info.view_mut((2 * i, 2 * j), (2, 2));
        block += m;
    };
    add(0, 0, &inv(&p0));
    for k in 0..n - 1 {
        add(k, k, &(f.transpose() * &qi * &f));
        add(k, k + 1, &-(f.transpose() * &qi));
        add(k + 1, k, &-(&qi * &f));
        add(k + 1, k + 1, &qi);
    }
    for (k, z) in zs.iter().enumerate().filter(|(_, z)| !z.is_nan()) {
        add(k, k, &(h.transpose() * &ri * &h));
        eta.rows_mut(2 * k, 2)
            .axpy(*z, &(h.transpose() * &ri).column(0), 1.0);
    }
    let chol = info.cholesky().expect("the information matrix is SPD");
    let (batch_mean, batch_cov) = (chol.solve(&eta), chol.inverse());
    // Both are the same Gaussian posterior; Λ's condition number is about 1e4, so round-off
    // stays far below this tolerance.
    for k in 0..n {
        assert!(
            (means.column(k) - batch_mean.rows(2 * k, 2)).norm()
                < 1e-9 * (1.0 + means.column(k).norm())
        );
        assert!((&covs[k] - batch_cov.view((2 * k, 2 * k), (2, 2))).norm() < 1e-9 * covs[k].norm());
    }
    Ok(())
}
