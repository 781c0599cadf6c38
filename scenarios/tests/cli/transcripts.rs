//! The command-line transcripts of the README and the guide (`docs/*.md`), run against the
//! built program: a snippet that stops matching the program's real output fails the test.
//!
//! The format is the one the documents show a user. In a ```` ```console ```` block, a line
//! `$ command` runs the command through `sh -c` (with the `scenarios` just built first on
//! `PATH`), and the lines after it, up to the next `$`, are its expected standard output and
//! standard error, interleaved as the user sees them. Two wildcards keep a transcript honest
//! where the output is not the point: a line `...` matches any number of lines, and `[..]`
//! inside a line matches any text. A command that should fail ends its output with the line
//! `[exit N]`. A block whose info string names a file (```` ```json file=cv.json ````) is
//! written into the document's working directory before the commands after it run.
//!
//! Every document runs in its own scratch directory, where its file blocks are written and
//! each console block starts; `$ cd DIR` (relative to the repository root) moves the rest of
//! that block into a fresh copy of DIR, so a transcript can use the stored test data without
//! ever writing into the repository.
//!
//! A small hand-written harness rather than `trycmd`, whose dependencies would have added to
//! every test build for two wildcards.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::scratch;

/// The repository root (the parent of this crate's manifest directory).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the crate sits inside the repository")
        .to_path_buf()
}

/// The documents whose transcripts are checked: the README and every guide chapter.
fn documents() -> Vec<PathBuf> {
    let mut docs = vec![root().join("README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .expect("the guide directory docs/")
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    guide.sort();
    docs.extend(guide);
    docs
}

/// A fenced block of a Markdown document: its info string, its lines and where it starts.
struct Block {
    info: String,
    lines: Vec<String>,
    line: usize,
}

fn blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        match (&mut open, line.strip_prefix("```")) {
            (None, Some(info)) => {
                open = Some(Block {
                    info: info.trim().to_string(),
                    lines: Vec::new(),
                    line: i + 1,
                });
            }
            (Some(_), Some(rest)) if rest.trim().is_empty() => {
                out.extend(open.take());
            }
            (Some(block), _) => block.lines.push(line.to_string()),
            (None, None) => {}
        }
    }
    out
}

/// Whether `actual` matches `expected` line for line, with the `...` and `[..]` wildcards.
fn matches(expected: &[String], actual: &[&str]) -> bool {
    match expected.split_first() {
        None => actual.is_empty(),
        Some((e, rest)) if e == "..." => (0..=actual.len()).any(|k| matches(rest, &actual[k..])),
        Some((e, rest)) => actual
            .split_first()
            .is_some_and(|(a, more)| line_matches(e, a) && matches(rest, more)),
    }
}

fn line_matches(expected: &str, actual: &str) -> bool {
    let mut parts = expected.split("[..]");
    let first = parts.next().unwrap_or("");
    let Some(mut rest) = actual.strip_prefix(first) else {
        return false;
    };
    let parts: Vec<&str> = parts.collect();
    for (i, part) in parts.iter().enumerate() {
        if i + 1 == parts.len() {
            return rest.ends_with(part);
        }
        match rest.find(part) {
            Some(at) => rest = &rest[at + part.len()..],
            None => return false,
        }
    }
    rest.is_empty()
}

/// Runs one `$` command in `dir`; returns the combined output's lines and the exit code.
fn run(dir: &Path, command: &str) -> (Vec<String>, i32) {
    let bin = Path::new(env!("CARGO_BIN_EXE_scenarios"))
        .parent()
        .expect("the binary's directory")
        .to_path_buf();
    let path = std::env::join_paths(std::iter::once(bin).chain(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    )))
    .expect("PATH");
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!("{command} 2>&1"))
        .current_dir(dir)
        .env("PATH", path)
        .output()
        .expect("run sh");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    (
        text.lines().map(str::to_string).collect(),
        out.status.code().unwrap_or(-1),
    )
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create the working copy");
    for entry in std::fs::read_dir(from).expect("read the directory to copy") {
        let entry = entry.expect("a directory entry");
        let target = to.join(entry.file_name());
        if entry.path().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).expect("copy a file");
        }
    }
}

/// Checks every transcript of one document; returns one message per mismatch.
fn check(doc: &Path, index: usize) -> Vec<String> {
    let name = doc.file_name().map(|n| n.to_string_lossy().into_owned());
    let name = name.unwrap_or_default();
    let text = std::fs::read_to_string(doc).expect("read the document");
    let home = scratch("transcripts", &format!("{index}-{name}"));
    let mut problems = Vec::new();
    for block in blocks(&text) {
        if let Some(file) = block
            .info
            .split_whitespace()
            .find_map(|w| w.strip_prefix("file="))
        {
            std::fs::write(home.join(file), block.lines.join("\n") + "\n").expect("write file");
            continue;
        }
        if block.info != "console" {
            continue;
        }
        let mut dir = home.clone();
        let mut i = 0;
        while i < block.lines.len() {
            let Some(command) = block.lines[i].strip_prefix("$ ") else {
                problems.push(format!(
                    "{name}:{}: output before any `$` line",
                    block.line + i + 1
                ));
                break;
            };
            let at = block.line + i + 1;
            let mut expected = Vec::new();
            i += 1;
            while i < block.lines.len() && !block.lines[i].starts_with("$ ") {
                expected.push(block.lines[i].clone());
                i += 1;
            }
            if let Some(sub) = command.strip_prefix("cd ") {
                dir = scratch("transcripts", &format!("{index}-{name}-{at}"));
                copy_dir(&root().join(sub.trim()), &dir);
                continue;
            }
            let want_exit = match expected.last().and_then(|l| l.strip_prefix("[exit ")) {
                Some(code) => {
                    let code = code.trim_end_matches(']').parse().expect("[exit N]");
                    expected.pop();
                    code
                }
                None => 0,
            };
            let (actual, code) = run(&dir, command);
            let lines: Vec<&str> = actual.iter().map(String::as_str).collect();
            if code != want_exit || !matches(&expected, &lines) {
                problems.push(format!(
                    "{name}:{at}: `{command}` exited {code} (expected {want_exit}) with\n{}\n\
                     --- expected ---\n{}",
                    actual.join("\n"),
                    expected.join("\n")
                ));
            }
        }
    }
    problems
}

#[test]
fn every_transcript_of_the_readme_and_the_guide_matches_the_program() {
    let mut problems = Vec::new();
    let mut checked = 0;
    for (i, doc) in documents().iter().enumerate() {
        let text = std::fs::read_to_string(doc).expect("read the document");
        checked += blocks(&text).iter().filter(|b| b.info == "console").count();
        problems.extend(check(doc, i));
    }
    assert!(
        checked >= 3,
        "only {checked} console blocks found: the documents lost them"
    );
    assert!(problems.is_empty(), "{}", problems.join("\n\n"));
}

#[test]
fn the_wildcards_match_what_they_say_and_nothing_more() {
    let lines = |s: &[&str]| s.iter().map(|l| l.to_string()).collect::<Vec<_>>();
    assert!(matches(&lines(&["a", "...", "d"]), &["a", "b", "c", "d"]));
    assert!(matches(&lines(&["a", "...", "b"]), &["a", "b"]));
    assert!(!matches(&lines(&["a", "d"]), &["a", "b", "d"]));
    assert!(line_matches("x = [..] m", "x = 3.25 m"));
    assert!(!line_matches("x = [..] m", "x = 3.25 s"));
    assert!(line_matches("[..]", "anything"));
    assert!(!line_matches("exact", "exactly"));
}
