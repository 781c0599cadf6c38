//! The fixed-lag smoother: streamed Rauch–Tung–Striebel estimates `x_{k−L|k}` over a window
//! of the last L + 1 steps of a linear, extended or unscented filter.
#![allow(non_snake_case)]

use faer::MatRef;

use std::sync::Arc;

use super::linalg::{mul, mul_nt, psd_cholesky, right_solve, symmetrise};
use super::{ForwardPass, Manifold};
use crate::storage::Dims;
use crate::{Error, Filter, PSD_TOL, RANK_TOL};

/// The fixed-lag smoother of lag L: after each recorded step k it holds the smoothed
/// estimates `x_{j|k}`, `P_{j|k}` of the last `min(L + 1, k + 1)` steps j = k − L … k given
/// the data up to k — among them `x_{k−L|k}`, the fixed-lag estimate ([`FixedLag::lagged`]).
///
/// The filter's steps go into a ring of L + 1 records (x_{j|j}, P_{j|j}, x_{j+1|j},
/// P_{j+1|j} and C_j = Cov(x_j, x_{j+1} | z_0..z_j), as the fixed-interval smoothers record
/// them), and each step runs the Rauch–Tung–Striebel backward pass from `(x_{k|k}, P_{k|k})`
/// over the window:
///
/// `J_j = C_j P_{j+1|j}⁻¹`,  `x_{j|k} = x_{j|j} + J_j (x_{j+1|k} − x_{j+1|j})`,
/// `P_{j|k} = P_{j|j} + J_j (P_{j+1|k} − P_{j+1|j}) J_jᵀ`,
///
/// `J_j` by a Cholesky solve (a zero pivot of a singular `P_{j+1|j}` gives a zero
/// component). The smoothed estimate of step j given data to k depends only on steps
/// j … k, so every estimate in the window is exactly the fixed-interval smoother's over the
/// data to k: at a lag at least the record's length the window after the last step *is*
/// the RTS smoother's output ([`crate::smoother::RtsSmoother`] for a [`Filter`],
/// [`super::NonlinearRts`] for an EKF or UKF). For a linear filter it also equals the
/// augmented-state fixed-lag smoother (Simon, "Optimal State Estimation", §9.2). A step
/// costs O(L n³) and allocates nothing: the ring and the workspaces are sized here.
///
/// ```
/// use kalman::nonlinear::FixedLag;
/// use kalman::smoother::RtsSmoother;
/// use kalman::{CovarianceForm, DynDims, Filter, Model};
///
/// // A random walk measured five times, smoothed with lag 2 and with the full RTS pass.
/// let model = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[0.5]], &[[1.0]])?;
/// let mut filter = Filter::new(model, &[0.0], &[[4.0]], CovarianceForm::Joseph)?;
/// let (mut lag, mut rts) = (FixedLag::new(1, 2)?, RtsSmoother::new());
/// for z in [1.0, 1.5, 0.7, 1.2, 2.0] {
///     filter.step(&[z], None)?;
///     lag.record_linear(&filter)?;
///     rts.record(&filter)?;
/// }
/// // After the last step: x_{2|4} is the fixed-lag estimate, and the window's
/// // estimates are the RTS smoother's for steps 2, 3, 4.
/// let (step, x, _) = lag.lagged().expect("five steps > lag 2");
/// let s = rts.smooth()?;
/// assert_eq!(step, 2);
/// assert!((x[0] - s.means[(0, 2)]).abs() < 1e-12);
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone)]
pub struct FixedLag {
    n: usize,
    /// Numbers per stored mean (n, or more on a manifold).
    stored: usize,
    /// The state's manifold, if any ([`FixedLag::with_manifold`]).
    space: Option<Arc<dyn Manifold + Send + Sync>>,
    lag: usize,
    steps: usize,
    /// The ring of records (slot = step mod (L + 1)).
    xf: Vec<f64>,
    pf: Vec<f64>,
    xp: Vec<f64>,
    pp: Vec<f64>,
    ct: Vec<f64>,
    /// The smoothed window: entry b is step k − b.
    xs: Vec<f64>,
    ps: Vec<f64>,
    /// Workspaces: the factor of P_{j+1|j} and its reciprocal pivots, J, and two scratches.
    l: Vec<f64>,
    inv: Vec<f64>,
    j: Vec<f64>,
    dx: Vec<f64>,
    dp: Vec<f64>,
    t: Vec<f64>,
}

impl core::fmt::Debug for FixedLag {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("FixedLag")
            .field("n", &self.n)
            .field("stored", &self.stored)
            .field("manifold", &self.space.is_some())
            .field("lag", &self.lag)
            .field("steps", &self.steps)
            .finish_non_exhaustive()
    }
}

