//! Against FilterPy (golden CSVs from `tests/golden/make_nonlinear.py`): Merwe's sigma
//! points and weights for several (n, α, β, κ), and EKF and UKF runs on a range–bearing
//! tracker and a pendulum (the plain and the square-root UKF), posterior means, covariances
//! and NIS to 1e-9.

use std::collections::BTreeMap;

use kalman::nonlinear::{AutoDiff, Ekf, EkfUpdate, ForwardPass, NlDims, SigmaPoints, SqrtUkf, Ukf};
use kalman::nonlinear::{Jacobians, NonlinearModel};
use kalman::{FixedDims, MatrixInput};

use super::models::{Pendulum, PendulumHand, RangeBearing, RangeBearingHand};

/// FilterPy and this crate do the same arithmetic in different orders (and FilterPy forms
/// Σ⁻¹ explicitly): agreement to 1e-9 relative leaves room for their round-off over 60–100
/// steps while catching any difference of formula.
const TOL: f64 = 1e-9;

fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= TOL * b.abs().max(1.0),
        "{what}: {a} vs FilterPy {b}"
    );
}

#[test]
fn merwe_sigma_points_and_weights_equal_filterpy() {
    let text = include_str!("../golden/merwe_sigma.csv");
    // case → (n, α, β, κ, what → (i, j) → value)
    type Entries = BTreeMap<(String, usize, usize), f64>;
    type Case = ((usize, f64, f64, f64), Entries);
    let mut cases: BTreeMap<usize, Case> = BTreeMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let num = |i: usize| f[i].parse::<f64>().expect("number");
        let case: usize = f[0].parse().expect("case");
        let e = cases.entry(case).or_insert((
            (f[1].parse().expect("n"), num(2), num(3), num(4)),
            Entries::new(),
        ));
        e.1.insert(
            (
                f[5].to_string(),
                f[6].parse().expect("i"),
                f[7].parse().expect("j"),
            ),
            num(8),
        );
    }
    assert_eq!(cases.len(), 6);
    for ((n, alpha, beta, kappa), e) in cases.values() {
        let n = *n;
        let get = |w: &str, i: usize, j: usize| e[&(w.to_string(), i, j)];
        let x: Vec<f64> = (0..n).map(|i| get("x", i, 0)).collect();
        let P = faer::Mat::from_fn(n, n, |i, j| get("P", i, j));
        let set = SigmaPoints::merwe(*alpha, *beta, *kappa);
        let pts = set.points(&x, &P).expect("points");
        for i in 0..n {
            for j in 0..2 * n + 1 {
                close(
                    pts[(i, j)],
                    get("sigma", i, j),
                    &format!("n={n} sigma({i},{j})"),
                );
            }
        }
        let (mut wm, mut wc) = (vec![0.0; 2 * n + 1], vec![0.0; 2 * n + 1]);
        set.weights(n, &mut wm, &mut wc).expect("weights");
        for j in 0..2 * n + 1 {
            close(wm[j], get("Wm", j, 0), &format!("n={n} Wm[{j}]"));
            close(wc[j], get("Wc", j, 0), &format!("n={n} Wc[{j}]"));
        }
    }
}

/// One row of a golden run: (z, x, P column-major, nis).
type Row = (Vec<f64>, Vec<f64>, Vec<f64>, f64);

fn read_run(text: &str, n: usize, m: usize) -> Vec<Row> {
    text.lines()
        .skip(1)
        .map(|line| {
            let v: Vec<f64> = line
                .split(',')
                .map(|s| s.parse::<f64>().expect("number"))
                .collect();
            assert_eq!(v.len(), 1 + m + n + n * n + 1);
            (
                v[1..1 + m].to_vec(),
                v[1 + m..1 + m + n].to_vec(),
                v[1 + m + n..1 + m + n + n * n].to_vec(),
                v[1 + m + n + n * n],
            )
        })
        .collect()
}

trait Run {
    fn run(&mut self, z: &[f64]) -> Option<f64>;
    fn posterior(&self) -> (&[f64], &[f64]);
}

impl<D: NlDims, M: Jacobians> Run for Ekf<D, M> {
    fn run(&mut self, z: &[f64]) -> Option<f64> {
        self.step(z, None).expect("ekf step").nis
    }
    fn posterior(&self) -> (&[f64], &[f64]) {
        self.filtered()
    }
}

impl<D: NlDims, M: NonlinearModel> Run for Ukf<D, M> {
    fn run(&mut self, z: &[f64]) -> Option<f64> {
        self.step(z, None).expect("ukf step").nis
    }
    fn posterior(&self) -> (&[f64], &[f64]) {
        self.filtered()
    }
}

impl<D: NlDims, M: NonlinearModel> Run for SqrtUkf<D, M> {
    fn run(&mut self, z: &[f64]) -> Option<f64> {
        self.step(z, None).expect("square-root ukf step").nis
    }
    fn posterior(&self) -> (&[f64], &[f64]) {
        self.filtered()
    }
}

