//! Whole-or-nothing output: every file is written to a temporary name beside its destination
//! and renamed into place only once it is complete, so an interrupted or failed run never
//! leaves a half-written report, CSV or model behind.
//!
//! The rules for a destination (checked before anything is written):
//! - a new name, or an existing regular file (replaced whole, keeping its permissions);
//! - a symbolic link to a regular file: the file it points to is replaced, the link stays;
//! - anything else — a directory, a device such as `/dev/null`, a FIFO, a socket, a dangling
//!   link — is refused, never replaced by a regular file;
//! - a command's `--out` that is the same file as one of its inputs (compared by device and
//!   inode, so `./x`, links and hard links are caught) is refused; see [`destination`];
//! - `--out -` means standard output for the commands that write one file ([`Destination`]).
//!
//! Directories on the way to a destination are created only when the file is written, and
//! removed again if the write fails. [`remove_partial_files_on_interrupt`] makes SIGINT and
//! SIGTERM remove the temporary files and directories of writes in progress.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use serde::Serialize;

use crate::error::{Error, Result};

/// Exit code after SIGINT or SIGTERM (128 + SIGINT, the shell's convention for Ctrl-C).
pub const INTERRUPTED_EXIT_CODE: i32 = 130;

/// Temporary files and freshly created directories of the writes in progress, removed by
/// the interrupt handler. Held while a write creates or renames, so an interrupt sees either
/// the temporary file or the finished destination, never neither.
static IN_PROGRESS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn in_progress() -> MutexGuard<'static, Vec<PathBuf>> {
    IN_PROGRESS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Removes `paths` (files, then directories only if empty), last first.
fn remove_all(paths: &[PathBuf]) {
    for p in paths.iter().rev() {
        if std::fs::remove_file(p).is_err() {
            let _ = std::fs::remove_dir(p);
        }
    }
}

/// Installs a SIGINT/SIGTERM handler that removes the temporary files (and directories
/// created for them) of the writes in progress and exits with [`INTERRUPTED_EXIT_CODE`].
/// Call it once, from the program's `main`.
///
/// # Errors
/// [`Error::Interrupt`] if a handler cannot be installed (one is already set).
pub fn remove_partial_files_on_interrupt() -> Result<()> {
    ctrlc::set_handler(|| {
        let open = in_progress();
        remove_all(&open);
        // Exit while still holding the lock: no write can rename into place after this.
        std::process::exit(INTERRUPTED_EXIT_CODE);
    })
    .map_err(Error::Interrupt)
}

/// Where a command that writes one file sends it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Destination {
    /// Standard output (`--out -`). A streaming command may have written part of its output
    /// when it fails; its exit code says so.
    Stdout,
    /// A file, written whole or not at all.
    File(PathBuf),
}

impl std::fmt::Display for Destination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Destination::Stdout => f.write_str("standard output"),
            Destination::File(p) => write!(f, "{}", p.display()),
        }
    }
}

/// Whether two existing paths are the same file (same device and inode on Unix; the same
/// canonical path elsewhere).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
            (Ok(x), Ok(y)) => x == y,
            _ => false,
        }
    }
}

