//! The filters use the symmetric part of a model's `Q_k` and `R_k`: a model whose matrices
//! carry an antisymmetric part (as a `G Gᵀ` summed in another order can, by round-off, or a
//! hand-typed off-diagonal pair that disagrees) filters as the model with their symmetric
//! part, and every covariance the filters report is exactly symmetric.

use kalman::FixedDims;
use kalman::nonlinear::{
    Ekf, EkfUpdate, ForwardPass, GenericModel, Jacobians, NonlinearModel, SigmaPoints, Ukf,
};

use super::models::{RangeBearing, RangeBearingHand};

/// Range and bearing with `s` times an entry added to Q's and R's (0, 1) entries and
/// subtracted from their (1, 0) entries: the symmetric parts are the model's own.
struct Skewed {
    inner: RangeBearingHand,
    s: f64,
}

impl NonlinearModel for Skewed {
    fn f(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]) {
        self.inner.f(x, u, k, out);
    }
    fn h(&mut self, x: &[f64], k: usize, out: &mut [f64]) {
        self.inner.h(x, k, out);
    }
    fn q(&mut self, k: usize, out: &mut [f64]) {
        GenericModel::q(&self.inner.0, k, out);
        // Q(0, 1) is column 1, row 0 (column-major, n = 4).
        out[4] += self.s * out[4];
        out[1] -= self.s * out[1];
    }
    fn r(&mut self, k: usize, out: &mut [f64]) {
        GenericModel::r(&self.inner.0, k, out);
        out[2] += self.s * out[0];
        out[1] -= self.s * out[0];
    }
    fn residual(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        self.inner.residual(a, b, out);
    }
}

impl Jacobians for Skewed {
    fn f_jacobian(&mut self, x: &[f64], u: Option<&[f64]>, k: usize, jac: &mut [f64]) {
        self.inner.f_jacobian(x, u, k, jac);
    }
    fn h_jacobian(&mut self, x: &[f64], k: usize, jac: &mut [f64]) {
        self.inner.h_jacobian(x, k, jac);
    }
}

fn model(s: f64) -> Skewed {
    Skewed {
        inner: RangeBearingHand::default(),
        s,
    }
}

/// The n×n column-major `p` is exactly symmetric.
fn assert_symmetric(p: &[f64], n: usize, what: &str) {
    for j in 0..n {
        for i in 0..j {
            // Exact: a reported covariance is stored once and mirrored.
            let (a, b) = (p[i + j * n], p[j + i * n]);
            assert!(a.to_bits() == b.to_bits(), "{what}: ({i}, {j}) {a} vs {b}");
        }
    }
}

/// Data along a pass of the target near the origin (range and bearing of the prior's track,
/// perturbed).
fn data(k: usize) -> [f64; 2] {
    let t = k as f64;
    let x0 = RangeBearing::x0();
    let (px, py) = (x0[0] + x0[1] * t, x0[2] + x0[3] * t);
    [
        (px * px + py * py).sqrt() + 0.3 * (1.7 * t).sin(),
        py.atan2(px) + 0.005 * (0.9 * t).cos(),
    ]
}

/// Runs the filters on the skewed and on the plain model side by side (`step` advances
/// one and returns its log-likelihood) and compares them at every step.
fn run_pair<F: ForwardPass>(
    mut skew: F,
    mut plain: F,
    mut step: impl FnMut(&mut F, &[f64]) -> f64,
    label: &str,
) {
    let n = 4;
    for k in 0..40 {
        let z = data(k);
        let (la, lb) = (step(&mut skew, &z), step(&mut plain, &z));
        let what = format!("{label} step {k}");
        for (x, p) in [skew.filtered(), skew.predicted()] {
            assert_symmetric(p, n, &what);
            assert_eq!(x.len(), n);
        }
        let ((xa, pa), (xb, pb)) = (skew.filtered(), plain.filtered());
        compare(xa, xb, pa, pb, &what);
        assert!((la - lb).abs() < 1e-9, "{what}: {la} vs {lb}");
    }
}

#[test]
fn an_antisymmetric_part_of_q_and_r_is_ignored_and_covariances_stay_symmetric() {
    let dims = FixedDims::<4, 2, 0>::new();
    let (x0, p0) = (RangeBearing::x0(), RangeBearing::p0());
    let updates = [
        EkfUpdate::Extended,
        EkfUpdate::Iterated {
            max_iterations: 4,
            tolerance: 1e-12,
        },
    ];
    for update in updates {
        let ekf = |s| Ekf::new(dims, model(s), &x0, &p0, update).expect("ekf");
        run_pair(
            ekf(0.3),
            ekf(0.0),
            |f, z| f.step(z, None).expect("step").log_likelihood,
            &format!("{update:?}"),
        );
    }
    for points in [SigmaPoints::Cubature, SigmaPoints::merwe(1.0, 2.0, 0.0)] {
        let ukf = |s| Ukf::new(dims, model(s), &x0, &p0, points).expect("ukf");
        run_pair(
            ukf(0.3),
            ukf(0.0),
            |f, z| f.step(z, None).expect("step").log_likelihood,
            &format!("{points:?}"),
        );
    }
}

/// The symmetric part of `Q + S` is Q up to the rounding of `(q + s) + (q − s)`, a few ulps
/// of the entries (~1e2 in range², 1e-4 in rad²): 1e-9 relative covers forty steps of it.
fn compare(xa: &[f64], xb: &[f64], pa: &[f64], pb: &[f64], what: &str) {
    let n = xa.len();
    for i in 0..n {
        assert!(
            (xa[i] - xb[i]).abs() <= 1e-9 * xb[i].abs().max(1.0),
            "{what}: x[{i}] {} vs {}",
            xa[i],
            xb[i]
        );
        for j in 0..n {
            let scale = (pb[i + i * n] * pb[j + j * n]).sqrt();
            let (a, b) = (pa[i + j * n], pb[i + j * n]);
            assert!(
                (a - b).abs() <= 1e-9 * scale,
                "{what}: P({i}, {j}) {a} vs {b}"
            );
        }
    }
}
