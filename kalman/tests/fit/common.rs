//! Seeded simulation and the local-linear-trend model shared by the fitting tests.

use kalman::fit::{
    Fit, Free, Matrix, MleOptions, Param, Series, StandardMap, Structure, System, mle,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// A seeded generator.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Simulates `len` steps of `sys` with diagonal Q and R (standard deviations from their
/// diagonals); returns z row-major.
pub fn simulate_diag(sys: &System, len: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let (n, m) = (sys.n(), sys.m());
    let mut x: Vec<f64> = (0..n)
        .map(|i| sys.x0[i] + sys.p0[(i, i)].sqrt() * rng.sample::<f64, _>(StandardNormal))
        .collect();
    let mut z = Vec::with_capacity(len * m);
    for _ in 0..len {
        for r in 0..m {
            let hx: f64 = (0..n).map(|c| sys.h[(r, c)] * x[c]).sum();
            z.push(hx + sys.r[(r, r)].sqrt() * rng.sample::<f64, _>(StandardNormal));
        }
        let mut xn = vec![0.0; n];
        for r in 0..n {
            xn[r] = (0..n).map(|c| sys.f[(r, c)] * x[c]).sum::<f64>()
                + sys.q[(r, r)].sqrt() * rng.sample::<f64, _>(StandardNormal);
        }
        x = xn;
    }
    z
}

/// The local linear trend: level and slope, the level measured.
pub fn llt(q_level: f64, q_slope: f64, r: f64, x0: [f64; 2], p0: [f64; 2]) -> System {
    System::new(
        &[[1.0, 1.0], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &[[q_level, 0.0], [0.0, q_slope]],
        &[[r]],
        &x0,
        &[[p0[0], 0.0], [0.0, p0[1]]],
    )
    .expect("valid LLT")
}

/// AR(1) plus noise: x_{k+1} = φ x_k + w, z = x + v, Var w = q, Var v = r, from x0 = 0,
/// P0 = 1.
pub fn ar1(phi: f64, q: f64, r: f64) -> System {
    System::new(&[[phi]], &[[1.0]], &[[q]], &[[r]], &[0.0], &[[1.0]]).expect("valid AR(1)")
}

/// AR(1) plus noise started far from the data (φ = 0.3, q = r = 2), and the map freeing φ,
/// q and r as entries of F, Q and R.
pub fn ar1_far_start() -> (System, StandardMap) {
    let start = ar1(0.3, 2.0, 2.0);
    let params = vec![
        Param::entry(Matrix::F, 0, 0),
        Param::entry(Matrix::Q, 0, 0),
        Param::entry(Matrix::R, 0, 0),
    ];
    let map = StandardMap::with_params(start.clone(), Free::default(), params).expect("map");
    (start, map)
}

/// The lower and upper limits of a central 99.9 % band of Binomial(n, p): the count lies
/// outside with probability below 0.1 %.
pub fn binomial_band(n: usize, p: f64) -> (usize, usize) {
    // pmf by the recursion pmf(k+1) = pmf(k)·(n−k)/(k+1)·p/(1−p), from pmf(0) = (1−p)^n in logs.
    let mut logpmf = vec![0.0; n + 1];
    logpmf[0] = n as f64 * (1.0 - p).ln();
    for k in 0..n {
        logpmf[k + 1] = logpmf[k] + ((n - k) as f64 / (k + 1) as f64).ln() + (p / (1.0 - p)).ln();
    }
    let pmf: Vec<f64> = logpmf.iter().map(|v| v.exp()).collect();
    let mut lo = 0;
    let mut acc = 0.0;
    while acc + pmf[lo] < 0.0005 {
        acc += pmf[lo];
        lo += 1;
    }
    let mut hi = n;
    let mut acc = 0.0;
    while acc + pmf[hi] < 0.0005 {
        acc += pmf[hi];
        hi -= 1;
    }
    (lo, hi)
}

/// The map freeing Q and R of `base` with structures `q`, `r`, and its converged maximum
/// likelihood fit on `data` from `base` (default options).
pub fn mle_qr(base: &System, q: Structure, r: Structure, data: &Series) -> (StandardMap, Fit) {
    let free = Free {
        q,
        r,
        ..Free::default()
    };
    let map = StandardMap::new(base.clone(), free).expect("map");
    let fit = mle_from(&map, base, data);
    assert!(fit.converged, "{}", fit.message);
    (map, fit)
}

/// The maximum likelihood fit of `map` on `data` from the parameters of `start` (default
/// options).
pub fn mle_from(map: &StandardMap, start: &System, data: &Series) -> Fit {
    mle(
        map,
        map.theta_of(start, Some(data)),
        data,
        &MleOptions::default(),
    )
    .expect("mle")
}