/// What an existing path is, for messages.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if meta.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// Why a destination is refused (the caller names the path or the option).
#[derive(Debug, thiserror::Error)]
enum Refusal {
    #[error("an empty file name")]
    EmptyName,
    #[error("{} is {kind}, not a directory", dir.display())]
    AncestorNotDirectory { dir: PathBuf, kind: &'static str },
    #[error("cannot resolve the symbolic link: {0}")]
    UnresolvedLink(std::io::Error),
    #[error("a symbolic link to {0}; refusing to replace it (only regular files are written)")]
    LinkToSpecial(&'static str),
    #[error("a symbolic link to a missing file; refusing to follow it")]
    DanglingLink,
    #[error("is {kind}; refusing to replace it: only regular files are written{}",
        if *directory { "" } else { "; use --out - for standard output" })]
    NotRegular { kind: &'static str, directory: bool },
}

/// The regular file to replace when writing `path`, by the rules in the module docs: `path`
/// itself, or the file a symbolic link points to. `Err` says why `path` is refused.
fn resolve(path: &Path) -> std::result::Result<PathBuf, Refusal> {
    if path.as_os_str().is_empty() {
        return Err(Refusal::EmptyName);
    }
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        // A new file: every existing ancestor must be a directory.
        for dir in path.ancestors().skip(1) {
            if let Ok(m) = std::fs::metadata(dir) {
                if !m.is_dir() {
                    return Err(Refusal::AncestorNotDirectory {
                        dir: dir.to_path_buf(),
                        kind: kind_of(&m),
                    });
                }
                break;
            }
        }
        return Ok(path.to_path_buf());
    };
    if meta.file_type().is_symlink() {
        return match std::fs::metadata(path) {
            Ok(target) if target.is_file() => {
                std::fs::canonicalize(path).map_err(Refusal::UnresolvedLink)
            }
            Ok(target) => Err(Refusal::LinkToSpecial(kind_of(&target))),
            Err(_) => Err(Refusal::DanglingLink),
        };
    }
    if meta.is_file() {
        return Ok(path.to_path_buf());
    }
    Err(Refusal::NotRegular {
        kind: kind_of(&meta),
        directory: meta.is_dir(),
    })
}

/// Checks a command's single output `out` before any work: `-` is standard output;
/// otherwise the file must follow the rules in the module docs and must not be the same
/// file as any of `inputs` (`(option, path)` pairs, for the message).
///
/// # Errors
/// [`Error::Usage`] (exit code 2) naming `--out` and, for a clash, the input.
pub fn destination(out: &Path, inputs: &[(&str, &Path)]) -> Result<Destination> {
    destination_of("--out", out, inputs)
}

/// [`destination`] for an output given by the option `option` (e.g. `--diagnostics`),
/// which the messages name.
///
/// # Errors
/// As [`destination`].
pub fn destination_of(option: &str, out: &Path, inputs: &[(&str, &Path)]) -> Result<Destination> {
    if out.as_os_str() == "-" {
        return Ok(Destination::Stdout);
    }
    let target =
        resolve(out).map_err(|why| Error::Usage(format!("{option} {}: {why}", out.display())))?;
    for (input_option, input) in inputs {
        if same_file(&target, input) {
            return Err(Error::Usage(format!(
                "{option} {}: is the same file as {input_option} {}; refusing to overwrite an input",
                out.display(),
                input.display()
            )));
        }
    }
    Ok(Destination::File(target))
}

/// Checks a command's outputs before any work: its main output `out` and its optional side
/// outputs (`(option, path)`, `None` for an option not given), each as [`destination_of`]
/// (its rules, and not one of `inputs`), and no two the same destination (standard output
/// twice, or one file named twice, however spelt).
///
/// # Errors
/// As [`destination_of`]; [`Error::Usage`] (exit code 2) naming both options for two outputs
/// with one destination.
pub fn destinations<const N: usize>(
    out: (&str, &Path),
    side: [(&str, Option<&Path>); N],
    inputs: &[(&str, &Path)],
) -> Result<(Destination, [Option<Destination>; N])> {
    let main = destination_of(out.0, out.1, inputs)?;
    let mut seen = vec![(out.0, out.1, main.clone())];
    let mut checked = [const { None }; N];
    for ((option, path), slot) in side.into_iter().zip(checked.iter_mut()) {
        let Some(path) = path else { continue };
        let d = destination_of(option, path, inputs)?;
        if let Some((first, first_path, _)) = seen.iter().find(|(_, _, e)| same_destination(e, &d))
        {
            return Err(Error::Usage(format!(
                "{option} {}: is the same destination as {first} {}; give them different files",
                path.display(),
                first_path.display(),
            )));
        }
        seen.push((option, path, d.clone()));
        *slot = Some(d);
    }
    Ok((main, checked))
}

/// Whether two destinations are one: both standard output, or files with the same absolute
/// path or (when they exist) the same file.
fn same_destination(a: &Destination, b: &Destination) -> bool {
    match (a, b) {
        (Destination::Stdout, Destination::Stdout) => true,
        (Destination::File(x), Destination::File(y)) => {
            let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
            abs(x) == abs(y) || same_file(x, y)
        }
        _ => false,
    }
}

