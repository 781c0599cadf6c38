//! Configurations: invalid values are typed errors naming the field; serde round-trips and
//! fills defaults; unknown fields are rejected.

use sensors::{
    Accelerometer, AccelerometerConfig, ChannelSensor, ChannelSensorConfig, DampedCosineConfig,
    DampedCosineProcess, Error, ExpCorrelated, ExpCorrelatedConfig, FirstOrderLag, Gyro,
    GyroConfig, IrregularRollingConfig, IrregularRollingProcess, LagInput, LevelSensor,
    LevelSensorConfig, PlatformMotion, PlatformMotionConfig, RollingAxisConfig, WhiteNoise,
};

fn level(f: impl FnOnce(&mut LevelSensorConfig)) -> Result<LevelSensor, Error> {
    let mut c = LevelSensorConfig::default();
    f(&mut c);
    LevelSensor::new(&c, 0.1)
}

fn accel(f: impl FnOnce(&mut AccelerometerConfig)) -> Result<Accelerometer, Error> {
    let mut c = AccelerometerConfig::default();
    f(&mut c);
    Accelerometer::new(&c)
}

#[test]
fn invalid_level_sensor_configuration_is_a_typed_error() {
    assert!(matches!(
        level(|c| c.step_m = -0.01),
        Err(Error::NotPositive { name: "step_m", .. })
    ));
    assert!(matches!(
        level(|c| c.step_m = 0.0),
        Err(Error::NotPositive { name: "step_m", .. })
    ));
    assert!(matches!(
        level(|c| c.damper_time_constant_s = -2.0),
        Err(Error::Negative {
            name: "damper_time_constant_s",
            ..
        })
    ));
    assert!(matches!(
        level(|c| c.sensor_radius_m = -1.5),
        Err(Error::Negative {
            name: "sensor_radius_m",
            ..
        })
    ));
    assert!(matches!(
        level(|c| c.sensor_angle_deg = f64::NAN),
        Err(Error::NotFinite {
            name: "sensor_angle_deg",
            ..
        })
    ));
    assert!(matches!(
        level(|c| c.noise_std_m = f64::NAN),
        Err(Error::NotFinite {
            name: "noise_std_m",
            ..
        })
    ));
    assert!(matches!(
        level(|c| c.dead_time_s = -0.1),
        Err(Error::Negative {
            name: "dead_time_s",
            ..
        })
    ));
    assert!(matches!(
        LevelSensor::new(&LevelSensorConfig::default(), 0.0),
        Err(Error::NotPositive { name: "dt_s", .. })
    ));
    assert!(matches!(
        FirstOrderLag::new(-1.0, 0.1, LagInput::ZeroOrderHold),
        Err(Error::Negative {
            name: "time_constant_s",
            ..
        })
    ));
}

#[test]
fn invalid_accelerometer_configuration_is_a_typed_error() {
    assert!(matches!(
        accel(|c| c.sensor_radius_m = -25.0),
        Err(Error::NotPositive {
            name: "sensor_radius_m",
            ..
        })
    ));
    for bad in [90.5f64, -91.0, 180.0] {
        assert!(matches!(
            accel(|c| c.sensor_offset_angle = bad.to_radians()),
            Err(Error::OutOfRange { name: "sensor_offset_angle", min, max, .. })
                if (min + std::f64::consts::FRAC_PI_2).abs() < 1e-15 && (max - std::f64::consts::FRAC_PI_2).abs() < 1e-15
        ));
    }
    assert!(accel(|c| c.sensor_offset_angle = 90f64.to_radians()).is_ok());
    assert!(accel(|c| c.sensor_offset_angle = -90f64.to_radians()).is_ok());
    assert!(matches!(
        accel(|c| c.sensor_offset_angle = f64::NAN),
        Err(Error::NotFinite {
            name: "sensor_offset_angle",
            ..
        })
    ));
    assert!(matches!(
        accel(|c| c.misalignment_deg[1] = f64::NAN),
        Err(Error::NotFinite {
            name: "misalignment_deg[1]",
            ..
        })
    ));
    assert!(matches!(
        accel(|c| c.range_mps2 = 0.0),
        Err(Error::NotPositive {
            name: "range_mps2",
            ..
        })
    ));
    assert!(matches!(
        accel(|c| c.limiting_error_mps2 = -0.02),
        Err(Error::Negative {
            name: "limiting_error_mps2",
            ..
        })
    ));
    assert!(matches!(
        accel(|c| c.gravity_mps2 = f64::INFINITY),
        Err(Error::NotFinite {
            name: "gravity_mps2",
            ..
        })
    ));
}

