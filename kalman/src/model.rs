//! Validated model types and the validation layer shared by both storage paths.
#![allow(non_snake_case)]

use faer::{Mat, MatRef, Side};

use crate::Error;
use crate::storage::{Buf, Dims, DynDims, FIXED_MAX};

/// The workspace's covariance tolerances (their home is `numerics`): symmetry within
/// `SYMMETRY_TOL·max|A|` (accepted matrices are stored symmetrised), PSD down to
/// `−PSD_TOL·max|λ|`.
pub use numerics::{PSD_TOL, SYMMETRY_TOL};

pub use crate::input::{Diagonal, MatrixInput};

/// A faer copy of a matrix input (for the solvers that work on whole matrices: Riccati,
/// matrix exponential, Kalman–Bucy).
pub(crate) fn owned<T: MatrixInput + ?Sized>(a: &T) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| a.at(i, j))
}

/// Checks that `a` is `rows`×`cols` with finite entries: [`Error::Shape`] or
/// [`Error::NonFinite`] (the first bad entry in column-major order) naming `name`. The one
/// shape/finiteness check of matrix inputs in the crate.
pub(crate) fn check(
    name: &'static str,
    a: impl MatrixInput,
    rows: usize,
    cols: usize,
) -> Result<(), Error> {
    check_shape(name, &a, rows, cols)?;
    for j in 0..cols {
        for i in 0..rows {
            if !a.at(i, j).is_finite() {
                return Err(Error::NonFinite {
                    name,
                    rows,
                    cols,
                    row: i,
                    col: j,
                });
            }
        }
    }
    Ok(())
}

/// The shape half of [`check`]: [`Error::Shape`] naming `name` unless `a` is `rows`×`cols`.
pub(crate) fn check_shape(
    name: &'static str,
    a: &impl MatrixInput,
    rows: usize,
    cols: usize,
) -> Result<(), Error> {
    if a.nrows() != rows || a.ncols() != cols {
        return Err(Error::Shape {
            name,
            rows: a.nrows(),
            cols: a.ncols(),
            expected_rows: rows,
            expected_cols: cols,
        });
    }
    Ok(())
}

/// Checks the shape and finiteness of `a` ([`check`]) and copies it column-major into
/// `dst` (untouched on error).
pub(crate) fn load(
    name: &'static str,
    a: &impl MatrixInput,
    rows: usize,
    cols: usize,
    dst: &mut [f64],
) -> Result<(), Error> {
    check(name, a, rows, cols)?;
    for j in 0..cols {
        for i in 0..rows {
            dst[i + j * rows] = a.at(i, j);
        }
    }
    Ok(())
}

/// Checks that the vector `v` has length `n` and finite entries: [`Error::Shape`] or
/// [`Error::NonFinite`] naming `name`.
#[inline(always)]
pub(crate) fn check_vec(name: &'static str, v: &[f64], n: usize) -> Result<(), Error> {
    if v.len() != n {
        return Err(Error::Shape {
            name,
            rows: v.len(),
            cols: 1,
            expected_rows: n,
            expected_cols: 1,
        });
    }
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(Error::NonFinite {
            name,
            rows: n,
            cols: 1,
            row: i,
            col: 0,
        });
    }
    Ok(())
}

/// Checks the length and finiteness of a vector ([`check_vec`]) and copies it (`dst`
/// untouched on error).
pub(crate) fn load_vec(
    name: &'static str,
    v: &[f64],
    n: usize,
    dst: &mut [f64],
) -> Result<(), Error> {
    check_vec(name, v, n)?;
    dst[..n].copy_from_slice(v);
    Ok(())
}

