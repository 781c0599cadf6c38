//! Modes of different kinds and dimensions: the mixing and the combined estimate of a
//! constant-velocity mode embedded in a constant-acceleration mode, checked against the
//! cycle worked by hand from two plain filters; an IMM over a linear filter, an EKF and a
//! UKF that allocates nothing per step; and the typed errors of the constructors.

use kalman::imm::{Embedding, Imm, ImmRecord, Mode};
use kalman::nonlinear::{CentralDiff, Ekf, EkfUpdate, FnModel, SigmaPoints, Ukf};
use kalman::{CovarianceForm, DynDims, Error, Filter, FixedDims, Model};

use super::manoeuvre::{ct, cv};
use crate::common::counting::allocations;

const DT: f64 = 0.5;

fn cv2() -> Filter {
    let m = Model::new(
        DynDims::new(2, 1, 0).expect("dims"),
        &[[1.0, DT], [0.0, 1.0]],
        &[[1.0, 0.0]],
        &[[1e-3, 0.0], [0.0, 1e-2]],
        &[[0.5]],
    )
    .expect("CV");
    Filter::new(
        m,
        &[0.0, 1.0],
        &[[1.0, 0.0], [0.0, 0.5]],
        CovarianceForm::Joseph,
    )
    .expect("CV")
}

fn ca3() -> Filter {
    let h = DT * DT / 2.0;
    let m = Model::new(
        DynDims::new(3, 1, 0).expect("dims"),
        &[[1.0, DT, h], [0.0, 1.0, DT], [0.0, 0.0, 1.0]],
        &[[1.0, 0.0, 0.0]],
        &[[1e-3, 0.0, 0.0], [0.0, 1e-2, 0.0], [0.0, 0.0, 0.3]],
        &[[0.5]],
    )
    .expect("CA");
    Filter::new(
        m,
        &[0.2, 0.8, 0.5],
        &[[1.2, 0.1, 0.0], [0.1, 0.6, 0.05], [0.0, 0.05, 0.4]],
        CovarianceForm::Joseph,
    )
    .expect("CA")
}

const PI: [[f64; 2]; 2] = [[0.9, 0.1], [0.2, 0.8]];
const MU0: [f64; 2] = [0.7, 0.3];

fn cv_ca() -> Imm {
    Imm::new(
        vec![
            (
                Box::new(cv2()) as Box<dyn Mode>,
                Embedding::new(3, &[0, 1])
                    .and_then(|e| e.with_fill(&[0.0, 0.0, 0.25], &[0.0, 0.0, 2.0]))
                    .expect("embedding"),
            ),
            (Box::new(ca3()), Embedding::identity(3)),
        ],
        &PI,
        &MU0,
    )
    .expect("IMM")
}

