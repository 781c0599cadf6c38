//! The data CSV (`t,z1,…,zm[,u1,…,up]`) read one row at a time, and the estimates CSV
//! (`t,x1,…,xn,P1_1,…,Pn_n,nis`) written one row at a time, so neither grows with the log.
//!
//! Data rules: the header names the columns exactly in that order (`t`, then `z1…zm` with
//! m ≥ 1, then `u1…up`); every row has as many fields as the header; `t` is finite and
//! never decreases (rows with the same `t` are one instant); a `z` cell that is empty or `NaN` (any case) is a missing value;
//! `u` cells must be present and finite. Blank lines are skipped; fields may be quoted and
//! padded with spaces; a UTF-8 byte-order mark is ignored. The file must end with a newline:
//! a last line without one is an error, since it usually means the file was cut short or is
//! still being written (`4,5.` of `4,5.25`). A quoted field that runs over a line break (an
//! unbalanced `"`) is an error. Each error is one line naming the file, the line and the
//! column (1-based, with the column's name).

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// One data row: time, measurements (NaN = missing) and control inputs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Row {
    /// Time stamp.
    pub t: f64,
    /// Measurements `z1…zm`; NaN marks a missing value.
    pub z: Vec<f64>,
    /// Control inputs `u1…up`.
    pub u: Vec<f64>,
}

/// A reader that remembers the last byte it passed on (to tell a file that ends with a
/// newline from one cut short).
#[derive(Debug)]
struct LastByte<R> {
    inner: R,
    last: Option<u8>,
}

impl<R: Read> Read for LastByte<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if let Some(&b) = buf[..n].last() {
            self.last = Some(b);
        }
        Ok(n)
    }
}

/// A short, one-line rendering of a cell's text for messages.
fn shown(text: &str) -> String {
    let escaped: String = text.escape_debug().collect();
    match escaped.char_indices().nth(40) {
        Some((i, _)) => format!("{}…", &escaped[..i]),
        None => escaped,
    }
}

/// A streaming reader of a data CSV: the header is read by [`DataReader::new`], then one
/// row per [`DataReader::read_row`], reusing the caller's buffers.
#[derive(Debug)]
pub struct DataReader<R: Read> {
    path: PathBuf,
    csv: csv::Reader<LastByte<R>>,
    last_line: u64,
    record: csv::ByteRecord,
    m: usize,
    p: usize,
    last_t: Option<f64>,
    /// The measurement columns' names as the header gives them (`z1…zm`, or the model's
    /// channel names).
    names: Vec<String>,
}

impl<R: Read> DataReader<R> {
    /// Reads the header of the CSV `reader` (named `path` in errors).
    ///
    /// # Errors
    /// [`Error::Invalid`] for an empty file or a header that is not `t,z1,…,zm[,u1,…,up]`;
    /// [`Error::Read`] for an I/O error.
    pub fn new(path: &Path, reader: R) -> Result<Self> {
        Self::with_channels(path, reader, None)
    }