/// Checks symmetry within [`SYMMETRY_TOL`] and symmetrises `a` (`n`×`n`, column-major) with
/// the crate's kernel ([`crate::kernels::symmetrise`]).
pub(crate) fn check_symmetric(name: &'static str, a: &mut [f64], n: usize) -> Result<(), Error> {
    let scale = a[..n * n].iter().fold(0.0_f64, |s, x| s.max(x.abs()));
    let tol = numerics::symmetry_tolerance(scale);
    let mut worst = (0.0, 0, 0);
    for j in 0..n {
        for i in j + 1..n {
            let d = (a[i + j * n] - a[j + i * n]).abs();
            if d > worst.0 {
                worst = (d, i, j);
            }
        }
    }
    if worst.0 > tol {
        return Err(Error::NotSymmetric {
            name,
            n,
            row: worst.1,
            col: worst.2,
            diff: worst.0,
            tol,
        });
    }
    crate::kernels::symmetrise(a, n);
    Ok(())
}

/// The covariance rule: [`check_symmetric`] (which symmetrises `a` in place), then
/// [`psd_factor`] writing a square factor of `a` into `factor`.
pub(crate) fn checked_factor(
    name: &'static str,
    a: &mut [f64],
    n: usize,
    factor: &mut [f64],
) -> Result<(), Error> {
    check_symmetric(name, a, n)?;
    psd_factor(name, a, n, factor)
}

/// Checks that the symmetric `a` is PSD within [`PSD_TOL`] and writes a square factor
/// `G` with `G Gᵀ = a` into `factor` (leading dimension `n`): the Cholesky factor when `a`
/// is positive definite, else `V·diag(√λ₊)` from its eigen-decomposition.
pub(crate) fn psd_factor(
    name: &'static str,
    a: &[f64],
    n: usize,
    factor: &mut [f64],
) -> Result<(), Error> {
    let A = MatRef::from_column_major_slice(&a[..n * n], n, n);
    let scale = a[..n * n].iter().fold(0.0_f64, |s, x| s.max(x.abs()));
    // Fast path: a Cholesky factor with pivots well above round-off proves definiteness.
    if let Ok(llt) = A.llt(Side::Lower) {
        let L = llt.L();
        let min_pivot = (0..n).fold(f64::INFINITY, |s, i| s.min(L[(i, i)]));
        if min_pivot * min_pivot > 1e-8 * scale {
            for j in 0..n {
                for i in 0..n {
                    factor[i + j * n] = if i >= j { L[(i, j)] } else { 0.0 };
                }
            }
            return Ok(());
        }
    }
    let evd = A
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| Error::Factorisation {
            name,
            reason: "symmetric eigen-decomposition did not converge",
        })?;
    let s = evd.S().column_vector();
    let u = evd.U();
    let lmax = (0..n).fold(0.0_f64, |m, i| m.max(s[i].abs()));
    let lmin = (0..n).fold(f64::INFINITY, |m, i| m.min(s[i]));
    let tol = numerics::psd_tolerance(lmax);
    if lmin < -tol {
        return Err(Error::NotPositiveSemidefinite {
            name,
            n,
            min_eigenvalue: lmin,
            tol,
        });
    }
    for j in 0..n {
        let r = s[j].max(0.0).sqrt();
        for i in 0..n {
            factor[i + j * n] = u[(i, j)] * r;
        }
    }
    Ok(())
}

