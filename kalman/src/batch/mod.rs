//! Many independent series of one linear model, filtered in lockstep.
//!
//! A fleet of sensors, a bank of Monte Carlo runs or thousands of time series often share one
//! model `(F, H, Q, R)` and one prior. [`BatchFilter`] filters them together: the series are
//! taken [`LANES`] at a time, and every quantity of the step (each entry of x, P, the gain,
//! the innovation covariance) is held as a row of `LANES` numbers, one per series, so every
//! arithmetic operation of the step is the same operation on a whole row — the layout the
//! compiler turns into vector instructions. Groups of series run on rayon's threads with
//! the feature `parallel`.
//!
//! The step is the engine's (update with `z_k`, then predict to `k + 1`). A missing entry
//! (`NaN`) of one series is masked out of that series' update exactly: its row of H and its
//! innovation are set to zero and its row and column of R to those of the identity, so the
//! innovation covariance is block-diagonal with a unit block for it, its gain column is zero,
//! and the update is the one with the present entries alone. The log-likelihood, summed per
//! series, counts only the present entries.
//!
//! What the batch path does not do, and the scalar [`crate::Filter`] does: a cross-covariance
//! S or a control input (the model must have neither), the square-root form, and a singular
//! innovation covariance (an exact channel with a singular R): the batch step factors it by
//! Cholesky and reports a pivot at or below `RANK_TOL` times its largest diagonal entry as
//! [`Error::SingularInnovation`] with the series and the step, rather than take the
//! pseudo-inverse path of the scalar filter.
//!
//! ```
//! use kalman::batch::BatchFilter;
//! use kalman::{CovarianceForm, DynDims, Filter, Model};
//! # fn main() -> Result<(), kalman::Error> {
//! let model = Model::new(
//!     DynDims::new(2, 1, 0)?,
//!     &[[1.0, 0.1], [0.0, 1.0]],
//!     &[[1.0, 0.0]],
//!     &[[1e-4, 0.0], [0.0, 1e-3]],
//!     &[[0.01]],
//! )?;
//! // Three series of four steps, (series, time, m) row-major; NaN is a missing sample.
//! let zs = [
//!     0.11, 0.19, f64::NAN, 0.42, //
//!     1.0, 1.1, 1.2, 1.3, //
//!     f64::NAN, f64::NAN, 0.5, 0.45,
//! ];
//! let batch = BatchFilter::new(&model, CovarianceForm::Joseph)?;
//! let out = batch.run(&[0.0, 1.0], &[[1.0, 0.0], [0.0, 1.0]], &zs, 3)?;
//! // The same as the scalar filter on series 0.
//! let mut kf = Filter::new(model, &[0.0, 1.0], &[[1.0, 0.0], [0.0, 1.0]], CovarianceForm::Joseph)?;
//! for k in 0..4 {
//!     kf.step(&[zs[k]], None)?;
//!     assert!((out.mean(0, k)[0] - kf.state()[0]).abs() < 1e-12);
//! }
//! # Ok(())
//! # }
//! ```

use crate::kernels::LN_2PI;
use crate::kernels::RANK_TOL;
use crate::model::{MatrixInput, load, load_vec, psd_factor, symmetrise};
use crate::{CovarianceForm, Dims, Error, Model};

/// Series filtered together in one group: every quantity of the step is a row of this many
/// numbers (a multiple of the vector width of current x86 and ARM cores).
pub const LANES: usize = 8;

/// One linear model for many series; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct BatchFilter {
    n: usize,
    m: usize,
    /// Row-major n×n, m×n, n×n and m×m.
    f: Vec<f64>,
    h: Vec<f64>,
    q: Vec<f64>,
    r: Vec<f64>,
    form: CovarianceForm,
    covariances: bool,
}

