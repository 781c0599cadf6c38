//! An independent reference filter in plain loops over `Vec<Vec<f64>>`, written from the
//! textbook "delayed" (one-step predictor) recursion rather than the engine's code:
//! K_p = (F P Hᵀ + S) Σ⁻¹, x_{k+1|k} = F x + B u + K_p e, P_{k+1|k} = F P Fᵀ + Q − K_p Σ K_pᵀ,
//! with x_{k|k} = x + P Hᵀ Σ⁻¹ e, P_{k|k} = P − P Hᵀ Σ⁻¹ H P. Missing rows are removed
//! by building the observed sub-problem explicitly; Σ⁻¹ by Gauss–Jordan with pivoting.

pub type M = Vec<Vec<f64>>;

pub fn from_faer(a: faer::MatRef<'_, f64>) -> M {
    (0..a.nrows())
        .map(|i| (0..a.ncols()).map(|j| a[(i, j)]).collect())
        .collect()
}

fn mul(a: &M, b: &M) -> M {
    let (r, k, c) = (a.len(), b.len(), b.first().map_or(0, Vec::len));
    let mut out = vec![vec![0.0; c]; r];
    for i in 0..r {
        for j in 0..c {
            let mut s = 0.0;
            for l in 0..k {
                s += a[i][l] * b[l][j];
            }
            out[i][j] = s;
        }
    }
    out
}

fn tr(a: &M) -> M {
    let c = a.first().map_or(0, Vec::len);
    (0..c)
        .map(|j| a.iter().map(|row| row[j]).collect())
        .collect()
}

fn add(a: &M, b: &M, s: f64) -> M {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p + s * q).collect())
        .collect()
}

fn inv(a: &M) -> M {
    let n = a.len();
    let mut m: M = a
        .iter()
        .enumerate()
        .map(|(i, row)| {
            let mut r = row.clone();
            r.extend((0..n).map(|j| if i == j { 1.0 } else { 0.0 }));
            r
        })
        .collect();
    for c in 0..n {
        let piv = (c..n)
            .max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))
            .unwrap_or(c);
        m.swap(c, piv);
        let d = m[c][c];
        for v in m[c].iter_mut() {
            *v /= d;
        }
        for r in 0..n {
            if r != c {
                let f = m[r][c];
                let pivot_row = m[c].clone();
                for (v, p) in m[r].iter_mut().zip(&pivot_row) {
                    *v -= f * p;
                }
            }
        }
    }
    m.into_iter().map(|r| r[n..].to_vec()).collect()
}

/// The reference filter's output after each step: x_{k|k}, P_{k|k}, x_{k+1|k}, P_{k+1|k}.
pub struct RefStep {
    pub xf: Vec<f64>,
    pub pf: M,
    pub xp: Vec<f64>,
    pub pp: M,
    /// `None` on a predict-only step.
    pub nis: Option<f64>,
    /// Innovation e_k (0 in missing entries), Σ_k = H P Hᵀ + R and K_k = P Hᵀ Σ_k⁻¹ over
    /// the observed entries (0 in the rows and columns of missing ones).
    pub e: Vec<f64>,
    pub sig: M,
    pub gain: M,
}

pub fn run(p: &kalman::strategies::FilterProblem) -> Vec<RefStep> {
    let (n, m) = (p.system.n(), p.system.m());
    let F = from_faer(p.system.f.as_ref());
    let H = from_faer(p.system.h.as_ref());
    let Q = from_faer(p.system.q.as_ref());
    let R = from_faer(p.system.r.as_ref());
    let S =
        p.s.as_ref()
            .map_or(vec![vec![0.0; m]; n], |s| from_faer(s.as_ref()));
    let B = from_faer(p.system.b.as_ref());
    let mut x = p.system.x0.clone();
    let mut P = from_faer(p.system.p0.as_ref());
    let mut out = Vec::new();
    for (z, u) in p.z.iter().zip(&p.u) {
        let obs: Vec<usize> = (0..m).filter(|&i| !z[i].is_nan()).collect();
        let Bu: Vec<f64> = (0..n)
            .map(|i| (0..p.system.p()).map(|l| B[i][l] * u[l]).sum())
            .collect();
        let Fx: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| F[i][j] * x[j]).sum())
            .collect();
        let FPFt = mul(&mul(&F, &P), &tr(&F));
        let step = if obs.is_empty() {
            RefStep {
                xf: x.clone(),
                pf: P.clone(),
                xp: (0..n).map(|i| Fx[i] + Bu[i]).collect(),
                pp: add(&FPFt, &Q, 1.0),
                nis: None,
                e: vec![0.0; m],
                sig: vec![vec![0.0; m]; m],
                gain: vec![vec![0.0; m]; n],
            }
        } else {
            let Ho: M = obs.iter().map(|&i| H[i].clone()).collect();
            let Ro: M = obs
                .iter()
                .map(|&i| obs.iter().map(|&j| R[i][j]).collect())
                .collect();
            let So: M = (0..n)
                .map(|r| obs.iter().map(|&j| S[r][j]).collect())
                .collect();
            let e: Vec<f64> = obs
                .iter()
                .enumerate()
                .map(|(a, &i)| z[i] - (0..n).map(|j| Ho[a][j] * x[j]).sum::<f64>())
                .collect();
            let PHt = mul(&P, &tr(&Ho));
            let Sig = add(&mul(&Ho, &PHt), &Ro, 1.0);
            let Si = inv(&Sig);
            let K = mul(&PHt, &Si);
            let Kp = mul(&add(&mul(&F, &PHt), &So, 1.0), &Si);
            let Ke: Vec<f64> = (0..n)
                .map(|i| (0..obs.len()).map(|a| K[i][a] * e[a]).sum())
                .collect();
            let Kpe: Vec<f64> = (0..n)
                .map(|i| (0..obs.len()).map(|a| Kp[i][a] * e[a]).sum())
                .collect();
            let nis = (0..obs.len())
                .map(|a| (0..obs.len()).map(|b| e[a] * Si[a][b] * e[b]).sum::<f64>())
                .sum();
            RefStep {
                xf: (0..n).map(|i| x[i] + Ke[i]).collect(),
                pf: add(&P, &mul(&K, &tr(&PHt)), -1.0),
                xp: (0..n).map(|i| Fx[i] + Bu[i] + Kpe[i]).collect(),
                pp: add(&add(&FPFt, &Q, 1.0), &mul(&mul(&Kp, &Sig), &tr(&Kp)), -1.0),
                nis: Some(nis),
                e: scatter_vec(m, &obs, &e),
                sig: (0..m)
                    .map(|i| {
                        let a = obs.iter().position(|&o| o == i);
                        scatter_vec(m, &obs, a.map_or(&[][..], |a| &Sig[a]))
                    })
                    .collect(),
                gain: K.iter().map(|row| scatter_vec(m, &obs, row)).collect(),
            }
        };
        x = step.xp.clone();
        P = step.pp.clone();
        out.push(step);
    }
    out
}

/// The length-`m` vector with `v[a]` at `obs[a]` and 0 elsewhere (an empty `v`: all 0).
fn scatter_vec(m: usize, obs: &[usize], v: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; m];
    for (&i, &x) in obs.iter().zip(v) {
        out[i] = x;
    }
    out
}
