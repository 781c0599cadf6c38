//! GainSchedule: reproduces the full filter's estimates to 1e-12 on the same data (with
//! missing values and with cross-covariance, on both storage paths), the fixed-gain mode,
//! and zero allocations per scheduled step.

use faer::Mat;
use kalman::riccati::Dare;
use kalman::schedule::{GainSchedule, ScheduleOptions};
use kalman::{CovarianceForm, Dims, DynDims, Filter, FixedDims, Model};
use rand::RngExt;

use super::common::{joint_noise, randn, rng, spd, with_radius};
use crate::common::counting::allocations;

struct Problem {
    F: Mat<f64>,
    H: Mat<f64>,
    Q: Mat<f64>,
    R: Mat<f64>,
    S: Mat<f64>,
    B: Mat<f64>,
    P0: Mat<f64>,
    x0: Vec<f64>,
    zs: Vec<Vec<f64>>,
    us: Vec<Vec<f64>>,
}

fn problem(seed: u64, n: usize, m: usize, steps: usize, missing: bool) -> Problem {
    let mut g = rng(seed);
    let F = with_radius(&mut g, n, 0.97);
    let H = randn(&mut g, m, n);
    let (Q, R, S) = joint_noise(&mut g, n, m);
    let B = randn(&mut g, n, 1);
    let P0 = spd(&mut g, n, 1.0);
    let x0 = (0..n).map(|_| g.random_range(-1.0..1.0)).collect();
    let zs = (0..steps)
        .map(|k| {
            (0..m)
                .map(|i| {
                    // Missing: one channel at steps 40 and 41, everything at step 90.
                    if missing && ((k == 40 || k == 41) && i == 0 || k == 90) {
                        f64::NAN
                    } else {
                        g.random_range(-3.0..3.0)
                    }
                })
                .collect()
        })
        .collect();
    let us = (0..steps)
        .map(|_| vec![g.random_range(-1.0..1.0)])
        .collect();
    Problem {
        F,
        H,
        Q,
        R,
        S,
        B,
        P0,
        x0,
        zs,
        us,
    }
}

fn model<D: Dims>(dims: D, p: &Problem, cross: bool) -> Model<D> {
    let m = Model::new(dims, &p.F, &p.H, &p.Q, &p.R)
        .expect("model")
        .with_control(&p.B)
        .expect("B");
    if cross {
        m.with_cross_covariance(&p.S).expect("S")
    } else {
        m
    }
}

/// Max over steps of |x_sched − x_full| / max(1, |x_full|), for x_{k|k}, x_{k+1|k} and e_k.
fn compare<D: Dims>(dims: D, p: &Problem, cross: bool) -> (f64, usize) {
    let sched = GainSchedule::new(model(dims, p, cross), &p.P0, ScheduleOptions::default())
        .expect("schedule");
    let mut run = sched.runner(&p.x0).expect("runner");
    let mut full =
        Filter::new(model(dims, p, cross), &p.x0, &p.P0, CovarianceForm::Joseph).expect("filter");
    let mut worst = 0.0_f64;
    for (z, u) in p.zs.iter().zip(&p.us) {
        run.step(z, Some(u)).expect("scheduled step");
        full.step(z, Some(u)).expect("full step");
        assert_eq!(
            run.innovation().len(),
            full.innovation().len(),
            "innovation length"
        );
        for (a, b) in run
            .state()
            .iter()
            .zip(full.state())
            .chain(run.predicted_state().iter().zip(full.predicted_state()))
            .chain(run.innovation().iter().zip(full.innovation()))
        {
            worst = worst.max((a - b).abs() / b.abs().max(1.0));
        }
    }
    (worst, sched.len())
}

