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
