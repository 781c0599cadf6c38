//! One pass of the output-error integration over a record: the checked problem, the
//! seeded dual passes, the whitening by `R_k` and the sums the Gauss–Newton step needs.

use faer::{Mat, MatRef};
use num_dual::Dual64;

use super::super::FitError;
use super::super::dense::lower_factor;
use crate::nonlinear::GenericModel;
use crate::storage::Dims;

/// How the residuals are weighed: by the model's `R_k`, whitened by their Cholesky factors
/// (one group of sums), or by a constant diagonal R (one group of raw sums per channel).
#[derive(Clone, Debug)]
pub(super) enum Weights {
    Model,
    Diag(Vec<f64>),
}

/// Sums over the record for one group: `Σ e²`, the count, `Σ Sᵀe` and `Σ SᵀS` (lower).
#[derive(Clone, Debug)]
pub(super) struct Group {
    ss: f64,
    count: usize,
    grad: Vec<f64>,
    info: Vec<f64>,
}

/// The checked problem.
pub(super) struct Problem<'a, G> {
    model: &'a G,
    n: usize,
    pub(super) m: usize,
    x0: Vec<f64>,
    free: &'a [usize],
    z: MatRef<'a, f64>,
    u: Option<MatRef<'a, f64>>,
    /// Row-major copy of u (N×p), so `f` gets a slice.
    u_rows: Vec<f64>,
    p_in: usize,
}

fn shape(name: &'static str, rows: usize, cols: usize, er: usize, ec: usize) -> FitError {
    crate::Error::Shape {
        name,
        rows,
        cols,
        expected_rows: er,
        expected_cols: ec,
    }
    .into()
}

/// A quantity that is not finite at step `step`: [`crate::Error::Diverged`].
pub(super) fn not_finite(what: &'static str, step: usize, value: f64) -> FitError {
    crate::Error::Diverged { step, what, value }.into()
}

