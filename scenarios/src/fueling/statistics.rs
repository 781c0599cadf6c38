//! The statistics a safety margin needs, from the per-run records: a confidence interval on
//! every random-error ratio (delta method over the runs), and each strategy's tail quantiles
//! and 3σ band of the fuelling error.
//!
//! **Ratio intervals (delta method).** A ratio r = s_a/s_b of two sample standard deviations
//! over the same n runs has log r = ½(log s_a² − log s_b²). To first order
//! log s_a² − log σ_a² ≈ mean(u_a) with u_a,i = (a_i − ā)²/s_a² − 1, so
//! Var(log r̂) ≈ Var(u_a − u_b)/(4n), with the variance of u_a − u_b estimated from the runs
//! themselves (no normality assumed: heavy tails and the correlation between the two
//! strategies, which share every run's world, are both in it). The 95 % interval is
//! r̂·exp(±1.96·SE(log r̂)), which stays positive. Everything here is a function of the
//! records alone, so a merge of shards gives the same numbers as one run.
//!
//! **Sweep ranges (bootstrap).** How much a strategy's random error moves over a sweep (the
//! range max − min of its per-point standard deviations) and the ratio of two such ranges are
//! not smooth functions of the runs, so their intervals come from a percentile bootstrap over
//! the runs: [`RESAMPLES`] times, draw the sweep's run indices with replacement (one draw
//! serves every point, since run i of every point shares a random stream), recompute every
//! point's standard deviations from the resampled runs, and take the 2.5 % and 97.5 %
//! quantiles of the statistic. The resampling stream is fixed by the campaign seed, so the
//! intervals are deterministic and a merge of shards reproduces them. A range of noisy
//! estimates is biased upward by the points' own Monte Carlo noise; the interval describes the
//! range as estimated from this many runs, not the noise-free one.

use rand::RngExt;
use serde::{Deserialize, Serialize};

use super::parameters::Sweep;
use super::records::{Outcome, PerStrategy, SweepRecords};
use crate::montecarlo::run_rng;

/// The standard normal's 97.5 % quantile: half-width of a 95 % interval in standard errors.
pub const Z95: f64 = 1.959_963_984_540_054;

/// A ratio with its delta-method standard error and 95 % confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RatioCi {
    /// The ratio of the sample standard deviations.
    pub ratio: f64,
    /// Standard error of the ratio (r̂·SE(log r̂)).
    pub se: f64,
    /// Lower end of the 95 % interval.
    pub lo: f64,
    /// Upper end of the 95 % interval.
    pub hi: f64,
    /// Runs in which both strategies stopped (the pairs the ratio is computed from).
    pub runs: usize,
}

/// Tail of one strategy's fuelling error at one point, mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Tail {
    /// 1 % quantile.
    pub q01_mm: f64,
    /// 5 % quantile.
    pub q05_mm: f64,
    /// 95 % quantile.
    pub q95_mm: f64,
    /// 99 % quantile.
    pub q99_mm: f64,
    /// mean − 3σ.
    pub band_lo_mm: f64,
    /// mean + 3σ.
    pub band_hi_mm: f64,
    /// Fraction of the runs outside the 3σ band (0.0027 for a normal error).
    pub outside_band: f64,
}

/// Ratios to relay logic of one sweep point, with the point's coordinates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PointRatios {
    /// The point's coordinate values, in the sweep's key order.
    pub at: Vec<f64>,
    /// std(strategy)/std(relay) with its interval.
    pub ratios: PerStrategy<RatioCi>,
}

/// Bootstrap resamples per interval: the Monte Carlo error of a 2.5 % quantile of 1000
/// resamples is about 0.1 of the interval's half-width, well below the digits reported.
pub const RESAMPLES: usize = 1000;

/// A sweep statistic with its percentile-bootstrap 95 % interval over the runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BootCi {
    /// The statistic on the runs themselves.
    pub value: f64,
    /// 2.5 % quantile over the resamples.
    pub lo: f64,
    /// 97.5 % quantile over the resamples.
    pub hi: f64,
}

