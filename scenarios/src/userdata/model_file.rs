//! Model files of `filter`, `discretize` and `steady-state`: discrete and continuous linear
//! models in JSON or TOML (chosen by the extension), matrices as row-major nested arrays.
//!
//! Parsing checks everything that is structural — syntax (with the parser's line and
//! column), unknown keys, ragged rows, the shapes implied by `F`/`A` and `H`/`C`, and finite
//! entries — and names the matrix and the rule in the message. Symmetry and positive
//! semi-definiteness of the covariances are checked by the engines (`kalman`, `model`) when
//! the model is handed to them, so there is one rule and one tolerance for each.
#![allow(non_snake_case)]

use std::path::Path;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Row-major nested arrays, as written in a model file.
pub type Rows = Vec<Vec<f64>>;

/// A validated discrete model file
///
/// ```text
/// x_{k+1} = F x_k + B u_k + w_k,   z_k = H x_k + D u_k + v_k,
/// cov(w) = Q,  cov(v) = R,  E[w_k v_kᵀ] = S,  x_0 ~ (x0, P0)
/// ```
///
/// with n states, m measurements and p control inputs (p = 0 without `B`). Shapes and
/// finiteness are checked; symmetry and PSD are the filter engine's to check.
#[derive(Debug, Clone, PartialEq)]
pub struct DiscreteModel {
    /// Sampling interval Δt in seconds (finite, > 0).
    pub dt: f64,
    /// Transition matrix (n×n).
    pub F: DMatrix<f64>,
    /// Control input matrix (n×p; n×0 when the file has no `B`).
    pub B: DMatrix<f64>,
    /// Measurement matrix (m×n).
    pub H: DMatrix<f64>,
    /// Control feed-through (m×p; zero when the file has no `D`).
    pub D: DMatrix<f64>,
    /// Process-noise covariance (n×n).
    pub Q: DMatrix<f64>,
    /// Measurement-noise covariance (m×m).
    pub R: DMatrix<f64>,
    /// Cross-covariance `E[w_k v_kᵀ]` (n×m), if given.
    pub S: Option<DMatrix<f64>>,
    /// Initial state mean (n; zero when the file has no `x0`).
    pub x0: DVector<f64>,
    /// Initial state covariance (n×n), if given (`filter` requires it).
    pub P0: Option<DMatrix<f64>>,
    /// Names of the m measurement channels, if given (the data header may use them).
    pub channels: Option<Vec<String>>,
}

impl DiscreteModel {
    /// Number of states n.
    pub fn n(&self) -> usize {
        self.F.nrows()
    }
    /// Number of measurements m.
    pub fn m(&self) -> usize {
        self.H.nrows()
    }
    /// Number of control inputs p.
    pub fn p(&self) -> usize {
        self.B.ncols()
    }
}

/// A validated continuous model file
///
/// ```text
/// ẋ = A x + B u + G w,   y = C x + D u,   E[w(t) w(s)ᵀ] = Qc δ(t − s)
/// ```
///
/// with n states, m outputs, p control inputs and q noise inputs. `R`, if given, is the
/// covariance of the measurement noise of one sample and is copied to the discrete model.
#[derive(Debug, Clone, PartialEq)]
pub struct ContinuousModel {
    /// State matrix (n×n).
    pub A: DMatrix<f64>,
    /// Control input matrix (n×p; n×0 without `B`).
    pub B: DMatrix<f64>,
    /// Noise input matrix (n×q; the identity without `G`).
    pub G: DMatrix<f64>,
    /// Noise intensity (q×q; zero without `Qc`).
    pub Qc: DMatrix<f64>,
    /// Output matrix (m×n).
    pub C: DMatrix<f64>,
    /// Feed-through (m×p; zero without `D`).
    pub D: DMatrix<f64>,
    /// Covariance of one sample's measurement noise (m×m), if given.
    pub R: Option<DMatrix<f64>>,
    /// Initial state mean at the first row's time stamp (n; zero without `x0`).
    pub x0: DVector<f64>,
    /// Initial state covariance (n×n), if given (`filter` requires it).
    pub P0: Option<DMatrix<f64>>,
    /// Names of the m measurement channels, if given (the data header may use them).
    pub channels: Option<Vec<String>>,
}

