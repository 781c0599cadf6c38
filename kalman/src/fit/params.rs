//! Parameterisations θ → System: the [`ParamMap`] trait, the standard map that frees Q, R,
//! x0 and a diagonal P0, and a closure-based map for user models.

use faer::Mat;

use super::entries::{self, Matrix, Param, Transform};
use super::{FitError, Series, System};

/// A map from an unconstrained parameter vector θ to a [`System`], with the derivative of
/// every matrix with respect to every parameter.
///
/// Implement [`ParamMap::derivatives`] when the derivatives are known in closed form; the
/// default differentiates [`ParamMap::system`] by central differences (a fallback: the
/// likelihood gradient is then exact only up to that differencing of the matrices).
pub trait ParamMap {
    /// Number of parameters.
    fn n_params(&self) -> usize;
    /// A name per parameter (used in messages).
    fn names(&self) -> Vec<String>;
    /// The system at θ.
    ///
    /// # Errors
    /// Whatever makes θ invalid for the map.
    fn system(&self, theta: &[f64]) -> Result<System, FitError>;
    /// `∂System/∂θ_i` for every i.
    ///
    /// # Errors
    /// As [`ParamMap::system`].
    fn derivatives(&self, theta: &[f64]) -> Result<Vec<Derivative>, FitError> {
        central_differences(self, theta)
    }
    /// Indices of the parameters that are logarithms of variances (a variance whose
    /// logarithm runs to −∞ is an optimum on the boundary). Default: none.
    fn log_variances(&self) -> Vec<usize> {
        Vec::new()
    }
}

/// The derivative of a [`System`] with respect to one parameter; `None` means identically
/// zero (skipped by the recursions).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Derivative {
    /// ∂F/∂θ_i.
    pub f: Option<Mat<f64>>,
    /// ∂B/∂θ_i.
    pub b: Option<Mat<f64>>,
    /// ∂H/∂θ_i.
    pub h: Option<Mat<f64>>,
    /// ∂Q/∂θ_i.
    pub q: Option<Mat<f64>>,
    /// ∂R/∂θ_i.
    pub r: Option<Mat<f64>>,
    /// ∂x0/∂θ_i.
    pub x0: Option<Vec<f64>>,
    /// ∂P0/∂θ_i.
    pub p0: Option<Mat<f64>>,
}

fn check_theta(theta: &[f64], len: usize) -> Result<(), FitError> {
    if theta.len() != len {
        return Err(FitError::Parameters(format!(
            "θ has {} entries, the map has {len}",
            theta.len()
        )));
    }
    if let Some(i) = theta.iter().position(|v| !v.is_finite()) {
        return Err(FitError::Parameters(format!(
            "θ[{i}] = {} is not finite",
            theta[i]
        )));
    }
    Ok(())
}

/// Central differences of a map's matrices, step `1e-6·max(1, |θ_i|)`: truncation
/// `O(h²)` ≈ 1e-12 relative, round-off ≈ 1e-10 relative.
fn central_differences<M: ParamMap + ?Sized>(
    map: &M,
    theta: &[f64],
) -> Result<Vec<Derivative>, FitError> {
    let mut out = Vec::with_capacity(theta.len());
    let mut t = theta.to_vec();
    for i in 0..theta.len() {
        let h = 1e-6 * theta[i].abs().max(1.0);
        t[i] = theta[i] + h;
        let hi = map.system(&t)?;
        t[i] = theta[i] - h;
        let lo = map.system(&t)?;
        t[i] = theta[i];
        let d = |a: &Mat<f64>, b: &Mat<f64>| -> Option<Mat<f64>> {
            let m = Mat::from_fn(a.nrows(), a.ncols(), |r, c| {
                (a[(r, c)] - b[(r, c)]) / (2.0 * h)
            });
            let nz = (0..m.ncols()).any(|c| (0..m.nrows()).any(|r| m[(r, c)] != 0.0));
            nz.then_some(m)
        };
        let dx0: Vec<f64> = hi
            .x0
            .iter()
            .zip(&lo.x0)
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect();
        out.push(Derivative {
            f: d(&hi.f, &lo.f),
            b: d(&hi.b, &lo.b),
            h: d(&hi.h, &lo.h),
            q: d(&hi.q, &lo.q),
            r: d(&hi.r, &lo.r),
            x0: dx0.iter().any(|v| *v != 0.0).then_some(dx0),
            p0: d(&hi.p0, &lo.p0),
        });
    }
    Ok(out)
}

