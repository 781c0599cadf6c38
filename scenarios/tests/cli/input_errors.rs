//! Input errors of `filter`, `discretize`, `steady-state` and the shard options, driven through
//! the built binary: each names the file, line, matrix, key path or argument at fault, on one
//! line, and leaves nothing behind; and a property test that feeds arbitrary bytes to the
//! model and CSV parsers (in process) and to `filter`.
#![allow(non_snake_case)]

use std::path::Path;

use nalgebra::DMatrix;
use proptest::prelude::*;

use crate::common::*;

#[test]
fn csv_errors_name_file_line_and_column() {
    let dir = with_model("ud", "csverr", WALK_JSON);
    let filter = argv("filter --model m.json --data z.csv --out est.csv");
    for (csv, expect) in [
        (
            "t,z1\n0,1\n1,x2\n",
            &["z.csv: line 3, column 2 (z1): `x2` is not a number"][..],
        ),
        (
            "t,z1\n0,1\n1\n",
            &["z.csv: line 3, column 2 (z1): missing field"],
        ),
        (
            "t,z1\n0,1\n1,2,3\n",
            &["z.csv: line 3, column 3: extra field"],
        ),
        (
            "t,z1\n1,1\n0,2\n",
            &["z.csv: line 3, column 1 (t)", "must not decrease"],
        ),
        ("t,y1\n", &["z.csv: line 1, column 2", "expected `z1`"]),
        (
            "t,z1,z2\n0,1,2\n",
            &["z.csv: line 1", "2 measurement columns", "m = 1"],
        ),
        (
            "t,z1,u1\n0,1,2\n",
            &["z.csv: line 1", "control columns", "p = 0"],
        ),
    ] {
        write(&dir, "z.csv", csv);
        refused(&dir, &filter, expect, 2);
    }
    // An error far into the file, after thousands of estimates were streamed out: the
    // output file must still not appear (whole or nothing).
    let mut csv = String::from("t,z1\n");
    for k in 0..5000 {
        csv.push_str(&format!("{k},1\n"));
    }
    csv.push_str("5000,1e999\n");
    write(&dir, "z.csv", &csv);
    refused(
        &dir,
        &filter,
        &["z.csv: line 5002, column 2 (z1): `1e999` is not finite"],
        2,
    );
    // A data file that does not exist.
    std::fs::remove_file(dir.join("z.csv")).expect("remove");
    refused(&dir, &filter, &["z.csv", "cannot read"], 1);
}

