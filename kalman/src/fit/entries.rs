//! Parameters that set single matrix entries, or several entries at once (a shared
//! parameter), through a transform: the free entries of [`super::StandardMap`].

use faer::Mat;

use super::{FitError, System};

/// A matrix (or vector) of a [`System`] that a parameter can enter.
///
/// # Example
/// ```
/// use kalman::fit::Matrix;
/// assert_eq!(Matrix::X0.name(), "x0");
/// assert!(Matrix::R.is_covariance() && !Matrix::F.is_covariance());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Matrix {
    /// The transition `F` (n×n).
    F,
    /// The control matrix `B` (n×p).
    B,
    /// The measurement matrix `H` (m×n).
    H,
    /// The process noise covariance `Q` (n×n, symmetric).
    Q,
    /// The measurement noise covariance `R` (m×m, symmetric).
    R,
    /// The prior mean `x0` (n, column 0 only).
    X0,
    /// The prior covariance `P0` (n×n, symmetric).
    P0,
}

impl Matrix {
    /// The matrix's name as the equations and the summaries write it (`F`, `x0`, `P0`, …).
    pub fn name(self) -> &'static str {
        match self {
            Matrix::F => "F",
            Matrix::B => "B",
            Matrix::H => "H",
            Matrix::Q => "Q",
            Matrix::R => "R",
            Matrix::X0 => "x0",
            Matrix::P0 => "P0",
        }
    }

    /// Whether the matrix is a covariance (an off-diagonal entry sets its mirror too).
    pub fn is_covariance(self) -> bool {
        matches!(self, Matrix::Q | Matrix::R | Matrix::P0)
    }

    /// Rows and columns of the matrix in `sys`.
    fn shape(self, sys: &System) -> (usize, usize) {
        let (n, m, p) = (sys.n(), sys.m(), sys.p());
        match self {
            Matrix::F | Matrix::Q | Matrix::P0 => (n, n),
            Matrix::B => (n, p),
            Matrix::H => (m, n),
            Matrix::R => (m, m),
            Matrix::X0 => (n, 1),
        }
    }

    /// The entry `(i, j)` of the matrix in `sys`.
    pub(crate) fn get(self, sys: &System, i: usize, j: usize) -> f64 {
        match self {
            Matrix::F => sys.f[(i, j)],
            Matrix::B => sys.b[(i, j)],
            Matrix::H => sys.h[(i, j)],
            Matrix::Q => sys.q[(i, j)],
            Matrix::R => sys.r[(i, j)],
            Matrix::X0 => sys.x0[i],
            Matrix::P0 => sys.p0[(i, j)],
        }
    }
}

/// How a parameter θ maps to the value `v` it gives its entries.
///
/// # Example
/// ```
/// use kalman::fit::Transform;
/// let (v, dv) = Transform::Log.value(0.0);
/// assert_eq!((v, dv), (1.0, 1.0));
/// assert_eq!(Transform::Log.theta(-1.0), None, "a variance cannot be negative");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Transform {
    /// `v = θ` (an unbounded coefficient: an entry of F, H, B, x0, an off-diagonal
    /// covariance).
    #[default]
    Identity,
    /// `v = e^θ` (a variance or an intensity: positive, and a zero variance is the
    /// boundary θ → −∞).
    Log,
    /// `v = tanh θ` (a coefficient bounded to (−1, 1): a correlation, a stable AR(1)
    /// coefficient).
    Tanh,
}

impl Transform {
    /// `v(θ)` and `dv/dθ`.
    pub fn value(self, theta: f64) -> (f64, f64) {
        match self {
            Transform::Identity => (theta, 1.0),
            Transform::Log => {
                let v = theta.exp();
                (v, v)
            }
            Transform::Tanh => {
                let v = theta.tanh();
                (v, 1.0 - v * v)
            }
        }
    }

    /// θ of a value, or `None` where the transform cannot reach it (a non-positive value
    /// under `Log`, `|v| ≥ 1` under `Tanh`).
    pub fn theta(self, v: f64) -> Option<f64> {
        match self {
            Transform::Identity => v.is_finite().then_some(v),
            Transform::Log => (v > 0.0 && v.is_finite()).then(|| v.ln()),
            Transform::Tanh => (v.abs() < 1.0).then(|| v.atanh()),
        }
    }
}

