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
    let mut f = Filter::new(model, &p.system.x0, &p.system.p0, form).expect("filter");
    let _ = f.step(&p.z[0], Some(&p.u[0]));
    let before = allocations();
    for (z, u) in p.z.iter().zip(&p.u).skip(1) {
        let info = f.step(z, Some(u));
        assert!(info.is_ok());
    }
    // An all-missing (predict-only) step too.
    let nan = [f64::NAN; 16];
    let _ = f.step(&nan[..p.system.m()], Some(&p.u[0]));
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

/// A time-stamped record through `kalman::sampling` and `kalman::gate`: once the cache is
/// full, neither a cache hit, nor a miss that resamples the oldest entry in place, nor a
/// gate's screen allocates, in any covariance form.
#[test]
fn a_sampled_record_with_a_gate_allocates_nothing_once_the_cache_is_full() {
    use kalman::gate::{Gate, GateRule};
    use kalman::sampling::{ContinuousModel, Sampler};
    let cv = ContinuousModel::new(
        &[[0.0, 1.0], [0.0, -0.1]],
        &[[1.0, 0.0], [0.0, 1.0]],
        &[[0.0, 0.0], [0.0, 0.5]],
        &[[4.0, 0.0], [0.0, 0.04]],
    )
    .and_then(|m| m.with_control(&[[0.0], [1.0]]))
    .expect("model");
    for form in FORMS {
        let mut sampler = Sampler::new(cv.clone(), 4).expect("sampler");
        let mut kf = Filter::new(
            sampler.at(0.1).expect("sampled").clone(),
            &[0.0, 1.0],
            &[[10.0, 0.0], [0.0, 10.0]],
            form,
        )
        .expect("filter");
        let mut gate = Gate::new(GateRule::Entries, 0.999, kf.model()).expect("gate");
        let mut vector = Gate::new(GateRule::Vector, 0.999, kf.model()).expect("gate");
        // Fill the cache (these allocate: each new slot is a model).
        for dt in [0.1, 0.2, 0.3, 0.4] {
            sampler.at(dt).expect("sampled");
        }
        let before = allocations();
        for k in 0..200 {
            // Repeating intervals (hits) and new ones (misses that evict).
            let dt = if k % 3 == 0 {
                0.05 + 1e-3 * k as f64
            } else {
                0.1
            };
            let z = [k as f64 * 0.1, if k == 50 { 1e6 } else { 1.0 }];
            let model = sampler.at(dt).expect("sampled");
            vector.screen(&kf, model, &z).expect("screened");
            gate.screen(&kf, model, &z).expect("screened");
            kf.step_with(model, gate.kept(), Some(&[0.01]))
                .expect("step");
        }
        assert_eq!(allocations() - before, 0, "{form:?}");
        assert!(sampler.distinct() > 60);
    }
}
