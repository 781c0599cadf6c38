//! A multi-rate record with time stamps and wild points, filtered at its own intervals:
//! `cargo run -p stochest-kalman --example irregular`.
//!
//! A target moving at 30 m/s is seen by a position sensor at about 1 Hz and a velocity sensor
//! at about 10 Hz, on jittered clocks; two readings are wild (a dropout read as 0 and a
//! 50σ velocity spike). The continuous model is sampled exactly at each interval, and the
//! gate rejects the wild readings before the update, reporting each one.

use kalman::gate::{Gate, GateRule};
use kalman::sampling::{ContinuousModel, Sampler};
use kalman::{CovarianceForm, Filter};

fn main() -> Result<(), kalman::Error> {
    // ẋ = [[0, 1], [0, 0]] x + w, white acceleration of intensity 0.5 m²/s³; z = (position,
    // velocity) with standard deviations 2 m and 0.2 m/s.
    let model = ContinuousModel::new(
        &[[0.0, 1.0], [0.0, 0.0]],
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[0.0, 0.0], [0.0, 0.5]],
        &[[4.0, 0.0], [0.0, 0.04]],
    )?;
    // (t, position, velocity): NaN where a sensor did not sample.
    let nan = f64::NAN;
    let mut rows = Vec::new();
    for k in 0..200 {
        let t = 0.1 * k as f64 + 0.02 * ((k * 7919) % 5) as f64 / 5.0;
        let position = if k % 10 == 0 { 30.0 * t } else { nan };
        rows.push((t, [position, 30.0]));
    }
    rows[50].1[0] = 0.0; // a dropout read as zero
    rows[120].1[1] = 40.0; // a 50σ spike
    let mut sampler = Sampler::new(model, 64)?;
    let mut kf = Filter::new(
        sampler.at(0.0)?.clone(),
        &[0.0, 25.0],
        &[[100.0, 0.0], [0.0, 100.0]],
        CovarianceForm::Joseph,
    )?;
    let mut gate = Gate::new(GateRule::Entries, 0.9999, kf.model())?;
    for k in 0..rows.len() {
        let (t, z) = rows[k];
        let dt = rows.get(k + 1).map_or(0.0, |next| next.0 - t);
        let step = sampler.at(dt)?;
        gate.screen(&kf, step, &z)?;
        for r in gate.rejected() {
            println!(
                "t = {t:.3}: rejected channel {} = {} (e²/Σ = {:.0})",
                r.entry + 1,
                r.value,
                r.nis
            );
        }
        kf.step_with(step, gate.kept(), None)?;
    }
    let (t, _) = rows[rows.len() - 1];
    println!(
        "at t = {t:.3}: position {:.2} m (truth {:.2}), velocity {:.3} m/s; {} distinct intervals sampled",
        kf.state()[0],
        30.0 * t,
        kf.state()[1],
        sampler.distinct()
    );
    Ok(())
}
