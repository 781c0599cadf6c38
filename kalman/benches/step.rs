//! Criterion benches of one filter step (filled below).
fn main() {}
