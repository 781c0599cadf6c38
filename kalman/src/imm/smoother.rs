//! The IMM smoother: a recorded forward pass ([`ImmRecord`], filled by
//! [`Imm::step_recorded`](super::Imm::step_recorded)) and one backward pass with smoothed
//! mode probabilities.
//!
//! # Form
//! A low-complexity backward recursion in the spirit of R. Lopez and P. Danès,
//! "Low-complexity IMM smoothing for jump Markov nonlinear systems", IEEE Trans. Aerospace
//! and Electronic Systems 53(3), 2017: a backward mixing step (the dual of the forward one)
//! and one Rauch–Tung–Striebel step per mode, so r RTS steps per time step (not the r² of
//! C.-J. Kim's, "Dynamic linear models with Markov-switching", J. Econometrics 60, 1994, or
//! of Helmick, Blair and Hoffman's pairwise forms). The backward mixing weighs the modes by
//! Kim's backward transition probabilities alone; Lopez and Danès's full interaction step,
//! which also weighs each pair of modes by the likelihood of its backward prediction, is not
//! implemented. With μ^j_k the filtered mode probabilities and
//! `c^l_{k+1} = Σ_i Π_il μ^i_k`:
//! 1. backward transition probabilities `b_{jl} = Π_jl μ^j_k / c^l_{k+1}` and the smoothed
//!    mode probabilities `μ^j_{k|N} = Σ_l b_{jl} μ^l_{k+1|N}`;
//! 2. backward mixing: `w_{l|j} = b_{jl} μ^l_{k+1|N} / μ^j_{k|N}`,
//!    `x̃^j = Σ_l w_{l|j} x^{l→j}_{k+1|N}`, `P̃^j = Σ_l w_{l|j}(P^{l→j}_{k+1|N} + spread)`
//!    (a component of mode j that mode l lacks taken from mode j's own `x^j_{k+1|N}`, as in
//!    the forward mixing);
//! 3. the mode-matched RTS step from the mode's own (unmixed) posterior and its prediction
//!    by the mode's model, `x̂^j_{k+1|k}, P̂^j_{k+1|k}, C^j_k` (recorded by an extra
//!    prediction per mode in the recorded forward step):
//!    `G = C^j_k (P̂^j_{k+1|k})⁻¹` (a Cholesky solve),
//!    `x^j_{k|N} = x^j_{k|k} + G (x̃^j − x̂^j_{k+1|k})`,
//!    `P^j_{k|N} = P^j_{k|k} + G (P̃^j − P̂^j_{k+1|k}) Gᵀ`;
//! 4. the combined smoothed estimate over the common state with `μ_{k|N}`, as the filter's.
//!
//! At the last step the smoothed estimates are the filtered ones. With one mode, or with
//! identical modes, this is exactly the RTS smoother. Where a quiet mode's smoothed estimate
//! inside a manoeuvre is mixed back along the leg before it, the smoother can be worse than
//! the filter on that leg (the price of the probability-only weights above).
#![allow(non_snake_case)]

use faer::Mat;

use super::ops::ModeOps;
use super::{Imm, ImmStep, Moments, Structure, mixing_probabilities};
use crate::Error;

/// A recorded IMM forward pass: per step the mode probabilities, and per mode the
/// mode-matched posterior, its one-step prediction and the cross-covariance `C_k`.
///
/// ```
/// use kalman::imm::{Embedding, Imm, ImmRecord, Mode};
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
/// # fn main() -> Result<(), kalman::Error> {
/// let mode = |q: f64| -> Result<Box<dyn Mode>, kalman::Error> {
///     let m = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[q]], &[[1.0]])?;
///     Ok(Box::new(Filter::new(m, &[0.0], &[[1.0]], CovarianceForm::Joseph)?))
/// };
/// // One mode: the IMM smoother is the RTS smoother (here x = (1, 2), see `smoother`).
/// let mut imm = Imm::new(vec![(mode(1.0)?, Embedding::identity(1))], &[[1.0]], &[1.0])?;
/// let mut rec = ImmRecord::new();
/// for z in [1.0, 3.0] {
///     imm.step_recorded(&[z], None, &mut rec)?;
/// }
/// let s = rec.smooth()?;
/// assert!((s.means[(0, 0)] - 1.0).abs() < 1e-12 && (s.means[(0, 1)] - 2.0).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, Default)]
pub struct ImmRecord {
    s: Option<Structure>,
    steps: usize,
    mu: Vec<f64>,
    xf: Vec<f64>,
    pf: Vec<f64>,
    xp: Vec<f64>,
    pp: Vec<f64>,
    cc: Vec<f64>,
    scratch: Vec<f64>,
}

