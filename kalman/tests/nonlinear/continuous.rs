//! Continuous dynamics over a record's time stamps (`TimeStamped`): the RK4 map of a linear
//! model against its stability polynomial and `expm`, of ẋ = −x³ against the closed form
//! (value and Jacobian), a pendulum's EKF + RTS Monte Carlo NEES on an irregular clock, the
//! typed errors, and no allocation per step.

use kalman::nonlinear::{
    AutoDiff, ContinuousDynamics, DEFAULT_MAX_SUBSTEP, Ekf, EkfUpdate, GenericModel, Jacobians,
    NonlinearRts, Scalar, SigmaPoints, TimeStamped, Ukf,
};
use kalman::{DynDims, Error, chi2_quantile};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::common::assert_f_non_finite_at;
use crate::common::counting::allocations;

/// ẋ = A x with a noise intensity W, position measured.
struct LinearDyn {
    a: [[f64; 2]; 2],
    w: [f64; 4],
}

impl ContinuousDynamics for LinearDyn {
    fn a<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _t: f64, out: &mut [T]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = x[0] * self.a[i][0] + x[1] * self.a[i][1];
        }
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0];
    }
    fn w(&self, _t: f64, out: &mut [f64]) {
        out.copy_from_slice(&self.w);
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out[0] = 1.0;
    }
}

type M2 = [[f64; 2]; 2];

fn mm(a: &M2, b: &M2) -> M2 {
    let mut c = [[0.0; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
        }
    }
    c
}

fn norm(a: &M2) -> f64 {
    a.iter().flatten().map(|v| v * v).sum::<f64>().sqrt()
}

/// `F P Fᵀ + W Δt` (P, W row-major 2×2).
fn propagate(f: &M2, p: &M2, w: &M2, dt: f64) -> M2 {
    let fp = mm(f, p);
    let ft = [[f[0][0], f[1][0]], [f[0][1], f[1][1]]];
    let mut out = mm(&fp, &ft);
    for i in 0..2 {
        for j in 0..2 {
            out[i][j] += w[i][j] * dt;
        }
    }
    out
}

/// RK4 applied to ẋ = A x over one step h is the degree-4 Taylor polynomial of `e^{hA}`
/// (its stability function), so s sub-steps are `R(hA)^s`: an independent statement of what
/// the integrator must compute.
fn rk4_power(a: &M2, h: f64, s: usize) -> M2 {
    let ha = [[h * a[0][0], h * a[0][1]], [h * a[1][0], h * a[1][1]]];
    let mut r = [[1.0, 0.0], [0.0, 1.0]];
    let mut term = r;
    for j in 1..=4 {
        term = mm(&term, &ha);
        for (ri, ti) in r.iter_mut().zip(&term) {
            for (rv, tv) in ri.iter_mut().zip(ti) {
                *rv += tv / [1.0, 1.0, 2.0, 6.0, 24.0][j];
            }
        }
    }
    let mut out = [[1.0, 0.0], [0.0, 1.0]];
    for _ in 0..s {
        out = mm(&out, &r);
    }
    out
}

fn sub(a: &M2, b: &M2) -> M2 {
    [
        [a[0][0] - b[0][0], a[0][1] - b[0][1]],
        [a[1][0] - b[1][0], a[1][1] - b[1][1]],
    ]
}

/// The spectral norm of a 2×2 matrix: the square root of the largest eigenvalue of `MᵀM`.
fn norm2(m: &M2) -> f64 {
    let a = m[0][0] * m[0][0] + m[1][0] * m[1][0];
    let c = m[0][1] * m[0][1] + m[1][1] * m[1][1];
    let b = m[0][0] * m[0][1] + m[1][0] * m[1][1];
    (0.5 * (a + c) + (0.25 * (a - c) * (a - c) + b * b).sqrt()).sqrt()
}

fn diff(a: &M2, b: &M2) -> f64 {
    let d = [
        [a[0][0] - b[0][0], a[0][1] - b[0][1]],
        [a[1][0] - b[1][0], a[1][1] - b[1][1]],
    ];
    norm(&d)
}