impl ContinuousModel {
    /// Number of states n.
    pub fn n(&self) -> usize {
        self.A.nrows()
    }
    /// Number of measurements m.
    pub fn m(&self) -> usize {
        self.C.nrows()
    }
    /// Number of control inputs p.
    pub fn p(&self) -> usize {
        self.B.ncols()
    }
}

/// A model file as `filter` reads it: discrete (with `dt`) or continuous (sampled at the
/// record's own time stamps), told apart by its keys (`F` or `A`).
#[derive(Debug, Clone, PartialEq)]
pub enum AnyModel {
    /// A discrete model (`dt`, `F`, `H`, …).
    Discrete(DiscreteModel),
    /// A continuous model (`A`, `C`, …).
    Continuous(ContinuousModel),
}

/// The serialised form of a discrete model (what `discretize` writes and `filter` reads).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiscreteFile {
    /// Δt.
    pub dt: f64,
    /// `F`.
    pub F: Rows,
    /// `B`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub B: Option<Rows>,
    /// `H`.
    pub H: Rows,
    /// `D`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub D: Option<Rows>,
    /// `Q`.
    pub Q: Rows,
    /// `R`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub R: Option<Rows>,
    /// `S`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub S: Option<Rows>,
    /// `x0`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x0: Option<Vec<f64>>,
    /// `P0`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub P0: Option<Rows>,
    /// `channels`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub channels: Option<Vec<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ContinuousFile {
    A: Rows,
    #[serde(default)]
    B: Option<Rows>,
    #[serde(default)]
    G: Option<Rows>,
    #[serde(default)]
    Qc: Option<Rows>,
    C: Rows,
    #[serde(default)]
    D: Option<Rows>,
    #[serde(default)]
    R: Option<Rows>,
    #[serde(default)]
    x0: Option<Vec<f64>>,
    #[serde(default)]
    P0: Option<Rows>,
    #[serde(default)]
    channels: Option<Vec<String>>,
}

/// Row-major nested arrays of a matrix.
pub fn to_rows(m: &DMatrix<f64>) -> Rows {
    m.row_iter().map(|r| r.iter().copied().collect()).collect()
}

/// The file formats a model can be written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Json,
    Toml,
}

fn format_of(path: &Path) -> Result<Format> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("json") => Ok(Format::Json),
        Some("toml") => Ok(Format::Toml),
        _ => Err(Error::invalid(
            path,
            "unknown model format: the file name must end in .json or .toml",
        )),
    }
}

/// The non-number token (`NaN`, `Infinity`, …) at 1-based `line`/`column` of `text`, if
/// that is what a JSON syntax error there is about.
fn non_json_number(text: &str, line: usize, column: usize) -> Option<&'static str> {
    const TOKENS: [&str; 8] = [
        "-Infinity",
        "+Infinity",
        "Infinity",
        "-NaN",
        "NaN",
        "-inf",
        "inf",
        "+inf",
    ];
    let l = text.lines().nth(line.checked_sub(1)?)?;
    // The parser reports the column of the offending byte or the one after it.
    (column.saturating_sub(2)..=column).find_map(|start| {
        let rest = l.get(start..)?;
        TOKENS
            .iter()
            .find(|t| {
                rest.get(..t.len())
                    .is_some_and(|head| head.eq_ignore_ascii_case(t))
            })
            .copied()
    })
}

