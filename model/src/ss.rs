//! Continuous and discrete linear state-space models with control and noise inputs.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::validate;

/// The names and shape rules of a state-space quadruple (state, input, output and
/// feed-through matrices): the continuous (A, B, C, D) and discrete (F, B, H, D) models
/// follow the same rules under their own names.
struct Notation {
    state: &'static str,
    output: &'static str,
    input_rule: &'static str,
    output_rule: &'static str,
    feedthrough_rule: &'static str,
}

const CONTINUOUS: Notation = Notation {
    state: "A",
    output: "C",
    input_rule: "B must have as many rows as A",
    output_rule: "C must have as many columns as A",
    feedthrough_rule: "D must be (rows of C)×(columns of B)",
};

const DISCRETE: Notation = Notation {
    state: "F",
    output: "H",
    input_rule: "B must have as many rows as F",
    output_rule: "H must have as many columns as F",
    feedthrough_rule: "D must be (rows of H)×(columns of B)",
};

impl Notation {
    /// Checks the quadruple (square state matrix, then input, output, feed-through); returns n.
    fn check(
        &self,
        state: &DMatrix<f64>,
        b: &DMatrix<f64>,
        output: &DMatrix<f64>,
        d: &DMatrix<f64>,
    ) -> Result<usize> {
        let n = validate::square(self.state, state)?;
        self.check_input(n, b)?;
        validate::shape(self.output, output, output.nrows(), n, self.output_rule)?;
        self.check_feedthrough(output.nrows(), b.ncols(), d)?;
        Ok(n)
    }

    /// The input matrix B has n rows.
    fn check_input(&self, n: usize, b: &DMatrix<f64>) -> Result<()> {
        validate::shape("B", b, n, b.ncols(), self.input_rule)
    }

    /// The input matrix B (n×p) with the zero feed-through D (m×p) that goes with it.
    fn input(&self, n: usize, m: usize, b: DMatrix<f64>) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
        self.check_input(n, &b)?;
        let d = DMatrix::zeros(m, b.ncols());
        Ok((b, d))
    }

    /// The feed-through D is m×p.
    fn check_feedthrough(&self, m: usize, p: usize, d: &DMatrix<f64>) -> Result<()> {
        validate::shape("D", d, m, p, self.feedthrough_rule)
    }
}

/// A continuous-time linear model
///
/// ```text
/// ẋ = A·x + B·u + G·w,     y = C·x + D·u,     E[w(t)w(s)ᵀ] = W·δ(t − s)
/// ```
///
/// with n states, p control inputs `u`, q white-noise inputs `w` of intensity (spectral
/// density) `W` (q×q, symmetric PSD) and m outputs. Built by [`ContinuousSs::new`] (no noise)
/// and [`ContinuousSs::with_noise`]; every constructor checks shapes, finiteness, and that `W`
/// is symmetric PSD. Deserialisation runs the same checks.
///
/// # Example
/// ```
/// use model::ContinuousSs;
/// use model::nalgebra::dmatrix;
///
/// // A mass-spring-damper driven by a force u and by white force noise of intensity 0.1.
/// let sys = ContinuousSs::new(
///     dmatrix![0.0, 1.0; -4.0, -0.4], // A
///     dmatrix![0.0; 1.0],             // B
///     dmatrix![1.0, 0.0],             // C
///     dmatrix![0.0],                  // D
/// )?
/// .with_noise(dmatrix![0.0; 1.0], dmatrix![0.1])?; // G, W
/// assert_eq!((sys.n_states(), sys.n_inputs(), sys.n_noise(), sys.n_outputs()), (2, 1, 1, 1));
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ContinuousSsRaw")]
pub struct ContinuousSs {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    c: DMatrix<f64>,
    d: DMatrix<f64>,
    g: DMatrix<f64>,
    w: DMatrix<f64>,
}

