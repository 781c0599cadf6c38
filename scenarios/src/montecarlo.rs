//! Monte Carlo plumbing shared by every scenario: per-run seeds, deterministic shards, and a
//! parallel map over runs with a progress bar.
//!
//! Run `i` of a campaign with seed `s` always draws from the stream [`run_seed`]`(s, i)`, and
//! results come back in run order, so a summary is identical for any `--threads` and a
//! campaign split with `--shard K/N` and merged gives the same per-run records.

use std::io::IsTerminal;
use std::ops::Range;
use std::str::FromStr;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::error::{Error, Result};

/// The seed of run `run` of a campaign seeded with `seed` (SplitMix64 finaliser over both, so
/// neighbouring runs get unrelated streams).
pub fn run_seed(seed: u64, run: u64) -> u64 {
    let mut z = seed ^ run.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random generator of run `run` of a campaign seeded with `seed`.
pub fn run_rng(seed: u64, run: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(run_seed(seed, run))
}

/// A deterministic slice `K/N` of a campaign (1-based `index`, `index` ≤ `count`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Shard {
    /// Which slice, from 1.
    pub index: usize,
    /// How many slices in all.
    pub count: usize,
}

impl Shard {
    /// The whole campaign.
    pub const ALL: Shard = Shard { index: 1, count: 1 };

    /// The runs of a campaign of `total` runs that this shard owns: contiguous, and the
    /// shards `1/N … N/N` cover `0..total` exactly once in order.
    pub fn runs(&self, total: usize) -> Range<usize> {
        let start = total * (self.index - 1) / self.count;
        let end = total * self.index / self.count;
        start..end
    }
}

impl FromStr for Shard {
    type Err = Error;

    /// Parses `K/N` with 1 ≤ K ≤ N ≤ 10⁶; the message says which part is wrong (the caller
    /// names the option).
    fn from_str(s: &str) -> Result<Self> {
        // Far more slices than any job array, and small enough that `runs` cannot overflow
        // for any campaign that fits in memory.
        const MAX_COUNT: usize = 1_000_000;
        let usage = |why: &str| Error::Usage(why.to_string());
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| usage("expected K/N, slice K of N (for example 2/8)"))?;
        let whole = |part: &str, name: &str| -> Result<usize> {
            let part = part.trim();
            if part.is_empty() || !part.bytes().all(|b| b.is_ascii_digit()) {
                return Err(usage(&format!("{name} must be a whole number")));
            }
            // Too many digits for usize is past the limit below anyway.
            Ok(part.parse::<usize>().unwrap_or(usize::MAX))
        };
        let index = whole(k, "K")?;
        let count = whole(n, "N")?;
        if count == 0 || count > MAX_COUNT {
            return Err(usage(&format!("N must be between 1 and {}", MAX_COUNT)));
        }
        if index == 0 || index > count {
            return Err(usage("K must be between 1 and N"));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Runs `job(i)` for every `i` in `runs` on `threads` worker threads (all cores when `None`)
/// and returns the results in run order. A progress bar labelled `label` is drawn on stderr
/// when it is a terminal; otherwise the function is silent.
pub fn par_runs<T, F>(
    runs: Range<usize>,
    threads: Option<usize>,
    label: &str,
    job: F,
) -> Result<Vec<T>>
where
    T: Send,
    F: Fn(usize) -> T + Sync + Send,
{
    count_simulation();
    let bar = if std::io::stderr().is_terminal() {
        let bar = indicatif::ProgressBar::new(runs.len() as u64);
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "{prefix:>12} [{bar:40}] {pos}/{len} runs, {elapsed} elapsed, eta {eta}",
        ) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_prefix(label.to_string());
        bar
    } else {
        indicatif::ProgressBar::hidden()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|source| Error::Threads { threads, source })?;
    let out = pool.install(|| {
        runs.into_par_iter()
            .map(|i| {
                let r = job(i);
                bar.inc(1);
                r
            })
            .collect::<Vec<T>>()
    });
    bar.finish_and_clear();
    Ok(out)
}

#[cfg(test)]
thread_local! {
    /// Simulations started on this thread, for the tests that show a step simulates nothing.
    static STARTED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Counts a simulation started on the calling thread ([`par_runs`], and a scenario's own
/// single simulations); the count exists in the crate's tests only.
pub(crate) fn count_simulation() {
    #[cfg(test)]
    STARTED.with(|c| c.set(c.get() + 1));
}

/// The simulations started on this thread so far ([`count_simulation`]).
#[cfg(test)]
pub(crate) fn simulations_started() -> usize {
    STARTED.with(std::cell::Cell::get)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_partition_the_runs_in_order() {
        for total in [0, 1, 7, 1000] {
            for count in 1..=5 {
                let mut next = 0;
                for index in 1..=count {
                    let r = Shard { index, count }.runs(total);
                    assert_eq!(r.start, next);
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
    }

    #[test]
    fn shard_parsing_rejects_nonsense() {
        assert_eq!(
            "2/3".parse::<Shard>().ok(),
            Some(Shard { index: 2, count: 3 })
        );
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn results_do_not_depend_on_threads() {
        use rand::RngExt;
        let draw = |i: usize| run_rng(42, i as u64).random::<u64>();
        let one = par_runs(0..64, Some(1), "t", draw).expect("pool");
        let two = par_runs(0..64, Some(2), "t", draw).expect("pool");
        assert_eq!(one, two);
        assert_ne!(one[0], one[1], "neighbouring runs must differ");
    }
}