/// How a covariance is freed.
///
/// # Example
/// ```
/// use kalman::CovarianceForm;
/// use kalman::fit::{EmOptions, Free, Series, StandardMap, Structure, System, em, log_likelihood};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // A local level: learn the scalar Q and R from ten samples.
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let free = Free { q: Structure::Scalar, r: Structure::Scalar, ..Free::default() };
/// let map = StandardMap::new(base.clone(), free)?;
/// let z = [0.3, 1.1, 0.8, 1.9, 2.4, 2.2, 3.1, 3.9, 3.5, 4.2];
/// let data = Series::new(&z, 1)?;
/// let fit = em(&map, &data, &EmOptions { tol: 1e-9, max_iter: 2000, ..EmOptions::default() })?;
/// // EM never lowers the likelihood: the optimum is at least as likely as the start.
/// assert!(fit.loglik >= log_likelihood(&base, &data, CovarianceForm::Joseph)? - 1e-9);
/// # Ok(())
/// # }
/// ```
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Structure {
    /// Kept at the base system's value.
    #[default]
    Fixed,
    /// `σ²·I`, θ = ln σ² (one parameter).
    Scalar,
    /// `diag(σ_i²)`, θ_i = ln σ_i² (one per row).
    Diag,
    /// `L Lᵀ` with `L` lower triangular, θ = ln L_ii on the diagonal and `L_ij` below it
    /// (packed column by column), so every iterate is PSD.
    Full,
}

impl Structure {
    fn count(self, n: usize) -> usize {
        match self {
            Structure::Fixed => 0,
            Structure::Scalar => 1,
            Structure::Diag => n,
            Structure::Full => n * (n + 1) / 2,
        }
    }
}

/// What [`StandardMap`] frees.
///
/// # Example
/// ```
/// use kalman::CovarianceForm;
/// use kalman::fit::{EmOptions, Free, Series, StandardMap, Structure, System, em, log_likelihood};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// // A local level: learn the scalar Q and R from ten samples.
/// let base = System::new(&[[1.0]], &[[1.0]], &[[1.0]], &[[1.0]], &[0.0], &[[10.0]])?;
/// let free = Free { q: Structure::Scalar, r: Structure::Scalar, ..Free::default() };
/// let map = StandardMap::new(base.clone(), free)?;
/// let z = [0.3, 1.1, 0.8, 1.9, 2.4, 2.2, 3.1, 3.9, 3.5, 4.2];
/// let data = Series::new(&z, 1)?;
/// let fit = em(&map, &data, &EmOptions { tol: 1e-9, max_iter: 2000, ..EmOptions::default() })?;
/// // EM never lowers the likelihood: the optimum is at least as likely as the start.
/// assert!(fit.loglik >= log_likelihood(&base, &data, CovarianceForm::Joseph)? - 1e-9);
/// # Ok(())
/// # }
/// ```
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct Free {
    /// Structure of the free Q.
    pub q: Structure,
    /// Structure of the free R.
    pub r: Structure,
    /// Whether the prior mean x0 is free.
    pub x0: bool,
    /// Whether the prior covariance P0 is free as a diagonal (θ = ln P0_ii).
    pub p0_diag: bool,
}

/// The standard parameterisation: `Q` and `R` freed with a [`Structure`], optionally `x0`
/// and a diagonal `P0`, and any number of [`Param`]s — single entries of `F`, `B`, `H`,
/// `Q`, `R`, `x0`, `P0`, or one value shared by several entries, each through its
/// [`Transform`]; every entry not freed keeps the base system's value exactly. θ is laid
/// out as `[Q | R | x0 | P0 | params]`.
///
/// # Example
/// ```
/// use kalman::fit::{Free, ParamMap, StandardMap, Structure, System};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let base = System::new(&[[1.0, 1.0], [0.0, 1.0]], &[[1.0, 0.0]], &[[1.0, 0.0], [0.0, 0.1]], &[[2.0]], &[0.0, 0.0], &[[10.0, 0.0], [0.0, 10.0]])?;
/// let map = StandardMap::new(base, Free { q: Structure::Full, r: Structure::Scalar, ..Free::default() })?;
/// assert_eq!(map.n_params(), 4);
/// let sys = map.system(&[0.0, 0.5, 0.0, 2.0_f64.ln()])?;
/// assert!((sys.q[(1, 0)] - 0.5).abs() < 1e-15 && (sys.r[(0, 0)] - 2.0).abs() < 1e-15);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct StandardMap {
    base: System,
    free: Free,
    params: Vec<Param>,
}