deserialize_via! {
    ContinuousSs,
    ContinuousSsRaw {
        a: DMatrix<f64>, b: DMatrix<f64>, c: DMatrix<f64>, d: DMatrix<f64>,
        g: DMatrix<f64>, w: DMatrix<f64>,
    },
    |r| ContinuousSs::new(r.a, r.b, r.c, r.d)?.with_noise(r.g, r.w)
}

impl ContinuousSs {
    /// A noise-free model `ẋ = A x + B u`, `y = C x + D u`.
    ///
    /// # Errors
    /// [`Error::NotSquare`] for a non-square `A`, [`Error::DimensionMismatch`] when `B`, `C`
    /// or `D` disagree with `A` and each other, [`Error::NonFiniteMatrix`] for NaN/∞.
    pub fn new(a: DMatrix<f64>, b: DMatrix<f64>, c: DMatrix<f64>, d: DMatrix<f64>) -> Result<Self> {
        let n = CONTINUOUS.check(&a, &b, &c, &d)?;
        Ok(Self {
            g: DMatrix::zeros(n, 0),
            w: DMatrix::zeros(0, 0),
            a,
            b,
            c,
            d,
        })
    }

    /// A model without control input, `ẋ = A x`, `y = C x` (p = 0): the common start of a
    /// filtering model; add noise with [`ContinuousSs::with_noise`] and, if there is one, a
    /// control input with [`ContinuousSs::with_input`].
    ///
    /// # Errors
    /// [`Error::NotSquare`] for a non-square `A`, [`Error::DimensionMismatch`] when `C` has
    /// not as many columns as `A`, [`Error::NonFiniteMatrix`] for NaN/∞.
    ///
    /// # Example
    /// ```
    /// use model::ContinuousSs;
    /// use model::nalgebra::dmatrix;
    ///
    /// // Constant velocity driven by white acceleration noise of intensity 0.1, position seen.
    /// let sys = ContinuousSs::autonomous(dmatrix![0.0, 1.0; 0.0, 0.0], dmatrix![1.0, 0.0])?
    ///     .with_noise(dmatrix![0.0; 1.0], dmatrix![0.1])?;
    /// assert_eq!((sys.n_states(), sys.n_inputs(), sys.n_noise()), (2, 0, 1));
    /// # Ok::<(), model::Error>(())
    /// ```
    pub fn autonomous(a: DMatrix<f64>, c: DMatrix<f64>) -> Result<Self> {
        let n = a.nrows();
        let m = c.nrows();
        Self::new(a, DMatrix::zeros(n, 0), c, DMatrix::zeros(m, 0))
    }

    /// Sets the control input `B·u` (n×p) with a zero feed-through `D` (m×p), replacing any
    /// earlier input; [`ContinuousSs::with_feedthrough`] sets a non-zero `D` afterwards.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] when `B` has not as many rows as `A`,
    /// [`Error::NonFiniteMatrix`] for NaN/∞.
    ///
    /// # Example
    /// ```
    /// use model::ContinuousSs;
    /// use model::nalgebra::dmatrix;
    ///
    /// // A double integrator driven by a commanded acceleration.
    /// let sys = ContinuousSs::autonomous(dmatrix![0.0, 1.0; 0.0, 0.0], dmatrix![1.0, 0.0])?
    ///     .with_input(dmatrix![0.0; 1.0])?;
    /// assert_eq!((sys.n_inputs(), sys.d().shape()), (1, (1, 1)));
    /// assert!(sys.with_input(dmatrix![1.0]).is_err()); // B needs n = 2 rows
    /// # Ok::<(), model::Error>(())
    /// ```
    pub fn with_input(mut self, b: DMatrix<f64>) -> Result<Self> {
        (self.b, self.d) = CONTINUOUS.input(self.a.nrows(), self.c.nrows(), b)?;
        Ok(self)
    }

