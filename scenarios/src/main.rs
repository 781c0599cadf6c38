//! The `scenarios` command-line program (being built).

fn main() {
    eprintln!("scenarios: not built yet");
    std::process::exit(2);
}
