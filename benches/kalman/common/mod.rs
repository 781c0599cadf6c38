//! The deterministic bench problem shared by `benches/kalman/step.rs` and `benches/kalman/steady.rs`
//! (identical to the one `benches/kalman/filterpy_step.py` builds), and its engine model.

use faer::Mat;
use kalman::{Dims, Model};

/// The bench problem: a contractive F, dense H, diagonal Q, R; z_k[i] = sin(0.37 k + 1.3 i).
pub struct Problem {
    pub F: Mat<f64>,
    pub H: Mat<f64>,
    pub Q: Mat<f64>,
    pub R: Mat<f64>,
    pub z: Vec<Vec<f64>>,
}

pub fn problem(n: usize, m: usize) -> Problem {
    let s = 1.0 / (n as f64).sqrt();
    let F = Mat::from_fn(n, n, |i, j| {
        (if i == j { 0.95 } else { 0.0 }) + 0.05 * s * (1.0 + i as f64 + 3.0 * j as f64).sin()
    });
    let H = Mat::from_fn(m, n, |i, j| (1.0 + 2.0 * i as f64 + j as f64).cos());
    let Q = Mat::from_fn(n, n, |i, j| {
        if i == j {
            0.01 * (1.0 + 0.1 * i as f64)
        } else {
            0.0
        }
    });
    let R = Mat::from_fn(m, m, |i, j| {
        if i == j {
            0.1 * (1.0 + 0.1 * i as f64)
        } else {
            0.0
        }
    });
    let z = (0..64)
        .map(|k| {
            (0..m)
                .map(|i| (0.37 * k as f64 + 1.3 * i as f64).sin())
                .collect()
        })
        .collect();
    Problem { F, H, Q, R, z }
}

/// The engine's model of `p` on the storage path `dims`.
pub fn model<D: Dims>(p: &Problem, dims: D) -> Model<D> {
    Model::new(dims, &p.F, &p.H, &p.Q, &p.R).unwrap()
}