#[test]
fn reproduces_the_full_filter() {
    for (seed, cross, missing) in [
        (1, false, false),
        (2, true, false),
        (3, false, true),
        (4, true, true),
    ] {
        let p = problem(seed, 7, 2, 300, missing);
        let (d, len) = compare(DynDims::new(7, 2, 1).expect("dims"), &p, cross);
        // Tolerance 1e-12 (the issue's): the schedule's gains are the engine's own, bit for
        // bit, during the transient; the steady gain is the fixed point to 1e-14 relative.
        assert!(d < 1e-12, "dyn seed {seed}: {d:e}");
        assert!(len > 1 && len < 300, "schedule length {len}");
        let (d, _) = compare(FixedDims::<7, 2, 1>::new(), &p, cross);
        assert!(d < 1e-12, "fixed seed {seed}: {d:e}");
    }
}

/// Two channels measuring the same state with fully correlated noise (R = 0.5·11ᵀ) make
/// Σ = H P Hᵀ + R singular at every step, so the cross gain S Σ⁺ comes from the
/// eigen-decomposition: the schedule still reproduces the full filter (whose own fallback
/// is the engine's Jacobi pseudo-inverse, an independent route to the same S Σ⁺ e). With
/// δ of independent noise added to the second channel, Σ's Cholesky succeeds but its last
/// pivot (≈ δ) lies below `RANK_TOL`·max Σ_ii: both must still treat the channels as
/// dependent — an inverse through that pivot would multiply the channels' √δ-sized
/// disagreement by 1/δ and leave the full filter's estimates far behind. The case with R
/// scaled by c = 200 puts the pivot δ = 10⁻¹² between `RANK_TOL`/max Σ_ii and
/// `RANK_TOL`·max Σ_ii, so the threshold must scale with Σ, not against it.
#[test]
fn reproduces_the_full_filter_with_a_singular_innovation_covariance() {
    for (c, delta) in [(1.0, 0.0), (1.0, 1e-13), (200.0, 1e-12)] {
        let dims = DynDims::new(2, 2, 0).expect("dims");
        let F = faer::mat![[0.9, 0.1], [0.0, 0.8]];
        let H = faer::mat![[1.0, 0.0], [1.0, 0.0]];
        let Q = faer::mat![[0.2, 0.0], [0.0, 0.1]];
        let R = faer::mat![[0.5 * c, 0.5 * c], [0.5 * c, 0.5 * c + delta]];
        // Joint covariance [[R, Sᵀ], [S, Q]] PSD: minimising over u₁ + u₂ leaves
        // 0.18 w₁² − 0.02 w₁w₂ + 0.095 w₂² > 0 (c ≥ 1 and δ ≥ 0 only add to R).
        let S = faer::mat![[0.1, 0.1], [0.05, 0.05]];
        let model = || {
            Model::new(dims, &F, &H, &Q, &R)
                .and_then(|m| m.with_cross_covariance(&S))
                .expect("model")
        };
        let P0 = Mat::<f64>::identity(2, 2);
        let sched = GainSchedule::new(model(), &P0, ScheduleOptions::default()).expect("schedule");
        let x0 = [0.3, -0.2];
        let mut run = sched.runner(&x0).expect("runner");
        let mut full = Filter::new(model(), &x0, &P0, CovarianceForm::Joseph).expect("filter");
        let mut g = rng(10);
        for _ in 0..60 {
            // The channels read the same value up to the second one's √δ of own noise.
            let z1: f64 = g.random_range(-3.0..3.0);
            let z2 = z1 + delta.sqrt() * g.random_range(-1.0..1.0);
            run.step(&[z1, z2], None).expect("scheduled step");
            full.step(&[z1, z2], None).expect("full step");
            // Tolerance: the two pseudo-inverses differ by rounding of O(1) numbers (Σ's
            // nonzero eigenvalue is about 2); 1e-10 leaves room for their accumulation.
            for (a, b) in run.predicted_state().iter().zip(full.predicted_state()) {
                assert!(
                    (a - b).abs() < 1e-10 * b.abs().max(1.0),
                    "δ = {delta}: {a} vs {b}"
                );
            }
        }
    }
}

