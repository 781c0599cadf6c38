//! The crate's headline job: the truth side of a fuelling test — a tank filling at 10 mm/s on
//! a rolling platform, read by a quantized level sensor in a hydro-damper and by the ship's
//! gyro — reproducible from one seed. `cargo run -p stochest-sensors --example fuelling`

use sensors::{
    Gyro, GyroConfig, LevelSensor, LevelSensorConfig, PlatformMotion, PlatformMotionConfig,
    seeded_rng,
};

fn main() -> Result<(), sensors::Error> {
    let dt = 0.1;
    let mut rng = seeded_rng(2024);
    let mut platform = PlatformMotion::new(&PlatformMotionConfig::default(), dt)?;
    let mut level_sensor = LevelSensor::new(&LevelSensorConfig::default(), dt)?;
    let gyro_cfg = GyroConfig {
        noise_std_deg: 0.02,
        ..GyroConfig::default()
    };
    let mut gyro = Gyro::new(&gyro_cfg, dt)?;
    println!("t_s,level_m,at_sensor_m,reading_m,roll_deg,pitch_deg,gyro_pitch_deg");
    let mut level = 2.0;
    for k in 0..600 {
        level += 0.010 * dt;
        let attitude = platform.next(&mut rng);
        let reading = level_sensor.step(level, attitude, &mut rng);
        let seen = gyro.step(attitude, &mut rng);
        if k % 20 == 0 {
            println!(
                "{:.1},{level:.4},{:.4},{:.3},{:.3},{:.3},{:.3}",
                f64::from(k) * dt,
                reading.at_sensor,
                reading.reading,
                attitude.roll.to_degrees(),
                attitude.pitch.to_degrees(),
                seen.pitch.to_degrees(),
            );
        }
    }
    Ok(())
}