/// The temporary sibling of `path` used while writing it.
fn temporary(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.partial", std::process::id()))
}

/// Creates the missing directories above `path`; returns those it created, outermost first.
fn create_parents(path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut missing: Vec<PathBuf> = path
        .ancestors()
        .skip(1)
        .filter(|d| !d.as_os_str().is_empty())
        .take_while(|d| std::fs::symlink_metadata(d).is_err())
        .map(Path::to_path_buf)
        .collect();
    missing.reverse();
    let mut created = Vec::new();
    for d in missing {
        match std::fs::create_dir(&d) {
            Ok(()) => created.push(d),
            // Another writer of the same run made it in the meantime.
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => {
                remove_all(&created);
                return Err(e);
            }
        }
    }
    Ok(created)
}

/// Writes a file through a streaming writer; the destination appears only if `fill` succeeds
/// and the data reached the disk. On any error (or SIGINT/SIGTERM, see
/// [`remove_partial_files_on_interrupt`]) the temporary file and any directory created for it
/// are removed.
///
/// # Errors
/// [`Error::Usage`] if `path` is refused by the rules in the module docs, [`Error::Write`]
/// for I/O, or `fill`'s error.
pub fn write_with<T>(path: &Path, fill: impl FnOnce(&mut dyn Write) -> Result<T>) -> Result<T> {
    let target = resolve(path).map_err(|why| Error::Usage(format!("{}: {why}", path.display())))?;
    let write_err = |source| Error::Write {
        path: path.to_path_buf(),
        source,
    };
    let tmp = temporary(&target);
    let (file, created) = {
        let mut open = in_progress();
        let created = create_parents(&target).map_err(write_err)?;
        let file = match std::fs::File::create(&tmp) {
            Ok(f) => f,
            Err(e) => {
                remove_all(&created);
                return Err(write_err(e));
            }
        };
        open.extend(created.iter().cloned());
        open.push(tmp.clone());
        (file, created)
    };
    let forget = |open: &mut Vec<PathBuf>| {
        open.retain(|p| *p != tmp && !created.contains(p));
    };
    let result = (|| {
        if let Ok(old) = std::fs::metadata(&target) {
            file.set_permissions(old.permissions()).map_err(write_err)?;
        }
        let mut out = std::io::BufWriter::new(file);
        let value = fill(&mut out)?;
        out.flush().map_err(write_err)?;
        out.get_ref().sync_all().map_err(write_err)?;
        drop(out);
        let mut open = in_progress();
        std::fs::rename(&tmp, &target).map_err(write_err)?;
        forget(&mut open);
        Ok(value)
    })();
    if result.is_err() {
        let mut open = in_progress();
        let _ = std::fs::remove_file(&tmp);
        remove_all(&created);
        forget(&mut open);
    }
    result
}

/// Writes to `dest` through a streaming writer: a file whole or not at all
/// ([`write_with`]), or standard output.
///
/// # Errors
/// As [`write_with`]; [`Error::Write`] naming standard output for a failed write there.
pub fn write_to<T>(
    dest: &Destination,
    fill: impl FnOnce(&mut dyn Write) -> Result<T>,
) -> Result<T> {
    match dest {
        Destination::File(p) => write_with(p, fill),
        Destination::Stdout => {
            let mut out = std::io::BufWriter::new(std::io::stdout().lock());
            let value = fill(&mut out)?;
            out.flush().map_err(|source| Error::Write {
                path: PathBuf::from("standard output"),
                source,
            })?;
            Ok(value)
        }
    }
}

/// Writes `bytes` to `dest` whole or not at all.
///
/// # Errors
/// As [`write_to`].
pub fn write_bytes_to(dest: &Destination, bytes: &[u8]) -> Result<()> {
    let name = PathBuf::from(dest.to_string());
    write_to(dest, |out| {
        out.write_all(bytes)
            .map_err(|source| Error::Write { path: name, source })
    })
}

/// Writes `bytes` to `path` whole or not at all.
///
/// # Errors
/// As [`write_with`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_with(path, |out| {
        out.write_all(bytes).map_err(|source| Error::Write {
            path: path.to_path_buf(),
            source,
        })
    })
}