fn col_major(p: faer::MatRef<'_, f64>) -> M2 {
    [[p[(0, 0)], p[(0, 1)]], [p[(1, 0)], p[(1, 1)]]]
}

/// Linear dynamics on an irregular clock (a one-instant pair, intervals from 3 ms to 1.2 s):
/// the EKF's and the UKF's one-step predictions from the filter's own previous moments.
///
/// - Against `R(hA)^s` (the RK4 stability polynomial) to round-off: `1e-13` relative,
///   some hundred flops of unit-size entries per interval.
/// - Against `F = e^{AΔt}` from `kalman::continuous::expm`, to RK4's error: with the one
///   sub-step error `ε = ‖R(hA) − e^{hA}‖` (the Taylor remainder, `≈ (h‖A‖)⁵/120`; here
///   evaluated with `expm(hA)`) and `g = max(‖R(hA)‖, ‖e^{hA}‖)`, the telescoping sum
///   `R^s − E^s = Σ_j R^j (R − E) E^{s−1−j}` gives `δ = ‖R^s − e^{AΔt}‖ ≤ s ε g^{s−1}`; the
///   mean's error is at most `δ ‖x‖` and the covariance's `(2 ‖F‖ + δ) δ ‖P‖` (spectral
///   norms; the Frobenius norm of a 2×2 difference is at most √2 times its spectral norm).
///   A floor of 1e-13 covers the round-off of `expm` and of the products. The bounds are 2
///   to 15 times the errors seen, which reach 2e-6 over the 1.2 s interval.
#[test]
fn linear_dynamics_predict_as_the_matrix_exponential() {
    let a = [[0.0, 1.0], [-4.0, -0.4]];
    let w = [[0.01, 0.002], [0.002, 0.3]];
    let dyn_w = [w[0][0], w[1][0], w[0][1], w[1][1]];
    let t = [0.0, 0.003, 0.14, 0.14, 0.5, 1.7, 1.75];
    let hmax = 0.05;
    let d = DynDims::new(2, 1, 0).expect("dims");
    let model = || {
        TimeStamped::new(LinearDyn { a, w: dyn_w }, d, &t)
            .and_then(|m| m.with_max_substep(hmax))
            .expect("model")
    };
    let x0 = [1.0, -0.5];
    let p0 = [[0.2, 0.05], [0.05, 0.4]];
    let mut ekf =
        Ekf::new(d, AutoDiff::new(d, model()), &x0, &p0, EkfUpdate::Extended).expect("ekf");
    let mut ukf = Ukf::new(
        d,
        AutoDiff::new(d, model()),
        &x0,
        &p0,
        SigmaPoints::merwe(0.5, 2.0, 0.0),
    )
    .expect("ukf");
    let mut worst_expm = 0.0_f64;
    for k in 0..t.len() {
        let x = ekf.predicted_state().to_vec();
        let p = col_major(ekf.predicted_covariance());
        let xu = ukf.predicted_state().to_vec();
        ekf.step(&[f64::NAN], None).expect("ekf step");
        ukf.step(&[f64::NAN], None).expect("ukf step");
        let m = ekf.model().inner();
        let dt = m.interval(k);
        let s = m.substeps(k);
        assert_eq!(s, (dt / hmax).ceil() as usize);
        let h = if s == 0 { 0.0 } else { dt / s as f64 };
        let rk = rk4_power(&a, h, s);
        let ad = [[a[0][0] * dt, a[0][1] * dt], [a[1][0] * dt, a[1][1] * dt]];
        let e = kalman::continuous::expm(ad).expect("expm");
        let f = [[e[(0, 0)], e[(0, 1)]], [e[(1, 0)], e[(1, 1)]]];
        let xn = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let pn = norm(&p);
        // Against the stability polynomial, to round-off.
        let round = 1e-13 * (1.0 + s as f64);
        for (i, row) in rk.iter().enumerate() {
            let want = row[0] * x[0] + row[1] * x[1];
            let got = ekf.predicted_state()[i];
            assert!(
                (got - want).abs() <= round * xn,
                "k {k}: EKF x[{i}] {got} vs {want}"
            );
            let want_u = row[0] * xu[0] + row[1] * xu[1];
            let got_u = ukf.predicted_state()[i];
            assert!((got_u - want_u).abs() <= round * xn, "k {k}: UKF x[{i}]");
        }
        let pp = col_major(ekf.predicted_covariance());
        assert!(
            diff(&pp, &propagate(&rk, &p, &w, dt)) <= round * pn.max(1.0),
            "k {k}: P"
        );
        // Against e^{AΔt}, to RK4's error bound.
        let ah = [[a[0][0] * h, a[0][1] * h], [a[1][0] * h, a[1][1] * h]];
        let eh = kalman::continuous::expm(ah).expect("expm");
        let eh = [[eh[(0, 0)], eh[(0, 1)]], [eh[(1, 0)], eh[(1, 1)]]];
        let r1 = rk4_power(&a, h, 1);
        let eps = norm2(&sub(&r1, &eh));
        let g = norm2(&r1).max(norm2(&eh));
        let delta = s as f64 * eps * g.powi(s.max(1) as i32 - 1) + 1e-13;
        let xe = [
            f[0][0] * x[0] + f[0][1] * x[1],
            f[1][0] * x[0] + f[1][1] * x[1],
        ];
        let ex = ((ekf.predicted_state()[0] - xe[0]).powi(2)
            + (ekf.predicted_state()[1] - xe[1]).powi(2))
        .sqrt();
        assert!(
            ex <= delta * xn,
            "k {k}: mean error {ex:e} > {:e}",
            delta * xn
        );
        let ep = diff(&pp, &propagate(&f, &p, &w, dt));
        let bound = 2f64.sqrt() * (2.0 * norm2(&f) + delta) * delta * pn + 1e-14 * pn;
        assert!(ep <= bound, "k {k}: covariance error {ep:e} > {bound:e}");
        worst_expm = worst_expm.max(ex / xn);
    }
    // The RK4 error is seen (the check above is not vacuous): h = 0.05 leaves ~1e-7.
    assert!(worst_expm > 1e-10, "{worst_expm:e}");
}

