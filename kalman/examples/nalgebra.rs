//! nalgebra in, nalgebra out: a constant-velocity track with gaps, smoothed in one call, and the
//! steady-state gain of the same model (`cargo run -p stochest-kalman --example nalgebra
//! --features nalgebra`).

use kalman::nalgebra::{DMatrix, dmatrix};
use kalman::{CovarianceForm, DynDims, Filter, Model, ToNalgebra};

fn main() -> Result<(), kalman::Error> {
    let dt = 1.0;
    let f = dmatrix![1.0, dt; 0.0, 1.0];
    let h = dmatrix![1.0, 0.0];
    let q = dmatrix![1.0 / 3.0, 0.5; 0.5, 1.0] * 0.01; // white acceleration
    let r = dmatrix![0.25];
    let model = Model::new(DynDims::new(2, 1, 0)?, &f, &h, &q, &r)?;
    let mut filter = Filter::new(
        model,
        &[0.0, 0.0],
        &(DMatrix::identity(2, 2) * 10.0),
        CovarianceForm::Joseph,
    )?;
    let zs = [1.1, 2.0, f64::NAN, 3.9, 5.1, f64::NAN, 8.0];
    let smoothed = filter.run_smoothed(zs.map(|z| [z]))?; // RTS over the whole record
    let means: DMatrix<f64> = smoothed.means.to_nalgebra(); // column k is x_{k|N−1}
    let last: DMatrix<f64> = filter.covariance().to_nalgebra();
    println!("smoothed track {means}filtered P at the end {last}");
    let steady = kalman::riccati::dare(&f, &h, &q, &r, None)?; // the same matrices again
    println!("steady-state gain {}", steady.gain.to_nalgebra());
    Ok(())
}
