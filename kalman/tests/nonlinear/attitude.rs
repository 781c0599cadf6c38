//! Attitude on the unit-quaternion manifold: gyro-driven kinematics with a gyro bias,
//! corrected by two body-frame reference vectors (an accelerometer's vertical and a
//! magnetometer's field). The state is `(q, b)`, 7 stored and 6 tangent; the simulated
//! flights tumble through a pitch of 90° (where an Euler-angle chart is singular) and a
//! roll past ±180° (where it wraps).

use kalman::nonlinear::{
    CentralDiff, Ekf, EkfUpdate, FnModel, Manifold, NlDims, NonlinearModel, Part, Product,
    SigmaPoints, SqrtUkf, Ukf, quaternion,
};
use kalman::{Dims, DynDims, FixedDims};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Gyro sampling interval (s), samples per flight, vector measurements every `EVERY` steps.
pub const DT: f64 = 0.02;
pub const STEPS: usize = 400;
pub const EVERY: usize = 5;
/// Gyro white noise per sample and bias random-walk step (rad/s), reference-vector noise.
pub const SIGMA_G: f64 = 0.02;
pub const SIGMA_B: f64 = 1e-4;
pub const SIGMA_V: f64 = 0.02;
/// Prior standard deviations: attitude (rad) and bias (rad/s).
pub const P0_ATT: f64 = 0.1;
pub const P0_BIAS: f64 = 0.01;

/// The reference directions: the vertical and a magnetic field inclined 60° below the
/// horizon (reference frame).
const G_REF: [f64; 3] = [0.0, 0.0, 1.0];
const M_REF: [f64; 3] = [0.5, 0.0, 0.866_025_403_784_438_6];

pub fn space() -> Product {
    Product::new([Part::Quaternion, Part::Vector(3)])
}

fn diag(v: &[f64]) -> Vec<Vec<f64>> {
    (0..v.len())
        .map(|i| {
            (0..v.len())
                .map(|j| if i == j { v[i] } else { 0.0 })
                .collect()
        })
        .collect()
}

/// Q per step (tangent): attitude `σ_g² Δt²`, bias `σ_b²`; R: `σ_v²` on the six rows.
pub fn q() -> Vec<Vec<f64>> {
    let a = (SIGMA_G * DT).powi(2);
    let b = SIGMA_B * SIGMA_B;
    diag(&[a, a, a, b, b, b])
}

pub fn r() -> Vec<Vec<f64>> {
    diag(&[SIGMA_V * SIGMA_V; 6])
}

pub fn p0() -> Vec<Vec<f64>> {
    let (a, b) = (P0_ATT * P0_ATT, P0_BIAS * P0_BIAS);
    diag(&[a, a, a, b, b, b])
}

/// `q ← q ⊗ exp((ω_m − b) Δt)`, `b ← b`, with the gyro sample `ω_m` as the input.
pub fn kinematics(x: &[f64], u: Option<&[f64]>, _k: usize, out: &mut [f64]) {
    let w = u.unwrap_or(&[0.0; 3]);
    let rate = [(w[0] - x[4]) * DT, (w[1] - x[5]) * DT, (w[2] - x[6]) * DT];
    let q = quaternion::mul([x[0], x[1], x[2], x[3]], quaternion::exp(rate));
    out[..4].copy_from_slice(&q);
    out[4..].copy_from_slice(&x[4..]);
}

/// The two reference vectors seen in the body frame.
pub fn vectors(x: &[f64], _k: usize, out: &mut [f64]) {
    let q = [x[0], x[1], x[2], x[3]];
    out[..3].copy_from_slice(&quaternion::rotate_inverse(q, G_REF));
    out[3..].copy_from_slice(&quaternion::rotate_inverse(q, M_REF));
}

type Kin = fn(&[f64], Option<&[f64]>, usize, &mut [f64]);
type Obs = fn(&[f64], usize, &mut [f64]);

pub fn model<D: Dims>(d: D) -> FnModel<Kin, Obs, D> {
    FnModel::new(d, kinematics as Kin, vectors as Obs, &q(), &r())
        .expect("model")
        .with_manifold(space())
        .expect("tangent dimension 6")
}