/// ẋ = −x³, whose flow is `x(t) = x0 / √(1 + 2 x0² t)` with `∂x(t)/∂x0 = (1 + 2 x0² t)^{-3/2}`.
#[derive(Clone, Debug)]
struct Cubic;

impl ContinuousDynamics for Cubic {
    fn a<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _t: f64, out: &mut [T]) {
        out[0] = -(x[0] * x[0] * x[0]);
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0];
    }
    fn w(&self, _t: f64, out: &mut [f64]) {
        out[0] = 1e-2;
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out[0] = 1.0;
    }
}

/// The integrated map and its AD Jacobian against the closed form over intervals of 0.01,
/// 0.25, 0 (one instant), 1 and 3 time units, at two sub-steps. RK4 is fourth order, so
/// its global error is `e(h) ≈ C h⁴`: from s to s' sub-steps the error shrinks by
/// `ρ = (s'/s)⁴`, and Richardson's estimate `|y_h − y_h'| · ρ/(ρ − 1)` is the error of
/// `y_h` to leading order. The test asks for both: the ratio `e(h)/e(h')` within 25 % of ρ
/// (the next order's share is `O(h x0²)` relative, ≤ 1 % at these sub-steps), and `e(h)`
/// within twice Richardson's estimate; the errors (1e-10 and more) stand well above the
/// round-off of 1500 sub-steps (1e-13). An integrator of lower order, or a wrong stage
/// time or weight, fails the ratio.
#[test]
fn cubic_decay_matches_its_closed_form_and_derivative() {
    let t = [0.0, 0.01, 0.26, 0.26, 1.26, 4.26];
    let x0 = 1.5;
    let d = DynDims::new(1, 1, 0).expect("dims");
    let at = |hmax: f64| {
        let m = TimeStamped::new(Cubic, d, &t)
            .and_then(|m| m.with_max_substep(hmax))
            .expect("model");
        let mut ad = AutoDiff::new(d, m.clone());
        (0..t.len())
            .map(|k| {
                let (mut y, mut jac) = ([0.0_f64], [0.0_f64]);
                m.f(&[x0], None, k, &mut y);
                ad.f_jacobian(&[x0], None, k, &mut jac);
                (y[0], jac[0], m.substeps(k))
            })
            .collect::<Vec<_>>()
    };
    let (coarse, fine) = (at(0.004), at(0.002));
    for k in 0..t.len() {
        let dt = if k + 1 < t.len() {
            t[k + 1] - t[k]
        } else {
            0.0
        };
        let g = 1.0 + 2.0 * x0 * x0 * dt;
        let (x, dx) = (x0 / g.sqrt(), g.powf(-1.5));
        if dt <= 0.0 {
            // One instant (and the last row): the identity map, exactly.
            assert_eq!(coarse[k].0.to_bits(), x0.to_bits());
            assert_eq!(coarse[k].1.to_bits(), 1.0_f64.to_bits());
            assert_eq!(coarse[k].2, 0);
            continue;
        }
        let rho = (fine[k].2 as f64 / coarse[k].2 as f64).powi(4);
        for (name, exact, yh, yh2) in [
            ("x", x, coarse[k].0, fine[k].0),
            ("dx/dx0", dx, coarse[k].1, fine[k].1),
        ] {
            let (eh, eh2) = ((yh - exact).abs(), (yh2 - exact).abs());
            let richardson = (yh - yh2).abs() * rho / (rho - 1.0);
            assert!(eh > 1e-13, "k {k} {name}: error {eh:e} near round-off");
            assert!(
                (0.75 * rho..=1.25 * rho).contains(&(eh / eh2)),
                "k {k} {name}: error ratio {} for rho {rho} (errors {eh:e}, {eh2:e})",
                eh / eh2
            );
            assert!(
                eh <= 2.0 * richardson,
                "k {k} {name}: {eh:e} vs {richardson:e}"
            );
        }
    }
}

