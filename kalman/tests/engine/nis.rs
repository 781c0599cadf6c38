//! Consistency: the NIS of a consistent filter lies in its 95 % χ² band, and the
//! log-likelihood is the Gaussian density of the innovation.

use crate::FORMS;
use kalman::strategies::{FilterProblem, ProblemOptions};
use kalman::{CovarianceForm, DynDims, Filter, FixedDims, chi2_quantile};

#[test]
fn nis_of_a_consistent_filter_is_in_the_95_percent_band() {
    let steps = 2000;
    let opts = ProblemOptions {
        steps,
        correlated: true,
        missing: 0.1,
        ..ProblemOptions::default()
    };
    let p = FilterProblem::generate(4, 3, opts, 5);
    for form in FORMS {
        let mut f = Filter::new(
            p.model(FixedDims::<4, 3, 0>::new()).expect("model"),
            &p.system.x0,
            &p.system.p0,
            form,
        )
        .expect("filter");
        let (mut sum, mut dof, mut inside, mut used) = (0.0, 0usize, 0usize, 0usize);
        for z in &p.z {
            let info = f.step(z, None).expect("step");
            // A step without a measurement has no NIS and no degrees of freedom.
            assert_eq!(info.nis.is_none(), info.observed == 0);
            dof += info.rank;
            if let Some(nis) = info.nis.filter(|_| info.rank > 0) {
                sum += nis;
                used += 1;
                let lo = chi2_quantile(0.025, info.rank);
                let hi = chi2_quantile(0.975, info.rank);
                if nis >= lo && nis <= hi {
                    inside += 1;
                }
            }
        }
        // Innovations of a consistent filter are independent, so the summed NIS is χ² with
        // Σ rank degrees of freedom: it must lie in that distribution's 95 % band.
        let (lo, hi) = (chi2_quantile(0.025, dof), chi2_quantile(0.975, dof));
        assert!(
            sum >= lo && sum <= hi,
            "{form:?}: ΣNIS {sum} not in [{lo}, {hi}] (dof {dof})"
        );
        // Per step, 95 % of the NIS values fall in their own 95 % band (binomial standard
        // deviation over ~2000 steps is 0.5 %; allow 3 of them).
        let frac = inside as f64 / used as f64;
        assert!(
            (frac - 0.95).abs() < 0.015,
            "{form:?}: {frac} of steps inside the band"
        );
    }
}

#[test]
fn log_likelihood_is_the_gaussian_density_of_the_innovation() {
    let p = FilterProblem::generate(3, 2, ProblemOptions::default(), 9);
    let mut f = Filter::new(
        p.model(DynDims::new(3, 2, 0).expect("dims"))
            .expect("model"),
        &p.system.x0,
        &p.system.p0,
        CovarianceForm::Joseph,
    )
    .expect("filter");
    for z in &p.z {
        let info = f.step(z, None).expect("step");
        let s = f.innovation_covariance();
        let e = f.innovation();
        let det = s[(0, 0)] * s[(1, 1)] - s[(0, 1)] * s[(1, 0)];
        let q = (s[(1, 1)] * e[0] * e[0] - 2.0 * s[(0, 1)] * e[0] * e[1] + s[(0, 0)] * e[1] * e[1])
            / det;
        let ll = -0.5 * (q + det.ln() + 2.0 * (2.0 * std::f64::consts::PI).ln());
        // 1e-10: closed-form 2×2 inverse of a well-conditioned Σ.
        let nis = info.nis.expect("a measured step has a NIS");
        assert!((nis - q).abs() < 1e-10 * q.max(1.0));
        assert!((info.log_likelihood - ll).abs() < 1e-10 * ll.abs().max(1.0));
    }
}

