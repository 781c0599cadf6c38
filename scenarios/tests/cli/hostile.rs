//! A table of hostile inputs — broken model files and CSVs, outputs that are inputs or
//! devices, bad arguments and shards — fed to every command through the built binary. Each
//! row must fail with its exit code and one line on stderr naming the culprit, write no
//! output file, and leave every input and a pre-existing output byte for byte as it was.

use std::collections::BTreeMap;
use std::path::Path;

use crate::common::{device_node, run, scratch};

/// The files every row starts from: a scalar random walk (TOML and JSON), a continuous
/// model, a good data CSV, a shard directory, and an existing output that must survive.
const BASE: &[(&str, &str)] = &[
    (
        "m.toml",
        "dt = 1\nF = [[1]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\nx0 = [0]\nP0 = [[1]]\n",
    ),
    (
        "m.json",
        r#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "x0": [0], "P0": [[1]]}"#,
    ),
    (
        "c.json",
        r#"{"A": [[-1]], "C": [[1]], "Qc": [[2]], "R": [[1]]}"#,
    ),
    ("z.csv", "t,z1\n0,1\n1,2\n2,3\n"),
    ("shard1/summary.json", "{\n"),
    ("est.csv", "precious output\n"),
    ("d.json", "precious model\n"),
];

/// How a row prepares its directory beyond [`BASE`] and its own files.
#[derive(Clone, Copy)]
enum Setup {
    None,
    /// `name` → `target` symbolic link.
    Symlink(&'static str, &'static str),
    /// `name` hard link to `target`.
    HardLink(&'static str, &'static str),
    /// A FIFO called `name`.
    Fifo(&'static str),
    /// An empty directory called `name`.
    Dir(&'static str),
    /// A character device `name` with major number 1 and the given minor (3: a copy of
    /// /dev/null, 7: of /dev/full), made here so the system's own are never at risk; where
    /// mknod is not permitted, a link to the system's, which such a user cannot replace.
    Device(&'static str, &'static str),
}

/// One hostile input: extra files, the arguments, the exit code and what the one line on
/// stderr must contain (the culprit).
struct Row {
    files: Vec<(&'static str, &'static [u8])>,
    setup: Setup,
    args: &'static [&'static str],
    code: i32,
    culprit: Vec<&'static str>,
}

fn row(
    files: &[(&'static str, &'static [u8])],
    args: &'static [&'static str],
    culprit: &[&'static str],
) -> Row {
    Row {
        files: files.to_vec(),
        setup: Setup::None,
        args,
        code: 2,
        culprit: culprit.to_vec(),
    }
}

fn with(setup: Setup, args: &'static [&'static str], culprit: &[&'static str]) -> Row {
    Row {
        setup,
        ..row(&[], args, culprit)
    }
}

/// A broken model file `name` (`bad.json` or `bad.toml`) with `text`, which the error names
/// besides `culprit`.
fn model(
    name: &'static str,
    text: &'static [u8],
    args: &'static [&'static str],
    culprit: &[&'static str],
) -> Row {
    let mut r = row(&[(name, text)], args, &[name]);
    r.culprit.extend(culprit);
    r
}

/// A broken JSON model `bad.json`, given to `args`.
fn json(args: &'static [&'static str], text: &'static [u8], culprit: &[&'static str]) -> Row {
    model("bad.json", text, args, culprit)
}

/// A broken TOML model `bad.toml`, given to `filter`.
fn toml(text: &'static [u8], culprit: &[&'static str]) -> Row {
    model("bad.toml", text, FILTER_TOML, culprit)
}

