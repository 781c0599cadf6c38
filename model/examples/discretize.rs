//! The crate's headline job: a continuous model with white-noise input, discretised for a
//! Kalman filter by zero-order hold with Van Loan noise and by Tustin, side by side.
//! `cargo run -p stochest-model --example discretize`

use model::nalgebra::dmatrix;
use model::{
    ContinuousSs, Discretization, IrregularRollingShaping, NoiseConvention, ShapingFilter,
};

fn main() -> Result<(), model::Error> {
    // A mass on a spring with light damping, position measured, pushed by white force noise.
    let sys = ContinuousSs::new(
        dmatrix![0.0, 1.0; -4.0, -0.4], // A
        dmatrix![0.0; 1.0],             // B
        dmatrix![1.0, 0.0],             // C
        dmatrix![0.0],                  // D
    )?
    .with_noise(dmatrix![0.0; 1.0], dmatrix![0.05])?; // G, W
    let dt = 0.1;
    for method in [Discretization::Zoh, Discretization::Tustin] {
        let d = sys.discretize(dt, method, NoiseConvention::VanLoan)?;
        println!("{method:?}, dt = {dt} s");
        println!("  F = {}", d.f());
        println!("  B = {}", d.b());
        println!("  Q = G Q Gᵀ = {}", d.process_covariance());
        println!("  spectral radius {:.6}", model::spectral_radius(d.f())?);
    }

    // A shaping filter: sea rolling with a 10 s period, σ = 1°, sampled every 0.1 s.
    let rolling = IrregularRollingShaping::new(
        1f64.to_radians().powi(2),
        0.08,
        2.0 * std::f64::consts::PI / 10.0,
    )?;
    let d = rolling.discretize(dt, Discretization::Zoh, NoiseConvention::VanLoan)?;
    let p = model::discrete_lyapunov(d.f(), &d.process_covariance())?;
    let var = (d.h() * &p * d.h().transpose())[(0, 0)];
    println!(
        "rolling: stationary σ of the discrete model {:.4}° (continuous {:.4}°)",
        var.sqrt().to_degrees(),
        rolling.variance().sqrt().to_degrees()
    );
    Ok(())
}