/// A damped pendulum, x = (θ, ω): `θ̇ = ω`, `ω̇ = −(g/L) sin θ − c ω + w`, its angle
/// measured.
struct Pendulum {
    q: f64,
    sigma: f64,
}

const G_L: f64 = 9.81;
const DAMP: f64 = 0.3;
/// The record's intervals are drawn from [DT_LO, DT_HI] (seconds).
const DT_LO: f64 = 0.005;
const DT_HI: f64 = 0.025;
const ROWS: usize = 100;

impl ContinuousDynamics for Pendulum {
    fn a<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _t: f64, out: &mut [T]) {
        out[0] = x[1];
        out[1] = -x[0].sin() * G_L - x[1] * DAMP;
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0];
    }
    fn w(&self, _t: f64, out: &mut [f64]) {
        out.copy_from_slice(&[0.0, 0.0, 0.0, self.q]);
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out[0] = self.sigma * self.sigma;
    }
}

/// `eᵀ P⁻¹ e` of a 2×2 SPD P (by its closed-form solve).
fn nees(e: [f64; 2], p: &M2) -> f64 {
    let det = p[0][0] * p[1][1] - p[0][1] * p[1][0];
    (e[0] * (p[1][1] * e[0] - p[0][1] * e[1]) + e[1] * (p[0][0] * e[1] - p[1][0] * e[0])) / det
}

