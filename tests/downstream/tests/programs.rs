//! Runs the three programs as a user would and fails if any of them fails (each asserts its
//! own numbers against an independent closed form or property).

use std::process::Command;

fn run(exe: &str) {
    let out = Command::new(exe).output().expect("the program starts");
    assert!(
        out.status.success(),
        "{exe} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn tracker_with_gaps_and_rts_matches_the_batch_posterior() {
    run(env!("CARGO_BIN_EXE_tracker"));
}

#[test]
fn dare_and_lqr_solve_their_equations_and_stabilise() {
    run(env!("CARGO_BIN_EXE_lqr"));
}

#[test]
fn tikhonov_matches_the_regularised_normal_equations() {
    run(env!("CARGO_BIN_EXE_wls_tikhonov"));
}

/// Code lines of a program: neither blank nor a comment (`//` in Rust, `#` in Python).
fn code_lines(path: &str, comment: &str) -> usize {
    let text = std::fs::read_to_string(path).expect("the program is readable");
    text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with(comment)).count()
}

/// The two numbers of a program's "Length: R code lines here, P in …" header.
fn stated_lengths(path: &str) -> (usize, usize) {
    let text = std::fs::read_to_string(path).expect("the program is readable");
    let header: String = text
        .lines()
        .take_while(|l| l.starts_with("//!"))
        .map(|l| l.trim_start_matches("//!"))
        .collect::<Vec<_>>()
        .join(" ");
    let after = header.split("Length: ").nth(1).expect("a Length: header");
    let numbers: Vec<usize> =
        after.split_whitespace().filter_map(|w| w.parse().ok()).take(2).collect();
    (numbers[0], numbers[1])
}

#[test]
fn each_program_is_no_longer_than_its_python_version_as_its_header_states() {
    let dir = env!("CARGO_MANIFEST_DIR");
    for name in ["tracker", "lqr", "wls_tikhonov"] {
        let rust = format!("{dir}/src/bin/{name}.rs");
        let python = format!("{dir}/filterpy/{name}.py");
        // The Python programs are laid out as black does at rustfmt's width, 100.
        let text = std::fs::read_to_string(&python).expect("the Python program is readable");
        assert!(text.lines().all(|l| l.chars().count() <= 100), "{python} has lines over 100");
        let counted = (code_lines(&rust, "//"), code_lines(&python, "#"));
        assert_eq!(stated_lengths(&rust), counted, "{rust}: header vs counted (Rust, Python)");
        // The point of the comparison: the Rust program is no longer than the Python one.
        assert!(
            counted.0 <= counted.1,
            "{rust}: {} code lines against Python's {}",
            counted.0,
            counted.1
        );
    }
}
