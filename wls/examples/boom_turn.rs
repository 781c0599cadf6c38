//! Runs the paper's full turn with ±Δa = 0.02 m/s² for each method and unit/weight option and
//! prints the worst errors (°, °/s²), the first violation and the first undefined cycle.
use wls::boom::{
    AngleUnit, BoomConfig, BoomMethod, ErrorVariant, Limits, RateWeight, RotationProfile,
    ideal_accelerometer, run_turn,
};

fn main() -> Result<(), wls::Error> {
    let tr = RotationProfile::default().trajectory()?;
    println!(
        "eps_d = {:.5} deg/s^2, {} points, t_end = {:.2} s",
        tr.deceleration_deg_s2,
        tr.points.len(),
        tr.points.last().map_or(0.0, |p| p.t)
    );
    let base = BoomConfig::default();
    let meas = ideal_accelerometer(base.g, base.sensor_radius);
    let limits = Limits::paper();
    let fp = RateWeight::FixedPoint {
        max_iterations: 20,
        tolerance: 1e-12,
    };
    let variants = [
        (
            "direct",
            BoomMethod::Direct,
            AngleUnit::Radian,
            AngleUnit::Radian,
            RateWeight::PreviousCycle,
        ),
        (
            "linear3",
            BoomMethod::Linear3,
            AngleUnit::Radian,
            AngleUnit::Radian,
            RateWeight::PreviousCycle,
        ),
        (
            "wls rad/rad prev",
            BoomMethod::Wls,
            AngleUnit::Radian,
            AngleUnit::Radian,
            RateWeight::PreviousCycle,
        ),
        (
            "wls rad/rad fp",
            BoomMethod::Wls,
            AngleUnit::Radian,
            AngleUnit::Radian,
            fp,
        ),
        (
            "wls deg/rad prev",
            BoomMethod::Wls,
            AngleUnit::Degree,
            AngleUnit::Radian,
            RateWeight::PreviousCycle,
        ),
        (
            "wls deg/rad fp",
            BoomMethod::Wls,
            AngleUnit::Degree,
            AngleUnit::Radian,
            fp,
        ),
        (
            "wls deg/deg prev",
            BoomMethod::Wls,
            AngleUnit::Degree,
            AngleUnit::Degree,
            RateWeight::PreviousCycle,
        ),
        (
            "wls deg/deg fp",
            BoomMethod::Wls,
            AngleUnit::Degree,
            AngleUnit::Degree,
            fp,
        ),
        (
            "wls rad/deg fp",
            BoomMethod::Wls,
            AngleUnit::Radian,
            AngleUnit::Degree,
            fp,
        ),
    ];
    let gammas: Vec<f64> = std::env::args().nth(1).map_or(vec![0.0, 10.0], |s| {
        s.split(',').filter_map(|x| x.parse().ok()).collect()
    });
    for gamma_deg in gammas {
        for (name, method, eu, ru, rw) in variants {
            let cfg = BoomConfig {
                method,
                epsilon_unit: eu,
                epsilon_rate_unit: ru,
                rate_weight: rw,
                sensor_offset_angle: gamma_deg.to_radians(),
                ..base.clone()
            };
            for v in [ErrorVariant::plus(0.02), ErrorVariant::minus(0.02)] {
                let run = run_turn(&tr.points, &cfg, &meas, &v, limits)?;
                let f = |o: Option<(f64, f64)>| {
                    o.map_or("-".to_string(), |(t, a)| {
                        format!("t={t:.2} a={:.2}", a.to_degrees())
                    })
                };
                println!(
                    "g={gamma_deg:>4} {name:<18} {:<2} max da={:>10.4} de={:>10.4}  viol {:<20} undef {}",
                    v.label(),
                    run.max_angle_error.to_degrees(),
                    run.max_epsilon_error.to_degrees(),
                    f(run.first_violation),
                    f(run.first_undefined)
                );
            }
        }
    }
    Ok(())
}
