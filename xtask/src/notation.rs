//! The workspace's notation, checked: every matrix parameter of a public function of a library
//! crate is named by a symbol of the notation table (ARCHITECTURE.md, "Notation"), in either
//! case, or by a descriptive word — never by a stray letter that means something else.

use std::path::Path;

/// The matrix symbols of the notation table: continuous `A B C D G W`, discrete
/// `F B H D G J`, noise `Q R S`, covariance and gain `P K`, `P0`/`x0`, the WLS weight `V`,
/// the LQR cross weight `N`, and `M` for "any matrix" in generic functions.
const SYMBOLS: &[&str] = &[
    "a", "b", "c", "d", "f", "g", "h", "j", "k", "m", "n", "p", "q", "r", "s", "v", "w", "p0", "x0",
];

/// Types that make a parameter a matrix.
const MATRIX_TYPES: &[&str] = &["Matrix", "MatRef", "MatMut", "Mat<", "MatrixInput"];

/// Whether `name` follows the notation: a symbol of [`SYMBOLS`] (any case), or a
/// descriptive lower-case word of at least three characters (`weights`, `loop_gain`).
pub(crate) fn allowed(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    SYMBOLS.contains(&lower.as_str())
        || (name.len() >= 3
            && name
                .chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'))
}

/// One problem line per matrix parameter of a `pub fn` in `text` (the file `rel`) whose name
/// is not [`allowed`].
pub(crate) fn check(rel: &str, text: &str, problems: &mut Vec<String>) {
    let mut rest = text;
    let mut offset = 0;
    while let Some(at) = rest.find("pub fn ") {
        let start = offset + at;
        let after = &text[start + "pub fn ".len()..];
        let Some(open) = after.find('(') else { break };
        let name: String = after[..open]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let params = balanced(&after[open + 1..]);
        for param in split_top(params) {
            let Some((pname, ty)) = param.split_once(':') else {
                continue;
            };
            let pname = pname.trim().trim_start_matches("mut ").trim();
            if MATRIX_TYPES.iter().any(|t| ty.contains(t)) && !allowed(pname) {
                let line = text[..start].lines().count() + 1;
                problems.push(format!(
                    "{rel}:{line}: `{name}` takes matrix `{pname}`: name it by the notation \
                     table (ARCHITECTURE.md) or by a descriptive word"
                ));
            }
        }
        let step = at + "pub fn ".len();
        rest = &rest[step..];
        offset += step;
    }
}

/// The text up to the `)` closing a parameter list whose `(` was just consumed.
fn balanced(s: &str) -> &str {
    let mut depth = 0usize;
    for (i, c) in s.char_indices() {
        match c {
            '(' | '[' | '<' => depth += 1,
            ')' if depth == 0 => return &s[..i],
            ')' | ']' | '>' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    s
}

/// Splits a parameter list at its top-level commas.
fn split_top(s: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let (mut depth, mut from) = (0usize, 0);
    for (i, c) in s.char_indices() {
        match c {
            '(' | '[' | '<' => depth += 1,
            ')' | ']' | '>' => depth = depth.saturating_sub(1),
            ',' if depth == 0 => {
                out.push(&s[from..i]);
                from = i + 1;
            }
            _ => {}
        }
    }
    out.push(&s[from..]);
    out
}

/// Runs [`check`] on every `.rs` file below `src`.
pub(crate) fn check_crate(root: &Path, files: &[std::path::PathBuf], src: &Path) -> Vec<String> {
    let mut problems = Vec::new();
    for f in files.iter().filter(|f| f.starts_with(src)) {
        if f.extension().is_some_and(|e| e == "rs")
            && let Ok(text) = std::fs::read_to_string(f)
        {
            let rel = f.strip_prefix(root).unwrap_or(f).display().to_string();
            check(&rel, &text, &mut problems);
        }
    }
    problems
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_matrix_parameters_off_the_table() {
        let text = "/// x\npub fn connect(k: &DMatrix<f64>, e: &DMatrix<f64>,\n    qd: \
                    MatRef<'_, f64>, n: usize, loop_gain: &DMatrix<f64>) {}\n\
                    pub fn dare(A: impl MatrixInput, P0: &Mat<f64>, x: f64) {}\n";
        let mut problems = Vec::new();
        check("m.rs", text, &mut problems);
        assert_eq!(problems.len(), 2, "{problems:?}");
        assert!(problems[0].starts_with("m.rs:2: `connect` takes matrix `e`"));
        assert!(problems[1].contains("matrix `qd`"));
    }

    #[test]
    fn symbols_in_either_case_and_words_are_allowed() {
        for ok in ["A", "a", "P0", "x0", "weights", "loop_gain", "cov"] {
            assert!(allowed(ok), "{ok}");
        }
        for bad in ["e", "qd", "L", "Ad", "T"] {
            assert!(!allowed(bad), "{bad}");
        }
    }
}
