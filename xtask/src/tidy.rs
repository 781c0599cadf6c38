//! `cargo xtask tidy`: mechanical checks of the tree that reviews should not have to make.
//!
//! - every `.rs` file starts with a `//!` line saying what it is for;
//! - no line of a source, manifest or Markdown file ends in white space;
//! - internal path dependencies carry the workspace's version (`version = "0.1.0"`) in
//!   `[dependencies]` and no version in `[dev-dependencies]` (after rust-analyzer);
//! - library crates depend on no sibling except as STYLE.md allows;
//! - no Rust source file is longer than [`MAX_LINES`] lines;
//! - no `Result<_, String>` in `scenarios` (errors are typed);
//! - no import cycle between the modules of a crate;
//! - matrix parameters of the library crates' public functions follow the notation table
//!   ([`crate::notation`]).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// The version every internal path dependency carries: `[workspace.package] version`.
const VERSION: &str = "0.1.0";

/// The sibling crates each crate may depend on (the one-way dependency direction).
const ALLOWED: &[(&str, &[&str])] = &[
    ("numerics", &[]),
    ("model", &["numerics"]),
    ("kalman", &["numerics"]),
    ("wls", &["numerics"]),
    ("sensors", &["model"]),
    (
        "scenarios",
        &["numerics", "model", "kalman", "wls", "sensors"],
    ),
    ("python", &["model", "kalman", "wls", "sensors"]),
    ("benches", &["kalman", "wls", "sensors", "scenarios"]),
    ("xtask", &[]),
];

/// Sibling dependencies allowed only as optional ones (off by default, so the crate still
/// builds alone): `model`'s feature `kalman`, the one-call bridge to a Kalman filter model.
const OPTIONAL: &[(&str, &str)] = &[("model", "kalman")];

/// The longest a Rust source file may be.
const MAX_LINES: usize = 800;

/// Files still over [`MAX_LINES`], each waiting to be split by the change that owns it; the
/// list only shrinks (an entry whose file is back under the limit is itself reported).
const OVER_LENGTH: &[&str] = &[];

/// Import cycles still present, as `crate: a -> b` lines of [`cycles`]' output, each waiting
/// for the change that owns it; the list only shrinks, like [`OVER_LENGTH`].
const KNOWN_CYCLES: &[&str] = &[];

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
        if ext == "rs" {
            let lines = text.lines().count();
            let listed = OVER_LENGTH.contains(&rel.as_str());
            if lines > MAX_LINES && !listed {
                problems.push(format!(
                    "{rel}: {lines} lines, more than {MAX_LINES}: split it by what it does"
                ));
            }
            if lines <= MAX_LINES && listed {
                problems.push(format!(
                    "{rel}: {lines} lines, within the limit: remove it from OVER_LENGTH"
                ));
            }
            if rel.starts_with("python/src/") && text.contains(concat!("macro_rules", "!")) {
                problems.push(format!(
                    "{rel}: defines a macro: the Python crate is ordinary functions and \
                     #[pymethods], so rustfmt formats every line"
                ));
            }
            if rel.starts_with("scenarios/") {
                for (i, line) in text.lines().enumerate() {
                    if string_result(line) {
                        problems.push(format!(
                            "{rel}:{}: `Result<_, String>`: return a typed error",
                            i + 1
                        ));
                    }
                }
            }
        }
    }
    let mut found = Vec::new();
    for krate in ALLOWED.iter().map(|(name, _)| *name) {
        let src = root.join(krate).join("src");
        if src.is_dir() {
            found.extend(cycles(krate, &src, &files)?);
        }
    }
    for c in &found {
        if !KNOWN_CYCLES.contains(&c.as_str()) {
            problems.push(format!("import cycle: {c}"));
        }
    }
    for krate in crate::examples::CRATES {
        problems.extend(crate::notation::check_crate(
            root,
            &files,
            &root.join(krate).join("src"),
        ));
    }
    for k in KNOWN_CYCLES {
        if !found.iter().any(|c| c == k) {
            problems.push(format!(
                "import cycle `{k}` is gone: remove it from KNOWN_CYCLES"
            ));
        }
    }
    problems.extend(crate::homes::check(root, &files));
    let items = crate::examples::scan(root)?;
    let share = crate::examples::share(&items);
    if share < crate::examples::REQUIRED {
        problems.push(format!(
            "only {:.1} % of the library crates' {} top-level public items carry a compiled doc \
             example (required {:.0} %; `cargo xtask doc-examples` lists the rest)",
            100.0 * share,
            items.len(),
            100.0 * crate::examples::REQUIRED
        ));
    }
    Ok(problems)
}

