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
