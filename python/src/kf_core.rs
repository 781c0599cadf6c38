//! The arithmetic of the FilterPy-compatible `KalmanFilter`: FilterPy's predict, Joseph-form
//! update and correlated update (its `M`) on preallocated row-major buffers, plus the
//! missing-row handling FilterPy lacks. The Python layer (`kf.rs`) only moves data in and out.
#![allow(non_snake_case)]

use pyo3::PyResult;

use crate::convert::{entries, filled, memory_error, zeros};
use crate::linalg::{Factor, add_mul_vec, mul, mul_bt, mul_vec};

/// Why an update could not be computed.
#[derive(Debug)]
pub(crate) enum UpdateError {
    /// The innovation covariance S of the present rows is singular.
    SingularS,
}

/// State, model and last-step quantities, all row-major, sized once at construction.
#[derive(Debug, Clone)]
pub(crate) struct Core {
    pub n: usize,
    pub m: usize,
    pub p: usize,
    pub x: Vec<f64>,
    pub P: Vec<f64>,
    pub F: Vec<f64>,
    pub Q: Vec<f64>,
    pub H: Vec<f64>,
    pub R: Vec<f64>,
    /// n×p; `None` as FilterPy's `B = None` (no control).
    pub B: Option<Vec<f64>>,
    pub M: Vec<f64>,
    pub alpha_sq: f64,
    pub K: Vec<f64>,
    pub y: Vec<f64>,
    pub S: Vec<f64>,
    /// The last measurement (NaN where missing; all NaN for `None`).
    pub z: Vec<f64>,
    pub x_prior: Vec<f64>,
    pub P_prior: Vec<f64>,
    pub x_post: Vec<f64>,
    pub P_post: Vec<f64>,
    /// Indices of the rows used by the last update, and the factorisation of their S.
    pub rows: Vec<usize>,
    pub fac: Factor,
    /// Whether `fac` holds a factorisation (false before the first update).
    pub factored: bool,
    // Workspace.
    hr: Vec<f64>,
    rr: Vec<f64>,
    mr: Vec<f64>,
    yr: Vec<f64>,
    pht: Vec<f64>,
    kr: Vec<f64>,
    sr: Vec<f64>,
    st: Vec<f64>,
    hp: Vec<f64>,
    t1: Vec<f64>,
    t2: Vec<f64>,
    tx: Vec<f64>,
}

impl Core {
    /// FilterPy's defaults: x = 0, P = Q = F = I, H = 0, R = I, B = None, M = 0. Every
    /// buffer is allocated fallibly: dimensions too large for memory are a `MemoryError`.
    pub(crate) fn new(n: usize, m: usize, p: usize) -> PyResult<Self> {
        let what = "the KalmanFilter's buffers";
        let (nn, mm, nm) = (
            entries(n, n, what)?,
            entries(m, m, what)?,
            entries(n, m, what)?,
        );
        let eye = |k: usize, len: usize| -> PyResult<Vec<f64>> {
            let mut e = zeros(len, what)?;
            for i in 0..k {
                e[i * k + i] = 1.0;
            }
            Ok(e)
        };
        let z = |len: usize| zeros(len, what);
        Ok(Self {
            n,
            m,
            p,
            x: z(n)?,
            P: eye(n, nn)?,
            F: eye(n, nn)?,
            Q: eye(n, nn)?,
            H: z(nm)?,
            R: eye(m, mm)?,
            B: None,
            M: z(nm)?,
            alpha_sq: 1.0,
            K: z(nm)?,
            y: z(m)?,
            S: z(mm)?,
            z: filled(m, f64::NAN, what)?,
            x_prior: z(n)?,
            P_prior: eye(n, nn)?,
            x_post: z(n)?,
            P_post: eye(n, nn)?,
            rows: Vec::with_capacity(m),
            fac: Factor::try_new(m).ok_or_else(|| memory_error(mm, what))?,
            factored: false,
            hr: z(nm)?,
            rr: z(mm)?,
            mr: z(nm)?,
            yr: z(m)?,
            pht: z(nm)?,
            kr: z(nm)?,
            sr: z(mm)?,
            st: z(mm)?,
            hp: z(nm)?,
            t1: z(nn)?,
            t2: z(nn)?,
            tx: z(n)?,
        })
    }

