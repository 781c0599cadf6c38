//! Zero heap allocations per nonlinear step (EKF, iterated EKF, the plain and the square-root
//! UKF with every sigma-point set; hand, AD and central-difference Jacobians), on the fixed
//! and dynamic paths, with the counting global allocator (`common/counting.rs`).

use kalman::nonlinear::{
    AutoDiff, CentralDiff, Ekf, EkfUpdate, FixedLag, FnModel, Jacobians, NlDims, NonlinearModel,
    SigmaPoints, SqrtUkf, Ukf,
};
use kalman::strategies::{FilterProblem, ProblemOptions};
use kalman::{DynDims, FixedDims};

use super::models::{Linear, RangeBearing};
use crate::common::counting::allocations;

trait Stepper {
    fn go(&mut self, z: &[f64], u: Option<&[f64]>);
}

impl<D: NlDims, M: Jacobians> Stepper for Ekf<D, M> {
    fn go(&mut self, z: &[f64], u: Option<&[f64]>) {
        assert!(self.step(z, u).is_ok());
    }
}

impl<D: NlDims, M: NonlinearModel> Stepper for Ukf<D, M> {
    fn go(&mut self, z: &[f64], u: Option<&[f64]>) {
        assert!(self.step(z, u).is_ok());
    }
}

impl<D: NlDims, M: NonlinearModel> Stepper for SqrtUkf<D, M> {
    fn go(&mut self, z: &[f64], u: Option<&[f64]>) {
        assert!(self.step(z, u).is_ok());
    }
}

/// Allocations during the steps after the first (construction and the first step are
/// outside the count), with missing entries and an all-missing step.
fn count(f: &mut dyn Stepper, zs: &[Vec<f64>], us: &[Vec<f64>]) -> usize {
    f.go(&zs[0], us.first().map(Vec::as_slice));
    let before = allocations();
    for (k, z) in zs.iter().enumerate().skip(1) {
        f.go(z, us.get(k).map(Vec::as_slice));
    }
    let nan = [f64::NAN; 16];
    f.go(&nan[..zs[0].len()], us.first().map(Vec::as_slice));
    allocations() - before
}

fn linear_case<D: NlDims>(p: &FilterProblem, d: D) {
    let updates = [
        EkfUpdate::Extended,
        EkfUpdate::Iterated {
            max_iterations: 4,
            tolerance: 0.0,
        },
    ];
    for u in updates {
        let mut f = Ekf::new(d, Linear::new(p), &p.system.x0, &p.system.p0, u).expect("ekf");
        assert_eq!(count(&mut f, &p.z, &p.u), 0, "EKF {u:?} hand");
        let cd = CentralDiff::new(d, Linear::new(p));
        let mut f = Ekf::new(d, cd, &p.system.x0, &p.system.p0, u).expect("ekf");
        assert_eq!(
            count(&mut f, &p.z, &p.u),
            0,
            "EKF {u:?} central differences"
        );
    }
    for s in [
        SigmaPoints::merwe(0.5, 2.0, 0.0),
        SigmaPoints::Cubature,
        SigmaPoints::julier(1.0),
        SigmaPoints::Simplex,
    ] {
        let mut f = Ukf::new(d, Linear::new(p), &p.system.x0, &p.system.p0, s).expect("ukf");
        assert_eq!(count(&mut f, &p.z, &p.u), 0, "UKF {s:?}");
        let mut f = SqrtUkf::new(d, Linear::new(p), &p.system.x0, &p.system.p0, s).expect("sqrt");
        assert_eq!(count(&mut f, &p.z, &p.u), 0, "square-root UKF {s:?}");
    }
}

#[test]
fn no_allocation_per_nonlinear_step() {
    let opts = ProblemOptions {
        steps: 10,
        missing: 0.2,
        p: 1,
        ..ProblemOptions::default()
    };
    let p = FilterProblem::generate(7, 2, opts, 41);
    linear_case(&p, FixedDims::<7, 2, 1>::new());
    linear_case(&p, DynDims::new(7, 2, 1).expect("dims"));
    let big = FilterProblem::generate(20, 5, opts, 42);
    linear_case(&big, DynDims::new(20, 5, 1).expect("dims"));

    // AD Jacobians and closures, on the range–bearing tracker.
    let zs: Vec<Vec<f64>> = (0..10)
        .map(|k| {
            vec![
                70.0 - k as f64,
                if k == 4 {
                    f64::NAN
                } else {
                    -0.5 + 0.02 * k as f64
                },
            ]
        })
        .collect();
    let x0 = RangeBearing::x0();
    let p0 = RangeBearing::p0();
    let fixed = FixedDims::<4, 2>::new();
    let dynd = DynDims::new(4, 2, 0).expect("dims");
    let mut f = Ekf::new(
        fixed,
        AutoDiff::new(fixed, RangeBearing::default()),
        &x0,
        &p0,
        EkfUpdate::Extended,
    )
    .expect("ekf");
    assert_eq!(count(&mut f, &zs, &[]), 0, "EKF AD fixed");
    let mut f = Ekf::new(
        dynd,
        AutoDiff::new(dynd, RangeBearing::default()),
        &x0,
        &p0,
        EkfUpdate::Extended,
    )
    .expect("ekf");
    assert_eq!(count(&mut f, &zs, &[]), 0, "EKF AD dyn");
    let closures = FnModel::new(
        fixed,
        |x: &[f64], _u: Option<&[f64]>, _k: usize, out: &mut [f64]| {
            out.copy_from_slice(x);
            out[0] += x[1];
            out[2] += x[3];
        },
        |x: &[f64], _k: usize, out: &mut [f64]| {
            out[0] = x[0].hypot(x[2]);
            out[1] = x[2].atan2(x[0]);
        },
        &[
            [0.01, 0.0, 0.0, 0.0],
            [0.0, 0.01, 0.0, 0.0],
            [0.0, 0.0, 0.01, 0.0],
            [0.0, 0.0, 0.0, 0.01],
        ],
        &[[0.25, 0.0], [0.0, 1e-4]],
    )
    .expect("model");
    let mut f = Ukf::new(fixed, closures.clone(), &x0, &p0, SigmaPoints::Cubature).expect("ukf");
    assert_eq!(count(&mut f, &zs, &[]), 0, "UKF closures fixed");
    let set = SigmaPoints::merwe(0.5, 2.0, -1.0);
    let mut f = SqrtUkf::new(fixed, closures, &x0, &p0, set).expect("sqrt");
    assert_eq!(count(&mut f, &zs, &[]), 0, "square-root UKF closures fixed");
}