/// A validated linear model `x_{k+1} = F x_k + B u_k + w_k`, `z_k = H x_k + v_k`,
/// `cov(w) = Q`, `cov(v) = R`, `E[w_k v_kᵀ] = S`, on the storage path `D`.
///
/// Construction checks shapes, finiteness, symmetry ([`SYMMETRY_TOL`]) and PSD
/// ([`PSD_TOL`]) of `Q`, `R` and of the joint noise covariance `[[R, Sᵀ], [S, Q]]`. It also
/// stores a square factor of that joint covariance for the square-root form.
///
/// # Example
/// ```
/// use kalman::{DynDims, Model};
///
/// // Constant velocity with a known acceleration input and correlated noise.
/// let dt = 0.1;
/// let model = Model::new(
///     DynDims::new(2, 1, 1)?,
///     &[[1.0, dt], [0.0, 1.0]],
///     &[[1.0, 0.0]],
///     &[[1e-4, 0.0], [0.0, 1e-2]],
///     &[[0.1]],
/// )?
/// .with_control(&[[dt * dt / 2.0], [dt]])?
/// .with_cross_covariance(&[[0.0], [1e-3]])?;
/// assert!(model.s().is_some());
/// // An indefinite joint covariance [[R, Sᵀ], [S, Q]] is refused by name.
/// let bad = Model::new(DynDims::new(1, 1, 0)?, &[[1.0]], &[[1.0]], &[[1e-4]], &[[0.1]])?
///     .with_cross_covariance(&[[1.0]]);
/// assert!(bad.is_err());
/// # Ok::<(), kalman::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct Model<D: Dims> {
    pub(crate) dims: D,
    pub(crate) F: D::Nn,
    pub(crate) H: D::Mn,
    pub(crate) Q: D::Nn,
    pub(crate) R: D::Mm,
    pub(crate) S: Option<D::Nm>,
    pub(crate) B: D::Np,
    /// `G` with `G Gᵀ = [[R, Sᵀ], [S, Q]]`, in blocks.
    pub(crate) joint: JointFactor<D>,
}

/// A square factor `G = [[G_vv, G_vw], [G_wv, G_ww]]` of the joint noise covariance
/// `[[R, Sᵀ], [S, Q]]` (rows and columns ordered v (m) then w (n)), stored by blocks so that
/// each is sized by n and m alone.
#[derive(Clone, Debug)]
pub(crate) struct JointFactor<D: Dims> {
    /// m×m.
    pub(crate) vv: D::Mm,
    /// m×n.
    pub(crate) vw: D::Mn,
    /// n×m.
    pub(crate) wv: D::Nm,
    /// n×n.
    pub(crate) ww: D::Nn,
}

impl<D: Dims> Model<D> {
    /// A time-invariant model without control input or cross-covariance.
    ///
    /// # Errors
    /// [`Error::Shape`], [`Error::NonFinite`], [`Error::NotSymmetric`],
    /// [`Error::NotPositiveSemidefinite`] naming `F`, `H`, `Q` or `R`;
    /// [`Error::Dimension`] for an empty or (fixed path) oversized model.
    pub fn new(
        dims: D,
        F: &impl MatrixInput,
        H: &impl MatrixInput,
        Q: &impl MatrixInput,
        R: &impl MatrixInput,
    ) -> Result<Self, Error> {
        let (n, m, p) = (dims.n(), dims.m(), dims.p());
        check_dims(&dims)?;
        let mut model = Model {
            dims,
            F: D::Nn::zeros(n * n),
            H: D::Mn::zeros(m * n),
            Q: D::Nn::zeros(n * n),
            R: D::Mm::zeros(m * m),
            S: None,
            B: D::Np::zeros(n * p),
            joint: JointFactor {
                vv: D::Mm::zeros(m * m),
                vw: D::Mn::zeros(m * n),
                wv: D::Nm::zeros(n * m),
                ww: D::Nn::zeros(n * n),
            },
        };
        load("F", F, n, n, model.F.as_mut_slice())?;
        load("H", H, m, n, model.H.as_mut_slice())?;
        load("Q", Q, n, n, model.Q.as_mut_slice())?;
        load("R", R, m, m, model.R.as_mut_slice())?;
        check_symmetric("Q", model.Q.as_mut_slice(), n)?;
        check_symmetric("R", model.R.as_mut_slice(), m)?;
        let mut scratch = vec![0.0; n.max(m) * n.max(m)];
        psd_factor("Q", model.Q.as_slice(), n, &mut scratch)?;
        psd_factor("R", model.R.as_slice(), m, &mut scratch)?;
        model.refactor_joint()?;
        Ok(model)
    }