#[test]
fn model_errors_name_matrix_and_rule() {
    let dir = scratch("ud", "modelerr");
    write(&dir, "z.csv", "t,z1\n0,1\n");
    let inputs = 2;
    let filter = argv("filter --model m.toml --data z.csv --out est.csv");
    let base = "dt = 1\nF = [[1, 0], [0, 1]]\nH = [[1, 0]]\nQ = [[1, 0], [0, 1]]\nR = [[1]]\nP0 = [[1, 0], [0, 1]]\n";
    // Each row: a replacement in the valid model, what the one-line refusal must say.
    for (from, to, expect) in [
        // Shape.
        (
            "H = [[1, 0]]",
            "H = [[1, 0, 0]]",
            &["m.toml", "matrix H is 1×3, expected 1×2", "shape"][..],
        ),
        (
            "R = [[1]]",
            "R = [[1], [2]]",
            &["matrix R is 2×1, expected 1×1", "shape"],
        ),
        (
            "F = [[1, 0], [0, 1]]",
            "F = [[1, 0], [0]]",
            &["matrix F: row 2 has 1 entries", "shape"],
        ),
        // NaN.
        (
            "Q = [[1, 0], [0, 1]]",
            "Q = [[1, 0], [0, nan]]",
            &["matrix Q has NaN at row 2, column 2", "NaN"],
        ),
        // Not symmetric (checked by the engine, which names the matrix).
        (
            "Q = [[1, 0], [0, 1]]",
            "Q = [[1, 0.5], [0, 1]]",
            &["m.toml", "Q (2x2) is not symmetric"],
        ),
        (
            "P0 = [[1, 0], [0, 1]]",
            "P0 = [[1, 0.5], [0, 1]]",
            &["P0 (2x2) is not symmetric"],
        ),
        // Not PSD.
        (
            "R = [[1]]",
            "R = [[-1]]",
            &["m.toml", "R (1x1) is not positive semidefinite"],
        ),
        (
            "Q = [[1, 0], [0, 1]]",
            "Q = [[1, 2], [2, 1]]",
            &["Q (2x2) is not positive semidefinite"],
        ),
        // Syntax (with line and column), a missing P0.
        (
            "R = [[1]]",
            "R = [[1,,]]",
            &["m.toml", "invalid TOML model at line 5"],
        ),
        ("P0 = [[1, 0], [0, 1]]\n", "", &["matrix P0 is missing"]),
    ] {
        write(&dir, "m.toml", &base.replace(from, to));
        refused(&dir, &filter, expect, inputs);
    }
    // An unknown key, an unknown extension.
    write(&dir, "m.toml", &format!("{base}Rr = 1\n"));
    refused(&dir, &filter, &["unknown field `Rr`", "line 7"], inputs);
    write(&dir, "m.yaml", base);
    refused(
        &dir,
        &argv("filter --model m.yaml --data z.csv --out est.csv"),
        &["m.yaml", ".json or .toml"],
        3,
    );
    std::fs::remove_file(dir.join("m.yaml")).expect("remove");
    // JSON syntax errors carry line and column too.
    std::fs::remove_file(dir.join("m.toml")).expect("remove");
    write(&dir, "m.json", "{\"dt\": 1,\n \"F\": [[1, ]]}");
    refused(
        &dir,
        &argv("filter --model m.json --data z.csv --out est.csv"),
        &["m.json", "invalid JSON model", "line 2 column"],
        2,
    );
    // Continuous models: shape, NaN, Qc not symmetric / not PSD, a singular Tustin map.
    let disc = |m: &'static str| {
        argv_with(
            "discretize --model {} --dt 0.5 --method tustin --out d.json",
            &[m],
        )
    };
    let cont = |text: &str, expect: &[&str]| {
        write(&dir, "c.json", text);
        refused(&dir, &disc("c.json"), expect, 3);
    };
    cont(
        r#"{"A": [[0, 1]], "C": [[1, 0]]}"#,
        &["c.json", "matrix A is 1×2, expected 1×1", "shape"],
    );
    cont(
        r#"{"A": [[-1]], "C": [[1, 0]]}"#,
        &["matrix C is 1×2, expected 1×1"],
    );
    cont(
        r#"{"A": [[-1, 0], [0, -1]], "C": [[1, 0]], "Qc": [[1, 1], [0, 1]]}"#,
        &["c.json", "matrix Qc", "symmetric"],
    );
    cont(
        r#"{"A": [[-1, 0], [0, -1]], "C": [[1, 0]], "Qc": [[1, 2], [2, 1]]}"#,
        &["c.json", "matrix Qc", "positive semi-definite"],
    );
    cont(r#"{"A": [[4]], "C": [[1]]}"#, &["c.json", "singular"]);
    cont(
        r#"{"A": [[-1]], "C": [[1]], "G": [[1], [1]]}"#,
        &["c.json", "matrix G is 2×1, expected 1×1"],
    );
    // A bad --dt is a usage error (exit code 2).
    write(&dir, "c.json", r#"{"A": [[-1]], "C": [[1]]}"#);
    refused(
        &dir,
        &argv("discretize --model c.json --dt=-1 --method zoh --out d.json"),
        &["--dt -1"],
        3,
    );
}

/// A small valid model for the property tests (n = 2, m = 2, p = 1).
const PROP_MODEL: &str = r#"{"dt": 0.1, "F": [[1, 0.1], [0, 1]], "B": [[0], [0.1]],
  "H": [[1, 0], [0, 1]], "Q": [[0.01, 0], [0, 0.01]], "R": [[1, 0], [0, 1]],
  "P0": [[1, 0], [0, 1]]}"#;