    /// As [`DataReader::new`], for a model whose measurement channels are named `channels`:
    /// the header may then name its measurement columns either `z1…zm` or by those names,
    /// in the model's order.
    ///
    /// # Errors
    /// As [`DataReader::new`].
    pub fn with_channels(path: &Path, reader: R, channels: Option<&[String]>) -> Result<Self> {
        let csv = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(LastByte {
                inner: reader,
                last: None,
            });
        let mut this = DataReader {
            path: path.to_path_buf(),
            csv,
            last_line: 0,
            record: csv::ByteRecord::new(),
            m: 0,
            p: 0,
            last_t: None,
            names: Vec::new(),
        };
        if !this.next_record()? {
            return Err(this.at(
                1,
                None,
                "empty file: expected the header t,z1,…,zm[,u1,…,up]",
            ));
        }
        let line = this.line();
        let mut m = 0;
        let mut p = 0;
        let mut by_name = false;
        for (j, field) in this.record.iter().enumerate() {
            let field = if j == 0 {
                field.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(field)
            } else {
                field
            };
            let name = shown(&String::from_utf8_lossy(field));
            // The measurement columns are `z1…zm` or, if the model names its channels, those
            // names: the first one decides.
            if j == 1 {
                by_name = channels.is_some_and(|c| c.first() == Some(&name));
            }
            let next_z = match channels {
                Some(c) if by_name => c.get(m).cloned(),
                _ => Some(format!("z{}", m + 1)),
            };
            let ok = match j {
                0 => name == "t",
                _ if p == 0 && next_z.as_ref() == Some(&name) => {
                    m += 1;
                    this.names.push(name.clone());
                    true
                }
                _ if m > 0 && name == format!("u{}", p + 1) => {
                    p += 1;
                    true
                }
                _ => false,
            };
            if !ok {
                let next_z = match (channels, next_z) {
                    (Some(c), _) if m == 0 => format!("`z1` or `{}`", c[0]),
                    (_, Some(z)) => format!("`{z}` or `u1`"),
                    (_, None) => "`u1`".to_string(),
                };
                let expected = match j {
                    0 => "`t`".to_string(),
                    _ if m == 0 => next_z.trim_end_matches(" or `u1`").to_string(),
                    _ if p == 0 => next_z,
                    _ => format!("`u{}`", p + 1),
                };
                return Err(this.at(
                    line,
                    Some(j),
                    &format!("header `{name}`: expected {expected} (header: t,z1,…,zm[,u1,…,up])"),
                ));
            }
        }
        if m == 0 {
            return Err(this.at(
                line,
                Some(this.record.len()),
                "header has no measurement column: expected t,z1,…,zm[,u1,…,up] with m ≥ 1",
            ));
        }
        this.m = m;
        this.p = p;
        Ok(this)
    }

    /// Number of measurement columns m.
    pub fn m(&self) -> usize {
        self.m
    }

    /// Number of control-input columns p.
    pub fn p(&self) -> usize {
        self.p
    }

    /// The name of measurement column `i` (0-based) as the header gives it.
    pub fn channel(&self, i: usize) -> &str {
        &self.names[i]
    }

    /// The file this reader reads (for error messages).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The line (1-based) of the last record read.
    pub fn line(&self) -> u64 {
        self.record.position().map_or(0, csv::Position::line)
    }

    /// The name of 0-based column `j`.
    fn column_name(&self, j: usize) -> String {
        match j {
            0 => "t".into(),
            j if j <= self.m => self.names[j - 1].clone(),
            j => format!("u{}", j - self.m),
        }
    }

    /// An [`Error::Invalid`] at `line` and, if given, 0-based column `col`.
    fn at(&self, line: u64, col: Option<usize>, what: &str) -> Error {
        let place = match col {
            Some(j) if self.m > 0 => {
                format!("line {line}, column {} ({})", j + 1, self.column_name(j))
            }
            Some(j) => format!("line {line}, column {}", j + 1),
            None => format!("line {line}"),
        };
        Error::invalid(&self.path, format!("{place}: {what}"))
    }

    /// Reads the next record; at the end, checks that the file ended with a newline.
    fn next_record(&mut self) -> Result<bool> {
        let more =
            self.csv
                .read_byte_record(&mut self.record)
                .map_err(|e| match e.into_kind() {
                    csv::ErrorKind::Io(source) => Error::Read {
                        path: self.path.clone(),
                        source,
                    },
                    other => Error::invalid(&self.path, format!("malformed CSV: {other:?}")),
                })?;
        if !more {
            let last = self.csv.get_ref().last;
            // (No record at all — an empty file, or only a byte-order mark — is reported as
            // an empty file by the caller.)
            if self.last_line > 0 && last.is_some_and(|b| b != b'\n' && b != b'\r') {
                return Err(self.at(
                    self.last_line,
                    None,
                    "the last line has no final newline: the file looks cut short (or is \
                     still being written); if it is whole, end it with a newline",
                ));
            }
            return Ok(false);
        }
        let line = self.line();
        self.last_line = line;
        if let Some(j) = self
            .record
            .iter()
            .position(|f| f.contains(&b'\n') || f.contains(&b'\r'))
        {
            return Err(self.at(
                line,
                Some(j),
                "unbalanced quote: a quoted field runs over the end of the line",
            ));
        }
        Ok(true)
    }