#[test]
fn fixed_gain_mode_matches_a_filter_started_at_steady_state() {
    let p = problem(5, 4, 2, 200, false);
    let dims = DynDims::new(4, 2, 1).expect("dims");
    let ss = Dare::new(&p.F, &p.H, &p.Q, &p.R)
        .and_then(|p| p.solve())
        .expect("DARE");
    let sched = GainSchedule::fixed_gain(model(dims, &p, false), &ss).expect("fixed gain");
    // The one steady gain: a schedule is never empty.
    assert_eq!(sched.len(), 1);
    assert!(!sched.is_empty());
    let mut run = sched.runner(&p.x0).expect("runner");
    let mut full = Filter::new(
        model(dims, &p, false),
        &p.x0,
        &ss.prior,
        CovarianceForm::Joseph,
    )
    .expect("filter");
    for (z, u) in p.zs.iter().zip(&p.us) {
        run.step(z, Some(u)).expect("step");
        full.step(z, Some(u)).expect("step");
        // Tolerance: the filter started at P∞ stays there to rounding (DARE residual 1e-10
        // relative bounds its drift; the gains agree to ~1e-12).
        for (a, b) in run.state().iter().zip(full.state()) {
            assert!((a - b).abs() < 1e-9 * b.abs().max(1.0));
        }
    }
}

fn steady_allocations<D: Dims>(dims: D) -> usize {
    let p = problem(6, 7, 2, 1000, false);
    let sched = GainSchedule::new(model(dims, &p, true), &p.P0, ScheduleOptions::default())
        .expect("schedule");
    let mut run = sched.runner(&p.x0).expect("runner");
    run.step(&p.zs[0], Some(&p.us[0])).expect("step");
    let before = allocations();
    for (z, u) in p.zs.iter().zip(&p.us).skip(1) {
        let r = run.step(z, Some(u));
        assert!(r.is_ok());
    }
    // A new stream through the same runner.
    let r = run.reset(&p.x0);
    assert!(r.is_ok());
    for (z, u) in p.zs.iter().zip(&p.us).take(100) {
        let r = run.step(z, Some(u));
        assert!(r.is_ok());
    }
    allocations() - before
}

#[test]
fn no_allocation_per_scheduled_step() {
    assert_eq!(steady_allocations(DynDims::new(7, 2, 1).expect("dims")), 0);
    assert_eq!(steady_allocations(FixedDims::<7, 2, 1>::new()), 0);
}

#[test]
fn bad_inputs_are_typed_errors() {
    let p = problem(7, 3, 2, 10, false);
    let sched = GainSchedule::new(
        model(DynDims::new(3, 2, 1).expect("dims"), &p, false),
        &p.P0,
        ScheduleOptions::default(),
    )
    .expect("schedule");
    let mut run = sched.runner(&p.x0).expect("runner");
    assert!(matches!(
        run.step(&[1.0], None),
        Err(kalman::Error::Shape { name: "z", .. })
    ));
    assert!(matches!(
        run.step(&[1.0, f64::INFINITY], None),
        Err(kalman::Error::NonFinite { name: "z", .. })
    ));
    assert!(matches!(
        run.reset(&[0.0]),
        Err(kalman::Error::Shape { name: "x0", .. })
    ));
    // An undetectable model never settles: a typed error, not a hang.
    let F = faer::mat![[1.5, 0.0], [0.0, 0.5]];
    let H = faer::mat![[0.0, 1.0]];
    let I = Mat::<f64>::identity(2, 2);
    let m = Model::new(
        DynDims::new(2, 1, 0).expect("dims"),
        &F,
        &H,
        &I,
        &faer::mat![[1.0]],
    )
    .expect("model");
    let opts = ScheduleOptions {
        max_steps: 500,
        ..ScheduleOptions::default()
    };
    assert!(matches!(
        GainSchedule::new(m, &I, opts),
        Err(kalman::Error::RiccatiNoConvergence { .. })
    ));
}