    /// Sets the control feed-through `D` (m×p, p from the input set before).
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] when `D` is not (rows of C)×(columns of B),
    /// [`Error::NonFiniteMatrix`] for NaN/∞.
    ///
    /// # Example
    /// ```
    /// use model::ContinuousSs;
    /// use model::nalgebra::dmatrix;
    ///
    /// let sys = ContinuousSs::autonomous(dmatrix![-1.0], dmatrix![1.0])?
    ///     .with_input(dmatrix![1.0])?
    ///     .with_feedthrough(dmatrix![0.5])?;
    /// assert!((sys.d()[(0, 0)] - 0.5).abs() < 1e-15);
    /// # Ok::<(), model::Error>(())
    /// ```
    pub fn with_feedthrough(mut self, d: DMatrix<f64>) -> Result<Self> {
        CONTINUOUS.check_feedthrough(self.c.nrows(), self.b.ncols(), &d)?;
        self.d = d;
        Ok(self)
    }

    /// Adds the noise input `G·w` with white-noise intensity `W` (replacing any earlier one).
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] when `G` has the wrong number of rows or `W` is not q×q,
    /// [`Error::NonFiniteMatrix`], [`Error::NotSymmetric`], [`Error::NotPositiveSemiDefinite`].
    pub fn with_noise(mut self, g: DMatrix<f64>, w: DMatrix<f64>) -> Result<Self> {
        let n = self.a.nrows();
        validate::shape("G", &g, n, g.ncols(), "G must have as many rows as A")?;
        validate::covariance("W", &w, g.ncols(), "W must be q×q with q = columns of G")?;
        self.g = g;
        self.w = w;
        Ok(self)
    }

    /// State matrix `A` (n×n).
    pub fn a(&self) -> &DMatrix<f64> {
        &self.a
    }
    /// Control input matrix `B` (n×p).
    pub fn b(&self) -> &DMatrix<f64> {
        &self.b
    }
    /// Output matrix `C` (m×n).
    pub fn c(&self) -> &DMatrix<f64> {
        &self.c
    }
    /// Feed-through `D` (m×p).
    pub fn d(&self) -> &DMatrix<f64> {
        &self.d
    }
    /// Noise input matrix `G` (n×q).
    pub fn g(&self) -> &DMatrix<f64> {
        &self.g
    }
    /// White-noise intensity `W` (q×q).
    pub fn w(&self) -> &DMatrix<f64> {
        &self.w
    }
    /// Number of states n.
    pub fn n_states(&self) -> usize {
        self.a.nrows()
    }
    /// Number of control inputs p.
    pub fn n_inputs(&self) -> usize {
        self.b.ncols()
    }
    /// Number of noise inputs q.
    pub fn n_noise(&self) -> usize {
        self.g.ncols()
    }
    /// Number of outputs m.
    pub fn n_outputs(&self) -> usize {
        self.c.nrows()
    }
}

/// A discrete-time linear model with sampling interval `dt`
///
/// ```text
/// x_{k+1} = F·x_k + B·u_k + G·w_k,     y_k = H·x_k + D·u_k + J·w_k,     cov(w_k) = Q
/// ```
///
/// with n states, p control inputs, q noise inputs (`w_k` white, zero mean, covariance `Q`,
/// symmetric PSD) and m outputs. `J` is the noise feed-through (it arises from Tustin or from
/// the paper's shaping filters, where the same `w_k` drives the state and the output: the
/// cross-covariance of process and output noise is then `G·Q·Jᵀ`).
///
/// # Example
/// ```
/// use model::DiscreteSs;
/// use model::nalgebra::dmatrix;
///
/// // AR(1) state seen in its own noise: x_{k+1} = 0.9 x_k + w_k, y_k = x_k + 0.5 w_k.
/// let d = DiscreteSs::new(dmatrix![0.9], dmatrix![0.0], dmatrix![1.0], dmatrix![0.0], 0.1)?
///     .with_noise(dmatrix![1.0], dmatrix![0.5], dmatrix![0.04])?;
/// // cov(G w, J w) = G Q Jᵀ = 0.02: process and output noise are correlated.
/// assert!((d.cross_covariance()[(0, 0)] - 0.02).abs() < 1e-15);
/// # Ok::<(), model::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "DiscreteSsRaw")]
pub struct DiscreteSs {
    f: DMatrix<f64>,
    b: DMatrix<f64>,
    h: DMatrix<f64>,
    d: DMatrix<f64>,
    g: DMatrix<f64>,
    j: DMatrix<f64>,
    q: DMatrix<f64>,
    dt: f64,
}

