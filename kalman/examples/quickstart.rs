//! The README's example of using `kalman` alone:
//! `cargo run -p stochest-kalman --example quickstart`.

use kalman::{CovarianceForm, DynDims, Filter, Model};

fn main() -> Result<(), kalman::Error> {
    let dt = 0.1; // constant velocity, position measured
    let model = Model::new(
        DynDims::new(2, 1, 0)?,      // n = 2 states, m = 1 measurement, p = 0 inputs
        &[[1.0, dt], [0.0, 1.0]],    // F
        &[[1.0, 0.0]],               // H
        &[[1e-4, 0.0], [0.0, 1e-3]], // Q
        &[[0.01]],                   // R
    )?;
    let mut filter = Filter::new(
        model,
        &[0.0, 1.0],
        &[[1.0, 0.0], [0.0, 1.0]],
        CovarianceForm::Joseph,
    )?;
    for z in [0.11, 0.19, f64::NAN, 0.42] {
        // NaN: a missing sample, predict only
        let info = filter.step(&[z], None)?; // update with z_k, then predict to k + 1
        println!(
            "x = {:?}, NIS = {:.3}",
            filter.state(),
            info.nis.map_or(f64::NAN, |v| v)
        );
    }
    Ok(())
}