/// The EKF and its RTS smoother over an irregular record (100 rows, intervals from 5 to
/// 25 ms and one pair at one instant; a swing of 0.8 rad, far from the small-angle regime),
/// 200 runs. The truth is simulated independently of the filter's RK4 and of its
/// `Q = W Δt`: Euler–Maruyama at 0.5 ms, with the prior drawn from the filter's own.
/// At each row R times the Monte Carlo mean NEES is χ²(R n) if the estimates are
/// consistent; every row's mean NEES, filtered and smoothed, must lie in the two-sided
/// 99.99 % band (200 checks: at most a 2 % chance that one falls outside by luck; seeded).
///
/// The approximations left are the EKF's linearisation (σ_θ ≈ 0.02 rad after the first
/// rows, so sin's curvature is negligible over the spread), Euler–Maruyama's weak error
/// (0.5 ms against a 2 s period) and the first-order `Q`, which lacks the
/// `(A W + W Aᵀ) Δt²/2` cross term. That last one is visible: with 2000 runs the filtered
/// mean NEES sits near 1.92 for these intervals and near 1.8 for intervals of 20–100 ms
/// (a bias growing with Δt, as the first-order form predicts), both inside this band's
/// half-width of about 0.55 at 200 runs.
#[test]
fn pendulum_ekf_and_smoother_are_consistent_on_an_irregular_clock() {
    let runs = 200;
    let mut rng = ChaCha8Rng::seed_from_u64(20261202);
    let mut t = vec![0.0_f64];
    while t.len() < ROWS {
        let last = t[t.len() - 1];
        let dt = if t.len() == ROWS / 2 {
            0.0
        } else {
            DT_LO + (DT_HI - DT_LO) * rand::RngExt::random::<f64>(&mut rng)
        };
        t.push(last + dt);
    }
    let (q, sigma) = (0.02, 0.02);
    let m0 = [0.8, 0.0];
    let p0: M2 = [[0.01, 0.0], [0.0, 0.04]];
    let d = DynDims::new(2, 1, 0).expect("dims");
    let n = 2;
    let mut filtered = vec![0.0; t.len()];
    let mut smoothed = vec![0.0; t.len()];
    for _ in 0..runs {
        // Truth: x0 from the prior, then Euler–Maruyama between the stamps.
        let (e0, e1): (f64, f64) = (
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
        );
        let mut x = [m0[0] + p0[0][0].sqrt() * e0, m0[1] + p0[1][1].sqrt() * e1];
        let mut truth = Vec::with_capacity(t.len());
        let mut z = Vec::with_capacity(t.len());
        for k in 0..t.len() {
            if k > 0 {
                let dt = t[k] - t[k - 1];
                let s = (dt / 5e-4).ceil() as usize;
                for _ in 0..s {
                    let h = dt / s as f64;
                    let xi: f64 = StandardNormal.sample(&mut rng);
                    let th = x[0] + h * x[1];
                    x[1] += h * (-G_L * x[0].sin() - DAMP * x[1]) + (q * h).sqrt() * xi;
                    x[0] = th;
                }
            }
            truth.push(x);
            let v: f64 = StandardNormal.sample(&mut rng);
            z.push(x[0] + sigma * v);
        }
        let model = TimeStamped::new(Pendulum { q, sigma }, d, &t)
            .and_then(|m| m.with_max_substep(0.01))
            .expect("model");
        let mut ekf =
            Ekf::new(d, AutoDiff::new(d, model), &m0, &p0, EkfUpdate::Extended).expect("ekf");
        let mut rts = NonlinearRts::new();
        for k in 0..t.len() {
            ekf.step(&[z[k]], None).expect("step");
            rts.record(&ekf).expect("record");
            let e = [truth[k][0] - ekf.state()[0], truth[k][1] - ekf.state()[1]];
            filtered[k] += nees(e, &col_major(ekf.covariance())) / runs as f64;
        }
        let s = rts.smooth().expect("smooth");
        for k in 0..t.len() {
            let e = [truth[k][0] - s.means[(0, k)], truth[k][1] - s.means[(1, k)]];
            smoothed[k] += nees(e, &col_major(s.covariances[k].as_ref())) / runs as f64;
        }
    }
    let dof = runs * n;
    let (lo, hi) = (
        chi2_quantile(0.00005, dof) / runs as f64,
        chi2_quantile(0.99995, dof) / runs as f64,
    );
    for k in 0..t.len() {
        assert!(
            (lo..=hi).contains(&filtered[k]),
            "row {k}: filtered NEES {} outside [{lo}, {hi}]",
            filtered[k]
        );
        assert!(
            (lo..=hi).contains(&smoothed[k]),
            "row {k}: smoothed NEES {} outside [{lo}, {hi}]",
            smoothed[k]
        );
    }
}

