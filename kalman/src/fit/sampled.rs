//! The noise of a continuous model fitted over a record's own time stamps: free entries of
//! the process-noise intensity `W`, of `R`, `x0` and `P0`, the model sampled exactly at
//! each interval of the record, and the likelihood maximised through the filter-error
//! engine ([`super::filter_error()`]).
//!
//! # The model
//! `ẋ = A x + B u + G w` with `E[w(t) w(s)ᵀ] = W δ(t − s)` (`G = I` unless a noise input
//! is given), `z_k = H x(t_k) + v_k`, `cov(v_k) = R`, and the prior `(x0, P0)` of the first
//! row. Step k predicts over `Δt_k = t_{k+1} − t_k`:
//!
//! ```text
//! F_k = e^{AΔt_k},   B_k = ∫₀^Δt_k e^{Aτ} dτ B  (zero-order hold),
//! Q_k = ∫₀^Δt_k e^{Aτ} G W Gᵀ e^{Aᵀτ} dτ   (Van Loan),
//! ```
//!
//! Two rows with the same stamp are one instant (`Δt = 0`: `F = I`, `Q = 0`).
//!
//! # Why the fit is exact and cheap
//! `Q_k` is linear in `W`, so with the free entries `W = W⁰ + Σ_j v_j(θ) S_j` (each
//! `S_j` the unit cells parameter j sets, with their coefficients) it is
//! `Q_k = Q_k⁰ + Σ_j v_j(θ) Q_k^{(j)}`, every term sampled once per *distinct* interval when
//! the map is built. The likelihood and its exact gradient at any θ then cost one filter
//! pass per parameter with no matrix exponential: a regular or quantised clock pays the
//! sampling once. `B` and `H` stay fixed. A free entry of the drift `A` (addressed as
//! [`Matrix::F`]) puts θ inside the exponential: each step then samples its interval at θ,
//! the exponential evaluated over the pass's dual numbers (the same Padé approximant and
//! squarings as in `f64`), so the gradient stays exact and each pass pays one exponential
//! per step.
//!
//! # Example
//! ```
//! use kalman::fit::{Matrix, MleOptions, Param, SampledMap, Series, Transform};
//! use kalman::sampling::ContinuousModel;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // A random walk of unknown intensity q seen every 0.1–0.3 s through noise of unknown R.
//! let model = ContinuousModel::new(&[[0.0]], &[[1.0]], &[[1.0]], &[[1.0]])?;
//! let t: Vec<f64> = (0..200).map(|k| 0.2 * k as f64 + 0.1 * (k as f64).sin()).collect();
//! let z: Vec<f64> = t.iter().map(|t| (0.7 * t).sin()).collect();
//! let params = vec![Param::entry(Matrix::Q, 0, 0), Param::entry(Matrix::R, 0, 0)];
//! let map = SampledMap::new(&model, &[0.0], &[[1.0]], &t, params)?;
//! let fit = map.fit(&Series::new(&z, 1)?, &MleOptions::default())?;
//! let values = map.values(&fit.theta)?; // [("Q[0,0]", q̂), ("R[0,0]", R̂)]
//! assert!(values[0].1 > values[1].1, "a smooth signal: the walk, not the noise, moves it");
//! # Ok(())
//! # }
//! ```
#![allow(non_snake_case)]

use std::collections::HashMap;

use faer::Mat;

use super::filter_error::{ParametricFit, ParametricModel, filter_error};
use super::{Entry, FitError, Matrix, MleOptions, Param, Series, Transform};
use crate::MatrixInput;
use crate::nonlinear::Scalar;
use crate::sampling::{ContinuousModel, Sampler};