/// Writes `value` as pretty JSON (with a final newline) whole or not at all.
///
/// # Errors
/// As [`write_with`]; [`Error::Serialise`] if `value` cannot be serialised.
pub fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    write_atomic(path, json_text(path, value)?.as_bytes())
}

/// The text [`write_json`] writes to `path`: pretty JSON with a final newline.
///
/// # Errors
/// [`Error::Serialise`] naming `path` if `value` cannot be serialised.
pub fn json_text(path: &Path, value: &impl Serialize) -> Result<String> {
    let mut text = serde_json::to_string_pretty(value).map_err(|source| Error::Serialise {
        path: path.to_path_buf(),
        source,
    })?;
    text.push('\n');
    Ok(text)
}

/// Writes several outputs, each whole or not at all ([`write_bytes_to`]), at the same time:
/// a file's cost is mostly the wait for its data to reach the disk, and the waits overlap.
/// Every output is attempted; the first error in `outputs`' order is returned, and an
/// output that failed is absent while the others are whole.
///
/// # Errors
/// As [`write_bytes_to`], for the first output that failed.
pub fn write_files(outputs: &[(&Destination, &[u8])]) -> Result<()> {
    let results: Vec<Result<()>> = match outputs {
        [] => Vec::new(),
        [(dest, bytes)] => vec![write_bytes_to(dest, bytes)],
        [(first, bytes), rest @ ..] => std::thread::scope(|scope| {
            let others: Vec<_> = rest
                .iter()
                .map(|(dest, bytes)| scope.spawn(move || write_bytes_to(dest, bytes)))
                .collect();
            let mut results = vec![write_bytes_to(first, bytes)];
            results.extend(others.into_iter().map(|h| {
                h.join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
            }));
            results
        }),
    };
    results.into_iter().collect()
}

/// Writes a CSV file with a header and numeric rows, whole or not at all. Numbers use Rust's
/// shortest round-trip formatting, so the file reads back to the same `f64` values.
///
/// # Errors
/// As [`write_with`].
pub fn write_csv(path: &Path, header: &[&str], rows: &[Vec<f64>]) -> Result<()> {
    write_atomic(path, csv_text(header, rows).as_bytes())
}

/// The text of a CSV file: the header, then one line per row with Rust's shortest
/// round-trip formatting of every value (so the file reads back to the same `f64`s).
pub fn csv_text(header: &[&str], rows: &[Vec<f64>]) -> String {
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
    text
}

