//! Counts the top-level public items of the library crates that carry a compiled doc example.
//!
//! An item counts when it is a `pub struct`, `pub enum`, `pub trait` or `pub fn` written at
//! the top level of a module file (not inside an `impl` or a nested block) and reachable by a
//! user: its module chain from `lib.rs` is all `pub mod` (and not `#[doc(hidden)]`), or the
//! item's name is re-exported by a `pub use`. It carries an example when its `///` doc holds a
//! code fence that rustdoc compiles: no language, `rust`, `no_run` or `should_panic` (not
//! `text`, `ignore`, `compile_fail` or another language). A source scan, not a compiler
//! query: it reads the conventional layout this workspace uses (`mod x;` lines at column 0).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// The library crates whose items are counted.
pub(crate) const CRATES: &[&str] = &["numerics", "model", "kalman", "wls", "sensors"];

/// The share of counted items that must carry an example.
pub(crate) const REQUIRED: f64 = 0.80;

/// One public item found by the scan.
#[derive(Debug, Clone)]
pub(crate) struct Item {
    /// `crate/src/...rs:line`.
    pub(crate) at: String,
    /// `struct Foo`, `fn bar`, ...
    pub(crate) what: String,
    /// Whether its docs hold a compiled example.
    pub(crate) has_example: bool,
}

/// Scans every library crate below `root`.
pub(crate) fn scan(root: &Path) -> Result<Vec<Item>> {
    let mut items = Vec::new();
    for krate in CRATES {
        let src = root.join(krate).join("src");
        let mut files = Vec::new();
        modules(&src.join("lib.rs"), true, &mut files)?;
        let mut reexported = BTreeSet::new();
        for (file, _) in &files {
            let text = std::fs::read_to_string(file)?;
            reexports(&text, &mut reexported);
        }
        for (file, public) in &files {
            let text = std::fs::read_to_string(file)?;
            let rel = file
                .strip_prefix(root)
                .unwrap_or(file)
                .display()
                .to_string();
            items_in(&rel, &text, *public, &reexported, &mut items);
        }
    }
    Ok(items)
}

/// The share of `items` with an example, in [0, 1] (1 for no items).
pub(crate) fn share(items: &[Item]) -> f64 {
    if items.is_empty() {
        return 1.0;
    }
    items.iter().filter(|i| i.has_example).count() as f64 / items.len() as f64
}

/// Collects `file` and the module files it declares, with whether each is publicly reachable.
fn modules(file: &Path, public: bool, out: &mut Vec<(PathBuf, bool)>) -> Result<()> {
    let text =
        std::fs::read_to_string(file).with_context(|| format!("reading {}", file.display()))?;
    out.push((file.to_path_buf(), public));
    let dir = match file.file_name().and_then(|n| n.to_str()) {
        Some("lib.rs" | "mod.rs") => file.parent().map(Path::to_path_buf),
        _ => file
            .parent()
            .map(|p| p.join(file.file_stem().unwrap_or_default())),
    }
    .unwrap_or_default();
    let mut hidden = false;
    for line in text.lines() {
        if line.starts_with("#[doc(hidden)]") {
            hidden = true;
            continue;
        }
        if line.starts_with("#[") {
            continue;
        }
        let (is_pub, rest) = if let Some(r) = line.strip_prefix("pub mod ") {
            (true, r)
        } else if let Some(r) = line.strip_prefix("mod ") {
            (false, r)
        } else {
            hidden = false;
            continue;
        };
        let Some(name) = rest.strip_suffix(';') else {
            hidden = false;
            continue;
        };
        let flat = dir.join(format!("{name}.rs"));
        let nested = dir.join(name).join("mod.rs");
        let path = if flat.exists() { flat } else { nested };
        if path.exists() {
            modules(&path, public && is_pub && !hidden, out)?;
        }
        hidden = false;
    }
    Ok(())
}

