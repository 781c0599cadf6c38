//! The range-and-bearing track shared by `benches/kalman/nonlinear.rs` and
//! `benches/kalman/imm.rs` (the FilterPy script's data): its measurements and prior.

/// 64 measurements of a circle of radius 50 m centred 200 m out, one turn per 64 steps,
/// with a deterministic ripple standing in for noise (the FilterPy script's data).
pub fn measurements() -> Vec<[f64; 2]> {
    (0..64)
        .map(|k| {
            let t = 2.0 * std::f64::consts::PI * k as f64 / 64.0;
            let (px, py) = (200.0 + 50.0 * t.cos(), 50.0 * t.sin());
            [
                px.hypot(py) + 0.3 * (1.7 * k as f64).sin(),
                py.atan2(px) + 0.005 * (2.3 * k as f64).cos(),
            ]
        })
        .collect()
}

/// The prior mean: (px, vx, py, vy).
pub const X0: [f64; 4] = [250.0, 0.0, 0.0, 4.9];
/// The prior covariance.
pub const P0: [[f64; 4]; 4] = [
    [10.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 10.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];