/// How far the random error moves over one sweep: every strategy's range max − min of its
/// per-point standard deviations, and two ratios of ranges, each with its bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ranges {
    /// max − min over the points of each strategy's random error, mm.
    pub range_mm: PerStrategy<BootCi>,
    /// The two-channel filter's range over relay logic's.
    pub kf2_over_relay: BootCi,
    /// The two-channel filter's range over the one-channel filter's.
    pub kf2_over_kf1: BootCi,
}

/// Margins of the headline point and the ratio intervals of the sweeps the report quotes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Margins {
    /// The amplitude of the headline point (the amplitude sweep's largest), degrees.
    pub amplitude_deg: f64,
    /// How the ratio intervals are computed.
    pub ratio_interval: &'static str,
    /// std(strategy)/std(relay) at the headline point.
    pub ratios: PerStrategy<RatioCi>,
    /// Tail quantiles and 3σ band of each strategy's fuelling error at the headline point.
    pub tails: PerStrategy<Tail>,
    /// Ratios at each point of the target-phase sweep.
    pub target: Vec<PointRatios>,
    /// Ratios at each point of the quantization-step sweep.
    pub step: Vec<PointRatios>,
    /// How the range intervals are computed.
    pub range_interval: &'static str,
    /// Ranges over the amplitude sweep (growth with amplitude).
    pub amplitude: Ranges,
    /// Ranges over the rolling-period sweep.
    pub period: Ranges,
    /// Ranges over the amplitude × period table (the invariance spread).
    pub invariance: Ranges,
}

/// The delta-method interval of std(a)/std(b) over the runs where both are finite.
pub fn std_ratio(a: &[f64], b: &[f64]) -> RatioCi {
    let pairs: Vec<(f64, f64)> = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
        .collect();
    let n = pairs.len();
    let nan = RatioCi {
        ratio: f64::NAN,
        se: f64::NAN,
        lo: f64::NAN,
        hi: f64::NAN,
        runs: n,
    };
    if n < 2 {
        return nan;
    }
    let nf = n as f64;
    let (ma, mb) = pairs
        .iter()
        .fold((0.0, 0.0), |(sa, sb), (x, y)| (sa + x / nf, sb + y / nf));
    let (va, vb) = pairs.iter().fold((0.0, 0.0), |(sa, sb), (x, y)| {
        (sa + (x - ma).powi(2), sb + (y - mb).powi(2))
    });
    let (va, vb) = (va / (nf - 1.0), vb / (nf - 1.0));
    if !(va > 0.0 && vb > 0.0) {
        return nan;
    }
    let u: Vec<f64> = pairs
        .iter()
        .map(|(x, y)| (x - ma).powi(2) / va - (y - mb).powi(2) / vb)
        .collect();
    let mu = u.iter().sum::<f64>() / nf;
    let var_u = u.iter().map(|x| (x - mu).powi(2)).sum::<f64>() / (nf - 1.0);
    let se_log = 0.5 * (var_u / nf).sqrt();
    let ratio = (va / vb).sqrt();
    RatioCi {
        ratio,
        se: ratio * se_log,
        lo: ratio * (-Z95 * se_log).exp(),
        hi: ratio * (Z95 * se_log).exp(),
        runs: n,
    }
}

/// Every strategy's sample standard deviation at every point, in mm, with run `i` counted
/// `counts[i]` times (a run index beyond `counts` counts once); non-finite outcomes are left
/// out. With all counts 1 this is the summary's `std_mm`.
fn point_stds(points: &[Vec<(usize, Outcome)>], counts: &[u32]) -> Vec<[f64; 5]> {
    points
        .iter()
        .map(|runs| {
            let weight = |i: usize| f64::from(counts.get(i).copied().unwrap_or(1));
            std::array::from_fn(|k| {
                let finite = || {
                    runs.iter()
                        .filter(move |(_, o)| o[k].is_finite())
                        .map(|(i, o)| (weight(*i), o[k] * 1e3))
                };
                let (n, sum) = finite().fold((0.0, 0.0), |(n, s), (w, x)| (n + w, s + w * x));
                let mean = sum / n;
                let ss: f64 = finite().map(|(w, x)| w * (x - mean).powi(2)).sum();
                (ss / (n - 1.0)).sqrt()
            })
        })
        .collect()
}