/// What a [`FixedLag`] carries from step to step, to save and restore it
/// ([`FixedLag::state`], [`FixedLag::from_state`]): the ring of the last L + 1 records and
/// the smoothed window, each buffer in the smoother's layout (step slot `j mod (L + 1)`,
/// n×n blocks column-major).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FixedLagState {
    /// States n.
    pub n: usize,
    /// Numbers per stored mean: n for a vector state, more on a manifold (the means'
    /// buffers hold (L + 1)·stored).
    pub stored: usize,
    /// The lag L.
    pub lag: usize,
    /// Steps recorded.
    pub steps: usize,
    /// x_{j|j}, (L + 1)·stored.
    pub xf: Vec<f64>,
    /// P_{j|j}, (L + 1)·n².
    pub pf: Vec<f64>,
    /// x_{j+1|j}, (L + 1)·stored.
    pub xp: Vec<f64>,
    /// P_{j+1|j}, (L + 1)·n².
    pub pp: Vec<f64>,
    /// C_j, (L + 1)·n².
    pub ct: Vec<f64>,
    /// The smoothed means, entry b the step k − b, (L + 1)·stored.
    pub xs: Vec<f64>,
    /// The smoothed covariances, (L + 1)·n².
    pub ps: Vec<f64>,
}

impl FixedLag {
    /// What the smoother carries, for [`FixedLag::from_state`].
    pub fn state(&self) -> FixedLagState {
        FixedLagState {
            n: self.n,
            stored: self.stored,
            lag: self.lag,
            steps: self.steps,
            xf: self.xf.clone(),
            pf: self.pf.clone(),
            xp: self.xp.clone(),
            pp: self.pp.clone(),
            ct: self.ct.clone(),
            xs: self.xs.clone(),
            ps: self.ps.clone(),
        }
    }

    /// The smoother [`FixedLag::state`] saved (for a state on a manifold, follow with
    /// [`FixedLag::with_manifold`]).
    ///
    /// ```
    /// use kalman::nonlinear::FixedLag;
    /// let s = FixedLag::new(2, 3)?;
    /// assert_eq!(FixedLag::from_state(s.state())?.state(), s.state());
    /// let mut bad = s.state();
    /// bad.pf.pop();
    /// assert!(FixedLag::from_state(bad).is_err());
    /// # Ok::<(), kalman::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::Dimension`] naming `n` (zero) or `stored` (below n); [`Error::Shape`]
    /// naming the buffer whose length does not match n, the stored length and the lag; [`Error::NonFinite`] naming a buffer with a
    /// NaN or infinite entry.
    pub fn from_state(state: FixedLagState) -> Result<Self, Error> {
        let (n, lag, ns) = (state.n, state.lag, state.stored);
        if ns < n {
            return Err(Error::Dimension {
                name: "stored",
                value: ns,
                rule: "a stored mean holds at least n numbers",
            });
        }
        let FixedLagState {
            xf,
            pf,
            xp,
            pp,
            ct,
            xs,
            ps,
            ..
        } = state;
        // The lengths are checked before anything is allocated: the buffers given bound
        // what the smoother allocates, whatever n and the lag say.
        let w = lag.checked_add(1);
        let vec_len = w.and_then(|w| w.checked_mul(ns));
        let mat_len = w.and_then(|w| w.checked_mul(n)?.checked_mul(n));
        let bufs = [
            ("xf", xf, vec_len),
            ("pf", pf, mat_len),
            ("xp", xp, vec_len),
            ("pp", pp, mat_len),
            ("ct", ct, mat_len),
            ("xs", xs, vec_len),
            ("ps", ps, mat_len),
        ];
        for (name, buf, len) in &bufs {
            if Some(buf.len()) != *len {
                return Err(Error::Shape {
                    name,
                    rows: buf.len(),
                    cols: 1,
                    expected_rows: len.unwrap_or(usize::MAX),
                    expected_cols: 1,
                });
            }
            if let Some(row) = buf.iter().position(|v| !v.is_finite()) {
                return Err(Error::NonFinite {
                    name,
                    rows: buf.len(),
                    cols: 1,
                    row,
                    col: 0,
                });
            }
        }
        let mut out = Self::new(n, lag)?;
        out.stored = ns;
        let [xf, pf, xp, pp, ct, xs, ps] = bufs.map(|(_, buf, _)| buf);
        (out.xf, out.pf, out.xp, out.pp, out.ct, out.xs, out.ps) = (xf, pf, xp, pp, ct, xs, ps);
        out.steps = state.steps;
        Ok(out)
    }