/// `SteadyState::of` on an engine model equals `Dare` on its matrices, on both paths, and the
/// schedule's steady prior equals it.
#[test]
fn steady_state_of_model_matches_schedule() {
    let p = problem(8, 7, 2, 10, false);
    let dyn_ss =
        kalman::riccati::SteadyState::of(&model(DynDims::new(7, 2, 1).expect("dims"), &p, true))
            .expect("dyn");
    let fix_ss = kalman::riccati::SteadyState::of(&model(FixedDims::<7, 2, 1>::new(), &p, true))
        .expect("fixed");
    assert!((&dyn_ss.prior - &fix_ss.prior).norm_l2() <= 1e-14 * dyn_ss.prior.norm_l2());
    let sched = GainSchedule::new(
        model(DynDims::new(7, 2, 1).expect("dims"), &p, true),
        &p.P0,
        ScheduleOptions::default(),
    )
    .expect("schedule");
    let d = (sched.steady_prior().to_owned() - &dyn_ss.prior).norm_l2() / dyn_ss.prior.norm_l2();
    // Tolerance: the schedule stops at a relative change of 1e-14 (times 1/(1 − ρ_cl)).
    assert!(d < 1e-10, "{d:e}");
    let k = (sched.gain(usize::MAX).to_owned() - &dyn_ss.gain).norm_l2() / dyn_ss.gain.norm_l2();
    assert!(k < 1e-10, "{k:e}");
}

/// Entering the missing-value fallback restarts the engine filter (`Filter::reset`
/// validates P and may allocate); the full steps after that allocate nothing, and neither
/// do scheduled steps after re-entry.
#[test]
fn fallback_allocates_only_on_entry() {
    let p = problem(9, 7, 2, 400, true);
    for fixed in [false, true] {
        let counts = if fixed {
            fallback_counts(FixedDims::<7, 2, 1>::new(), &p)
        } else {
            fallback_counts(DynDims::new(7, 2, 1).expect("dims"), &p)
        };
        let (before_entry, after_entry, back_on_schedule) = counts;
        assert_eq!(before_entry, 0, "fixed {fixed}");
        assert_eq!(after_entry, 0, "fixed {fixed}");
        assert!(
            back_on_schedule,
            "fixed {fixed}: the runner never returned to the schedule"
        );
    }
}

/// (allocations in steps 1..40, allocations in steps 41..end, back on schedule at the end).
fn fallback_counts<D: Dims>(dims: D, p: &Problem) -> (usize, usize, bool) {
    let sched = GainSchedule::new(model(dims, p, false), &p.P0, ScheduleOptions::default())
        .expect("schedule");
    let mut run = sched.runner(&p.x0).expect("runner");
    run.step(&p.zs[0], Some(&p.us[0])).expect("step");
    let a0 = allocations();
    for k in 1..40 {
        run.step(&p.zs[k], Some(&p.us[k])).expect("step");
    }
    let a1 = allocations();
    // Step 40 has a missing entry: enters the fallback (may allocate).
    run.step(&p.zs[40], Some(&p.us[40])).expect("step");
    assert!(!run.on_schedule());
    let a2 = allocations();
    for k in 41..p.zs.len() {
        run.step(&p.zs[k], Some(&p.us[k])).expect("step");
    }
    let a3 = allocations();
    (a1 - a0, a3 - a2, run.on_schedule())
}

