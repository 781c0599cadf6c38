//! JSON and TOML round trips of every serialisable type; invalid data is rejected on load.

use model::{
    Channels, ContinuousSs, ContinuousTf, DampedCosineShaping, DiscreteSs, DiscreteTf,
    Discretization, ExponentialShaping, FuelModel, FuelParams, IrregularRollingShaping,
    NoiseConvention, Realisation, discretize,
};
use nalgebra::DMatrix;
use serde::{Serialize, de::DeserializeOwned};

fn roundtrip<T: Serialize + DeserializeOwned + PartialEq + std::fmt::Debug>(v: &T) {
    let json = serde_json::to_string(v).expect("to JSON");
    let back: T = serde_json::from_str(&json).expect("from JSON");
    assert_eq!(&back, v, "JSON: {json}");
    let toml_text = toml::to_string(v).expect("to TOML");
    let back: T = toml::from_str(&toml_text).expect("from TOML");
    assert_eq!(&back, v, "TOML:\n{toml_text}");
}

fn sample_continuous() -> ContinuousSs {
    ContinuousSs::new(
        DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -2.0, -0.3]),
        DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
        DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
        DMatrix::zeros(1, 1),
    )
    .expect("valid")
    .with_noise(
        DMatrix::from_row_slice(2, 1, &[0.0, 1.0]),
        DMatrix::from_element(1, 1, 0.4),
    )
    .expect("valid")
}

#[test]
fn state_space_models() {
    let c = sample_continuous();
    roundtrip(&c);
    let d = discretize(
        &c,
        0.1,
        Discretization::Tustin,
        NoiseConvention::IntensityOverDt,
    )
    .expect("ok");
    roundtrip(&d);
    let v = discretize(&c, 0.1, Discretization::Zoh, NoiseConvention::VanLoan).expect("ok");
    roundtrip(&v);
}

#[test]
fn transfer_functions_filters_and_enums() {
    roundtrip(&ContinuousTf::new(vec![1.0, 0.5], vec![1.0, 0.2, 0.1]).expect("valid"));
    roundtrip(&DiscreteTf::new(vec![0.1, 0.1], vec![1.0, -0.8], 0.05).expect("valid"));
    roundtrip(&ExponentialShaping::new(1e-6, 20.0).expect("valid"));
    roundtrip(&IrregularRollingShaping::new(3e-5, 0.08, 0.628).expect("valid"));
    roundtrip(&DampedCosineShaping::new(8.3e-6, 0.05, 6.0).expect("valid"));
    for m in [
        Discretization::Zoh,
        Discretization::Tustin,
        Discretization::TustinPrewarp { omega: 2.0 },
        Discretization::ForwardEuler,
        Discretization::BackwardEuler,
    ] {
        let json = serde_json::to_string(&m).expect("to JSON");
        assert_eq!(
            serde_json::from_str::<Discretization>(&json).expect("from JSON"),
            m
        );
    }
}

#[test]
fn fuel_params_and_model() {
    roundtrip(&FuelParams::default());
    let odd = FuelParams {
        max_tilt_amplitude: 0.0,
        gyro_noise_var: 1e-7,
        ..FuelParams::default()
    };
    roundtrip(&odd);
    for (ch, re) in [
        (Channels::LevelAndTilt, Realisation::Paper),
        (Channels::LevelOnly, Realisation::Zoh),
    ] {
        let m: FuelModel = FuelParams::default().build(ch, re).expect("builds");
        roundtrip(&m);
    }
    // Partial TOML: missing fields take the documented defaults; unknown fields are errors.
    let p: FuelParams = toml::from_str("dt = 0.05\nt_y = 3.0\n").expect("partial TOML");
    assert_eq!(
        p,
        FuelParams {
            dt: 0.05,
            t_y: 3.0,
            ..FuelParams::default()
        }
    );
    assert!(toml::from_str::<FuelParams>("dtt = 0.05\n").is_err());
}

#[test]
fn invalid_data_is_rejected_on_load() {
    let c = sample_continuous();
    let mut v: serde_json::Value = serde_json::to_value(&c).expect("to JSON");
    // Replace A by a 1×1 matrix (same format as nalgebra writes it).
    v["a"] = serde_json::to_value(DMatrix::from_element(1, 1, 1.0)).expect("to JSON");
    let e = serde_json::from_value::<ContinuousSs>(v).expect_err("mismatched A must fail");
    assert!(e.to_string().contains("B"), "{e}");
    let bad_dt = r#"{"num":[1.0],"den":[1.0],"dt":-1.0}"#;
    let e = serde_json::from_str::<DiscreteTf>(bad_dt).expect_err("negative dt must fail");
    assert!(e.to_string().contains("dt"), "{e}");
    let bad = r#"{"variance":1.0,"time_constant":0.0}"#;
    assert!(serde_json::from_str::<ExponentialShaping>(bad).is_err());
    let d: DiscreteSs = discretize(
        &c,
        0.1,
        Discretization::Zoh,
        NoiseConvention::IntensityOverDt,
    )
    .expect("ok");
    let mut v = serde_json::to_value(&d).expect("to JSON");
    v["q"] = serde_json::to_value(DMatrix::from_element(1, 1, -1.0)).expect("to JSON");
    let e = serde_json::from_value::<DiscreteSs>(v).expect_err("negative Q must fail");
    assert!(e.to_string().contains("Q"), "{e}");
}
