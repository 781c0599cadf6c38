//! `filter` on a time-stamped, multi-rate record with wild points, against an independent
//! reference: `tests/data/irregular/generate.py` simulates a constant-velocity target seen by
//! a GNSS fix (~1 Hz, x and y together) and a velocity sensor (~10 Hz), with jittered stamps,
//! a 5 s dropout, three same-instant row pairs and six planted wild points, and filters it
//! with scipy's `expm` (Van Loan) and a hand-written Joseph-form filter, gate and RTS
//! smoother. The numbers it wrote are stored; these tests run the program on the same files.

use std::path::{Path, PathBuf};

use crate::common::{argv_with, close, ok, read, read_csv, refused, scratch, write};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/irregular")
        .join(name)
}

/// Agreement of two estimates CSVs, entry by entry, to `1e-8·(1 + |value|)`: the reference
/// was checked against 50-digit arithmetic to 6e-11 absolute in x (which reaches 4·10⁴) and
/// the two exponentials differ by round-off only, so 1e-8 relative leaves three orders of
/// margin while catching any modelling difference (a wrong Δt moves x by metres). The `nis`
/// column reaches 3·10⁷ at a GNSS fix read as zero, hence the relative part.
fn assert_matches(got: &Path, want: &Path) {
    let (h1, a) = read_csv(got);
    let (h2, b) = read_csv(want);
    assert_eq!(h1, h2, "headers");
    assert_eq!(a.len(), b.len(), "row count");
    for (k, (ra, rb)) in a.iter().zip(&b).enumerate() {
        assert_eq!(ra.len(), rb.len());
        for (j, (x, y)) in ra.iter().zip(rb).enumerate() {
            assert!(
                close(*x, *y, 1e-8),
                "{}: data row {} column {}: {x} against the reference {y}",
                got.display(),
                k + 1,
                j + 1
            );
        }
    }
}

/// `(t, channel)` of the rows of a `t,channel,value[,nis]` CSV.
fn entries(path: &Path) -> Vec<(String, String)> {
    read(path)
        .lines()
        .skip(1)
        .map(|l| {
            let mut f = l.split(',');
            let t = f.next().expect("t").to_string();
            let c = f.next().expect("channel").to_string();
            (t, c)
        })
        .collect()
}

fn record(dir: &Path) -> (String, String) {
    let model = dir.join("model.json");
    let record = dir.join("record.csv");
    std::fs::copy(data("model.json"), &model).expect("copy model");
    std::fs::copy(data("record.csv"), &record).expect("copy record");
    (
        model.to_string_lossy().into_owned(),
        record.to_string_lossy().into_owned(),
    )
}

#[test]
fn an_irregular_record_is_filtered_at_its_own_time_stamps_in_every_form() {
    let dir = scratch("irregular", "forms");
    let (model, rec) = record(&dir);
    for form in ["joseph", "standard", "sqrt"] {
        let out = dir.join(format!("{form}.csv"));
        let out_s = out.to_string_lossy();
        ok(
            &dir,
            &argv_with(
                "filter --model {} --data {} --out {} --form {}",
                &[&model, &rec, &out_s, form],
            ),
        );
        assert_matches(&out, &data("filtered.csv"));
    }
}

#[test]
fn the_gate_rejects_exactly_the_planted_wild_points_and_the_smoother_sees_the_gated_pass() {
    let dir = scratch("irregular", "gated");
    let (model, rec) = record(&dir);
    let (out, rej, smooth) = (
        dir.join("gated.csv"),
        dir.join("rejected.csv"),
        dir.join("smoothed.csv"),
    );
    let (out_s, rej_s, smooth_s) = (
        out.to_string_lossy(),
        rej.to_string_lossy(),
        smooth.to_string_lossy(),
    );
    ok(
        &dir,
        &argv_with(
            "filter --model {} --data {} --out {} --gate 0.9999 --rejected {}",
            &[&model, &rec, &out_s, &rej_s],
        ),
    );
    assert_matches(&out, &data("gated.csv"));
    assert_eq!(entries(&rej), entries(&data("wild.csv")));
    // The statistic of each rejection, against the reference's.
    let nis = |p: &Path| -> Vec<f64> {
        read(p)
            .lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().expect("nis").parse().expect("number"))
            .collect()
    };
    for (a, b) in nis(&rej).iter().zip(nis(&data("rejected.csv"))) {
        assert!(close(*a, b, 1e-8), "rejection statistic {a} against {b}");
    }
    ok(
        &dir,
        &argv_with(
            "filter --model {} --data {} --out {} --gate 0.9999 --smooth",
            &[&model, &rec, &smooth_s],
        ),
    );
    assert_matches(&smooth, &data("smoothed_gated.csv"));
}