#[test]
fn singular_innovation_covariance_takes_the_rank_revealing_path() {
    // Two identical exact channels: Σ has rank 1. The update must stay finite, symmetric,
    // PSD, and report rank 1 with one degree of freedom, in any unit (Q and P0 scaled by c,
    // the data by √c: the rank decision is relative to Σ's scale).
    use kalman::Model;
    let F = [[1.0, 0.1], [0.0, 1.0]];
    let H = [[1.0, 0.0], [1.0, 0.0]];
    let R = [[0.0, 0.0], [0.0, 0.0]];
    for c in [1.0_f64, 1e-12, 1e12] {
        let s = c.sqrt();
        let Q = [[1e-4 * c, 0.0], [0.0, 1e-3 * c]];
        for form in FORMS {
            let model =
                Model::new(DynDims::new(2, 2, 0).expect("dims"), &F, &H, &Q, &R).expect("model");
            let P0 = [[c, 0.0], [0.0, c]];
            let mut f = Filter::new(model, &[0.0, 0.0], &P0, form).expect("filter");
            for k in 0..50 {
                let z = 0.1 * k as f64 * s;
                let info = f.step(&[z, z], None).expect("step");
                assert_eq!(info.rank, 1, "{form:?} c {c:e} step {k}");
                assert_eq!(info.observed, 2);
                let P = f.covariance();
                // The exactly measured position has zero filtered variance (to round-off of
                // the prior's scale, ~c).
                assert!(P[(0, 0)].abs() < 1e-12 * c, "{form:?}: P00 {}", P[(0, 0)]);
                assert!(
                    (f.state()[0] - z).abs() < 1e-9 * s,
                    "{form:?}: x0 {} vs {z}",
                    f.state()[0]
                );
                let ev = P.self_adjoint_eigenvalues(faer::Side::Lower).expect("evd");
                assert!(ev[0] >= -1e-12 * c && P[(0, 1)].is_finite());
                assert!((P[(0, 1)] - P[(1, 0)]).abs() <= 0.0);
            }
            // Velocity is learned from the exact positions: 0.1·√c per 0.1 s step = √c.
            assert!(
                (f.state()[1] - s).abs() < 1e-6 * s,
                "{form:?} c {c:e}: v {}",
                f.state()[1]
            );
        }
    }
}

/// A channel that is an exact multiple of another (z₂ = g z₁, noise included: R = r·[[1, g],
/// [g, g²]]) carries no information of its own, so the filter must give the estimates, NIS
/// and rank of the one-channel filter. Σ is singular with unequal diagonal entries, so the
/// dense forms' eigen-decomposition has to rotate by a non-trivial angle: by about 63° for
/// g = 2, and by almost exactly 45° for g = 1.001 (a twin sensor whose gain differs by 0.1 %:
/// two channels of almost equal variance and correlation 1).
#[test]
fn an_exactly_dependent_channel_adds_nothing() {
    use kalman::Model;
    let F = [[0.95, 0.1], [-0.1, 0.9]];
    let Q = [[0.02, 0.0], [0.0, 0.05]];
    let r = 0.3;
    let dims2 = DynDims::new(2, 2, 0).expect("dims");
    let dims1 = DynDims::new(2, 1, 0).expect("dims");
    let P0 = [[2.0, 0.3], [0.3, 1.0]];
    for (g, form) in [2.0, 1.001].into_iter().flat_map(|g| FORMS.map(|f| (g, f))) {
        let H2 = [[1.0, 0.5], [g, 0.5 * g]];
        let R2 = [[r, g * r], [g * r, g * g * r]];
        let two = Model::new(dims2, &F, &H2, &Q, &R2).expect("model");
        let one = Model::new(dims1, &F, &[[1.0, 0.5]], &Q, &[[r]]).expect("model");
        let mut f2 = Filter::new(two, &[0.5, -0.5], &P0, form).expect("filter");
        let mut f1 = Filter::new(one, &[0.5, -0.5], &P0, form).expect("filter");
        for k in 0..30 {
            let z = (0.4 * k as f64).sin();
            let i2 = f2.step(&[z, g * z], None).expect("step");
            let i1 = f1.step(&[z], None).expect("step");
            assert_eq!(i2.rank, 1, "{form:?} g {g} step {k}");
            // Tolerance: both are O(1) computations of the same numbers; the two-channel
            // one adds a rank cut (the dropped eigenvalue is round-off, ~1e-16 of the kept
            // one) and the rotation that finds it.
            let close = |a: f64, b: f64| (a - b).abs() < 1e-10 * b.abs().max(1.0);
            let (nis2, nis1) = (i2.nis.expect("nis"), i1.nis.expect("nis"));
            assert!(
                close(nis2, nis1),
                "{form:?} g {g} step {k}: NIS {nis2} vs {nis1}"
            );
            // The log-likelihood is that of the density on Σ's range (log pdet Σ): the data
            // (z, g z) lie on the line along (1, g)/√(1 + g²), where their coordinate is
            // √(1 + g²)·z, so the density there is z's divided by √(1 + g²).
            let dl = i2.log_likelihood - i1.log_likelihood;
            assert!(
                close(dl, -0.5 * (1.0 + g * g).ln()),
                "{form:?} g {g} step {k}: log-likelihoods {} vs {}",
                i2.log_likelihood,
                i1.log_likelihood
            );
            let (P2, P1) = (f2.covariance(), f1.covariance());
            for i in 0..2 {
                assert!(
                    close(f2.state()[i], f1.state()[i]),
                    "{form:?} g {g} step {k}: x"
                );
                for j in 0..2 {
                    assert!(close(P2[(i, j)], P1[(i, j)]), "{form:?} g {g} step {k}: P");
                }
            }
        }
    }
}