    /// Factors S over `rows` again (after the state was restored from a pickle), so the
    /// likelihood, the Mahalanobis distance and SI read as before; `false` if S is singular.
    pub(crate) fn refactor(&mut self) -> bool {
        let (m, r) = (self.m, self.rows.len());
        for (a, &i) in self.rows.iter().enumerate() {
            for (b, &j) in self.rows.iter().enumerate() {
                self.st[b * r + a] = self.S[i * m + j];
            }
        }
        self.factored = self.fac.factor(&self.st[..r * r], r);
        self.factored
    }

    /// x = F x + B u (B u only with a control matrix and an input), P = α² F P Fᵀ + Q.
    /// `F`, `Q`, `B` override the filter's own for this call when given.
    pub(crate) fn predict(
        &mut self,
        u: Option<&[f64]>,
        F: Option<&[f64]>,
        Q: Option<&[f64]>,
        B: Option<&[f64]>,
    ) {
        let n = self.n;
        let F = F.unwrap_or(&self.F);
        let Q = Q.unwrap_or(&self.Q);
        mul_vec(F, &self.x, n, n, &mut self.tx);
        if let (Some(B), Some(u)) = (B.or(self.B.as_deref()), u) {
            add_mul_vec(B, u, &mut self.tx);
        }
        self.x.copy_from_slice(&self.tx);
        // F P Fᵀ is symmetric: its upper triangle, mirrored (half of the second product).
        mul(F, &self.P, n, n, n, &mut self.t1);
        for i in 0..n {
            let ti = &self.t1[i * n..(i + 1) * n];
            for j in i..n {
                let s: f64 = ti
                    .iter()
                    .zip(&F[j * n..(j + 1) * n])
                    .map(|(a, b)| a * b)
                    .sum();
                self.P[i * n + j] = self.alpha_sq * s + Q[i * n + j];
                self.P[j * n + i] = self.alpha_sq * s + Q[j * n + i];
            }
        }
        self.x_prior.copy_from_slice(&self.x);
        self.P_prior.copy_from_slice(&self.P);
    }

    /// FilterPy's `update` (`correlated == false`: Joseph form) or `update_correlated`
    /// (S = H P Hᵀ + H M + Mᵀ Hᵀ + R, K = (P Hᵀ + M) S⁻¹, P ← P − K (H P + Mᵀ)), over the
    /// rows of `z` that are not NaN. An all-NaN `z` is FilterPy's `z = None`: nothing is
    /// updated, y = 0, x_post/P_post = the prior. `R`, `H` override the filter's own.
    pub(crate) fn update(
        &mut self,
        z: &[f64],
        R: Option<&[f64]>,
        H: Option<&[f64]>,
        correlated: bool,
    ) -> Result<(), UpdateError> {
        self.update_with(z, None, R, H, correlated)
    }

    /// FilterPy's EKF update: the Joseph-form update with the innovation `y` given (the
    /// user's residual of z and h(x)) instead of z − H x, H the Jacobian; z is stored.
    pub(crate) fn update_innovation(
        &mut self,
        z: &[f64],
        y: &[f64],
        R: Option<&[f64]>,
        H: &[f64],
    ) -> Result<(), UpdateError> {
        self.update_with(z, Some(y), R, Some(H), false)
    }