/// Standard errors of the free entries, in the shapes of the free matrices (delta method
/// from the covariance of θ); `None` for what is fixed.
#[derive(Clone, Debug, PartialEq)]
pub struct MatrixStdErrors {
    /// Of Q's entries.
    pub q: Option<Mat<f64>>,
    /// Of R's entries.
    pub r: Option<Mat<f64>>,
    /// Of x0's entries.
    pub x0: Option<Vec<f64>>,
    /// Of P0's diagonal.
    pub p0: Option<Vec<f64>>,
    /// Of each free [`Param`]'s value `v(θ)`, by its name, in the map's order.
    pub params: Vec<(String, f64)>,
}

fn cov_count(s: Structure, n: usize) -> usize {
    s.count(n)
}

/// Fills `out` with the covariance of structure `s` from `t`; with `d = Some(i)`, with its
/// derivative with respect to `t[i]` instead.
fn cov_from(s: Structure, t: &[f64], n: usize, d: Option<usize>) -> Mat<f64> {
    match s {
        Structure::Fixed => Mat::zeros(n, n),
        Structure::Scalar => Mat::from_fn(n, n, |i, j| if i == j { t[0].exp() } else { 0.0 }),
        Structure::Diag => Mat::from_fn(n, n, |i, j| {
            if i == j && d.is_none_or(|k| k == i) {
                t[i].exp()
            } else {
                0.0
            }
        }),
        Structure::Full => {
            let l = chol_factor(t, n);
            match d {
                None => Mat::from_fn(n, n, |i, j| (0..n).map(|k| l[(i, k)] * l[(j, k)]).sum()),
                Some(p) => {
                    // dL has one non-zero entry: at the packed position p.
                    let (r, c) = packed(p, n);
                    let v = if r == c { l[(r, c)] } else { 1.0 };
                    // d(L Lᵀ) = dL Lᵀ + L dLᵀ; (dL Lᵀ)_{ij} = δ_{ir} v L_{jc}.
                    Mat::from_fn(n, n, |i, j| {
                        let a = if i == r { v * l[(j, c)] } else { 0.0 };
                        let b = if j == r { v * l[(i, c)] } else { 0.0 };
                        a + b
                    })
                }
            }
        }
    }
}

/// Position (row, col) of packed index p (column by column, lower triangle).
fn packed(mut p: usize, n: usize) -> (usize, usize) {
    for c in 0..n {
        let len = n - c;
        if p < len {
            return (c + p, c);
        }
        p -= len;
    }
    (n, n)
}

fn chol_factor(t: &[f64], n: usize) -> Mat<f64> {
    let mut l = Mat::zeros(n, n);
    let mut p = 0;
    for c in 0..n {
        for r in c..n {
            l[(r, c)] = if r == c { t[p].exp() } else { t[p] };
            p += 1;
        }
    }
    l
}

/// θ of a covariance `a` under structure `s`; non-positive variances become `fallback`.
fn theta_of(s: Structure, a: &Mat<f64>, fallback: f64) -> Vec<f64> {
    let n = a.nrows();
    let pos = |v: f64| {
        if v > 0.0 && v.is_finite() {
            v
        } else {
            fallback
        }
    };
    match s {
        Structure::Fixed => Vec::new(),
        Structure::Scalar => vec![pos((0..n).map(|i| a[(i, i)]).sum::<f64>() / n as f64).ln()],
        Structure::Diag => (0..n).map(|i| pos(a[(i, i)]).ln()).collect(),
        Structure::Full => {
            let mut w = super::flat(a);
            let ok = super::dense::lower_factor(&mut w, n);
            if !ok {
                w = vec![0.0; n * n];
                for i in 0..n {
                    w[i + i * n] = pos(a[(i, i)]).sqrt();
                }
            }
            let mut t = Vec::new();
            for c in 0..n {
                for r in c..n {
                    let v = w[r + c * n];
                    t.push(if r == c {
                        v.max(fallback.sqrt() * 1e-3).ln()
                    } else {
                        v
                    });
                }
            }
            t
        }
    }
}