/// Runs `steps` steps of a two-state filter whose Q, R and P0 are `c` times the given ones,
/// on the data `√c·z_k`; returns each step's (rank, NIS, log-likelihood).
fn scaled_run(
    form: CovarianceForm,
    H: &[[f64; 2]; 2],
    R: &[[f64; 2]; 2],
    c: f64,
    data: impl Fn(usize) -> [f64; 2],
    steps: usize,
) -> Vec<(usize, f64, f64)> {
    let F = [[0.95, 0.1], [-0.1, 0.9]];
    let scale = |a: [[f64; 2]; 2]| a.map(|row| row.map(|v| v * c));
    let (Q, R, P0) = (
        scale([[0.02, 0.0], [0.0, 0.05]]),
        scale(*R),
        scale([[2.0, 0.3], [0.3, 1.0]]),
    );
    let dims = DynDims::new(2, 2, 0).expect("dims");
    let model = kalman::Model::new(dims, &F, H, &Q, &R).expect("model");
    let mut f = Filter::new(model, &[0.0, 0.0], &P0, form).expect("filter");
    (0..steps)
        .map(|k| {
            let z = data(k).map(|v| v * c.sqrt());
            let info = f.step(&z, None).expect("step");
            (info.rank, info.nis.expect("nis"), info.log_likelihood)
        })
        .collect()
}

/// The rank test is relative to Σ's scale: a second channel that repeats the first (times
/// −0.3) up to an independent part of relative variance ~1e-8 — four orders above
/// `RANK_TOL` = 1e-12 — is kept (rank 2) whether Q, R and P0 are in units scaled by 1e-12, 1
/// or 1e12, and its NIS does not depend on the unit.
#[test]
fn a_nearly_dependent_channel_is_kept_in_any_unit() {
    let (r, k) = (0.3, -0.3);
    let H = [[1.0, 0.5], [k, 0.5 * k]];
    let R = [[r, k * r], [k * r, (k * k + 1e-8) * r]];
    let data = |j: usize| {
        let z = (0.4 * j as f64).sin();
        [z, k * z + 1e-4 * (1.3 * j as f64).cos()]
    };
    for form in FORMS {
        let unit = scaled_run(form, &H, &R, 1.0, data, 30);
        for c in [1e-12, 1.0, 1e12] {
            for (j, (&(rank, nis, _), &(_, nis1, _))) in scaled_run(form, &H, &R, c, data, 30)
                .iter()
                .zip(&unit)
                .enumerate()
            {
                assert_eq!(rank, 2, "{form:?} c {c:e} step {j}");
                // Σ's condition number is ~1e9: the same numbers in another unit agree to
                // about 1e9·ε.
                assert!(
                    (nis - nis1).abs() < 1e-5 * nis1.max(1.0),
                    "{form:?} c {c:e} step {j}: NIS {nis} vs {nis1}"
                );
            }
        }
    }
}

