//! RTS smoother: smoothed means equal the batch least-squares solution of the whole
//! trajectory (and smoothed covariances the blocks of its inverse information matrix), on
//! both storage paths; smoothed covariance ≤ filtered.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side, mat};
use kalman::smoother::{RtsSmoother, Smoothed};
use kalman::{CovarianceForm, Dims, DynDims, Filter, FixedDims, Model};
use proptest::prelude::*;
use rand::RngExt;

use super::common::{min_eig, randn, rng, spd, with_radius};

/// A linear-Gaussian smoothing problem: the model, the prior of x_0 and the measurements
/// (NaN = missing).
struct Problem {
    F: Mat<f64>,
    H: Mat<f64>,
    Q: Mat<f64>,
    R: Mat<f64>,
    x0: Vec<f64>,
    P0: Mat<f64>,
    zs: Vec<Vec<f64>>,
}

/// The RTS smoother's output on `pr` with the filter on storage `dims`, and the filtered
/// covariances P_{k|k}.
fn smooth<D: Dims>(dims: D, pr: &Problem) -> (Smoothed, Vec<Mat<f64>>) {
    let model = Model::new(dims, &pr.F, &pr.H, &pr.Q, &pr.R).expect("model");
    let mut f = Filter::new(model, &pr.x0, &pr.P0, CovarianceForm::Joseph).expect("filter");
    let mut s = RtsSmoother::new();
    let mut filtered = Vec::new();
    for z in &pr.zs {
        f.step(z, None).expect("step");
        s.record(&f).expect("record");
        filtered.push(f.covariance().to_owned());
    }
    (s.smooth().expect("smooth"), filtered)
}

/// Batch least squares over x_0..x_{N−1}: prior, measurement and dynamics residuals weighted
/// by P0⁻¹, R⁻¹, Q⁻¹. Returns (solution n×N, inverse information blocks).
fn batch(pr: &Problem) -> (Mat<f64>, Vec<Mat<f64>>) {
    let Problem {
        F,
        H,
        Q,
        R,
        x0,
        P0,
        zs,
    } = pr;
    let (n, N) = (F.nrows(), zs.len());
    let inv = |A: &Mat<f64>| {
        A.llt(Side::Lower)
            .expect("pd")
            .solve(Mat::<f64>::identity(A.nrows(), A.nrows()))
    };
    let (Qi, P0i) = (inv(Q), inv(P0));
    let mut J = Mat::<f64>::zeros(n * N, n * N);
    let mut h = Mat::<f64>::zeros(n * N, 1);
    let add = |J: &mut Mat<f64>, r: usize, c: usize, B: &Mat<f64>| {
        for j in 0..n {
            for i in 0..n {
                J[(r * n + i, c * n + j)] += B[(i, j)];
            }
        }
    };
    add(&mut J, 0, 0, &P0i);
    let x0m = Mat::from_fn(n, 1, |i, _| x0[i]);
    let hp = &P0i * &x0m;
    for i in 0..n {
        h[(i, 0)] += hp[(i, 0)];
    }
    for (k, z) in zs.iter().enumerate() {
        // Observed rows only (NaN = missing).
        let rows: Vec<usize> = (0..z.len()).filter(|&i| !z[i].is_nan()).collect();
        if !rows.is_empty() {
            let Ho = Mat::from_fn(rows.len(), n, |i, j| H[(rows[i], j)]);
            let Ro = Mat::from_fn(rows.len(), rows.len(), |i, j| R[(rows[i], rows[j])]);
            let zo = Mat::from_fn(rows.len(), 1, |i, _| z[rows[i]]);
            let llt = Ro.llt(Side::Lower).expect("R pd");
            add(&mut J, k, k, &(Ho.transpose() * llt.solve(&Ho)));
            let hk = Ho.transpose() * llt.solve(&zo);
            for i in 0..n {
                h[(k * n + i, 0)] += hk[(i, 0)];
            }
        }
        if k + 1 < N {
            add(&mut J, k, k, &(F.transpose() * &Qi * F));
            add(&mut J, k + 1, k + 1, &Qi);
            add(&mut J, k, k + 1, &(-(F.transpose() * &Qi)));
            add(&mut J, k + 1, k, &(-(&Qi * F)));
        }
    }
    let llt = J.llt(Side::Lower).expect("information matrix pd");
    let x = llt.solve(&h);
    let Jinv = llt.solve(Mat::<f64>::identity(n * N, n * N));
    let means = Mat::from_fn(n, N, |i, k| x[(k * n + i, 0)]);
    let covs = (0..N)
        .map(|k| Jinv.as_ref().submatrix(k * n, k * n, n, n).to_owned())
        .collect();
    (means, covs)
}