impl<'a, G: GenericModel> Problem<'a, G> {
    pub(super) fn new(
        model: &'a G,
        dims: impl Dims,
        x0: &[f64],
        free: &'a [usize],
        z: MatRef<'a, f64>,
        u: Option<MatRef<'a, f64>>,
    ) -> Result<Self, FitError> {
        let (n, m, p_in) = (dims.n(), dims.m(), dims.p());
        if x0.len() != n {
            return Err(shape("x0", x0.len(), 1, n, 1));
        }
        if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
            return Err(crate::Error::NonFinite {
                name: "x0",
                rows: n,
                cols: 1,
                row: i,
                col: 0,
            }
            .into());
        }
        if free.is_empty() {
            return Err(FitError::NothingFree);
        }
        for (j, &i) in free.iter().enumerate() {
            if i >= n {
                return Err(FitError::Parameters(format!(
                    "free index {i} (entry {j} of free) is out of range for an initial state of n = {n}"
                )));
            }
            if free[..j].contains(&i) {
                return Err(FitError::Parameters(format!(
                    "free index {i} is repeated (entries {} and {j} of free)",
                    free[..j].iter().position(|&v| v == i).unwrap_or(0)
                )));
            }
        }
        let len = z.nrows();
        if z.ncols() != m || len == 0 {
            return Err(shape("z", len, z.ncols(), len.max(1), m));
        }
        for k in 0..len {
            for i in 0..m {
                if z[(k, i)].is_infinite() {
                    return Err(FitError::Data(format!(
                        "z has an infinite entry at step {k}, row {i}"
                    )));
                }
            }
        }
        if (0..len).all(|k| (0..m).all(|i| z[(k, i)].is_nan())) {
            return Err(FitError::NoMeasurements);
        }
        let mut u_rows = Vec::new();
        match u {
            Some(u) => {
                if u.nrows() != len || u.ncols() != p_in {
                    return Err(shape("u", u.nrows(), u.ncols(), len, p_in));
                }
                u_rows.reserve(len * p_in);
                for k in 0..len {
                    for i in 0..p_in {
                        let v = u[(k, i)];
                        if !v.is_finite() {
                            return Err(crate::Error::NonFinite {
                                name: "u",
                                rows: len,
                                cols: p_in,
                                row: k,
                                col: i,
                            }
                            .into());
                        }
                        u_rows.push(v);
                    }
                }
            }
            None if p_in > 0 => return Err(shape("u", 0, 0, len, p_in)),
            None => {}
        }
        Ok(Self {
            model,
            n,
            m,
            x0: x0.to_vec(),
            free,
            z,
            u,
            u_rows,
            p_in,
        })
    }

    pub(super) fn len(&self) -> usize {
        self.z.nrows()
    }

    fn u_at(&self, k: usize) -> Option<&[f64]> {
        self.u
            .map(|_| &self.u_rows[k * self.p_in..(k + 1) * self.p_in])
    }

    pub(super) fn names(&self) -> Vec<String> {
        self.free.iter().map(|i| format!("x0[{i}]")).collect()
    }

    pub(super) fn n_obs(&self) -> usize {
        let (len, m) = (self.len(), self.m);
        (0..len)
            .map(|k| (0..m).filter(|&i| !self.z[(k, i)].is_nan()).count())
            .sum()
    }

    /// The diagonal of the model's `R_0`.
    pub(super) fn model_r_diag(&self) -> Vec<f64> {
        let m = self.m;
        let mut r = vec![0.0; m * m];
        self.model.r(0, &mut r);
        (0..m).map(|i| r[i + i * m]).collect()
    }

    fn groups(&self, weights: &Weights, p: usize) -> Vec<Group> {
        let count = match weights {
            Weights::Model => 1,
            Weights::Diag(_) => self.m,
        };
        vec![
            Group {
                ss: 0.0,
                count: 0,
                grad: vec![0.0; p],
                info: vec![0.0; p * p],
            };
            count
        ]
    }

    /// One pass at θ: the group sums, with the sensitivity sums when `sens` (p dual passes
    /// in lockstep), else the residual sums only (one `f64` pass).
    pub(super) fn pass(
        &self,
        theta: &[f64],
        weights: &Weights,
        sens: bool,
    ) -> Result<Vec<Group>, FitError> {
        let (n, m, len) = (self.n, self.m, self.len());
        let p = if sens { self.free.len() } else { 0 };
        let mut groups = self.groups(weights, p);
        let mut x0 = self.x0.clone();
        for (&i, &t) in self.free.iter().zip(theta) {
            x0[i] = t;
        }
        // p seeded dual states (sens) or one real one.
        let lanes = p.max(1);
        let seed = |j: usize| -> Vec<Dual64> {
            (0..n)
                .map(|i| Dual64::new(x0[i], if sens && self.free[j] == i { 1.0 } else { 0.0 }))
                .collect()
        };
        let mut xd: Vec<Vec<Dual64>> = if sens {
            (0..p).map(seed).collect()
        } else {
            Vec::new()
        };
        let mut next_d = xd.clone();
        let mut yd = vec![vec![Dual64::from_re(0.0); m]; if sens { lanes } else { 0 }];
        let mut x = x0.clone();
        let mut next = vec![0.0; n];
        let mut y = vec![0.0; m];
        let mut zf = vec![0.0; m];
        let mut e = vec![0.0; m];
        let mut s = vec![0.0; m * p]; // row-major: s[i·p + j] = ∂y_i/∂θ_j
        let mut rk = vec![0.0; m * m];
        let mut l = vec![0.0; m * m];
        let mut obs = Vec::with_capacity(m);
        for k in 0..len {
            if sens {
                for j in 0..p {
                    self.model.h(&xd[j], k, &mut yd[j]);
                }
                for i in 0..m {
                    y[i] = yd[0][i].re;
                    for j in 0..p {
                        let d = yd[j][i].eps;
                        if !d.is_finite() {
                            return Err(not_finite("the output sensitivity ∂y_k/∂θ", k, d));
                        }
                        s[i * p + j] = d;
                    }
                }
            } else {
                self.model.h(&x, k, &mut y);
            }
            if let Some(v) = y.iter().find(|v| !v.is_finite()) {
                return Err(not_finite("the output h(x_k, k)", k, *v));
            }
            obs.clear();
            for i in 0..m {
                let v = self.z[(k, i)];
                if v.is_nan() {
                    zf[i] = y[i];
                } else {
                    zf[i] = v;
                    obs.push(i);
                }
            }
            if !obs.is_empty() {
                self.model.residual(&zf, &y, &mut e);
                if let Some(&i) = obs.iter().find(|&&i| !e[i].is_finite()) {
                    return Err(not_finite("the residual z_k − h(x_k, k)", k, e[i]));
                }
                match weights {
                    Weights::Diag(_) => {
                        for &i in &obs {
                            accumulate(&mut groups[i], e[i], &s[i * p..(i + 1) * p]);
                        }
                    }
                    Weights::Model => {
                        self.whiten(k, &obs, &mut rk, &mut l, &mut e, &mut s, p)?;
                        for r in 0..obs.len() {
                            accumulate(&mut groups[0], e[r], &s[r * p..(r + 1) * p]);
                        }
                    }
                }
            }
            if k + 1 == len {
                break;
            }
            let u = self.u_at(k);
            if sens {
                for j in 0..p {
                    self.model.f(&xd[j], u, k, &mut next_d[j]);
                }
                std::mem::swap(&mut xd, &mut next_d);
                if let Some(v) = xd[0].iter().find(|v| !v.re.is_finite()) {
                    return Err(not_finite("the predicted state f(x_k, u_k, k)", k, v.re));
                }
                for x in &xd {
                    if let Some(v) = x.iter().find(|v| !v.eps.is_finite()) {
                        return Err(not_finite("the state sensitivity ∂x_{k+1}/∂θ", k, v.eps));
                    }
                }
            } else {
                self.model.f(&x, u, k, &mut next);
                std::mem::swap(&mut x, &mut next);
                if let Some(v) = x.iter().find(|v| !v.is_finite()) {
                    return Err(not_finite("the predicted state f(x_k, u_k, k)", k, *v));
                }
            }
        }
        for g in &mut groups {
            symmetrise_lower(&mut g.info, p);
        }
        Ok(groups)
    }

    /// Whitens the observed rows by the Cholesky factor L of `R_k`'s observed block:
    /// `e ← L⁻¹ e_o`, `S ← L⁻¹ S_o` (the first `obs.len()` rows of each).
    #[allow(clippy::too_many_arguments)]
    fn whiten(
        &self,
        k: usize,
        obs: &[usize],
        rk: &mut [f64],
        l: &mut [f64],
        e: &mut [f64],
        s: &mut [f64],
        p: usize,
    ) -> Result<(), FitError> {
        let (m, mo) = (self.m, obs.len());
        self.model.r(k, rk);
        for (c, &j) in obs.iter().enumerate() {
            for (r, &i) in obs.iter().enumerate() {
                l[r + c * mo] = rk[i + j * m];
            }
        }
        let l = &mut l[..mo * mo];
        if l.iter().any(|v| !v.is_finite()) || !lower_factor(l, mo) {
            return Err(FitError::NotPositiveDefinite { name: "R", step: k });
        }
        for (r, &i) in obs.iter().enumerate() {
            e[r] = e[i];
            if r != i {
                s.copy_within(i * p..(i + 1) * p, r * p);
            }
        }
        // Forward substitution, rows in order (row r depends on rows before it only).
        for r in 0..mo {
            let d = l[r + r * mo];
            for c in 0..r {
                let lrc = l[r + c * mo];
                e[r] -= lrc * e[c];
                for j in 0..p {
                    s[r * p + j] -= lrc * s[c * p + j];
                }
            }
            e[r] /= d;
            for v in &mut s[r * p..(r + 1) * p] {
                *v /= d;
            }
        }
        Ok(())
    }
}