/// A continuous model with free noise entries, sampled at the intervals of one record's time
/// stamps: a [`ParametricModel`] for [`filter_error`] (see the [module](self)).
///
/// The free [`Param`]s address [`Matrix::Q`] as the intensity `W` (q×q for a noise input
/// `G` of q columns, n×n without one), [`Matrix::R`], [`Matrix::X0`] and [`Matrix::P0`], with
/// [`Param::entry`]'s conventions (a diagonal variance log-transformed, an off-diagonal
/// covariance entry setting its mirror). Memory: one n×n matrix per distinct interval and
/// free intensity parameter, plus F, B and the fixed part of Q per distinct interval.
#[derive(Clone, Debug)]
pub struct SampledMap {
    n: usize,
    m: usize,
    p: usize,
    /// Columns of the noise input G.
    nq: usize,
    params: Vec<Param>,
    /// The interval of each step (index into the per-interval blocks).
    step: Vec<usize>,
    /// Per distinct interval: F (n×n), B_d (n×p), the fixed part of Q_d (n×n) and one
    /// n×n block per parameter (zero for a parameter outside W), column-major.
    f: Vec<f64>,
    b: Vec<f64>,
    q_fixed: Vec<f64>,
    q_basis: Vec<f64>,
    h: Vec<f64>,
    /// The base W, R, x0 and P0 (column-major); a free cell's base value is replaced.
    qc: Vec<f64>,
    r: Vec<f64>,
    x0: Vec<f64>,
    p0: Vec<f64>,
    g: Vec<f64>,
    /// Whether a parameter enters the drift `A` (addressed as [`Matrix::F`]): then every step
    /// samples its interval at θ, through the exponential over the scalar of the pass.
    drift: bool,
    /// The base drift `A` (n×n), the continuous control matrix (n×p) and each distinct
    /// interval's Δt.
    a: Vec<f64>,
    bc: Vec<f64>,
    dts: Vec<f64>,
}

/// The matrices of a [`SampledMap`] at a θ ([`SampledMap::matrices`]).
///
/// # Example
/// ```
/// use kalman::fit::{Matrix, Param, SampledMap};
/// use kalman::sampling::ContinuousModel;
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let model = ContinuousModel::new(&[[0.0]], &[[1.0]], &[[2.0]], &[[0.5]])?;
/// let map = SampledMap::new(&model, &[0.0], &[[1.0]], &[0.0, 0.1, 0.3], vec![Param::entry(Matrix::R, 0, 0)])?;
/// let at = map.matrices(&[0.0])?; // R = e⁰ = 1, the intensity kept at 2
/// assert_eq!((at.w[(0, 0)], at.r[(0, 0)]), (2.0, 1.0));
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct Matrices {
    /// The drift `A` (n×n).
    pub a: Mat<f64>,
    /// The process-noise intensity `W` (q×q).
    pub w: Mat<f64>,
    /// The measurement noise covariance `R` (m×m).
    pub r: Mat<f64>,
    /// The prior mean.
    pub x0: Vec<f64>,
    /// The prior covariance (n×n).
    pub p0: Mat<f64>,
}

impl SampledMap {
    /// The map of `model` (its intensity `W` as `W`, `G = I`) with the prior `(x0, P0)`, at
    /// the time stamps `t` (seconds, non-decreasing), with the free `params`.
    ///
    /// # Errors
    /// As [`SampledMap::with_noise_input`].
    pub fn new(
        model: &ContinuousModel,
        x0: &[f64],
        P0: &impl MatrixInput,
        t: &[f64],
        params: Vec<Param>,
    ) -> Result<Self, FitError> {
        let n = model.n();
        let identity = Mat::<f64>::identity(n, n);
        Self::with_noise_input(model, &identity, &model.w(), x0, P0, t, params)
    }

