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

/// A command line written as on a shell (words split at white space; no quoting), as the
/// argument list the helpers below take: `ok(&dir, &argv("merge a b --out m"))`.
pub fn argv(line: &'static str) -> Vec<&'static str> {
    line.split_whitespace().collect()
}

/// [`argv`] with each `{}` word replaced by the next of `values`, in order:
/// `argv_with("filter --model m.toml --form {}", &[form])`.
pub fn argv_with<'a>(line: &'static str, values: &[&'a str]) -> Vec<&'a str> {
    let mut values = values.iter();
    let words: Vec<&'a str> = line
        .split_whitespace()
        .map(|w| {
            if w == "{}" {
                values.next().copied().expect("a value for every {}")
            } else {
                w
            }
        })
        .collect();
    assert!(values.next().is_none(), "a {{}} for every value");
    words
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

/// The closing stage between the shards `s1`, `s2` in `dir` and their merge: a merge without
/// it is refused naming `finish.toml` and the command to run, and writes nothing; then
/// `finish s1 s2 … --out fin` (with `finish_args`) and `merge s1 s2 fin --out merged`.
pub fn finish_then_merge(dir: &Path, finish_args: &[&str]) {
    let err = fails(dir, &argv("merge s1 s2 --out merged"));
    assert!(
        err.contains("finish.toml") && err.contains("scenarios finish"),
        "{err}"
    );
    assert!(
        !dir.join("merged").exists(),
        "a failed merge writes nothing"
    );
    let mut finish = argv("finish s1 s2");
    finish.extend_from_slice(finish_args);
    finish.extend(["--out", "fin"]);
    ok(dir, &finish);
    ok(dir, &argv("merge s1 s2 fin --out merged"));
}

pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write input");
    p
}

/// A fresh scratch directory (as [`scratch`]) holding the model file `m.json` with `model`.
pub fn with_model(family: &str, name: &str, model: &str) -> PathBuf {
    let dir = scratch(family, name);
    write(&dir, "m.json", model);
    dir
}

/// Runs a command that must fail with exit code 2 and exactly one line on stderr containing
/// every string of `expect`, leaving nothing in `dir` but the inputs (`inputs` files).
pub fn refused(dir: &Path, args: &[&str], expect: &[&str], inputs: usize) {
    let out = run(dir, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "one line on stderr: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: `{e}` not in: {err}");
    }
    let left = std::fs::read_dir(dir).map(|d| d.count()).unwrap_or(0);
    assert_eq!(
        left, inputs,
        "a failed run must leave no output or temporary file"
    );
}

/// Header and numeric rows of a CSV written by the program.
pub fn read_csv(path: &Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).expect("read output");
    let mut lines = text.lines();
    let header = lines.next().expect("header").to_string();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().expect("number"))
                .collect()
        })
        .collect();
    (header, rows)
}

pub fn close(a: f64, b: f64, tol: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

/// Reads a JSON file written by the program.
pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("read")).expect("JSON")
}

pub fn mat(v: &serde_json::Value) -> Vec<Vec<f64>> {
    v.as_array()
        .expect("matrix")
        .iter()
        .map(|r| {
            r.as_array()
                .expect("row")
                .iter()
                .map(|x| x.as_f64().expect("number"))
                .collect()
        })
        .collect()
}

/// Every file in `dir` (following links) with its bytes, to show a failed run touched none.
pub fn snapshot(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .expect("list dir")
        .map(|e| {
            let e = e.expect("entry");
            let bytes = std::fs::read(e.path()).unwrap_or_default();
            (e.file_name().to_string_lossy().into_owned(), bytes)
        })
        .collect()
}

/// Makes `path` a character device like `/dev/null` (`minor` "3") or `/dev/full` ("7") —
/// a node made here, never the system's own, so a regression that replaced it cannot break
/// the machine. Without the right to mknod, a link to the real one, which such a user cannot
/// replace anyway.
pub fn device_node(path: &Path, minor: &str) {
    let made = Command::new("mknod")
        .arg(path)
        .args(["c", "1", minor])
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !made {
        let real = if minor == "7" {
            "/dev/full"
        } else {
            "/dev/null"
        };
        std::os::unix::fs::symlink(real, path).expect("link");
    }
}

/// A scalar random walk with a prior, and a discrete JSON and a continuous model beside it.
pub const WALK_TOML: &str =
    "dt = 1\nF = [[1]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\nx0 = [0]\nP0 = [[1]]\n";
pub const WALK_JSON: &str =
    r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "x0": [0], "P0": [[1]]}"#;
pub const CONT_JSON: &str = r#"{"A": [[-1]], "C": [[1]], "Qc": [[2]], "R": [[1]]}"#;