/// Adds one (whitened or raw) residual and its sensitivity row to a group.
fn accumulate(g: &mut Group, e: f64, s: &[f64]) {
    let p = s.len();
    g.ss += e * e;
    g.count += 1;
    for j in 0..p {
        g.grad[j] += s[j] * e;
        let sj = s[j];
        for i in j..p {
            g.info[i + j * p] += s[i] * sj;
        }
    }
}

fn symmetrise_lower(a: &mut [f64], p: usize) {
    for j in 0..p {
        for i in j + 1..p {
            a[j + i * p] = a[i + j * p];
        }
    }
}

/// The weight of each group: 1 for the whitened group, `1/R_ii` per channel.
fn group_weights(weights: &Weights) -> Vec<f64> {
    match weights {
        Weights::Model => vec![1.0],
        Weights::Diag(r) => r.iter().map(|v| 1.0 / v).collect(),
    }
}

/// `J` from the groups.
pub(super) fn cost_of(groups: &[Group], weights: &Weights) -> f64 {
    let w = group_weights(weights);
    0.5 * groups.iter().zip(&w).map(|(g, w)| w * g.ss).sum::<f64>()
}

/// `(J, M, g)` from the groups.
pub(super) fn combine(groups: &[Group], weights: &Weights, p: usize) -> (f64, Mat<f64>, Vec<f64>) {
    let w = group_weights(weights);
    let mut info = Mat::zeros(p, p);
    let mut grad = vec![0.0; p];
    for (g, w) in groups.iter().zip(&w) {
        for j in 0..p {
            grad[j] += w * g.grad[j];
            for i in 0..p {
                info[(i, j)] += w * g.info[i + j * p];
            }
        }
    }
    (cost_of(groups, weights), info, grad)
}

/// The diagonal R of the residuals' mean squares (the model's `R_0` for an unobserved
/// channel).
pub(super) fn mean_squares(groups: &[Group], fallback: &[f64]) -> Result<Vec<f64>, FitError> {
    groups
        .iter()
        .enumerate()
        .map(|(i, g)| {
            if g.count == 0 {
                Ok(fallback[i])
            } else if g.ss > 0.0 {
                Ok(g.ss / g.count as f64)
            } else {
                Err(FitError::NotIdentifiable {
                    what: format!("R[{i},{i}]"),
                    why: format!(
                        "the residuals of channel {i} are all zero, so its noise variance cannot be estimated; fix R instead"
                    ),
                })
            }
        })
        .collect()
}