#[test]
fn mixing_across_dimensions_matches_the_hand_cycle() {
    let mut imm = cv_ca();
    let (mut a, mut b) = (cv2(), ca3());
    let z = 0.9;
    imm.step(&[z], None).expect("IMM");
    let la = a.step(&[z], None).expect("CV").log_likelihood;
    let lb = b.step(&[z], None).expect("CA").log_likelihood;
    // μ ∝ μ0 · likelihood.
    let (wa, wb) = (MU0[0] * la.exp(), MU0[1] * lb.exp());
    let mu = [wa / (wa + wb), wb / (wa + wb)];
    assert!((imm.mode_probabilities()[0] - mu[0]).abs() < 1e-14);
    // Combined: CV lifted with the fill a = 0.25 ± √2.
    let (xa, xb) = (a.state().to_vec(), b.state().to_vec());
    let lift = [xa[0], xa[1], 0.25];
    for i in 0..3 {
        let want = mu[0] * lift[i] + mu[1] * xb[i];
        assert!((imm.state()[i] - want).abs() < 1e-13, "x[{i}]");
    }
    let (Pa, Pb) = (a.covariance(), b.covariance());
    let pa = |i: usize, j: usize| match (i, j) {
        (2, 2) => 2.0,
        (2, _) | (_, 2) => 0.0,
        _ => Pa[(i, j)],
    };
    for i in 0..3 {
        for j in 0..3 {
            let x = imm.state();
            let want = mu[0] * (pa(i, j) + (lift[i] - x[i]) * (lift[j] - x[j]))
                + mu[1] * (Pb[(i, j)] + (xb[i] - x[i]) * (xb[j] - x[j]));
            assert!(
                (imm.covariance()[(i, j)] - want).abs() < 1e-13,
                "P[{i},{j}]"
            );
        }
    }
    // Mixing into CA: the CV source lacks the acceleration, which takes CA's own value.
    let c1 = PI[0][1] * mu[0] + PI[1][1] * mu[1];
    let (o0, o1) = (PI[0][1] * mu[0] / c1, PI[1][1] * mu[1] / c1);
    let src = [xa[0], xa[1], xb[2]];
    let mixed: Vec<f64> = (0..3).map(|i| o0 * src[i] + o1 * xb[i]).collect();
    for i in 0..3 {
        assert!(
            (imm.mode_mixed_state(1)[i] - mixed[i]).abs() < 1e-13,
            "mixed CA x[{i}]"
        );
    }
    // The predicted probabilities are Πᵀμ.
    assert!((imm.predicted_mode_probabilities()[1] - c1).abs() < 1e-14);
    // Mixing into CV: (p, v) of both, no fill.
    let c0 = PI[0][0] * mu[0] + PI[1][0] * mu[1];
    let (o0, o1) = (PI[0][0] * mu[0] / c0, PI[1][0] * mu[1] / c0);
    for i in 0..2 {
        let want = o0 * xa[i] + o1 * xb[i];
        assert!(
            (imm.mode_mixed_state(0)[i] - want).abs() < 1e-13,
            "mixed CV x[{i}]"
        );
    }
    // And each mode predicts from its mixed posterior with its own model.
    let m = imm.mode_mixed_state(1).to_vec();
    let h = DT * DT / 2.0;
    let pred = [m[0] + DT * m[1] + h * m[2], m[1] + DT * m[2], m[2]];
    for i in 0..3 {
        assert!((imm.mode_predicted_state(1)[i] - pred[i]).abs() < 1e-13);
    }
}

#[test]
fn an_imm_step_over_three_filter_kinds_allocates_nothing() {
    let x0 = [0.0, 40.0, 0.0, 0.0, 0.0];
    let p0: [[f64; 5]; 5] =
        std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 10.0 } else { 0.0 }));
    let p4: [[f64; 4]; 4] = std::array::from_fn(|i| std::array::from_fn(|j| p0[i][j]));
    let turn =
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| super::manoeuvre::turn(x, out);
    let pos = |x: &[f64], _k: usize, out: &mut [f64]| {
        out[0] = x[0];
        out[1] = x[2];
    };
    let d = DynDims::new(5, 2, 0).expect("dims");
    let q: [[f64; 5]; 5] =
        std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 0.1 } else { 0.0 }));
    let r = [[100.0, 0.0], [0.0, 100.0]];
    let ekf_model = CentralDiff::new(d, FnModel::new(d, turn, pos, &q, &r).expect("model"));
    let ekf = Ekf::new(d, ekf_model, &x0, &p0, EkfUpdate::Extended).expect("EKF");
    let ukf_dyn = Ukf::new(
        d,
        FnModel::new(d, turn, pos, &q, &r).expect("model"),
        &x0,
        &p0,
        SigmaPoints::Cubature,
    )
    .expect("UKF");
    let modes: Vec<(Box<dyn Mode>, Embedding)> = vec![
        (
            Box::new(cv(0.05, &x0[..4], &p4)),
            Embedding::new(5, &[0, 1, 2, 3]).expect("e"),
        ),
        (Box::new(ct(0.5, 1e-4, &x0, &p0)), Embedding::identity(5)),
        (Box::new(ekf), Embedding::identity(5)),
        (Box::new(ukf_dyn), Embedding::identity(5)),
    ];
    let t = [
        [0.85, 0.05, 0.05, 0.05],
        [0.05, 0.85, 0.05, 0.05],
        [0.05, 0.05, 0.85, 0.05],
        [0.05, 0.05, 0.05, 0.85],
    ];
    let mut imm = Imm::new(modes, &t, &[0.25; 4]).expect("IMM");
    imm.step(&[1.0, 0.5], None).expect("first step");
    let before = allocations();
    for k in 1..12 {
        let z = if k == 5 {
            [f64::NAN, f64::NAN]
        } else if k == 7 {
            [40.0 * k as f64, f64::NAN]
        } else {
            [40.0 * k as f64, 0.3 * k as f64]
        };
        imm.step(&z, None).expect("step");
    }
    assert_eq!(allocations() - before, 0);
    assert_eq!(imm.steps(), 12);
    assert_eq!(imm.last_step().observed, 2);
}