    /// The map of `model` with the process noise entering through `G` (n×q) with intensity
    /// `W` (q×q, symmetric PSD; it replaces the n×n intensity `model` was built with).
    ///
    /// # Errors
    /// [`FitError::Parameters`] for a parameter on `F`, `B` or `H` (fixed here), an entry
    /// outside its matrix, a zero or non-finite coefficient, a cell set twice or a base value
    /// its transform cannot reach; [`FitError::Data`] for time stamps that are not finite or
    /// go back (naming the row), an `x0`, `P0`, `G` or `W` of the wrong shape or not
    /// finite, or an interval whose exponential overflows.
    pub fn with_noise_input(
        model: &ContinuousModel,
        G: &impl MatrixInput,
        W: &impl MatrixInput,
        x0: &[f64],
        P0: &impl MatrixInput,
        t: &[f64],
        params: Vec<Param>,
    ) -> Result<Self, FitError> {
        let (n, m, p) = (model.n(), model.m(), model.p());
        let data = |msg: String| FitError::Data(msg);
        let g = dense("G", G, n, G.ncols())?;
        let nq = G.ncols();
        let qc = dense("W", W, nq, nq)?;
        let p0 = dense("P0", P0, n, n)?;
        if x0.len() != n || x0.iter().any(|v| !v.is_finite()) {
            return Err(data(format!(
                "x0 must hold {n} finite values (it has {})",
                x0.len()
            )));
        }
        check_params(&params, n, m, nq)?;
        let mut this = SampledMap {
            n,
            m,
            p,
            nq,
            params,
            step: Vec::with_capacity(t.len()),
            f: Vec::new(),
            b: Vec::new(),
            q_fixed: Vec::new(),
            q_basis: Vec::new(),
            h: model
                .h()
                .col_iter()
                .flat_map(|c| c.iter().copied())
                .collect(),
            r: model
                .r()
                .col_iter()
                .flat_map(|c| c.iter().copied())
                .collect(),
            qc,
            x0: x0.to_vec(),
            p0,
            g,
            drift: false,
            a: model
                .a()
                .col_iter()
                .flat_map(|c| c.iter().copied())
                .collect(),
            bc: model
                .b()
                .col_iter()
                .flat_map(|c| c.iter().copied())
                .collect(),
            dts: Vec::new(),
        };
        this.drift = this
            .params
            .iter()
            .any(|p| p.entries().iter().any(|e| e.matrix == Matrix::F));
        this.theta0()?;
        this.sample(model, t)?;
        Ok(this)
    }