/// `filter` of model `bad.json` on the good data.
const FILTER_JSON: &[&str] = &[
    "filter", "--model", "bad.json", "--data", "z.csv", "--out", "est.csv",
];
/// `filter` of model `bad.toml` on the good data.
const FILTER_TOML: &[&str] = &[
    "filter", "--model", "bad.toml", "--data", "z.csv", "--out", "est.csv",
];
/// `filter` of the good model on data `bad.csv`.
const FILTER_CSV: &[&str] = &[
    "filter", "--model", "m.toml", "--data", "bad.csv", "--out", "est.csv",
];
/// `steady-state` of model `bad.json`.
const STEADY_JSON: &[&str] = &["steady-state", "--model", "bad.json", "--out", "ss.json"];
/// `discretize` of continuous model `bad.json` (ZOH, Δt = 0.5).
const DISC_JSON: &[&str] = &[
    "discretize",
    "--model",
    "bad.json",
    "--dt",
    "0.5",
    "--method",
    "zoh",
    "--out",
    "d.json",
];

fn rows() -> Vec<Row> {
    vec![
        // --- Model files: JSON.
        json(FILTER_JSON, b"{\"dt\": 1,", &["line 1"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[NaN]], "R": [[1]], "P0": [[1]]}"#, &["key Q[0][0]", "NaN is not a JSON number"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[Infinity]], "H": [[1]], "Q": [[1]], "R": [[1]], "P0": [[1]]}"#, &["key F[0][0]", "Infinity is not a JSON number"]),
        json(STEADY_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[-Infinity]], "P0": [[1]]}"#, &["key R[0][0]", "-Infinity is not a JSON number"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "P0": [[1]], "Z": 0}"#, &["unknown field `Z`"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [["1"]], "Q": [[1]], "R": [[1]], "P0": [[1]]}"#, &["key H[0][0]", "invalid type"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "P0": [[1]]} x"#, &["trailing characters"]),
        json(FILTER_JSON, b"", &["EOF while parsing"]),
        json(STEADY_JSON, b"[]", &["invalid length 0"]),
        json(STEADY_JSON, br#"{"dt": 1, "F": [[1e400]], "H": [[1]], "Q": [[1]], "R": [[1]]}"#, &["key F[0][0]", "number out of range"]),
        json(FILTER_JSON, br#"{"dt": 0, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "P0": [[1]]}"#, &["dt = 0"]),
        json(STEADY_JSON, br#"{"dt": -1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]]}"#, &["dt = -1"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "P0": [[1]]}"#, &["matrix R is missing"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]]}"#, &["matrix P0 is missing"]),
        json(STEADY_JSON, br#"{"dt": 1, "F": [[1, 0], [0]], "H": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": [[1]]}"#, &["matrix F: row 2 has 1 entries"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1, 0]], "Q": [[1]], "R": [[1]], "P0": [[1]]}"#, &["matrix H is 1×2, expected 1×1"]),
        json(STEADY_JSON, br#"{"dt": 1, "F": [[1, 0], [0, 1]], "H": [[1, 0]], "Q": [[1, 0.5], [0, 1]], "R": [[1]]}"#, &["Q", "not symmetric"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[-1]], "P0": [[1]]}"#, &["R", "not positive semidefinite"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "P0": [[-2]]}"#, &["P0", "not positive semidefinite"]),
        json(STEADY_JSON, br#"{"dt": 1, "F": [], "H": [[1]], "Q": [[1]], "R": [[1]]}"#, &["matrix F is empty"]),
        json(FILTER_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "x0": [0, 1], "P0": [[1]]}"#, &["vector x0 has 2 entries"]),
        json(STEADY_JSON, br#"{"dt": 1, "F": [[1]], "B": [[1]], "H": [[1]], "D": [[1, 2]], "Q": [[1]], "R": [[1]]}"#, &["matrix D is 1×2, expected 1×1"]),
        json(STEADY_JSON, br#"{"dt": 1, "F": [[1]], "H": [[1]], "Q": [[1]], "R": [[1]], "S": [[1, 1]]}"#, &["matrix S is 1×2, expected 1×1"]),
        json(STEADY_JSON, br#"{"dt": 1, "F": [[2]], "H": [[0]], "Q": [[1]], "R": [[1]]}"#, &["not detectable"]),
        // --- Model files: TOML, names and kinds.
        toml(b"dt = 1\nF = [[1,,]]\n", &["invalid TOML model at line 2"]),
        toml(b"dt = 1\nF = [[1]]\nH = [[1]]\nQ = [[nan]]\nR = [[1]]\nP0 = [[1]]\n", &["matrix Q has NaN at row 1, column 1"]),
        toml(b"dt = 1\nF = [[inf]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\nP0 = [[1]]\n", &["matrix F has inf"]),
        toml(b"dt = 1\nF = [[1]]\nH = [[1]]\nQ = [[1]]\nR = [[1]]\nP0 = [[1]]\nPO = 1\n", &["unknown field `PO`", "line 7"]),
        toml(b"\xff\xfe\x00garbage", &["cannot read", "UTF-8"]),
        row(
            &[("bad.yaml", b"dt: 1\n")],
            &["filter", "--model", "bad.yaml", "--data", "z.csv", "--out", "est.csv"],
            &["bad.yaml", ".json or .toml"],
        ),
        row(
            &[],
            &["filter", "--model", "missing.json", "--data", "z.csv", "--out", "est.csv"],
            &["missing.json", "cannot read"],
        ),
        with(
            Setup::Dir("model.json"),
            &["steady-state", "--model", "model.json", "--out", "ss.json"],
            &["model.json", "cannot read"],
        ),
        // --- Continuous models and discretize.
        json(DISC_JSON, br#"{"A": [[0, 1]], "C": [[1, 0]]}"#, &["matrix A is 1×2, expected 1×1"]),
        json(DISC_JSON, br#"{"A": [[-1, 0], [0, -1]], "C": [[1, 0]], "Qc": [[1, 2], [2, 1]]}"#, &["matrix Qc", "positive semi-definite"]),
        json(DISC_JSON, br#"{"A": [[-1]], "C": [[1]], "G": [[1], [1]]}"#, &["matrix G is 2×1, expected 1×1"]),
        json(&["discretize", "--model", "bad.json", "--dt", "0.5", "--method", "tustin", "--out", "d.json"], br#"{"A": [[4]], "C": [[1]]}"#, &["singular"]),
        json(&["discretize", "--model", "bad.json", "--dt", "1", "--method", "zoh", "--out", "d.json"], br#"{"A": [[1000]], "C": [[1]]}"#, &["--dt 1", "too large for this A"]),
        json(&["discretize", "--model", "bad.json", "--dt", "1", "--method", "euler", "--out", "d.json"], br#"{"A": [[1000]], "C": [[1]], "Qc": [[1]]}"#, &["--dt 1", "too large for this A", "Van Loan"]),
        // --- A filter that diverges on the data: F11 = 1e10 unmeasured overflows by row 16.
        row(
            &[
                (
                    "bad.json",
                    br#"{"dt": 1, "F": [[1e10, 0], [0, 0.5]], "H": [[0, 1]], "Q": [[1, 0], [0, 1]], "R": [[1]], "P0": [[1, 0], [0, 1]]}"#,
                ),
                (
                    "long.csv",
                    b"t,z1\n0,1\n1,1\n2,1\n3,1\n4,1\n5,1\n6,1\n7,1\n8,1\n9,1\n10,1\n11,1\n12,1\n13,1\n14,1\n15,1\n16,1\n17,1\n18,1\n19,1\n",
                ),
            ],
            &["filter", "--model", "bad.json", "--data", "long.csv", "--out", "est.csv", "--form", "sqrt"],
            &["long.csv: line ", "the filter diverged"],
        ),
        // --- Data CSVs.
        row(&[("bad.csv", b"t,y1\n0,1\n")], FILTER_CSV, &["bad.csv", "line 1, column 2", "expected `z1`"]),
        row(&[("bad.csv", b"")], FILTER_CSV, &["bad.csv", "line 1: empty file"]),
        row(&[("bad.csv", b"\xEF\xBB\xBF")], FILTER_CSV, &["bad.csv", "line 1: empty file"]),
        row(&[("bad.csv", b"t,z1")], FILTER_CSV, &["bad.csv", "line 1: the last line has no final newline"]),
        row(&[("bad.csv", b"t,z1\n0,1\n1,5.")], FILTER_CSV, &["bad.csv", "line 3: the last line has no final newline"]),
        row(&[("bad.csv", b"t,z1\n0,1\n1,2.O\n")], FILTER_CSV, &["bad.csv", "line 3, column 2 (z1): `2.O` is not a number"]),
        row(&[("bad.csv", b"t,z1\n0,1\n1,-inf\n")], FILTER_CSV, &["bad.csv", "line 3, column 2 (z1): `-inf` is not finite"]),
        row(&[("bad.csv", b"t,z1\n1,1\n0,2\n")], FILTER_CSV, &["bad.csv", "line 3, column 1 (t)", "must not decrease"]),
        row(&[("bad.csv", b"t,z1\nNaN,1\n")], FILTER_CSV, &["bad.csv", "line 2, column 1 (t): missing value"]),
        row(&[("bad.csv", b"t,z1\n0\n")], FILTER_CSV, &["bad.csv", "line 2, column 2 (z1): missing field"]),
        row(&[("bad.csv", b"t,z1\n0,1,2\n")], FILTER_CSV, &["bad.csv", "line 2, column 3: extra field"]),
        row(&[("bad.csv", b"t,z1\n0,\"1\n1,2\n")], FILTER_CSV, &["bad.csv", "line 2, column 2 (z1): unbalanced quote"]),
        row(&[("bad.csv", b"t,z1,z2\n0,1,2\n")], FILTER_CSV, &["bad.csv", "line 1", "2 measurement columns", "m = 1"]),
        row(&[("bad.csv", b"t,z1,u1\n0,1,2\n")], FILTER_CSV, &["bad.csv", "line 1", "control columns", "p = 0"]),
        row(&[("bad.csv", b"t,z1\n0,\xff\n")], FILTER_CSV, &["bad.csv", "line 2, column 2 (z1): not UTF-8"]),
        row(&[("bad.csv", b"t,z1\n0,1\n1,\"2\"x\"\n")], FILTER_CSV, &["bad.csv", "line 3, column 2 (z1)", "is not a number"]),
        row(
            &[],
            &["filter", "--model", "m.toml", "--data", "nope.csv", "--out", "est.csv"],
            &["nope.csv", "cannot read"],
        ),
        with(
            Setup::Dir("dir.csv"),
            &["filter", "--model", "m.toml", "--data", "dir.csv", "--out", "est.csv", "--smooth"],
            &["dir.csv", "cannot read"],
        ),
        // --- Output paths.
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "z.csv"], &["--out z.csv", "same file as --data z.csv"]),
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "./z.csv", "--smooth"], &["--out ./z.csv", "same file as --data z.csv"]),
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "m.toml"], &["--out m.toml", "same file as --model m.toml"]),
        row(&[], &["steady-state", "--model", "m.json", "--out", "m.json"], &["--out m.json", "same file as --model m.json"]),
        row(
            &[],
            &["discretize", "--model", "c.json", "--dt", "0.1", "--method", "zoh", "--out", "./c.json"],
            &["--out ./c.json", "same file as --model c.json"],
        ),
        with(
            Setup::Symlink("link.csv", "z.csv"),
            &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "link.csv"],
            &["--out link.csv", "same file as --data z.csv"],
        ),
        with(
            Setup::HardLink("hard.csv", "z.csv"),
            &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "hard.csv"],
            &["--out hard.csv", "same file as --data z.csv"],
        ),
        with(
            Setup::Device("null", "3"),
            &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "null"],
            &["--out null", "character device"],
        ),
        with(
            Setup::Device("full", "7"),
            &["steady-state", "--model", "m.toml", "--out", "full"],
            &["--out full", "character device"],
        ),
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "."], &["--out .", "a directory"]),
        with(
            Setup::Symlink("dangling.csv", "nowhere/x.csv"),
            &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "dangling.csv"],
            &["--out dangling.csv", "symbolic link to a missing file"],
        ),
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "z.csv/est.csv"], &["--out z.csv/est.csv", "not a directory"]),
        with(
            Setup::Fifo("pipe.csv"),
            &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "pipe.csv"],
            &["--out pipe.csv", "a FIFO"],
        ),
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", ""], &["--out", "a value is required"]),
        Row {
            code: 1,
            ..row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "/proc/est.csv"], &["/proc/est.csv", "cannot write"])
        },
        row(&[], &["merge", "shard1", "--out", "shard1"], &["--out shard1", "is the shard directory shard1"]),
        row(&[], &["fueling", "--out", "-"], &["--out -", "fueling writes a directory"]),
        row(&[], &["merge", "shard1", "--out", "-"], &["--out -", "merge writes a directory"]),
        row(&[], &["finish", "shard1", "--out", "shard1"], &["--out shard1", "is the shard directory shard1"]),
        row(&[], &["finish", "shard1", "--out", "-"], &["--out -", "finish writes a directory"]),
        // --- Arguments.
        row(&[], &["discretize", "--model", "c.json", "--dt", "-1", "--method", "zoh", "--out", "d.json"], &["--dt -1", "must be finite and > 0"]),
        row(&[], &["discretize", "--model", "c.json", "--dt", "nan", "--method", "zoh", "--out", "d.json"], &["--dt nan", "must be finite and > 0"]),
        row(&[], &["discretize", "--model", "c.json", "--dt", "1s", "--method", "zoh", "--out", "d.json"], &["--dt 1s", "not a number"]),
        row(&[], &["discretize", "--model", "c.json", "--dt", "1\n2", "--method", "zoh", "--out", "d.json"], &["--dt 1 2", "not a number"]),
        row(&[], &["filter", "--model", "m.toml", "--data", "no\nsuch.csv", "--out", "est.csv"], &["no such.csv", "cannot read"]),
        row(
            &[],
            &["discretize", "--model", "c.json", "--dt", "0.1", "--method", "tustin-prewarp:-1", "--out", "d.json"],
            &["--method tustin-prewarp:-1", "pre-warp frequency W > 0"],
        ),
        row(&[], &["discretize", "--model", "c.json", "--dt", "0.1", "--method", "rk4", "--out", "d.json"], &["--method rk4", "unknown method"]),
        row(
            &[],
            &["discretize", "--model", "c.json", "--dt", "0.1", "--method", "zoh", "--noise", "pink", "--out", "d.json"],
            &["--noise pink", "expected van-loan or intensity-over-dt"],
        ),
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "est.csv", "--form", "qr"], &["--form qr", "expected joseph, standard or sqrt"]),
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv", "--out", "est.csv", "--smoothe"], &["unknown argument --smoothe", "did you mean --smooth"]),
        row(&[], &["filter", "--model", "m.toml", "--data", "z.csv"], &["--out: required but not given"]),
        row(&[], &["steady-state", "--model", "m.toml", "--out", "ss.json", "extra"], &["unknown argument extra"]),
        row(&[], &["boom", "--seed", "-5", "--out", "r"], &["--seed -5", "expected a whole number"]),
        row(&[], &["uav", "--runs", "0", "--out", "r"], &["--runs 0", "must be at least 1"]),
        row(&[], &["fueling", "--threads", "-2", "--out", "r"], &["--threads -2", "expected a whole number"]),
        row(&[], &["fuel"], &["unknown command fuel", "did you mean fueling"]),
        // --- Shards.
        row(&[], &["fueling", "--shard", "5/4", "--out", "r"], &["--shard 5/4: K must be between 1 and N"]),
        row(&[], &["uav", "--shard", "0/4", "--out", "r"], &["--shard 0/4: K must be between 1 and N"]),
        row(
            &[],
            &["boom", "--shard", "18446744073709551615/18446744073709551615", "--out", "r"],
            &["--shard 18446744073709551615/18446744073709551615: N must be between 1 and 1000000"],
        ),
        row(&[], &["all", "--shard", "1/0", "--out", "r"], &["--shard 1/0: N must be between 1 and 1000000"]),
        row(&[], &["fueling", "--shard", "-1/2", "--out", "r"], &["--shard -1/2: K must be a whole number"]),
        row(&[], &["fueling", "--shard", "1/2/3", "--out", "r"], &["--shard 1/2/3: N must be a whole number"]),
        row(&[], &["fueling", "--shard", "half", "--out", "r"], &["--shard half: expected K/N"]),
        row(&[], &["merge", "shard1", "--out", "merged"], &["shard1/summary.json"]),
        with(Setup::Dir("shard2"), &["merge", "shard2", "--out", "merged"], &["shard2/summary.json", "cannot read"]),
        row(&[], &["merge", "missing-shard", "--out", "merged"], &["missing-shard/summary.json", "cannot read"]),
        row(&[], &["finish", "missing-shard", "--out", "f"], &["missing-shard/summary.json", "cannot read"]),
    ]
}