/// The smoothed estimates: column k of `means` is `x_{k|N}` in the common state,
/// `covariances[k]` is `P_{k|N}`, column k of `mode_probabilities` is `μ_{k|N}`.
///
/// ```
/// use kalman::imm::{Embedding, Imm, ImmRecord, Mode};
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
/// # fn main() -> Result<(), kalman::Error> {
/// let mode = || -> Result<Box<dyn Mode>, kalman::Error> {
///     let m = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.1]], &[[1.0]])?;
///     Ok(Box::new(Filter::new(m, &[0.0], &[[1.0]], CovarianceForm::Joseph)?))
/// };
/// let pi = [[0.8, 0.2], [0.3, 0.7]];
/// let modes = vec![(mode()?, Embedding::identity(1)), (mode()?, Embedding::identity(1))];
/// let mut imm = Imm::new(modes, &pi, &[0.5, 0.5])?;
/// let mut rec = ImmRecord::new();
/// for z in [0.2, 0.4, 0.1] {
///     imm.step_recorded(&[z], None, &mut rec)?;
/// }
/// let s = rec.smooth()?;
/// // Each column of smoothed mode probabilities sums to one.
/// for k in 0..3 {
///     assert!((s.mode_probabilities[(0, k)] + s.mode_probabilities[(1, k)] - 1.0).abs() < 1e-12);
/// }
/// assert_eq!(s.covariances.len(), 3);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct ImmSmoothed {
    /// n_c × N.
    pub means: Mat<f64>,
    /// N matrices n_c × n_c.
    pub covariances: Vec<Mat<f64>>,
    /// r × N.
    pub mode_probabilities: Mat<f64>,
}

impl Imm {
    /// [`Imm::step`], recording into `rec` what the smoother needs (one extra prediction
    /// per mode, from its own posterior; the record grows, so this allocates).
    ///
    /// # Errors
    /// As [`Imm::step`]; [`Error::Dimension`] naming `record` if `rec` holds another IMM's
    /// steps (a different number of modes or embeddings).
    pub fn step_recorded(
        &mut self,
        z: &[f64],
        u: Option<&[f64]>,
        rec: &mut ImmRecord,
    ) -> Result<ImmStep, Error> {
        if let Some(s) = &rec.s
            && (s.r != self.s.r || s.emb != self.s.emb)
        {
            return Err(Error::Dimension {
                name: "record",
                value: self.s.r,
                rule: "a record holds the steps of one IMM (same modes and embeddings)",
            });
        }
        self.step_inner(z, u, Some(rec))
    }
}

impl ImmRecord {
    /// An empty record.
    pub fn new() -> Self {
        Self::default()
    }

    /// Steps recorded.
    pub fn len(&self) -> usize {
        self.steps
    }

    /// Whether no step is recorded.
    pub fn is_empty(&self) -> bool {
        self.steps == 0
    }

    /// Starts a step: the structure (first time) and μ_k.
    pub(super) fn begin(&mut self, imm: &Imm) {
        if self.s.is_none() {
            self.s = Some(imm.s.clone());
        }
        self.mu.extend_from_slice(&imm.mu);
        self.steps += 1;
    }

    /// Mode j's posterior, prediction and cross-covariance, just after its mode-matched
    /// prediction.
    pub(super) fn push_mode(&mut self, f: &dyn ModeOps, n: usize) {
        let (x, P) = f.mode_posterior();
        self.xf.extend_from_slice(x);
        self.pf.extend_from_slice(P);
        let (x, P) = f.mode_prior();
        self.xp.extend_from_slice(x);
        self.pp.extend_from_slice(P);
        self.scratch.resize(n * n, 0.0);
        f.mode_cross_covariance(&mut self.scratch);
        self.cc.extend_from_slice(&self.scratch[..n * n]);
    }

