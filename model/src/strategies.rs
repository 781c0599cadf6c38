//! Proptest strategies (feature `proptest`): random stable systems, SPD matrices with a chosen
//! condition number, and valid fuel-model parameter sets, for users' own property tests.

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

use crate::fuel::FuelParams;
use crate::ss::{ContinuousSs, DiscreteSs};

fn matrix(rows: usize, cols: usize, lo: f64, hi: f64) -> impl Strategy<Value = DMatrix<f64>> {
    prop::collection::vec(lo..hi, rows * cols).prop_map(move |v| DMatrix::from_vec(rows, cols, v))
}

/// An orthogonal n×n matrix (Q of a QR factorisation of a random matrix, diagonal of R made
/// positive).
fn orthogonal(n: usize) -> impl Strategy<Value = DMatrix<f64>> {
    matrix(n, n, -1.0, 1.0).prop_map(move |m| {
        // Shift by n·I so the random matrix is safely non-singular.
        let m = m + DMatrix::<f64>::identity(n, n) * (n as f64);
        let qr = m.qr();
        let mut q = qr.q();
        let r = qr.r();
        for j in 0..n {
            if r[(j, j)] < 0.0 {
                q.column_mut(j).neg_mut();
            }
        }
        q
    })
}

/// A symmetric positive definite n×n matrix with 2-norm condition number exactly `cond`
/// (≥ 1): `U·diag(λ)·Uᵀ`, U random orthogonal, λ from `cond` down to 1 (log-spaced ends,
/// random interior).
///
/// # Example
/// ```
/// use model::strategies::spd_matrix;
/// use proptest::prelude::*;
///
/// proptest!(|(m in spd_matrix(4, 100.0))| {
///     let eig = m.clone().symmetric_eigen().eigenvalues;
///     let cond = eig.max() / eig.min();
///     prop_assert!((cond - 100.0).abs() < 1e-6 * 100.0);
/// });
/// ```
pub fn spd_matrix(n: usize, cond: f64) -> impl Strategy<Value = DMatrix<f64>> {
    let cond = if cond.is_finite() { cond.max(1.0) } else { 1.0 };
    (orthogonal(n), prop::collection::vec(0.0..1.0f64, n)).prop_map(move |(u, t)| {
        let lam: Vec<f64> = (0..n)
            .map(|i| {
                let frac = if i == 0 {
                    1.0
                } else if i + 1 == n {
                    0.0
                } else {
                    t[i]
                };
                cond.powf(frac)
            })
            .collect();
        let d = DMatrix::from_diagonal(&DVector::from_vec(lam));
        crate::validate::symmetrize(&(&u * d * u.transpose()))
    })
}

/// (n, l, m) with 1 ≤ n ≤ `max_states`, 1 ≤ l ≤ `max_inputs`, 1 ≤ m ≤ `max_outputs`.
fn sizes(
    max_states: usize,
    max_inputs: usize,
    max_outputs: usize,
) -> impl Strategy<Value = (usize, usize, usize)> {
    (
        1..=max_states.max(1),
        1..=max_inputs.max(1),
        1..=max_outputs.max(1),
    )
}

/// (B, C, D, G, noise covariance) of [`io_matrices`].
type IoMatrices = (
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
    DMatrix<f64>,
);

/// The input, output, feed-through and noise matrices of a model with n states, l control
/// and l noise inputs and m outputs: B (n×l), C (m×n), D (m×l), G (n×l) with entries in
/// [−1, 1], and an SPD noise covariance (l×l, condition ≤ 10).
fn io_matrices(n: usize, l: usize, m: usize) -> impl Strategy<Value = IoMatrices> {
    (
        matrix(n, l, -1.0, 1.0),
        matrix(m, n, -1.0, 1.0),
        matrix(m, l, -1.0, 1.0),
        matrix(n, l, -1.0, 1.0),
        spd_matrix(l, 10.0),
    )
}