    /// Reads the next row into `row` (resized to m and p). Returns `false` at the end.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the line and column of a missing or extra field, a value
    /// that is not a number, a non-finite `t` or `u`, or a `t` that does not increase.
    pub fn read_row(&mut self, row: &mut Row) -> Result<bool> {
        if !self.next_record()? {
            return Ok(false);
        }
        let line = self.line();
        let width = 1 + self.m + self.p;
        let got = self.record.len();
        if got < width {
            return Err(self.at(
                line,
                Some(got),
                &format!("missing field: the row has {got} fields, the header {width}"),
            ));
        }
        if got > width {
            return Err(Error::invalid(
                &self.path,
                format!(
                    "line {line}, column {}: extra field: the row has {got} fields, the header {width}",
                    width + 1
                ),
            ));
        }
        row.z.resize(self.m, f64::NAN);
        row.u.resize(self.p, 0.0);
        for j in 0..width {
            let field = &self.record[j];
            let text =
                std::str::from_utf8(field).map_err(|_| self.at(line, Some(j), "not UTF-8 text"))?;
            let missing = text.is_empty() || text.eq_ignore_ascii_case("nan");
            let is_z = j >= 1 && j <= self.m;
            if missing {
                if is_z {
                    row.z[j - 1] = f64::NAN;
                    continue;
                }
                return Err(self.at(
                    line,
                    Some(j),
                    "missing value (only z cells may be empty or NaN)",
                ));
            }
            let v: f64 = text.parse().map_err(|_| {
                self.at(line, Some(j), &format!("`{}` is not a number", shown(text)))
            })?;
            if !v.is_finite() {
                return Err(self.at(line, Some(j), &format!("`{}` is not finite", shown(text))));
            }
            match j {
                0 => {
                    if let Some(last) = self.last_t
                        && v < last
                    {
                        return Err(self.at(
                            line,
                            Some(0),
                            &format!("t = {v} is before the previous row's t = {last} (t must not decrease; rows with the same t are one instant)"),
                        ));
                    }
                    self.last_t = Some(v);
                    row.t = v;
                }
                j if is_z => row.z[j - 1] = v,
                j => row.u[j - 1 - self.m] = v,
            }
        }
        Ok(true)
    }
}

/// Reads a whole data CSV held in memory (the parser the property test and fuzz target
/// drive): returns (m, p, rows).
///
/// # Errors
/// As [`DataReader::new`] and [`DataReader::read_row`].
pub fn parse_data(path: &Path, bytes: &[u8]) -> Result<(usize, usize, Vec<Row>)> {
    let mut reader = DataReader::new(path, bytes)?;
    let mut rows = Vec::new();
    let mut row = Row::default();
    while reader.read_row(&mut row)? {
        rows.push(row.clone());
    }
    Ok((reader.m(), reader.p(), rows))
}

/// The header of the estimates CSV for n states: `t,x1..xn,P1_1..Pn_n,nis` (only the
/// diagonal of P unless `full`, then every `Pi_j`, row by row).
pub fn estimates_header(n: usize, full: bool) -> String {
    let mut h = String::from("t");
    for i in 1..=n {
        h.push_str(&format!(",x{i}"));
    }
    for i in 1..=n {
        if full {
            for j in 1..=n {
                h.push_str(&format!(",P{i}_{j}"));
            }
        } else {
            h.push_str(&format!(",P{i}_{i}"));
        }
    }
    h.push_str(",nis");
    h
}