/// A tracked 2-state model over 12 random measurements, the sixth missing.
fn gapped() -> Problem {
    let mut g = rng(11);
    let zs: Vec<Vec<f64>> = (0..12)
        .map(|k| {
            vec![if k == 5 {
                f64::NAN
            } else {
                g.random_range(-2.0..2.0)
            }]
        })
        .collect();
    Problem {
        F: mat![[1.0, 0.5], [0.0, 0.9]],
        H: mat![[1.0, 0.0]],
        Q: mat![[0.01, 0.002], [0.002, 0.05]],
        R: mat![[0.3]],
        x0: vec![0.5, -0.2],
        P0: mat![[2.0, 0.1], [0.1, 1.0]],
        zs,
    }
}

#[test]
fn smoothed_means_equal_batch_least_squares_on_both_paths() {
    let pr = gapped();
    let zs = &pr.zs;
    let (lsx, lsP) = batch(&pr);
    let (dyn_s, filtered) = smooth(DynDims::new(2, 1, 0).expect("dims"), &pr);
    let (fix_s, _) = smooth(FixedDims::<2, 1>::new(), &pr);
    // Tolerance: both sides are backward-stable solves of a well-conditioned (cond ~1e3)
    // problem with values O(1): 1e-10 leaves a wide margin over ~1e-13 round-off.
    for k in 0..zs.len() {
        for i in 0..2 {
            assert!(
                (dyn_s.means[(i, k)] - lsx[(i, k)]).abs() < 1e-10,
                "mean {k},{i}"
            );
            // The two storage paths run the same kernels: agree to 1e-12.
            assert!((dyn_s.means[(i, k)] - fix_s.means[(i, k)]).abs() < 1e-12);
            for j in 0..2 {
                assert!(
                    (dyn_s.covariances[k][(i, j)] - lsP[k][(i, j)]).abs() < 1e-10,
                    "cov {k},{i},{j}"
                );
                assert!(
                    (dyn_s.covariances[k][(i, j)] - fix_s.covariances[k][(i, j)]).abs() < 1e-12
                );
            }
        }
        // Smoothed ≤ filtered.
        let d = &filtered[k] - &dyn_s.covariances[k];
        assert!(min_eig(&d) >= -1e-12 * filtered[k].norm_l2());
    }
}

/// A random stable model (spectral radius `r`) with 20 random measurements, every seventh
/// entry missing when `gaps`.
fn random_problem(seed: u64, n: usize, m: usize, r: f64, gaps: bool) -> Problem {
    let mut g = rng(seed);
    let F = with_radius(&mut g, n, r);
    let H = randn(&mut g, m, n);
    let Q = spd(&mut g, n, 0.05);
    let R = spd(&mut g, m, 0.05);
    let P0 = spd(&mut g, n, 0.5);
    let zs: Vec<Vec<f64>> = (0..20)
        .map(|k| {
            (0..m)
                .map(|i| {
                    if gaps && (k + i) % 7 == 3 {
                        f64::NAN
                    } else {
                        g.random_range(-1.0..1.0)
                    }
                })
                .collect()
        })
        .collect();
    Problem {
        F,
        H,
        Q,
        R,
        x0: vec![0.0; n],
        P0,
        zs,
    }
}

proptest! {

    /// Random models: P_{k|k} − P_{k|N} is PSD (to round-off 1e-10·‖P_{k|k}‖) and the
    /// smoothed covariance is symmetric PSD.
    #[test]
    fn smoothed_covariance_below_filtered(seed in any::<u64>(), n in 1usize..=5, m in 1usize..=3, r in 0.3f64..1.2) {
        let pr = random_problem(seed, n, m, r, false);
        let (s, filtered) = smooth(DynDims::new(n, m, 0).expect("dims"), &pr);
        for k in 0..pr.zs.len() {
            let d = &filtered[k] - &s.covariances[k];
            prop_assert!(min_eig(&d) >= -1e-10 * filtered[k].norm_l2(), "step {k}");
            prop_assert!(min_eig(&s.covariances[k]) >= -1e-10 * filtered[k].norm_l2());
        }
    }
}