#[test]
fn bad_stamps_and_substeps_are_typed_errors() {
    let d = DynDims::new(1, 1, 0).expect("dims");
    let err = TimeStamped::new(Cubic, d, &[0.0, 0.1, f64::NAN, 0.3]).expect_err("refused");
    assert!(
        matches!(err, Error::TimeStamp { name: "t", index: 2, value, .. } if value.is_nan()),
        "{err}"
    );
    let err = TimeStamped::new(Cubic, d, &[0.0, 0.1, f64::INFINITY]).expect_err("refused");
    assert!(
        matches!(
            err,
            Error::TimeStamp {
                name: "t",
                index: 2,
                ..
            }
        ),
        "{err}"
    );
    let err = TimeStamped::new(Cubic, d, &[0.0, 0.1, 0.2, 0.15, 0.3]).expect_err("refused");
    assert!(
        matches!(err, Error::TimeStamp { name: "t", index: 3, value, .. } if (value - 0.15).abs() < 1e-15),
        "{err}"
    );
    assert!(err.to_string().contains("t[3]"), "{err}");
    let ok = TimeStamped::new(Cubic, d, &[0.0, 0.0, 0.5]).expect("equal stamps are one instant");
    assert!((ok.max_substep() - DEFAULT_MAX_SUBSTEP).abs() < 1e-18);
    for bad in [0.0, -0.01, f64::NAN, f64::INFINITY] {
        let err = ok.clone().with_max_substep(bad).expect_err("refused");
        assert!(
            matches!(
                err,
                Error::InvalidOption {
                    name: "max_substep",
                    ..
                }
            ),
            "{bad}: {err}"
        );
    }
    // A 10⁵ s gap at the default 0.01 would be 10⁷ sub-steps: refused, naming the option.
    let err = TimeStamped::new(Cubic, d, &[0.0, 1e5]).expect_err("refused");
    assert!(
        matches!(
            err,
            Error::InvalidOption {
                name: "max_substep",
                ..
            }
        ),
        "{err}"
    );

    let big = DynDims::new(33, 1, 0).expect("dims");
    let err = TimeStamped::new(Cubic, big, &[0.0]).expect_err("refused");
    assert!(
        matches!(
            err,
            Error::Dimension {
                name: "n",
                value: 33,
                ..
            }
        ),
        "{err}"
    );
}

/// ẋ = x², whose flow from x(t0) = 2 blows up half a time unit later.
#[derive(Clone, Debug)]
struct BlowUp;

impl ContinuousDynamics for BlowUp {
    fn a<T: Scalar>(&self, x: &[T], _u: Option<&[f64]>, _t: f64, out: &mut [T]) {
        out[0] = x[0] * x[0];
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0];
    }
    fn w(&self, _t: f64, out: &mut [f64]) {
        out[0] = 1e-4;
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out[0] = 1e-2;
    }
}

/// An interval past the blow-up makes the integrated state non-finite: the EKF's typed
/// error for a non-finite transition at that step (step 1), not a panic; the first step
/// (x: 1 → 2 over 0.5) is fine.
#[test]
fn an_interval_past_a_blow_up_is_the_filters_error_at_that_step() {
    let d = DynDims::new(1, 1, 0).expect("dims");
    let model = TimeStamped::new(BlowUp, d, &[0.0, 0.5, 3.0, 3.1]).expect("model");
    let mut ekf = Ekf::new(
        d,
        AutoDiff::new(d, model),
        &[1.0],
        &[[1e-4]],
        EkfUpdate::Extended,
    )
    .expect("ekf");
    ekf.step(&[f64::NAN], None).expect("step 0");
    assert!((ekf.predicted_state()[0] - 2.0).abs() < 1e-6);
    let err = ekf.step(&[2.0], None).expect_err("refused");
    assert_f_non_finite_at(&err, 1);
}

