//! Run-record files: the CSV files a campaign writes one row per Monte Carlo run into, the
//! ground truth every other output is recomputed from. Each file is described in the
//! campaign's `summary.json` by its row count and FNV-1a checksum, so a file read back for
//! `merge` is provably whole: a missing final newline, a short file or a changed byte is an
//! error naming the file (and the line, where there is one to name).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The layout of one record file: its name, its CSV header and the index grid its key
/// columns run over.
///
/// The first `grid.len()` columns of every row are integer indices (for example point and
/// run); a complete campaign holds exactly one row for every combination, in lexicographic
/// order, with the run index last.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordFile {
    /// File name inside the output directory.
    pub name: String,
    /// Column names.
    pub header: Vec<&'static str>,
    /// Extent of each key column: `grid[i]` values `0..grid[i]`; the last is the run.
    pub grid: Vec<usize>,
}

/// What `summary.json` says about a record file: enough to prove it was read back whole.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileCheck {
    /// File name.
    pub file: String,
    /// Data rows (header excluded).
    pub rows: usize,
    /// FNV-1a (64-bit) of the file's bytes, 16 hex digits.
    pub fnv1a: String,
}

/// FNV-1a, 64-bit (Fowler, Noll and Vo): `h = (h ⊕ byte)·0x100000001b3` from the offset basis
/// `0xcbf29ce484222325`. Not cryptographic; it catches truncation and changed bytes, which
/// is all a record check needs.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

pub use crate::output::csv_text;

/// The per-run records of a scenario, as the campaign writes them to their record files and
/// reads them back; `P` is the scenario's parameter struct.
pub trait RunRecords<P>: Sized {
    /// The record files of a campaign with parameters `params` (none for a deterministic
    /// one).
    fn record_files(params: &P) -> Vec<RecordFile>;

    /// The rows of each record file, in [`RunRecords::record_files`] order, keys first.
    fn to_tables(&self) -> Vec<Vec<Vec<f64>>>;

    /// The records back from the rows of each record file (keys checked by the campaign).
    ///
    /// # Errors
    /// [`Error::Invalid`] if the tables or their rows do not fit the parameters.
    fn from_tables(params: &P, tables: Vec<Vec<Vec<f64>>>) -> Result<Self>;
}

/// A record that is one row of a scenario's only record file: a `Vec` of them is the
/// scenario's [`RunRecords`], one table of one row per record, in key order.
pub trait Row: Sized {
    /// The scenario's parameter struct.
    type Params;

    /// The record file's name.
    const FILE: &'static str;

    /// The record file's columns, keys first.
    fn header() -> Vec<&'static str>;

    /// The extent of each key column for the parameters `params` (the run last).
    fn grid(params: &Self::Params) -> Vec<usize>;

    /// The record's row, in [`Row::header`] order.
    fn to_row(&self) -> Vec<f64>;

    /// The record of `row`, or `None` if `row` does not have the header's width.
    fn from_row(row: &[f64]) -> Option<Self>;
}

impl<R: Row> RunRecords<R::Params> for Vec<R> {
    fn record_files(params: &R::Params) -> Vec<RecordFile> {
        vec![RecordFile {
            name: R::FILE.into(),
            header: R::header(),
            grid: R::grid(params),
        }]
    }

    fn to_tables(&self) -> Vec<Vec<Vec<f64>>> {
        vec![self.iter().map(R::to_row).collect()]
    }

    fn from_tables(_params: &R::Params, tables: Vec<Vec<Vec<f64>>>) -> Result<Self> {
        let [rows]: [Vec<Vec<f64>>; 1] = tables.try_into().map_err(|t: Vec<_>| {
            Error::invalid(R::FILE, format!("{} tables, expected 1", t.len()))
        })?;
        let width = R::header().len();
        rows.into_iter()
            .map(|row| {
                R::from_row(&row).ok_or_else(|| {
                    Error::invalid(
                        R::FILE,
                        format!("a row of {} fields, expected {width}", row.len()),
                    )
                })
            })
            .collect()
    }
}

/// The check of a record file's text.
pub fn check_of(name: &str, text: &str) -> FileCheck {
    FileCheck {
        file: name.to_string(),
        rows: text.lines().count().saturating_sub(1),
        fnv1a: format!("{:016x}", fnv1a(text.as_bytes())),
    }
}