    /// Samples every distinct interval of `t`: F and B_d from the crate's sampler, the fixed
    /// part of Q_d and each intensity parameter's block by Van Loan.
    fn sample(&mut self, model: &ContinuousModel, t: &[f64]) -> Result<(), FitError> {
        let n = self.n;
        let data = |msg: String| FitError::Data(msg);
        let mut slots: HashMap<u64, usize> = HashMap::new();
        let mut sampler = Sampler::new(model.clone(), 1).map_err(|e| data(e.to_string()))?;
        // W of the fixed part (the free W cells zeroed) and of each parameter's cells.
        let mut fixed = self.qc.clone();
        for prm in &self.params {
            for e in prm.entries().iter().filter(|e| e.matrix == Matrix::Q) {
                for (i, j) in mirror(e) {
                    fixed[i + j * self.nq] = 0.0;
                }
            }
        }
        let mut intensities = vec![self.gwg(&fixed)];
        for prm in &self.params {
            let mut s = vec![0.0; self.nq * self.nq];
            for e in prm.entries().iter().filter(|e| e.matrix == Matrix::Q) {
                for (i, j) in mirror(e) {
                    s[i + j * self.nq] += e.coefficient;
                }
            }
            intensities.push(self.gwg(&s));
        }
        let A = model.a().to_owned();
        for k in 0..t.len() {
            if !t[k].is_finite() {
                return Err(data(format!("t at row {k} is {} (must be finite)", t[k])));
            }
            let dt = match t.get(k + 1) {
                Some(&next) if !next.is_finite() => {
                    return Err(data(format!(
                        "t at row {} is {next} (must be finite)",
                        k + 1
                    )));
                }
                Some(&next) if next < t[k] => {
                    return Err(data(format!(
                        "t goes back at row {}: {next} after {}",
                        k + 1,
                        t[k]
                    )));
                }
                Some(&next) => next - t[k],
                None => 0.0,
            };
            if let Some(&i) = slots.get(&dt.to_bits()) {
                self.step.push(i);
                continue;
            }
            let overflow = |e: String| data(format!("the interval {dt} s after row {k}: {e}"));
            let sampled = sampler.at(dt).map_err(|e| overflow(e.to_string()))?;
            self.f
                .extend(sampled.f().col_iter().flat_map(|c| c.iter().copied()));
            self.b
                .extend(sampled.b().col_iter().flat_map(|c| c.iter().copied()));
            for (j, w) in intensities.iter().enumerate() {
                let blocks = if j == 0 {
                    &mut self.q_fixed
                } else {
                    &mut self.q_basis
                };
                if dt == 0.0 || w.iter().all(|&v| v == 0.0) {
                    blocks.extend(std::iter::repeat_n(0.0, n * n));
                    continue;
                }
                let W = Mat::from_fn(n, n, |i, j| w[i + j * n]);
                let (_, qd) = crate::continuous::van_loan(A.as_ref(), W.as_ref(), dt)
                    .map_err(|e| overflow(e.to_string()))?;
                if qd.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
                    return Err(overflow("the integrated noise overflows f64".into()));
                }
                blocks.extend(qd.col_iter().flat_map(|c| c.iter().copied()));
            }
            self.dts.push(dt);
            slots.insert(dt.to_bits(), slots.len());
            self.step.push(slots.len() - 1);
        }
        Ok(())
    }

    /// `G S Gᵀ` (n×n) of a q×q `S`.
    fn gwg(&self, s: &[f64]) -> Vec<f64> {
        let (n, q) = (self.n, self.nq);
        let mut out = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                let mut acc = 0.0;
                for b in 0..q {
                    for a in 0..q {
                        acc += self.g[i + a * n] * s[a + b * q] * self.g[j + b * n];
                    }
                }
                out[i + j * n] = acc;
            }
        }
        out
    }

    /// The number of rows the map was sampled for.
    pub fn len(&self) -> usize {
        self.step.len()
    }

    /// Whether the map was sampled for no row.
    pub fn is_empty(&self) -> bool {
        self.step.is_empty()
    }

    /// How many distinct intervals the record has (each sampled once).
    pub fn distinct_intervals(&self) -> usize {
        self.f.len() / (self.n * self.n)
    }

    /// The free parameters.
    pub fn params(&self) -> &[Param] {
        &self.params
    }

    /// θ of the base values (each parameter's first entry over its coefficient, through the
    /// inverse transform): the natural start of a fit.
    ///
    /// # Errors
    /// [`FitError::Parameters`] naming a parameter whose base value its transform cannot
    /// reach (a zero variance under the log).
    pub fn theta0(&self) -> Result<Vec<f64>, FitError> {
        self.params
            .iter()
            .map(|prm| {
                let e = prm.entries()[0];
                let v = self.base(e) / e.coefficient;
                prm.transform().theta(v).ok_or_else(|| {
                    FitError::Parameters(format!(
                        "{}: the base value {v} cannot be reached by its transform (a variance \
                         must start positive)",
                        prm.name()
                    ))
                })
            })
            .collect()
    }

    fn base(&self, e: Entry) -> f64 {
        let (i, j) = (e.row, e.col);
        match e.matrix {
            Matrix::Q => self.qc[i + j * self.nq],
            Matrix::R => self.r[i + j * self.m],
            Matrix::X0 => self.x0[i],
            Matrix::P0 => self.p0[i + j * self.n],
            Matrix::F => self.a[i + j * self.n],
            Matrix::B | Matrix::H => f64::NAN,
        }
    }

    /// The parameters' values `v(θ)` by name.
    ///
    /// # Errors
    /// [`FitError::Parameters`] for a θ of the wrong length or with a non-finite entry.
    pub fn values(&self, theta: &[f64]) -> Result<Vec<(String, f64)>, FitError> {
        self.check_theta(theta)?;
        Ok(self
            .params
            .iter()
            .zip(theta)
            .map(|(prm, &th)| (prm.name().to_string(), prm.transform().value(th).0))
            .collect())
    }

    /// The matrices at θ, each the base with the free cells set.
    ///
    /// # Errors
    /// As [`SampledMap::values`].
    pub fn matrices(&self, theta: &[f64]) -> Result<Matrices, FitError> {
        self.check_theta(theta)?;
        let (n, m, q) = (self.n, self.m, self.nq);
        let mut a = self.a.clone();
        let (mut qc, mut r, mut x0, mut p0) = (
            self.qc.clone(),
            self.r.clone(),
            self.x0.clone(),
            self.p0.clone(),
        );
        for (prm, &th) in self.params.iter().zip(theta) {
            let v = prm.transform().value(th).0;
            for e in prm.entries() {
                for (i, j) in mirror(e) {
                    match e.matrix {
                        Matrix::Q => qc[i + j * q] = e.coefficient * v,
                        Matrix::R => r[i + j * m] = e.coefficient * v,
                        Matrix::X0 => x0[i] = e.coefficient * v,
                        Matrix::P0 => p0[i + j * n] = e.coefficient * v,
                        Matrix::F => a[i + j * n] = e.coefficient * v,
                        Matrix::B | Matrix::H => {}
                    }
                }
            }
        }
        let mat = |v: &[f64], k: usize| Mat::from_fn(k, k, |i, j| v[i + j * k]);
        Ok(Matrices {
            a: mat(&a, n),
            w: mat(&qc, q),
            r: mat(&r, m),
            x0,
            p0: mat(&p0, n),
        })
    }

    fn check_theta(&self, theta: &[f64]) -> Result<(), FitError> {
        if theta.len() != self.params.len() {
            return Err(FitError::Parameters(format!(
                "θ has {} entries, the map has {} parameters",
                theta.len(),
                self.params.len()
            )));
        }
        if let Some(i) = theta.iter().position(|v| !v.is_finite()) {
            return Err(FitError::Parameters(format!(
                "entry {i} ({}) is {}",
                self.params[i].name(),
                theta[i]
            )));
        }
        Ok(())
    }

    /// Maximum likelihood over `data` (the record whose stamps the map was sampled at), from
    /// the base values ([`SampledMap::theta0`]): [`filter_error`] on this map.
    ///
    /// # Errors
    /// [`FitError::Data`] for a record whose length or input width is not the map's, and
    /// those of [`filter_error`].
    pub fn fit(&self, data: &Series<'_>, opts: &MleOptions) -> Result<ParametricFit, FitError> {
        if data.len() != self.len() {
            return Err(FitError::Data(format!(
                "the record has {} rows, the map was sampled at {} time stamps",
                data.len(),
                self.len()
            )));
        }
        if data.p() != self.p {
            return Err(FitError::Data(format!(
                "the record has {} input columns, the model has p = {}",
                data.p(),
                self.p
            )));
        }
        filter_error(self, self.theta0()?, std::slice::from_ref(data), opts)
    }

    /// The drift at θ over the scalar of the pass.
    fn drift_at<T: Scalar>(&self, theta: &[T]) -> Vec<T> {
        let mut a: Vec<T> = self.a.iter().map(|&v| T::from(v)).collect();
        self.set(theta, Matrix::F, self.n, &mut a);
        a
    }

    /// `out = F x + B_d u` with `[[F, B_d], [0, I]] = e^{[[A, B], [0, 0]]Δt}` at θ (NaN where
    /// the exponential is not finite, which the pass reports as its divergence).
    fn f_at<T: Scalar>(&self, theta: &[T], x: &[T], u: Option<&[f64]>, dt: f64, out: &mut [T]) {
        let (n, p) = (self.n, self.p);
        if dt == 0.0 {
            out[..n].copy_from_slice(&x[..n]);
            return;
        }
        let a = self.drift_at(theta);
        let k = n + p;
        let mut m = vec![T::from(0.0); k * k];
        for j in 0..n {
            for i in 0..n {
                m[i + j * k] = a[i + j * n] * dt;
            }
        }
        for j in 0..p {
            for i in 0..n {
                m[i + (n + j) * k] = T::from(self.bc[i + j * n] * dt);
            }
        }
        let Some(e) = numerics::expm_of(&m, k, n) else {
            out[..n].iter_mut().for_each(|o| *o = T::from(f64::NAN));
            return;
        };
        for i in 0..n {
            let mut acc = T::from(0.0);
            for j in 0..n {
                acc += e[i + j * k] * x[j];
            }
            if let Some(u) = u {
                for j in 0..p {
                    acc += e[i + (n + j) * k] * u[j];
                }
            }
            out[i] = acc;
        }
    }

    /// Van Loan's `Q` at θ: `e^{[[−A, W], [0, Aᵀ]]Δt} = [[·, F⁻¹Q], [0, Fᵀ]]`, W = G W_θ Gᵀ.
    fn q_at<T: Scalar>(&self, theta: &[T], dt: f64, out: &mut [T]) {
        let (n, q) = (self.n, self.nq);
        out[..n * n].iter_mut().for_each(|o| *o = T::from(0.0));
        if dt == 0.0 {
            return;
        }
        let a = self.drift_at(theta);
        let mut wq: Vec<T> = self.qc.iter().map(|&v| T::from(v)).collect();
        self.set(theta, Matrix::Q, q, &mut wq);
        let k = 2 * n;
        let mut m = vec![T::from(0.0); k * k];
        for j in 0..n {
            for i in 0..n {
                let mut w = T::from(0.0);
                for b in 0..q {
                    for c in 0..q {
                        w += wq[c + b * q] * (self.g[i + c * n] * self.g[j + b * n]);
                    }
                }
                m[i + j * k] = -(a[i + j * n] * dt);
                m[i + (n + j) * k] = w * dt;
                m[n + i + (n + j) * k] = a[j + i * n] * dt;
            }
        }
        let Some(e) = numerics::expm_of(&m, k, n) else {
            out[..n * n].iter_mut().for_each(|o| *o = T::from(f64::NAN));
            return;
        };
        // F = (E₂₂)ᵀ, Q = F E₁₂, symmetrised.
        for j in 0..n {
            for i in 0..n {
                let mut acc = T::from(0.0);
                for l in 0..n {
                    acc += e[n + l + (n + i) * k] * e[l + (n + j) * k];
                }
                out[i + j * n] = acc;
            }
        }
        for j in 0..n {
            for i in 0..j {
                let s = (out[i + j * n] + out[j + i * n]) * 0.5;
                out[i + j * n] = s;
                out[j + i * n] = s;
            }
        }
    }

    fn interval(&self, k: usize) -> usize {
        // Past the last stamp (not reached through `fit`): the last row's Δt = 0 block.
        self.step
            .get(k)
            .or(self.step.last())
            .copied()
            .unwrap_or_default()
    }

    /// `out[cells of Matrix::which] = coefficient · v(θ)`, for the matrix `which` of
    /// `k`×`k` entries.
    fn set<T: Scalar>(&self, theta: &[T], which: Matrix, k: usize, out: &mut [T]) {
        for (prm, &th) in self.params.iter().zip(theta) {
            let v = value(prm.transform(), th);
            for e in prm.entries().iter().filter(|e| e.matrix == which) {
                for (i, j) in mirror(e) {
                    out[i + j * k] = v * T::from(e.coefficient);
                }
            }
        }
    }
}