/// No heap allocation per step: the RK4 stages are stack arrays, and AD's workspaces and
/// the filter's are sized at construction (counted by the binary's allocator).
#[test]
fn steps_allocate_nothing() {
    let d = DynDims::new(2, 1, 0).expect("dims");
    let t: Vec<f64> = (0..20)
        .map(|k| 0.05 * k as f64 + 0.01 * (k % 3) as f64)
        .collect();
    let model = TimeStamped::new(
        Pendulum {
            q: 0.02,
            sigma: 0.02,
        },
        d,
        &t,
    )
    .expect("model");
    let p0 = [[0.01, 0.0], [0.0, 0.04]];
    let mut ekf = Ekf::new(
        d,
        AutoDiff::new(d, model),
        &[0.5, 0.0],
        &p0,
        EkfUpdate::Extended,
    )
    .expect("ekf");
    ekf.step(&[0.5], None).expect("first step");
    let before = allocations();
    for k in 1..t.len() {
        let z = if k % 4 == 0 { f64::NAN } else { 0.5 };
        assert!(ekf.step(&[z], None).is_ok());
    }
    assert_eq!(allocations() - before, 0);
}

/// `ẋ = cos(ω t) + u`: state-independent, so RK4 is Simpson's rule on each sub-step.
#[derive(Clone, Debug)]
struct Forced;

const OMEGA: f64 = 3.0;

impl ContinuousDynamics for Forced {
    fn a<T: Scalar>(&self, _x: &[T], u: Option<&[f64]>, t: f64, out: &mut [T]) {
        out[0] = T::from((OMEGA * t).cos() + u.map_or(0.0, |u| u[0]));
    }
    fn h<T: Scalar>(&self, x: &[T], _k: usize, out: &mut [T]) {
        out[0] = x[0];
    }
    fn w(&self, _t: f64, out: &mut [f64]) {
        out[0] = 1.0;
    }
    fn r(&self, _k: usize, out: &mut [f64]) {
        out[0] = 1.0;
    }
}

/// The drift sees the absolute time of each stage (the stamps start at t = 100) and the
/// input held over the interval: the map is `x + (sin ω t₁ − sin ω t₀)/ω + u Δt`. Simpson's
/// rule errs by at most `h⁴ Δt max|g⁗| / 2880` with `g⁗ = ω⁴ cos`, so the tolerance is
/// `ω⁴ h⁴ Δt / 2880` plus round-off of the absolute time (100 · 1e-16 · ω per stage, some
/// 1e-13 over the interval); an integrator that evaluated the drift at the interval's
/// offset from 0, or at the start time for every stage, errs by order one.
#[test]
fn drift_sees_absolute_time_and_the_held_input() {
    let t = [100.0, 100.3, 101.0];
    let d = DynDims::new(1, 1, 1).expect("dims");
    let hmax = 0.02;
    let m = TimeStamped::new(Forced, d, &t)
        .and_then(|m| m.with_max_substep(hmax))
        .expect("model");
    let u = 0.7;
    for k in 0..2 {
        let mut y = [0.0_f64];
        m.f(&[1.0], Some(&[u]), k, &mut y);
        let dt = t[k + 1] - t[k];
        let h = dt / m.substeps(k) as f64;
        let want = 1.0 + ((OMEGA * t[k + 1]).sin() - (OMEGA * t[k]).sin()) / OMEGA + u * dt;
        let tol = OMEGA.powi(4) * h.powi(4) * dt / 2880.0 + 1e-12;
        assert!(
            (y[0] - want).abs() <= tol,
            "k {k}: {} vs {want} (tol {tol:e})",
            y[0]
        );
        // Q_k = W Δt_k.
        let mut q = [0.0];
        m.q(k, &mut q);
        assert!((q[0] - dt).abs() <= 1e-15 * dt.max(1.0));
    }
}