impl StandardMap {
    /// Frees `free` of `base`.
    ///
    /// # Errors
    /// [`FitError::NothingFree`] if nothing is free.
    pub fn new(base: System, free: Free) -> Result<Self, FitError> {
        Self::with_params(base, free, Vec::new())
    }

    /// Frees `free` of `base` and the entries of `params`.
    ///
    /// # Errors
    /// [`FitError::NothingFree`] if nothing is free; [`FitError::Parameters`] for an entry
    /// outside its matrix, a zero or non-finite coefficient, a parameter without entries,
    /// two parameters of one name, an entry set twice, or an entry of a matrix that `free`
    /// already frees as a whole.
    ///
    /// # Example
    /// ```
    /// use kalman::fit::{Free, Matrix, Param, ParamMap, StandardMap, System};
    /// # fn main() -> Result<(), kalman::fit::FitError> {
    /// // AR(2) plus noise: F = [φ1 1; φ2 0], Q = diag(σ², 0), R = σ²_ε.
    /// let base = System::new(&[[0.5, 1.0], [0.2, 0.0]], &[[1.0, 0.0]], &[[1.0, 0.0], [0.0, 0.0]], &[[0.5]], &[0.0, 0.0], &[[1.0, 0.0], [0.0, 1.0]])?;
    /// let params = vec![
    ///     Param::entry(Matrix::F, 0, 0),
    ///     Param::entry(Matrix::F, 1, 0),
    ///     Param::entry(Matrix::Q, 0, 0),
    ///     Param::entry(Matrix::R, 0, 0),
    /// ];
    /// let map = StandardMap::with_params(base.clone(), Free::default(), params)?;
    /// let theta = map.theta_of(&base, None);
    /// assert_eq!(theta, vec![0.5, 0.2, 0.0, 0.5_f64.ln()]);
    /// let sys = map.system(&[0.6, -0.3, 2.0_f64.ln(), 0.0])?;
    /// assert!((sys.f[(1, 0)] + 0.3).abs() < 1e-15 && (sys.q[(0, 0)] - 2.0).abs() < 1e-15);
    /// assert!((sys.f[(0, 1)] - 1.0).abs() < 1e-15); // not freed: kept exactly
    /// # Ok(())
    /// # }
    /// ```
    pub fn with_params(base: System, free: Free, params: Vec<Param>) -> Result<Self, FitError> {
        let mut taken = Vec::new();
        if free.q != Structure::Fixed {
            taken.push(Matrix::Q);
        }
        if free.r != Structure::Fixed {
            taken.push(Matrix::R);
        }
        if free.x0 {
            taken.push(Matrix::X0);
        }
        if free.p0_diag {
            taken.push(Matrix::P0);
        }
        entries::check(&params, &base, &taken)?;
        let map = Self { base, free, params };
        if map.n_params() == 0 {
            return Err(FitError::NothingFree);
        }
        Ok(map)
    }

    /// The free entry parameters (the last `params().len()` entries of θ).
    pub fn params(&self) -> &[Param] {
        &self.params
    }

    /// The value `v(θ)` of each free [`Param`], by its name.
    ///
    /// # Errors
    /// [`FitError::Parameters`] for a θ of the wrong length or with a non-finite entry.
    pub fn param_values(&self, theta: &[f64]) -> Result<Vec<(String, f64)>, FitError> {
        check_theta(theta, self.n_params())?;
        let t = self.split(theta)[4];
        Ok(self
            .params
            .iter()
            .zip(t)
            .map(|(p, &t)| (p.name().to_string(), p.transform().value(t).0))
            .collect())
    }

    /// The base system.
    pub fn base(&self) -> &System {
        &self.base
    }

    /// What is free.
    pub fn free(&self) -> Free {
        self.free
    }

    fn counts(&self) -> [usize; 5] {
        let (n, m) = (self.base.n(), self.base.m());
        [
            cov_count(self.free.q, n),
            cov_count(self.free.r, m),
            if self.free.x0 { n } else { 0 },
            if self.free.p0_diag { n } else { 0 },
            self.params.len(),
        ]
    }

