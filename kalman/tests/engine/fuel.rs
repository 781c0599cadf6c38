//! The fuel-level model of SPEC F (7 states, 2 measurements, exact tilt channel R₁₁ = 0,
//! cross-covariance S = B Q Dᵀ) runs 10⁶ steps on the fixed-size path: no NaN, P symmetric,
//! min eigenvalue ≥ −1e-12·trace P. Matrices are written here from SPEC F's formulas with
//! its default parameters (kalman has no sibling dependencies).

use kalman::{CovarianceForm, Filter, FixedDims, Model};
use rand::{RngExt, SeedableRng};

type M7 = [[f64; 7]; 7];
/// (F, G, H, D, diag Qu).
type Fuel = (M7, [[f64; 3]; 7], [[f64; 7]; 2], [[f64; 3]; 2], [f64; 3]);

/// (F, G_u, H, D, Qu) of SPEC F: x_k = A x_{k−1} + B u_{k−1}, z_k = C x_k + D u_k.
fn fuel() -> Fuel {
    let dt: f64 = 0.1;
    let (ta, dc, vc, delta, ty, radius) = (20.0, 1e-6, 0.01, 0.01, 2.0, 1.5);
    let beta = 2.0 * std::f64::consts::PI / 10.0;
    let mu = 0.08;
    let sigma = (1.0_f64 / 3.0).to_radians(); // A_max = 1°, σ = A_max/3 for ψ and θ
    let d_alpha = sigma * sigma; // var(ψ cos φ + θ sin φ) with independent ψ, θ
    let tc = delta / vc;
    let xi = 1.0 / ta;
    let gq = 2.0 * std::f64::consts::PI / tc;
    let a = 2.0 * mu / (mu * mu + beta * beta);
    let b = 1.0 / (mu * mu + beta * beta);
    let c = 2.0 * xi / (xi * xi + gq * gq);
    let d = 1.0 / (xi * xi + gq * gq);
    let pa = (ta - dt / 2.0) / (ta + dt / 2.0);
    let ka = ta * dt / ((ta + dt / 2.0) * (ta + dt / 2.0));
    let ga = dt / (2.0 * (ta + dt / 2.0));
    let qy = (ty - dt / 2.0) / (ty + dt / 2.0);
    let ky = ty * dt / ((ty + dt / 2.0) * (ty + dt / 2.0));
    let gy = dt / (2.0 * (ty + dt / 2.0));
    let n1 = 1.0 + 2.0 * a / dt + 4.0 * b / (dt * dt);
    let a1 = (2.0 - 8.0 * b / (dt * dt)) / n1;
    let a2 = (1.0 - 2.0 * a / dt + 4.0 * b / (dt * dt)) / n1;
    let (b1, b2) = (2.0 / n1, 2.0 / n1);
    let n2 = 1.0 + 2.0 * c / dt + 4.0 * d / (dt * dt);
    let c1 = (2.0 - 8.0 * d / (dt * dt)) / n2;
    let c2 = (1.0 - 2.0 * c / dt + 4.0 * d / (dt * dt)) / n2;
    let d0 = (2.0 + 4.0 * d.sqrt() / dt) / n2;
    let d1 = (2.0 - 4.0 * d.sqrt() / dt) / n2;
    let F = [
        [pa, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [ka, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, -a2, -a1, 0.0, 0.0, 0.0],
        [ka * dt / 2.0, dt, b2, b1, qy, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, -c2, -c1],
    ];
    let G = [
        [1.0, 0.0, 0.0],
        [ga, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [ga * dt / 2.0, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let H = [
        [0.0, 0.0, b2, b1, 0.0, 0.0, 0.0],
        [
            gy * ka * dt / 2.0,
            gy * dt,
            gy * b2,
            gy * b1,
            ky,
            -d0 * c2,
            d1 - d0 * c1,
        ],
    ];
    let D = [[0.0, 0.0, 0.0], [gy * ga * dt / 2.0, 0.0, d0]];
    let Qu = [
        2.0 * ta * dc / dt,
        2.0 * a * d_alpha * radius * radius / dt,
        delta * delta * c / (12.0 * dt),
    ];
    (F, G, H, D, Qu)
}

#[test]
fn fuel_model_runs_a_million_steps() {
    let (F, G, H, D, qu) = fuel();
    // Q = G Qu Gᵀ, R = D Qu Dᵀ (R₁₁ = 0 exactly), S = G Qu Dᵀ.
    let q = |A: &[[f64; 3]], Bm: &[[f64; 3]], i: usize, j: usize| -> f64 {
        (0..3).map(|l| A[i][l] * qu[l] * Bm[j][l]).sum()
    };
    let Q: M7 = std::array::from_fn(|i| std::array::from_fn(|j| q(&G, &G, i, j)));
    let R: [[f64; 2]; 2] = std::array::from_fn(|i| std::array::from_fn(|j| q(&D, &D, i, j)));
    let S: [[f64; 2]; 7] = std::array::from_fn(|i| std::array::from_fn(|j| q(&G, &D, i, j)));
    assert!(R[0][0].abs() < 1e-300 && R[1][1] > 0.0);
    // The mean fill rate V_c enters state 2 as a known input (SPEC F, "things left out" 1).
    let Bc = [[0.0], [1.0], [0.0], [0.0], [0.0], [0.0], [0.0]];
    let vc = 0.01;
    let model = Model::new(FixedDims::<7, 2, 1>::new(), &F, &H, &Q, &R)
        .and_then(|m| m.with_cross_covariance(&S))
        .and_then(|m| m.with_control(&Bc))
        .expect("fuel model is valid");
    let P0: M7 = std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 1e-4 } else { 0.0 }));
    let mut f = Filter::new(model, &[0.0; 7], &P0, CovarianceForm::Joseph).expect("filter");

    // Truth simulated from the same model: x_{k+1} = F x_k + G u_k + Bc V_c,
    // z_k = H x_k + D u_k, u_k ~ N(0, diag Qu).
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2024);
    let sd = qu.map(f64::sqrt);
    let mut x = [0.0_f64; 7];
    let mut min_ratio = f64::INFINITY;
    for k in 0..1_000_000usize {
        let u: [f64; 3] =
            std::array::from_fn(|l| sd[l] * rng.sample::<f64, _>(rand_distr::StandardNormal));
        let z: [f64; 2] = std::array::from_fn(|i| {
            (0..7).map(|j| H[i][j] * x[j]).sum::<f64>()
                + (0..3).map(|l| D[i][l] * u[l]).sum::<f64>()
        });
        let info = f.step(&z, Some(&[vc])).expect("step");
        assert!(
            info.nis.is_some_and(f64::is_finite) && f.state().iter().all(|v| v.is_finite()),
            "NaN at step {k}"
        );
        x = std::array::from_fn(|i| {
            (0..7).map(|j| F[i][j] * x[j]).sum::<f64>()
                + (0..3).map(|l| G[i][l] * u[l]).sum::<f64>()
                + Bc[i][0] * vc
        });
        if k % 10_000 == 0 || k == 999_999 {
            for P in [f.covariance(), f.predicted_covariance()] {
                let mut tr = 0.0;
                for i in 0..7 {
                    tr += P[(i, i)];
                    for j in 0..7 {
                        // The engine mirrors one computed triangle: symmetry is exact.
                        assert!((P[(i, j)] - P[(j, i)]).abs() <= 0.0, "asymmetric P at {k}");
                    }
                }
                let ev = P.self_adjoint_eigenvalues(faer::Side::Lower).expect("evd");
                assert!(
                    ev[0] >= -1e-12 * tr,
                    "step {k}: min eig {} trace {tr}",
                    ev[0]
                );
                min_ratio = min_ratio.min(ev[0] / tr);
            }
        }
    }
    // The level estimate follows the truth (the filter is not merely finite).
    // x is now x_{10⁶}, the predictor's target. 5 cm: the level's steady-state predicted
    // standard deviation is a few mm, so this only fails if the filter has lost track.
    let level = f.predicted_state()[4];
    assert!((level - x[4]).abs() < 0.05, "level {level} vs {}", x[4]);
    println!("fuel: min over checks of min eig / trace = {min_ratio:e}");
}
