//! The IMM against FilterPy 1.4.5's `IMMEstimator` on a linear two-mode case (golden JSON
//! from `tests/golden/make_imm.py`): the combined x, P and the mode probabilities after
//! every update, and the one-mode IMM against the plain filter.

use kalman::imm::{Embedding, Imm, Mode};
use kalman::{CovarianceForm, DynDims, Filter, FixedDims, Model};
use serde_json::Value;

fn mat(v: &Value) -> Vec<Vec<f64>> {
    v.as_array()
        .expect("rows")
        .iter()
        .map(|r| {
            r.as_array()
                .expect("row")
                .iter()
                .map(|x| x.as_f64().expect("f64"))
                .collect()
        })
        .collect()
}

fn vec1(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("vector")
        .iter()
        .map(|x| x.as_f64().expect("f64"))
        .collect()
}

fn to2(m: &[Vec<f64>]) -> [[f64; 2]; 2] {
    [[m[0][0], m[0][1]], [m[1][0], m[1][1]]]
}

/// The IMM of the golden case, on the storage path `fixed` chooses, in `form`.
fn golden_imm(g: &Value, fixed: bool, form: CovarianceForm) -> Imm {
    let (x0, P0) = (vec1(&g["x0"]), to2(&mat(&g["P0"])));
    let modes: Vec<(Box<dyn Mode>, Embedding)> = g["modes"]
        .as_array()
        .expect("modes")
        .iter()
        .map(|m| {
            let (F, Q) = (to2(&mat(&m["F"])), to2(&mat(&m["Q"])));
            let f: Box<dyn Mode> = if fixed {
                let model = Model::new(FixedDims::<2, 1>::new(), &F, &[[1.0, 0.0]], &Q, &[[0.25]])
                    .expect("model");
                Box::new(Filter::new(model, &x0, &P0, form).expect("filter"))
            } else {
                let model = Model::new(
                    DynDims::new(2, 1, 0).expect("dims"),
                    &F,
                    &[[1.0, 0.0]],
                    &Q,
                    &[[0.25]],
                )
                .expect("model");
                Box::new(Filter::new(model, &x0, &P0, form).expect("filter"))
            };
            (f, Embedding::identity(2))
        })
        .collect();
    let t = mat(&g["transition"]);
    Imm::new(
        modes,
        &[[t[0][0], t[0][1]], [t[1][0], t[1][1]]],
        &vec1(&g["mu0"]),
    )
    .expect("imm")
}

#[test]
fn matches_filterpy_imm_estimator() {
    let g: Value = serde_json::from_str(include_str!("../golden/imm_two_mode.json")).expect("json");
    assert_eq!(mat(&g["H"]), vec![vec![1.0, 0.0]]);
    assert_eq!(mat(&g["R"]), vec![vec![0.25]]);
    let z = vec1(&g["z"]);
    let steps = g["steps"].as_array().expect("steps");
    for (fixed, form) in [
        (false, CovarianceForm::Joseph),
        (true, CovarianceForm::Joseph),
        (false, CovarianceForm::Standard),
    ] {
        let mut imm = golden_imm(&g, fixed, form);
        let mut seen_switch = false;
        for (k, (zk, s)) in z.iter().zip(steps).enumerate() {
            imm.step(&[*zk], None).expect("step");
            let (x, P, mu) = (vec1(&s["x"]), vec1(&s["P"]), vec1(&s["mu"]));
            // Same cycle in double precision: the differences are round-off of a few
            // dozen operations per step, amplified over 40 steps by at most the filters'
            // condition (P's entries are O(0.1..1)); 1e-9 absolute leaves three orders of
            // margin over what was seen (< 1e-12) and is far below any algorithmic
            // difference (a wrong mixing or prior moves mu by > 1e-3 here).
            for i in 0..2 {
                assert!(
                    (imm.state()[i] - x[i]).abs() < 1e-9,
                    "{form:?} step {k}: x[{i}]"
                );
                assert!(
                    (imm.mode_probabilities()[i] - mu[i]).abs() < 1e-9,
                    "step {k}: mu[{i}]"
                );
                for j in 0..2 {
                    let p = imm.covariance()[(i, j)];
                    assert!(
                        (p - P[i * 2 + j]).abs() < 1e-9,
                        "{form:?} step {k}: P[{i},{j}] {p} vs {}",
                        P[i * 2 + j]
                    );
                }
            }
            seen_switch |= mu[1] > 0.9;
        }
        // The record holds a manoeuvre the IMM must have detected, so the comparison
        // covers both regimes and the switching.
        assert!(seen_switch);
    }
}