fn compare(f: &mut dyn Run, text: &str, n: usize, m: usize, what: &str) {
    let rows = read_run(text, n, m);
    assert!(rows.len() >= 60);
    for (k, (z, x, P, nis)) in rows.iter().enumerate() {
        let got = f.run(z);
        let (gx, gp) = f.posterior();
        for i in 0..n {
            close(gx[i], x[i], &format!("{what} step {k} x[{i}]"));
        }
        for i in 0..n * n {
            close(gp[i], P[i], &format!("{what} step {k} P[{i}]"));
        }
        match got {
            Some(v) => close(v, *nis, &format!("{what} step {k} nis")),
            None => assert!(
                nis.is_nan(),
                "{what} step {k}: missing z but FilterPy has a NIS"
            ),
        }
    }
}

fn prior<const N: usize>(x: [f64; N], P: &impl MatrixInput) -> ([f64; N], faer::Mat<f64>) {
    (x, faer::Mat::from_fn(N, N, |i, j| P.at(i, j)))
}

#[test]
fn range_bearing_runs_equal_filterpy() {
    let d = FixedDims::<4, 2>::new();
    let (x0, P0) = prior(RangeBearing::x0(), &RangeBearing::p0());
    let ekf_csv = include_str!("../golden/nl_rangebearing_ekf.csv");
    let mut hand = Ekf::new(
        d,
        RangeBearingHand::default(),
        &x0,
        &P0,
        EkfUpdate::Extended,
    )
    .expect("ekf");
    compare(
        &mut hand,
        ekf_csv,
        4,
        2,
        "range-bearing EKF (hand Jacobians)",
    );
    let ad = AutoDiff::new(d, RangeBearing::default());
    let mut ad = Ekf::new(d, ad, &x0, &P0, EkfUpdate::Extended).expect("ekf");
    compare(&mut ad, ekf_csv, 4, 2, "range-bearing EKF (AD Jacobians)");
    for (set, file) in [
        (
            SigmaPoints::merwe(0.5, 2.0, -1.0),
            include_str!("../golden/nl_rangebearing_ukf_merwe.csv"),
        ),
        (
            SigmaPoints::Cubature,
            include_str!("../golden/nl_rangebearing_ukf_cubature.csv"),
        ),
    ] {
        let mut ukf = Ukf::new(d, RangeBearingHand::default(), &x0, &P0, set).expect("ukf");
        compare(&mut ukf, file, 4, 2, &format!("range-bearing UKF {set:?}"));
        let mut sq = SqrtUkf::new(d, RangeBearingHand::default(), &x0, &P0, set).expect("sqrt");
        compare(
            &mut sq,
            file,
            4,
            2,
            &format!("range-bearing square-root UKF {set:?}"),
        );
    }
}

#[test]
fn pendulum_runs_equal_filterpy() {
    let d = FixedDims::<2, 1>::new();
    let (x0, P0) = prior([1.2, 0.0], &[[0.05, 0.0], [0.0, 0.1]]);
    let mut ekf = Ekf::new(d, PendulumHand::default(), &x0, &P0, EkfUpdate::Extended).expect("ekf");
    compare(
        &mut ekf,
        include_str!("../golden/nl_pendulum_ekf.csv"),
        2,
        1,
        "pendulum EKF",
    );
    for (set, file) in [
        (
            SigmaPoints::merwe(0.5, 2.0, 1.0),
            include_str!("../golden/nl_pendulum_ukf_merwe.csv"),
        ),
        (
            SigmaPoints::Cubature,
            include_str!("../golden/nl_pendulum_ukf_cubature.csv"),
        ),
    ] {
        let ad = AutoDiff::new(d, Pendulum::default());
        let mut ukf = Ukf::new(d, ad, &x0, &P0, set).expect("ukf");
        compare(&mut ukf, file, 2, 1, &format!("pendulum UKF {set:?}"));
        let ad = AutoDiff::new(d, Pendulum::default());
        let mut sq = SqrtUkf::new(d, ad, &x0, &P0, set).expect("sqrt");
        compare(
            &mut sq,
            file,
            2,
            1,
            &format!("pendulum square-root UKF {set:?}"),
        );
    }
}

#[test]
fn bearing_wrap_is_filterpy_formula_bit_for_bit() {
    use std::f64::consts::{PI, TAU};
    // The test models' `wrap` skips `fmod` when a + π is already in [0, 2π); it must return
    // exactly what FilterPy's `(a + π) % 2π − π` gives (as `rem_euclid`), at the edges of
    // that range, outside it and for signed zeros and non-finite input.
    let formula = |a: f64| (a + PI).rem_euclid(TAU) - PI;
    let mut inputs = vec![
        0.0,
        -0.0,
        PI,
        -PI,
        PI - 1e-16,
        -PI + 1e-16,
        f64::from_bits(PI.to_bits() - 1),
        f64::from_bits(PI.to_bits() + 1),
        TAU,
        -TAU,
        3.0 * PI,
        -7.5,
        1e6,
        -1e-300,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
    ];
    inputs.extend((0..2000).map(|i| -10.0 + 0.01 * i as f64 + 1e-7 * (i % 7) as f64));
    for a in inputs {
        let (got, want) = (super::models::wrap(a), formula(a));
        assert!(
            got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
            "wrap({a:e}) = {got:e}, formula {want:e}"
        );
    }
}