/// One entry a parameter sets: `matrix[row, col] = coefficient · v(θ)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    /// The matrix.
    pub matrix: Matrix,
    /// Row (0-based).
    pub row: usize,
    /// Column (0-based; 0 for `x0`).
    pub col: usize,
    /// The entry's multiple of the parameter's value.
    pub coefficient: f64,
}

/// A free parameter: one value `v(θ)` that sets one entry or, shared, several (each its
/// coefficient times `v`).
///
/// # Example
/// ```
/// use kalman::fit::{Matrix, Param, Transform};
/// // The AR coefficient F[0,0], unbounded.
/// let phi = Param::entry(Matrix::F, 0, 0);
/// assert_eq!(phi.name(), "F[0,0]");
/// // A variance on the diagonal of Q is log-transformed, so every iterate is positive.
/// assert_eq!(Param::entry(Matrix::Q, 1, 1).transform(), Transform::Log);
/// // One intensity q setting a constant-velocity model's whole Q = q·[Δt³/3 Δt²/2; Δt²/2 Δt].
/// let dt: f64 = 0.1;
/// let q = Param::shared("q", Transform::Log)
///     .with(Matrix::Q, 0, 0, dt.powi(3) / 3.0)
///     .with(Matrix::Q, 1, 0, dt.powi(2) / 2.0)
///     .with(Matrix::Q, 1, 1, dt);
/// assert_eq!(q.entries().len(), 3);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    name: String,
    transform: Transform,
    entries: Vec<Entry>,
}

impl Param {
    /// The single entry `matrix[row, col]` (coefficient 1), named `F[0,0]` and so on
    /// (`x0[i]` for the prior mean). A diagonal entry of Q, R or P0 is a variance and gets
    /// [`Transform::Log`]; every other entry [`Transform::Identity`]. An off-diagonal entry
    /// of a covariance also sets its mirror `[col, row]`.
    pub fn entry(matrix: Matrix, row: usize, col: usize) -> Self {
        let name = if matrix == Matrix::X0 {
            format!("x0[{row}]")
        } else {
            format!("{}[{row},{col}]", matrix.name())
        };
        let transform = if matrix.is_covariance() && row == col {
            Transform::Log
        } else {
            Transform::Identity
        };
        Self {
            name,
            transform,
            entries: vec![Entry {
                matrix,
                row,
                col,
                coefficient: 1.0,
            }],
        }
    }

    /// A named parameter with no entry yet; add them with [`Param::with`].
    pub fn shared(name: impl Into<String>, transform: Transform) -> Self {
        Self {
            name: name.into(),
            transform,
            entries: Vec::new(),
        }
    }

    /// Adds the entry `matrix[row, col] = coefficient · v(θ)`.
    #[must_use]
    pub fn with(mut self, matrix: Matrix, row: usize, col: usize, coefficient: f64) -> Self {
        self.entries.push(Entry {
            matrix,
            row,
            col,
            coefficient,
        });
        self
    }

    /// Replaces the transform.
    #[must_use]
    pub fn transformed(mut self, transform: Transform) -> Self {
        self.transform = transform;
        self
    }

    /// The parameter's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Its transform.
    pub fn transform(&self) -> Transform {
        self.transform
    }
    /// The entries it sets.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// The value `v` the base system gives this parameter: its first entry with a non-zero
    /// coefficient, divided by that coefficient.
    pub(crate) fn value_in(&self, sys: &System) -> f64 {
        let e = self.entries[0];
        e.matrix.get(sys, e.row, e.col) / e.coefficient
    }
}

/// The cells `(matrix, i, j)` an entry writes (its mirror too for a covariance).
pub(crate) fn cells(e: &Entry) -> Vec<(Matrix, usize, usize)> {
    if e.matrix.is_covariance() && e.row != e.col {
        vec![(e.matrix, e.row, e.col), (e.matrix, e.col, e.row)]
    } else {
        vec![(e.matrix, e.row, e.col)]
    }
}