deserialize_via! {
    DiscreteSs,
    DiscreteSsRaw {
        f: DMatrix<f64>, b: DMatrix<f64>, h: DMatrix<f64>, d: DMatrix<f64>,
        g: DMatrix<f64>, j: DMatrix<f64>, q: DMatrix<f64>, dt: f64,
    },
    |r| DiscreteSs::new(r.f, r.b, r.h, r.d, r.dt)?.with_noise(r.g, r.j, r.q)
}

impl DiscreteSs {
    /// A noise-free model `x_{k+1} = F x_k + B u_k`, `y_k = H x_k + D u_k` with interval `dt`.
    ///
    /// # Errors
    /// [`Error::NotSquare`] (`F`), [`Error::DimensionMismatch`] (`B`, `H`, `D`),
    /// [`Error::NonFiniteMatrix`], [`Error::InvalidParameter`] for `dt` not finite and > 0.
    pub fn new(
        f: DMatrix<f64>,
        b: DMatrix<f64>,
        h: DMatrix<f64>,
        d: DMatrix<f64>,
        dt: f64,
    ) -> Result<Self> {
        validate::positive("dt", dt)?;
        let n = DISCRETE.check(&f, &b, &h, &d)?;
        let m = h.nrows();
        Ok(Self {
            g: DMatrix::zeros(n, 0),
            j: DMatrix::zeros(m, 0),
            q: DMatrix::zeros(0, 0),
            f,
            b,
            h,
            d,
            dt,
        })
    }

    /// A model without control input, `x_{k+1} = F x_k`, `y_k = H x_k` (p = 0); add noise
    /// with [`DiscreteSs::with_noise`] and a control input with [`DiscreteSs::with_input`].
    ///
    /// # Errors
    /// As [`DiscreteSs::new`].
    ///
    /// # Example
    /// ```
    /// use model::DiscreteSs;
    /// use model::nalgebra::dmatrix;
    ///
    /// // A random walk seen in its own noise, Δt = 1 s.
    /// let d = DiscreteSs::autonomous(dmatrix![1.0], dmatrix![1.0], 1.0)?
    ///     .with_noise(dmatrix![1.0], dmatrix![0.0], dmatrix![0.01])?;
    /// assert_eq!((d.n_states(), d.n_inputs(), d.n_noise()), (1, 0, 1));
    /// # Ok::<(), model::Error>(())
    /// ```
    pub fn autonomous(f: DMatrix<f64>, h: DMatrix<f64>, dt: f64) -> Result<Self> {
        let n = f.nrows();
        let m = h.nrows();
        Self::new(f, DMatrix::zeros(n, 0), h, DMatrix::zeros(m, 0), dt)
    }

