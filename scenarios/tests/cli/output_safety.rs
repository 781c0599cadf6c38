//! What the program does to the files around it: an output that is an input, device nodes,
//! links and standard output as `--out`, interrupts mid-write, failing runs and I/O errors —
//! inputs are never touched and an output is written whole or not at all.
#![allow(non_snake_case)]

use std::process::Command;

use crate::common::*;

#[test]
fn out_that_is_an_input_is_refused() {
    let dir = scratch("ud", "out-is-input");
    write(&dir, "m.toml", WALK_TOML);
    write(&dir, "m.json", WALK_JSON);
    write(&dir, "c.json", CONT_JSON);
    write(&dir, "track.csv", "t,z1\n0,1\n1,2\n");
    std::os::unix::fs::symlink("track.csv", dir.join("link.csv")).expect("symlink");
    std::fs::hard_link(dir.join("track.csv"), dir.join("hard.csv")).expect("hard link");
    let before = snapshot(&dir);
    let filter = |out: &'static str, smooth: bool| {
        let mut a = argv_with("filter --model m.toml --data track.csv --out {}", &[out]);
        if smooth {
            a.push("--smooth");
        }
        a
    };
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (filter("track.csv", false), "--data track.csv"),
        (filter("track.csv", true), "--data track.csv"),
        (filter("./track.csv", false), "--data track.csv"),
        (filter("link.csv", true), "--data track.csv"),
        (filter("hard.csv", false), "--data track.csv"),
        (filter("m.toml", false), "--model m.toml"),
        (
            argv("steady-state --model m.json --out m.json"),
            "--model m.json",
        ),
        (
            argv("discretize --model c.json --dt 0.1 --method zoh --out ./c.json"),
            "--model c.json",
        ),
    ];
    for (args, input) in cases {
        refused(
            &dir,
            &args,
            &["--out ", "is the same file as", input, "refusing"],
            before.len(),
        );
        assert_eq!(snapshot(&dir), before, "{args:?} changed an input");
    }
}

#[test]
fn device_nodes_links_and_standard_output_as_out() {
    use std::os::unix::fs::FileTypeExt;
    let dir = scratch("ud", "out-devices");
    write(&dir, "m.toml", WALK_TOML);
    write(&dir, "c.json", CONT_JSON);
    write(&dir, "z.csv", "t,z1\n0,1\n1,2\n");
    let filter = |out: &str| {
        run(
            &dir,
            &argv_with("filter --model m.toml --data z.csv --out {}", &[out]),
        )
    };
    for (name, minor) in [("null", "3"), ("full", "7")] {
        device_node(&dir.join(name), minor);
    }
    let status = Command::new("mkfifo")
        .arg(dir.join("fifo"))
        .status()
        .expect("mkfifo");
    assert!(status.success());
    // Like /dev/stdout when stdout is a pipe: a link to a FIFO.
    std::os::unix::fs::symlink("fifo", dir.join("stdout")).expect("link");
    for (dev, what) in [
        ("null", "character device"),
        ("full", "character device"),
        ("fifo", "a FIFO"),
        ("stdout", "symbolic link to a FIFO"),
    ] {
        let out = filter(dev);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{dev}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.contains(&format!("--out {dev}")) && err.contains(what),
            "{err}"
        );
        assert!(out.stdout.is_empty());
    }
    for dev in ["null", "full"] {
        let t = std::fs::metadata(dir.join(dev))
            .expect("device")
            .file_type();
        assert!(t.is_char_device(), "{dev} must stay a device");
    }
    let t = std::fs::metadata(dir.join("stdout"))
        .expect("fifo")
        .file_type();
    assert!(t.is_fifo(), "the FIFO must stay a FIFO");
    for name in ["null", "full", "stdout"] {
        std::fs::remove_file(dir.join(name)).expect("remove");
    }
    std::fs::remove_file(dir.join("fifo")).expect("remove fifo");
    // The reference output, to a plain new file.
    ok(
        &dir,
        &argv("filter --model m.toml --data z.csv --out plain.csv"),
    );
    let plain = std::fs::read(dir.join("plain.csv")).expect("plain");
    // A link to a regular file: the file is replaced whole, the link stays a link.
    write(&dir, "real.csv", "old contents\n");
    std::os::unix::fs::symlink("real.csv", dir.join("link.csv")).expect("symlink");
    let out = filter("link.csv");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let link = std::fs::symlink_metadata(dir.join("link.csv")).expect("link");
    assert!(link.file_type().is_symlink(), "the link must stay a link");
    assert_eq!(std::fs::read(dir.join("real.csv")).expect("real"), plain);
    // `-` is standard output: the same bytes, and no file named `-`.
    let out = filter("-");
    assert!(out.status.success());
    assert_eq!(out.stdout, plain);
    for args in [
        argv("steady-state --model m.toml --out"),
        argv("discretize --model c.json --dt 0.1 --method zoh --out"),
    ] {
        let mut to_file = args.clone();
        to_file.push("file.json");
        ok(&dir, &to_file);
        let mut to_stdout = args.clone();
        to_stdout.push("-");
        let out = run(&dir, &to_stdout);
        assert!(out.status.success(), "{to_stdout:?}");
        assert_eq!(
            out.stdout,
            std::fs::read(dir.join("file.json")).expect("file"),
            "{to_stdout:?}"
        );
    }
    assert!(
        !dir.join("-").exists(),
        "`--out -` must not create a file named -"
    );
}

