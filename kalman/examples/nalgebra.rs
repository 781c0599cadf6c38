//! nalgebra in, nalgebra out: a constant-velocity track with gaps, smoothed in one call, and the
//! steady-state gain of the same model (`cargo run -p stochest-kalman --example nalgebra
//! --features nalgebra`).

use kalman::prelude::*; // Model, Dare, …, ToNalgebra and nalgebra's DMatrix, dmatrix!, …

fn main() -> Result<(), kalman::Error> {
    let dt = 1.0;
    let f = dmatrix![1.0, dt; 0.0, 1.0];
    let h = dmatrix![1.0, 0.0];
    let q = dmatrix![1.0 / 3.0, 0.5; 0.5, 1.0] * 0.01; // white acceleration
    let r = dmatrix![0.25];
    let model = Model::from_matrices(&f, &h, &q, &r)?; // n and m read off F and H
    let zs = dvector![1.1, 2.0, f64::NAN, 3.9, 5.1, f64::NAN, 8.0]; // NaN: missing
    let p0 = DMatrix::identity(2, 2) * 10.0;
    // Filter the whole record and RTS-smooth it in one call, nalgebra out.
    let s = model.smooth(&[0.0, 0.0], &p0, &zs)?.to_nalgebra();
    println!("smoothed track (column k is x_k|N-1) {}", s.means);
    println!("last smoothed covariance {}", s.covariances[zs.len() - 1]);
    let steady = Dare::new(&f, &h, &q, &r)?.solve()?.to_nalgebra();
    println!("steady-state gain {}", steady.gain);
    Ok(())
}