    /// [`Core::update`], with the innovation of each row `y` when given.
    fn update_with(
        &mut self,
        z: &[f64],
        y: Option<&[f64]>,
        R: Option<&[f64]>,
        H: Option<&[f64]>,
        correlated: bool,
    ) -> Result<(), UpdateError> {
        let (n, m) = (self.n, self.m);
        self.z.copy_from_slice(z);
        self.rows.clear();
        self.rows.extend((0..m).filter(|&i| !z[i].is_nan()));
        if self.rows.is_empty() {
            self.y.fill(0.0);
            self.x_post.copy_from_slice(&self.x);
            self.P_post.copy_from_slice(&self.P);
            // FilterPy leaves K and S as they were; so do we, and the log-likelihood is
            // then that of y = 0 under the last S (FilterPy's behaviour).
            self.rows.extend(0..m);
            return Ok(());
        }
        let R = R.unwrap_or(&self.R);
        let H = H.unwrap_or(&self.H);
        let r = self.rows.len();
        // Gather the present rows.
        for (a, &i) in self.rows.iter().enumerate() {
            self.hr[a * n..(a + 1) * n].copy_from_slice(&H[i * n..(i + 1) * n]);
            for (b, &j) in self.rows.iter().enumerate() {
                self.rr[a * r + b] = R[i * m + j];
            }
            for k in 0..n {
                self.mr[k * r + a] = self.M[k * m + i];
            }
        }
        let (hr, rr, mr) = (&self.hr[..r * n], &self.rr[..r * r], &self.mr[..n * r]);
        // y = z − H x
        for (a, &i) in self.rows.iter().enumerate() {
            let hx: f64 = hr[a * n..(a + 1) * n]
                .iter()
                .zip(&self.x)
                .map(|(h, x)| h * x)
                .sum();
            self.yr[a] = y.map_or(z[i] - hx, |y| y[i]);
        }
        // PHT = P Hᵀ (n×r); S = H PHT + R (+ H M + Mᵀ Hᵀ).
        let pht = &mut self.pht[..n * r];
        mul_bt(&self.P, hr, n, n, r, pht);
        let sr = &mut self.sr[..r * r];
        mul(hr, pht, r, n, r, sr);
        for (s, v) in sr.iter_mut().zip(rr) {
            *s += v;
        }
        if correlated {
            // H M (r×r) and its transpose.
            for a in 0..r {
                for b in 0..r {
                    let hm: f64 = (0..n).map(|k| hr[a * n + k] * mr[k * r + b]).sum();
                    sr[a * r + b] += hm;
                    sr[b * r + a] += hm;
                }
            }
            for (p, mv) in pht.iter_mut().zip(mr) {
                *p += mv; // PHT + M
            }
        }
        // K = (PHT [+ M]) S⁻¹: Sᵀ Kᵀ = (PHT)ᵀ, solved with the factorisation of Sᵀ.
        for a in 0..r {
            for b in 0..r {
                self.st[a * r + b] = sr[b * r + a];
            }
        }
        if !self.fac.factor(&self.st[..r * r], r) {
            return Err(UpdateError::SingularS);
        }
        self.factored = true;
        let kt = &mut self.kr[..r * n];
        for a in 0..r {
            for k in 0..n {
                kt[a * n + k] = pht[k * r + a];
            }
        }
        self.fac.solve(kt, n);
        // x = x + K y
        for k in 0..n {
            self.x[k] += (0..r).map(|a| kt[a * n + k] * self.yr[a]).sum::<f64>();
        }
        if correlated {
            // P ← P − K (H P + Mᵀ)
            mul(hr, &self.P, r, n, n, &mut self.hp); // H P (r×n)
            for a in 0..r {
                for k in 0..n {
                    self.hp[a * n + k] += mr[k * r + a];
                }
            }
            for i in 0..n {
                for j in 0..n {
                    let s: f64 = (0..r).map(|a| kt[a * n + i] * self.hp[a * n + j]).sum();
                    self.P[i * n + j] -= s;
                }
            }
        } else {
            // Joseph form, FilterPy's P ← (I − K H) P (I − K H)ᵀ + K R Kᵀ, in O(n² r):
            // with A = (I − K H) P = P − K (H P), it is A + (K R − A Hᵀ) Kᵀ.
            mul(hr, &self.P, r, n, n, &mut self.hp); // H P (r×n)
            for i in 0..n {
                for j in 0..n {
                    let khp: f64 = (0..r).map(|a| kt[a * n + i] * self.hp[a * n + j]).sum();
                    self.t2[i * n + j] = self.P[i * n + j] - khp;
                }
            }
            let c = &mut self.pht[..n * r]; // K R − A Hᵀ (n×r)
            for i in 0..n {
                for a in 0..r {
                    let kr: f64 = (0..r).map(|b| kt[b * n + i] * rr[b * r + a]).sum();
                    let aht: f64 = (0..n).map(|j| self.t2[i * n + j] * hr[a * n + j]).sum();
                    c[i * r + a] = kr - aht;
                }
            }
            for i in 0..n {
                for j in 0..n {
                    let ck: f64 = (0..r).map(|a| c[i * r + a] * kt[a * n + j]).sum();
                    self.P[i * n + j] = self.t2[i * n + j] + ck;
                }
            }
        }
        // Scatter K, y, S back to full size (zeros in the rows/columns of missing entries).
        self.K.fill(0.0);
        self.y.fill(0.0);
        self.S.fill(0.0);
        for (a, &i) in self.rows.iter().enumerate() {
            self.y[i] = self.yr[a];
            for k in 0..n {
                self.K[k * m + i] = kt[a * n + k];
            }
            for (b, &j) in self.rows.iter().enumerate() {
                self.S[i * m + j] = sr[a * r + b];
            }
        }
        self.x_post.copy_from_slice(&self.x);
        self.P_post.copy_from_slice(&self.P);
        Ok(())
    }