/// The seven range statistics of [`Ranges`] from per-point standard deviations, in the order
/// relay … kf2_midstep ranges, kf2/relay, kf2/kf1.
fn range_stats(stds: &[[f64; 5]]) -> [f64; 7] {
    let range = |k: usize| {
        let (lo, hi) = stds
            .iter()
            .map(|s| s[k])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            });
        hi - lo
    };
    let r: [f64; 5] = std::array::from_fn(range);
    [r[0], r[1], r[2], r[3], r[4], r[2] / r[0], r[2] / r[1]]
}

/// The ranges of one sweep's per-run records with bootstrap intervals from `resamples`
/// resamples of the run indices drawn from `seed`'s stream.
pub fn ranges(points: &[Vec<(usize, Outcome)>], seed: u64, resamples: usize) -> Ranges {
    let value = range_stats(&point_stds(points, &[]));
    let mut ids: Vec<usize> = points.iter().flatten().map(|(i, _)| *i).collect();
    ids.sort_unstable();
    ids.dedup();
    let mut counts = vec![0u32; ids.last().map_or(0, |i| i + 1)];
    let mut draws: [Vec<f64>; 7] = Default::default();
    let mut rng = run_rng(seed, BOOTSTRAP_STREAM);
    if !ids.is_empty() {
        for _ in 0..resamples {
            counts.fill(0);
            for _ in 0..ids.len() {
                counts[ids[rng.random_range(0..ids.len())]] += 1;
            }
            for (d, v) in draws
                .iter_mut()
                .zip(range_stats(&point_stds(points, &counts)))
            {
                if v.is_finite() {
                    d.push(v);
                }
            }
        }
    }
    let ci: [BootCi; 7] = std::array::from_fn(|j| {
        let d = &mut draws[j];
        d.sort_by(f64::total_cmp);
        // Fewer finite resamples than this leave the quantiles to chance.
        let enough = d.len() * 10 >= resamples * 9 && d.len() >= 20;
        BootCi {
            value: value[j],
            lo: if enough { quantile(d, 0.025) } else { f64::NAN },
            hi: if enough { quantile(d, 0.975) } else { f64::NAN },
        }
    });
    Ranges {
        range_mm: PerStrategy::from_fn(|k| ci[k]),
        kf2_over_relay: ci[5],
        kf2_over_kf1: ci[6],
    }
}

/// The stream index of the bootstrap's resampling (far from any run index).
const BOOTSTRAP_STREAM: u64 = u64::MAX - 1;

/// The `p` quantile of sorted finite `v` (linear interpolation between order statistics,
/// Hyndman & Fan's type 7, the default of R and NumPy).
pub fn quantile(sorted: &[f64], p: f64) -> f64 {
    match sorted.len() {
        0 => f64::NAN,
        1 => sorted[0],
        n => {
            let h = (n - 1) as f64 * p.clamp(0.0, 1.0);
            let i = (h.floor() as usize).min(n - 2);
            sorted[i] + (h - i as f64) * (sorted[i + 1] - sorted[i])
        }
    }
}

/// Tail quantiles and 3σ band of the finite values of `errors_m` (metres), in mm.
pub fn tail(errors_m: impl Iterator<Item = f64>) -> Tail {
    let mut v: Vec<f64> = errors_m
        .filter(|x| x.is_finite())
        .map(|x| x * 1e3)
        .collect();
    v.sort_by(f64::total_cmp);
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let std = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let (lo, hi) = (mean - 3.0 * std, mean + 3.0 * std);
    Tail {
        q01_mm: quantile(&v, 0.01),
        q05_mm: quantile(&v, 0.05),
        q95_mm: quantile(&v, 0.95),
        q99_mm: quantile(&v, 0.99),
        band_lo_mm: lo,
        band_hi_mm: hi,
        outside_band: v.iter().filter(|x| **x < lo || **x > hi).count() as f64 / n,
    }
}

/// Every strategy's ratio to relay logic over the runs of one point.
pub fn ratios_to_relay(runs: &[(usize, Outcome)]) -> PerStrategy<RatioCi> {
    let column = |i: usize| runs.iter().map(|(_, o)| o[i]).collect::<Vec<f64>>();
    let relay = column(0);
    PerStrategy::from_fn(|i| std_ratio(&column(i), &relay))
}

