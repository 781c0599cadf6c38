//! Tests of `wls::boom` paths the main boom tests do not reach: every invalid scalar of the
//! rotation profile is rejected by name, before any integration runs.

use wls::Error;
use wls::boom::{Deceleration, RotationProfile};

/// The field an `InvalidParameter` error names, or a panic showing what came instead.
fn invalid_name<T: std::fmt::Debug>(result: Result<T, Error>) -> &'static str {
    match result {
        Err(Error::InvalidParameter { name, .. }) => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

/// A final angle, step or fixed deceleration that is not finite and positive is a typed error
/// naming the field, from both entry points. Each rule has two halves (finite, and > 0), so
/// each is probed with a non-finite value and with a finite value ≤ 0.
#[test]
fn invalid_profile_scalars_are_named() {
    for bad in [f64::NAN, f64::INFINITY, 0.0, -10.0] {
        let cases = [
            (
                RotationProfile {
                    final_angle_deg: bad,
                    ..RotationProfile::default()
                },
                "profile.final_angle_deg",
            ),
            (
                RotationProfile {
                    dt: bad,
                    ..RotationProfile::default()
                },
                "profile.dt",
            ),
            (
                RotationProfile {
                    deceleration: Deceleration::Fixed(bad),
                    ..RotationProfile::default()
                },
                "profile.deceleration",
            ),
        ];
        for (profile, name) in cases {
            assert_eq!(invalid_name(profile.trajectory()), name, "value {bad}");
            assert_eq!(
                invalid_name(profile.solve_deceleration()),
                name,
                "value {bad}"
            );
        }
    }
}