#[test]
fn invalid_process_and_instrument_configuration_is_a_typed_error() {
    assert!(matches!(
        WhiteNoise::new(-1.0, 0.1),
        Err(Error::Negative {
            name: "std_dev",
            ..
        })
    ));
    assert!(matches!(
        ExpCorrelated::new(
            &ExpCorrelatedConfig {
                correlation_time_s: 0.0,
                ..ExpCorrelatedConfig::default()
            },
            0.1
        ),
        Err(Error::NotPositive {
            name: "correlation_time_s",
            ..
        })
    ));
    assert!(matches!(
        IrregularRollingProcess::new(
            &IrregularRollingConfig {
                irregularity_per_s: 0.0,
                ..IrregularRollingConfig::default()
            },
            0.1
        ),
        Err(Error::NotPositive {
            name: "irregularity_per_s",
            ..
        })
    ));
    assert!(matches!(
        IrregularRollingProcess::new(&IrregularRollingConfig::default(), f64::NAN),
        Err(Error::NotFinite { name: "dt_s", .. })
    ));
    assert!(matches!(
        DampedCosineProcess::new(
            &DampedCosineConfig {
                frequency_rad_s: f64::NAN,
                ..DampedCosineConfig::default()
            },
            0.1
        ),
        Err(Error::NotFinite {
            name: "frequency_rad_s",
            ..
        })
    ));
    assert!(matches!(
        PlatformMotion::new(
            &PlatformMotionConfig {
                roll: RollingAxisConfig {
                    max_amplitude_deg: -1.0,
                    ..RollingAxisConfig::default()
                },
                ..PlatformMotionConfig::default()
            },
            0.1
        ),
        Err(Error::Negative {
            name: "max_amplitude_deg",
            ..
        })
    ));
    assert!(matches!(
        Gyro::new(
            &GyroConfig {
                sample_period_s: -0.1,
                ..GyroConfig::default()
            },
            0.1
        ),
        Err(Error::NotPositive {
            name: "sample_period_s",
            ..
        })
    ));
    assert!(matches!(
        ChannelSensor::new(
            &ChannelSensorConfig {
                bandwidth_hz: Some(0.0),
                ..ChannelSensorConfig::default()
            },
            0.01
        ),
        Err(Error::NotPositive {
            name: "bandwidth_hz",
            ..
        })
    ));
    assert!(matches!(
        ChannelSensor::new(
            &ChannelSensorConfig {
                quantization_step: -0.1,
                ..ChannelSensorConfig::default()
            },
            0.01
        ),
        Err(Error::Negative {
            name: "quantization_step",
            ..
        })
    ));
}

#[test]
fn configurations_round_trip_through_serde_and_fill_defaults() {
    let l: LevelSensorConfig = serde_json::from_str(r#"{"step_m": 0.005}"#).expect("parses");
    assert!((l.step_m - 0.005).abs() < 1e-15);
    assert!((l.damper_time_constant_s - 2.0).abs() < 1e-15);
    assert!(serde_json::from_str::<LevelSensorConfig>(r#"{"stepm": 1}"#).is_err());
    let a = AccelerometerConfig {
        sensor_offset_angle: 10f64.to_radians(),
        bias: sensors::BiasVariant::Minus,
        ..AccelerometerConfig::default()
    };
    let back: AccelerometerConfig =
        serde_json::from_str(&serde_json::to_string(&a).expect("serialises")).expect("parses");
    assert_eq!(back, a);
    let p: PlatformMotionConfig =
        serde_json::from_str(r#"{"roll": {"max_amplitude_deg": 0.5}}"#).expect("parses");
    assert!((p.roll.max_amplitude_deg - 0.5).abs() < 1e-15);
    assert!((p.pitch.max_amplitude_deg - 1.0).abs() < 1e-15);
    let u = ChannelSensorConfig::potentiometer();
    let back: ChannelSensorConfig =
        serde_json::from_str(&serde_json::to_string(&u).expect("serialises")).expect("parses");
    assert_eq!(back, u);
    let g: GyroConfig = serde_json::from_str("{}").expect("parses");
    assert_eq!(g, GyroConfig::default());
}