    /// Sets the control input `B·u_k` (n×p) with a zero feed-through `D` (m×p), replacing
    /// any earlier input, as [`ContinuousSs::with_input`] does for the continuous model;
    /// [`DiscreteSs::with_feedthrough`] sets a non-zero `D` afterwards.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] when `B` has not as many rows as `F`,
    /// [`Error::NonFiniteMatrix`] for NaN/∞.
    ///
    /// # Example
    /// ```
    /// use model::DiscreteSs;
    /// use model::nalgebra::dmatrix;
    ///
    /// // A sampled double integrator driven by a piecewise-constant acceleration, Δt = 0.1 s,
    /// // whose position sensor also reads half of the commanded acceleration.
    /// let dt = 0.1;
    /// let d = DiscreteSs::autonomous(dmatrix![1.0, dt; 0.0, 1.0], dmatrix![1.0, 0.0], dt)?
    ///     .with_input(dmatrix![dt * dt / 2.0; dt])?;
    /// assert_eq!((d.n_inputs(), d.d().shape()), (1, (1, 1)));
    /// assert!(d.clone().with_feedthrough(dmatrix![1.0, 1.0]).is_err()); // D must be 1×1
    /// let d = d.with_feedthrough(dmatrix![0.5])?;
    /// assert!((d.d()[(0, 0)] - 0.5).abs() < 1e-15);
    /// # Ok::<(), model::Error>(())
    /// ```
    pub fn with_input(mut self, b: DMatrix<f64>) -> Result<Self> {
        (self.b, self.d) = DISCRETE.input(self.f.nrows(), self.h.nrows(), b)?;
        Ok(self)
    }

    /// Sets the control feed-through `D` (m×p, p from the input set before); the example of
    /// [`DiscreteSs::with_input`] shows both.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] when `D` is not (rows of H)×(columns of B),
    /// [`Error::NonFiniteMatrix`] for NaN/∞.
    pub fn with_feedthrough(mut self, d: DMatrix<f64>) -> Result<Self> {
        DISCRETE.check_feedthrough(self.h.nrows(), self.b.ncols(), &d)?;
        self.d = d;
        Ok(self)
    }

    /// Adds the noise input: `G·w_k` in the state, `J·w_k` in the output, `cov(w_k) = Q`.
    ///
    /// # Errors
    /// [`Error::DimensionMismatch`] for `G` (n×q), `J` (m×q) or `Q` (q×q),
    /// [`Error::NonFiniteMatrix`], [`Error::NotSymmetric`], [`Error::NotPositiveSemiDefinite`].
    pub fn with_noise(mut self, g: DMatrix<f64>, j: DMatrix<f64>, q: DMatrix<f64>) -> Result<Self> {
        let n = self.f.nrows();
        let m = self.h.nrows();
        validate::shape("G", &g, n, g.ncols(), "G must have as many rows as F")?;
        validate::shape(
            "J",
            &j,
            m,
            g.ncols(),
            "J must be (rows of H)×(columns of G)",
        )?;
        validate::covariance("Q", &q, g.ncols(), "Q must be q×q with q = columns of G")?;
        self.g = g;
        self.j = j;
        self.q = q;
        Ok(self)
    }