impl ParametricModel for SampledMap {
    fn dims(&self) -> (usize, usize, usize) {
        (self.n, self.m, self.params.len())
    }

    fn names(&self) -> Vec<String> {
        self.params.iter().map(|p| p.name().to_string()).collect()
    }

    fn f<T: Scalar>(&self, theta: &[T], x: &[T], u: Option<&[f64]>, k: usize, out: &mut [T]) {
        let (n, p) = (self.n, self.p);
        let iv = self.interval(k);
        if self.drift {
            return self.f_at(theta, x, u, self.dts.get(iv).copied().unwrap_or(0.0), out);
        }
        let (F, B) = (
            &self.f[iv * n * n..(iv + 1) * n * n],
            &self.b[iv * n * p..(iv + 1) * n * p],
        );
        for i in 0..n {
            let mut acc = T::from(0.0);
            for j in 0..n {
                acc += x[j] * T::from(F[i + j * n]);
            }
            if let Some(u) = u {
                acc += T::from((0..p).map(|j| B[i + j * n] * u[j]).sum::<f64>());
            }
            out[i] = acc;
        }
    }

    fn h<T: Scalar>(&self, _theta: &[T], x: &[T], _k: usize, out: &mut [T]) {
        let (n, m) = (self.n, self.m);
        for i in 0..m {
            let mut acc = T::from(0.0);
            for j in 0..n {
                acc += x[j] * T::from(self.h[i + j * m]);
            }
            out[i] = acc;
        }
    }

