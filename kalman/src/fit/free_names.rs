//! What to fit, by name: the items `Q:scalar|diag|full`, `R:scalar|diag|full`, `x0`,
//! `P0:diag`, the single entries `F[i,j]`, `B[i,j]`, `H[i,j]`, `Q[i,j]`, `R[i,j]`,
//! `P0[i,j]`, `x0[i]` (0-based, as [`Param::entry`] names them) and `Q:white-acceleration`
//! (the one intensity of a constant-velocity or constant-acceleration `Q`), parsed into a
//! [`FreeSpec`] and turned into a [`StandardMap`] over a base [`System`]. `Qc` is accepted
//! for `Q` (a continuous model's intensity). The command line's `--free` and the Python
//! module's `free=[...]` both read their names here.
#![allow(non_snake_case)]

use faer::Mat;

use super::{FitError, Free, Matrix, Param, StandardMap, Structure, System, Transform};

/// The parsed free items: the matrices freed as a whole, the single entries, and whether
/// `Q` is the white-acceleration intensity.
///
/// ```
/// use kalman::fit::{FreeSpec, Matrix, Structure, System};
/// # fn main() -> Result<(), kalman::fit::FitError> {
/// let spec = FreeSpec::parse(&["F[0,0]", "Q[0,0], R:diag"])?;
/// assert_eq!(spec.entries, [(Matrix::F, 0, 0), (Matrix::Q, 0, 0)]);
/// assert_eq!(spec.free.r, Structure::Diag);
/// // Each malformed item is refused by name.
/// let err = FreeSpec::parse(&["G[0,0]"]).unwrap_err().to_string();
/// assert!(err.contains("unknown matrix 'G'"), "{err}");
///
/// // A constant-velocity model sampled at Δt = 0.5: one intensity for the whole Q.
/// let F = [[1.0, 0.5], [0.0, 1.0]];
/// let base = System::new(&F, &[[1.0, 0.0]], &[[1.0, 0.0], [0.0, 1.0]], &[[1.0]], &[0.0, 0.0], &[[1.0, 0.0], [0.0, 1.0]])?;
/// let map = FreeSpec::parse(&["Q:white-acceleration", "R:diag"])?.map(base, Some(0.5))?;
/// let names = kalman::fit::ParamMap::names(&map);
/// assert!(names.iter().any(|n| n == "Q:white-acceleration"));
/// // Q = q·[[Δt³/3, Δt²/2], [Δt²/2, Δt]]
/// let q = &map.base().q;
/// assert!((q[(0, 1)] / q[(1, 1)] - 0.25).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FreeSpec {
    /// Q, R, x0, P0 freed as a whole.
    pub free: Free,
    /// Single entries `(matrix, row, column)`, in the order given (`x0[i]` is `(X0, i, 0)`).
    pub entries: Vec<(Matrix, usize, usize)>,
    /// `Q:white-acceleration`.
    pub white_acceleration: bool,
}

fn bad(m: String) -> FitError {
    FitError::Parameters(m)
}

fn twice(name: &str) -> FitError {
    bad(format!("{name} is listed twice"))
}

fn entry_name((m, i, j): (Matrix, usize, usize)) -> String {
    Param::entry(m, i, j).name().to_string()
}

impl FreeSpec {
    /// Parses free items; each string may itself hold several, comma-separated outside
    /// brackets (`"F[0,0],Q:diag"` is two). Every item at most once; an empty list parses
    /// (and is then [`FreeSpec::is_empty`]).
    ///
    /// # Errors
    /// [`FitError::Parameters`] naming the item: an unknown matrix or item, a malformed or
    /// negative index, a missing or unknown structure, an item listed twice.
    pub fn parse<S: AsRef<str>>(items: &[S]) -> Result<Self, FitError> {
        let mut spec = FreeSpec::default();
        let mut seen: Vec<&str> = Vec::new();
        for item in items.iter().flat_map(|s| split_items(s.as_ref())) {
            if let Some(entry) = parse_entry(item) {
                let e = entry?;
                if spec.entries.contains(&e) {
                    return Err(twice(&entry_name(e)));
                }
                spec.entries.push(e);
                continue;
            }
            spec.whole(item, &mut seen)?;
        }
        Ok(spec)
    }