/// A discrete model's one `dt` is refused on a record with other spacings, naming the line,
/// and bad time stamps are one-line errors naming the line; nothing is written.
#[test]
fn bad_time_stamps_and_a_fixed_interval_on_an_irregular_record_are_refused() {
    let dir = scratch("irregular", "refused");
    let discrete = r#"{"dt": 0.1, "F": [[1, 0.1], [0, 1]], "H": [[1, 0]],
        "Q": [[0.001, 0], [0, 0.01]], "R": [[1]], "P0": [[1, 0], [0, 1]]}"#;
    write(&dir, "d.json", discrete);
    write(&dir, "z.csv", "t,z1\n0,1\n0.1,2\n0.2,3\n0.35,4\n");
    refused(
        &dir,
        &argv_with("filter --model d.json --data z.csv --out e.csv", &[]),
        &["z.csv: line 5", "dt = 0.1", "continuous form"],
        2,
    );
    refused(
        &dir,
        &argv_with(
            "fit --model d.json --data z.csv --free Q:scalar --out f.json",
            &[],
        ),
        &["z.csv: line 5", "dt = 0.1", "continuous form"],
        2,
    );
    // Regular to round-off (0.1 steps accumulated in binary) is accepted.
    let mut regular = String::from("t,z1\n");
    let mut t = 0.0_f64;
    for k in 0..50 {
        regular.push_str(&format!("{t},{k}\n"));
        t += 0.1;
    }
    write(&dir, "r.csv", &regular);
    ok(
        &dir,
        &argv_with("filter --model d.json --data r.csv --out e.csv", &[]),
    );
    std::fs::remove_file(dir.join("r.csv")).expect("remove");
    std::fs::remove_file(dir.join("e.csv")).expect("remove");

    std::fs::remove_file(dir.join("d.json")).expect("remove");
    let continuous = r#"{"A": [[0, 1], [0, 0]], "C": [[1, 0]], "Qc": [[0, 0], [0, 0.5]],
        "R": [[1]], "P0": [[1, 0], [0, 1]]}"#;
    write(&dir, "c.json", continuous);
    let cases: [(&str, &[&str]); 3] = [
        (
            "t,z1\n0,1\nNaN,2\n",
            &["z.csv: line 3, column 1 (t)", "missing value"],
        ),
        (
            "t,z1\n0,1\n0.5,2\n0.4,3\n",
            &["z.csv: line 4, column 1 (t)", "must not decrease"],
        ),
        (
            "t,z1\n0,1\n1e300,2\n",
            &["z.csv: line 3", "cannot be sampled", "overflows"],
        ),
    ];
    for (csv, expect) in cases {
        write(&dir, "z.csv", csv);
        refused(
            &dir,
            &argv_with("filter --model c.json --data z.csv --out e.csv", &[]),
            expect,
            2,
        );
    }
    write(&dir, "z.csv", "t,z1\n0,1\n1,2\n");
    refused(
        &dir,
        &argv_with(
            "fit --model c.json --data z.csv --free R:scalar --method em --out f.json",
            &[],
        ),
        &["--method em needs a discrete model"],
        2,
    );
    // Two rows of one instant are one time stamp: Δt = 0 between them.
    write(&dir, "z.csv", "t,z1\n0,1\n0,1.5\n1,2\n");
    ok(
        &dir,
        &argv_with("filter --model c.json --data z.csv --out e.csv", &[]),
    );
}

#[test]
fn gate_options_are_checked() {
    let dir = scratch("irregular", "options");
    let (model, rec) = record(&dir);
    for bad in ["1", "0", "-0.5", "abc", "NaN"] {
        let out = crate::common::run(
            &dir,
            &argv_with(
                "filter --model {} --data {} --out e.csv --gate {}",
                &[&model, &rec, bad],
            ),
        );
        assert_eq!(out.status.code(), Some(2), "--gate {bad}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--gate"));
    }
    // --rejected needs --gate.
    let out = crate::common::run(
        &dir,
        &argv_with(
            "filter --model {} --data {} --out e.csv --rejected r.csv",
            &[&model, &rec],
        ),
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(!dir.join("e.csv").exists() && !dir.join("r.csv").exists());
}

/// Channel names in the model file name the data header's columns and the rejections.
#[test]
fn channel_names_from_the_model_name_the_header_and_the_rejections() {
    let dir = scratch("irregular", "channels");
    let model = read(&data("model.json"));
    let named = model.replacen(
        '{',
        "{\n  \"channels\": [\"gnss_x\", \"gnss_y\", \"vel_x\"],",
        1,
    );
    write(&dir, "model.json", &named);
    let record = read(&data("record.csv")).replacen("t,z1,z2,z3", "t,gnss_x,gnss_y,vel_x", 1);
    write(&dir, "record.csv", &record);
    ok(
        &dir,
        &argv_with(
            "filter --model model.json --data record.csv --out e.csv --gate 0.9999 --rejected r.csv",
            &[],
        ),
    );
    assert_matches(&dir.join("e.csv"), &data("gated.csv"));
    let rename = |c: &str| match c {
        "z1" => "gnss_x",
        "z2" => "gnss_y",
        _ => "vel_x",
    };
    let want: Vec<(String, String)> = entries(&data("wild.csv"))
        .into_iter()
        .map(|(t, c)| (t, rename(&c).to_string()))
        .collect();
    assert_eq!(entries(&dir.join("r.csv")), want);
    // The z1… header still reads; a header with other names is refused naming the column.
    write(&dir, "z.csv", "t,z1,z2,z3\n0,1,2,3\n");
    ok(
        &dir,
        &argv_with("filter --model model.json --data z.csv --out e2.csv", &[]),
    );
    write(&dir, "z.csv", "t,gnss_x,gnss_z,vel_x\n0,1,2,3\n");
    let err = crate::common::fails(
        &dir,
        &argv_with("filter --model model.json --data z.csv --out e3.csv", &[]),
    );
    assert!(
        err.contains("line 1, column 3") && err.contains("`gnss_y`"),
        "{err}"
    );
    // Bad names are refused in the model file.
    for (channels, expect) in [
        ("[\"a\", \"b\"]", "2 names for m = 3"),
        ("[\"a\", \"a\", \"b\"]", "named twice"),
        ("[\"a\", \"z2\", \"b\"]", "reserves"),
        ("[\"a\", \"b c\", \"d\"]", "must be a non-empty name"),
    ] {
        let bad = model.replacen('{', &format!("{{\n  \"channels\": {channels},"), 1);
        write(&dir, "bad.json", &bad);
        let err = crate::common::fails(
            &dir,
            &argv_with("filter --model bad.json --data z.csv --out e4.csv", &[]),
        );
        assert!(
            err.contains("bad.json") && err.contains(expect),
            "{channels}: {err}"
        );
    }
}