    /// Adds the cross-covariance `S = E[w_k v_kᵀ]` (n×m) of process and measurement noise.
    ///
    /// # Errors
    /// [`Error::Shape`]/[`Error::NonFinite`] naming `S`; [`Error::NotPositiveSemidefinite`]
    /// naming `[[R, S^T], [S, Q]]` if the joint noise covariance is indefinite.
    pub fn with_cross_covariance(mut self, S: &impl MatrixInput) -> Result<Self, Error> {
        let (n, m) = (self.dims.n(), self.dims.m());
        let mut buf = D::Nm::zeros(n * m);
        load("S", S, n, m, buf.as_mut_slice())?;
        self.S = Some(buf);
        self.refactor_joint()?;
        Ok(self)
    }

    /// Adds the control matrix `B` (n×p) of the known input `u_k`. A dynamic-size model built
    /// without inputs (p = 0, e.g. by [`Model::from_matrices`]) takes p from `B`'s columns;
    /// otherwise `B` must have the p columns the dimensions say.
    ///
    /// # Errors
    /// [`Error::Shape`]/[`Error::NonFinite`] naming `B`.
    pub fn with_control(mut self, B: &impl MatrixInput) -> Result<Self, Error> {
        if self.dims.p() == 0 && B.ncols() > 0 {
            if let Some(dims) = self.dims.with_inputs(B.ncols()) {
                self.dims = dims;
                self.B = D::Np::zeros(self.dims.n() * B.ncols());
            }
        }
        let (n, p) = (self.dims.n(), self.dims.p());
        load("B", B, n, p, self.B.as_mut_slice())?;
        Ok(self)
    }

    /// Overwrites F, Q and B of a model without cross-covariance S (a sampled interval of a
    /// continuous model, in `sampling`): Q is checked symmetric and PSD by the crate's
    /// rule and symmetrised, and the joint noise factor is that of `[[R, 0], [0, Q]]`. Allocates
    /// nothing unless R or Q is singular (then the eigen-decomposition path).
    pub(crate) fn resample(&mut self, F: &[f64], Q: &[f64], B: &[f64]) -> Result<(), Error> {
        let (n, m, p) = (self.dims.n(), self.dims.m(), self.dims.p());
        self.F.as_mut_slice()[..n * n].copy_from_slice(&F[..n * n]);
        self.Q.as_mut_slice()[..n * n].copy_from_slice(&Q[..n * n]);
        check_symmetric("Q", self.Q.as_mut_slice(), n)?;
        self.B.as_mut_slice()[..n * p].copy_from_slice(&B[..n * p]);
        if self.S.is_some() {
            return self.refactor_joint();
        }
        // The Cholesky factors of the two blocks, with psd_factor's fast-path rule (pivots
        // above 1e-8 of the scale prove definiteness); anything else takes the general path.
        let fast = |a: &[f64], k: usize, out: &mut [f64]| -> bool {
            let scale = a[..k * k].iter().fold(0.0_f64, |s, x| s.max(x.abs()));
            out[..k * k].copy_from_slice(&a[..k * k]);
            if !crate::kernels::cholesky(&mut out[..k * k], k, 1e-8 * scale) {
                return false;
            }
            for j in 1..k {
                for i in 0..j {
                    out[i + j * k] = 0.0;
                }
            }
            true
        };
        let J = &mut self.joint;
        if !(fast(self.R.as_slice(), m, J.vv.as_mut_slice())
            && fast(self.Q.as_slice(), n, J.ww.as_mut_slice()))
        {
            return self.refactor_joint();
        }
        J.vw.as_mut_slice()[..m * n]
            .iter_mut()
            .for_each(|x| *x = 0.0);
        J.wv.as_mut_slice()[..n * m]
            .iter_mut()
            .for_each(|x| *x = 0.0);
        Ok(())
    }

