//! On a linear model the EKF, the iterated EKF and the UKF (Merwe and cubature) reproduce
//! the linear filter, and the extended and unscented RTS smoothers the linear RTS smoother,
//! on both storage paths (missing entries and a control input included).

use faer::MatRef;
use kalman::nonlinear::{Ekf, EkfUpdate, NlDims, NonlinearRts, SigmaPoints, SqrtUkf, Ukf};
use kalman::smoother::RtsSmoother;
use kalman::strategies::{FilterProblem, ProblemOptions};
use kalman::{CovarianceForm, DynDims, Filter, FixedDims};

use super::models::Linear;

/// Round-off bound: every quantity is a few dozen n³ products away from the linear
/// filter's, whose entries are O(scale); 1e-12 of the scale is ~4500 ulps.
const TOL: f64 = 1e-12;

fn close(a: &[f64], b: &[f64], what: &str) {
    let scale = b.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= TOL * scale,
            "{what}[{i}]: {x} vs {y} (scale {scale})"
        );
    }
}

fn flat(m: MatRef<'_, f64>) -> Vec<f64> {
    let mut v = Vec::new();
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            v.push(m[(i, j)]);
        }
    }
    v
}

/// The linear filter's NIS as a number (0 on a predict-only step) whether the engine
/// reports it as `f64` or as `Option<f64>`.
trait NisValue {
    fn value(self) -> f64;
}

impl NisValue for f64 {
    fn value(self) -> f64 {
        self
    }
}

impl NisValue for Option<f64> {
    fn value(self) -> f64 {
        self.unwrap_or(0.0)
    }
}

fn problem(n: usize, m: usize, seed: u64) -> FilterProblem {
    let opts = ProblemOptions {
        steps: 40,
        correlated: false,
        exact_channel: false,
        missing: 0.15,
        p: 1,
    };
    FilterProblem::generate(n, m, opts, seed)
}

enum Which {
    Ekf(EkfUpdate),
    Ukf(SigmaPoints),
    Sqrt(SigmaPoints),
}

fn check<D: NlDims>(p: &FilterProblem, dims: D, which: &Which) {
    let model = p.model(dims).expect("model");
    let mut lin =
        Filter::new(model, &p.system.x0, &p.system.p0, CovarianceForm::Joseph).expect("filter");
    let mut lin_s = RtsSmoother::new();
    let mut nl_s = NonlinearRts::new();
    let nl = Linear::new(p);
    let (mut ekf, mut ukf, mut sqrt) = (None, None, None);
    match which {
        Which::Ekf(u) => {
            ekf = Some(Ekf::new(dims, nl, &p.system.x0, &p.system.p0, *u).expect("ekf"))
        }
        Which::Ukf(s) => {
            ukf = Some(Ukf::new(dims, nl, &p.system.x0, &p.system.p0, *s).expect("ukf"))
        }
        Which::Sqrt(s) => {
            sqrt = Some(SqrtUkf::new(dims, nl, &p.system.x0, &p.system.p0, *s).expect("sqrt"))
        }
    }
    for (k, (z, u)) in p.z.iter().zip(&p.u).enumerate() {
        let a = lin.step(z, Some(u)).expect("linear step");
        let (b, xf, pf, xp, pp) = if let Some(f) = ekf.as_mut() {
            let b = f.step(z, Some(u)).expect("ekf step");
            nl_s.record(f).expect("record");
            (
                b,
                f.state().to_vec(),
                flat(f.covariance()),
                f.predicted_state().to_vec(),
                flat(f.predicted_covariance()),
            )
        } else if let Some(f) = sqrt.as_mut() {
            let b = f.step(z, Some(u)).expect("square-root ukf step");
            nl_s.record(f).expect("record");
            (
                b,
                f.state().to_vec(),
                flat(f.covariance()),
                f.predicted_state().to_vec(),
                flat(f.predicted_covariance()),
            )
        } else {
            let f = ukf.as_mut().expect("ukf");
            let b = f.step(z, Some(u)).expect("ukf step");
            nl_s.record(f).expect("record");
            (
                b,
                f.state().to_vec(),
                flat(f.covariance()),
                f.predicted_state().to_vec(),
                flat(f.predicted_covariance()),
            )
        };
        lin_s.record(&lin).expect("record");
        close(&xf, lin.state(), &format!("x_{{{k}|{k}}}"));
        close(&pf, &flat(lin.covariance()), &format!("P_{{{k}|{k}}}"));
        close(&xp, lin.predicted_state(), &format!("x_{{{k}+1|{k}}}"));
        close(
            &pp,
            &flat(lin.predicted_covariance()),
            &format!("P_{{{k}+1|{k}}}"),
        );
        assert_eq!(b.observed, a.observed);
        if a.observed > 0 {
            let (nis, lin) = (b.nis.expect("nis"), a.nis.value());
            assert!(
                (nis - lin).abs() <= TOL * lin.max(1.0),
                "nis {nis} vs {lin}"
            );
            assert!(
                (b.log_likelihood - a.log_likelihood).abs()
                    <= TOL * a.log_likelihood.abs().max(1.0)
            );
        } else {
            assert!(b.nis.is_none());
        }
    }
    let (ls, ns) = (
        lin_s.smooth().expect("linear smooth"),
        nl_s.smooth().expect("nonlinear smooth"),
    );
    for k in 0..p.z.len() {
        let a: Vec<f64> = (0..p.system.n()).map(|i| ls.means[(i, k)]).collect();
        let b: Vec<f64> = (0..p.system.n()).map(|i| ns.means[(i, k)]).collect();
        // The backward pass divides by P_{k+1|k}: allow 10× the forward tolerance.
        let scale = a.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
        for i in 0..p.system.n() {
            assert!(
                (a[i] - b[i]).abs() <= 10.0 * TOL * scale,
                "smoothed x[{i}] step {k}"
            );
        }
        let (pa, pb) = (
            flat(ls.covariances[k].as_ref()),
            flat(ns.covariances[k].as_ref()),
        );
        let scale = pa.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
        for (x, y) in pa.iter().zip(&pb) {
            assert!((x - y).abs() <= 10.0 * TOL * scale, "smoothed P step {k}");
        }
    }
}