/// A random stable continuous model with 1..=`max_states` states, 1..=`max_inputs` control
/// inputs, 1..=`max_outputs` outputs and as many noise inputs as control inputs (W SPD with
/// condition ≤ 10).
///
/// `A = −(M Mᵀ/n + εI) + (K − Kᵀ)/2` with entries of M, K in [−1, 1] and ε ∈ [0.1, 1]: its
/// symmetric part is ≤ −εI, so every eigenvalue has real part ≤ −ε, and ‖A‖ ≤ 1 + n.
///
/// # Example
/// ```
/// use model::strategies::stable_continuous;
/// use proptest::prelude::*;
///
/// proptest!(|(sys in stable_continuous(4, 1, 1))| {
///     prop_assert!(model::spectral_abscissa(sys.a()).expect("finite") < 0.0);
/// });
/// ```
pub fn stable_continuous(
    max_states: usize,
    max_inputs: usize,
    max_outputs: usize,
) -> impl Strategy<Value = ContinuousSs> {
    sizes(max_states, max_inputs, max_outputs)
        .prop_flat_map(|(n, l, m)| {
            (
                matrix(n, n, -1.0, 1.0),
                matrix(n, n, -1.0, 1.0),
                0.1..1.0f64,
                io_matrices(n, l, m),
            )
        })
        .prop_filter_map("valid model", |(mm, k, eps, (b, c, d, g, w))| {
            let n = mm.nrows();
            let a = -(&mm * mm.transpose() / n as f64 + DMatrix::<f64>::identity(n, n) * eps)
                + (&k - k.transpose()) * 0.5;
            ContinuousSs::new(a, b, c, d).ok()?.with_noise(g, w).ok()
        })
}

/// A random stable discrete model: `F = r·M/‖M‖₂` with r ∈ [0, 0.95] (so the spectral radius
/// is ≤ 0.95), Δt ∈ [0.01, 1], other matrices with entries in [−1, 1], noise covariance SPD
/// (condition ≤ 10), `J = 0`.
///
/// # Example
/// ```
/// use model::strategies::stable_discrete;
/// use proptest::prelude::*;
///
/// proptest!(|(sys in stable_discrete(4, 1, 1))| {
///     prop_assert!(model::spectral_radius(sys.f()).expect("finite") < 1.0);
/// });
/// ```
pub fn stable_discrete(
    max_states: usize,
    max_inputs: usize,
    max_outputs: usize,
) -> impl Strategy<Value = DiscreteSs> {
    sizes(max_states, max_inputs, max_outputs)
        .prop_flat_map(|(n, l, m)| {
            (
                matrix(n, n, -1.0, 1.0),
                0.0..0.95f64,
                io_matrices(n, l, m),
                0.01..1.0f64,
            )
        })
        .prop_filter_map("valid model", |(mm, r, (b, c, d, g, q), dt)| {
            let norm = mm.clone().svd(false, false).singular_values.max();
            if norm <= 1e-6 {
                return None;
            }
            let f = mm * (r / norm);
            let (m, p) = (c.nrows(), g.ncols());
            DiscreteSs::new(f, b, c, d, dt)
                .ok()?
                .with_noise(g, DMatrix::zeros(m, p), q)
                .ok()
        })
}

/// Valid fuel-model parameter sets around [`FuelParams::default`]'s assumed values:
/// Δt ∈ [0.02, 0.5] s,
/// T_a ∈ [5, 60] s, D_c ∈ [1e-7, 1e-5] (m/s)², V_c ∈ [2, 50] mm/s, δ ∈ [2, 20] mm,
/// T_y ∈ [0.5, 5] s, R ∈ [0.5, 3] m, φ ∈ [0, 2π), rolling period ∈ [5, 20] s,
/// μ ∈ [0.02, 0.3] 1/s, A_max ∈ [0, 2]°, gyro noise variance ∈ [0, 1e-6] rad².
///
/// # Example
/// ```
/// use model::strategies::fuel_params;
/// use proptest::prelude::*;
///
/// proptest!(|(p in fuel_params())| {
///     prop_assert!(p.validate().is_ok());
/// });
/// ```
pub fn fuel_params() -> impl Strategy<Value = FuelParams> {
    (
        (0.02..0.5f64, 5.0..60.0f64, 1e-7..1e-5f64, 0.002..0.05f64),
        (
            0.002..0.02f64,
            0.5..5.0f64,
            0.5..3.0f64,
            0.0..std::f64::consts::TAU,
        ),
        (5.0..20.0f64, 0.02..0.3f64, 0.0..2.0f64, 0.0..1e-6f64),
    )
        .prop_map(
            |((dt, t_a, d_c, v_c), (delta, t_y, r, phi), (period, mu, amax_deg, gyro))| {
                FuelParams {
                    dt,
                    t_a,
                    d_c,
                    v_c,
                    delta,
                    t_y,
                    sensor_radius: r,
                    phi,
                    rolling_period: period,
                    mu,
                    max_tilt_amplitude: amax_deg.to_radians(),
                    gyro_noise_var: gyro,
                }
            },
        )
}
