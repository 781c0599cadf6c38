//! Property tests: the rolling discretisation against an independent Van Loan computation,
//! the lag against closed forms, quantizer and accelerometer bounds and formulas.

use approx::relative_eq;
use nalgebra::Matrix4;
use proptest::prelude::*;
use sensors::{
    Accelerometer, AccelerometerConfig, BoomMotion, FirstOrderLag, IrregularRollingConfig,
    IrregularRollingProcess, LagInput, Quantizer, Rounding, seeded_rng,
};

proptest! {
    /// Q_d of the rolling filter equals the Van Loan integral (matrix exponential of the
    /// block matrix [[−A, G q Gᵀ], [0, Aᵀ]]·Δt, nalgebra's Padé `exp`), and Φ = e^{AΔt}.
    #[test]
    fn rolling_discretisation_matches_van_loan(
        mu in 0.02f64..1.0,
        period in 1.0f64..30.0,
        dt in 0.02f64..2.0,
    ) {
        let p = IrregularRollingProcess::new(
            &IrregularRollingConfig { std_dev: 1.0, period_s: period, irregularity_per_s: mu },
            dt,
        ).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let beta = 2.0 * std::f64::consts::PI / period;
        let w2 = mu * mu + beta * beta;
        // ẍ + 2μẋ + ω₀²x = noise of intensity q; unit variance needs q = 4μω₀².
        let q = 4.0 * mu * w2;
        #[rustfmt::skip]
        let m = Matrix4::new(
            0.0, -1.0, 0.0, 0.0,
            w2, 2.0 * mu, 0.0, q,
            0.0, 0.0, 0.0, -w2,
            0.0, 0.0, 1.0, -2.0 * mu,
        ) * dt;
        let e = m.exp();
        let phi = e.fixed_view::<2, 2>(2, 2).transpose();
        let qd = phi * e.fixed_view::<2, 2>(0, 2);
        let (f, qp) = (p.transition(), p.noise_covariance());
        // Entries are O(1)·(1, ω₀, ω₀²); Padé scaling-and-squaring and the stationarity
        // identity both carry ~1e-14 absolute error per unit of ‖M‖; 1e-9 leaves room.
        for i in 0..2 {
            for j in 0..2 {
                prop_assert!(relative_eq!(f[i][j], phi[(i, j)], epsilon = 1e-9 * (1.0 + w2)),
                    "Φ[{i}][{j}] {} vs {}", f[i][j], phi[(i, j)]);
                prop_assert!(relative_eq!(qp[i][j], qd[(i, j)], epsilon = 1e-9 * (1.0 + w2)),
                    "Q[{i}][{j}] {} vs {}", qp[i][j], qd[(i, j)]);
            }
        }
        // PSD.
        prop_assert!(qp[0][0] >= 0.0 && qp[1][1] >= 0.0);
        prop_assert!(qp[0][0] * qp[1][1] - qp[0][1] * qp[0][1] >= -1e-15 * w2);
    }

    /// The piecewise-linear lag is exact for any ramp from any initial state.
    #[test]
    fn lag_is_exact_for_ramps(
        tc in 0.05f64..20.0,
        dt in 0.001f64..1.0,
        y0 in -5.0f64..5.0,
        u0 in -5.0f64..5.0,
        slope in -3.0f64..3.0,
        steps in 1usize..50,
    ) {
        let mut lag = FirstOrderLag::new(tc, dt, LagInput::PiecewiseLinear)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        lag.reset_to(y0, u0);
        let mut y = y0;
        for k in 1..=steps {
            #[allow(clippy::cast_precision_loss)]
            let t = k as f64 * dt;
            y = lag.step(u0 + slope * t);
        }
        #[allow(clippy::cast_precision_loss)]
        let t = steps as f64 * dt;
        // y(t) = u(t) − T·s + (y0 − u0 + T·s)·e^{−t/T}.
        let want = u0 + slope * t - tc * slope + (y0 - u0 + tc * slope) * (-t / tc).exp();
        prop_assert!(relative_eq!(y, want, epsilon = 1e-10 * (1.0 + want.abs() + tc * slope.abs())),
            "{y} vs {want}");
    }

    /// Floor quantization error lies in [−δ, 0]; nearest in [−δ/2, δ/2] (to rounding).
    #[test]
    fn quantizer_error_bounds(x in -1e3f64..1e3, delta in 1e-4f64..1.0) {
        let slack = 1e-12 * (1.0 + x.abs());
        let f = Quantizer::new("q", delta, Rounding::Floor, 0.0)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        let e = f.quantize(x) - x;
        prop_assert!(e <= slack && e >= -delta - slack, "floor error {e}");
        let n = Quantizer::new("q", delta, Rounding::Nearest, 0.0)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        let e = n.quantize(x) - x;
        prop_assert!(e.abs() <= delta / 2.0 + slack, "nearest error {e}");
    }

    /// Noise-free readings equal SPEC B's formulas and every reading stays within range.
    #[test]
    fn accelerometer_formulas_and_range(
        alpha_deg in -10.0f64..100.0,
        gamma_deg in -90.0f64..=90.0,
        omega in -0.5f64..0.5,
        eps in -2.0f64..2.0,
        noise in 0.0f64..3.0,
        seed in 0u64..1000,
    ) {
        let cfg = AccelerometerConfig {
            sensor_offset_angle: gamma_deg.to_radians(),
            centripetal: true,
            ..AccelerometerConfig::default()
        };
        let acc = Accelerometer::new(&cfg).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let m = BoomMotion { angle: alpha_deg.to_radians(), rate: omega, acceleration: eps };
        let c = acc.clean(m);
        let d = (alpha_deg - gamma_deg).to_radians();
        prop_assert!(relative_eq!(c.x, 9.8 * d.sin() - omega * omega * 25.0, epsilon = 1e-12));
        prop_assert!(relative_eq!(c.y, 9.8 * d.cos() + eps * 25.0, epsilon = 1e-12));
        let noisy = Accelerometer::new(&AccelerometerConfig { noise_std_mps2: noise, ..cfg })
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        let out = noisy.measure(m, &mut seeded_rng(seed));
        prop_assert!(out.iter().all(|v| v.abs() <= 10.0));
    }
}
