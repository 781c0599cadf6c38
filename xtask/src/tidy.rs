//! `cargo xtask tidy`: mechanical checks of the tree that reviews should not have to make.
//!
//! - every `.rs` file starts with a `//!` line saying what it is for;
//! - no line of a source, manifest or Markdown file ends in white space;
//! - internal path dependencies carry `version = "0.0.0"` in `[dependencies]` and no version
//!   in `[dev-dependencies]` (STYLE.md, after rust-analyzer);
//! - library crates depend on no sibling except as STYLE.md allows.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// The sibling crates each crate may depend on (the one-way dependency direction).
const ALLOWED: &[(&str, &[&str])] = &[
    ("model", &[]),
    ("kalman", &[]),
    ("wls", &[]),
    ("sensors", &["model"]),
    ("scenarios", &["model", "kalman", "wls", "sensors"]),
    ("xtask", &[]),
];

/// Returns one human-readable line per problem found below `root`.
pub(crate) fn check(root: &Path) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    let mut files = Vec::new();
    walk(root, root, &mut files)?;
    for path in &files {
        let rel = path
            .strip_prefix(root)
            .unwrap_or(path)
            .display()
            .to_string();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !matches!(ext, "rs" | "toml" | "md") && !rel.starts_with(".ci/") {
            continue;
        }
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {rel}"))?;
        if ext == "rs" && !text.starts_with("//!") {
            problems.push(format!(
                "{rel}: does not start with a `//!` line saying what it is for"
            ));
        }
        for (i, line) in text.lines().enumerate() {
            if line.ends_with(' ') || line.ends_with('\t') {
                problems.push(format!("{rel}:{}: trailing whitespace", i + 1));
            }
        }
        if path.file_name().is_some_and(|n| n == "Cargo.toml") && rel != "Cargo.toml" {
            manifest(&rel, &text, &mut problems);
        }
    }
    Ok(problems)
}

/// Checks one crate manifest's internal dependencies.
fn manifest(rel: &str, text: &str, problems: &mut Vec<String>) {
    let krate = rel.split('/').next().unwrap_or("");
    let allowed = ALLOWED
        .iter()
        .find(|(name, _)| *name == krate)
        .map(|(_, a)| *a);
    let mut section = String::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.starts_with('[') {
            section = line.trim_matches(|c| c == '[' || c == ']').to_string();
            continue;
        }
        if !line.contains("path = \"../") {
            continue;
        }
        let dep = line.split(['=', ' ']).next().unwrap_or("").trim();
        let at = format!("{rel}:{}", i + 1);
        let has_version = line.contains("version = \"0.0.0\"");
        let any_version = line.contains("version");
        match section.as_str() {
            "dependencies" => {
                if !has_version {
                    problems.push(format!(
                        "{at}: internal dependency `{dep}` needs `version = \"0.0.0\"`"
                    ));
                }
                if let Some(allowed) = allowed
                    && !allowed.contains(&dep)
                {
                    problems.push(format!(
                        "{at}: `{krate}` may not depend on sibling `{dep}` (see STYLE.md)"
                    ));
                }
            }
            "dev-dependencies" if any_version => problems.push(format!(
                "{at}: internal dev-dependency `{dep}` carries no version"
            )),
            _ => {}
        }
    }
}

/// Collects the files below `dir`, skipping build output, VCS data and generated reports.
fn walk(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    for entry in std::fs::read_dir(dir).with_context(|| format!("listing {}", dir.display()))? {
        let entry = entry?;
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if entry.file_type()?.is_dir() {
            let rel = path.strip_prefix(root).unwrap_or(&path);
            let skip = matches!(
                name.as_ref(),
                "target" | ".git" | "reports" | "corpus" | "artifacts"
            ) || rel.starts_with("proptest-regressions");
            if !skip {
                walk(root, &path, out)?;
            }
        } else {
            out.push(path);
        }
    }
    Ok(())
}