/// The true body rates (rad/s) at time t: a pitch-up through 90° and on to 135°, a roll
/// through 180°, then a mixed tumble.
fn body_rate(t: f64) -> [f64; 3] {
    use core::f64::consts::PI;
    if t < 3.0 {
        [0.0, PI / 4.0, 0.0]
    } else if t < 5.5 {
        [1.6, 0.0, 0.2]
    } else {
        [0.3 * (2.0 * t).sin(), -0.4, 0.9]
    }
}

/// One simulated flight: the true states (stored), the gyro samples and the measurements
/// (NaN between the vector measurements), with the prior mean drawn from the prior about
/// the truth.
pub struct Flight {
    pub truth: Vec<[f64; 7]>,
    pub gyro: Vec<[f64; 3]>,
    pub z: Vec<[f64; 6]>,
    pub x0: [f64; 7],
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

pub fn flight(seed: u64) -> Flight {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let s = space();
    let mut x = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    for i in 4..7 {
        x[i] = P0_BIAS * normal(&mut rng);
    }
    // The prior mean is the truth moved by a draw from the prior: truth = x0 ⊞ δ.
    let delta: Vec<f64> = (0..6)
        .map(|i| [P0_ATT, P0_ATT, P0_ATT, P0_BIAS, P0_BIAS, P0_BIAS][i] * normal(&mut rng))
        .collect();
    let neg: Vec<f64> = delta.iter().map(|v| -v).collect();
    let mut x0 = [0.0; 7];
    s.boxplus(&x, &neg, &mut x0);
    // Re-centre so that truth = x0 ⊞ δ exactly (⊞ −δ then ⊞ δ is the identity only to
    // first order on the quaternion part).
    s.boxplus(&x0, &delta, &mut x);
    let (mut truth, mut gyro, mut z) = (vec![], vec![], vec![]);
    for k in 0..STEPS {
        let t = k as f64 * DT;
        truth.push(x);
        let q = [x[0], x[1], x[2], x[3]];
        let mut zk = [f64::NAN; 6];
        if k % EVERY == 0 {
            let g = quaternion::rotate_inverse(q, G_REF);
            let m = quaternion::rotate_inverse(q, M_REF);
            for i in 0..3 {
                zk[i] = g[i] + SIGMA_V * normal(&mut rng);
                zk[3 + i] = m[i] + SIGMA_V * normal(&mut rng);
            }
        }
        z.push(zk);
        let w = body_rate(t);
        let mut sample = [0.0; 3];
        for i in 0..3 {
            sample[i] = w[i] + x[4 + i] + SIGMA_G * normal(&mut rng);
        }
        gyro.push(sample);
        let qn = quaternion::normalise(quaternion::mul(
            q,
            quaternion::exp([w[0] * DT, w[1] * DT, w[2] * DT]),
        ));
        x[..4].copy_from_slice(&qn);
        for i in 4..7 {
            x[i] += SIGMA_B * normal(&mut rng);
        }
    }
    Flight { truth, gyro, z, x0 }
}

/// `eᵀ P⁻¹ e` by a Cholesky solve (P n×n column-major, SPD).
fn nees(p: &[f64], e: &[f64]) -> f64 {
    let n = e.len();
    let mut l = vec![0.0; n * n];
    for j in 0..n {
        let d = p[j + j * n] - (0..j).map(|k| l[j + k * n] * l[j + k * n]).sum::<f64>();
        l[j + j * n] = d.sqrt();
        for i in j + 1..n {
            let s = p[i + j * n] - (0..j).map(|k| l[i + k * n] * l[j + k * n]).sum::<f64>();
            l[i + j * n] = s / l[j + j * n];
        }
    }
    let mut y = e.to_vec();
    for i in 0..n {
        let s = y[i] - (0..i).map(|k| l[i + k * n] * y[k]).sum::<f64>();
        y[i] = s / l[i + i * n];
    }
    y.iter().map(|v| v * v).sum()
}

/// The filters run here, behind one interface: a step, the stored state and P.
pub trait Attitude {
    fn go(&mut self, z: &[f64], u: &[f64]);
    fn x(&self) -> Vec<f64>;
    fn p(&self) -> Vec<f64>;
}

macro_rules! attitude {
    ($t:ident, $bound:path) => {
        impl<D: NlDims, M: $bound> Attitude for $t<D, M> {
            fn go(&mut self, z: &[f64], u: &[f64]) {
                if let Err(e) = self.step(z, Some(u)) {
                    panic!("{e}");
                }
            }
            fn x(&self) -> Vec<f64> {
                self.state().to_vec()
            }
            fn p(&self) -> Vec<f64> {
                let c = self.covariance();
                (0..36).map(|i| c[(i % 6, i / 6)]).collect()
            }
        }
    };
}
attitude!(Ukf, NonlinearModel);
attitude!(SqrtUkf, NonlinearModel);
attitude!(Ekf, kalman::nonlinear::Jacobians);

/// Runs `filter` over `f`, checking |q| = 1 to 1e-12 after every step, and returns the
/// NEES of every step.
fn run(filter: &mut dyn Attitude, f: &Flight) -> Vec<f64> {
    let s = space();
    let mut out = Vec::with_capacity(STEPS);
    let mut e = [0.0; 6];
    for k in 0..STEPS {
        filter.go(&f.z[k], &f.gyro[k]);
        let x = filter.x();
        let norm = x[..4].iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((norm - 1.0).abs() < 1e-12, "step {k}: |q| = {norm}");
        s.boxminus(&f.truth[k], &x, &mut e);
        out.push(nees(&filter.p(), &e));
    }
    out
}

type Build = fn(&Flight) -> Box<dyn Attitude>;

fn ukf(f: &Flight) -> Box<dyn Attitude> {
    let d = FixedDims::<6, 6, 3, 7>::new();
    let points = SigmaPoints::merwe(0.5, 2.0, 0.0);
    Box::new(Ukf::new(d, model(d), &f.x0, &p0(), points).expect("ukf"))
}

fn ekf(f: &Flight) -> Box<dyn Attitude> {
    let d = DynDims::new(6, 6, 3)
        .and_then(|d| d.with_stored(7))
        .expect("dims");
    let m = CentralDiff::new(d, model(d));
    Box::new(Ekf::new(d, m, &f.x0, &p0(), EkfUpdate::Extended).expect("ekf"))
}

/// The simulated flights really pass through the attitudes where Euler angles fail: a
/// pitch within 0.1° of 90° and a roll that wraps past ±180°.
#[test]
fn the_flights_pass_through_gimbal_lock_and_the_roll_wrap() {
    let f = flight(1);
    let euler = |q: &[f64]| {
        let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
        let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
        let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
        (pitch, roll)
    };
    let near_lock = f
        .truth
        .iter()
        .map(|x| (euler(x).0.to_degrees() - 90.0).abs())
        .fold(f64::INFINITY, f64::min);
    assert!(near_lock < 0.1, "closest pitch to 90°: {near_lock}° away");
    let wraps = f
        .truth
        .windows(2)
        .filter(|w| (euler(&w[1]).1 - euler(&w[0]).1).abs() > core::f64::consts::PI)
        .count();
    assert!(wraps >= 1, "the roll never wraps");
}

/// Consistency over 100 flights: at each step the mean NEES over the runs, times the
/// number of runs, is χ² with 6·runs degrees of freedom if the filter's covariance is its
/// error's; the two-sided 95 % band for the mean holds at (nominally) 95 % of the steps.
/// Neighbouring steps' errors are correlated, so the fraction seen scatters about 95 % by
/// more than a binomial count of independent steps would: 85 % is required (three
/// binomial standard deviations below 95 % for the ~20 independent stretches a flight of
/// 400 steps with vector fixes every 5 holds), with the grand mean inside the band.
#[test]
fn the_manifold_filters_are_consistent_through_gimbal_lock() {
    let runs = 100;
    let dof = 6 * runs;
    let lo = kalman::chi2_quantile(0.025, dof) / runs as f64;
    let hi = kalman::chi2_quantile(0.975, dof) / runs as f64;
    let flights: Vec<Flight> = (0..runs as u64).map(|s| flight(100 + s)).collect();
    for (name, build) in [("UKF", ukf as Build), ("EKF", ekf as Build)] {
        let mut mean = vec![0.0; STEPS];
        for f in &flights {
            let mut filter = build(f);
            for (m, e) in mean.iter_mut().zip(run(filter.as_mut(), f)) {
                *m += e / runs as f64;
            }
        }
        let inside = mean.iter().filter(|m| (lo..=hi).contains(*m)).count();
        let grand = mean.iter().sum::<f64>() / STEPS as f64;
        let frac = inside as f64 / STEPS as f64;
        assert!(
            frac >= 0.85 && (lo..=hi).contains(&grand),
            "{name}: {inside}/{STEPS} steps in [{lo:.3}, {hi:.3}], grand mean {grand:.3}"
        );
    }
}

/// Where both work, the square-root UKF on the manifold agrees with the plain one to
/// round-off (the same points, means and deviations; only the covariance's arithmetic
/// differs), and the fixed and dynamic paths agree bit for bit.
#[test]
fn square_root_and_storage_paths_agree_on_the_manifold() {
    let f = flight(7);
    let points = SigmaPoints::merwe(0.5, 2.0, 0.0);
    let fixed = FixedDims::<6, 6, 3, 7>::new();
    let dynamic = DynDims::new(6, 6, 3)
        .and_then(|d| d.with_stored(7))
        .expect("dims");
    let mut a = Ukf::new(fixed, model(fixed), &f.x0, &p0(), points).expect("ukf");
    let mut b = SqrtUkf::new(fixed, model(fixed), &f.x0, &p0(), points).expect("sqrt");
    let mut c = Ukf::new(dynamic, model(dynamic), &f.x0, &p0(), points).expect("dyn");
    let mut worst: f64 = 0.0;
    for k in 0..STEPS {
        a.go(&f.z[k], &f.gyro[k]);
        b.go(&f.z[k], &f.gyro[k]);
        c.go(&f.z[k], &f.gyro[k]);
        assert_eq!(a.x(), c.x(), "step {k}: fixed and dynamic paths");
        assert_eq!(a.p(), c.p(), "step {k}: fixed and dynamic paths");
        for (u, v) in a.x().iter().zip(b.x()) {
            worst = worst.max((u - v).abs());
        }
    }
    // A few hundred steps of O(10 ε)-relative differences between two factorisations of
    // one covariance, fed back through the gain: 1e-10 is far above that and far below
    // the 1e-3 rad errors the filter makes.
    assert!(worst < 1e-10, "square-root vs plain UKF: {worst:e}");
}

/// A dims/manifold mismatch, an unnormalisable x0 and a model without a manifold on
/// manifold dims are typed errors at construction.
#[test]
fn manifold_mismatches_are_typed_errors() {
    let f = flight(3);
    let points = SigmaPoints::Cubature;
    let d7 = DynDims::new(6, 6, 3)
        .and_then(|d| d.with_stored(7))
        .expect("dims");
    let d8 = DynDims::new(6, 6, 3)
        .and_then(|d| d.with_stored(8))
        .expect("dims");
    let e = Ukf::new(d8, model(d8), &[0.0; 8], &p0(), points).expect_err("stored 8 ≠ 7");
    assert!(
        matches!(e, kalman::Error::Dimension { name: "stored", .. }),
        "{e}"
    );
    let zero = [0.0; 7];
    let e = Ukf::new(d7, model(d7), &zero, &p0(), points).expect_err("q = 0");
    assert!(matches!(e, kalman::Error::ModelNonFinite { .. }), "{e}");
    let plain = FnModel::new(d7, kinematics as Kin, vectors as Obs, &q(), &r()).expect("model");
    let e = Ukf::new(d7, plain, &f.x0, &p0(), points).expect_err("no manifold");
    assert!(
        matches!(e, kalman::Error::Dimension { name: "stored", .. }),
        "{e}"
    );
    let e = FnModel::new(d7, kinematics as Kin, vectors as Obs, &q(), &r())
        .expect("model")
        .with_manifold(Product::new([Part::Quaternion]))
        .expect_err("tangent 3 ≠ 6");
    assert!(
        matches!(
            e,
            kalman::Error::Dimension {
                name: "manifold",
                ..
            }
        ),
        "{e}"
    );
    let lin = kalman::Model::new(d7, &q(), &diag(&[1.0; 6]), &q(), &r()).expect_err("linear");
    assert!(
        matches!(lin, kalman::Error::Dimension { name: "stored", .. }),
        "{lin}"
    );
}

/// The extended and the unscented RTS smoothers on the manifold over 100 flights: the
/// smoothed states are consistent (per-step mean NEES in the χ² band as for the filters),
/// every smoothed quaternion has unit norm, and the smoothed attitude error is smaller
/// than the filtered one on average (the smoother sees the fixes after each step too).
#[test]
fn the_manifold_smoothers_are_consistent_and_beat_the_filters() {
    let runs = 100;
    let dof = 6 * runs;
    let lo = kalman::chi2_quantile(0.025, dof) / runs as f64;
    let hi = kalman::chi2_quantile(0.975, dof) / runs as f64;
    let s = space();
    let d = FixedDims::<6, 6, 3, 7>::new();
    let points = SigmaPoints::merwe(0.5, 2.0, 0.0);
    for name in ["UKF", "EKF"] {
        let mut mean = vec![0.0; STEPS];
        let (mut filtered_err, mut smoothed_err) = (0.0, 0.0);
        let mut e = [0.0; 6];
        for seed in 0..runs as u64 {
            let f = flight(500 + seed);
            let mut rts = kalman::nonlinear::NonlinearRts::new();
            let mut filtered = Vec::with_capacity(STEPS);
            if name == "UKF" {
                let mut ukf = Ukf::new(d, model(d), &f.x0, &p0(), points).expect("ukf");
                for k in 0..STEPS {
                    ukf.go(&f.z[k], &f.gyro[k]);
                    rts.record(&ukf).expect("record");
                    filtered.push(ukf.x());
                }
            } else {
                let cd = CentralDiff::new(d, model(d));
                let mut ekf = Ekf::new(d, cd, &f.x0, &p0(), EkfUpdate::Extended).expect("ekf");
                for k in 0..STEPS {
                    ekf.go(&f.z[k], &f.gyro[k]);
                    rts.record(&ekf).expect("record");
                    filtered.push(ekf.x());
                }
            }
            let out = rts.smooth_on(&s).expect("smooth");
            for k in 0..STEPS {
                s.boxminus(&f.truth[k], &filtered[k], &mut e);
                filtered_err += e[..3].iter().map(|v| v * v).sum::<f64>();
                let x: Vec<f64> = (0..7).map(|i| out.means[(i, k)]).collect();
                let norm = x[..4].iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!((norm - 1.0).abs() < 1e-12, "{name} step {k}: |q| = {norm}");
                s.boxminus(&f.truth[k], &x, &mut e);
                smoothed_err += e[..3].iter().map(|v| v * v).sum::<f64>();
                let p: Vec<f64> = (0..36)
                    .map(|i| out.covariances[k][(i % 6, i / 6)])
                    .collect();
                mean[k] += nees(&p, &e) / runs as f64;
            }
        }
        let inside = mean.iter().filter(|m| (lo..=hi).contains(*m)).count();
        let grand = mean.iter().sum::<f64>() / STEPS as f64;
        assert!(
            inside as f64 >= 0.85 * STEPS as f64 && (lo..=hi).contains(&grand),
            "{name}: {inside}/{STEPS} steps in [{lo:.3}, {hi:.3}], grand mean {grand:.3}"
        );
        // Between fixes (every 5 steps) the smoother interpolates with the data on both
        // sides: its mean-square attitude error is well below the filter's.
        assert!(
            smoothed_err < 0.7 * filtered_err,
            "{name}: smoothed {smoothed_err:e} vs filtered {filtered_err:e}"
        );
    }
}

/// On a vector "manifold" (a product of one vector part) the manifold pass is the vector
/// pass: the same means and covariances to round-off; and the vector pass refuses stored
/// points it would add as vectors.
#[test]
fn the_manifold_pass_reduces_to_the_vector_pass() {
    let f = flight(9);
    let d = FixedDims::<6, 6, 3, 7>::new();
    let points = SigmaPoints::merwe(0.5, 2.0, 0.0);
    let mut ukf = Ukf::new(d, model(d), &f.x0, &p0(), points).expect("ukf");
    let mut rts = kalman::nonlinear::NonlinearRts::new();
    for k in 0..50 {
        ukf.go(&f.z[k], &f.gyro[k]);
        rts.record(&ukf).expect("record");
    }
    let e = rts.smooth().expect_err("stored points");
    assert!(
        matches!(e, kalman::Error::Dimension { name: "stored", .. }),
        "{e}"
    );
    let e = rts
        .smooth_on(&Product::new([Part::Quaternion]))
        .expect_err("wrong manifold");
    assert!(
        matches!(
            e,
            kalman::Error::Dimension {
                name: "manifold",
                ..
            }
        ),
        "{e}"
    );

    // A vector state: the range–bearing-free random walk of the pendulum tests.
    let dv = DynDims::new(2, 1, 0).expect("dims");
    let walk = FnModel::new(
        dv,
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
            out[0] = x[0] + 0.1 * x[1];
            out[1] = x[1] - 0.1 * x[0].sin();
        },
        |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0].sin(),
        &[[1e-4, 0.0], [0.0, 1e-3]],
        &[[1e-2]],
    )
    .expect("model");
    let mut plain =
        Ukf::new(dv, walk, &[0.3, 0.0], &[[0.1, 0.0], [0.0, 0.1]], points).expect("ukf");
    let mut rts = kalman::nonlinear::NonlinearRts::new();
    for k in 0..60 {
        let z = (0.3 * (0.2 * k as f64).cos()).sin();
        plain.step(&[z], None).expect("step");
        rts.record(&plain).expect("record");
    }
    let a = rts.smooth().expect("vector pass");
    let b = rts
        .smooth_on(&Product::new([Part::Vector(2)]))
        .expect("manifold pass");
    for k in 0..60 {
        for i in 0..2 {
            // x + J d against x ⊞ (J d): one rounding of the product apart.
            assert!(
                (a.means[(i, k)] - b.means[(i, k)]).abs() < 1e-15,
                "mean {k}"
            );
            for j in 0..2 {
                let (p, q) = (a.covariances[k][(i, j)], b.covariances[k][(i, j)]);
                assert_eq!(p.to_bits(), q.to_bits(), "P {k}");
            }
        }
    }
}