/// Checks the text `text` of the file `path` against the check stored for it: the final
/// newline, the row count (lines after the first) and the FNV-1a checksum.
///
/// # Errors
/// [`Error::Invalid`] naming `path` and what does not agree.
pub fn verify(path: &Path, text: &str, check: &FileCheck) -> Result<()> {
    let bad = |message: String| Error::invalid(path, message);
    let lines = text.lines().count();
    if !text.ends_with('\n') {
        return Err(bad(format!(
            "line {lines}: no final newline: the file is cut short"
        )));
    }
    if lines.saturating_sub(1) != check.rows {
        return Err(bad(format!(
            "{} rows, but summary.json records {}: the file is incomplete or was changed",
            lines.saturating_sub(1),
            check.rows
        )));
    }
    let sum = format!("{:016x}", fnv1a(text.as_bytes()));
    if sum != check.fnv1a {
        return Err(bad(format!(
            "FNV-1a checksum {sum}, but summary.json records {}: the file was changed",
            check.fnv1a
        )));
    }
    Ok(())
}

/// Parses the record file `path` (its text `text`) against its layout and the check stored
/// for it: the final newline, the row count and the checksum must all agree before a single
/// number is read, and every row must have the header's width and integer keys inside the
/// grid.
///
/// # Errors
/// [`Error::Invalid`] naming `path` and, where it can, the line.
pub fn parse(
    path: &Path,
    text: &str,
    layout: &RecordFile,
    check: &FileCheck,
) -> Result<Vec<(Vec<usize>, Vec<f64>)>> {
    let bad = |message: String| Error::invalid(path, message);
    verify(path, text, check)?;
    let mut it = text.lines();
    let header = it.next().unwrap_or_default();
    let expected = layout.header.join(",");
    if header != expected {
        return Err(bad(format!(
            "line 1: header is `{header}`, expected `{expected}`"
        )));
    }
    let keys = layout.grid.len();
    let mut rows = Vec::with_capacity(check.rows);
    for (n, line) in it.enumerate() {
        let at = |what: String| bad(format!("line {}: {what}", n + 2));
        let values: Vec<f64> = line
            .split(',')
            .map(str::parse::<f64>)
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| at(format!("not a number: {e}")))?;
        if values.len() != layout.header.len() {
            return Err(at(format!(
                "{} fields, expected {}",
                values.len(),
                layout.header.len()
            )));
        }
        let mut key = Vec::with_capacity(keys);
        for (i, (&x, &extent)) in values.iter().zip(&layout.grid).enumerate() {
            if !(x >= 0.0 && x.fract() == 0.0 && x < extent as f64) {
                return Err(at(format!(
                    "`{}` = {x} is not an index below {extent}",
                    layout.header[i]
                )));
            }
            key.push(x as usize);
        }
        rows.push((key, values));
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout() -> RecordFile {
        RecordFile {
            name: "r.csv".into(),
            header: vec!["point", "run", "x"],
            grid: vec![2, 3],
        }
    }

    #[test]
    fn fnv1a_matches_the_published_test_vectors() {
        // From the FNV reference (Landon Curt Noll's test suite): "", "a", "foobar".
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn values_round_trip_exactly() {
        let rows = vec![vec![1.0, 2.0, 0.1 + 0.2], vec![0.0, 0.0, -1e-3 / 3.0]];
        let text = csv_text(&layout().header, &rows);
        let check = check_of("r.csv", &text);
        let back = parse(Path::new("r.csv"), &text, &layout(), &check).expect("parses");
        assert_eq!(back[0].0, vec![1, 2]);
        for ((_, got), want) in back.iter().zip(&rows) {
            for (a, b) in got.iter().zip(want) {
                assert_eq!(a.to_bits(), b.to_bits());
            }
        }
    }

    #[test]
    fn damaged_files_are_refused_by_name_and_line() {
        let text = csv_text(&layout().header, &[vec![1.0, 2.0, -0.0027]]);
        let check = check_of("r.csv", &text);
        let path = Path::new("r.csv");
        // Cut inside the last number: no final newline.
        let cut = &text[..text.len() - 3];
        let msg = parse(path, cut, &layout(), &check)
            .expect_err("cut")
            .to_string();
        assert!(msg.contains("r.csv") && msg.contains("line 2"), "{msg}");
        // Cut at a line end: one row short.
        let short = "point,run,x\n";
        let msg = parse(path, short, &layout(), &check)
            .expect_err("short")
            .to_string();
        assert!(msg.contains("0 rows"), "{msg}");
        // A changed digit, same length and line count.
        let changed = text.replace("0.0027", "0.0028");
        let msg = parse(path, &changed, &layout(), &check)
            .expect_err("changed")
            .to_string();
        assert!(msg.contains("checksum"), "{msg}");
        // A key outside the grid, with a check that matches the bad text.
        let outside = csv_text(&layout().header, &[vec![2.0, 0.0, 1.0]]);
        let msg = parse(path, &outside, &layout(), &check_of("r.csv", &outside))
            .expect_err("outside")
            .to_string();
        assert!(msg.contains("line 2") && msg.contains("point"), "{msg}");
    }
}