/// In units where Π L_ii = (det Σ)^{1/2} leaves f64's normal range (c = 1e±240 with three
/// channels: det Σ ~ c³), the log-likelihood is still the unit-1 one shifted by the Jacobian
/// of the change of unit, −½·m·ln c per step, and NIS and rank are unchanged.
#[test]
fn the_log_likelihood_survives_units_where_det_sigma_overflows() {
    use kalman::Model;
    let F = [[0.9, 0.2, 0.0], [0.0, 0.8, 0.1], [0.1, 0.0, 0.7]];
    let H = [[1.0, 0.2, 0.0], [0.3, 1.0, -0.4], [0.0, 0.5, 1.0]];
    let dims = DynDims::new(3, 3, 0).expect("dims");
    let run = |form: CovarianceForm, c: f64| -> Vec<(usize, f64, f64)> {
        let diag = |a: [f64; 3]| {
            let mut m = [[0.0; 3]; 3];
            for i in 0..3 {
                m[i][i] = a[i] * c;
            }
            m
        };
        let model = Model::new(
            dims,
            &F,
            &H,
            &diag([0.1, 0.2, 0.05]),
            &diag([0.5, 0.3, 0.4]),
        )
        .expect("model");
        let mut f = Filter::new(model, &[0.0; 3], &diag([1.0, 2.0, 0.5]), form).expect("filter");
        (0..20)
            .map(|k| {
                let t = k as f64;
                let z = [t.sin(), (0.7 * t).cos(), 0.1 * t].map(|v| v * c.sqrt());
                let info = f.step(&z, None).expect("step");
                (info.rank, info.nis.expect("nis"), info.log_likelihood)
            })
            .collect()
    };
    for form in FORMS {
        let unit = run(form, 1.0);
        for c in [1e-240_f64, 1e240] {
            let shift = -1.5 * c.ln();
            for (k, (&(rank, nis, ll), &(rank1, nis1, ll1))) in
                run(form, c).iter().zip(&unit).enumerate()
            {
                assert_eq!(rank, rank1, "{form:?} c {c:e} step {k}");
                // The shift is ±829; rounding in it and in the three logarithms of pivots
                // ~1e120 is ~1e-13. NIS: the same O(1) numbers in another unit.
                assert!(
                    (ll - shift - ll1).abs() < 1e-9,
                    "{form:?} c {c:e} step {k}: {ll} − ({shift}) vs {ll1}"
                );
                assert!(
                    (nis - nis1).abs() < 1e-9 * nis1.max(1.0),
                    "{form:?} step {k}"
                );
            }
        }
    }
}

/// Rows of the base model's H (two states): the first two are those of a two-channel model,
/// the others extend it for the tests with more independent channels (K ≤ 9 below).
const H_BASE: [[f64; 2]; 9] = [
    [1.0, 0.5],
    [-0.2, 1.0],
    [0.3, -0.7],
    [0.8, 0.1],
    [-0.5, -0.4],
    [0.2, 0.9],
    [0.6, -0.3],
    [-0.9, 0.2],
    [0.4, 0.4],
];

/// Entry (i, j) of the base model's R: the two-channel model's block, then a diagonal of
/// 0.2–0.36 with 0.01 off it (diagonally dominant, so positive definite).
fn r_base(i: usize, j: usize) -> f64 {
    match (i, j) {
        (0, 0) => 0.3,
        (1, 1) => 0.2,
        (0, 1) | (1, 0) => 0.05,
        _ if i == j => 0.2 + 0.02 * i as f64,
        _ => 0.01,
    }
}

/// Channels `J z` that repeat K independent ones `z` through fixed combinations (J's first
/// rows the identity) leave rank, NIS and estimates those of the K-channel filter; the data
/// lie on the K-plane `z ↦ J z`, whose volume element is `√det(JᵀJ)`, so the log-likelihood
/// (the density on Σ's range) is the K-channel one minus `½ ln det(JᵀJ)`.
fn dependent_channels_cost_the_jacobian<const K: usize, const M: usize>(J: [[f64; K]; M], tol: f64)
where
    [[f64; 2]; M]: kalman::MatrixInput,
    [[f64; M]; M]: kalman::MatrixInput,
    [[f64; 2]; K]: kalman::MatrixInput,
    [[f64; K]; K]: kalman::MatrixInput,
{
    use kalman::Model;
    let F = [[0.95, 0.1], [-0.1, 0.9]];
    let Q = [[0.02, 0.0], [0.0, 0.05]];
    let P0 = [[2.0, 0.3], [0.3, 1.0]];
    let Hb: [[f64; 2]; K] = core::array::from_fn(|i| H_BASE[i]);
    let Rb: [[f64; K]; K] = core::array::from_fn(|i| core::array::from_fn(|j| r_base(i, j)));
    // H = J H_b, R = J R_b Jᵀ (the base model's H_b, R_b), by their sums.
    let H: [[f64; 2]; M] = J.map(|u| [0, 1].map(|c| (0..K).map(|i| u[i] * Hb[i][c]).sum()));
    let JR: [[f64; K]; M] =
        J.map(|u| core::array::from_fn(|c| (0..K).map(|i| u[i] * Rb[i][c]).sum()));
    let R: [[f64; M]; M] = JR.map(|u| J.map(|v| (0..K).map(|i| u[i] * v[i]).sum()));
    // det(JᵀJ) of the K×K Gram matrix (an LU determinant: JᵀJ is well conditioned here).
    let gram = faer::Mat::from_fn(K, K, |i, k| J.iter().map(|u| u[i] * u[k]).sum::<f64>());
    let jac = -0.5 * gram.determinant().ln();
    for form in FORMS {
        let dims = |m| DynDims::new(2, m, 0).expect("dims");
        let many = Model::new(dims(M), &F, &H, &Q, &R).expect("model");
        let base = Model::new(dims(K), &F, &Hb, &Q, &Rb).expect("model");
        let mut fm = Filter::new(many, &[0.5, -0.5], &P0, form).expect("filter");
        let mut fk = Filter::new(base, &[0.5, -0.5], &P0, form).expect("filter");
        for k in 0..30 {
            let t = k as f64;
            let z: [f64; K] = core::array::from_fn(|i| match i {
                0 => (0.4 * t).sin(),
                1 => (0.9 * t).cos(),
                _ => ((0.3 + 0.2 * i as f64) * t + i as f64).sin(),
            });
            let zm = J.map(|u| (0..K).map(|i| u[i] * z[i]).sum::<f64>());
            let (im, ik) = (
                fm.step(&zm, None).expect("step"),
                fk.step(&z, None).expect("step"),
            );
            assert_eq!(im.rank, K, "{form:?} M {M} step {k}");
            let close = |x: f64, y: f64| (x - y).abs() < tol * y.abs().max(1.0);
            let (nm, nk) = (im.nis.expect("nis"), ik.nis.expect("nis"));
            assert!(close(nm, nk), "{form:?} M {M} step {k}: NIS {nm} vs {nk}");
            let dl = im.log_likelihood - ik.log_likelihood;
            assert!(close(dl, jac), "{form:?} M {M} step {k}: {dl} vs {jac}");
            for i in 0..2 {
                assert!(
                    close(fm.state()[i], fk.state()[i]),
                    "{form:?} M {M} step {k}"
                );
            }
        }
    }
}