fn all(n: usize) -> Vec<Which> {
    vec![
        Which::Ekf(EkfUpdate::Extended),
        Which::Ekf(EkfUpdate::Iterated {
            max_iterations: 5,
            tolerance: 1e-10,
        }),
        // α = 0.5, κ = 3 − n: W_0 is negative (−8 at n = 7) yet the centred means keep the
        // error at round-off. (α = 1e-3 makes |W_0| ≈ 1e6: the covariance sums then lose
        // six digits, which is the scaled transform's cost, not a filter error.)
        Which::Ukf(SigmaPoints::merwe(0.5, 2.0, 3.0 - n as f64)),
        Which::Ukf(SigmaPoints::merwe(1.0, 2.0, 0.0)),
        Which::Ukf(SigmaPoints::Cubature),
        Which::Ukf(SigmaPoints::julier(1.0)),
        Which::Ukf(SigmaPoints::Simplex),
        // The square-root form: a negative centre weight (downdates), none, and the simplex.
        Which::Sqrt(SigmaPoints::merwe(0.5, 2.0, 3.0 - n as f64)),
        Which::Sqrt(SigmaPoints::Cubature),
        Which::Sqrt(SigmaPoints::Simplex),
    ]
}

#[test]
fn nonlinear_filters_reproduce_the_linear_filter_fixed() {
    let p = problem(7, 2, 31);
    for w in all(7) {
        check(&p, FixedDims::<7, 2, 1>::new(), &w);
    }
}

#[test]
fn nonlinear_filters_reproduce_the_linear_filter_dyn() {
    for (n, m, seed) in [(3, 3, 32), (10, 4, 33), (1, 1, 34)] {
        let p = problem(n, m, seed);
        for w in all(n) {
            check(&p, DynDims::new(n, m, 1).expect("dims"), &w);
        }
    }
}

#[test]
fn iterated_ekf_needs_two_linearisations_on_a_linear_model() {
    // The second Gauss–Newton step of a linear problem is zero: converged at iteration 2.
    let p = problem(4, 2, 35);
    let mut f = Ekf::new(
        DynDims::new(4, 2, 1).expect("dims"),
        Linear::new(&p),
        &p.system.x0,
        &p.system.p0,
        EkfUpdate::Iterated {
            max_iterations: 10,
            tolerance: 1e-9,
        },
    )
    .expect("iekf");
    for (z, u) in p.z.iter().zip(&p.u) {
        let info = f.step(z, Some(u)).expect("step");
        if info.observed > 0 {
            assert_eq!(info.iterations, 2);
        } else {
            assert_eq!(info.iterations, 0);
        }
    }
}