proptest! {
    // Every outcome is Ok or a clean error; a panic fails the test.
    #[test]
    fn parsers_never_panic_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        use scenarios::userdata::{data, model_file};
        let text = String::from_utf8_lossy(&bytes);
        for name in ["m.json", "m.toml"] {
            let _ = model_file::parse_discrete(Path::new(name), &text);
            let _ = model_file::parse_continuous(Path::new(name), &text);
        }
        let _ = data::parse_data(Path::new("z.csv"), &bytes);
    }

    // Near-valid inputs reach deeper than random bytes: tokens of the formats' alphabets.
    #[test]
    fn parsers_never_panic_on_format_like_text(
        model in "[\\[\\]{}\",:= \\n0-9.eE+\\-a-zA-Z_]{0,200}",
        csv in "(t,z1(,z2)?(,u1)?\\n)?([0-9.eE+\\-,\" naNifINF]{0,12}\\n){0,12}",
    ) {
        use scenarios::userdata::{data, model_file};
        for name in ["m.json", "m.toml"] {
            let _ = model_file::parse_discrete(Path::new(name), &model);
            let _ = model_file::parse_continuous(Path::new(name), &model);
        }
        let _ = data::parse_data(Path::new("z.csv"), csv.as_bytes());
    }

    // Any well-shaped model written as JSON or TOML reads back to the same matrices.
    #[test]
    fn model_files_round_trip(
        (n, m, p) in (1usize..=5, 1usize..=3, 0usize..=2),
        seed in any::<u64>(),
        toml_format in any::<bool>(),
    ) {
        use scenarios::userdata::model_file::{parse_discrete, DiscreteFile};
        let mut state = seed | 1;
        let mut next = move || {
            // xorshift64: a seeded stream of values in [-10, 10) with up to 17 digits.
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0
        };
        let mut rows = |r: usize, c: usize| -> Vec<Vec<f64>> {
            (0..r).map(|_| (0..c).map(|_| next()).collect()).collect()
        };
        let file = DiscreteFile {
            dt: 0.25,
            F: rows(n, n),
            B: (p > 0).then(|| rows(n, p)),
            H: rows(m, n),
            D: (p > 0).then(|| rows(m, p)),
            Q: rows(n, n),
            R: Some(rows(m, m)),
            S: Some(rows(n, m)),
            x0: Some(rows(1, n).remove(0)),
            P0: Some(rows(n, n)),
            channels: None,
        };
        let (name, text) = if toml_format {
            ("m.toml", toml::to_string(&file).expect("toml"))
        } else {
            ("m.json", serde_json::to_string(&file).expect("json"))
        };
        let parsed = parse_discrete(Path::new(name), &text).expect("a well-shaped model parses");
        let back = |m: &DMatrix<f64>| -> Vec<Vec<f64>> {
            m.row_iter().map(|r| r.iter().copied().collect()).collect()
        };
        prop_assert_eq!(back(&parsed.F), file.F.clone());
        prop_assert_eq!(back(&parsed.H), file.H.clone());
        prop_assert_eq!(Some(back(&parsed.R)), file.R.clone());
        prop_assert_eq!(parsed.S.as_ref().map(back), file.S.clone());
        prop_assert_eq!(parsed.P0.as_ref().map(back), file.P0.clone());
        prop_assert_eq!(parsed.x0.as_slice(), file.x0.as_deref().unwrap_or_default());
        prop_assert_eq!((parsed.p(), back(&parsed.D).concat()), (p, file.D.clone().unwrap_or_default().concat()));
    }

    // The whole `filter` command in process, on a valid model and arbitrary CSV rows
    // (numbers of any size, gaps, garbage): Ok, or an error that names the data file.
    #[test]
    fn filter_never_panics_on_arbitrary_rows(
        rows in proptest::collection::vec(
            (any::<f64>(), prop_oneof![Just(String::new()), "[0-9.eE+\\-na]{1,8}"], any::<f64>()),
            0..20,
        ),
    ) {
        let dir = std::env::temp_dir().join(format!("scenarios-ud-prop-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        std::fs::write(dir.join("m.json"), PROP_MODEL).expect("model");
        let mut csv = String::from("t,z1,z2,u1\n");
        for (k, (z1, z2, u)) in rows.iter().enumerate() {
            csv.push_str(&format!("{k},{z1:e},{z2},{u:e}\n"));
        }
        std::fs::write(dir.join("z.csv"), &csv).expect("csv");
        let args = scenarios::userdata::FilterArgs {
            model: dir.join("m.json"),
            data: dir.join("z.csv"),
            out: dir.join("est.csv"),
            form: scenarios::userdata::Form::Joseph,
            smooth: false,
            full_covariance: false,
            diagnostics: None,
            diagnostics_lags: 20,
            gate: None,
            rejected: None,
        };
        let _ = std::fs::remove_file(&args.out);
        match scenarios::userdata::filter(&args) {
            Ok(()) => prop_assert!(args.out.exists()),
            Err(e) => {
                prop_assert!(e.to_string().contains("z.csv"), "{}", e);
                prop_assert_eq!(e.exit_code(), 2);
                prop_assert!(!args.out.exists());
            }
        }
    }
}

/// Runs `args` expecting exit code 2, nothing on stdout and exactly `expect` as stderr.
fn usage_error(dir: &Path, args: &[&str], expect: &str) {
    let out = run(dir, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(out.stdout.is_empty(), "{args:?}");
    assert_eq!(err, format!("scenarios: {expect}\n"), "{args:?}");
}

#[test]
fn argument_errors_are_one_line_naming_the_argument() {
    let dir = scratch("ud", "args");
    write(&dir, "c.json", CONT_JSON);
    let disc = |dt: &'static str| {
        argv_with(
            "discretize --model c.json --dt {} --method zoh --out d.json",
            &[dt],
        )
    };
    usage_error(
        &dir,
        &argv("fueling --shard 5/4 --out r"),
        "--shard 5/4: K must be between 1 and N",
    );
    usage_error(
        &dir,
        &disc("-1"),
        "--dt -1: must be finite and > 0 (seconds)",
    );
    usage_error(&dir, &disc("0"), "--dt 0: must be finite and > 0 (seconds)");
    usage_error(
        &dir,
        &disc("1e400"),
        "--dt 1e400: must be finite and > 0 (seconds)",
    );
    usage_error(
        &dir,
        &disc("abc"),
        "--dt abc: not a number (seconds, finite and > 0)",
    );
    usage_error(
        &dir,
        &argv("fueling --runs -3 --out r"),
        "--runs -3: expected a whole number",
    );
    usage_error(
        &dir,
        &argv("fueling --threads 0 --out r"),
        "--threads 0: must be at least 1",
    );
    usage_error(
        &dir,
        &argv("filter --model m.json --data z.csv --out e.csv --form bad"),
        "--form bad: expected joseph, standard or sqrt",
    );
    usage_error(
        &dir,
        &["filter", "--frm", "sqrt"],
        "unknown argument --frm (did you mean --form?)",
    );
    usage_error(
        &dir,
        &["filter", "--model", "m.json"],
        "--data and --out: required but not given",
    );
    usage_error(
        &dir,
        &["filtr"],
        "unknown command filtr: expected fueling, uav, boom, flightpath, all, merge, filter, discretize, \
         steady-state or fit (did you mean fit or filter?)",
    );
    usage_error(
        &dir,
        &[],
        "a command is required: fueling, uav, boom, flightpath, all, merge, filter, discretize, \
         steady-state or fit (see scenarios --help)",
    );
    usage_error(
        &dir,
        &["uav", "--out", "-"],
        "--out -: uav writes a directory of files; standard output (-) is only for filter, \
         discretize and steady-state",
    );
    // Help still goes to stdout with exit code 0.
    let out = run(&dir, &["filter", "--help"]);
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("--model"));
    assert_eq!(
        std::fs::read_dir(&dir).expect("dir").count(),
        1,
        "nothing written"
    );
}