/// The fixed-lag smoother on the manifold: at a lag covering the record its window after
/// the last step is the manifold RTS smoother's output (the same backward recursion over
/// the same records), and its state survives a save and restore.
#[test]
fn the_manifold_fixed_lag_smoother_equals_rts_at_full_lag() {
    let f = flight(11);
    let steps = 40;
    let d = FixedDims::<6, 6, 3, 7>::new();
    let points = SigmaPoints::merwe(0.5, 2.0, 0.0);
    let mut ukf = Ukf::new(d, model(d), &f.x0, &p0(), points).expect("ukf");
    let mut rts = kalman::nonlinear::NonlinearRts::new();
    let mut lag = kalman::nonlinear::FixedLag::new(6, steps)
        .and_then(|l| l.with_manifold(space()))
        .expect("lag");
    let mut plain = kalman::nonlinear::FixedLag::new(6, 3).expect("lag");
    for k in 0..steps {
        ukf.go(&f.z[k], &f.gyro[k]);
        rts.record(&ukf).expect("record");
        lag.record(&ukf).expect("record");
        let e = plain
            .record(&ukf)
            .expect_err("a vector smoother refuses stored points");
        assert!(
            matches!(e, kalman::Error::Dimension { name: "stored", .. }),
            "{e}"
        );
    }
    let all = rts.smooth_on(&space()).expect("smooth");
    // Both solve for J by a Cholesky factorisation of P_{j+1|j}, in two implementations
    // (the window's own kernels, faer in the RTS pass), so they agree to round-off: sums
    // of a few dozen products of O(1) numbers over 40 steps, 1e-12 absolute (as the
    // vector fixed-lag tests).
    for back in 0..steps {
        let (j, x, p) = lag.smoothed(back).expect("in window");
        for i in 0..7 {
            assert!(
                (x[i] - all.means[(i, j)]).abs() <= 1e-12,
                "mean of step {j}"
            );
        }
        for c in 0..6 {
            for r in 0..6 {
                assert!(
                    (p[(r, c)] - all.covariances[j][(r, c)]).abs() <= 1e-12,
                    "P {j}"
                );
            }
        }
    }
    let restored = kalman::nonlinear::FixedLag::from_state(lag.state())
        .and_then(|l| l.with_manifold(space()))
        .expect("restore");
    assert_eq!(restored.state(), lag.state());
}
