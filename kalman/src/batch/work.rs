//! The batch step's per-group state: the rows of every quantity ([`Work`]), the running
//! log-likelihood ([`Loglik`]), the slice of the output a group writes ([`GroupOut`]), and the
//! finiteness probe.

use super::{BatchOutput, LANES};
use crate::Error;

/// The first of the `lanes` series whose state (named `x`) or a diagonal entry of whose
/// covariance (named `p`) is not finite, with the name and the value: one vector pass that
/// sums `0·v` (NaN if any v is not), and a search only when it is.
#[inline(always)]
pub(super) fn non_finite(
    w: &Work,
    n: usize,
    lanes: usize,
    x: &'static str,
    p: &'static str,
) -> Option<(usize, &'static str, f64)> {
    let mut probe = [0.0; LANES];
    for i in 0..n {
        for l in 0..LANES {
            probe[l] += 0.0 * w.x[i][l] + 0.0 * w.p[i * n + i][l];
        }
    }
    if probe[..lanes].iter().all(|v| v.is_finite()) {
        return None;
    }
    (0..lanes).find_map(|l| {
        (0..n).find_map(|i| {
            let (v, d) = (w.x[i][l], w.p[i * n + i][l]);
            if !v.is_finite() {
                Some((l, x, v))
            } else if !d.is_finite() {
                Some((l, p, d))
            } else {
                None
            }
        })
    })
}

pub(super) fn in_series(series: usize, error: Error) -> Error {
    Error::InSeries {
        series,
        error: Box::new(error),
    }
}

/// The log-likelihood of each lane: a sum, and the product of the steps' `det Σ` not yet in
/// it. A logarithm per lane and step would be a fifth of the batch step at n = 2; the product
/// takes one only when it leaves `[2^-500, 2^500]` (or at the end). The product of K factors
/// carries K ulps of relative error, K·2⁻⁵³ in its logarithm: below 1e-13 for the ~500 steps
/// between flushes at any realistic Σ.
pub(super) struct Loglik {
    pub(super) sum: [f64; LANES],
    pub(super) det: [f64; LANES],
}

/// The range the running `det Σ` product is kept in, and a step's factor must be in to join
/// it (2^±500: the product of two such numbers neither over- nor underflows).
pub(super) const DET_RANGE: (f64, f64) = (3.054936363499605e-151, 3.273390607896142e150);

impl Loglik {
    pub(super) fn new() -> Self {
        Self {
            sum: [0.0; LANES],
            det: [1.0; LANES],
        }
    }

    /// Moves the product into the sum when a lane's has left [`DET_RANGE`].
    #[inline(always)]
    pub(super) fn keep_in_range(&mut self) {
        let mut out = false;
        for l in 0..LANES {
            out |= !(self.det[l] >= DET_RANGE.0 && self.det[l] <= DET_RANGE.1);
        }
        if out {
            self.flush();
        }
    }

    fn flush(&mut self) {
        for l in 0..LANES {
            self.sum[l] -= 0.5 * self.det[l].ln();
            self.det[l] = 1.0;
        }
    }

    pub(super) fn total(&mut self) -> [f64; LANES] {
        self.flush();
        self.sum
    }
}

/// One group's rows: every quantity a row of [`LANES`] numbers, matrices row-major.
pub(super) struct Work {
    pub(super) x: Vec<[f64; LANES]>,
    pub(super) p: Vec<[f64; LANES]>,
    pub(super) z: Vec<[f64; LANES]>,
    pub(super) e: Vec<[f64; LANES]>,
    pub(super) present: Vec<[f64; LANES]>,
    pub(super) pht: Vec<[f64; LANES]>,
    pub(super) sigma: Vec<[f64; LANES]>,
    pub(super) k: Vec<[f64; LANES]>,
    pub(super) ks: Vec<[f64; LANES]>,
    pub(super) a: Vec<[f64; LANES]>,
    pub(super) t: Vec<[f64; LANES]>,
    pub(super) y: Vec<[f64; LANES]>,
    pub(super) s: Vec<[f64; LANES]>,
    /// `1 / L_jj` of the innovation covariance's factor.
    pub(super) inv: Vec<[f64; LANES]>,
}

impl Work {
    pub(super) fn new(n: usize, m: usize) -> Self {
        let rows = |len: usize| vec![[0.0; LANES]; len];
        Self {
            x: rows(n),
            p: rows(n * n),
            z: rows(m),
            e: rows(m),
            present: rows(m),
            pht: rows(n * m),
            sigma: rows(m * m),
            k: rows(n * m),
            ks: rows(n * m),
            a: rows(n * n),
            t: rows(n * n),
            y: rows(m),
            s: rows(m * m),
            inv: rows(m),
        }
    }
}

/// The part of a [`BatchOutput`] one group writes.
pub(super) struct GroupOut<'a> {
    pub(super) means: &'a mut [f64],
    pub(super) covariances: Option<&'a mut [f64]>,
    pub(super) last: &'a mut [f64],
    pub(super) loglik: &'a mut [f64],
}

impl<'a> GroupOut<'a> {
    pub(super) fn split(out: &'a mut BatchOutput, n: usize, steps: usize, cov: bool) -> Vec<Self> {
        let means = out.means.chunks_mut(LANES * steps * n);
        let last = out.last_covariances.chunks_mut(LANES * n * n);
        let loglik = out.log_likelihood.chunks_mut(LANES);
        let mut covs: Vec<Option<&'a mut [f64]>> = if cov {
            out.covariances
                .chunks_mut(LANES * steps * n * n)
                .map(Some)
                .collect()
        } else {
            Vec::new()
        };
        let groups = out.series.div_ceil(LANES);
        covs.resize_with(groups, || None);
        means
            .zip(last)
            .zip(loglik)
            .zip(covs)
            .map(|(((means, last), loglik), covariances)| GroupOut {
                means,
                covariances,
                last,
                loglik,
            })
            .collect()
    }
}