    /// θ of a system under this map (the inverse of [`ParamMap::system`] on the free part).
    /// A variance that is not positive in `sys` starts at `0.1·v̄` instead, `v̄` the mean
    /// sample variance of the data's observed channels (1 without data).
    pub fn theta_of(&self, sys: &System, data: Option<&Series<'_>>) -> Vec<f64> {
        let fallback = data.map_or(1.0, data_scale) * 0.1;
        let mut t = theta_of(self.free.q, &sys.q, fallback);
        t.extend(theta_of(self.free.r, &sys.r, fallback));
        if self.free.x0 {
            t.extend_from_slice(&sys.x0);
        }
        if self.free.p0_diag {
            t.extend((0..sys.n()).map(|i| {
                if sys.p0[(i, i)] > 0.0 {
                    sys.p0[(i, i)].ln()
                } else {
                    fallback.ln()
                }
            }));
        }
        t.extend(self.params.iter().map(|p| {
            let v = p.value_in(sys);
            p.transform().theta(v).unwrap_or(match p.transform() {
                Transform::Log => fallback.ln(),
                Transform::Identity | Transform::Tanh => 0.0,
            })
        }));
        t
    }

    /// Splits θ into its `[Q | R | x0 | P0 | params]` blocks.
    fn split<'t>(&self, theta: &'t [f64]) -> [&'t [f64]; 5] {
        let c = self.counts();
        let (q, rest) = theta.split_at(c[0]);
        let (r, rest) = rest.split_at(c[1]);
        let (x, rest) = rest.split_at(c[2]);
        let (p, e) = rest.split_at(c[3]);
        [q, r, x, p, e]
    }

    /// Standard errors of the free matrix entries from the covariance of θ (`cov`,
    /// `n_params`², column-major), by the delta method `se(a) = √(∇a ᵀ cov ∇a)`.
    ///
    /// # Errors
    /// [`FitError::Parameters`] for a θ or `cov` of the wrong size.
    pub fn matrix_std_errors(
        &self,
        theta: &[f64],
        cov: &Mat<f64>,
    ) -> Result<MatrixStdErrors, FitError> {
        let k = self.n_params();
        if cov.nrows() != k || cov.ncols() != k {
            return Err(FitError::Parameters(format!(
                "cov is {}x{}, expected {k}x{k}",
                cov.nrows(),
                cov.ncols()
            )));
        }
        let d = self.derivatives(theta)?;
        let se = |get: &dyn Fn(&Derivative) -> Option<f64>| -> f64 {
            let g: Vec<f64> = d.iter().map(|di| get(di).unwrap_or(0.0)).collect();
            let mut v = 0.0;
            for i in 0..k {
                for j in 0..k {
                    v += g[i] * cov[(i, j)] * g[j];
                }
            }
            v.max(0.0).sqrt()
        };
        let (n, m) = (self.base.n(), self.base.m());
        let mat_se = |s: Structure, dim: usize, pick: &dyn Fn(&Derivative) -> Option<&Mat<f64>>| {
            (s != Structure::Fixed)
                .then(|| Mat::from_fn(dim, dim, |i, j| se(&|di| pick(di).map(|a| a[(i, j)]))))
        };
        Ok(MatrixStdErrors {
            q: mat_se(self.free.q, n, &|di| di.q.as_ref()),
            r: mat_se(self.free.r, m, &|di| di.r.as_ref()),
            x0: self.free.x0.then(|| {
                (0..n)
                    .map(|i| se(&|di| di.x0.as_ref().map(|a| a[i])))
                    .collect()
            }),
            p0: self.free.p0_diag.then(|| {
                (0..n)
                    .map(|i| se(&|di| di.p0.as_ref().map(|a| a[(i, i)])))
                    .collect()
            }),
            params: {
                let off = k - self.params.len();
                self.params
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let (_, dv) = p.transform().value(theta[off + i]);
                        let var = cov[(off + i, off + i)].max(0.0);
                        (p.name().to_string(), dv.abs() * var.sqrt())
                    })
                    .collect()
            },
        })
    }
}