    /// x = F x + B u (FilterPy's EKF `predict_x`; P unchanged).
    pub(crate) fn predict_x(&mut self, u: Option<&[f64]>) {
        mul_vec(&self.F, &self.x, self.n, self.n, &mut self.tx);
        if let (Some(B), Some(u)) = (self.B.as_deref(), u) {
            add_mul_vec(B, u, &mut self.tx);
        }
        self.x.copy_from_slice(&self.tx);
    }

    /// FilterPy's `update_sequential`: the Joseph-form update with the r rows of the
    /// measurement starting at row `start` (z_i, their noise covariance R_i r×r and their
    /// measurement rows H_i r×n), writing y, K and z in those rows only and leaving S and
    /// the likelihood of the last full update as they were (as FilterPy does).
    pub(crate) fn update_sequential(
        &mut self,
        start: usize,
        z_i: &[f64],
        R_i: &[f64],
        H_i: &[f64],
    ) -> Result<(), UpdateError> {
        let (n, m, r) = (self.n, self.m, z_i.len());
        let mut y = vec![0.0; r];
        mul_vec(H_i, &self.x, r, n, &mut y);
        for (yi, zi) in y.iter_mut().zip(z_i) {
            *yi = zi - *yi;
        }
        // S_i = H_i P H_iᵀ + R_i; K_iᵀ solves S_iᵀ K_iᵀ = (P H_iᵀ)ᵀ = H_i Pᵀ.
        let mut pht = vec![0.0; n * r];
        mul_bt(&self.P, H_i, n, n, r, &mut pht);
        let mut s = vec![0.0; r * r];
        mul(H_i, &pht, r, n, r, &mut s);
        let mut st = vec![0.0; r * r];
        for a in 0..r {
            for b in 0..r {
                st[a * r + b] = s[b * r + a] + R_i[b * r + a];
            }
        }
        let mut fac = Factor::new(r);
        if !fac.factor(&st, r) {
            return Err(UpdateError::SingularS);
        }
        let mut kt = vec![0.0; r * n];
        for a in 0..r {
            for k in 0..n {
                kt[a * n + k] = pht[k * r + a];
            }
        }
        fac.solve(&mut kt, n);
        let mut K = vec![0.0; n * r];
        for a in 0..r {
            for k in 0..n {
                K[k * r + a] = kt[a * n + k];
            }
        }
        // x += K_i y_i; P = (I − K_i H_i) P (I − K_i H_i)ᵀ + K_i R_i K_iᵀ, as FilterPy writes it.
        add_mul_vec(&K, &y, &mut self.x);
        let mut ikh = vec![0.0; n * n];
        mul(&K, H_i, n, r, n, &mut ikh);
        for (i, v) in ikh.iter_mut().enumerate() {
            let identity = if i % (n + 1) == 0 { 1.0 } else { 0.0 };
            *v = identity - *v;
        }
        let (mut a, mut b) = (vec![0.0; n * n], vec![0.0; n * n]);
        mul(&ikh, &self.P, n, n, n, &mut a);
        mul_bt(&a, &ikh, n, n, n, &mut b);
        let mut kr = vec![0.0; n * r];
        mul(&K, R_i, n, r, r, &mut kr);
        mul_bt(&kr, &K, n, r, n, &mut a);
        for ((p, u), v) in self.P.iter_mut().zip(&b).zip(&a) {
            *p = u + v;
        }
        for a in 0..r {
            self.y[start + a] = y[a];
            self.z[start + a] = z_i[a];
            for k in 0..n {
                self.K[k * m + start + a] = K[k * r + a];
            }
        }
        self.x_post.copy_from_slice(&self.x);
        self.P_post.copy_from_slice(&self.P);
        Ok(())
    }