#[test]
fn shard_out_of_range_is_refused() {
    let dir = scratch("ud", "shard");
    for (shard, why) in [
        (
            "18446744073709551615/18446744073709551615",
            "N must be between 1 and 1000000",
        ),
        ("1/18446744073709551616", "N must be between 1 and 1000000"),
        ("1/1000001", "N must be between 1 and 1000000"),
        ("18446744073709551616/2", "K must be between 1 and N"),
        ("0/4", "K must be between 1 and N"),
        ("1/0", "N must be between 1 and 1000000"),
        ("-1/2", "K must be a whole number"),
        ("1/two", "N must be a whole number"),
        ("3", "expected K/N, slice K of N (for example 2/8)"),
    ] {
        usage_error(
            &dir,
            &argv_with("fueling --shard {} --out r", &[shard]),
            &format!("--shard {shard}: {why}"),
        );
    }
    assert!(!dir.join("r").exists(), "no output directory");
}

#[test]
fn json_model_errors_name_the_key_path_and_a_bom_is_accepted() {
    let dir = scratch("ud", "json");
    write(&dir, "z.csv", "t,z1\n0,1\n1,2\n");
    let filter = argv("filter --model m.json --data z.csv --out est.csv");
    // As Python's json.dump writes non-finite floats.
    for (bad, key, token) in [
        (r#""Q": [[NaN]]"#, "key Q[0][0]", "NaN"),
        (r#""R": [[Infinity]]"#, "key R[0][0]", "Infinity"),
        (r#""P0": [[-Infinity]]"#, "key P0[0][0]", "-Infinity"),
    ] {
        let name = bad.split('"').nth(1).expect("key");
        let text = WALK_JSON.replace(&format!(r#""{name}": [[1]]"#), bad);
        assert_ne!(text, WALK_JSON, "{bad}");
        write(&dir, "m.json", &text);
        refused(
            &dir,
            &filter,
            &[
                "m.json: invalid JSON model",
                key,
                &format!("{token} is not a JSON number"),
            ],
            2,
        );
    }
    write(
        &dir,
        "m.json",
        &WALK_JSON.replace(r#""H": [[1]]"#, r#""H": [["1"]]"#),
    );
    refused(&dir, &filter, &["key H[0][0]", "invalid type: string"], 2);
    // A byte-order mark is accepted, and gives the same estimates.
    write(&dir, "m.json", WALK_JSON);
    ok(&dir, &filter);
    let plain = std::fs::read(dir.join("est.csv")).expect("est");
    std::fs::remove_file(dir.join("est.csv")).expect("remove");
    write(&dir, "m.json", &format!("\u{feff}{WALK_JSON}"));
    ok(&dir, &filter);
    assert_eq!(std::fs::read(dir.join("est.csv")).expect("est"), plain);
}

#[test]
fn discretize_computes_only_what_is_asked() {
    // ẋ = 1000 x: e^{1000·dt} overflows f64 for dt = 1 (e^{709.8} is the largest f64).
    let dir = scratch("ud", "disc-only");
    write(&dir, "c.json", r#"{"A": [[1000]], "C": [[1]]}"#);
    let disc = |dt: &'static str, method: &'static str| {
        argv_with(
            "discretize --model c.json --dt {} --method {} --out d.json",
            &[dt, method],
        )
    };
    // Forward Euler with no noise needs no exponential: F = 1 + A·dt, Q = 0.
    ok(&dir, &disc("1", "euler"));
    let d = read_json(&dir.join("d.json"));
    assert_eq!(mat(&d["F"]), vec![vec![1001.0]]);
    assert_eq!(mat(&d["Q"]), vec![vec![0.0]]);
    std::fs::remove_file(dir.join("d.json")).expect("remove");
    // ZOH does need e^{A·dt}: the message names --dt as the culprit.
    refused(
        &dir,
        &disc("1", "zoh"),
        &[
            "--dt 1: dt = 1 is too large for this A",
            "overflows",
            "c.json",
        ],
        1,
    );
    // A step 1000 times smaller is fine: F = e^{1}.
    ok(&dir, &disc("0.001", "zoh"));
    let f = mat(&read_json(&dir.join("d.json"))["F"])[0][0];
    assert!((f - 1f64.exp()).abs() < 4.0 * f64::EPSILON * f, "{f}");
}

#[test]
fn csv_truncated_last_line_and_unbalanced_quote_are_one_line_errors() {
    let dir = scratch("ud", "csv-trunc");
    write(&dir, "m.toml", WALK_TOML);
    let filter = argv("filter --model m.toml --data z.csv --out est.csv");
    // `4,5.25` cut to `4,5.` would read as 5: a last line with no newline is refused.
    for (csv, expect) in [
        (
            "t,z1\n0,1\n1,5.",
            "z.csv: line 3: the last line has no final newline",
        ),
        ("t,z1", "z.csv: line 1: the last line has no final newline"),
        (
            "t,z1\n0,\"1\n1,2\n2,3\n",
            "z.csv: line 2, column 2 (z1): unbalanced quote",
        ),
    ] {
        write(&dir, "z.csv", csv);
        refused(&dir, &filter, &[expect], 2);
    }
    // CRLF endings and a final blank line are whole files.
    write(&dir, "z.csv", "t,z1\r\n0,1\r\n1,5\r\n\r\n");
    ok(&dir, &filter);
}

#[test]
fn diverging_filter_is_refused_naming_the_row() {
    // x1 is unmeasured with F11 = 1e10: its variance grows by 1e20 a step from P0 = 1, so it
    // overflows f64 (1.8e308) around step 16 and every estimate after it, even the measured,
    // stable x2 (F22 = 0.5), would be inf or NaN. The run must stop at a row in that range,
    // name it, and write nothing.
    let dir = with_model(
        "ud",
        "diverge",
        r#"{"dt": 1, "F": [[1e10, 0], [0, 0.5]], "H": [[0, 1]], "Q": [[1, 0], [0, 1]],
            "R": [[1]], "P0": [[1, 0], [0, 1]]}"#,
    );
    let mut csv = String::from("t,z1\n");
    for k in 0..40 {
        csv.push_str(&format!("{k},{}\n", 0.5f64.powi(k)));
    }
    write(&dir, "z.csv", &csv);
    for extra in [
        &["--form", "joseph"][..],
        &["--form", "standard"],
        &["--form", "sqrt"],
        &["--smooth"],
    ] {
        let mut args = argv("filter --model m.json --data z.csv --out est.csv");
        args.extend_from_slice(extra);
        let out = run(&dir, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        let line: u64 = err
            .split("z.csv: line ")
            .nth(1)
            .and_then(|rest| rest.split(':').next())
            .and_then(|l| l.parse().ok())
            .unwrap_or_else(|| panic!("{extra:?}: no data line named: {err}"));
        // Data row k (from 0) is on line k + 2 and ends with prediction k + 1; P11 after j
        // predictions is about (1e10)^(2j) = 1e20^j: 1e300 after 15, past f64 after 16
        // (row 15, line 17). A check that flags an overflow a little before the infinity
        // may name a slightly earlier row.
        assert!((14..=20).contains(&line), "{extra:?}: line {line}: {err}");
        assert_eq!(
            std::fs::read_dir(&dir).expect("dir").count(),
            2,
            "{extra:?}: no output file"
        );
    }
}