fn point_ratios(sweep: &Sweep, rec: &SweepRecords) -> Vec<PointRatios> {
    sweep
        .points
        .iter()
        .zip(&rec.records)
        .map(|((at, _), runs)| PointRatios {
            at: at.clone(),
            ratios: ratios_to_relay(runs),
        })
        .collect()
}

/// The margins of a campaign seeded with `seed`: `top` is the index of the headline point in
/// the amplitude sweep (`sweeps[0]`); the other sweeps are found by their identifiers.
pub fn margins(sweeps: &[Sweep], records: &[SweepRecords], top: usize, seed: u64) -> Margins {
    let headline: &[(usize, Outcome)] = records
        .first()
        .and_then(|r| r.records.get(top))
        .map_or(&[], Vec::as_slice);
    let sweep = |id: &str| sweeps.iter().zip(records).find(|(s, _)| s.id == id);
    let of = |id: &str| {
        sweep(id)
            .map(|(s, r)| point_ratios(s, r))
            .unwrap_or_default()
    };
    let ranges_of = |id: &str| {
        let points = sweep(id).map_or(&[][..], |(_, r)| r.records.as_slice());
        ranges(points, seed, RESAMPLES)
    };
    Margins {
        amplitude_deg: sweeps
            .first()
            .and_then(|s| s.points.get(top))
            .and_then(|(at, _)| at.first().copied())
            .unwrap_or(f64::NAN),
        ratio_interval: "delta method over runs: SE(log r) = sqrt(Var(u_a - u_b)/(4n)), \
                         u = (x - mean)^2/var; 95 % interval r*exp(+-1.96 SE(log r))",
        ratios: ratios_to_relay(headline),
        tails: PerStrategy::from_fn(|i| tail(headline.iter().map(|(_, o)| o[i]))),
        target: of("target"),
        step: of("step"),
        range_interval: "percentile bootstrap over runs: 1000 resamples of the run indices \
                         (one draw for every point of a sweep), 2.5 % and 97.5 % quantiles",
        amplitude: ranges_of("amplitude"),
        period: ranges_of("period"),
        invariance: ranges_of("invariance"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::montecarlo::run_rng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        // 0, 1, …, 100: the p quantile of type 7 is exactly 100·p.
        let v: Vec<f64> = (0..=100).map(f64::from).collect();
        for p in [0.0, 0.01, 0.05, 0.5, 0.95, 0.99, 1.0] {
            assert!((quantile(&v, p) - 100.0 * p).abs() < 1e-12, "{p}");
        }
        // Between two points: (n − 1)·p = 0.25 of the way from 10 to 20.
        assert!((quantile(&[10.0, 20.0], 0.25) - 12.5).abs() < 1e-12);
    }

    #[test]
    fn gaussian_tails_match_the_normal_quantiles() {
        // 20 000 draws of N(2, 3²) in metres: the 1 % quantile is 2 − 2.326·3 mm. A sample
        // quantile at p has SE σ·sqrt(p(1−p)/n)/φ(z_p): 0.079 mm at 1 % and 99 %, 0.045 mm at
        // 5 % and 95 %; the bounds are 4 SE.
        let mut rng = run_rng(5, 0);
        let errors: Vec<f64> = (0..20_000)
            .map(|_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                (2.0 + 3.0 * z) * 1e-3
            })
            .collect();
        let t = tail(errors.iter().copied().chain([f64::NAN]));
        let z99 = 2.326_347_874;
        let z95 = 1.644_853_627;
        assert!((t.q01_mm - (2.0 - z99 * 3.0)).abs() < 0.32, "{t:?}");
        assert!((t.q99_mm - (2.0 + z99 * 3.0)).abs() < 0.32, "{t:?}");
        assert!((t.q05_mm - (2.0 - z95 * 3.0)).abs() < 0.18, "{t:?}");
        assert!((t.q95_mm - (2.0 + z95 * 3.0)).abs() < 0.18, "{t:?}");
        // mean − 3s: SE sqrt(σ²/n + 9σ²/(2n)) ≈ 0.05 mm.
        assert!((t.band_lo_mm - (2.0 - 9.0)).abs() < 0.2, "{t:?}");
        // 0.27 % outside ± 3σ: 54 of 20 000, Poisson SE ≈ 7.
        assert!((t.outside_band - 0.0027).abs() < 0.0012, "{t:?}");
    }

    /// Ratio estimates of `reps` independent samples of `n` pairs drawn by `draw`.
    fn replicate(
        reps: u64,
        n: usize,
        draw: impl Fn(&mut rand_chacha::ChaCha8Rng) -> (f64, f64),
    ) -> Vec<RatioCi> {
        (0..reps)
            .map(|r| {
                let mut rng = run_rng(17, r);
                let (a, b): (Vec<f64>, Vec<f64>) = (0..n).map(|_| draw(&mut rng)).unzip();
                std_ratio(&a, &b)
            })
            .collect()
    }

    #[test]
    fn delta_method_error_matches_the_spread_of_replicated_ratios() {
        // Correlated pairs with a heavy-tailed a (a Laplace-like mixture) and the true ratio
        // 0.5: the delta-method SE must match the empirical std of the ratio over 400
        // replications (whose own relative SE is 1/sqrt(800) ≈ 3.5 %: 15 % bound), and the
        // 95 % intervals must cover the truth 95 % of the time (binomial SE 1.1 %: ± 4 %).
        let n = 400;
        let draw = |rng: &mut rand_chacha::ChaCha8Rng| {
            let z1: f64 = StandardNormal.sample(rng);
            let z2: f64 = StandardNormal.sample(rng);
            let e: f64 = StandardNormal.sample(rng);
            // a = 0.5·(0.6 z1 + 0.8 z2)·s/norm: s is 1.4 or 0.5 independently of z (mean
            // square 0.793 = norm², kurtosis 6), so std(a) = 0.5 and std(a)/std(b) = 0.5.
            let scale = if e.abs() > 1.0 { 1.4 } else { 0.5 };
            let norm = (0.3173f64 * 1.96 + 0.6827 * 0.25).sqrt();
            (0.5 * (0.6 * z1 + 0.8 * z2) * scale / norm, z1)
        };
        let reps = replicate(400, n, draw);
        let m = reps.iter().map(|r| r.ratio).sum::<f64>() / reps.len() as f64;
        let sd = (reps.iter().map(|r| (r.ratio - m).powi(2)).sum::<f64>()
            / (reps.len() - 1) as f64)
            .sqrt();
        let se = reps.iter().map(|r| r.se).sum::<f64>() / reps.len() as f64;
        assert!(
            (se / sd - 1.0).abs() < 0.15,
            "delta SE {se} vs empirical {sd}"
        );
        let cover =
            reps.iter().filter(|r| r.lo <= 0.5 && 0.5 <= r.hi).count() as f64 / reps.len() as f64;
        assert!((cover - 0.95).abs() < 0.04, "coverage {cover}");
    }

    #[test]
    fn independent_gaussians_give_the_closed_form_error() {
        // For independent normal a and b, Var(u_a − u_b) = 2 + 2, so SE(log r) = 1/sqrt(n).
        let n = 5000;
        let r = &replicate(1, n, |rng| {
            let (a, b): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
            (2.0 * a, b)
        })[0];
        let se_log = r.se / r.ratio;
        // The estimate of Var(u) from 5000 pairs has relative SE ≈ sqrt(Var(u²))/(4·√n) ≈ 6 %.
        assert!((se_log * (n as f64).sqrt() - 1.0).abs() < 0.1, "{se_log}");
        assert!((r.ratio - 2.0).abs() < 4.0 * r.se, "{r:?}");
        // A strategy against itself: ratio 1 with zero width.
        let same = std_ratio(&[1.0, 2.0, 4.0], &[1.0, 2.0, 4.0]);
        assert!((same.ratio - 1.0).abs() < 1e-15 && same.se.abs() < 1e-15);
    }

    /// A sweep of `sigmas.len()` points with `n` runs each: strategy k at point j draws
    /// σ_kj·z (in mm, stored in metres) with z independent standard normals.
    fn gaussian_sweep(seed: u64, n: usize, sigmas: &[[f64; 5]]) -> Vec<Vec<(usize, Outcome)>> {
        let mut rng = run_rng(seed, 0);
        sigmas
            .iter()
            .map(|sig| {
                (0..n)
                    .map(|i| {
                        let o: Outcome = std::array::from_fn(|k| {
                            let z: f64 = StandardNormal.sample(&mut rng);
                            sig[k] * z * 1e-3
                        });
                        (i, o)
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn resampled_counts_give_the_standard_deviation_of_the_repeated_sample() {
        // Counting run i c_i times must equal writing it out c_i times (a reconstruction
        // identity, to round-off); with no counts it is the summary's per-point std.
        let points = gaussian_sweep(3, 7, &[[1.0, 2.0, 3.0, 4.0, 5.0]; 2]);
        let counts = [0u32, 2, 1, 3, 0, 1, 0];
        let repeated: Vec<Vec<(usize, Outcome)>> = points
            .iter()
            .map(|runs| {
                runs.iter()
                    .flat_map(|r| std::iter::repeat_n(*r, counts[r.0] as usize))
                    .map(|(_, o)| (usize::MAX, o))
                    .collect()
            })
            .collect();
        let weighted = point_stds(&points, &counts);
        let direct = point_stds(&repeated, &[]);
        for (w, d) in weighted.iter().zip(&direct) {
            for k in 0..5 {
                assert!((w[k] - d[k]).abs() <= 1e-12 * d[k], "{w:?} vs {d:?}");
            }
        }
        for (runs, w) in points.iter().zip(point_stds(&points, &[])) {
            let v: Vec<f64> = runs.iter().map(|(_, o)| o[2] * 1e3).collect();
            let m = v.iter().sum::<f64>() / 7.0;
            let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / 6.0).sqrt();
            assert!((w[2] - sd).abs() <= 1e-12 * sd);
        }
    }

    #[test]
    fn bootstrap_intervals_of_ranges_cover_the_truth() {
        // Three points whose true random errors are relay 2, 4, 6 mm, one-channel 1, 2, 3,
        // two-channel 1, 1.25, 1.5: true ranges 4, 2 and 0.5 mm, ratios 0.125 and 0.25. With
        // 300 runs a point the per-point std has SE σ/√600 ≈ 4 % of σ, so max and min are the
        // right points and the range is nearly unbiased. Over 200 replications the 95 %
        // intervals must cover the truth at a rate in [0.88, 0.99]: 3 binomial SE (1.5 %
        // each) either side of 95 %, and 2.5 % more below for the percentile bootstrap's
        // undercoverage of statistics built from standard deviations (their sampling
        // distribution is skewed); with 999 resamples instead of 199 the rates stay the same
        // within a percent, so the resample count is not what sets them.
        let sigmas = [
            [2.0, 1.0, 1.0, 1.0, 1.0],
            [4.0, 2.0, 1.25, 1.0, 1.0],
            [6.0, 3.0, 1.5, 1.0, 1.0],
        ];
        let reps = 200;
        let mut cover = [0usize; 3];
        for r in 0..reps {
            let g = ranges(&gaussian_sweep(100 + r, 300, &sigmas), r, 199);
            let hit = |b: BootCi, truth: f64| usize::from(b.lo <= truth && truth <= b.hi);
            cover[0] += hit(g.range_mm.relay, 4.0);
            cover[1] += hit(g.kf2_over_relay, 0.125);
            cover[2] += hit(g.kf2_over_kf1, 0.25);
            assert!(g.range_mm.kf2.lo <= g.range_mm.kf2.value);
            assert!(g.range_mm.kf2.value <= g.range_mm.kf2.hi);
        }
        for c in cover {
            let rate = c as f64 / reps as f64;
            assert!(
                (0.88..=0.99).contains(&rate),
                "coverage {cover:?} of {reps}"
            );
        }
    }

    #[test]
    fn ranges_are_deterministic_and_empty_sweeps_give_nan() {
        let points = gaussian_sweep(8, 50, &[[1.0; 5], [2.0; 5]]);
        assert_eq!(ranges(&points, 4, 100), ranges(&points, 4, 100));
        let none = ranges(&[], 4, 100);
        assert!(none.kf2_over_relay.value.is_nan() && none.kf2_over_relay.lo.is_nan());
    }
}
