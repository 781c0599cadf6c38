//! Platform motion: each axis is the irregular-rolling process with σ = A_max/3, the axes are
//! independent, and the tilt toward φ has the projected correlation.

use approx::assert_relative_eq;
use sensors::{PlatformMotion, PlatformMotionConfig, Process, RollingAxisConfig, seeded_rng};

use crate::stats::{Z, autocov, mean, se_autocov, se_mean};

#[test]
fn tilt_statistics_match_the_projected_correlation() {
    let dt = 0.5;
    let cfg = PlatformMotionConfig {
        roll: RollingAxisConfig::default(),
        pitch: RollingAxisConfig {
            max_amplitude_deg: 0.5,
            period_s: 7.0,
            irregularity_per_s: 0.15,
        },
    };
    let mut m = PlatformMotion::new(&cfg, dt).expect("valid");
    let phi = 30f64.to_radians();
    let mut rng = seeded_rng(41);
    let n = 300_000;
    let (mut tilt, mut cross) = (Vec::with_capacity(n), 0.0);
    for _ in 0..n {
        let a = m.next(&mut rng);
        tilt.push(a.tilt_toward(phi));
        cross += a.roll * a.pitch;
    }
    let r = |t: f64| m.tilt_correlation(phi, t);
    let terms = 1_000; // slowest decay e^{−0.04 j}: < 1e-12 beyond 700 lags
    let se = se_mean(r, dt, n, terms);
    assert!(mean(&tilt).abs() <= Z * se);
    for lag in [0usize, 1, 4, 7, 10, 20] {
        #[allow(clippy::cast_precision_loss)]
        let want = r(lag as f64 * dt);
        let tol = Z * se_autocov(r, dt, lag, n - lag, terms);
        let got = autocov(&tilt, lag);
        assert!(
            (got - want).abs() <= tol,
            "lag {lag}: {got:e} vs {want:e} ± {tol:e}"
        );
    }
    // Independence: E[θψ] = 0. SE of the cross-covariance (Bartlett):
    // √(Σ_j R_θ(j)R_ψ(j) / N).
    let cross = cross / f64::from(u32::try_from(n).expect("small"));
    let mut s = 0.0;
    for j in -(terms as i64)..=(terms as i64) {
        #[allow(clippy::cast_precision_loss)]
        let t = j as f64 * dt;
        s += m.roll().correlation(t) * m.pitch().correlation(t);
    }
    #[allow(clippy::cast_precision_loss)]
    let se = (s.abs() / n as f64).sqrt();
    assert!(cross.abs() <= Z * se, "E[θψ] = {cross:e} ± {:e}", Z * se);
    // σ = A_max/3 per axis.
    assert_relative_eq!(m.pitch().std_dev(), 0.5f64.to_radians() / 3.0);
    assert_relative_eq!(m.roll().variance(), (1f64.to_radians() / 3.0).powi(2));
}

#[test]
fn zero_amplitude_platform_stays_level() {
    let cfg = PlatformMotionConfig {
        roll: RollingAxisConfig {
            max_amplitude_deg: 0.0,
            ..RollingAxisConfig::default()
        },
        pitch: RollingAxisConfig {
            max_amplitude_deg: 0.0,
            ..RollingAxisConfig::default()
        },
    };
    let mut m = PlatformMotion::new(&cfg, 0.1).expect("A_max = 0 is valid");
    let mut rng = seeded_rng(1);
    for _ in 0..100 {
        let a = m.next(&mut rng);
        assert!(a.roll.abs() < f64::MIN_POSITIVE && a.pitch.abs() < f64::MIN_POSITIVE);
    }
}

#[test]
fn platform_is_reproducible() {
    let run = |seed| -> Vec<u64> {
        let mut m = PlatformMotion::new(&PlatformMotionConfig::default(), 0.1).expect("valid");
        let mut rng = seeded_rng(seed);
        (0..500)
            .flat_map(|_| {
                let a = m.next(&mut rng);
                [a.roll.to_bits(), a.pitch.to_bits()]
            })
            .collect()
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3), run(4));
}