#[test]
fn recording_does_not_change_the_filter() {
    let (mut a, mut b) = (cv_ca(), cv_ca());
    let mut rec = ImmRecord::new();
    for z in [0.9, 1.4, f64::NAN, 2.9, 4.8, 7.5] {
        let sa = a.step(&[z], None).expect("step");
        let sb = b.step_recorded(&[z], None, &mut rec).expect("step");
        assert_eq!(sa, sb);
        assert_eq!(a.state(), b.state());
        assert_eq!(a.mode_probabilities(), b.mode_probabilities());
    }
    let s = rec.smooth().expect("smooth");
    // The last smoothed estimate is the filtered one.
    for i in 0..3 {
        assert!((s.means[(i, 5)] - b.state()[i]).abs() < 1e-12);
    }
    // Another IMM's steps are refused by this record.
    let mut one = Imm::new(
        vec![(Box::new(cv2()) as Box<dyn Mode>, Embedding::identity(2))],
        &[[1.0]],
        &[1.0],
    )
    .expect("IMM");
    assert!(matches!(
        one.step_recorded(&[1.0], None, &mut rec),
        Err(Error::Dimension { name: "record", .. })
    ));
}

fn boxed(f: Filter) -> Box<dyn Mode> {
    Box::new(f)
}

#[test]
fn bad_input_is_a_typed_error() {
    let two = |t: &[[f64; 2]; 2], mu: &[f64]| {
        Imm::new(
            vec![
                (boxed(cv2()), Embedding::identity(2)),
                (boxed(cv2()), Embedding::identity(2)),
            ],
            t,
            mu,
        )
    };
    let ok = [[0.9, 0.1], [0.2, 0.8]];
    assert!(two(&ok, &[0.5, 0.5]).is_ok());
    assert!(matches!(
        two(&[[0.9, 0.2], [0.2, 0.8]], &[0.5, 0.5]),
        Err(Error::InvalidOption {
            name: "transition",
            ..
        })
    ));
    assert!(matches!(
        two(&[[1.1, -0.1], [0.2, 0.8]], &[0.5, 0.5]),
        Err(Error::InvalidOption {
            name: "transition",
            ..
        })
    ));
    assert!(matches!(
        two(&[[f64::NAN, 0.1], [0.2, 0.8]], &[0.5, 0.5]),
        Err(Error::NonFinite {
            name: "transition",
            ..
        })
    ));
    assert!(matches!(
        two(&ok, &[0.5, 0.4]),
        Err(Error::InvalidOption { name: "mu0", .. })
    ));
    assert!(matches!(
        two(&ok, &[1.0]),
        Err(Error::Shape { name: "mu0", .. })
    ));
    assert!(matches!(
        Imm::new(vec![(boxed(cv2()), Embedding::identity(2))], &ok, &[1.0]),
        Err(Error::Shape {
            name: "transition",
            ..
        })
    ));
    assert!(matches!(
        Imm::new(Vec::new(), &[[1.0]], &[1.0]),
        Err(Error::Dimension { name: "modes", .. })
    ));
    // A 2-state filter with a 3-state embedding; embeddings of different common sizes.
    assert!(matches!(
        Imm::new(
            vec![(boxed(cv2()), Embedding::identity(3))],
            &[[1.0]],
            &[1.0]
        ),
        Err(Error::Dimension { name: "modes", .. })
    ));
    assert!(matches!(
        Imm::new(
            vec![
                (boxed(cv2()), Embedding::identity(2)),
                (boxed(ca3()), Embedding::identity(3))
            ],
            &ok,
            &[0.5, 0.5]
        ),
        Err(Error::Dimension { name: "modes", .. })
    ));
    // Different m.
    let m2 = Model::new(
        DynDims::new(2, 2, 0).expect("dims"),
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[1.0, 0.0], [0.0, 1.0]],
    )
    .expect("model");
    let f2 = Filter::new(
        m2.clone(),
        &[0.0, 0.0],
        &[[1.0, 0.0], [0.0, 1.0]],
        CovarianceForm::Joseph,
    )
    .expect("filter");
    assert!(matches!(
        Imm::new(
            vec![
                (boxed(cv2()), Embedding::identity(2)),
                (boxed(f2), Embedding::identity(2))
            ],
            &ok,
            &[0.5, 0.5]
        ),
        Err(Error::Dimension { name: "modes", .. })
    ));
    // The square-root form and a cross-covariance S are refused by name.
    let sq = Filter::new(
        m2.clone(),
        &[0.0, 0.0],
        &[[1.0, 0.0], [0.0, 1.0]],
        CovarianceForm::SquareRoot,
    )
    .expect("filter");
    assert!(matches!(
        Imm::new(vec![(boxed(sq), Embedding::identity(2))], &[[1.0]], &[1.0]),
        Err(Error::InvalidOption { name: "form", .. })
    ));
    let ms = m2
        .with_cross_covariance(&[[0.1, 0.0], [0.0, 0.1]])
        .expect("S");
    let fs = Filter::new(
        ms,
        &[0.0, 0.0],
        &[[1.0, 0.0], [0.0, 1.0]],
        CovarianceForm::Joseph,
    )
    .expect("filter");
    assert!(matches!(
        Imm::new(vec![(boxed(fs), Embedding::identity(2))], &[[1.0]], &[1.0]),
        Err(Error::InvalidOption { name: "S", .. })
    ));
    // Embeddings.
    assert!(matches!(
        Embedding::new(3, &[0, 3]),
        Err(Error::Dimension {
            name: "indices",
            ..
        })
    ));
    assert!(matches!(
        Embedding::new(3, &[1, 1]),
        Err(Error::Dimension {
            name: "indices",
            ..
        })
    ));
    assert!(matches!(
        Embedding::new(3, &[]),
        Err(Error::Dimension {
            name: "indices",
            ..
        })
    ));
    let e = Embedding::new(3, &[0, 1]).expect("embedding");
    assert!(matches!(
        e.clone().with_fill(&[0.0; 3], &[0.0, 0.0, -1.0]),
        Err(Error::InvalidOption {
            name: "fill_variance",
            ..
        })
    ));
    assert!(matches!(
        e.with_fill(&[0.0; 2], &[0.0; 3]),
        Err(Error::Shape {
            name: "fill_mean",
            ..
        })
    ));
    // A step with the wrong z length; with an infinite entry.
    let mut imm = two(&ok, &[0.5, 0.5]).expect("IMM");
    assert!(matches!(
        imm.step(&[1.0, 2.0], None),
        Err(Error::Shape { name: "z", .. })
    ));
    assert!(matches!(
        imm.step(&[f64::INFINITY], None),
        Err(Error::NonFinite { name: "z", .. })
    ));
    let _ = FixedDims::<2, 1>::new();
}