    /// Transition matrix `F` (n×n).
    pub fn f(&self) -> &DMatrix<f64> {
        &self.f
    }
    /// Control input matrix `B` (n×p).
    pub fn b(&self) -> &DMatrix<f64> {
        &self.b
    }
    /// Output matrix `H` (m×n).
    pub fn h(&self) -> &DMatrix<f64> {
        &self.h
    }
    /// Control feed-through `D` (m×p).
    pub fn d(&self) -> &DMatrix<f64> {
        &self.d
    }
    /// Noise input matrix `G` (n×q).
    pub fn g(&self) -> &DMatrix<f64> {
        &self.g
    }
    /// Noise feed-through `J` (m×q).
    pub fn j(&self) -> &DMatrix<f64> {
        &self.j
    }
    /// Noise covariance `Q = cov(w_k)` (q×q).
    pub fn q(&self) -> &DMatrix<f64> {
        &self.q
    }
    /// Sampling interval Δt in seconds.
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// Number of states n.
    pub fn n_states(&self) -> usize {
        self.f.nrows()
    }
    /// Number of control inputs p.
    pub fn n_inputs(&self) -> usize {
        self.b.ncols()
    }
    /// Number of noise inputs q.
    pub fn n_noise(&self) -> usize {
        self.g.ncols()
    }
    /// Number of outputs m.
    pub fn n_outputs(&self) -> usize {
        self.h.nrows()
    }
    /// Process-noise covariance as it enters the state: `G·Q·Gᵀ` (n×n, symmetric).
    pub fn process_covariance(&self) -> DMatrix<f64> {
        validate::symmetrize(&(&self.g * &self.q * self.g.transpose()))
    }
    /// Output-noise covariance from the noise feed-through: `J·Q·Jᵀ` (m×m, symmetric).
    pub fn output_noise_covariance(&self) -> DMatrix<f64> {
        validate::symmetrize(&(&self.j * &self.q * self.j.transpose()))
    }
    /// Cross-covariance of process and output noise: `cov(G w_k, J w_k) = G·Q·Jᵀ` (n×m).
    pub fn cross_covariance(&self) -> DMatrix<f64> {
        &self.g * &self.q * self.j.transpose()
    }
    /// The same model with the noise inputs treated as extra control inputs appended after
    /// `u`: `B' = [B G]`, `D' = [D J]` (no noise left). Used for impulse responses from the
    /// noise and for composing shaping filters as signal blocks.
    pub fn noise_as_inputs(&self) -> DiscreteSs {
        let n = self.n_states();
        let m = self.n_outputs();
        let mut b = DMatrix::zeros(n, self.n_inputs() + self.n_noise());
        b.columns_mut(0, self.n_inputs()).copy_from(&self.b);
        b.columns_mut(self.n_inputs(), self.n_noise())
            .copy_from(&self.g);
        let mut d = DMatrix::zeros(m, self.n_inputs() + self.n_noise());
        d.columns_mut(0, self.n_inputs()).copy_from(&self.d);
        d.columns_mut(self.n_inputs(), self.n_noise())
            .copy_from(&self.j);
        DiscreteSs {
            f: self.f.clone(),
            b,
            h: self.h.clone(),
            d,
            g: DMatrix::zeros(n, 0),
            j: DMatrix::zeros(m, 0),
            q: DMatrix::zeros(0, 0),
            dt: self.dt,
        }
    }

    /// Builds without re-validating: for kernels whose outputs are valid by construction.
    pub(crate) fn from_parts_unchecked(
        f: DMatrix<f64>,
        b: DMatrix<f64>,
        h: DMatrix<f64>,
        d: DMatrix<f64>,
        g: DMatrix<f64>,
        j: DMatrix<f64>,
        q: DMatrix<f64>,
        dt: f64,
    ) -> Self {
        Self {
            f,
            b,
            h,
            d,
            g,
            j,
            q,
            dt,
        }
    }
}

impl ContinuousSs {
    /// Builds without re-validating: for kernels whose outputs are valid by construction.
    pub(crate) fn from_parts_unchecked(
        a: DMatrix<f64>,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
        g: DMatrix<f64>,
        w: DMatrix<f64>,
    ) -> Self {
        Self { a, b, c, d, g, w }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_as_inputs_appends_columns() {
        let s = DiscreteSs::new(
            DMatrix::from_element(1, 1, 0.5),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::from_element(1, 1, 2.0),
            DMatrix::from_element(1, 1, 0.0),
            0.1,
        )
        .expect("valid")
        .with_noise(
            DMatrix::from_element(1, 1, 3.0),
            DMatrix::from_element(1, 1, 4.0),
            DMatrix::from_element(1, 1, 2.0),
        )
        .expect("valid");
        let t = s.noise_as_inputs();
        assert_eq!((t.n_inputs(), t.n_noise()), (2, 0));
        assert!((t.b()[(0, 1)] - 3.0).abs() < 1e-15 && (t.d()[(0, 1)] - 4.0).abs() < 1e-15);
        assert!((s.process_covariance()[(0, 0)] - 18.0).abs() < 1e-15);
        assert!((s.cross_covariance()[(0, 0)] - 24.0).abs() < 1e-15);
        assert!((s.output_noise_covariance()[(0, 0)] - 32.0).abs() < 1e-15);
    }
}
