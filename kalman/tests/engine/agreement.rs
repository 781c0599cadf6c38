//! Agreement: the engine (every form, both storage paths) against the reference filter and
//! against itself.

use crate::FORMS;
use kalman::strategies::{FilterProblem, ProblemOptions};
use kalman::{CovarianceForm, Dims, DynDims, Filter, FixedDims};

use super::reference;

/// Largest |a − b| relative to max(1, max|b|) over the entries.
fn rel_vec(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0_f64, |s, (x, y)| s.max((x - y).abs()))
        / scale
}

fn rel_mat(a: faer::MatRef<'_, f64>, b: &reference::M) -> f64 {
    let mut scale = 1.0_f64;
    let mut worst = 0.0_f64;
    for (i, row) in b.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            scale = scale.max(v.abs());
            worst = worst.max((a[(i, j)] - v).abs());
        }
    }
    worst / scale
}

/// [`rel_mat`] over the entries whose row and column are observed in `z` (what the
/// innovation covariance holds in the others is a convention of each form).
fn rel_observed(a: faer::MatRef<'_, f64>, b: &reference::M, z: &[f64]) -> f64 {
    let keep = |i: usize, j: usize| !z[i].is_nan() && !z[j].is_nan();
    let mut scale = 1.0_f64;
    let mut worst = 0.0_f64;
    for (i, row) in b.iter().enumerate() {
        for (j, v) in row.iter().enumerate().filter(|&(j, _)| keep(i, j)) {
            scale = scale.max(v.abs());
            worst = worst.max((a[(i, j)] - v).abs());
        }
    }
    worst / scale
}

/// Runs the engine on `p` and returns the worst relative deviation from the reference in
/// x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k}, NIS, the innovation, the gain and (over the
/// observed entries) the innovation covariance over all steps.
pub fn deviation<D: Dims>(p: &FilterProblem, dims: D, form: CovarianceForm) -> f64 {
    let model = p.model(dims).expect("valid model");
    let mut f = Filter::new(model, &p.system.x0, &p.system.p0, form).expect("valid prior");
    let reference = reference::run(p);
    let mut worst = 0.0_f64;
    for ((z, u), r) in p.z.iter().zip(&p.u).zip(&reference) {
        let info = f.step(z, Some(u)).expect("step");
        worst = worst
            .max(rel_vec(f.state(), &r.xf))
            .max(rel_mat(f.covariance(), &r.pf))
            .max(rel_vec(f.predicted_state(), &r.xp))
            .max(rel_mat(f.predicted_covariance(), &r.pp))
            .max(rel_vec(f.innovation(), &r.e))
            .max(rel_mat(f.gain(), &r.gain))
            .max(rel_observed(f.innovation_covariance(), &r.sig, z))
            .max(match (info.nis, r.nis) {
                (Some(a), Some(b)) => (a - b).abs() / b.max(1.0),
                (None, None) => 0.0,
                // One says "no measurement", the other does not: as wrong as it gets.
                _ => f64::INFINITY,
            });
    }
    worst
}

#[test]
fn dyn_matches_reference_on_seeded_models() {
    // 1e-10 relative: the problems are well conditioned (P0, Q, R ≥ 0.1-ish spread, F
    // contractive), 20 steps of O(n³) arithmetic lose a few hundred ulps at most.
    for seed in 0..6 {
        for (correlated, missing) in [(false, 0.0), (true, 0.0), (false, 0.3), (true, 0.3)] {
            let opts = ProblemOptions {
                correlated,
                missing,
                p: 2,
                ..ProblemOptions::default()
            };
            let p = FilterProblem::generate(3 + seed as usize, 1 + seed as usize % 3, opts, seed);
            for form in FORMS {
                let dev = deviation(
                    &p,
                    DynDims::new(p.system.n(), p.system.m(), 2).expect("dims"),
                    form,
                );
                assert!(
                    dev < 1e-10,
                    "seed {seed} {form:?} S={correlated} miss={missing}: {dev:e}"
                );
            }
        }
    }
}

#[test]
fn fixed_matches_reference() {
    for seed in 0..4 {
        let opts = ProblemOptions {
            correlated: seed % 2 == 1,
            missing: 0.2,
            p: 1,
            ..ProblemOptions::default()
        };
        let p = FilterProblem::generate(7, 2, opts, seed);
        for form in FORMS {
            let dev = deviation(&p, FixedDims::<7, 2, 1>::new(), form);
            assert!(dev < 1e-10, "seed {seed} {form:?}: {dev:e}");
        }
    }
}
