//! Are the Cramér–Rao bounds honest? 95 % Wald intervals from the observed information
//! over repeated simulated records must cover the truth about 95 % of the time.

use kalman::fit::Series;

use super::common::{ar1, ar1_far_start, binomial_band, mle_from, rng, simulate_diag};

#[test]
fn wald_intervals_of_free_entries_cover_the_truth() {
    // AR(1) plus noise, φ, Q, R free as entries (a small model, so 240 fits take a few
    // seconds); 400 samples per record, where the estimates are close to normal.
    const RECORDS: usize = 240;
    let (phi, q, r) = (0.7, 1.0, 1.0);
    let truth = ar1(phi, q, r);
    let (start, map) = ar1_far_start();
    let want = [phi, q, r];
    let mut covered = [0usize; 3];
    let mut g = rng(2026);
    for run in 0..RECORDS {
        let z = simulate_diag(&truth, 400, &mut g);
        let data = Series::new(&z, 1).expect("series");
        let fit = mle_from(&map, &start, &data);
        assert!(fit.converged, "record {run}: {}", fit.message);
        let values = map.param_values(&fit.theta).expect("values");
        // A record whose information is singular gives no interval: it counts as a miss.
        let Some(cov) = fit.uncertainty.covariance.as_ref() else {
            continue;
        };
        let se = map.matrix_std_errors(&fit.theta, cov).expect("se").params;
        for i in 0..3 {
            if (values[i].1 - want[i]).abs() <= 1.959_964 * se[i].1 {
                covered[i] += 1;
            }
        }
    }
    // The acceptance band 88–99 %, and the 99.9 % band of Binomial(240, 0.95) (honest
    // intervals leave it with probability 0.1 %); both must hold.
    let (lo, hi) = binomial_band(RECORDS, 0.95);
    for (i, name) in ["F[0,0]", "Q[0,0]", "R[0,0]"].iter().enumerate() {
        let rate = covered[i] as f64 / RECORDS as f64;
        assert!(
            (0.88..=0.99).contains(&rate) && (lo..=hi).contains(&covered[i]),
            "{name}: {} of {RECORDS} intervals cover the truth ({rate:.3}; band {lo}–{hi})",
            covered[i]
        );
    }
}
