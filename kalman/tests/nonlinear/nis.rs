//! Consistency: on a simulated range–bearing tracker (200 runs of 25 steps, the truth
//! drawn from the filters' own prior and noise model) the mean NIS of the EKF, the iterated
//! EKF and the UKF lies in its χ² 95 % band.

use kalman::chi2_quantile;
use kalman::nonlinear::{Ekf, EkfUpdate, GenericModel, SigmaPoints, Ukf};
use kalman::{FixedDims, MatrixInput};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::models::{RangeBearing, RangeBearingHand};

/// Lower Cholesky factor of a small SPD matrix (column-major, n×n).
fn chol(a: &[f64], n: usize) -> Vec<f64> {
    let mut l = vec![0.0; n * n];
    for j in 0..n {
        let d = a[j + j * n] - (0..j).map(|k| l[j + k * n] * l[j + k * n]).sum::<f64>();
        l[j + j * n] = d.sqrt();
        for i in j + 1..n {
            let s = a[i + j * n] - (0..j).map(|k| l[i + k * n] * l[j + k * n]).sum::<f64>();
            l[i + j * n] = s / l[j + j * n];
        }
    }
    l
}

fn draw(l: &[f64], n: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let e: Vec<f64> = (0..n).map(|_| StandardNormal.sample(rng)).collect();
    (0..n)
        .map(|i| (0..=i).map(|j| l[i + j * n] * e[j]).sum())
        .collect()
}

#[test]
fn mean_nis_is_in_the_chi2_band() {
    let (runs, steps) = (200, 25);
    let model = RangeBearing::default();
    let (mut q, mut r) = ([0.0; 16], [0.0; 4]);
    model.q(0, &mut q);
    model.r(0, &mut r);
    let (lq, lr) = (chol(&q, 4), chol(&r, 2));
    let x0 = RangeBearing::x0();
    let p0 = RangeBearing::p0();
    let p0c: Vec<f64> = (0..16).map(|i| p0.at(i % 4, i / 4)).collect();
    let lp = chol(&p0c, 4);
    let d = FixedDims::<4, 2>::new();
    // Sums of NIS and their degrees of freedom, per filter.
    let mut sums = [(0.0, 0usize); 3];
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    for _ in 0..runs {
        let mut ekf = Ekf::new(
            d,
            RangeBearingHand::default(),
            &x0,
            &p0,
            EkfUpdate::Extended,
        )
        .expect("ekf");
        let it = EkfUpdate::Iterated {
            max_iterations: 10,
            tolerance: 1e-10,
        };
        let mut iekf = Ekf::new(d, RangeBearingHand::default(), &x0, &p0, it).expect("iekf");
        let mut ukf = Ukf::new(
            d,
            RangeBearingHand::default(),
            &x0,
            &p0,
            SigmaPoints::merwe(1.0, 2.0, -1.0),
        )
        .expect("ukf");
        let w = draw(&lp, 4, &mut rng);
        let mut x: Vec<f64> = (0..4).map(|i| x0[i] + w[i]).collect();
        for _ in 0..steps {
            let mut z = [0.0; 2];
            model.h(&x, 0, &mut z);
            let v = draw(&lr, 2, &mut rng);
            z[0] += v[0];
            z[1] += v[1];
            for (s, info) in sums.iter_mut().zip([
                ekf.step(&z, None).expect("ekf"),
                iekf.step(&z, None).expect("iekf"),
                ukf.step(&z, None).expect("ukf"),
            ]) {
                s.0 += info.nis.expect("observed");
                s.1 += info.observed;
            }
            let mut next = [0.0; 4];
            model.f(&x, None, 0, &mut next);
            let w = draw(&lq, 4, &mut rng);
            x = (0..4).map(|i| next[i] + w[i]).collect();
        }
    }
    let updates = (runs * steps) as f64;
    for ((sum, dof), name) in sums.iter().zip(["EKF", "iterated EKF", "UKF"]) {
        // Σ NIS ~ χ²(dof) for a consistent filter: the mean per update lies in
        // [χ²_{0.025}(dof), χ²_{0.975}(dof)] / updates with probability 0.95.
        let lo = chi2_quantile(0.025, *dof) / updates;
        let hi = chi2_quantile(0.975, *dof) / updates;
        let mean = sum / updates;
        assert!(
            (lo..=hi).contains(&mean),
            "{name}: mean NIS {mean:.4} outside [{lo:.4}, {hi:.4}]"
        );
    }
}