/// Adds every name re-exported by a `pub use` in `text` (the last path segment, or the
/// names inside braces).
fn reexports(text: &str, out: &mut BTreeSet<String>) {
    let mut rest = text;
    while let Some(i) = rest.find("pub use ") {
        let after = &rest[i + "pub use ".len()..];
        let end = after.find(';').unwrap_or(after.len());
        let stmt = &after[..end];
        let names = match stmt.find('{') {
            Some(b) => &stmt[b + 1..],
            None => stmt.rsplit("::").next().unwrap_or(stmt),
        };
        for name in names.split([',', '{', '}', ' ', '\n']) {
            let name = name.rsplit("::").next().unwrap_or(name).trim();
            if !name.is_empty() {
                out.insert(name.to_string());
            }
        }
        rest = &after[end..];
    }
}

/// The top-level public items of one file.
fn items_in(
    rel: &str,
    text: &str,
    public: bool,
    reexported: &BTreeSet<String>,
    out: &mut Vec<Item>,
) {
    let lines: Vec<&str> = text.lines().collect();
    for (i, line) in lines.iter().enumerate() {
        let Some((kind, name)) = declared(line) else {
            continue;
        };
        if !public && !reexported.contains(name) {
            continue;
        }
        // The doc block above: `///` lines, skipping attributes.
        let mut j = i;
        let mut docs = Vec::new();
        let mut hidden = false;
        while j > 0 {
            j -= 1;
            let above = lines[j].trim_start();
            if let Some(doc) = above.strip_prefix("///") {
                docs.push(doc.trim());
            } else if above.starts_with(")]") {
                // The end of a multi-line attribute: skip up to its `#[`.
                while j > 0 && !lines[j].trim_start().starts_with("#[") {
                    j -= 1;
                }
            } else if above.starts_with("#[") || above.starts_with("//") {
                hidden |= above.starts_with("#[doc(hidden)]");
            } else {
                break;
            }
        }
        if hidden {
            continue;
        }
        // Read the doc top-down so that only opening fences decide.
        let mut in_code = false;
        let mut has_example = false;
        for doc in docs.iter().rev() {
            if let Some(lang) = doc.strip_prefix("```") {
                if !in_code {
                    has_example |= compiled(lang);
                }
                in_code = !in_code;
            }
        }
        out.push(Item {
            at: format!("{rel}:{}", i + 1),
            what: format!("{kind} {name}"),
            has_example,
        });
    }
}

/// `(kind, name)` if `line` declares a top-level public struct, enum, trait or function.
fn declared(line: &str) -> Option<(&'static str, &str)> {
    let rest = line.strip_prefix("pub ")?;
    let rest = rest.strip_prefix("const ").unwrap_or(rest);
    let (kind, rest) = [
        ("struct", "struct "),
        ("enum", "enum "),
        ("trait", "trait "),
        ("fn", "fn "),
    ]
    .into_iter()
    .find_map(|(kind, kw)| rest.strip_prefix(kw).map(|r| (kind, r)))?;
    let end = rest
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    (end > 0).then(|| (kind, &rest[..end]))
}

/// Whether a code fence with this info string is compiled by rustdoc.
fn compiled(lang: &str) -> bool {
    lang.split(',').map(str::trim).all(|tag| {
        matches!(
            tag,
            "" | "rust" | "no_run" | "should_panic" | "edition2024" | "edition2021"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_items_and_their_examples() {
        let text = "\
/// A thing.\n/// ```\n/// let x = 1;\n/// ```\n#[derive(Debug)]\npub struct A;\n\
/// Text only.\n/// ```text\n/// x\n/// ```\npub fn b() {}\n\
pub(crate) fn c() {}\nimpl A {\n    pub fn d() {}\n}\npub enum E {}\n";
        let mut out = Vec::new();
        items_in("x.rs", text, true, &BTreeSet::new(), &mut out);
        let found: Vec<(&str, bool)> = out
            .iter()
            .map(|i| (i.what.as_str(), i.has_example))
            .collect();
        assert_eq!(
            found,
            [("struct A", true), ("fn b", false), ("enum E", false)]
        );
        let mut private = Vec::new();
        let names = BTreeSet::from(["E".to_string()]);
        items_in("x.rs", text, false, &names, &mut private);
        assert_eq!(private.len(), 1);
    }

    #[test]
    fn reads_reexports() {
        let mut names = BTreeSet::new();
        reexports(
            "pub use a::{B, c::D,\n    E};\npub use f::G;\nuse h::I;",
            &mut names,
        );
        assert_eq!(names.into_iter().collect::<Vec<_>>(), ["B", "D", "E", "G"]);
    }
}