    /// Makes this model `from` with its measurement noise scaled entry by entry, `v' = D v`
    /// for `D = diag(d)`: `R' = D R D`, `S' = S D`, and the joint factor's measurement rows
    /// scaled by D (so no refactorisation). Both models must have the same dimensions and
    /// the same presence of S (a clone of `from` has both); allocates nothing.
    pub(crate) fn scaled_measurement_noise(&mut self, from: &Model<D>, d: &[f64]) {
        let (n, m, p) = (self.dims.n(), self.dims.m(), self.dims.p());
        let copy =
            |dst: &mut [f64], src: &[f64], len: usize| dst[..len].copy_from_slice(&src[..len]);
        copy(self.F.as_mut_slice(), from.F.as_slice(), n * n);
        copy(self.H.as_mut_slice(), from.H.as_slice(), m * n);
        copy(self.Q.as_mut_slice(), from.Q.as_slice(), n * n);
        copy(self.B.as_mut_slice(), from.B.as_slice(), n * p);
        let R = self.R.as_mut_slice();
        let R0 = from.R.as_slice();
        for j in 0..m {
            for i in 0..m {
                R[i + j * m] = d[i] * R0[i + j * m] * d[j];
            }
        }
        if let (Some(S), Some(S0)) = (&mut self.S, &from.S) {
            let (S, S0) = (S.as_mut_slice(), S0.as_slice());
            for j in 0..m {
                for i in 0..n {
                    S[i + j * n] = S0[i + j * n] * d[j];
                }
            }
        }
        let (J, J0) = (&mut self.joint, &from.joint);
        let (vv, vv0) = (J.vv.as_mut_slice(), J0.vv.as_slice());
        for j in 0..m {
            for i in 0..m {
                vv[i + j * m] = d[i] * vv0[i + j * m];
            }
        }
        let (vw, vw0) = (J.vw.as_mut_slice(), J0.vw.as_slice());
        for j in 0..n {
            for i in 0..m {
                vw[i + j * m] = d[i] * vw0[i + j * m];
            }
        }
        copy(J.wv.as_mut_slice(), J0.wv.as_slice(), n * m);
        copy(J.ww.as_mut_slice(), J0.ww.as_slice(), n * n);
    }

    fn refactor_joint(&mut self) -> Result<(), Error> {
        let (n, m) = (self.dims.n(), self.dims.m());
        let d = n + m;
        let mut w = vec![0.0; d * d];
        let (R, Q) = (self.R.as_slice(), self.Q.as_slice());
        for j in 0..m {
            for i in 0..m {
                w[i + j * d] = R[i + j * m];
            }
        }
        for j in 0..n {
            for i in 0..n {
                w[m + i + (m + j) * d] = Q[i + j * n];
            }
        }
        if let Some(S) = &self.S {
            let S = S.as_slice();
            for j in 0..m {
                for i in 0..n {
                    w[m + i + j * d] = S[i + j * n];
                    w[j + (m + i) * d] = S[i + j * n];
                }
            }
        }
        let mut f = vec![0.0; d * d];
        psd_factor("[[R, S^T], [S, Q]]", &w, d, &mut f)?;
        let J = &mut self.joint;
        let (vv, vw) = (J.vv.as_mut_slice(), J.vw.as_mut_slice());
        let (wv, ww) = (J.wv.as_mut_slice(), J.ww.as_mut_slice());
        for j in 0..d {
            for i in 0..d {
                let g = f[i + j * d];
                match (i < m, j < m) {
                    (true, true) => vv[i + j * m] = g,
                    (true, false) => vw[i + (j - m) * m] = g,
                    (false, true) => wv[i - m + j * n] = g,
                    (false, false) => ww[i - m + (j - m) * n] = g,
                }
            }
        }
        Ok(())
    }