/// Tolerance of O(1) computations of the same numbers, one with rank cuts.
const DEPENDENT_TOL: f64 = 1e-10;

#[test]
fn a_channel_combining_two_others_costs_only_the_jacobian() {
    dependent_channels_cost_the_jacobian([[1.0, 0.0], [0.0, 1.0], [0.7, -1.3]], DEPENDENT_TOL);
}

/// Nine independent channels and one combining them all. In the square-root form the
/// dependent row's `W = C L₁⁻¹` is a back substitution through the pivot rows of the
/// pre-array; with nine channels on two states that array is only m + 2n = 14 columns wide,
/// so an entry read from a wrong place (the end of the row before) is no longer one of the
/// zeros right of a pivot, as it is with a few channels.
#[test]
fn a_channel_combining_nine_others_costs_only_the_jacobian() {
    let mut J = [[0.0; 9]; 10];
    for (i, row) in J.iter_mut().take(9).enumerate() {
        row[i] = 1.0;
    }
    J[9] = [0.7, -1.3, 0.4, 0.9, -0.6, 0.3, -0.8, 0.5, 1.1];
    dependent_channels_cost_the_jacobian(J, DEPENDENT_TOL);
}

#[test]
fn two_dependent_channels_cost_the_jacobian_of_their_plane() {
    dependent_channels_cost_the_jacobian(
        [[1.0, 0.0], [0.0, 1.0], [0.7, -1.3], [-0.4, 0.9]],
        DEPENDENT_TOL,
    );
}

/// Two dependent channels over three kept pivots. In the square-root form each dependent
/// row's `W = C L₁⁻¹` fills its own block of r entries of the scratch; with two pivots (the
/// test above) a block with a wrong end, such as `w[q·r .. q + 1 + r]`, still has room for
/// the r entries it is given, with three pivots it does not.
#[test]
fn two_channels_combining_three_others_cost_the_jacobian_of_their_plane() {
    dependent_channels_cost_the_jacobian(
        [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.7, -1.3, 0.4],
            [-0.4, 0.9, 1.1],
        ],
        DEPENDENT_TOL,
    );
}

/// The rank test is relative to the largest variance among the channels, not to the first
/// channel's: with the first channel in units 10⁴ times smaller than a dependent pair (and
/// their covariance ~10⁴ times the first's variance), the pair's round-off pivot (~ε of its
/// variance, ~1e-8) is far above `RANK_TOL` times the first channel's variance or the
/// covariance but below `RANK_TOL` times the pair's, and is cut.
#[test]
fn the_rank_test_scales_with_the_largest_channel_not_the_first() {
    // Tolerance: Σ's condition number grows by the 10⁸ ratio of the variances, and so may
    // the round-off of the filter that cuts the dependent pair (ε·10⁸ ≈ 1e-8).
    dependent_channels_cost_the_jacobian([[1.0, 0.0], [0.0, 1e4], [0.0, 7e3]], 1e-8);
}