/// Every regular file under `dir` (following links) with its bytes; directories and other
/// kinds by name alone.
fn snapshot(dir: &Path) -> BTreeMap<String, Option<Vec<u8>>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).expect("list") {
            let e = e.expect("entry");
            let path = e.path();
            let name = path
                .strip_prefix(dir)
                .expect("inside")
                .to_string_lossy()
                .into_owned();
            let kind = e.file_type().expect("type");
            if kind.is_dir() {
                todo.push(path);
                out.insert(name, None);
            } else if kind.is_file() || kind.is_symlink() {
                out.insert(name, std::fs::read(&path).ok());
            } else {
                out.insert(name, None);
            }
        }
    }
    out
}

fn prepare(dir: &Path, r: &Row) {
    for (name, text) in BASE {
        let p = dir.join(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).expect("dir");
        }
        std::fs::write(p, text).expect("base file");
    }
    for (name, bytes) in &r.files {
        std::fs::write(dir.join(name), bytes).expect("row file");
    }
    match r.setup {
        Setup::None => {}
        Setup::Symlink(name, target) => {
            std::os::unix::fs::symlink(target, dir.join(name)).expect("symlink");
        }
        Setup::HardLink(name, target) => {
            std::fs::hard_link(dir.join(target), dir.join(name)).expect("hard link");
        }
        Setup::Fifo(name) => {
            let ok = std::process::Command::new("mkfifo")
                .arg(dir.join(name))
                .status()
                .expect("mkfifo")
                .success();
            assert!(ok, "mkfifo");
        }
        Setup::Dir(name) => std::fs::create_dir(dir.join(name)).expect("dir"),
        Setup::Device(name, minor) => device_node(&dir.join(name), minor),
    }
}

