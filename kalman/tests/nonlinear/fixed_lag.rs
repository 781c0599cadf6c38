//! The fixed-lag smoother: x_{k−L|k} against the augmented-state fixed-lag smoother on a
//! linear model (golden from `tests/golden/make_sigma_fixed_lag.py`, FilterPy 1.4.5's
//! algorithm with its cross-covariances carried across steps; FilterPy's own numbers differ
//! from the RTS smoother's and are kept in the file for the record), and equal to the RTS
//! smoothers at a lag covering the record (linear filter and UKF).

use kalman::nonlinear::{FixedLag, FnModel, NonlinearRts, SigmaPoints, Ukf};
use kalman::{CovarianceForm, DynDims, Filter, FixedDims, Model};

/// Sums of a few dozen products of O(1–10) numbers on both sides: 1e-10 absolute.
const TOL: f64 = 1e-10;

#[test]
fn fixed_lag_equals_the_augmented_state_smoother_and_rts() {
    let text = include_str!("../golden/fixed_lag.csv");
    let (dt, q, r, lag) = (0.5, 0.2, 0.3, 5);
    let (mut x0, mut p0, mut z) = (vec![0.0; 2], vec![0.0; 4], Vec::new());
    let (mut want_lag, mut want_rts) = (Vec::new(), Vec::new());
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (k, i): (i64, usize) = (f[0].parse().expect("k"), f[3].parse().expect("i"));
        let v: f64 = f[4].parse().expect("value");
        match f[2] {
            "x0" => x0[i] = v,
            "P0" => p0[i] = v,
            "xf" if i == 0 => z.push(f[1].parse::<f64>().expect("z")),
            "lag" => want_lag.push((k as usize, i, v)),
            "rts" => want_rts.push((k as usize, i, v)),
            _ => {}
        }
    }
    assert_eq!(z.len(), 40);
    let qm = [
        [q * dt * dt * dt / 3.0, q * dt * dt / 2.0],
        [q * dt * dt / 2.0, q * dt],
    ];
    let p0m = [[p0[0], p0[2]], [p0[1], p0[3]]];
    let model = Model::new(
        FixedDims::<2, 1>::new(),
        &[[1.0, dt], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &qm,
        &[[r]],
    )
    .expect("model");
    let mut filter = Filter::new(model, &x0, &p0m, CovarianceForm::Joseph).expect("filter");
    let mut fl = FixedLag::new(2, lag).expect("smoother");
    let mut full = FixedLag::new(2, 100).expect("smoother");
    let mut got = vec![[0.0; 2]; z.len()];
    for (k, zk) in z.iter().enumerate() {
        filter.step(&[*zk], None).expect("step");
        fl.record_linear(&filter).expect("record");
        full.record_linear(&filter).expect("record");
        match fl.lagged() {
            Some((j, x, _)) => {
                assert_eq!(j, k - lag);
                got[k] = [x[0], x[1]];
            }
            None => assert!(k < lag),
        }
    }
    assert_eq!(want_lag.len(), 2 * (40 - lag));
    for (k, i, v) in want_lag {
        assert!((got[k][i] - v).abs() <= TOL, "x_{{{k}-L|{k}}}[{i}]");
    }
    assert_eq!(full.window(), 40);
    for (k, i, v) in want_rts {
        let (j, x, _) = full.smoothed(39 - k).expect("in the window");
        assert_eq!(j, k);
        assert!((x[i] - v).abs() <= TOL, "x_{{{k}|39}}[{i}]");
    }
}

/// A UKF on a nonlinear model: at lag ≥ N − 1 the window after the last step is the
/// unscented RTS smoother's output (means and covariances), at every step the lag-0
/// estimate is the filter's, and the lagged estimate equals the RTS smoother run over the
/// data to that step.
#[test]
fn fixed_lag_of_a_ukf_equals_the_unscented_rts_smoother() {
    let d = DynDims::new(2, 1, 0).expect("dims");
    let model = FnModel::new(
        d,
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
            out[0] = x[0] + 0.1 * x[1];
            out[1] = x[1] - 0.1 * x[0].sin();
        },
        |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0].sin(),
        &[[1e-4, 0.0], [0.0, 1e-3]],
        &[[1e-2]],
    )
    .expect("model");
    let set = SigmaPoints::merwe(0.5, 2.0, 1.0);
    let p0 = [[0.1, 0.0], [0.0, 0.1]];
    let zs: Vec<f64> = (0..25)
        .map(|k| (0.8 * (0.2 * k as f64).cos()).sin())
        .collect();
    let mut ukf = Ukf::new(d, model.clone(), &[0.7, 0.0], &p0, set).expect("ukf");
    let (mut fl, mut full, mut rts) = (
        FixedLag::new(2, 3).expect("lag"),
        FixedLag::new(2, 30).expect("lag"),
        NonlinearRts::new(),
    );
    let mut prefix: Vec<(Vec<f64>, f64)> = Vec::new();
    for (k, z) in zs.iter().enumerate() {
        ukf.step(&[*z], None).expect("step");
        fl.record(&ukf).expect("record");
        full.record(&ukf).expect("record");
        rts.record(&ukf).expect("record");
        let (_, x0, _) = fl.smoothed(0).expect("lag 0");
        assert!((x0[0] - ukf.state()[0]).abs() <= 0.0);
        if let Some((j, x, _)) = fl.lagged() {
            let s = rts.smooth().expect("smooth");
            assert!((x[0] - s.means[(0, j)]).abs() <= 1e-12, "step {k}");
            assert!((x[1] - s.means[(1, j)]).abs() <= 1e-12, "step {k}");
            prefix.push((x.to_vec(), s.means[(0, j)]));
        }
    }
    assert_eq!(prefix.len(), 25 - 3);
    let s = rts.smooth().expect("smooth");
    for j in 0..25 {
        let (step, x, P) = full.smoothed(24 - j).expect("window");
        assert_eq!(step, j);
        for i in 0..2 {
            assert!((x[i] - s.means[(i, j)]).abs() <= 1e-12);
            for c in 0..2 {
                assert!((P[(i, c)] - s.covariances[j][(i, c)]).abs() <= 1e-12);
            }
        }
    }
    // The smoother's n must be the filter's.
    let mut wrong = FixedLag::new(3, 2).expect("lag");
    assert!(matches!(
        wrong.record(&ukf),
        Err(kalman::Error::Dimension { name: "n", .. })
    ));
    assert!(FixedLag::new(0, 2).is_err());
}
