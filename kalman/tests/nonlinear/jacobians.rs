//! Jacobians: forward-mode AD equals the hand-written Jacobians to 1e-14 (the same
//! arithmetic, so a few ulps) on the boom accelerometer, range–bearing and pendulum models;
//! central differences stay within their documented truncation-plus-rounding bound.

use kalman::DynDims;
use kalman::nonlinear::{AutoDiff, CentralDiff, GenericModel, Jacobians};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::models::{Boom, Pendulum, PendulumHand, RangeBearing, RangeBearingHand};

fn close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tol * y.abs().max(1.0),
            "{what}[{i}]: {x} vs {y}"
        );
    }
}

fn boom(gamma_deg: f64) -> Boom {
    Boom {
        dt: 0.01,
        g: 9.8,
        r: 25.0,
        gamma: gamma_deg.to_radians(),
    }
}

#[test]
fn autodiff_equals_hand_written_jacobians() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for gamma in [0.0, 10.0] {
        let b = boom(gamma);
        let mut ad = AutoDiff::new(DynDims::new(3, 2, 0).expect("dims"), b.clone());
        for _ in 0..200 {
            let x = [
                rng.random_range(0.0..std::f64::consts::FRAC_PI_2),
                rng.random_range(-0.2..0.2),
                rng.random_range(-0.05..0.05),
            ];
            let (mut a, mut h) = ([0.0; 6], [0.0; 6]);
            ad.h_jacobian(&x, 0, &mut a);
            b.hjac(&x, &mut h);
            close(&a, &h, 1e-14, "boom dh/dx");
            let mut fa = [0.0; 9];
            ad.f_jacobian(&x, None, 0, &mut fa);
            let dt = b.dt;
            let fh = [1.0, 0.0, 0.0, dt, 1.0, 0.0, 0.5 * dt * dt, dt, 1.0];
            close(&fa, &fh, 1e-14, "boom df/dx");
        }
    }
    let mut ad = AutoDiff::new(
        DynDims::new(4, 2, 0).expect("dims"),
        RangeBearing::default(),
    );
    let mut hand = RangeBearingHand::default();
    let mut pad = AutoDiff::new(DynDims::new(2, 1, 0).expect("dims"), Pendulum::default());
    let mut phand = PendulumHand::default();
    for _ in 0..200 {
        let x: [f64; 4] = std::array::from_fn(|_| rng.random_range(-100.0..100.0));
        let (mut a, mut h) = ([0.0; 8], [0.0; 8]);
        ad.h_jacobian(&x, 0, &mut a);
        hand.h_jacobian(&x, 0, &mut h);
        close(&a, &h, 1e-14, "range-bearing dh/dx");
        let (mut a, mut h) = ([0.0; 16], [0.0; 16]);
        ad.f_jacobian(&x, None, 0, &mut a);
        hand.f_jacobian(&x, None, 0, &mut h);
        close(&a, &h, 1e-14, "range-bearing df/dx");
        let y = [rng.random_range(-3.0..3.0), rng.random_range(-5.0..5.0)];
        let (mut a, mut h) = ([0.0; 4], [0.0; 4]);
        pad.f_jacobian(&y, None, 0, &mut a);
        phand.f_jacobian(&y, None, 0, &mut h);
        close(&a, &h, 1e-14, "pendulum df/dx");
        let (mut a, mut h) = ([0.0; 2], [0.0; 2]);
        pad.h_jacobian(&y, 0, &mut a);
        phand.h_jacobian(&y, 0, &mut h);
        close(&a, &h, 1e-14, "pendulum dh/dx");
    }
}

#[test]
fn central_differences_within_their_documented_bound() {
    // Boom h: ∂³h/∂α³ = (−g cos, g sin) so |·| ≤ g; ω² r and ε r have zero third
    // derivatives. Bound per entry (CentralDiff's documentation): δ²/6·g + 4ε·max|h|/δ,
    // the factor 4 covering the few-ulp evaluation error of h (sin, products, sums).
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let eps = f64::EPSILON;
    let s = eps.cbrt();
    for gamma in [0.0, 10.0] {
        let b = boom(gamma);
        let model = kalman::nonlinear::FnModel::new(
            DynDims::new(3, 2, 0).expect("dims"),
            {
                let b = b.clone();
                move |x: &[f64], u: Option<&[f64]>, k: usize, out: &mut [f64]| b.f(x, u, k, out)
            },
            {
                let b = b.clone();
                move |x: &[f64], k: usize, out: &mut [f64]| b.h(x, k, out)
            },
            &[[0.0; 3]; 3],
            &[[1.0, 0.0], [0.0, 1.0]],
        )
        .expect("model");
        let mut cd = CentralDiff::new(DynDims::new(3, 2, 0).expect("dims"), model);
        let mut worst = 0.0_f64;
        for _ in 0..200 {
            let x = [
                rng.random_range(0.0..std::f64::consts::FRAC_PI_2),
                rng.random_range(-0.2..0.2),
                rng.random_range(-0.05..0.05),
            ];
            let (mut c, mut h) = ([0.0; 6], [0.0; 6]);
            cd.h_jacobian(&x, 0, &mut c);
            b.hjac(&x, &mut h);
            let mut hx = [0.0; 2];
            b.h(&x, 0, &mut hx);
            let hmax = hx[0].abs().max(hx[1].abs()) + b.g;
            for j in 0..3 {
                let d = s * x[j].abs().max(1.0);
                let third = if j == 0 { b.g } else { 0.0 };
                let bound = d * d / 6.0 * third + 4.0 * eps * hmax / d;
                for i in 0..2 {
                    let err = (c[i + 2 * j] - h[i + 2 * j]).abs();
                    worst = worst.max(err / bound);
                    assert!(
                        err <= bound,
                        "entry ({i}, {j}): error {err:e} > bound {bound:e}"
                    );
                }
            }
        }
        // The bound is not vacuous: the errors reach a visible fraction of it.
        assert!(worst > 1e-3, "worst error / bound = {worst}");
    }
}