    /// A smoother of `n` states and lag `lag` (0 gives the filtered estimates).
    ///
    /// # Errors
    /// [`Error::Dimension`] if n is 0.
    pub fn new(n: usize, lag: usize) -> Result<Self, Error> {
        if n == 0 {
            return Err(Error::Dimension {
                name: "n",
                value: 0,
                rule: "the fixed-lag smoother needs at least one state",
            });
        }
        let w = lag + 1;
        Ok(Self {
            n,
            stored: n,
            space: None,
            lag,
            steps: 0,
            xf: vec![0.0; w * n],
            pf: vec![0.0; w * n * n],
            xp: vec![0.0; w * n],
            pp: vec![0.0; w * n * n],
            ct: vec![0.0; w * n * n],
            xs: vec![0.0; w * n],
            ps: vec![0.0; w * n * n],
            l: vec![0.0; n * n],
            inv: vec![0.0; n],
            j: vec![0.0; n * n],
            dx: vec![0.0; n],
            dp: vec![0.0; n * n],
            t: vec![0.0; n * n],
        })
    }

    /// The smoother for a state on the manifold `space` (the model's, see
    /// [`super::FnModel::with_manifold`]): the window's means are stored points and
    /// `x_{j|k} = x_{j|j} ⊞ J_j (x_{j+1|k} ⊟ x_{j+1|j})`, the covariances tangent, as in
    /// [`super::NonlinearRts::smooth_on`]. Before any step is recorded, or on a smoother
    /// restored from the state of one on `space`.
    ///
    /// # Errors
    /// [`Error::Dimension`] naming `manifold` if `space`'s tangent dimension is not n, or
    /// its stored length is neither n (a fresh smoother) nor the restored state's.
    pub fn with_manifold(
        mut self,
        space: impl Manifold + Send + Sync + 'static,
    ) -> Result<Self, Error> {
        let fresh = self.steps == 0 && self.stored == self.n;
        if space.dim() != self.n || !(fresh || space.stored() == self.stored) {
            return Err(Error::Dimension {
                name: "manifold",
                value: space.stored(),
                rule: "the manifold must have the smoother's n and stored length",
            });
        }
        let ns = space.stored();
        if ns != self.stored {
            let w = self.lag + 1;
            (self.xf, self.xp, self.xs) = (vec![0.0; w * ns], vec![0.0; w * ns], vec![0.0; w * ns]);
            self.stored = ns;
        }
        self.space = Some(Arc::new(space));
        Ok(self)
    }

    /// The lag L.
    pub fn lag(&self) -> usize {
        self.lag
    }

    /// Steps recorded.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Steps in the smoothed window, `min(L + 1, steps)`.
    pub fn window(&self) -> usize {
        self.steps.min(self.lag + 1)
    }

    /// Records the step an EKF or UKF (any [`ForwardPass`]) has just taken and smooths the
    /// window.
    ///
    /// # Errors
    /// [`Error::Dimension`] if the filter's n is not the smoother's (nothing is recorded);
    /// [`Error::Factorisation`] naming `P_{k+1|k}` if a recorded prediction is not PSD.
    pub fn record(&mut self, filter: &impl ForwardPass) -> Result<(), Error> {
        let (n, ns) = (self.n, self.stored);
        let (xf, pf) = filter.filtered();
        let (xp, pp) = filter.predicted();
        if pf.len() != n * n || pp.len() != n * n {
            return Err(mismatch(pf.len().isqrt()));
        }
        if xf.len() != ns || xp.len() != ns {
            return Err(Error::Dimension {
                name: "stored",
                value: xf.len(),
                rule: "the filter's stored mean must have the smoother's length \
                       (a state on a manifold: FixedLag::with_manifold)",
            });
        }
        let s = self.steps % (self.lag + 1);
        self.xf[s * ns..(s + 1) * ns].copy_from_slice(xf);
        self.xp[s * ns..(s + 1) * ns].copy_from_slice(xp);
        self.pf[s * n * n..(s + 1) * n * n].copy_from_slice(pf);
        self.pp[s * n * n..(s + 1) * n * n].copy_from_slice(pp);
        filter.cross_covariance(&mut self.ct[s * n * n..(s + 1) * n * n]);
        self.steps += 1;
        self.smooth_window()
    }

    /// Records the step a linear [`Filter`] has just taken with its own model
    /// (`C_k = P_{k|k} Fᵀ − K_k Sᵀ`, as [`crate::smoother::RtsSmoother`] records it) and
    /// smooths the window.
    ///
    /// # Errors
    /// As [`FixedLag::record`].
    pub fn record_linear<D: Dims>(&mut self, filter: &Filter<D>) -> Result<(), Error> {
        let n = self.n;
        if filter.state().len() != n || self.stored != n {
            return Err(mismatch(filter.state().len()));
        }
        let s = self.steps % (self.lag + 1);
        let (Pf, Pp, F) = (
            filter.covariance(),
            filter.predicted_covariance(),
            filter.model().f(),
        );
        self.xf[s * n..(s + 1) * n].copy_from_slice(filter.state());
        self.xp[s * n..(s + 1) * n].copy_from_slice(filter.predicted_state());
        let m = filter.model().dims().m();
        let (K, S) = (filter.gain(), filter.model().s());
        for c in 0..n {
            for r in 0..n {
                let at = s * n * n + r + c * n;
                self.pf[at] = Pf[(r, c)];
                self.pp[at] = Pp[(r, c)];
                // (P Fᵀ)_{rc} = Σ_i P_ri F_ci, minus (K Sᵀ)_{rc} = Σ_a K_ra S_ca.
                let mut v: f64 = (0..n).map(|i| Pf[(r, i)] * F[(c, i)]).sum();
                if let Some(S) = S {
                    v -= (0..m).map(|a| K[(r, a)] * S[(c, a)]).sum::<f64>();
                }
                self.ct[at] = v;
            }
        }
        self.steps += 1;
        self.smooth_window()
    }