/// Whether `line` spells a `Result` whose error type is `String` (outside a comment).
fn string_result(line: &str) -> bool {
    let code = line.split("//").next().unwrap_or("");
    let mut rest = code;
    while let Some(at) = rest.find("Result<") {
        let after = &rest[at + "Result<".len()..];
        // Find the top-level comma and the closing `>` of this `Result<…>`.
        let mut depth = 0usize;
        let mut comma = None;
        for (i, c) in after.char_indices() {
            match c {
                '<' | '(' | '[' => depth += 1,
                '>' | ')' | ']' if depth == 0 => {
                    if let Some(k) = comma
                        && after[k + 1..i].trim() == "String"
                    {
                        return true;
                    }
                    break;
                }
                '>' | ')' | ']' => depth -= 1,
                ',' if depth == 0 => comma = Some(i),
                _ => {}
            }
        }
        rest = after;
    }
    false
}

/// The module path of a source file below `src` (`a/b.rs` and `a/b/mod.rs` → `a::b`; the
/// crate root → ``), or `None` for a file that is not a module of the crate (`bin/`, …).
fn module_of(src: &Path, path: &Path) -> Option<String> {
    let rel = path.strip_prefix(src).ok()?;
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let file = parts.pop()?;
    let stem = file.strip_suffix(".rs")?;
    if parts.first().is_some_and(|p| p == "bin") {
        return None;
    }
    if !matches!(stem, "mod" | "lib" | "main") {
        parts.push(stem.to_string());
    } else if matches!(stem, "lib" | "main") && !parts.is_empty() {
        return None;
    }
    Some(parts.join("::"))
}