/// Mean sample variance of the observed entries of each channel (1 if none has two).
pub(crate) fn data_scale(data: &Series<'_>) -> f64 {
    let m = data.m();
    let mut total = 0.0;
    let mut channels = 0;
    for c in 0..m {
        let v: Vec<f64> = (0..data.len())
            .map(|k| data.z(k)[c])
            .filter(|v| !v.is_nan())
            .collect();
        if v.len() > 1 {
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            total += v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
            channels += 1;
        }
    }
    if channels == 0 || total <= 0.0 {
        1.0
    } else {
        total / channels as f64
    }
}

impl ParamMap for StandardMap {
    fn n_params(&self) -> usize {
        self.counts().iter().sum()
    }

    fn names(&self) -> Vec<String> {
        let (n, m) = (self.base.n(), self.base.m());
        let mut out = Vec::new();
        let cov_names = |s: Structure, name: &str, dim: usize, out: &mut Vec<String>| match s {
            Structure::Fixed => {}
            Structure::Scalar => out.push(format!("ln {name} (scalar)")),
            Structure::Diag => out.extend((0..dim).map(|i| format!("ln {name}[{i},{i}]"))),
            Structure::Full => {
                for c in 0..dim {
                    for r in c..dim {
                        out.push(if r == c {
                            format!("ln chol({name})[{r},{c}]")
                        } else {
                            format!("chol({name})[{r},{c}]")
                        });
                    }
                }
            }
        };
        cov_names(self.free.q, "Q", n, &mut out);
        cov_names(self.free.r, "R", m, &mut out);
        if self.free.x0 {
            out.extend((0..n).map(|i| format!("x0[{i}]")));
        }
        if self.free.p0_diag {
            out.extend((0..n).map(|i| format!("ln P0[{i},{i}]")));
        }
        out.extend(self.params.iter().map(|p| p.name().to_string()));
        out
    }

    fn system(&self, theta: &[f64]) -> Result<System, FitError> {
        check_theta(theta, self.n_params())?;
        let [tq, tr, tx, tp, te] = self.split(theta);
        let (n, m) = (self.base.n(), self.base.m());
        let mut s = self.base.clone();
        if self.free.q != Structure::Fixed {
            s.q = cov_from(self.free.q, tq, n, None);
        }
        if self.free.r != Structure::Fixed {
            s.r = cov_from(self.free.r, tr, m, None);
        }
        if self.free.x0 {
            s.x0 = tx.to_vec();
        }
        if self.free.p0_diag {
            s.p0 = Mat::from_fn(n, n, |i, j| if i == j { tp[i].exp() } else { 0.0 });
        }
        entries::apply(&self.params, te, &mut s);
        Ok(s)
    }

    fn derivatives(&self, theta: &[f64]) -> Result<Vec<Derivative>, FitError> {
        check_theta(theta, self.n_params())?;
        let [tq, tr, _, tp, te] = self.split(theta);
        let (n, m) = (self.base.n(), self.base.m());
        let mut out = Vec::with_capacity(theta.len());
        for i in 0..tq.len() {
            out.push(Derivative {
                q: Some(cov_from(self.free.q, tq, n, Some(i))),
                ..Derivative::default()
            });
        }
        for i in 0..tr.len() {
            out.push(Derivative {
                r: Some(cov_from(self.free.r, tr, m, Some(i))),
                ..Derivative::default()
            });
        }
        if self.free.x0 {
            for i in 0..n {
                let mut e = vec![0.0; n];
                e[i] = 1.0;
                out.push(Derivative {
                    x0: Some(e),
                    ..Derivative::default()
                });
            }
        }
        if self.free.p0_diag {
            for i in 0..n {
                out.push(Derivative {
                    p0: Some(Mat::from_fn(n, n, |r, c| {
                        if r == i && c == i { tp[i].exp() } else { 0.0 }
                    })),
                    ..Derivative::default()
                });
            }
        }
        for (p, &t) in self.params.iter().zip(te) {
            out.push(entries::derivative(p, t, &self.base));
        }
        Ok(out)
    }