#[test]
fn hostile_inputs_fail_cleanly_and_touch_nothing() {
    let rows = rows();
    assert!(rows.len() >= 60, "the table has {} rows", rows.len());
    let mut failures = Vec::new();
    for (i, r) in rows.iter().enumerate() {
        let dir = scratch("hostile", &i.to_string());
        prepare(&dir, r);
        let before = snapshot(&dir);
        let out = run(&dir, r.args);
        let err = String::from_utf8_lossy(&out.stderr);
        let mut wrong = Vec::new();
        if out.status.code() != Some(r.code) {
            wrong.push(format!("exit {:?}, expected {}", out.status.code(), r.code));
        }
        if err.lines().count() != 1 || !err.starts_with("scenarios: ") {
            wrong.push("stderr is not one `scenarios: …` line".into());
        }
        for c in &r.culprit {
            if !err.contains(c) {
                wrong.push(format!("`{c}` not named"));
            }
        }
        if !out.stdout.is_empty() {
            wrong.push("wrote to stdout".into());
        }
        let after = snapshot(&dir);
        if after != before {
            let changed: Vec<_> = after
                .iter()
                .filter(|(k, v)| before.get(*k) != Some(v))
                .map(|(k, _)| k.clone())
                .chain(before.keys().filter(|k| !after.contains_key(*k)).cloned())
                .collect();
            wrong.push(format!("files created, changed or removed: {changed:?}"));
        }
        if !wrong.is_empty() {
            failures.push(format!(
                "row {i} {:?}: {} — stderr: {err}",
                r.args,
                wrong.join("; ")
            ));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
