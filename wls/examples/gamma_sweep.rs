//! Sweeps the sensor offset angle γ over 0–20° for the paper's turn (±Δa = 0.02 m/s²) and
//! prints the worst errors per γ, the feasible window and the smallest feasible γ.
use wls::boom::{
    BoomConfig, ErrorVariant, Limits, RotationProfile, ideal_accelerometer, sweep_gamma,
};

fn main() -> Result<(), wls::Error> {
    let tr = RotationProfile::default().trajectory()?;
    let cfg = BoomConfig::default();
    let meas = ideal_accelerometer(cfg.g, cfg.sensor_radius);
    let gammas: Vec<f64> = (0..=40)
        .map(|k| (0.5 * f64::from(k)).to_radians())
        .collect();
    for (name, limits) in [
        ("d_alpha = 1 deg, d_eps = 0.5 deg/s^2", Limits::paper()),
        (
            "d_alpha = 1 deg, d_eps = 0.25 deg/s^2",
            Limits {
                angular_acceleration: 0.25f64.to_radians(),
                ..Limits::paper()
            },
        ),
    ] {
        let rep = sweep_gamma(
            &tr.points,
            &cfg,
            &meas,
            &[ErrorVariant::plus(0.02), ErrorVariant::minus(0.02)],
            &gammas,
            limits,
        )?;
        println!("{name}");
        for r in &rep.rows {
            println!(
                "  gamma {:5.1} deg: max d_alpha {:8.4} deg, max d_eps {:8.4} deg/s^2 {}",
                r.gamma.to_degrees(),
                r.max_angle_error.to_degrees(),
                r.max_epsilon_error.to_degrees(),
                if r.feasible { "feasible" } else { "" }
            );
        }
        println!(
            "  smallest feasible: {:?} deg, window {:?} deg",
            rep.smallest_feasible.map(f64::to_degrees),
            rep.window.map(|(a, b)| (a.to_degrees(), b.to_degrees()))
        );
    }
    Ok(())
}