/// Deserialises JSON `text`, naming the key path of the place (`Q[0][0]`) in errors and
/// saying that NaN and Infinity are not JSON numbers.
fn deserialize_json<T: serde::de::DeserializeOwned>(path: &Path, text: &str) -> Result<T> {
    let describe = |key: &str, inner: &serde_json::Error| {
        let at = format!("line {} column {}", inner.line(), inner.column());
        let place = if key == "." || key.is_empty() {
            at
        } else {
            format!("key {key} at {at}")
        };
        let what = match non_json_number(text, inner.line(), inner.column()) {
            Some(token) if inner.is_syntax() => format!(
                "{token} is not a JSON number (JSON has no NaN or Infinity; write finite \
                 numbers, e.g. json.dump(..., allow_nan=False) in Python)"
            ),
            // serde_json's message ends in its own "at line L column C": said above.
            _ => {
                let m = inner.to_string();
                match m.rfind(" at line ") {
                    Some(i) => m[..i].to_string(),
                    None => m,
                }
            }
        };
        Error::invalid(path, format!("invalid JSON model, {place}: {what}"))
    };
    let mut de = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut de)
        .map_err(|e| describe(&e.path().to_string(), e.inner()))?;
    de.end().map_err(|e| describe("", &e))?;
    Ok(value)
}

/// Deserialises `text` as JSON or TOML (by `path`'s extension), naming line and column (and
/// for JSON the key path); a leading UTF-8 byte-order mark is ignored.
fn deserialize<T: serde::de::DeserializeOwned>(path: &Path, text: &str) -> Result<T> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    match format_of(path)? {
        Format::Json => deserialize_json(path, text),
        Format::Toml => toml::from_str(text).map_err(|e| {
            let at = e
                .span()
                .map(|span| {
                    // The span is in bytes; step back to a character boundary.
                    let mut start = span.start.min(text.len());
                    while !text.is_char_boundary(start) {
                        start -= 1;
                    }
                    let before = text.get(..start).unwrap_or("");
                    let line = before.matches('\n').count() + 1;
                    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
                    format!(" at line {line} column {column}")
                })
                .unwrap_or_default();
            Error::invalid(
                path,
                format!("invalid TOML model{at}: {}", e.message().trim_end()),
            )
        }),
    }
}

/// The optional control-input matrices `B` (n×p) and `D` (m×p) of a model file, p taken from
/// `B` (zero columns when absent); `names` are the matrices n and m come from, for messages.
fn control_matrices(
    path: &Path,
    b: Option<&Rows>,
    d: Option<&Rows>,
    n: usize,
    m: usize,
    names: [&str; 2],
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let [state, output] = names;
    let B = match b {
        Some(b) => {
            let p = b.first().map_or(0, Vec::len);
            matrix(
                path,
                "B",
                b,
                Some(n),
                Some(p),
                &format!("B must be n×p, n from {state}"),
            )?
        }
        None => DMatrix::zeros(n, 0),
    };
    let p = B.ncols();
    let D = match d {
        Some(d) => matrix(
            path,
            "D",
            d,
            Some(m),
            Some(p),
            &format!("D must be m×p, m from {output}, p from B"),
        )?,
        None => DMatrix::zeros(m, p),
    };
    Ok((B, D))
}

/// A matrix from nested rows with `rows`×`cols` required where given (`None`: taken from
/// the data). `why` says where the required dimension comes from.
fn matrix(
    path: &Path,
    name: &str,
    data: &Rows,
    rows: Option<usize>,
    cols: Option<usize>,
    why: &str,
) -> Result<DMatrix<f64>> {
    let r = data.len();
    let c = data.first().map_or(0, Vec::len);
    for (i, row) in data.iter().enumerate() {
        if row.len() != c {
            return Err(Error::invalid(
                path,
                format!(
                    "matrix {name}: row {} has {} entries but row 1 has {c} (shape: rows must have equal length)",
                    i + 1,
                    row.len()
                ),
            ));
        }
    }
    let er = rows.unwrap_or(r);
    let ec = cols.unwrap_or(c);
    // An empty matrix written `[]` has no rows to count columns from: accept it as r×0 or
    // 0×c when that is the shape required.
    let empty_ok = r == 0 && (er == 0 || ec == 0);
    if (r != er || c != ec) && !empty_ok {
        return Err(Error::invalid(
            path,
            format!("matrix {name} is {r}×{c}, expected {er}×{ec} (shape: {why})"),
        ));
    }
    let m = DMatrix::from_fn(er, ec, |i, j| data[i][j]);
    finite(path, name, &m)?;
    Ok(m)
}