/// Import cycles between the modules of crate `krate` (sources below `src`): one line per
/// cycle, `krate: a -> b -> a`. A module's imports are the `crate::…`, `super::…` and
/// `self::…` paths in its file before its `#[cfg(test)]` section, resolved to the longest
/// module they name; a module's own submodules and ancestors do not count.
fn cycles(krate: &str, src: &Path, files: &[PathBuf]) -> Result<Vec<String>> {
    use std::collections::{BTreeMap, BTreeSet};
    let mut modules: BTreeMap<String, PathBuf> = BTreeMap::new();
    for f in files {
        if f.starts_with(src)
            && f.extension().is_some_and(|e| e == "rs")
            && let Some(m) = module_of(src, f)
        {
            modules.insert(m, f.clone());
        }
    }
    let join = |a: &str, b: &str| {
        if a.is_empty() {
            b.to_string()
        } else {
            format!("{a}::{b}")
        }
    };
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, f) in &modules {
        let text =
            std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
        let body = text.split("#[cfg(test)]").next().unwrap_or("");
        let parent = m.rsplit_once("::").map_or("", |(p, _)| p).to_string();
        let mut out = BTreeSet::new();
        for (prefix, base) in [
            ("crate::", String::new()),
            ("super::", parent.clone()),
            ("self::", m.clone()),
        ] {
            let mut rest = body;
            while let Some(at) = rest.find(prefix) {
                let before = rest[..at].chars().last();
                rest = &rest[at + prefix.len()..];
                if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
                    continue;
                }
                let path: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                    .collect();
                let mut target = base.clone();
                let mut best = None;
                for seg in path.split("::").filter(|s| !s.is_empty()) {
                    target = join(&target, seg);
                    if modules.contains_key(&target) {
                        best = Some(target.clone());
                    }
                }
                if let Some(t) = best {
                    let related = t.starts_with(&format!("{m}::"))
                        || m.starts_with(&format!("{t}::"))
                        || t.is_empty()
                        || *m == t;
                    if !related {
                        out.insert(t);
                    }
                }
            }
        }
        edges.insert(m.clone(), out);
    }
    // Two modules on a cycle reach each other; report each strongly connected pair once,
    // with the shortest path round.
    let reach = |from: &str| -> BTreeMap<String, String> {
        let mut prev: BTreeMap<String, String> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([from.to_string()]);
        while let Some(n) = queue.pop_front() {
            for t in edges.get(&n).into_iter().flatten() {
                if !prev.contains_key(t) {
                    prev.insert(t.clone(), n.clone());
                    queue.push_back(t.clone());
                }
            }
        }
        prev
    };
    let mut seen = BTreeSet::new();
    let mut found = Vec::new();
    for m in modules.keys() {
        let prev = reach(m);
        if prev.contains_key(m) && !seen.contains(m) {
            let mut path = vec![m.clone()];
            let mut at = prev[m].clone();
            while at != *m {
                path.push(at.clone());
                at = prev[&at].clone();
            }
            path.push(m.clone());
            path.reverse();
            seen.extend(path.iter().cloned());
            found.push(format!("{krate}: {}", path.join(" -> ")));
        }
    }
    Ok(found)
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
        let has_version = line.contains(&format!("version = \"{VERSION}\""));
        let any_version = line.contains("version");
        match section.as_str() {
            "dependencies" => {
                if !has_version {
                    problems.push(format!(
                        "{at}: internal dependency `{dep}` needs `version = \"{VERSION}\"`"
                    ));
                }
                let bridge = line.contains("optional = true") && OPTIONAL.contains(&(krate, dep));
                if let Some(allowed) = allowed
                    && !allowed.contains(&dep)
                    && !bridge
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn string_results_are_found_and_typed_ones_are_not() {
        assert!(string_result("fn f() -> Result<u8, String> {"));
        assert!(string_result(
            "fn f() -> std::result::Result<Vec<(u8, u8)>, String> {"
        ));
        assert!(!string_result("fn f() -> Result<String, Error> {"));
        assert!(!string_result("fn f() -> Result<String> {"));
        assert!(!string_result("// Result<u8, String> in a comment"));
    }

    #[test]
    fn module_paths_follow_the_file_layout() {
        let src = Path::new("/c/src");
        let m = |p: &str| module_of(src, Path::new(p));
        assert_eq!(m("/c/src/lib.rs").as_deref(), Some(""));
        assert_eq!(m("/c/src/a.rs").as_deref(), Some("a"));
        assert_eq!(m("/c/src/a/mod.rs").as_deref(), Some("a"));
        assert_eq!(m("/c/src/a/b.rs").as_deref(), Some("a::b"));
        assert_eq!(m("/c/src/bin/x.rs"), None);
    }

    #[test]
    fn a_two_module_cycle_is_found_and_a_chain_is_not() {
        let dir = std::env::temp_dir().join(format!("tidy-cycles-{}", std::process::id()));
        let src = dir.join("src");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&src).expect("mkdir");
        let write = |name: &str, text: &str| {
            std::fs::write(src.join(name), text).expect("write");
            src.join(name)
        };
        let files = vec![
            write("lib.rs", "//! r\npub mod a;\npub mod b;\npub mod c;\n"),
            write("a.rs", "//! a\nuse crate::b::X;\n"),
            write("b.rs", "//! b\nuse super::c::Y;\n"),
            write(
                "c.rs",
                "//! c\nuse crate::a::Z;\n#[cfg(test)]\nuse crate::b::W;\n",
            ),
        ];
        let found = cycles("k", &src, &files).expect("reads");
        assert_eq!(found, vec!["k: a -> b -> c -> a".to_string()]);
        std::fs::write(src.join("c.rs"), "//! c\n").expect("write");
        assert!(cycles("k", &src, &files).expect("reads").is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