    /// The backward pass.
    ///
    /// # Errors
    /// [`Error::Dimension`] naming `record` if it is empty; [`Error::NotPositiveDefinite`]
    /// naming `P_{k+1|k}` if a mode's prediction covariance is not positive definite.
    pub fn smooth(&self) -> Result<ImmSmoothed, Error> {
        let Some(s) = self.s.as_ref().filter(|_| self.steps > 0) else {
            return Err(Error::Dimension {
                name: "record",
                value: 0,
                rule: "the smoother needs at least one recorded step",
            });
        };
        let (r, nc, N) = (s.r, s.nc, self.steps);
        let ns: Vec<usize> = (0..r).map(|j| s.n(j)).collect();
        let (mut off, mut offp) = (vec![0; r], vec![0; r]);
        let (mut a, mut b) = (0, 0);
        for j in 0..r {
            off[j] = a;
            offp[j] = b;
            a += ns[j];
            b += ns[j] * ns[j];
        }
        let (sa, sb) = (a, b);
        let blk = |k: usize, j: usize, sq: bool| -> std::ops::Range<usize> {
            if sq {
                k * sb + offp[j]..k * sb + offp[j] + ns[j] * ns[j]
            } else {
                k * sa + off[j]..k * sa + off[j] + ns[j]
            }
        };
        // Smoothed per-mode estimates at k + 1 (next) and k (cur).
        let mut xn = self.xf[(N - 1) * sa..N * sa].to_vec();
        let mut pn = self.pf[(N - 1) * sb..N * sb].to_vec();
        let mut mun = self.mu[(N - 1) * r..N * r].to_vec();
        let (mut xc, mut pc, mut muc) = (xn.clone(), pn.clone(), mun.clone());
        let mut means = Mat::<f64>::zeros(nc, N);
        let mut covariances = vec![Mat::<f64>::zeros(nc, nc); N];
        let mut probs = Mat::<f64>::zeros(r, N);
        let (mut ex, mut ep) = (vec![0.0; nc], vec![0.0; nc * nc]);
        let (mut xt, mut pt) = (vec![0.0; nc], vec![0.0; nc * nc]);
        let (mut L, mut G, mut d, mut T) = (
            vec![0.0; nc * nc],
            vec![0.0; nc * nc],
            vec![0.0; nc],
            vec![0.0; nc * nc],
        );
        let (mut bjl, mut cpred) = (vec![0.0; r * r], vec![0.0; r]);
        let mut out = |k: usize, x: &[f64], P: &[f64], mu: &[f64]| {
            let (mut cx, mut cp) = (vec![0.0; nc], vec![0.0; nc * nc]);
            let (mut lx, mut lp) = (vec![0.0; nc], vec![0.0; nc * nc]);
            for pass in 0..2 {
                for i in 0..r {
                    let (xi, Pi) = (
                        &x[off[i]..off[i] + ns[i]],
                        &P[offp[i]..offp[i] + ns[i] * ns[i]],
                    );
                    s.lift(i, (xi, Pi), &mut lx, &mut lp);
                    if pass == 0 {
                        Moments::add_mean(mu[i], &lx, &mut cx);
                    } else {
                        Moments::add_spread(mu[i], (&lx, &lp), &cx, &mut cp);
                    }
                }
            }
            Moments::finish(&mut cp);
            for a in 0..nc {
                means[(a, k)] = cx[a];
                for b in 0..nc {
                    covariances[k][(a, b)] = cp[a + b * nc];
                }
            }
            for i in 0..r {
                probs[(i, k)] = mu[i];
            }
        };
        out(N - 1, &xn, &pn, &mun);
        for k in (0..N.saturating_sub(1)).rev() {
            let mu = &self.mu[k * r..(k + 1) * r];
            // 1. Backward transition (the mixing probabilities ω_{j|l}, bjl[j + l·r]) and
            // smoothed mode probabilities.
            mixing_probabilities(&s.pi, mu, &mut cpred, &mut bjl);
            for j in 0..r {
                muc[j] = (0..r).map(|l| bjl[j + l * r] * mun[l]).sum();
            }
            let total: f64 = muc.iter().sum();
            if total > 0.0 {
                for v in &mut muc {
                    *v /= total;
                }
            }
            for j in 0..r {
                let n = ns[j];
                let xj_next = &xn[off[j]..off[j] + n];
                let pj_next = &pn[offp[j]..offp[j] + n * n];
                // 2. Backward mixing into mode j.
                let (xt, pt) = (&mut xt[..n], &mut pt[..n * n]);
                if muc[j] > 0.0 {
                    Moments::clear(xt, pt);
                    for pass in 0..2 {
                        for l in 0..r {
                            let w =
                                bjl[j + l * r] * mun[l] / (muc[j] * total.max(f64::MIN_POSITIVE));
                            if w <= 0.0 {
                                continue;
                            }
                            let xl = &xn[off[l]..off[l] + ns[l]];
                            let pl = &pn[offp[l]..offp[l] + ns[l] * ns[l]];
                            s.project(
                                l,
                                (xl, pl),
                                j,
                                (xj_next, pj_next),
                                &mut ex[..n],
                                &mut ep[..n * n],
                            );
                            let (ex, ep) = (&ex[..n], &ep[..n * n]);
                            if pass == 0 {
                                Moments::add_mean(w, ex, xt);
                            } else {
                                Moments::add_spread(w, (ex, ep), xt, pt);
                            }
                        }
                    }
                    Moments::finish(pt);
                } else {
                    xt.copy_from_slice(xj_next);
                    pt.copy_from_slice(pj_next);
                }
                // 3. Mode-matched RTS step.
                let xf = &self.xf[blk(k, j, false)];
                let pf = &self.pf[blk(k, j, true)];
                let xp = &self.xp[blk(k, j, false)];
                let pp = &self.pp[blk(k, j, true)];
                let cc = &self.cc[blk(k, j, true)];
                let (L, G, d, T) = (
                    &mut L[..n * n],
                    &mut G[..n * n],
                    &mut d[..n],
                    &mut T[..n * n],
                );
                factor_prediction(pp, n, L).map_err(|_| Error::NotPositiveDefinite {
                    name: "P_{k+1|k}",
                    n,
                    rule: "an IMM mode's one-step prediction covariance must be positive definite",
                })?;
                // G P̂ = C: each row g of G solves P̂ gᵀ = (row of C)ᵀ.
                for i in 0..n {
                    for a in 0..n {
                        d[a] = cc[i + a * n];
                    }
                    crate::kernels::cholesky_solve(L, n, d);
                    for a in 0..n {
                        G[i + a * n] = d[a];
                    }
                }
                let xs = &mut xc[off[j]..off[j] + n];
                for a in 0..n {
                    d[a] = xt[a] - xp[a];
                }
                for a in 0..n {
                    xs[a] = xf[a] + (0..n).map(|b| G[a + b * n] * d[b]).sum::<f64>();
                }
                // T = (P̃ − P̂) Gᵀ, P = P_f + G T.
                for a in 0..n {
                    for b in 0..n {
                        T[a + b * n] = (0..n)
                            .map(|c| (pt[a + c * n] - pp[a + c * n]) * G[b + c * n])
                            .sum();
                    }
                }
                let ps = &mut pc[offp[j]..offp[j] + n * n];
                for a in 0..n {
                    for b in 0..n {
                        ps[a + b * n] = pf[a + b * n]
                            + (0..n).map(|c| G[a + c * n] * T[c + b * n]).sum::<f64>();
                    }
                }
                for a in 0..n {
                    for b in 0..a {
                        let v = 0.5 * (ps[a + b * n] + ps[b + a * n]);
                        ps[a + b * n] = v;
                        ps[b + a * n] = v;
                    }
                }
            }
            out(k, &xc, &pc, &muc);
            std::mem::swap(&mut xn, &mut xc);
            std::mem::swap(&mut pn, &mut pc);
            std::mem::swap(&mut mun, &mut muc);
        }
        Ok(ImmSmoothed {
            means,
            covariances,
            mode_probabilities: probs,
        })
    }
}

/// Lower Cholesky factor of the n×n column-major `A` into `L` (the kernels' factorisation);
/// `Err` at a pivot not above `RANK_TOL` times the largest diagonal entry.
fn factor_prediction(A: &[f64], n: usize, L: &mut [f64]) -> Result<(), ()> {
    let scale = (0..n).fold(0.0_f64, |s, i| s.max(A[i + i * n].abs()));
    L.copy_from_slice(&A[..n * n]);
    // A pivot below round-off of the diagonal's scale is a singular prediction.
    if crate::kernels::cholesky(L, n, crate::RANK_TOL * scale) {
        Ok(())
    } else {
        Err(())
    }
}