fn finite(path: &Path, name: &str, m: &DMatrix<f64>) -> Result<()> {
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            let v = m[(i, j)];
            if !v.is_finite() {
                return Err(Error::invalid(
                    path,
                    format!(
                        "matrix {name} has {v} at row {}, column {} (NaN: entries must be finite)",
                        i + 1,
                        j + 1
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn square(path: &Path, name: &str, data: &Rows, what: &str) -> Result<DMatrix<f64>> {
    let n = data.len();
    if n == 0 {
        return Err(Error::invalid(
            path,
            format!("matrix {name} is empty (shape: the model needs at least one {what})"),
        ));
    }
    matrix(path, name, data, Some(n), Some(n), "it must be square")
}

/// Parses and checks a discrete model file (`path` gives the format by its extension and
/// names the file in errors; `text` is its contents).
///
/// # Errors
/// [`Error::Invalid`] naming the file and, for syntax, the line and column, or the matrix
/// and the rule broken (shape, NaN, `dt`).
pub fn parse_discrete(path: &Path, text: &str) -> Result<DiscreteModel> {
    let file: DiscreteFile = deserialize(path, text)?;
    discrete_from_file(path, &file)
}

/// Checks a deserialised discrete model (see [`parse_discrete`]).
///
/// # Errors
/// As [`parse_discrete`].
pub fn discrete_from_file(path: &Path, file: &DiscreteFile) -> Result<DiscreteModel> {
    if !(file.dt.is_finite() && file.dt > 0.0) {
        return Err(Error::invalid(
            path,
            format!("dt = {} is invalid: it must be finite and > 0", file.dt),
        ));
    }
    let F = square(path, "F", &file.F, "state")?;
    let n = F.nrows();
    if file.H.is_empty() {
        return Err(Error::invalid(
            path,
            "matrix H is empty (shape: the model needs at least one measurement)",
        ));
    }
    let H = matrix(path, "H", &file.H, None, Some(n), "H must be m×n, n from F")?;
    let m = H.nrows();
    let Q = matrix(
        path,
        "Q",
        &file.Q,
        Some(n),
        Some(n),
        "Q must be n×n, n from F",
    )?;
    let R = match &file.R {
        Some(r) => matrix(path, "R", r, Some(m), Some(m), "R must be m×m, m from H")?,
        None => {
            return Err(Error::invalid(
                path,
                "matrix R is missing (shape: a discrete model needs R, m×m)",
            ));
        }
    };
    let (B, D) = control_matrices(path, file.B.as_ref(), file.D.as_ref(), n, m, ["F", "H"])?;
    let S = file
        .S
        .as_ref()
        .map(|s| {
            matrix(
                path,
                "S",
                s,
                Some(n),
                Some(m),
                "S must be n×m, n from F, m from H",
            )
        })
        .transpose()?;
    let (x0, P0) = prior(path, file.x0.as_deref(), file.P0.as_ref(), n, "F")?;
    let channels = channel_names(path, file.channels.as_deref(), m, "H")?;
    Ok(DiscreteModel {
        dt: file.dt,
        F,
        B,
        H,
        D,
        Q,
        R,
        S,
        x0,
        P0,
        channels,
    })
}

/// Parses and checks a continuous model file (see [`parse_discrete`] for `path` and `text`).
///
/// # Errors
/// [`Error::Invalid`] naming the file and the line and column, or the matrix and the rule.
pub fn parse_continuous(path: &Path, text: &str) -> Result<ContinuousModel> {
    let file: ContinuousFile = deserialize(path, text)?;
    let A = square(path, "A", &file.A, "state")?;
    let n = A.nrows();
    if file.C.is_empty() {
        return Err(Error::invalid(
            path,
            "matrix C is empty (shape: the model needs at least one output)",
        ));
    }
    let C = matrix(path, "C", &file.C, None, Some(n), "C must be m×n, n from A")?;
    let m = C.nrows();
    let (B, D) = control_matrices(path, file.B.as_ref(), file.D.as_ref(), n, m, ["A", "C"])?;
    let G = match &file.G {
        Some(g) => {
            let q = g.first().map_or(0, Vec::len);
            matrix(path, "G", g, Some(n), Some(q), "G must be n×q, n from A")?
        }
        None => DMatrix::identity(n, n),
    };
    let q = G.ncols();
    let Qc = match &file.Qc {
        Some(w) => matrix(path, "Qc", w, Some(q), Some(q), "Qc must be q×q, q from G")?,
        None => DMatrix::zeros(q, q),
    };
    let R = file
        .R
        .as_ref()
        .map(|r| matrix(path, "R", r, Some(m), Some(m), "R must be m×m, m from C"))
        .transpose()?;
    let (x0, P0) = prior(path, file.x0.as_deref(), file.P0.as_ref(), n, "A")?;
    let channels = channel_names(path, file.channels.as_deref(), m, "C")?;
    Ok(ContinuousModel {
        A,
        B,
        G,
        Qc,
        C,
        D,
        R,
        x0,
        P0,
        channels,
    })
}

/// The measurement channels' names: m of them (m rows of `from`), distinct, each a
/// non-empty name of letters, digits, `_`, `-` or `.` that is not `t`, `z<k>` or `u<k>` (so a
/// data header stays unambiguous).
fn channel_names(
    path: &Path,
    names: Option<&[String]>,
    m: usize,
    from: &str,
) -> Result<Option<Vec<String>>> {
    let Some(names) = names else {
        return Ok(None);
    };
    let bad = |what: String| Err(Error::invalid(path, format!("channels: {what}")));
    if names.len() != m {
        return bad(format!(
            "{} names for m = {m} measurements (one name per row of {from})",
            names.len()
        ));
    }
    let reserved = |s: &str| {
        s == "t"
            || ["z", "u"].iter().any(|p| {
                s.strip_prefix(p)
                    .is_some_and(|k| !k.is_empty() && k.bytes().all(|b| b.is_ascii_digit()))
            })
    };
    for (i, name) in names.iter().enumerate() {
        let ok_chars = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if !ok_chars {
            return bad(format!(
                "channel {} `{}` must be a non-empty name of letters, digits, _, - or .",
                i + 1,
                name.escape_debug()
            ));
        }
        if reserved(name) {
            return bad(format!(
                "channel {} `{name}` is a name the data header reserves (t, z1…, u1…)",
                i + 1
            ));
        }
        if names[..i].contains(name) {
            return bad(format!("channel `{name}` is named twice"));
        }
    }
    Ok(Some(names.to_vec()))
}

/// The prior `x0` (zero when absent) and `P0` of a model file with n states (n from
/// matrix `from`).
fn prior(
    path: &Path,
    x0: Option<&[f64]>,
    P0: Option<&Rows>,
    n: usize,
    from: &str,
) -> Result<(DVector<f64>, Option<DMatrix<f64>>)> {
    let x0 = match x0 {
        Some(x) => {
            if x.len() != n {
                return Err(Error::invalid(
                    path,
                    format!(
                        "vector x0 has {} entries, expected {n} (shape: x0 must have n entries, n from {from})",
                        x.len()
                    ),
                ));
            }
            finite(path, "x0", &DMatrix::from_column_slice(n, 1, x))?;
            DVector::from_column_slice(x)
        }
        None => DVector::zeros(n),
    };
    let rule = format!("P0 must be n×n, n from {from}");
    let P0 = P0
        .map(|p0| matrix(path, "P0", p0, Some(n), Some(n), &rule))
        .transpose()?;
    Ok((x0, P0))
}

/// Parses a model file of either kind (see [`AnyModel`]).
///
/// # Errors
/// As [`parse_discrete`] or [`parse_continuous`].
pub fn parse_any(path: &Path, text: &str) -> Result<AnyModel> {
    let keys: serde_json::Value = deserialize(path, text)?;
    if keys.get("A").is_some() && keys.get("F").is_none() {
        parse_continuous(path, text).map(AnyModel::Continuous)
    } else {
        parse_discrete(path, text).map(AnyModel::Discrete)
    }
}

/// Reads and parses a model file of either kind.
///
/// # Errors
/// [`Error::Read`] if the file cannot be read, otherwise as [`parse_any`].
pub fn load_any(path: &Path) -> Result<AnyModel> {
    parse_any(path, &crate::config::read_text(path)?)
}

/// Reads and parses a discrete model file.
///
/// # Errors
/// [`Error::Read`] if the file cannot be read, otherwise as [`parse_discrete`].
pub fn load_discrete(path: &Path) -> Result<DiscreteModel> {
    parse_discrete(path, &crate::config::read_text(path)?)
}

/// Reads and parses a continuous model file.
///
/// # Errors
/// [`Error::Read`] if the file cannot be read, otherwise as [`parse_continuous`].
pub fn load_continuous(path: &Path) -> Result<ContinuousModel> {
    parse_continuous(path, &crate::config::read_text(path)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"{"dt": 0.1, "F": [[1, 0.1], [0, 1]], "H": [[1, 0]],
        "Q": [[0.01, 0], [0, 0.01]], "R": [[0.25]], "x0": [0, 1], "P0": [[1, 0], [0, 1]]}"#;

    fn err(path: &str, text: &str) -> String {
        parse_discrete(Path::new(path), text)
            .expect_err("must be rejected")
            .to_string()
    }

    #[test]
    fn good_json_and_toml_agree() {
        let j = parse_discrete(Path::new("m.json"), GOOD).expect("valid JSON");
        let t = parse_discrete(
            Path::new("m.TOML"),
            "dt = 0.1\nF = [[1, 0.1], [0, 1]]\nH = [[1, 0]]\nQ = [[0.01, 0], [0, 0.01]]\n\
             R = [[0.25]]\nx0 = [0, 1]\nP0 = [[1, 0], [0, 1]]\n",
        )
        .expect("valid TOML");
        assert_eq!(j, t);
        assert_eq!((j.n(), j.m(), j.p()), (2, 1, 0));
        assert_eq!(j.D.shape(), (1, 0));
        assert!(j.S.is_none());
    }

    #[test]
    fn errors_name_matrix_rule_and_position() {
        let e = err("m.json", &GOOD.replace("[[0.25]]", "[[0.25, 0]]"));
        assert!(
            e.contains("m.json") && e.contains("matrix R is 1×2, expected 1×1"),
            "{e}"
        );
        let e = err("m.json", &GOOD.replace("[0, 1]]", "[0]]"));
        assert!(e.contains("matrix F: row 2 has 1 entries"), "{e}");
        let e = err("m.json", "{\"dt\": 0.1,\n \"F\": [[1,]]}");
        assert!(e.contains("line 2 column"), "{e}");
        let e = err(
            "m.toml",
            "dt = 0.1\nF = [[nan]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\n",
        );
        assert!(e.contains("matrix F has NaN at row 1, column 1"), "{e}");
        let e = err(
            "m.toml",
            "dt = 0.1\nF = [[1]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\nX = 1\n",
        );
        assert!(
            e.contains("line 6") && e.contains("unknown field `X`"),
            "{e}"
        );
        let e = err("m.yaml", GOOD);
        assert!(e.contains(".json or .toml"), "{e}");
        let e = err("m.json", &GOOD.replace("\"dt\": 0.1", "\"dt\": -1"));
        assert!(e.contains("dt = -1"), "{e}");
    }

    #[test]
    fn continuous_defaults() {
        let c = parse_continuous(
            Path::new("c.json"),
            r#"{"A": [[0, 1], [0, 0]], "C": [[1, 0]]}"#,
        )
        .expect("valid");
        assert_eq!(c.G, DMatrix::identity(2, 2));
        assert_eq!(c.Qc, DMatrix::zeros(2, 2));
        assert_eq!(c.B.shape(), (2, 0));
        assert!(c.R.is_none());
    }
}
