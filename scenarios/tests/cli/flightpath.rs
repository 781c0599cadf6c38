//! `scenarios flightpath`: summary.json's keys, shards merged equal to one run, and
//! `--data` on the simulated flight written to CSV reproducing the in-memory estimates, and
//! the plot style of every figure both write.

use super::common::{argv, assert_same_files, ok, scratch, summary};

/// A 20 s flight (the manoeuvres compressed; every sensor and defect present).
const CONFIG: &str = "[flight]\nduration_s = 20.0\n";

#[test]
fn shards_merge_and_data_reproduces_the_nominal_run() {
    let dir = scratch("flightpath", "merge");
    std::fs::write(dir.join("short.toml"), CONFIG).expect("config");
    ok(
        &dir,
        &argv("flightpath --config short.toml --runs 2 --out whole"),
    );
    ok(
        &dir,
        &argv("flightpath --config short.toml --runs 2 --shard 1/2 --out a"),
    );
    ok(
        &dir,
        &argv("flightpath --config short.toml --runs 2 --shard 2/2 --out b"),
    );
    ok(&dir, &argv("merge a b --out merged"));
    assert_same_files(&dir.join("whole"), &dir.join("merged"));
    let s = summary(&dir.join("whole"));
    assert_eq!(s["scenario"], "flightpath");
    assert_eq!(s["parameters"].as_array().map(Vec::len), Some(12));
    for method in ["filter_smoother", "output_error"] {
        assert!(
            s["parameters"][0][method]["std"]
                .as_f64()
                .is_some_and(|v| v > 0.0)
        );
        let mc = &s["monte_carlo"][method];
        assert_eq!(mc.as_array().map(Vec::len), Some(12));
        assert!(mc[0]["coverage95"].as_f64().is_some());
    }
    assert_eq!(s["monte_carlo"]["runs"], 2);
    for g in ["position", "velocity", "attitude"] {
        let t = &s["trajectory"][g];
        assert!(
            t["smoothed_rms"].as_f64() < t["filtered_rms"].as_f64(),
            "{g}: {t}"
        );
    }
    assert!(
        s["trajectory"]["nees_smoothed"]["band"][1]
            .as_f64()
            .is_some()
    );

    // The nominal flight (run 0 of seed 1) written in the documented CSV format.
    let params: scenarios::flightpath::parameters::FlightPathParams =
        toml::from_str(CONFIG).expect("config parses");
    let rec = sensors::flight::simulate(&params.flight, &mut scenarios::montecarlo::run_rng(1, 0))
        .expect("flight");
    let data = scenarios::flightpath::simulation::flight_data(&rec);
    std::fs::write(
        dir.join("flight.csv"),
        scenarios::flightpath::userflight::flight_csv(&data),
    )
    .expect("csv");
    ok(
        &dir,
        &argv("flightpath --data flight.csv --config short.toml --out user"),
    );
    // Every figure of both runs keeps the plot style (`plots::check`).
    for out in ["whole", "user"] {
        let files = super::plots::svgs(&dir.join(out));
        assert!(files.len() >= 8, "{out}: {files:?}");
        let problems: Vec<String> = files.iter().flat_map(|f| super::plots::check(f)).collect();
        assert!(problems.is_empty(), "{}", problems.join("\n"));
    }
    // The truth line of each instrument error is drawn, not only named in the legend: its
    // colour (the palette's second) strokes the legend sample and the line.
    for f in super::plots::svgs(&dir.join("whole")) {
        if f.file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with("error_"))
        {
            let text = std::fs::read_to_string(&f).expect("svg");
            assert!(
                text.matches("stroke=\"#FF7F0E\"").count() >= 2,
                "{}: the truth line is not drawn",
                f.display()
            );
        }
    }
    let u = summary(&dir.join("user"));
    assert_eq!(u["scenario"], "flightpath-data");
    for j in 0..12 {
        for method in ["filter_smoother", "output_error"] {
            for what in ["estimate", "std"] {
                let (a, b) = (
                    &u["parameters"][j][method][what],
                    &s["parameters"][j][method][what],
                );
                assert_eq!(a, b, "error {j}, {method} {what}");
            }
        }
        assert!(u["parameters"][j].get("truth").is_none());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