/// Writes one estimates row: `t`, `x`, the diagonal (or all, row by row) of the n×n
/// column-major `p`, and `nis` (NaN when no measurement was available). Numbers use the
/// shortest representation that reads back to the same `f64` (`zmij`, as serde_json).
///
/// # Errors
/// [`Error::Write`] naming `path` on an I/O error.
pub fn write_estimate(
    out: &mut (impl Write + ?Sized),
    path: &Path,
    t: f64,
    x: &[f64],
    p: &[f64],
    full: bool,
    nis: f64,
) -> Result<()> {
    let n = x.len();
    let mut buf = zmij::Buffer::new();
    let mut go = || -> std::io::Result<()> {
        out.write_all(buf.format(t).as_bytes())?;
        let mut put = |v: f64| -> std::io::Result<()> {
            out.write_all(b",")?;
            out.write_all(buf.format(v).as_bytes())
        };
        for &v in x {
            put(v)?;
        }
        for i in 0..n {
            if full {
                for j in 0..n {
                    put(p[i + j * n])?;
                }
            } else {
                put(p[i + i * n])?;
            }
        }
        put(nis)?;
        out.write_all(b"\n")
    };
    go().map_err(|source| Error::Write {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        parse_data(Path::new("z.csv"), text.as_bytes())
            .expect_err("must be rejected")
            .to_string()
    }

    #[test]
    fn reads_missing_values_and_controls() {
        let (m, p, rows) = parse_data(
            Path::new("z.csv"),
            b"\xEF\xBB\xBFt, z1 ,z2,u1\r\n0,1.5,,3\n\n1,nan,2,\"4\"\n",
        )
        .expect("valid");
        assert_eq!((m, p, rows.len()), (2, 1, 2));
        assert!(rows[0].z[1].is_nan() && rows[1].z[0].is_nan());
        assert!((rows[0].z[0] - 1.5).abs() < f64::EPSILON);
        assert!((rows[1].u[0] - 4.0).abs() < f64::EPSILON);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = err("t,z1\n0,1\n1,abc\n");
        assert!(
            e.contains("z.csv: line 3, column 2 (z1): `abc` is not a number"),
            "{e}"
        );
        let e = err("t,z1,u1\n0,1,\n");
        assert!(e.contains("line 2, column 3 (u1): missing value"), "{e}");
        let e = err("t,z1\n0,1\n-1,2\n");
        assert!(
            e.contains("line 3, column 1 (t)") && e.contains("must not decrease"),
            "{e}"
        );
        // Two rows of one instant are one time stamp, not an error.
        let (_, _, rows) = parse_data(Path::new("z.csv"), b"t,z1\n0,1\n0,2\n").expect("same t");
        assert_eq!(rows.len(), 2);
        let e = err("t,z1\n0\n");
        assert!(e.contains("line 2, column 2 (z1): missing field"), "{e}");
        let e = err("t,z1\n0,1,2\n");
        assert!(e.contains("line 2, column 3: extra field"), "{e}");
        let e = err("t,z2\n");
        assert!(
            e.contains("line 1, column 2") && e.contains("expected `z1`"),
            "{e}"
        );
        let e = err("t,u1\n");
        assert!(e.contains("expected `z1`"), "{e}");
        let e = err("t\n");
        assert!(e.contains("no measurement column"), "{e}");
        let e = err("");
        assert!(e.contains("line 1: empty file"), "{e}");
        let e = err("t,z1\n0,inf\n");
        assert!(e.contains("`inf` is not finite"), "{e}");
    }

    #[test]
    fn estimates_layout() {
        assert_eq!(estimates_header(2, false), "t,x1,x2,P1_1,P2_2,nis");
        assert_eq!(estimates_header(2, true), "t,x1,x2,P1_1,P1_2,P2_1,P2_2,nis");
        let mut out = Vec::new();
        // Column-major P = [[1, 2], [3, 4]].
        write_estimate(
            &mut out,
            Path::new("e"),
            0.5,
            &[1.0, -2.0],
            &[1.0, 3.0, 2.0, 4.0],
            true,
            f64::NAN,
        )
        .expect("write");
        assert_eq!(
            String::from_utf8_lossy(&out),
            "0.5,1.0,-2.0,1.0,2.0,3.0,4.0,NaN\n"
        );
    }
}