    fn q<T: Scalar>(&self, theta: &[T], k: usize, out: &mut [T]) {
        let nn = self.n * self.n;
        let iv = self.interval(k);
        if self.drift {
            return self.q_at(theta, self.dts.get(iv).copied().unwrap_or(0.0), out);
        }
        for (o, &v) in out.iter_mut().zip(&self.q_fixed[iv * nn..(iv + 1) * nn]) {
            *o = T::from(v);
        }
        let np = self.params.len();
        for (j, (prm, &th)) in self.params.iter().zip(theta).enumerate() {
            if !prm.entries().iter().any(|e| e.matrix == Matrix::Q) {
                continue;
            }
            let v = value(prm.transform(), th);
            let block = &self.q_basis[(iv * np + j) * nn..(iv * np + j + 1) * nn];
            for (o, &s) in out.iter_mut().zip(block) {
                *o += v * T::from(s);
            }
        }
    }

    fn r<T: Scalar>(&self, theta: &[T], _k: usize, out: &mut [T]) {
        for (o, &v) in out.iter_mut().zip(&self.r) {
            *o = T::from(v);
        }
        self.set(theta, Matrix::R, self.m, out);
    }

    fn x0<T: Scalar>(&self, theta: &[T], out: &mut [T]) {
        for (o, &v) in out.iter_mut().zip(&self.x0) {
            *o = T::from(v);
        }
        self.set(theta, Matrix::X0, self.n, out);
    }

