//! One home per numerical concept: each kernel, the PSD rule and the matrix exponential is
//! defined once in the library code, and every other place calls that definition.
//!
//! The check counts the definitions (`fn name(` / `fn name<`, `const NAME:`) of each concept
//! in the `src/` trees of the library crates, the program and the Python extension, and
//! reports every definition that is neither the concept's home nor a copy still listed in
//! [`KNOWN_COPIES`]. That list only shrinks: a listed copy that is gone is itself reported.

use std::path::{Path, PathBuf};

/// Each concept by the names its definitions go by, with the file that is its home.
const HOMES: &[(&str, &[&str], &str)] = &[
    (
        "symmetrisation (A + Aᵀ)/2",
        &["symmetrise", "symmetrize"],
        "numerics/src/lib.rs",
    ),
    (
        "dense Cholesky factorisation",
        &["cholesky", "llt"],
        "kalman/src/kernels.rs",
    ),
    (
        "the Cholesky solve L Lᵀ x = b",
        &["cholesky_solve", "chol_solve"],
        "kalman/src/kernels.rs",
    ),
    (
        "dense matrix product",
        &["gemm", "matmul"],
        "kalman/src/kernels.rs",
    ),
    (
        "the PSD rule",
        &["psd_factor", "check_psd", "is_psd"],
        "kalman/src/model.rs",
    ),
    ("the PSD tolerance", &["PSD_TOL"], "numerics/src/lib.rs"),
    (
        "the symmetry tolerance",
        &["SYMMETRY_TOL"],
        "numerics/src/lib.rs",
    ),
    ("the matrix exponential", &["expm"], "numerics/src/expm.rs"),
    ("Van Loan's integral", &["van_loan"], "numerics/src/expm.rs"),
];

/// Definitions beyond the home still present (`file: name`), each waiting for the change
/// that makes it call the home instead.
const KNOWN_COPIES: &[&str] = &[
    "kalman/src/fit/dense.rs: gemm",
    "model/src/analysis.rs: psd_factor",
];

/// The public face of `kalman`'s kernels for the other crates: its functions only forward to
/// the home (each body names `crate::kernels::` or `crate::model::`), so they are not copies.
const FACE: &str = "kalman/src/dense.rs";

/// Whether the definition at line `i` of `code` forwards to a home: its body, up to the
/// closing brace at the definition's indentation, calls into `crate::kernels` or
/// `crate::model` (in [`FACE`]), or into `numerics` (a crate's face in its own matrix types
/// over the shared home, anywhere).
fn forwards(code: &str, i: usize, in_face: bool) -> bool {
    code.lines().skip(i + 1).take_while(|l| *l != "}").any(|l| {
        l.contains("numerics::")
            || (in_face && (l.contains("crate::kernels::") || l.contains("crate::model::")))
    })
}

/// The source trees searched.
const TREES: &[&str] = &[
    "numerics/src",
    "model/src",
    "kalman/src",
    "wls/src",
    "sensors/src",
    "scenarios/src",
    "python/src",
];

/// The names `line` defines, of those in [`HOMES`].
fn defined(line: &str) -> Vec<&'static str> {
    let code = line.split("//").next().unwrap_or("").trim_start();
    let mut found = Vec::new();
    for (_, names, _) in HOMES {
        for &name in *names {
            let fn_def = ["(", "<"]
                .iter()
                .any(|end| code.contains(&format!("fn {name}{end}")));
            let const_def = code.contains(&format!("const {name}:"));
            if fn_def || const_def {
                found.push(name);
            }
        }
    }
    found
}

/// One line per definition that is neither a home nor a listed copy, and per listed copy
/// that is gone.
pub(crate) fn check(root: &Path, files: &[PathBuf]) -> Vec<String> {
    let mut problems = Vec::new();
    let mut seen = Vec::new();
    for path in files {
        let rel = path
            .strip_prefix(root)
            .unwrap_or(path)
            .to_string_lossy()
            .replace('\\', "/");
        if !TREES.iter().any(|t| rel.starts_with(t)) || !rel.ends_with(".rs") {
            continue;
        }
        let Ok(text) = std::fs::read_to_string(path) else {
            continue;
        };
        // The library code only: a file's inline unit tests may define helpers of their own
        // (a `#[cfg(test)] mod tests;` line pointing at another file does not end the code).
        let code = text.split("#[cfg(test)]\nmod tests {").next().unwrap_or("");
        for (i, line) in code.lines().enumerate() {
            for name in defined(line) {
                let (what, _, home) = HOMES
                    .iter()
                    .find(|(_, names, _)| names.contains(&name))
                    .copied()
                    .unwrap_or(("", &[], ""));
                let entry = format!("{rel}: {name}");
                seen.push(entry.clone());
                let face = !rel.starts_with("numerics/") && forwards(code, i, rel == FACE);
                if rel != home && !face && !KNOWN_COPIES.contains(&entry.as_str()) {
                    problems.push(format!(
                        "{rel}:{}: a second definition of {what} (`{name}`): call the one in {home}",
                        i + 1
                    ));
                }
            }
        }
    }
    for copy in KNOWN_COPIES {
        if !seen.iter().any(|s| s == copy) {
            problems.push(format!(
                "`{copy}` is gone: remove it from KNOWN_COPIES in xtask/src/homes.rs"
            ));
        }
    }
    problems
}

#[cfg(test)]
mod tests {
    use super::defined;

    #[test]
    fn a_definition_is_found_and_a_call_is_not() {
        assert_eq!(
            defined("pub(crate) fn symmetrise(a: &mut [f64], n: usize) {"),
            ["symmetrise"]
        );
        assert_eq!(defined("pub fn expm<T>(a: T) -> Mat<f64> {"), ["expm"]);
        assert_eq!(defined("pub const PSD_TOL: f64 = 1e-10;"), ["PSD_TOL"]);
        assert!(defined("    kernels::symmetrise(&mut p, n);").is_empty());
        assert!(defined("// fn expm( in a comment").is_empty());
        assert!(defined("let tol = PSD_TOL * lmax;").is_empty());
    }
}