/// One measurement missing anywhere — inside the transient, at the last scheduled gain, just
/// after it — makes that step the full filter's (restarted from the scheduled prior of that
/// step, or the steady one past the schedule), so the stream equals the full filter at every
/// step; the runner counts the steps it took, also after jumping back onto the schedule,
/// and the schedule's length and the return to it are the same in any unit (Q, R, P0 scaled
/// by 1e6, the data by 1e3). Tolerance as `reproduces_the_full_filter`.
#[test]
fn a_missing_measurement_anywhere_is_the_full_filters_step() {
    let base = problem(3, 4, 2, 160, false);
    let len = GainSchedule::new(
        model(DynDims::new(4, 2, 1).expect("dims"), &base, false),
        &base.P0,
        ScheduleOptions::default(),
    )
    .expect("schedule")
    .len();
    assert!(len > 4 && len + 60 < 160, "{len}");
    for miss_at in [2, len - 1, len, len + 1] {
        let mut back_after = Vec::new();
        for scale in [1.0, 1e6] {
            let mut p = problem(3, 4, 2, 160, false);
            p.zs[miss_at][1] = f64::NAN;
            for M in [&mut p.Q, &mut p.R, &mut p.P0] {
                *M *= faer::Scale(scale);
            }
            let s = scale.sqrt();
            p.zs.iter_mut().flatten().for_each(|z| *z *= s);
            p.us.iter_mut().flatten().for_each(|u| *u *= s);
            p.x0.iter_mut().for_each(|x| *x *= s);
            let dims = DynDims::new(4, 2, 1).expect("dims");
            let sched =
                GainSchedule::new(model(dims, &p, false), &p.P0, ScheduleOptions::default())
                    .expect("schedule");
            // Its convergence test is relative: the same length in any unit.
            assert_eq!(sched.len(), len, "scale {scale:e}");
            let mut run = sched.runner(&p.x0).expect("runner");
            let mut full =
                Filter::new(model(dims, &p, false), &p.x0, &p.P0, CovarianceForm::Joseph)
                    .expect("filter");
            let mut back = None;
            for (k, (z, u)) in p.zs.iter().zip(&p.us).enumerate() {
                run.step(z, Some(u)).expect("scheduled step");
                full.step(z, Some(u)).expect("full step");
                assert_eq!(run.steps(), k + 1, "missing at {miss_at}");
                assert_eq!((run.state().len(), run.predicted_state().len()), (4, 4));
                let states = run.state().iter().zip(full.state());
                for (a, b) in states.chain(run.predicted_state().iter().zip(full.predicted_state()))
                {
                    assert!(
                        (a - b).abs() <= 1e-9 * b.abs().max(s),
                        "missing at {miss_at}, step {k}"
                    );
                }
                if k >= miss_at && back.is_none() && run.on_schedule() {
                    back = Some(k - miss_at);
                }
            }
            back_after.push(back.expect("back on the schedule"));
        }
        assert_eq!(
            back_after[0], back_after[1],
            "missing at {miss_at}: re-entry depends on the unit"
        );
    }
}

/// A deterministic model (Q = R = S = 0) from an exact prior (P0 = 0) has Σ = 0 at every
/// step: the cross gain S Σ⁺ must be the zero matrix (Σ⁺ = 0), not 0·∞, so the schedule is
/// built and the stream is the noise-free path x_{k+1} = F x_k + B u_k.
#[test]
fn a_zero_innovation_covariance_gives_zero_gains() {
    let dims = DynDims::new(2, 1, 1).expect("dims");
    let F = faer::mat![[1.0, 0.1], [0.0, 1.0]];
    let zero2 = Mat::<f64>::zeros(2, 2);
    let model = Model::new(
        dims,
        &F,
        &faer::mat![[1.0, 0.0]],
        &zero2,
        &Mat::<f64>::zeros(1, 1),
    )
    .and_then(|m| m.with_control(&faer::mat![[0.0], [1.0]]))
    .and_then(|m| m.with_cross_covariance(&Mat::<f64>::zeros(2, 1)))
    .expect("model");
    let sched = GainSchedule::new(model, &zero2, ScheduleOptions::default())
        .expect("a zero Σ is a valid (deterministic) case");
    let mut run = sched.runner(&[1.0, 0.5]).expect("runner");
    let mut x = [1.0, 0.5];
    for k in 0..5 {
        run.step(&[(k as f64).cos()], Some(&[0.2])).expect("step");
        x = [x[0] + 0.1 * x[1], x[1] + 0.2];
        for i in 0..2 {
            // A few additions of numbers ≤ 2: 1e-15.
            assert!(
                (run.predicted_state()[i] - x[i]).abs() <= 1e-15,
                "step {k}, x[{i}]"
            );
        }
    }
}