/// Cross-covariance S: the smoother's correlated-noise term (C_k = P_{k|k}Fᵀ − K_k Sᵀ) gives
/// the same smoothed trajectory as the classic RTS smoother on the equivalent decorrelated
/// model x_{k+1} = F̃ x_k + S R⁻¹ z_k + w̃_k (F̃ = F − S R⁻¹ H, Q̃ = Q − S R⁻¹ Sᵀ, the
/// measurement entering as a known input).
#[test]
fn correlated_noise_matches_the_decorrelated_model() {
    let mut g = rng(21);
    let (n, m) = (3, 2);
    let F = with_radius(&mut g, n, 0.9);
    let H = randn(&mut g, m, n);
    let (Q, R, S) = super::common::joint_noise(&mut g, n, m);
    let P0 = spd(&mut g, n, 0.5);
    let x0 = vec![0.1, -0.2, 0.3];
    let zs: Vec<Vec<f64>> = (0..15)
        .map(|_| (0..m).map(|_| g.random_range(-1.0..1.0)).collect())
        .collect();
    let llt = R.llt(Side::Lower).expect("R pd");
    let SRi = llt.solve(S.transpose()).transpose().to_owned();
    let Ft = &F - &SRi * &H;
    let Qt = super::common::sym(&Q - &SRi * S.transpose());

    let dims = DynDims::new(n, m, m).expect("dims");
    let a = Model::new(dims, &F, &H, &Q, &R)
        .expect("model")
        .with_cross_covariance(&S)
        .expect("S");
    let b = Model::new(dims, &Ft, &H, &Qt, &R)
        .expect("model")
        .with_control(&SRi)
        .expect("B");
    let (mut fa, mut fb) = (
        Filter::new(a, &x0, &P0, CovarianceForm::Joseph).expect("filter"),
        Filter::new(b, &x0, &P0, CovarianceForm::Joseph).expect("filter"),
    );
    let (mut sa, mut sb) = (RtsSmoother::new(), RtsSmoother::new());
    let zero = vec![0.0; m];
    for z in &zs {
        fa.step(z, Some(&zero)).expect("step");
        fb.step(z, Some(z)).expect("step");
        sa.record(&fa).expect("record");
        sb.record(&fb).expect("record");
    }
    let (sa, sb) = (sa.smooth().expect("smooth"), sb.smooth().expect("smooth"));
    // Tolerance: two algebraically equal recursions on O(1) data, 15 steps: ~1e-14 round-off.
    for k in 0..zs.len() {
        for i in 0..n {
            assert!(
                (sa.means[(i, k)] - sb.means[(i, k)]).abs() < 1e-10,
                "mean {k},{i}"
            );
            for j in 0..n {
                assert!((sa.covariances[k][(i, j)] - sb.covariances[k][(i, j)]).abs() < 1e-10);
            }
        }
    }
}

/// A deterministic model (Q = 0) from an exact prior (P0 = 0) has every covariance zero, so
/// the smoother's gain must be zero (the minimum-norm solve against the zero P_{k+1|k}), not
/// a division by it: the smoothed path is the filtered one, x_k = Fᵏ x0, with zero covariance.
#[test]
fn an_exact_prior_of_a_deterministic_model_is_smoothed_to_itself() {
    let F = mat![[1.0, 0.1], [0.0, 1.0]];
    let model = Model::new(
        DynDims::new(2, 1, 0).expect("dims"),
        &F,
        &mat![[1.0, 0.0]],
        &Mat::<f64>::zeros(2, 2),
        &mat![[1.0]],
    )
    .expect("model");
    let mut f = Filter::new(
        model,
        &[1.0, 0.5],
        &Mat::<f64>::zeros(2, 2),
        CovarianceForm::Joseph,
    )
    .expect("filter");
    let mut s = RtsSmoother::new();
    for k in 0..6 {
        f.step(&[(k as f64).sin()], None).expect("step");
        s.record(&f).expect("record");
    }
    let out = s
        .smooth()
        .expect("a zero covariance is smoothed, not divided by");
    for k in 0..6 {
        // x_k = (1 + 0.05 k, 0.5): sums of k terms of 0.05, exact to a few ε.
        let x = [1.0 + 0.05 * k as f64, 0.5];
        for i in 0..2 {
            assert!((out.means[(i, k)] - x[i]).abs() <= 1e-14, "x[{i}] at {k}");
            for j in 0..2 {
                assert!(out.covariances[k][(i, j)].abs() <= 0.0, "P[{i},{j}] at {k}");
            }
        }
    }
}