    /// The y of the rows used by the last update.
    fn y_rows(&self, out: &mut Vec<f64>) {
        out.clear();
        out.extend(self.rows.iter().map(|&i| self.y[i]));
    }

    /// log N(y; 0, S) over the rows of the last update (FilterPy's `log_likelihood`).
    pub(crate) fn log_likelihood(&self) -> Option<f64> {
        if !self.factored {
            return None;
        }
        let mut y = Vec::with_capacity(self.m);
        self.y_rows(&mut y);
        let mut work = vec![0.0; y.len()];
        let q = self.fac.quad(&y, &mut work);
        let r = y.len() as f64;
        Some(-0.5 * (r * (2.0 * std::f64::consts::PI).ln() + self.fac.log_abs_det() + q))
    }

    /// sqrt(yᵀ S⁻¹ y) over the rows of the last update (FilterPy's `mahalanobis`).
    pub(crate) fn mahalanobis(&self) -> Option<f64> {
        if !self.factored {
            return None;
        }
        let mut y = Vec::with_capacity(self.m);
        self.y_rows(&mut y);
        let mut work = vec![0.0; y.len()];
        Some(self.fac.quad(&y, &mut work).max(0.0).sqrt())
    }

    /// S⁻¹ (m×m, zeros in the rows/columns of missing entries), by solving S X = I.
    pub(crate) fn si(&self) -> Vec<f64> {
        let m = self.m;
        let mut out = vec![0.0; m * m];
        if !self.factored {
            return out;
        }
        let r = self.rows.len();
        // The factor is of Sᵀ: solving Sᵀ X = I gives X = S⁻ᵀ, transposed on the way out.
        let mut e = vec![0.0; r * r];
        for a in 0..r {
            e[a * r + a] = 1.0;
        }
        self.fac.solve(&mut e, r);
        for (a, &i) in self.rows.iter().enumerate() {
            for (b, &j) in self.rows.iter().enumerate() {
                out[i * m + j] = e[b * r + a];
            }
        }
        out
    }
}

/// The smoother's outputs: means, covariances, gains, predicted covariances (row-major).
pub(crate) type Smoothed = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// A model matrix over a series of steps: the same at every step, or one per step (the
/// row-major matrices one after another).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Steps<'a> {
    Same(&'a [f64]),
    Each(&'a [f64]),
}

impl<'a> Steps<'a> {
    /// The matrix of step k (`size` entries).
    pub(crate) fn at(self, k: usize, size: usize) -> &'a [f64] {
        match self {
            Steps::Same(a) => a,
            Steps::Each(a) => &a[k * size..(k + 1) * size],
        }
    }
}