/// Copies every regular, non-hidden file of directory `from` into `to` (each written whole or
/// not at all); used by `merge` to carry over the files every shard writes identically.
///
/// # Errors
/// [`Error::Read`] naming the file or directory that cannot be read; as [`write_with`].
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

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("scenarios-output-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = scratch("failed");
        let path = dir.join("x.csv");
        let r: Result<()> = write_with(&path, |out| {
            out.write_all(b"half").map_err(|source| Error::Write {
                path: path.clone(),
                source,
            })?;
            Err(Error::Degenerate("stopped"))
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

    #[test]
    fn failed_write_removes_the_directories_it_created() {
        let dir = scratch("dirs");
        let path = dir.join("new").join("deeper").join("x.csv");
        let r: Result<()> = write_with(&path, |_| Err(Error::Degenerate("stopped")));
        assert!(r.is_err());
        assert!(!dir.join("new").exists(), "created directories must go");
        assert!(dir.exists(), "an existing directory must stay");
        write_atomic(&path, b"x").expect("write");
        assert_eq!(std::fs::read(&path).expect("read"), b"x");
        // Other tests write concurrently: only this test's paths must be gone.
        assert!(!in_progress().iter().any(|p| p.starts_with(&dir)));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn links_are_followed_and_special_files_refused() {
        let dir = scratch("links");
        let real = dir.join("real.csv");
        std::fs::write(&real, "old").expect("write");
        let link = dir.join("link.csv");
        std::os::unix::fs::symlink(&real, &link).expect("symlink");
        write_atomic(&link, b"new").expect("write through the link");
        assert!(
            std::fs::symlink_metadata(&link)
                .expect("link")
                .file_type()
                .is_symlink(),
            "the link must stay a link"
        );
        assert_eq!(std::fs::read(&real).expect("read"), b"new");
        // A FIFO made here stands for any non-regular file (the system's devices are never
        // written to by tests: a regression would replace them).
        let fifo = dir.join("fifo");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo");
        assert!(made.success());
        let e = write_atomic(&fifo, b"x").expect_err("a FIFO is refused");
        assert!(e.to_string().contains("a FIFO"), "{e}");
        assert!(
            std::os::unix::fs::FileTypeExt::is_fifo(
                &std::fs::symlink_metadata(&fifo).expect("fifo").file_type()
            ),
            "the FIFO must stay a FIFO"
        );
        let e = write_atomic(&dir, b"x").expect_err("a directory is refused");
        assert!(e.to_string().contains("a directory"), "{e}");
        let dangling = dir.join("dangling.csv");
        std::os::unix::fs::symlink(dir.join("missing"), &dangling).expect("symlink");
        let e = write_atomic(&dangling, b"x").expect_err("a dangling link is refused");
        assert!(e.to_string().contains("missing file"), "{e}");
        let e = write_atomic(&real.join("x.csv"), b"x").expect_err("a file as a directory");
        assert!(e.to_string().contains("not a directory"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn destination_refuses_an_input() {
        let dir = scratch("same");
        let input = dir.join("m.json");
        std::fs::write(&input, "{}").expect("write");
        let dotted = dir.join(".").join("m.json");
        let e = destination(&dotted, &[("--model", &input)]).expect_err("same file");
        assert!(e.to_string().contains("same file as --model"), "{e}");
        assert_eq!(
            destination(Path::new("-"), &[]).expect("stdout"),
            Destination::Stdout
        );
        let other = dir.join("o.json");
        assert_eq!(
            destination(&other, &[("--model", &input)]).expect("new file"),
            Destination::File(other)
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn several_outputs_are_each_whole_or_absent() {
        // Three outputs written at once, the middle one under a regular file (cannot be
        // created): the other two are whole, the failed one and every temporary are absent,
        // and the error names the failed one.
        let dir = scratch("several");
        let blocker = dir.join("plain");
        std::fs::write(&blocker, "x").expect("write");
        let a = Destination::File(dir.join("a.json"));
        let b = Destination::File(blocker.join("b.json"));
        let c = Destination::File(dir.join("c.json"));
        let e = write_files(&[(&a, b"first"), (&b, b"second"), (&c, b"third")])
            .expect_err("b cannot be written");
        assert!(e.to_string().contains("b.json"), "{e}");
        assert_eq!(std::fs::read(dir.join("a.json")).expect("a"), b"first");
        assert_eq!(std::fs::read(dir.join("c.json")).expect("c"), b"third");
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["a.json", "c.json", "plain"]);
        write_files(&[]).expect("nothing to write");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn two_outputs_may_not_share_a_destination() {
        let dir = scratch("shared");
        let input = dir.join("m.json");
        std::fs::write(&input, "{}").expect("write");
        let out = dir.join("o.json");
        let dotted = dir.join(".").join("o.json");
        let inputs = [("--model", input.as_path())];
        let e = destinations(
            ("--out", &out),
            [("--summary", Some(dotted.as_path()))],
            &inputs,
        )
        .expect_err("one file under two spellings");
        assert!(e.to_string().contains("--summary"), "{e}");
        assert!(e.to_string().contains("same destination as --out"), "{e}");
        let e = destinations(
            ("--out", Path::new("-")),
            [("--summary", Some(Path::new("-")))],
            &inputs,
        )
        .expect_err("standard output twice");
        assert!(e.to_string().contains("same destination"), "{e}");
        let e = destinations(
            ("--out", &out),
            [("--summary", Some(input.as_path()))],
            &inputs,
        )
        .expect_err("an input");
        assert!(e.to_string().contains("same file as --model"), "{e}");
        let other = dir.join("s.json");
        let (main, [side, absent]) = destinations(
            ("--out", &out),
            [("--summary", Some(other.as_path())), ("--log", None)],
            &inputs,
        )
        .expect("distinct outputs");
        assert_eq!(main, Destination::File(out));
        assert_eq!(side, Some(Destination::File(other)));
        assert_eq!(absent, None);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