/// The fixed-lag smoother's record-and-smooth step allocates nothing either (a UKF and the
/// linear filter, lag 4, with missing entries).
#[test]
fn no_allocation_per_fixed_lag_step() {
    let opts = ProblemOptions {
        steps: 12,
        missing: 0.2,
        p: 1,
        ..ProblemOptions::default()
    };
    let p = FilterProblem::generate(5, 2, opts, 43);
    let d = DynDims::new(5, 2, 1).expect("dims");
    let mut ukf = Ukf::new(
        d,
        Linear::new(&p),
        &p.system.x0,
        &p.system.p0,
        SigmaPoints::Cubature,
    )
    .expect("ukf");
    let mut lin = kalman::Filter::new(
        p.model(d).expect("model"),
        &p.system.x0,
        &p.system.p0,
        kalman::CovarianceForm::Joseph,
    )
    .expect("filter");
    let (mut a, mut b) = (
        FixedLag::new(5, 4).expect("lag"),
        FixedLag::new(5, 4).expect("lag"),
    );
    let mut before = 0;
    for (k, (z, u)) in p.z.iter().zip(&p.u).enumerate() {
        if k == 1 {
            before = allocations();
        }
        ukf.step(z, Some(u)).expect("ukf step");
        a.record(&ukf).expect("record");
        lin.step(z, Some(u)).expect("linear step");
        b.record_linear(&lin).expect("record");
    }
    assert_eq!(allocations() - before, 0, "fixed-lag steps");
}

/// States on a manifold (the attitude model: a unit quaternion and a gyro bias, 7 stored,
/// 6 tangent): the EKF with tangent central differences, the plain and the square-root
/// UKF on both storage paths, and the manifold fixed-lag smoother allocate nothing per
/// step either.
#[test]
fn no_allocation_per_manifold_step() {
    use super::attitude::{flight, model, p0, space};
    let f = flight(21);
    let zs: Vec<Vec<f64>> = f.z[..20].iter().map(|z| z.to_vec()).collect();
    let us: Vec<Vec<f64>> = f.gyro[..20].iter().map(|u| u.to_vec()).collect();
    let fixed = FixedDims::<6, 6, 3, 7>::new();
    let dynd = DynDims::new(6, 6, 3)
        .and_then(|d| d.with_stored(7))
        .expect("dims");
    let set = SigmaPoints::merwe(0.5, 2.0, 0.0);
    let mut a = Ukf::new(fixed, model(fixed), &f.x0, &p0(), set).expect("ukf");
    assert_eq!(count(&mut a, &zs, &us), 0, "manifold UKF fixed");
    let mut b = Ukf::new(dynd, model(dynd), &f.x0, &p0(), set).expect("ukf");
    assert_eq!(count(&mut b, &zs, &us), 0, "manifold UKF dyn");
    let mut c = SqrtUkf::new(fixed, model(fixed), &f.x0, &p0(), set).expect("sqrt");
    assert_eq!(count(&mut c, &zs, &us), 0, "manifold square-root UKF fixed");
    for d in [
        EkfUpdate::Extended,
        EkfUpdate::Iterated {
            max_iterations: 3,
            tolerance: 0.0,
        },
    ] {
        let cd = CentralDiff::new(fixed, model(fixed));
        let mut e = Ekf::new(fixed, cd, &f.x0, &p0(), d).expect("ekf");
        assert_eq!(count(&mut e, &zs, &us), 0, "manifold EKF {d:?}");
    }
    let mut ukf = Ukf::new(fixed, model(fixed), &f.x0, &p0(), set).expect("ukf");
    let mut lag = FixedLag::new(6, 4)
        .and_then(|l| l.with_manifold(space()))
        .expect("lag");
    let mut before = 0;
    for k in 0..20 {
        if k == 1 {
            before = allocations();
        }
        ukf.step(&zs[k], Some(&us[k])).expect("ukf step");
        lag.record(&ukf).expect("record");
    }
    assert_eq!(allocations() - before, 0, "manifold fixed-lag steps");
}