/// Starts `filter` reading its data from a FIFO that the test holds open after a few rows,
/// so the run is certainly mid-write; sends `signal`; checks that nothing is left.
fn interrupt_mid_write(signal: &str) {
    use std::io::Write as _;
    let dir = scratch("ud", &format!("interrupt-{signal}"));
    write(&dir, "m.toml", WALK_TOML);
    let status = Command::new("mkfifo")
        .arg(dir.join("z.csv"))
        .status()
        .expect("mkfifo");
    assert!(status.success());
    let child = Command::new(env!("CARGO_BIN_EXE_scenarios"))
        .current_dir(&dir)
        .args(argv("filter --model m.toml --data z.csv --out sub/est.csv"))
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    // Opening the FIFO for writing waits for the program to open it for reading.
    let mut fifo = std::fs::OpenOptions::new()
        .write(true)
        .open(dir.join("z.csv"))
        .expect("open fifo");
    fifo.write_all(b"t,z1\n0,1\n1,2\n").expect("rows");
    fifo.flush().expect("flush");
    // Wait for the temporary file to appear (the program then blocks on the next row).
    let partial = || {
        std::fs::read_dir(dir.join("sub"))
            .map(|d| d.count())
            .unwrap_or(0)
    };
    let start = std::time::Instant::now();
    while partial() == 0 {
        assert!(
            start.elapsed() < std::time::Duration::from_secs(60),
            "no temporary file appeared"
        );
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let pid = child.id().to_string();
    // The shell's own `kill`, so the test needs no separate kill program.
    let status = Command::new("sh")
        .args(["-c", &format!("kill -s {signal} {pid}")])
        .status()
        .expect("kill");
    assert!(status.success());
    let out = child.wait_with_output().expect("wait");
    drop(fifo);
    assert_eq!(out.status.code(), Some(130), "{signal}: {out:?}");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(
        left.len(),
        2,
        "{signal}: only the inputs may remain (no partial file, no created directory): {left:?}"
    );
}

#[test]
fn interrupt_removes_the_partial_file() {
    interrupt_mid_write("INT");
    interrupt_mid_write("TERM");
}

#[test]
fn failing_run_leaves_no_directory() {
    let dir = scratch("ud", "no-dir");
    write(&dir, "m.toml", WALK_TOML);
    // Fails after rows were streamed into the temporary file in new/sub/.
    write(&dir, "bad.csv", "t,z1\n0,1\n1,2\n2,x\n");
    for out in ["new/sub/est.csv", "new/est.csv"] {
        refused(
            &dir,
            &argv_with("filter --model m.toml --data bad.csv --out {}", &[out]),
            &["bad.csv: line 4"],
            2,
        );
    }
    // Fails before writing (a bad model): no directory either.
    write(&dir, "good.csv", "t,z1\n0,1\n");
    write(&dir, "bad.toml", "dt = 1\n");
    refused(
        &dir,
        &argv("filter --model bad.toml --data good.csv --out new/est.csv"),
        &["bad.toml"],
        4,
    );
    // A successful run creates it.
    ok(
        &dir,
        &argv("filter --model m.toml --data good.csv --out new/sub/est.csv"),
    );
    assert!(dir.join("new/sub/est.csv").is_file());
}

#[test]
fn io_failures_exit_with_code_one() {
    // /proc takes no new files, even for root: an I/O failure, not the user's input.
    let dir = scratch("ud", "io");
    write(&dir, "m.toml", WALK_TOML);
    write(&dir, "z.csv", "t,z1\n0,1\n");
    let out = run(
        &dir,
        &argv("filter --model m.toml --data z.csv --out /proc/est.csv"),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("/proc/est.csv: cannot write"), "{err}");
}
