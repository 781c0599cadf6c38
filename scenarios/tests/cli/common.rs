//! Helpers shared by the command-family modules: a scratch directory per test, running the
//! built `scenarios` binary, and reading what it wrote.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty scratch directory for the test `name` of the command family `family`
/// (`scenarios-<family>-<pid>-<name>` under the system temp dir, so families and concurrent
/// test runs never share one).
pub fn scratch(family: &str, name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("scenarios-{family}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch dir");
    dir
}

/// Runs the built `scenarios` binary in `dir` with `args`.
pub fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scenarios"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run scenarios")
}

/// Runs `args` in `dir` and asserts success (stderr in the message otherwise).
pub fn ok(dir: &Path, args: &[&str]) {
    let out = run(dir, args);
    assert!(
        out.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The text of `path` (panics naming the file).
pub fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// `summary.json` in `dir`, parsed.
pub fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&read(&dir.join("summary.json"))).expect("summary is JSON")
}

/// Asserts that directories `a` and `b` hold the same file names with the same bytes.
pub fn assert_same_files(a: &Path, b: &Path) {
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap_or_else(|e| panic!("{}: {e}", d.display()))
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let (na, nb) = (names(a), names(b));
    assert_eq!(
        na,
        nb,
        "{} and {} hold different files",
        a.display(),
        b.display()
    );
    for n in &na {
        let (x, y) = (std::fs::read(a.join(n)), std::fs::read(b.join(n)));
        assert!(
            x.expect("read") == y.expect("read"),
            "{n} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// Runs `args` in `dir`, expecting exit code 2 and one line on stderr; returns the line.
pub fn fails(dir: &Path, args: &[&str]) -> String {
    let out = run(dir, args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "{args:?}: not one line: {err}"
    );
    err
}