    /// One whole-matrix item (`Q:diag`, `x0`, `P0:diag`, `Q:white-acceleration`).
    fn whole(&mut self, item: &str, seen: &mut Vec<&'static str>) -> Result<(), FitError> {
        let (name, kind) = match item.split_once(':') {
            Some((a, b)) => (a.trim(), Some(b.trim())),
            None => (item, None),
        };
        // A continuous model's intensity is Qc; the discrete form calls its matrix Q.
        let key: &'static str = match name {
            "Q" | "Qc" => "Q",
            "R" => "R",
            "x0" => "x0",
            "P0" => "P0",
            other => {
                return Err(bad(format!(
                    "unknown free item '{other}'{}: use Q:scalar|diag|full|white-acceleration, R:…, x0, P0:diag or entries such as F[0,0]",
                    kind.map(|k| format!(" with structure '{k}'"))
                        .unwrap_or_default()
                )));
            }
        };
        if seen.contains(&key) {
            return Err(twice(key));
        }
        seen.push(key);
        let structure = |kind: Option<&str>| match kind {
            Some("scalar") => Ok(Structure::Scalar),
            Some("diag") => Ok(Structure::Diag),
            Some("full") => Ok(Structure::Full),
            Some(k) => Err(bad(format!(
                "{key}:{k}: the structure must be scalar, diag or full"
            ))),
            None => Err(bad(format!(
                "{key} needs a structure: {key}:scalar, {key}:diag or {key}:full"
            ))),
        };
        match key {
            "Q" if kind == Some("white-acceleration") => self.white_acceleration = true,
            "Q" => self.free.q = structure(kind)?,
            "R" => self.free.r = structure(kind)?,
            "x0" if kind.is_none() => self.free.x0 = true,
            "x0" => return Err(bad("x0 takes no structure (write x0)".into())),
            _ if kind == Some("diag") => self.free.p0_diag = true,
            _ => {
                return Err(bad(
                    "P0 can only be freed as a diagonal (write P0:diag)".into()
                ));
            }
        }
        Ok(())
    }

    /// Several parsed lists as one (the command line's repeated `--free`).
    ///
    /// # Errors
    /// [`FitError::Parameters`] naming an item given in two of them.
    pub fn merge(specs: &[FreeSpec]) -> Result<FreeSpec, FitError> {
        let mut out = FreeSpec::default();
        for s in specs {
            let q_taken = out.free.q != Structure::Fixed || out.white_acceleration;
            if (s.free.q != Structure::Fixed || s.white_acceleration) && q_taken {
                return Err(twice("Q"));
            }
            if s.free.q != Structure::Fixed {
                out.free.q = s.free.q;
            }
            out.white_acceleration |= s.white_acceleration;
            if s.free.r != Structure::Fixed {
                if out.free.r != Structure::Fixed {
                    return Err(twice("R"));
                }
                out.free.r = s.free.r;
            }
            if s.free.x0 {
                if out.free.x0 {
                    return Err(twice("x0"));
                }
                out.free.x0 = true;
            }
            if s.free.p0_diag {
                if out.free.p0_diag {
                    return Err(twice("P0"));
                }
                out.free.p0_diag = true;
            }
            for e in &s.entries {
                if out.entries.contains(e) {
                    return Err(twice(&entry_name(*e)));
                }
                out.entries.push(*e);
            }
        }
        Ok(out)
    }

    /// Whether nothing is free.
    pub fn is_empty(&self) -> bool {
        self.free == Free::default() && self.entries.is_empty() && !self.white_acceleration
    }

    /// The [`Param`]s of the entries and, with white acceleration, the one shared
    /// intensity; `base.q` is then set to q₀·Q₁ (Q₁ from [`white_acceleration_q`] at `dt`,
    /// q₀ matching the trace of the given `Q`), so that every cell outside Q₁'s pattern is
    /// 0 and the start keeps the given scale.
    ///
    /// # Errors
    /// [`FitError::Parameters`] when white acceleration is asked without a positive `dt`
    /// or with an `F` that is not chains of integrators sampled at `dt`.
    pub fn params(&self, base: &mut System, dt: Option<f64>) -> Result<Vec<Param>, FitError> {
        let mut params: Vec<Param> = self
            .entries
            .iter()
            .map(|&(m, i, j)| Param::entry(m, i, j))
            .collect();
        if self.white_acceleration {
            let dt = match dt {
                Some(dt) if dt.is_finite() && dt > 0.0 => dt,
                _ => {
                    return Err(bad(
                        "Q:white-acceleration needs the model's sampling interval dt (positive and finite)".into(),
                    ));
                }
            };
            let q1 = white_acceleration_q(&base.f, dt)?;
            let n = base.n();
            let tr = |a: &Mat<f64>| (0..n).map(|i| a[(i, i)]).sum::<f64>();
            let q0 = tr(&base.q) / tr(&q1);
            let q0 = if q0.is_finite() && q0 > 0.0 { q0 } else { 1.0 };
            base.q = Mat::from_fn(n, n, |i, j| q0 * q1[(i, j)]);
            let mut p = Param::shared("Q:white-acceleration", Transform::Log);
            // the diagonal first: the start is read from the first entry
            for i in (0..n).filter(|&i| q1[(i, i)] > 0.0) {
                p = p.with(Matrix::Q, i, i, q1[(i, i)]);
            }
            for j in 0..n {
                for i in j + 1..n {
                    if q1[(i, j)] != 0.0 {
                        p = p.with(Matrix::Q, i, j, q1[(i, j)]);
                    }
                }
            }
            params.push(p);
        }
        Ok(params)
    }

    /// The [`StandardMap`] of this spec over `base` (`dt` the sampling interval, needed by
    /// white acceleration only); its [`StandardMap::base`] is the start.
    ///
    /// # Errors
    /// As [`FreeSpec::params`] and [`StandardMap::with_params`] (an entry outside its
    /// matrix, a covariance entry of a matrix freed whole, …); [`FitError::NothingFree`]
    /// for an empty spec.
    pub fn map(&self, mut base: System, dt: Option<f64>) -> Result<StandardMap, FitError> {
        if self.is_empty() {
            return Err(FitError::NothingFree);
        }
        let params = self.params(&mut base, dt)?;
        StandardMap::with_params(base, self.free, params)
    }
}