/// Checks `params` against the base system: entries inside their matrices, finite non-zero
/// coefficients, at least one entry each, no cell set by two parameters (or twice by one)
/// and none in `taken` (the matrices a covariance structure of the map already frees).
pub(crate) fn check(params: &[Param], base: &System, taken: &[Matrix]) -> Result<(), FitError> {
    let bad = |m: String| Err(FitError::Parameters(m));
    let mut seen: Vec<(Matrix, usize, usize, &str)> = Vec::new();
    let mut names: Vec<&str> = Vec::new();
    for p in params {
        if names.contains(&p.name.as_str()) {
            return bad(format!("two free parameters are named {}", p.name));
        }
        names.push(&p.name);
        if p.entries.is_empty() {
            return bad(format!("{} sets no matrix entry", p.name));
        }
        for e in &p.entries {
            let (r, c) = e.matrix.shape(base);
            let entry = format!("{}[{},{}]", e.matrix.name(), e.row, e.col);
            if e.row >= r || e.col >= c {
                let matrix = e.matrix.name();
                return bad(format!(
                    "{}: entry {entry} is outside the {r}×{c} matrix {matrix}",
                    p.name
                ));
            }
            if !e.coefficient.is_finite() || e.coefficient == 0.0 {
                let value = e.coefficient;
                return bad(format!(
                    "{}: the coefficient of {entry} is {value} (must be finite and non-zero)",
                    p.name
                ));
            }
            if taken.contains(&e.matrix) {
                return bad(format!(
                    "{}: {} is already free as a whole (free either the matrix or its entries)",
                    p.name,
                    e.matrix.name()
                ));
            }
            for cell in cells(e) {
                if let Some(other) = seen.iter().find(|s| (s.0, s.1, s.2) == cell).map(|s| s.3) {
                    return bad(format!(
                        "{}[{},{}] is set by both {other} and {}",
                        cell.0.name(),
                        cell.1,
                        cell.2,
                        p.name
                    ));
                }
                seen.push((cell.0, cell.1, cell.2, &p.name));
            }
        }
    }
    Ok(())
}

fn cell_mut(sys: &mut System, m: Matrix, i: usize, j: usize) -> &mut f64 {
    match m {
        Matrix::F => &mut sys.f[(i, j)],
        Matrix::B => &mut sys.b[(i, j)],
        Matrix::H => &mut sys.h[(i, j)],
        Matrix::Q => &mut sys.q[(i, j)],
        Matrix::R => &mut sys.r[(i, j)],
        Matrix::X0 => &mut sys.x0[i],
        Matrix::P0 => &mut sys.p0[(i, j)],
    }
}

/// Writes every parameter's entries into `sys` (θ one entry per parameter).
pub(crate) fn apply(params: &[Param], theta: &[f64], sys: &mut System) {
    for (p, &t) in params.iter().zip(theta) {
        let (v, _) = p.transform.value(t);
        for e in &p.entries {
            for (m, i, j) in cells(e) {
                *cell_mut(sys, m, i, j) = e.coefficient * v;
            }
        }
    }
}

/// `∂System/∂θ` of one parameter: `coefficient · dv/dθ` in each of its cells.
pub(crate) fn derivative(p: &Param, theta: f64, sys: &System) -> super::Derivative {
    let (_, dv) = p.transform.value(theta);
    let mut d = super::Derivative::default();
    for e in &p.entries {
        for (m, i, j) in cells(e) {
            let value = e.coefficient * dv;
            let (r, c) = m.shape(sys);
            let slot = match m {
                Matrix::F => &mut d.f,
                Matrix::B => &mut d.b,
                Matrix::H => &mut d.h,
                Matrix::Q => &mut d.q,
                Matrix::R => &mut d.r,
                Matrix::P0 => &mut d.p0,
                Matrix::X0 => {
                    d.x0.get_or_insert_with(|| vec![0.0; r])[i] = value;
                    continue;
                }
            };
            slot.get_or_insert_with(|| Mat::zeros(r, c))[(i, j)] = value;
        }
    }
    d
}

/// The pattern `Q₁` when `params` is one log-transformed intensity setting Q (`Q = q·Q₁`,
/// every other cell of the base Q zero): the one entry structure EM updates in closed
/// form. `None` otherwise.
pub(crate) fn q_intensity(params: &[Param], base: &System) -> Option<Mat<f64>> {
    let [p] = params else { return None };
    if p.transform != Transform::Log || p.entries.iter().any(|e| e.matrix != Matrix::Q) {
        return None;
    }
    let n = base.n();
    let mut q1 = Mat::zeros(n, n);
    let mut set = vec![false; n * n];
    for e in &p.entries {
        for (_, i, j) in cells(e) {
            q1[(i, j)] = e.coefficient;
            set[i + j * n] = true;
        }
    }
    let rest_zero = (0..n).all(|j| (0..n).all(|i| set[i + j * n] || base.q[(i, j)] == 0.0));
    rest_zero.then_some(q1)
}