/// The backward pass of `pr` in square-root form, recorded from the same filter as
/// [`smooth`].
fn smooth_sqrt(pr: &Problem) -> kalman::smoother::SqrtSmoothed {
    let n = pr.F.nrows();
    let dims = DynDims::new(n, pr.H.nrows(), 0).expect("dims");
    let model = Model::new(dims, &pr.F, &pr.H, &pr.Q, &pr.R).expect("model");
    let mut f = Filter::new(model, &pr.x0, &pr.P0, CovarianceForm::Joseph).expect("filter");
    let mut s = RtsSmoother::new();
    for z in &pr.zs {
        f.step(z, None).expect("step");
        s.record(&f).expect("record");
    }
    s.smooth_sqrt().expect("square-root smooth")
}

/// The square-root backward pass gives the batch least-squares solution and its inverse
/// information blocks, as the covariance form does; its factors are lower triangular with a
/// nonnegative diagonal. Same problem and tolerance as
/// `smoothed_means_equal_batch_least_squares_on_both_paths`.
#[test]
fn the_square_root_pass_equals_batch_least_squares() {
    let pr = gapped();
    let (lsx, lsP) = batch(&pr);
    let s = smooth_sqrt(&pr);
    for k in 0..pr.zs.len() {
        let S = &s.factors[k];
        assert!(S[(0, 1)].abs() <= 0.0 && S[(0, 0)] >= 0.0 && S[(1, 1)] >= 0.0);
        let P = s.covariance(k).expect("a step");
        assert_eq!(
            P[(0, 1)].to_bits(),
            P[(1, 0)].to_bits(),
            "S Sᵀ exactly symmetric"
        );
        for i in 0..2 {
            assert!(
                (s.means[(i, k)] - lsx[(i, k)]).abs() < 1e-10,
                "mean {k},{i}"
            );
            for j in 0..2 {
                assert!(
                    (P[(i, j)] - lsP[k][(i, j)]).abs() < 1e-10,
                    "cov {k},{i},{j}"
                );
            }
        }
    }
    assert!(s.covariance(pr.zs.len()).is_none());
}

proptest! {
    /// Random models with gaps: the square-root pass equals the covariance form to
    /// round-off (1e-9 relative to ‖P_{k|k}‖: both are backward-stable passes over the same
    /// record, differing in the order of their operations only).
    #[test]
    fn the_square_root_pass_equals_the_covariance_form(seed in any::<u64>(), n in 1usize..=5, m in 1usize..=3, r in 0.3f64..1.2) {
        let pr = random_problem(seed, n, m, r, true);
        let (plain, filtered) = smooth(DynDims::new(n, m, 0).expect("dims"), &pr);
        let sq = smooth_sqrt(&pr);
        for k in 0..pr.zs.len() {
            let scale = filtered[k].norm_l2();
            let P = sq.covariance(k).expect("a step");
            prop_assert!((&P - &plain.covariances[k]).norm_l2() <= 1e-9 * scale, "P at {k}");
            let dx = (0..n).map(|i| (sq.means[(i, k)] - plain.means[(i, k)]).abs()).fold(0.0, f64::max);
            prop_assert!(dx <= 1e-9 * (1.0 + scale.sqrt()), "x at {k}");
        }
    }
}

/// An exact prior of a deterministic model: every joint covariance is zero, so every pivot
/// is a zero pivot; the square-root pass gives the filtered path with zero factors, as the
/// covariance form does (see `an_exact_prior_of_a_deterministic_model_is_smoothed_to_itself`).
#[test]
fn the_square_root_pass_takes_zero_pivots_for_an_exact_prior() {
    let pr = Problem {
        F: mat![[1.0, 0.1], [0.0, 1.0]],
        H: mat![[1.0, 0.0]],
        Q: Mat::<f64>::zeros(2, 2),
        R: mat![[1.0]],
        x0: vec![1.0, 0.5],
        P0: Mat::<f64>::zeros(2, 2),
        zs: (0..6).map(|k| vec![(k as f64).sin()]).collect(),
    };
    let s = smooth_sqrt(&pr);
    for k in 0..6 {
        let x = [1.0 + 0.05 * k as f64, 0.5];
        for i in 0..2 {
            assert!((s.means[(i, k)] - x[i]).abs() <= 1e-14, "x[{i}] at {k}");
            for j in 0..2 {
                assert!(s.factors[k][(i, j)].abs() <= 0.0, "S[{i},{j}] at {k}");
            }
        }
    }
    let empty = RtsSmoother::new()
        .smooth_sqrt()
        .expect_err("nothing recorded");
    assert!(
        matches!(empty, kalman::Error::Dimension { name: "steps", .. }),
        "{empty:?}"
    );
}
