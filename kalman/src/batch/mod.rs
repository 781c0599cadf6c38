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
use crate::model::{MatrixInput, checked_factor, load, load_vec};
use crate::{CovarianceForm, Dims, Error, Model};

mod work;

use work::{DET_RANGE, GroupOut, Loglik, Work, in_series, non_finite};

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
        checked_factor("P0", &mut p, n, &mut vec![0.0; n * n])?;
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
            macro_rules! sized {
                ($($nn:literal, $mm:literal);*) => {
                    match (n, m) {
                        $(($nn, $mm) => arch.dispatch(
                            #[inline(always)]
                            || self.group::<$nn, $mm>(g, series, steps, zs, prior, slot),
                        ),)*
                        _ => arch.dispatch(
                            #[inline(always)]
                            || self.group::<0, 0>(g, series, steps, zs, prior, slot),
                        ),
                    }
                };
            }
            sized!(1, 1; 2, 1; 2, 2; 3, 1; 3, 2; 4, 1; 4, 2; 6, 1; 6, 2; 6, 3)
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

    /// `(n, m)`: the compile-time sizes `N`, `M` where they are not 0 (so the kernels'
    /// loops unroll for the common small models), the model's own otherwise.
    #[inline(always)]
    fn sizes<const N: usize, const M: usize>(&self) -> (usize, usize) {
        (
            if N == 0 { self.n } else { N },
            if M == 0 { self.m } else { M },
        )
    }

    /// Filters group `g` (series `g·LANES ..`) into its slot of the output, with `N` and `M`
    /// the model's sizes known at compile time (0: known at run time).
    #[inline(always)]
    fn group<const N: usize, const M: usize>(
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
        let mut loglik = Loglik::new();
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
            if let Some((l, pivot, tol)) = self.update::<N, M>(&mut w, &mut loglik) {
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
            self.predict::<N>(&mut w);
            let (x, p) = ("x_{k+1|k}", "P_{k+1|k}");
            if let Some((l, what, value)) = non_finite(&w, n, lanes, x, p) {
                let step = k;
                return Err(in_series(first + l, Error::Diverged { step, what, value }));
            }
        }
        slot.loglik[..lanes].copy_from_slice(&loglik.total()[..lanes]);
        Ok(())
    }

    /// The measurement update of every lane; the lane, pivot and tolerance of a singular
    /// innovation covariance if one is.
    #[inline(always)]
    fn update<const N: usize, const M: usize>(
        &self,
        w: &mut Work,
        loglik: &mut Loglik,
    ) -> Option<(usize, f64, f64)> {
        let (n, m) = self.sizes::<N, M>();
        let Work {
            e,
            inv,
            k,
            p,
            pht,
            present,
            s,
            sigma,
            x,
            y,
            z,
            ..
        } = &mut *w;
        let e = &mut e[..m];
        let inv = &mut inv[..m];
        let k = &mut k[..n * m];
        let p = &mut p[..n * n];
        let pht = &mut pht[..n * m];
        let present = &mut present[..m];
        let s = &mut s[..m * m];
        let sigma = &mut sigma[..m * m];
        let x = &mut x[..n];
        let y = &mut y[..m];
        let z = &mut z[..m];
        // Masked innovation e and H x.
        for j in 0..m {
            let mut hx = [0.0; LANES];
            for c in 0..n {
                let h = self.h[j * n + c];
                for l in 0..LANES {
                    hx[l] += h * x[c][l];
                }
            }
            for l in 0..LANES {
                let seen = !z[j][l].is_nan();
                present[j][l] = if seen { 1.0 } else { 0.0 };
                e[j][l] = if seen { z[j][l] - hx[l] } else { 0.0 };
            }
        }
        // P Hᵀ (n×m), its columns masked.
        for i in 0..n {
            for j in 0..m {
                let mut acc = [0.0; LANES];
                for c in 0..n {
                    let h = self.h[j * n + c];
                    for l in 0..LANES {
                        acc[l] += p[i * n + c][l] * h;
                    }
                }
                for l in 0..LANES {
                    pht[i * m + j][l] = acc[l] * present[j][l];
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
                        acc[l] += h * pht[i * m + c][l];
                    }
                }
                let r = self.r[j * m + c];
                for l in 0..LANES {
                    let both = present[j][l] * present[c][l];
                    let unit = if j == c { 1.0 - present[j][l] } else { 0.0 };
                    sigma[j * m + c][l] = both * (acc[l] + r) + unit;
                }
            }
        }
        // Σ kept for the Joseph form; Cholesky Σ = L Lᵀ, lane by lane in lockstep (L in the
        // lower triangle of `sigma`).
        s.copy_from_slice(sigma);
        let mut largest = [0.0f64; LANES];
        for j in 0..m {
            for l in 0..LANES {
                largest[l] = largest[l].max(sigma[j * m + j][l]);
            }
        }
        for j in 0..m {
            for c in 0..j {
                let mut acc = sigma[j * m + c];
                for t in 0..c {
                    for l in 0..LANES {
                        acc[l] -= sigma[j * m + t][l] * sigma[c * m + t][l];
                    }
                }
                for l in 0..LANES {
                    sigma[j * m + c][l] = acc[l] * inv[c][l];
                }
            }
            let mut d = sigma[j * m + j];
            for t in 0..j {
                for l in 0..LANES {
                    d[l] -= sigma[j * m + t][l] * sigma[j * m + t][l];
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
                let root = d[l].sqrt();
                sigma[j * m + j][l] = root;
                inv[j][l] = 1.0 / root;
            }
        }
        // Kᵀ = Σ⁻¹ (P Hᵀ)ᵀ by two triangular solves per row of P Hᵀ; v = L⁻¹ e alongside.
        for i in 0..=n {
            // Row i of P Hᵀ (i < n), or the innovation (i = n).
            for j in 0..m {
                y[j] = if i < n { pht[i * m + j] } else { e[j] };
                for t in 0..j {
                    for l in 0..LANES {
                        y[j][l] -= sigma[j * m + t][l] * y[t][l];
                    }
                }
                for l in 0..LANES {
                    y[j][l] *= inv[j][l];
                }
            }
            if i == n {
                // ln L = −½ (|L⁻¹e|² + ln det Σ + present · ln 2π), det Σ = Π L_jj²
                // (a missing entry's unit pivot adds nothing) into the running product.
                for l in 0..LANES {
                    let mut quad = 0.0;
                    let mut det = 1.0;
                    let mut seen = 0.0;
                    for j in 0..m {
                        quad += y[j][l] * y[j][l];
                        det *= sigma[j * m + j][l] * sigma[j * m + j][l];
                        seen += present[j][l];
                    }
                    loglik.sum[l] -= 0.5 * (quad + seen * LN_2PI);
                    if det >= DET_RANGE.0 && det <= DET_RANGE.1 {
                        loglik.det[l] *= det;
                    } else {
                        // A step's own det Σ beyond 2^±500 (or its product over- or
                        // underflowing): its logarithm pivot by pivot.
                        for j in 0..m {
                            loglik.sum[l] -= sigma[j * m + j][l].ln();
                        }
                    }
                }
                loglik.keep_in_range();
                break;
            }
            for j in (0..m).rev() {
                for t in j + 1..m {
                    for l in 0..LANES {
                        y[j][l] -= sigma[t * m + j][l] * y[t][l];
                    }
                }
                for l in 0..LANES {
                    y[j][l] *= inv[j][l];
                }
            }
            for j in 0..m {
                k[i * m + j] = y[j];
            }
        }
        // x⁺ = x + K e.
        for i in 0..n {
            for j in 0..m {
                for l in 0..LANES {
                    x[i][l] += k[i * m + j][l] * e[j][l];
                }
            }
        }
        match self.form {
            CovarianceForm::Standard => self.standard::<N, M>(w),
            _ => self.joseph::<N, M>(w),
        }
        None
    }

    /// `P⁺ = P − K (P Hᵀ)ᵀ`, the upper triangle computed and mirrored.
    #[inline(always)]
    fn standard<const N: usize, const M: usize>(&self, w: &mut Work) {
        let (n, m) = self.sizes::<N, M>();
        let Work { k, p, pht, .. } = &mut *w;
        let k = &mut k[..n * m];
        let p = &mut p[..n * n];
        let pht = &mut pht[..n * m];
        for i in 0..n {
            for c in i..n {
                let mut acc = p[i * n + c];
                for j in 0..m {
                    for l in 0..LANES {
                        acc[l] -= k[i * m + j][l] * pht[c * m + j][l];
                    }
                }
                p[i * n + c] = acc;
                p[c * n + i] = acc;
            }
        }
    }

    /// Joseph's `P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ`, expanded as
    /// `P − K (P Hᵀ)ᵀ − (P Hᵀ) Kᵀ + K Σ Kᵀ` (the same matrix for any K, at O(n² m) instead
    /// of O(n³)) and computed by its upper triangle; Σ is the masked one, so a missing
    /// entry's zero gain column drops out.
    #[inline(always)]
    fn joseph<const N: usize, const M: usize>(&self, w: &mut Work) {
        let (n, m) = self.sizes::<N, M>();
        let Work {
            k, ks, p, pht, s, ..
        } = &mut *w;
        let k = &mut k[..n * m];
        let ks = &mut ks[..n * m];
        let p = &mut p[..n * n];
        let pht = &mut pht[..n * m];
        let s = &mut s[..m * m];
        // K Σ (n×m), Σ from its lower triangle.
        for i in 0..n {
            for c in 0..m {
                let mut acc = [0.0; LANES];
                for j in 0..m {
                    let at = if j >= c { j * m + c } else { c * m + j };
                    for l in 0..LANES {
                        acc[l] += k[i * m + j][l] * s[at][l];
                    }
                }
                ks[i * m + c] = acc;
            }
        }
        for i in 0..n {
            for c in i..n {
                let mut acc = p[i * n + c];
                for j in 0..m {
                    for l in 0..LANES {
                        acc[l] += ks[i * m + j][l] * k[c * m + j][l]
                            - k[i * m + j][l] * pht[c * m + j][l]
                            - pht[i * m + j][l] * k[c * m + j][l];
                    }
                }
                p[i * n + c] = acc;
                p[c * n + i] = acc;
            }
        }
    }

    /// `x⁻ = F x⁺`, `P⁻ = F P⁺ Fᵀ + Q` (by its upper triangle).
    #[inline(always)]
    fn predict<const N: usize>(&self, w: &mut Work) {
        let n = self.sizes::<N, 0>().0;
        let Work { a, p, t, x, .. } = &mut *w;
        let a = &mut a[..n * n];
        let p = &mut p[..n * n];
        let t = &mut t[..n];
        let x = &mut x[..n];
        for i in 0..n {
            let mut acc = [0.0; LANES];
            for c in 0..n {
                let f = self.f[i * n + c];
                for l in 0..LANES {
                    acc[l] += f * x[c][l];
                }
            }
            t[i] = acc;
        }
        x.copy_from_slice(t);
        for i in 0..n {
            for c in 0..n {
                let mut acc = [0.0; LANES];
                for t in 0..n {
                    let f = self.f[i * n + t];
                    for l in 0..LANES {
                        acc[l] += f * p[t * n + c][l];
                    }
                }
                a[i * n + c] = acc;
            }
        }
        for i in 0..n {
            for c in i..n {
                let mut acc = [self.q[i * n + c]; LANES];
                for t in 0..n {
                    let f = self.f[c * n + t];
                    for l in 0..LANES {
                        acc[l] += a[i * n + t][l] * f;
                    }
                }
                p[i * n + c] = acc;
                p[c * n + i] = acc;
            }
        }
    }
}

/// The largest m the batch step's fixed buffers take.
const MAX_M: usize = 16;