/// Splits at the commas outside brackets (`F[0,0],Q:diag` is two items), trimmed, the
/// empty ones dropped.
fn split_items(s: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let (mut depth, mut start) = (0_i32, 0);
    for (i, c) in s.char_indices() {
        match c {
            '[' => depth += 1,
            ']' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&s[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push(&s[start..]);
    out.into_iter()
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .collect()
}

/// Parses an entry item `NAME[i,j]` (or `x0[i]`); `None` when `item` has no bracket.
fn parse_entry(item: &str) -> Option<Result<(Matrix, usize, usize), FitError>> {
    let (name, rest) = item.split_once('[')?;
    let Some(inner) = rest.strip_suffix(']') else {
        return Some(Err(bad(format!("{item}: an entry is written NAME[i,j]"))));
    };
    let matrix = match name.trim() {
        "F" | "A" => Matrix::F,
        "B" => Matrix::B,
        "H" => Matrix::H,
        "Q" | "Qc" => Matrix::Q,
        "R" => Matrix::R,
        "P0" => Matrix::P0,
        "x0" => Matrix::X0,
        other => {
            return Some(Err(bad(format!(
                "unknown matrix '{other}' in {item}: entries of F, B, H, Q, R, P0 (NAME[i,j], 0-based) or x0[i]"
            ))));
        }
    };
    let idx: Vec<Option<usize>> = inner
        .split(',')
        .map(|t| t.trim().parse::<usize>().ok())
        .collect();
    let want = if matrix == Matrix::X0 { 1 } else { 2 };
    if idx.len() != want || idx.iter().any(Option::is_none) {
        return Some(Err(bad(format!(
            "{item}: {} (0-based non-negative integers)",
            if want == 1 {
                "x0 takes one index, x0[i]"
            } else {
                "an entry takes two indices, NAME[i,j]"
            }
        ))));
    }
    let idx: Vec<usize> = idx.into_iter().flatten().collect();
    Some(Ok((matrix, idx[0], idx.get(1).copied().unwrap_or(0))))
}

/// The unit white-acceleration covariance of a model whose `F` is chains of integrators
/// sampled at `dt`: A = log(F)/Δt (F − I nilpotent, so the series ends), the noise entering
/// every state whose row of A is zero (the last state of each chain), Q₁ = ∫₀^Δt e^{Aτ} G
/// Gᵀ e^{Aᵀτ} dτ by Van Loan; e^{AΔt} must give `F` back.
///
/// # Errors
/// [`FitError::Parameters`] when `F` is not such a chain (F − I not nilpotent, or
/// e^{log(F)} not `F`).
pub fn white_acceleration_q(F: &Mat<f64>, dt: f64) -> Result<Mat<f64>, FitError> {
    let n = F.nrows();
    let refuse = |why: &str| {
        bad(format!(
            "Q:white-acceleration needs F to be chains of integrators (constant velocity or constant acceleration) sampled at dt: {why}"
        ))
    };
    if n == 0 || F.ncols() != n || !(dt.is_finite() && dt > 0.0) {
        return Err(refuse("F must be square and dt positive"));
    }
    let N = Mat::from_fn(n, n, |i, j| F[(i, j)] - if i == j { 1.0 } else { 0.0 });
    // log(I + N) = N − N²/2 + N³/3 − … (finite when N is nilpotent)
    let mut log = Mat::<f64>::zeros(n, n);
    let mut power = N.clone();
    for k in 1..=n {
        let sign = if k % 2 == 1 { 1.0 } else { -1.0 };
        log += Mat::from_fn(n, n, |i, j| sign * power[(i, j)] / k as f64);
        power = &power * &N;
    }
    let scale = F.norm_max().max(1.0);
    // false for a NaN too
    let small = |x: f64| x <= 1e-9 * scale;
    if !small(power.norm_max()) {
        return Err(refuse("F − I is not nilpotent"));
    }
    let A = Mat::from_fn(n, n, |i, j| log[(i, j)] / dt);
    let W = Mat::from_fn(n, n, |i, j| {
        let zero_row = (0..n).all(|c| A[(i, c)].abs() <= 1e-12 * scale / dt);
        if i == j && zero_row { 1.0 } else { 0.0 }
    });
    let (Fs, Q1) = crate::continuous::van_loan(&A, &W, dt).map_err(|e| refuse(&e.to_string()))?;
    if !small((&Fs - F).norm_max()) || Q1.norm_max().is_nan() || Q1.norm_max() <= 0.0 {
        return Err(refuse("e^{log(F)} does not give F back"));
    }
    Ok(Q1)
}