    fn p0<T: Scalar>(&self, theta: &[T], out: &mut [T]) {
        for (o, &v) in out.iter_mut().zip(&self.p0) {
            *o = T::from(v);
        }
        self.set(theta, Matrix::P0, self.n, out);
    }
}

/// `v(θ)` over a generic scalar.
fn value<T: Scalar>(transform: Transform, theta: T) -> T {
    match transform {
        Transform::Identity => theta,
        Transform::Log => theta.exp(),
        Transform::Tanh => theta.tanh(),
    }
}

/// The `(row, column)` cells an entry sets ([`super::entries::cells`]).
fn mirror(e: &Entry) -> impl Iterator<Item = (usize, usize)> {
    super::entries::cells(e).into_iter().map(|(_, i, j)| (i, j))
}

/// A `rows`×`cols` matrix, column-major, checked finite.
fn dense(name: &str, a: &impl MatrixInput, rows: usize, cols: usize) -> Result<Vec<f64>, FitError> {
    if a.nrows() != rows || a.ncols() != cols {
        return Err(FitError::Data(format!(
            "{name} is {}×{}, expected {rows}×{cols}",
            a.nrows(),
            a.ncols()
        )));
    }
    let mut out = Vec::with_capacity(rows * cols);
    for j in 0..cols {
        for i in 0..rows {
            let v = a.at(i, j);
            if !v.is_finite() {
                return Err(FitError::Data(format!("{name}[{i},{j}] is {v}")));
            }
            out.push(v);
        }
    }
    Ok(out)
}

/// The free parameters' matrices, shapes, coefficients and cells.
fn check_params(params: &[Param], n: usize, m: usize, nq: usize) -> Result<(), FitError> {
    let bad = |msg: String| Err(FitError::Parameters(msg));
    let mut seen: Vec<(Matrix, usize, usize, &str)> = Vec::new();
    for prm in params {
        if prm.entries().is_empty() {
            return bad(format!("{} sets no matrix entry", prm.name()));
        }
        if params.iter().filter(|q| q.name() == prm.name()).count() > 1 {
            return bad(format!("two free parameters are named {}", prm.name()));
        }
        for e in prm.entries() {
            let (rows, cols) = match e.matrix {
                Matrix::Q => (nq, nq),
                Matrix::R => (m, m),
                Matrix::X0 => (n, 1),
                Matrix::P0 => (n, n),
                Matrix::F => (n, n),
                Matrix::B | Matrix::H => {
                    return bad(format!(
                        "{}: {} is fixed in a continuous model's fit (the drift A, addressed as \
                         F, its noise intensity Q, R, x0 and P0 can be free)",
                        prm.name(),
                        e.matrix.name()
                    ));
                }
            };
            if e.row >= rows || e.col >= cols {
                return bad(format!(
                    "{}: entry {}[{},{}] is outside the {rows}×{cols} matrix",
                    prm.name(),
                    e.matrix.name(),
                    e.row,
                    e.col
                ));
            }
            if !e.coefficient.is_finite() || e.coefficient == 0.0 {
                return bad(format!(
                    "{}: the coefficient of {}[{},{}] is {} (must be finite and non-zero)",
                    prm.name(),
                    e.matrix.name(),
                    e.row,
                    e.col,
                    e.coefficient
                ));
            }
            for (i, j) in mirror(e) {
                if let Some(s) = seen.iter().find(|s| (s.0, s.1, s.2) == (e.matrix, i, j)) {
                    return bad(format!(
                        "{}[{i},{j}] is set by both {} and {}",
                        e.matrix.name(),
                        s.3,
                        prm.name()
                    ));
                }
                seen.push((e.matrix, i, j, prm.name()));
            }
        }
    }
    Ok(())
}