    /// The dimensions.
    pub fn dims(&self) -> D {
        self.dims
    }
    /// Transition matrix `F` (n×n).
    pub fn f(&self) -> MatRef<'_, f64> {
        let n = self.dims.n();
        MatRef::from_column_major_slice(&self.F.as_slice()[..n * n], n, n)
    }
    /// Measurement matrix `H` (m×n).
    pub fn h(&self) -> MatRef<'_, f64> {
        let (n, m) = (self.dims.n(), self.dims.m());
        MatRef::from_column_major_slice(&self.H.as_slice()[..m * n], m, n)
    }
    /// Process noise covariance `Q` (n×n).
    pub fn q(&self) -> MatRef<'_, f64> {
        let n = self.dims.n();
        MatRef::from_column_major_slice(&self.Q.as_slice()[..n * n], n, n)
    }
    /// Measurement noise covariance `R` (m×m).
    pub fn r(&self) -> MatRef<'_, f64> {
        let m = self.dims.m();
        MatRef::from_column_major_slice(&self.R.as_slice()[..m * m], m, m)
    }
    /// Cross-covariance `S` (n×m), if any.
    pub fn s(&self) -> Option<MatRef<'_, f64>> {
        let (n, m) = (self.dims.n(), self.dims.m());
        self.S
            .as_ref()
            .map(|s| MatRef::from_column_major_slice(&s.as_slice()[..n * m], n, m))
    }
    /// Control matrix `B` (n×p; zero unless set).
    pub fn b(&self) -> MatRef<'_, f64> {
        let (n, p) = (self.dims.n(), self.dims.p());
        MatRef::from_column_major_slice(&self.B.as_slice()[..n * p], n, p)
    }
}

impl Model<DynDims> {
    /// A dynamic-size model whose dimensions are read off the matrices: n from `F`'s rows,
    /// m from `H`'s rows, no control input (add one with [`Model::with_control`], which then
    /// takes p from `B`). The same checks as [`Model::new`], so a matrix of the wrong shape
    /// is still refused by name.
    ///
    /// # Errors
    /// As [`Model::new`]; [`Error::Dimension`] if `F` or `H` has no rows.
    ///
    /// # Example
    /// ```
    /// use kalman::{Dims, Model};
    ///
    /// let dt = 0.5;
    /// let model = Model::from_matrices(&[[1.0, dt], [0.0, 1.0]], &[[1.0, 0.0]], &[[1e-3, 0.0], [0.0, 1e-2]], &[[0.1]])?
    ///     .with_control(&[[dt * dt / 2.0], [dt]])?;
    /// assert_eq!((model.dims().n(), model.dims().m(), model.dims().p()), (2, 1, 1));
    /// // H with three columns does not fit two states.
    /// let bad = Model::from_matrices(&[[1.0, dt], [0.0, 1.0]], &[[1.0, 0.0, 0.0]], &[[1.0, 0.0], [0.0, 1.0]], &[[1.0]]);
    /// assert!(matches!(bad, Err(kalman::Error::Shape { name: "H", .. })));
    /// # Ok::<(), kalman::Error>(())
    /// ```
    pub fn from_matrices(
        F: &impl MatrixInput,
        H: &impl MatrixInput,
        Q: &impl MatrixInput,
        R: &impl MatrixInput,
    ) -> Result<Self, Error> {
        Self::new(DynDims::new(F.nrows(), H.nrows(), 0)?, F, H, Q, R)
    }
}

fn check_dims<D: Dims>(dims: &D) -> Result<(), Error> {
    for (name, v) in [("n", dims.n()), ("m", dims.m())] {
        if v == 0 {
            return Err(Error::Dimension {
                name,
                value: v,
                rule: "must be at least 1",
            });
        }
    }
    if dims.stored() != dims.n() {
        return Err(Error::Dimension {
            name: "stored",
            value: dims.stored(),
            rule: "a linear model's state is a vector: stored length = n",
        });
    }
    if dims.is_fixed() {
        for (name, v) in [("n", dims.n()), ("m", dims.m()), ("p", dims.p())] {
            if v > FIXED_MAX {
                return Err(Error::Dimension {
                    name,
                    value: v,
                    rule: "the fixed-size path supports n, m, p <= 16",
                });
            }
        }
    }
    Ok(())
}

