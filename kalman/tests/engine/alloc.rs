//! Zero heap allocations per step, for each covariance form and both storage paths, with a
//! counting global allocator (`common/counting.rs`).

use crate::FORMS;
use kalman::strategies::{FilterProblem, ProblemOptions};
use kalman::{CovarianceForm, Dims, DynDims, Filter, FixedDims};

use crate::common::counting::allocations;

/// Allocations during all steps of `p` after the first (construction and the first step
/// are outside the count).
fn count<D: Dims>(p: &FilterProblem, dims: D, form: CovarianceForm) -> usize {
    let model = p.model(dims).expect("model");
    let mut f = Filter::new(model, &p.x0, &p.p0, form).expect("filter");
    let _ = f.step(&p.z[0], Some(&p.u[0]));
    let before = allocations();
    for (z, u) in p.z.iter().zip(&p.u).skip(1) {
        let info = f.step(z, Some(u));
        assert!(info.is_ok());
    }
    // An all-missing (predict-only) step too.
    let nan = [f64::NAN; 16];
    let _ = f.step(&nan[..p.m()], Some(&p.u[0]));
    allocations() - before
}

#[test]
fn no_allocation_per_step() {
    for form in FORMS {
        for (correlated, exact_channel) in [(false, false), (true, true)] {
            let opts = ProblemOptions {
                steps: 10,
                correlated,
                exact_channel,
                missing: 0.2,
                p: 1,
            };
            // Small model: fixed path and dynamic path with the crate's own loops.
            let small = FilterProblem::generate(7, 2, opts, 11);
            assert_eq!(
                count(&small, FixedDims::<7, 2, 1>::new(), form),
                0,
                "{form:?} fixed"
            );
            assert_eq!(
                count(&small, DynDims::new(7, 2, 1).expect("dims"), form),
                0,
                "{form:?} dyn"
            );
            // Larger model: products go through faer's GEMM.
            let big = FilterProblem::generate(24, 6, opts, 12);
            assert_eq!(
                count(&big, DynDims::new(24, 6, 1).expect("dims"), form),
                0,
                "{form:?} dyn faer"
            );
        }
    }
}