/// What a [`BatchFilter::run`] produced, per series.
#[derive(Debug, Clone, PartialEq)]
pub struct BatchOutput {
    /// Series, steps, states.
    pub series: usize,
    /// Steps per series.
    pub steps: usize,
    /// States n.
    pub n: usize,
    /// `x_{k|k}` of every series and step, `(series, steps, n)` row-major.
    pub means: Vec<f64>,
    /// `P_{k|k}` of every series and step, `(series, steps, n, n)` row-major, when asked for
    /// with [`BatchFilter::with_covariances`] (it is n² numbers a step: 32 MB for 10 000
    /// series of 100 steps at n = 2); otherwise empty.
    pub covariances: Vec<f64>,
    /// `P_{N−1|N−1}` of every series, `(series, n, n)` row-major.
    pub last_covariances: Vec<f64>,
    /// The Gaussian log-likelihood of each series (the sum of its steps' terms; a missing
    /// entry contributes nothing).
    pub log_likelihood: Vec<f64>,
}

impl BatchOutput {
    /// `x_{k|k}` of series `s` at step `k`.
    pub fn mean(&self, s: usize, k: usize) -> &[f64] {
        let at = (s * self.steps + k) * self.n;
        &self.means[at..at + self.n]
    }
}

impl BatchFilter {
    /// The batch filter of `model` (which must have no cross-covariance S and no control
    /// input) with the covariance update `form` (`Joseph` or `Standard`).
    ///
    /// # Errors
    /// [`Error::InvalidOption`] for the square-root form, a model with S or with a control
    /// input.
    pub fn new<D: Dims>(model: &Model<D>, form: CovarianceForm) -> Result<Self, Error> {
        if form == CovarianceForm::SquareRoot {
            return Err(Error::InvalidOption {
                name: "form",
                value: f64::NAN,
                rule: "the batch filter offers the Joseph and the standard forms",
            });
        }
        if model.s().is_some() {
            return Err(Error::InvalidOption {
                name: "S",
                value: f64::NAN,
                rule: "the batch filter takes a model without cross-covariance S",
            });
        }
        let dims = model.dims();
        if dims.m() > MAX_M {
            return Err(Error::Dimension {
                name: "m",
                value: dims.m(),
                rule: "the batch filter takes at most 16 measurement entries",
            });
        }
        if dims.p() > 0 {
            return Err(Error::InvalidOption {
                name: "p",
                value: dims.p() as f64,
                rule: "the batch filter takes a model without a control input",
            });
        }
        let row_major = |a: faer::MatRef<'_, f64>| {
            let mut v = Vec::with_capacity(a.nrows() * a.ncols());
            for i in 0..a.nrows() {
                for j in 0..a.ncols() {
                    v.push(a[(i, j)]);
                }
            }
            v
        };
        Ok(Self {
            n: dims.n(),
            m: dims.m(),
            f: row_major(model.f()),
            h: row_major(model.h()),
            q: row_major(model.q()),
            r: row_major(model.r()),
            form,
            covariances: false,
        })
    }

    /// Also returns `P_{k|k}` of every series and step ([`BatchOutput::covariances`]).
    #[must_use]
    pub fn with_covariances(mut self, yes: bool) -> Self {
        self.covariances = yes;
        self
    }

    /// Filters `series` series from the prior `(x0, P0)`. `zs` holds them one after the
    /// other, `(series, steps, m)` row-major, with `NaN` for a missing entry; `steps` is
    /// `zs.len() / (series · m)`.
    ///
    /// # Errors
    /// [`Error::Shape`] if `x0`, `P0` or `zs` does not fit the model, [`Error::NonFinite`]
    /// or a covariance error for a bad prior, and [`Error::InSeries`] naming the series of
    /// an infinite measurement ([`Error::NonFinite`]), a singular innovation covariance
    /// ([`Error::SingularInnovation`]) or a divergence ([`Error::Diverged`]).
    pub fn run(
        &self,
        x0: &[f64],
        p0: &impl MatrixInput,
        zs: &[f64],
        series: usize,
    ) -> Result<BatchOutput, Error> {
        let (n, m) = (self.n, self.m);
        let mut x = vec![0.0; n];
        load_vec("x0", x0, n, &mut x)?;
        let mut p = vec![0.0; n * n];
        load("P0", p0, n, n, &mut p)?;
        symmetrise("P0", &mut p, n)?;
        psd_factor("P0", &p, n, &mut vec![0.0; n * n])?;
        let per_series = zs.len().checked_div(series).unwrap_or(0);
        if series * per_series != zs.len() || (m > 0 && per_series % m != 0) {
            return Err(Error::Shape {
                name: "z",
                rows: series,
                cols: if series == 0 { zs.len() } else { per_series },
                expected_rows: series,
                expected_cols: per_series.div_ceil(m) * m,
            });
        }
        let steps = per_series.checked_div(m).unwrap_or(0);
        let mut out = BatchOutput {
            series,
            steps,
            n,
            means: vec![0.0; series * steps * n],
            covariances: vec![
                0.0;
                if self.covariances {
                    series * steps * n * n
                } else {
                    0
                }
            ],
            last_covariances: vec![0.0; series * n * n],
            log_likelihood: vec![0.0; series],
        };
        if steps == 0 {
            return Ok(out);
        }
        // P0 is symmetric: its column-major copy is its row-major one.
        let prior = (&x[..], &p[..]);
        let groups = series.div_ceil(LANES);
        // Each group runs with the widest vector instructions the processor has (pulp detects
        // them at run time; mul and add stay separate, so every instruction set gives the same
        // bits).
        let arch = pulp::Arch::new();
        let run_group = |g: usize, slot: GroupOut<'_>| {
            arch.dispatch(
                #[inline(always)]
                || self.group(g, series, steps, zs, prior, slot),
            )
        };
        let slots = GroupOut::split(&mut out, n, steps, self.covariances);
        debug_assert_eq!(slots.len(), groups);
        // The error reported is the first series' in order, whatever the threads did.
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            let results: Vec<Result<(), Error>> = slots
                .into_par_iter()
                .enumerate()
                .map(|(g, slot)| run_group(g, slot))
                .collect();
            results.into_iter().collect::<Result<(), Error>>()?;
        }
        #[cfg(not(feature = "parallel"))]
        for (g, slot) in slots.into_iter().enumerate() {
            run_group(g, slot)?;
        }
        Ok(out)
    }

    /// Filters group `g` (series `g·LANES ..`) into its slot of the output.
    #[inline(always)]
    fn group(
        &self,
        g: usize,
        series: usize,
        steps: usize,
        zs: &[f64],
        (x0, p0): (&[f64], &[f64]),
        mut slot: GroupOut<'_>,
    ) -> Result<(), Error> {
        let (n, m) = (self.n, self.m);
        let first = g * LANES;
        let lanes = LANES.min(series - first);
        let mut w = Work::new(n, m);
        for i in 0..n {
            w.x[i] = [x0[i]; LANES];
        }
        for (e, &v) in p0.iter().enumerate() {
            w.p[e] = [v; LANES];
        }
        let mut loglik = [0.0; LANES];
        for k in 0..steps {
            // The step's measurements: lanes past the last series stay missing.
            for j in 0..m {
                for l in 0..LANES {
                    let v = if l < lanes {
                        zs[((first + l) * steps + k) * m + j]
                    } else {
                        f64::NAN
                    };
                    if v.is_infinite() {
                        return Err(in_series(
                            first + l,
                            Error::NonFinite {
                                name: "z",
                                rows: steps,
                                cols: m,
                                row: k,
                                col: j,
                            },
                        ));
                    }
                    w.z[j][l] = v;
                }
            }
            if let Some((l, pivot, tol)) = self.update(&mut w, &mut loglik) {
                return Err(in_series(
                    first + l,
                    Error::SingularInnovation {
                        filter: "batch",
                        step: k,
                        m,
                        pivot,
                        tol,
                    },
                ));
            }
            if let Some((l, what, value)) = non_finite(&w, n, lanes, "x_{k|k}", "P_{k|k}") {
                let step = k;
                return Err(in_series(first + l, Error::Diverged { step, what, value }));
            }
            for l in 0..lanes {
                let at = (l * steps + k) * n;
                for i in 0..n {
                    slot.means[at + i] = w.x[i][l];
                }
                if let Some(cov) = slot.covariances.as_deref_mut() {
                    let at = (l * steps + k) * n * n;
                    for e in 0..n * n {
                        cov[at + e] = w.p[e][l];
                    }
                }
                if k + 1 == steps {
                    for e in 0..n * n {
                        slot.last[l * n * n + e] = w.p[e][l];
                    }
                }
            }
            self.predict(&mut w);
            let (x, p) = ("x_{k+1|k}", "P_{k+1|k}");
            if let Some((l, what, value)) = non_finite(&w, n, lanes, x, p) {
                let step = k;
                return Err(in_series(first + l, Error::Diverged { step, what, value }));
            }
        }
        slot.loglik[..lanes].copy_from_slice(&loglik[..lanes]);
        Ok(())
    }

    /// The measurement update of every lane; the lane, pivot and tolerance of a singular
    /// innovation covariance if one is.
    #[inline(always)]
    fn update(&self, w: &mut Work, loglik: &mut [f64; LANES]) -> Option<(usize, f64, f64)> {
        let (n, m) = (self.n, self.m);
        // Masked innovation e and H x.
        for j in 0..m {
            let mut hx = [0.0; LANES];
            for c in 0..n {
                let h = self.h[j * n + c];
                for l in 0..LANES {
                    hx[l] += h * w.x[c][l];
                }
            }
            for l in 0..LANES {
                let present = !w.z[j][l].is_nan();
                w.present[j][l] = if present { 1.0 } else { 0.0 };
                w.e[j][l] = if present { w.z[j][l] - hx[l] } else { 0.0 };
            }
        }
        // P Hᵀ (n×m), its columns masked.
        for i in 0..n {
            for j in 0..m {
                let mut acc = [0.0; LANES];
                for c in 0..n {
                    let h = self.h[j * n + c];
                    for l in 0..LANES {
                        acc[l] += w.p[i * n + c][l] * h;
                    }
                }
                for l in 0..LANES {
                    w.pht[i * m + j][l] = acc[l] * w.present[j][l];
                }
            }
        }
        // Σ = H P Hᵀ + R on the present entries, the identity on the missing ones.
        for j in 0..m {
            for c in 0..=j {
                let mut acc = [0.0; LANES];
                for i in 0..n {
                    let h = self.h[j * n + i];
                    for l in 0..LANES {
                        acc[l] += h * w.pht[i * m + c][l];
                    }
                }
                let r = self.r[j * m + c];
                for l in 0..LANES {
                    let both = w.present[j][l] * w.present[c][l];
                    let unit = if j == c { 1.0 - w.present[j][l] } else { 0.0 };
                    w.sigma[j * m + c][l] = both * (acc[l] + r) + unit;
                }
            }
        }
        // Σ kept for the Joseph form; Cholesky Σ = L Lᵀ, lane by lane in lockstep (L in the
        // lower triangle of `sigma`).
        w.s.copy_from_slice(&w.sigma);
        let mut largest = [0.0f64; LANES];
        for j in 0..m {
            for l in 0..LANES {
                largest[l] = largest[l].max(w.sigma[j * m + j][l]);
            }
        }
        for j in 0..m {
            for c in 0..j {
                let mut acc = w.sigma[j * m + c];
                for t in 0..c {
                    for l in 0..LANES {
                        acc[l] -= w.sigma[j * m + t][l] * w.sigma[c * m + t][l];
                    }
                }
                for l in 0..LANES {
                    w.sigma[j * m + c][l] = acc[l] / w.sigma[c * m + c][l];
                }
            }
            let mut d = w.sigma[j * m + j];
            for t in 0..j {
                for l in 0..LANES {
                    d[l] -= w.sigma[j * m + t][l] * w.sigma[j * m + t][l];
                }
            }
            let mut bad = false;
            for l in 0..LANES {
                bad |= d[l].is_nan() | (d[l] <= RANK_TOL * largest[l]);
            }
            if bad {
                let l = (0..LANES)
                    .find(|&l| d[l].is_nan() | (d[l] <= RANK_TOL * largest[l]))
                    .unwrap_or(0);
                return Some((l, d[l], RANK_TOL * largest[l]));
            }
            for l in 0..LANES {
                w.sigma[j * m + j][l] = d[l].sqrt();
            }
        }
        // Kᵀ = Σ⁻¹ (P Hᵀ)ᵀ by two triangular solves per row of P Hᵀ; v = L⁻¹ e alongside.
        for i in 0..=n {
            // Row i of P Hᵀ (i < n), or the innovation (i = n).
            let y = &mut w.y;
            for j in 0..m {
                y[j] = if i < n { w.pht[i * m + j] } else { w.e[j] };
                for t in 0..j {
                    for l in 0..LANES {
                        y[j][l] -= w.sigma[j * m + t][l] * y[t][l];
                    }
                }
                for l in 0..LANES {
                    y[j][l] /= w.sigma[j * m + j][l];
                }
            }
            if i == n {
                // ln L = −½ (|L⁻¹e|² + ln det Σ + present · ln 2π).
                for l in 0..LANES {
                    let mut quad = 0.0;
                    let mut logdet = 0.0;
                    let mut present = 0.0;
                    for j in 0..m {
                        quad += y[j][l] * y[j][l];
                        logdet += 2.0 * w.sigma[j * m + j][l].ln();
                        present += w.present[j][l];
                    }
                    loglik[l] -= 0.5 * (quad + logdet + present * LN_2PI);
                }
                break;
            }
            for j in (0..m).rev() {
                for t in j + 1..m {
                    for l in 0..LANES {
                        y[j][l] -= w.sigma[t * m + j][l] * y[t][l];
                    }
                }
                for l in 0..LANES {
                    y[j][l] /= w.sigma[j * m + j][l];
                }
            }
            for j in 0..m {
                w.k[i * m + j] = y[j];
            }
        }
        // x⁺ = x + K e.
        for i in 0..n {
            for j in 0..m {
                for l in 0..LANES {
                    w.x[i][l] += w.k[i * m + j][l] * w.e[j][l];
                }
            }
        }
        match self.form {
            CovarianceForm::Standard => self.standard(w),
            _ => self.joseph(w),
        }
        None
    }

    /// `P⁺ = P − K (P Hᵀ)ᵀ`, the upper triangle computed and mirrored.
    #[inline(always)]
    fn standard(&self, w: &mut Work) {
        let (n, m) = (self.n, self.m);
        for i in 0..n {
            for c in i..n {
                let mut acc = w.p[i * n + c];
                for j in 0..m {
                    for l in 0..LANES {
                        acc[l] -= w.k[i * m + j][l] * w.pht[c * m + j][l];
                    }
                }
                w.p[i * n + c] = acc;
                w.p[c * n + i] = acc;
            }
        }
    }

    /// Joseph's `P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ`, expanded as
    /// `P − K (P Hᵀ)ᵀ − (P Hᵀ) Kᵀ + K Σ Kᵀ` (the same matrix for any K, at O(n² m) instead
    /// of O(n³)) and computed by its upper triangle; Σ is the masked one, so a missing
    /// entry's zero gain column drops out.
    #[inline(always)]
    fn joseph(&self, w: &mut Work) {
        let (n, m) = (self.n, self.m);
        // K Σ (n×m), Σ from its lower triangle.
        for i in 0..n {
            for c in 0..m {
                let mut acc = [0.0; LANES];
                for j in 0..m {
                    let at = if j >= c { j * m + c } else { c * m + j };
                    for l in 0..LANES {
                        acc[l] += w.k[i * m + j][l] * w.s[at][l];
                    }
                }
                w.ks[i * m + c] = acc;
            }
        }
        for i in 0..n {
            for c in i..n {
                let mut acc = w.p[i * n + c];
                for j in 0..m {
                    for l in 0..LANES {
                        acc[l] += w.ks[i * m + j][l] * w.k[c * m + j][l]
                            - w.k[i * m + j][l] * w.pht[c * m + j][l]
                            - w.pht[i * m + j][l] * w.k[c * m + j][l];
                    }
                }
                w.p[i * n + c] = acc;
                w.p[c * n + i] = acc;
            }
        }
    }

    /// `x⁻ = F x⁺`, `P⁻ = F P⁺ Fᵀ + Q` (by its upper triangle).
    #[inline(always)]
    fn predict(&self, w: &mut Work) {
        let n = self.n;
        for i in 0..n {
            let mut acc = [0.0; LANES];
            for c in 0..n {
                let f = self.f[i * n + c];
                for l in 0..LANES {
                    acc[l] += f * w.x[c][l];
                }
            }
            w.t[i] = acc;
        }
        for i in 0..n {
            w.x[i] = w.t[i];
        }
        for i in 0..n {
            for c in 0..n {
                let mut acc = [0.0; LANES];
                for t in 0..n {
                    let f = self.f[i * n + t];
                    for l in 0..LANES {
                        acc[l] += f * w.p[t * n + c][l];
                    }
                }
                w.a[i * n + c] = acc;
            }
        }
        for i in 0..n {
            for c in i..n {
                let mut acc = [self.q[i * n + c]; LANES];
                for t in 0..n {
                    let f = self.f[c * n + t];
                    for l in 0..LANES {
                        acc[l] += w.a[i * n + t][l] * f;
                    }
                }
                w.p[i * n + c] = acc;
                w.p[c * n + i] = acc;
            }
        }
    }
}