/// A source of per-step models for time-varying systems: step `k` uses `model(k)` (its `H`
/// for the update with `z_k`, its `F`, `B`, `Q`, `S` for the prediction to `k + 1`).
/// Models are validated once when built, so a step stays allocation-free.
pub trait ModelSource<D: Dims> {
    /// The model of step `k` (`None` ends the sequence: the step returns
    /// [`Error::NoModel`]).
    fn model(&self, k: usize) -> Option<&Model<D>>;
}

impl<D: Dims> ModelSource<D> for Model<D> {
    fn model(&self, _k: usize) -> Option<&Model<D>> {
        Some(self)
    }
}

/// A list of models, one per step; steps past the end reuse the last one.
impl<D: Dims> ModelSource<D> for [Model<D>] {
    fn model(&self, k: usize) -> Option<&Model<D>> {
        self.get(k).or(self.last())
    }
}

impl<D: Dims> ModelSource<D> for Vec<Model<D>> {
    fn model(&self, k: usize) -> Option<&Model<D>> {
        self.as_slice().model(k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::FixedDims;

    const F: [[f64; 2]; 2] = [[1.0, 0.5], [0.0, 1.0]];
    const H: [[f64; 2]; 1] = [[1.0, 0.0]];
    const Q: [[f64; 2]; 2] = [[0.02, 0.01], [0.01, 0.04]];
    const R: [[f64; 1]; 1] = [[0.3]];

    #[test]
    fn from_matrices_reads_the_dimensions_and_stores_the_same_model_as_new() {
        let inferred = Model::from_matrices(&F, &H, &Q, &R).expect("valid");
        let explicit =
            Model::new(DynDims::new(2, 1, 0).expect("dims"), &F, &H, &Q, &R).expect("valid");
        assert_eq!(inferred.dims(), explicit.dims());
        for (a, b) in [(inferred.f(), explicit.f()), (inferred.q(), explicit.q())] {
            assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
            assert!((a - b).norm_max() < f64::MIN_POSITIVE);
        }
        // Q with the wrong shape is still refused by name: n comes from F, not from Q.
        let bad = Model::from_matrices(&F, &H, &[[1.0]], &R);
        assert!(matches!(
            bad,
            Err(Error::Shape {
                name: "Q",
                expected_rows: 2,
                ..
            })
        ));
        let empty = Model::from_matrices(&Mat::<f64>::zeros(0, 0), &H, &Q, &R);
        assert!(matches!(empty, Err(Error::Dimension { name: "n", .. })));
    }

    #[test]
    fn with_control_takes_p_from_b_only_where_p_is_free() {
        let b = [[0.125, 1.0], [0.5, 0.0]];
        let model = Model::from_matrices(&F, &H, &Q, &R)
            .and_then(|m| m.with_control(&b))
            .expect("valid");
        assert_eq!(model.dims().p(), 2);
        assert!((model.b()[(0, 1)] - 1.0).abs() < f64::MIN_POSITIVE);
        // Declared p = 1: a two-column B is a shape error, as before.
        let declared =
            Model::new(DynDims::new(2, 1, 1).expect("dims"), &F, &H, &Q, &R).expect("valid");
        assert!(matches!(
            declared.with_control(&b),
            Err(Error::Shape {
                name: "B",
                expected_cols: 1,
                ..
            })
        ));
        // The fixed path's p is part of the type.
        let fixed = Model::new(FixedDims::<2, 1, 0>::new(), &F, &H, &Q, &R).expect("valid");
        assert!(matches!(
            fixed.with_control(&b),
            Err(Error::Shape {
                name: "B",
                expected_cols: 0,
                ..
            })
        ));
    }
}
