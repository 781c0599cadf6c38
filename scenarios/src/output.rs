//! Whole-or-nothing output: every file is written to a temporary name beside its destination
//! and renamed into place only once it is complete, so an interrupted or failed run never
//! leaves a half-written report, CSV or model behind.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::error::{Error, Result};

/// The temporary sibling of `path` used while writing it.
fn temporary(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.partial", std::process::id()))
}

/// Writes a file through a streaming writer; the destination appears only if `fill` succeeds
/// and the data reached the disk. On any error the temporary file is removed.
pub fn write_with<T>(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<T>,
) -> Result<T> {
    let write_err = |source| Error::Write {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(write_err)?;
    }
    let tmp = temporary(path);
    let result = (|| {
        let file = std::fs::File::create(&tmp).map_err(write_err)?;
        let mut out = std::io::BufWriter::new(file);
        let value = fill(&mut out)?;
        out.flush().map_err(write_err)?;
        out.get_ref().sync_all().map_err(write_err)?;
        drop(out);
        std::fs::rename(&tmp, path).map_err(write_err)?;
        Ok(value)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Writes `bytes` to `path` whole or not at all.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |out| {
        out.write_all(bytes).map_err(|source| Error::Write {
            path: path.to_path_buf(),
            source,
        })
    })
}

/// Writes `value` as pretty JSON (with a final newline) whole or not at all.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)
        .map_err(|e| Error::Compute(format!("{}: cannot serialise: {e}", path.display())))?;
    text.push('\n');
    write_atomic(path, text.as_bytes())
}

/// Writes a CSV file with a header and numeric rows, whole or not at all. Numbers use Rust's
/// shortest round-trip formatting, so the file reads back to the same `f64` values.
pub fn write_csv(path: &Path, header: &[&str], rows: &[Vec<f64>]) -> Result<()> {
    let mut text = header.join(",");
    text.push('\n');
    for row in rows {
        for (i, v) in row.iter().enumerate() {
            if i > 0 {
                text.push(',');
            }
            text.push_str(&v.to_string());
        }
        text.push('\n');
    }
    write_atomic(path, text.as_bytes())
}

/// Copies every regular, non-hidden file of directory `from` into `to` (each written whole or
/// not at all); used by `merge` to carry over the files every shard writes identically.
pub fn copy_files(from: &Path, to: &Path) -> Result<()> {
    let read_err = |source| Error::Read {
        path: from.to_path_buf(),
        source,
    };
    let mut names = Vec::new();
    for entry in std::fs::read_dir(from).map_err(read_err)? {
        let entry = entry.map_err(read_err)?;
        let name = entry.file_name();
        let is_file = entry.file_type().map_err(read_err)?.is_file();
        if is_file && !name.to_string_lossy().starts_with('.') {
            names.push(name);
        }
    }
    names.sort();
    for name in names {
        let src = from.join(&name);
        let bytes = std::fs::read(&src).map_err(|source| Error::Read { path: src, source })?;
        write_atomic(&to.join(&name), &bytes)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = std::env::temp_dir().join(format!("scenarios-output-{}", std::process::id()));
        let path = dir.join("x.csv");
        let r: Result<()> = write_with(&path, |out| {
            out.write_all(b"half")
                .map_err(|e| Error::Compute(e.to_string()))?;
            Err(Error::Compute("stopped".into()))
        });
        assert!(r.is_err());
        assert!(!path.exists());
        let leftovers = std::fs::read_dir(&dir).map(|d| d.count()).unwrap_or(0);
        assert_eq!(leftovers, 0, "the temporary file must be removed");
        write_csv(&path, &["a", "b"], &[vec![1.0, 0.1]]).expect("write");
        assert_eq!(
            std::fs::read_to_string(&path).expect("read"),
            "a,b\n1,0.1\n"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