#[test]
fn one_mode_is_the_filter() {
    let model = Model::new(
        DynDims::new(2, 1, 0).expect("dims"),
        &[[1.0, 0.5], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &[[0.01, 0.0], [0.0, 0.1]],
        &[[0.3]],
    )
    .expect("model");
    let mut plain = Filter::new(
        model.clone(),
        &[0.0, 1.0],
        &[[1.0, 0.0], [0.0, 1.0]],
        CovarianceForm::Joseph,
    )
    .expect("filter");
    let f = Filter::new(
        model,
        &[0.0, 1.0],
        &[[1.0, 0.0], [0.0, 1.0]],
        CovarianceForm::Joseph,
    )
    .expect("filter");
    let mut imm = Imm::new(
        vec![(Box::new(f) as Box<dyn Mode>, Embedding::identity(2))],
        &[[1.0]],
        &[1.0],
    )
    .expect("imm");
    for (k, z) in [0.3, 0.9, f64::NAN, 1.2, 2.5].iter().enumerate() {
        let a = plain.step(&[*z], None).expect("step");
        let b = imm.step(&[*z], None).expect("step");
        // One mode, weight one: the same operations in the same order.
        assert!(
            (a.log_likelihood - b.log_likelihood).abs() < 1e-13,
            "step {k}"
        );
        for i in 0..2 {
            assert!((plain.state()[i] - imm.state()[i]).abs() < 1e-13);
            assert!((plain.predicted_state()[i] - imm.mode_predicted_state(0)[i]).abs() < 1e-13);
            for j in 0..2 {
                assert!((plain.covariance()[(i, j)] - imm.covariance()[(i, j)]).abs() < 1e-13);
            }
        }
        assert_eq!(b.observed, usize::from(!z.is_nan()));
    }
    assert_eq!(imm.steps(), 5);
}

/// Two one-state modes far from the origin with a tight covariance (x ≈ 1e4, P = 1e-12, the
/// spread between the modes 1e-6): the combined P is the two-pass mixture formula to 1e-24
/// absolute (its own size is ~1e-12; a second moment x² ≈ 1e8 formed and subtracted would
/// leave errors of ~1e8·ε ≈ 1e-8, four orders larger than P itself).
#[test]
fn a_tight_covariance_far_from_the_origin_is_kept() {
    let mode = |x0: f64| -> Box<dyn Mode> {
        let m = Model::new(
            FixedDims::<1, 1>::new(),
            &[[1.0]],
            &[[1.0]],
            &[[0.0]],
            &[[1e-12]],
        )
        .expect("model");
        Box::new(Filter::new(m, &[x0], &[[1e-12]], CovarianceForm::Joseph).expect("filter"))
    };
    let (a, b) = (1e4, 1e4 + 1e-6);
    let imm = Imm::new(
        vec![
            (mode(a), Embedding::identity(1)),
            (mode(b), Embedding::identity(1)),
        ],
        &[[0.9, 0.1], [0.1, 0.9]],
        &[0.3, 0.7],
    )
    .expect("imm");
    let x = 0.3 * a + 0.7 * b;
    let p = 0.3 * ((a - x) * (a - x) + 1e-12) + 0.7 * ((b - x) * (b - x) + 1e-12);
    assert!((imm.state()[0] - x).abs() <= 1e-12 * x);
    let got = imm.covariance()[(0, 0)];
    assert!((got - p).abs() < 1e-24, "P = {got:e}, two-pass {p:e}");
}