    /// `(j, x_{j|k}, P_{j|k})` for j = k − `back` (k the last recorded step), or `None` if
    /// `back` is outside the window.
    pub fn smoothed(&self, back: usize) -> Option<(usize, &[f64], MatRef<'_, f64>)> {
        if back >= self.window() {
            return None;
        }
        let (n, ns) = (self.n, self.stored);
        Some((
            self.steps - 1 - back,
            &self.xs[back * ns..(back + 1) * ns],
            MatRef::from_column_major_slice(&self.ps[back * n * n..(back + 1) * n * n], n, n),
        ))
    }

    /// The fixed-lag estimate `(k − L, x_{k−L|k}, P_{k−L|k})`, once more than L steps are
    /// recorded.
    pub fn lagged(&self) -> Option<(usize, &[f64], MatRef<'_, f64>)> {
        if self.steps > self.lag {
            self.smoothed(self.lag)
        } else {
            None
        }
    }

    /// The backward pass over the window, from the newest record.
    fn smooth_window(&mut self) -> Result<(), Error> {
        let (n, w, ns) = (self.n, self.lag + 1, self.stored);
        let k = self.steps - 1;
        let slot = |j: usize| j % w;
        let s = slot(k);
        self.xs[..ns].copy_from_slice(&self.xf[s * ns..(s + 1) * ns]);
        self.ps[..n * n].copy_from_slice(&self.pf[s * n * n..(s + 1) * n * n]);
        for back in 1..self.window() {
            let s = slot(k - back);
            let nn = n * n;
            let Pp = &self.pp[s * nn..(s + 1) * nn];
            psd_cholesky(Pp, n, &mut self.l, &mut self.inv, RANK_TOL, PSD_TOL).map_err(|_| {
                Error::Factorisation {
                    name: "P_{k+1|k}",
                    reason: "a recorded prediction covariance is not positive semidefinite",
                }
            })?;
            // J = C (L Lᵀ)⁻¹.
            self.j.copy_from_slice(&self.ct[s * nn..(s + 1) * nn]);
            right_solve(&self.l, &self.inv, n, &mut self.j, n);
            let (done, todo) = (back - 1, back);
            // x_{j|k} = x_{j|j} ⊞ J (x_{j+1|k} ⊟ x_{j+1|j}) (+ and − for a vector state).
            let (before, after) = self.xs.split_at_mut(todo * ns);
            let (next, x) = (&before[done * ns..], &mut after[..ns]);
            let (xf, xp) = (
                &self.xf[s * ns..(s + 1) * ns],
                &self.xp[s * ns..(s + 1) * ns],
            );
            match &self.space {
                None => {
                    for i in 0..n {
                        self.dx[i] = next[i] - xp[i];
                    }
                    x.copy_from_slice(xf);
                    mul(x, &self.j, &self.dx, n, n, 1, true);
                }
                Some(space) => {
                    space.boxminus(next, xp, &mut self.dx);
                    self.t[..n].fill(0.0);
                    mul(&mut self.t[..n], &self.j, &self.dx, n, n, 1, true);
                    space.boxplus(xf, &self.t[..n], x);
                }
            }
            // P_{j|k} = P_{j|j} + J (P_{j+1|k} − P_{j+1|j}) Jᵀ.
            for i in 0..nn {
                self.dp[i] = self.ps[done * nn + i] - Pp[i];
            }
            mul(&mut self.t, &self.j, &self.dp, n, n, n, false);
            let P = &mut self.ps[todo * nn..(todo + 1) * nn];
            P.copy_from_slice(&self.pf[s * nn..(s + 1) * nn]);
            mul_nt(P, &self.t, &self.j, n, n, n, true);
            symmetrise(P, n);
        }
        Ok(())
    }
}

/// The error for a filter whose n (`value`) is not the smoother's.
fn mismatch(value: usize) -> Error {
    Error::Dimension {
        name: "n",
        value,
        rule: "the fixed-lag smoother's n must match the filter's",
    }
}