/// The largest m the batch step's fixed buffers take.
const MAX_M: usize = 16;

/// The first of the `lanes` series whose state (named `x`) or a diagonal entry of whose
/// covariance (named `p`) is not finite, with the name and the value: one vector pass that
/// sums `0·v` (NaN if any v is not), and a search only when it is.
#[inline(always)]
fn non_finite(
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

fn in_series(series: usize, error: Error) -> Error {
    Error::InSeries {
        series,
        error: Box::new(error),
    }
}

/// One group's rows: every quantity a row of [`LANES`] numbers, matrices row-major.
struct Work {
    x: Vec<[f64; LANES]>,
    p: Vec<[f64; LANES]>,
    z: Vec<[f64; LANES]>,
    e: Vec<[f64; LANES]>,
    present: Vec<[f64; LANES]>,
    pht: Vec<[f64; LANES]>,
    sigma: Vec<[f64; LANES]>,
    k: Vec<[f64; LANES]>,
    ks: Vec<[f64; LANES]>,
    a: Vec<[f64; LANES]>,
    t: Vec<[f64; LANES]>,
    y: Vec<[f64; LANES]>,
    s: Vec<[f64; LANES]>,
}

impl Work {
    fn new(n: usize, m: usize) -> Self {
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
        }
    }
}

/// The part of a [`BatchOutput`] one group writes.
struct GroupOut<'a> {
    means: &'a mut [f64],
    covariances: Option<&'a mut [f64]>,
    last: &'a mut [f64],
    loglik: &'a mut [f64],
}

impl<'a> GroupOut<'a> {
    fn split(out: &'a mut BatchOutput, n: usize, steps: usize, cov: bool) -> Vec<Self> {
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
