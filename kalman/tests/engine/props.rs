//! Property tests on random consistent problems (n 1..=12, m 1..=6): the three covariance
//! forms agree, P stays symmetric PSD, and the fixed-size and dynamic paths agree.

use kalman::strategies::{FilterProblem, ProblemOptions, problem};
use kalman::{CovarianceForm, Dims, DynDims, Filter, FixedDims};
use proptest::prelude::*;

/// Per-step (x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k}) of a run, flattened.
fn run<D: Dims>(p: &FilterProblem, dims: D, form: CovarianceForm) -> Vec<Vec<f64>> {
    let model = p.model(dims).expect("model");
    let mut f = Filter::new(model, &p.system.x0, &p.system.p0, form).expect("filter");
    let mut out = Vec::new();
    for (z, u) in p.z.iter().zip(&p.u) {
        f.step(z, Some(u)).expect("step");
        let mut v = f.state().to_vec();
        let n = p.system.n();
        for (P, x) in [
            (f.covariance(), None),
            (f.predicted_covariance(), Some(f.predicted_state())),
        ] {
            for j in 0..n {
                for i in 0..n {
                    v.push(P[(i, j)]);
                }
            }
            if let Some(x) = x {
                v.extend_from_slice(x);
            }
        }
        out.push(v);
    }
    out
}

/// Worst |a − b| / max(1, max|b|) per step vector.
fn worst(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    a.iter().zip(b).fold(0.0_f64, |w, (x, y)| {
        let scale = y.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
        let d = x
            .iter()
            .zip(y)
            .fold(0.0_f64, |s, (p, q)| s.max((p - q).abs()));
        w.max(d / scale)
    })
}

/// `f` symmetric and PSD up to round-off relative to `scale` (the trace of the prior
/// covariance of the step, which bounds P in PSD order; with an exact channel the filtered
/// P is ~0 in some direction and only the round-off of the update remains there).
fn check_sym_psd(f: faer::MatRef<'_, f64>, scale: f64) -> Result<(), TestCaseError> {
    let n = f.nrows();
    let mut tr = 0.0;
    for i in 0..n {
        tr += f[(i, i)];
        for j in 0..n {
            // Both paths mirror one computed triangle: symmetry is exact.
            prop_assert!((f[(i, j)] - f[(j, i)]).abs() <= 0.0);
        }
    }
    let ev = f.self_adjoint_eigenvalues(faer::Side::Lower).expect("evd");
    // Round-off of a PSD matrix: eigenvalues ≥ −1e-12·scale (≈ 1e4 ulps).
    let scale = scale.max(tr);
    prop_assert!(ev[0] >= -1e-12 * scale, "min eig {} scale {scale}", ev[0]);
    Ok(())
}

/// The sizes at which the fixed-size path is compared with the dynamic one.
const FIXED_N: [usize; 6] = [1, 2, 3, 5, 8, 12];
const FIXED_M: [usize; 4] = [1, 2, 3, 6];

/// Dispatches a runtime (n, m) to `FixedDims<N, M, 1>`.
macro_rules! fixed_run {
    ($p:expr, $form:expr, $n:expr, $m:expr; [$($N:literal)*]; $ms:tt) => {{
        let mut out: Option<Vec<Vec<f64>>> = None;
        $( if $n == $N { fixed_run!(@m out, $p, $form, $m, $N, $ms); } )*
        out.expect("n, m among the fixed sizes")
    }};
    (@m $out:ident, $p:expr, $form:expr, $m:expr, $N:literal, [$($M:literal)*]) => {
        $( if $m == $M { $out = Some(run($p, FixedDims::<$N, $M, 1>::new(), $form)); } )*
    };
}

fn opts(correlated: bool, exact: bool, missing: f64) -> ProblemOptions {
    ProblemOptions {
        steps: 12,
        correlated,
        exact_channel: exact,
        missing,
        p: 1,
    }
}

proptest! {
    #[test]
    fn forms_agree_and_paths_agree(
        p in prop_oneof![
            problem(1..=12, 1..=6, opts(false, false, 0.0)),
            problem(1..=12, 1..=6, opts(true, false, 0.2)),
            problem(1..=12, 1..=6, opts(true, true, 0.0)),
        ]
    ) {
        let (n, m) = (p.system.n(), p.system.m());
        let dims = DynDims::new(n, m, 1).expect("dims");
        let joseph = run(&p, dims, CovarianceForm::Joseph);
        // 1e-9 relative between forms: the same quantities through different arithmetic
        // (O(n³) operations, 12 steps) on problems with moderate conditioning.
        for form in [CovarianceForm::Standard, CovarianceForm::SquareRoot] {
            let other = run(&p, dims, form);
            let w = worst(&other, &joseph);
            prop_assert!(w < 1e-9, "{form:?} vs Joseph: {w:e} (n={n}, m={m})");
        }
        // 1e-12 between storage paths: identical kernels; only the order of the
        // multiply-adds differs where the dynamic path hands a product to faer. The fixed
        // path is instantiated at representative sizes only (n = 1, 2, 3, 5, 8, 12 and
        // m = 1, 2, 3, 6: one state, one channel, m = n, m > n, m < n, the largest drawn),
        // since each (N, M) is a whole monomorphised filter in this test binary.
        if FIXED_N.contains(&n) && FIXED_M.contains(&m) {
            for form in [CovarianceForm::Joseph, CovarianceForm::Standard, CovarianceForm::SquareRoot] {
                let d = run(&p, dims, form);
                let f = fixed_run!(&p, form, n, m; [1 2 3 5 8 12]; [1 2 3 6]);
                let w = worst(&f, &d);
                prop_assert!(w < 1e-12, "{form:?} fixed vs dyn: {w:e} (n={n}, m={m})");
            }
        }
        for form in [CovarianceForm::Joseph, CovarianceForm::Standard, CovarianceForm::SquareRoot] {
            let model = p.model(dims).expect("model");
            let mut f = Filter::new(model, &p.system.x0, &p.system.p0, form).expect("filter");
            for (z, u) in p.z.iter().zip(&p.u) {
                let prior = f.predicted_covariance();
                let scale: f64 = (0..p.system.n()).map(|i| prior[(i, i)]).sum();
                f.step(z, Some(u)).expect("step");
                check_sym_psd(f.covariance(), scale)?;
                check_sym_psd(f.predicted_covariance(), 0.0)?;
            }
        }
    }
}