/// FilterPy's `rts_smoother`: returns (x, P, K, Pp) with the smoothed means (n_steps×n),
/// covariances and gains (n_steps×n×n) and the predicted covariances. The step from k to
/// k + 1 uses F_{k+1} and Q_{k+1}, FilterPy's index (the matrices `batch_filter` predicted
/// step k + 1 with), so F_0 and Q_0 are not used: Pp_k = F_{k+1} P_k F_{k+1}ᵀ + Q_{k+1}.
/// K_k = P_k F_{k+1}ᵀ Pp_k⁻¹ is solved (Pp_k K_kᵀ = F_{k+1} P_kᵀ), not formed with an
/// inverse. `x` and `P` come in holding the filtered means and covariances and are
/// smoothed in place; `Pp` and `K` are the caller's buffers of `P`'s size (allocated
/// fallibly there). `Err(k)`: Pp_k is singular.
pub(crate) fn rts(
    (mut x, mut P): (Vec<f64>, Vec<f64>),
    (mut Pp, mut K): (Vec<f64>, Vec<f64>),
    steps: usize,
    n: usize,
    Fs: Steps<'_>,
    Qs: Steps<'_>,
) -> Result<Smoothed, usize> {
    Pp.copy_from_slice(&P);
    K.fill(0.0);
    let (nn, mut t1, mut t2, mut d, mut fx) = (
        n * n,
        vec![0.0; n * n],
        vec![0.0; n * n],
        vec![0.0; n],
        vec![0.0; n],
    );
    let mut fac = Factor::new(n);
    for k in (0..steps.saturating_sub(1)).rev() {
        let (pk, pk1) = (k * nn, (k + 1) * nn);
        let (F, Q) = (Fs.at(k + 1, nn), Qs.at(k + 1, nn));
        mul(F, &P[pk..pk + nn], n, n, n, &mut t1); // F P_k
        mul_bt(&t1, F, n, n, n, &mut t2);
        for (o, (a, q)) in Pp[pk..pk + nn].iter_mut().zip(t2.iter().zip(Q)) {
            *o = a + q;
        }
        // K_kᵀ = Pp⁻ᵀ (P_k Fᵀ)ᵀ = Pp_kᵀ \ (F P_kᵀ).
        for i in 0..n {
            for j in 0..n {
                t2[i * n + j] = Pp[pk + j * n + i];
            }
        }
        if !fac.factor(&t2, n) {
            return Err(k);
        }
        mul_bt(F, &P[pk..pk + nn], n, n, n, &mut t1); // F P_kᵀ
        fac.solve(&mut t1, n); // K_kᵀ
        for i in 0..n {
            for j in 0..n {
                K[pk + i * n + j] = t1[j * n + i];
            }
        }
        // x_k += K_k (x_{k+1} − F x_k)
        mul_vec(F, &x[k * n..(k + 1) * n], n, n, &mut fx);
        for i in 0..n {
            d[i] = x[(k + 1) * n + i] - fx[i];
        }
        for i in 0..n {
            x[k * n + i] += (0..n).map(|j| K[pk + i * n + j] * d[j]).sum::<f64>();
        }
        // P_k += K_k (P_{k+1} − Pp_k) K_kᵀ
        for i in 0..nn {
            t2[i] = P[pk1 + i] - Pp[pk + i];
        }
        mul(&K[pk..pk + nn], &t2, n, n, n, &mut t1);
        mul_bt(&t1, &K[pk..pk + nn], n, n, n, &mut t2);
        for (o, v) in P[pk..pk + nn].iter_mut().zip(&t2) {
            *o += v;
        }
    }
    Ok((x, P, K, Pp))
}
