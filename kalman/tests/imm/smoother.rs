//! The IMM smoother against the Rauch–Tung–Striebel smoother where they must agree: one
//! mode, and two identical modes (whatever Π, the mixture of equal estimates is that
//! estimate and every mode is the one filter), on the linear and the unscented path.

use kalman::imm::{Embedding, Imm, ImmRecord, Mode};
use kalman::nonlinear::{FnModel, NonlinearRts, SigmaPoints, Ukf};
use kalman::{CovarianceForm, DynDims, Filter, Model};

const F: [[f64; 2]; 2] = [[1.0, 0.5], [0.0, 0.9]];
const Q: [[f64; 2]; 2] = [[0.02, 0.01], [0.01, 0.3]];
const P0: [[f64; 2]; 2] = [[2.0, 0.3], [0.3, 1.0]];
const X0: [f64; 2] = [0.5, -0.2];
const Z: [f64; 8] = [0.3, 0.9, f64::NAN, 1.7, 2.5, 2.2, f64::NAN, 3.9];

fn linear() -> Filter {
    let model = Model::new(
        DynDims::new(2, 1, 0).expect("dims"),
        &F,
        &[[1.0, 0.0]],
        &Q,
        &[[0.4]],
    )
    .expect("model");
    Filter::new(model, &X0, &P0, CovarianceForm::Joseph).expect("filter")
}

fn unscented() -> Ukf<DynDims, impl kalman::nonlinear::NonlinearModel + Clone + 'static> {
    let d = DynDims::new(2, 1, 0).expect("dims");
    let model = FnModel::new(
        d,
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
            out[0] = x[0] + 0.5 * x[1];
            out[1] = 0.9 * x[1] + 0.1 * x[0].sin();
        },
        |x: &[f64], _k: usize, out: &mut [f64]| out[0] = x[0] + 0.1 * x[0] * x[0],
        &Q,
        &[[0.4]],
    )
    .expect("model");
    Ukf::new(d, model, &X0, &P0, SigmaPoints::merwe(0.5, 2.0, 0.0)).expect("ukf")
}

fn smoothed(modes: Vec<Box<dyn Mode>>, pi: &[[f64; 2]; 2]) -> kalman::imm::ImmSmoothed {
    let r = modes.len();
    let modes = modes
        .into_iter()
        .map(|m| (m, Embedding::identity(2)))
        .collect();
    let mut imm = if r == 1 {
        Imm::new(modes, &[[1.0]], &[1.0])
    } else {
        Imm::new(modes, pi, &[0.3, 0.7])
    }
    .expect("imm");
    let mut rec = ImmRecord::new();
    for z in Z {
        imm.step_recorded(&[z], None, &mut rec).expect("step");
    }
    assert_eq!(rec.len(), Z.len());
    rec.smooth().expect("smooth")
}

fn close(
    s: &kalman::imm::ImmSmoothed,
    means: faer::MatRef<'_, f64>,
    covs: &[faer::Mat<f64>],
    tol: f64,
) {
    for k in 0..Z.len() {
        for i in 0..2 {
            let (a, b) = (s.means[(i, k)], means[(i, k)]);
            assert!((a - b).abs() < tol, "step {k}: x[{i}] {a} vs {b}");
            for j in 0..2 {
                let (a, b) = (s.covariances[k][(i, j)], covs[k][(i, j)]);
                assert!((a - b).abs() < tol, "step {k}: P[{i},{j}] {a} vs {b}");
            }
        }
    }
}

/// Same operations as the RTS recursion up to the order of a few sums: 1e-12 is a few
/// hundred ulps of the O(1) estimates.
const TOL: f64 = 1e-12;

#[test]
fn linear_modes_give_the_rts_smoother() {
    let rts = linear().run_smoothed(Z.map(|z| [z])).expect("rts");
    let one = smoothed(vec![Box::new(linear())], &[[1.0, 0.0], [0.0, 1.0]]);
    close(&one, rts.means.as_ref(), &rts.covariances, TOL);
    let pi = [[0.8, 0.2], [0.4, 0.6]];
    let two = smoothed(vec![Box::new(linear()), Box::new(linear())], &pi);
    close(&two, rts.means.as_ref(), &rts.covariances, TOL);
    // Equal likelihoods: μ_k is the prior propagated by Π, and so is μ_{k|N}.
    let mut mu = [0.3, 0.7];
    for k in 0..Z.len() {
        assert!(
            (two.mode_probabilities[(0, k)] - mu[0]).abs() < 1e-12,
            "step {k}"
        );
        mu = [
            mu[0] * pi[0][0] + mu[1] * pi[1][0],
            mu[0] * pi[0][1] + mu[1] * pi[1][1],
        ];
    }
}

#[test]
fn unscented_modes_give_the_unscented_rts_smoother() {
    let mut ukf = unscented();
    let mut rts = NonlinearRts::new();
    for z in Z {
        ukf.step(&[z], None).expect("step");
        rts.record(&ukf).expect("record");
    }
    let rts = rts.smooth().expect("rts");
    let two = smoothed(
        vec![Box::new(unscented()), Box::new(unscented())],
        &[[0.9, 0.1], [0.2, 0.8]],
    );
    close(&two, rts.means.as_ref(), &rts.covariances, 1e-10);
}

#[test]
fn an_empty_record_is_refused() {
    assert!(matches!(
        ImmRecord::new().smooth(),
        Err(kalman::Error::Dimension { name: "record", .. })
    ));
}