/// A steady state solved for another model is refused by the fixed-gain schedule, naming the
/// gain, when either of its dimensions differs (here only the measurement count).
#[test]
fn a_fixed_gain_of_the_wrong_shape_is_named() {
    let p = problem(5, 4, 2, 10, false);
    let ss = Dare::new(&p.F, &p.H, &p.Q, &p.R)
        .and_then(|p| p.solve())
        .expect("DARE");
    let one_channel = Model::new(
        DynDims::new(4, 1, 0).expect("dims"),
        &p.F,
        &p.H.subrows(0, 1),
        &p.Q,
        &p.R.submatrix(0, 0, 1, 1),
    )
    .expect("model");
    let e = GainSchedule::fixed_gain(one_channel, &ss).expect_err("a 4×2 gain for one channel");
    assert!(
        matches!(
            e,
            kalman::Error::Shape {
                name: "K",
                expected_rows: 4,
                expected_cols: 1,
                ..
            }
        ),
        "{e:?}"
    );
}

/// The fallback returns to the schedule at the first step after which the full filter's
/// P_{k+1|k} is within `reentry_tolerance`·max|P∞| of P∞ entrywise, as documented. The model
/// is diagonal, so P∞ has zero off-diagonal entries and its largest entry is the first
/// variance: a scale taken from the wrong entries would be 0 or the smaller variance. The
/// criterion is evaluated here on an independent full filter from P0; it agrees with the
/// runner's restarted one to rounding, so the test first checks that no step lies within 10 %
/// of the threshold, where rounding could decide.
#[test]
fn the_fallback_returns_at_the_first_step_within_the_reentry_tolerance() {
    let dims = DynDims::new(2, 2, 0).expect("dims");
    let model = || {
        Model::new(
            dims,
            &faer::mat![[0.95, 0.0], [0.0, 0.5]],
            &faer::mat![[1.0, 0.0], [0.0, 1.0]],
            &faer::mat![[1.0, 0.0], [0.0, 0.01]],
            &faer::mat![[1.0, 0.0], [0.0, 1.0]],
        )
        .expect("model")
    };
    let P0 = Mat::<f64>::identity(2, 2);
    let tol = 1e-6;
    let opts = ScheduleOptions {
        reentry_tolerance: tol,
        ..ScheduleOptions::default()
    };
    let sched = GainSchedule::new(model(), &P0, opts).expect("schedule");
    let miss_at = sched.len() + 5;
    let Ps = sched.steady_prior().to_owned();
    let big = Ps[(0, 0)].abs().max(Ps[(1, 1)].abs());
    assert!(
        Ps[(0, 0)] > 10.0 * Ps[(1, 1)],
        "the first variance dominates"
    );
    let mut run = sched.runner(&[0.0, 0.0]).expect("runner");
    let mut full = Filter::new(model(), &[0.0, 0.0], &P0, CovarianceForm::Joseph).expect("filter");
    let (mut expected, mut back) = (None, None);
    for k in 0..miss_at + 200 {
        let z = if k == miss_at {
            [0.3, f64::NAN]
        } else {
            [0.3, -0.2]
        };
        run.step(&z, None).expect("scheduled step");
        full.step(&z, None).expect("full step");
        if k < miss_at {
            continue;
        }
        let Pp = full.predicted_covariance();
        let mut diff = 0.0_f64;
        for j in 0..2 {
            for i in 0..2 {
                diff = diff.max((Pp[(i, j)] - Ps[(i, j)]).abs());
            }
        }
        let ratio = diff / (tol * big);
        assert!(
            (ratio - 1.0).abs() > 0.1,
            "step {k}: ratio {ratio} too close to call"
        );
        if expected.is_none() && ratio <= 1.0 {
            expected = Some(k);
        }
        if back.is_none() && run.on_schedule() {
            back = Some(k);
        }
    }
    let expected = expected.expect("the full filter settles within 200 steps");
    assert!(expected > miss_at, "the missing step must perturb P");
    assert_eq!(back, Some(expected));
}