    fn log_variances(&self) -> Vec<usize> {
        let c = self.counts();
        let (n, m) = (self.base.n(), self.base.m());
        let mut out = Vec::new();
        let diag_positions = |s: Structure, dim: usize, offset: usize, out: &mut Vec<usize>| match s
        {
            Structure::Fixed => {}
            Structure::Scalar => out.push(offset),
            Structure::Diag => out.extend(offset..offset + dim),
            Structure::Full => {
                let mut p = offset;
                for col in 0..dim {
                    out.push(p);
                    p += dim - col;
                }
            }
        };
        diag_positions(self.free.q, n, 0, &mut out);
        diag_positions(self.free.r, m, c[0], &mut out);
        if self.free.p0_diag {
            out.extend(c[0] + c[1] + c[2]..c[0] + c[1] + c[2] + c[3]);
        }
        let off = c[0] + c[1] + c[2] + c[3];
        out.extend(
            self.params
                .iter()
                .enumerate()
                .filter(|(_, p)| p.transform() == Transform::Log)
                .map(|(i, _)| off + i),
        );
        out
    }
}

/// A [`ParamMap`] from a closure `θ → System` (derivatives by central differences) and,
/// optionally, a closure for the exact derivatives.
///
/// # Example
/// ```
/// use kalman::fit::{FnMap, ParamMap, System};
/// // A first-order Gauss–Markov process sampled at Δt = 0.1, θ = (ln σ², ln μ).
/// let map = FnMap::new(2, |t: &[f64]| {
///     let (var, mu) = (t[0].exp(), t[1].exp());
///     let phi = (-mu * 0.1).exp();
///     System::new(&[[phi]], &[[1.0]], &[[var * (1.0 - phi * phi)]], &[[0.01]], &[0.0], &[[var]])
/// });
/// let sys = map.system(&[0.0, 0.0]).unwrap();
/// assert!((sys.f[(0, 0)] - (-0.1f64).exp()).abs() < 1e-15);
/// ```
pub struct FnMap<S, D = fn(&[f64]) -> Result<Vec<Derivative>, FitError>>
where
    S: Fn(&[f64]) -> Result<System, FitError>,
    D: Fn(&[f64]) -> Result<Vec<Derivative>, FitError>,
{
    len: usize,
    system: S,
    derivatives: Option<D>,
    log_variances: Vec<usize>,
}

impl<S, D> std::fmt::Debug for FnMap<S, D>
where
    S: Fn(&[f64]) -> Result<System, FitError>,
    D: Fn(&[f64]) -> Result<Vec<Derivative>, FitError>,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FnMap")
            .field("len", &self.len)
            .finish_non_exhaustive()
    }
}

impl<S> FnMap<S>
where
    S: Fn(&[f64]) -> Result<System, FitError>,
{
    /// A map of `len` parameters whose derivatives are taken by central differences.
    pub fn new(len: usize, system: S) -> Self {
        Self {
            len,
            system,
            derivatives: None,
            log_variances: Vec::new(),
        }
    }
}

impl<S, D> FnMap<S, D>
where
    S: Fn(&[f64]) -> Result<System, FitError>,
    D: Fn(&[f64]) -> Result<Vec<Derivative>, FitError>,
{
    /// A map of `len` parameters with exact derivatives.
    pub fn with_derivatives(len: usize, system: S, derivatives: D) -> Self {
        Self {
            len,
            system,
            derivatives: Some(derivatives),
            log_variances: Vec::new(),
        }
    }

    /// Declares which parameters are logarithms of variances (for the boundary flag).
    pub fn with_log_variances(mut self, idx: Vec<usize>) -> Self {
        self.log_variances = idx;
        self
    }
}

impl<S, D> ParamMap for FnMap<S, D>
where
    S: Fn(&[f64]) -> Result<System, FitError>,
    D: Fn(&[f64]) -> Result<Vec<Derivative>, FitError>,
{
    fn n_params(&self) -> usize {
        self.len
    }
    fn names(&self) -> Vec<String> {
        (0..self.len).map(|i| format!("θ[{i}]")).collect()
    }
    fn system(&self, theta: &[f64]) -> Result<System, FitError> {
        check_theta(theta, self.len)?;
        (self.system)(theta)
    }
    fn derivatives(&self, theta: &[f64]) -> Result<Vec<Derivative>, FitError> {
        check_theta(theta, self.len)?;
        match &self.derivatives {
            Some(d) => d(theta),
            None => central_differences(self, theta),
        }
    }
    fn log_variances(&self) -> Vec<usize> {
        self.log_variances.clone()
    }
}
