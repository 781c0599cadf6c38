//! The Python package's tests: builds `python/` into a cached venv with maturin and runs its
//! pytest suite (FilterPy side by side, bad inputs). Part of `cargo xtask test`.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::{root, run};

/// What the venv holds: the build tool, the package's one dependency, the test runner and
/// the reference implementation the tests compare against. The venv's directory name is a
/// hash of this list (and of the interpreter's version), so changing it makes a new venv.
const REQUIREMENTS: &[&str] = &[
    "maturin>=1.9.4,<2",
    "numpy>=1.23",
    "pytest>=8",
    "filterpy==2.0.0",
];

/// The FilterPy release whose own test files the conformance run takes from its source
/// distribution (the same version as the venv's, whose other names those files still use).
const FILTERPY_SDIST: &str = "filterpy==2.0.0";

/// The interpreter to build the venv from: `$PYTHON`, else `python3`, else `python`.
fn interpreter() -> Result<(String, String)> {
    let candidates: Vec<String> = match std::env::var("PYTHON") {
        Ok(p) => vec![p],
        Err(_) => vec!["python3".into(), "python".into()],
    };
    for cand in &candidates {
        let out = Command::new(cand)
            .args([
                "-c",
                "import sys; print('%d.%d.%d' % sys.version_info[:3]); \
                 assert sys.version_info >= (3, 11)",
            ])
            .output();
        if let Ok(out) = out
            && out.status.success()
        {
            let version = String::from_utf8_lossy(&out.stdout).trim().to_string();
            return Ok((cand.clone(), version));
        }
    }
    bail!(
        "no Python 3.11 or later found ({}): the Python package's tests need one with the venv \
         module; install it or point $PYTHON at it",
        candidates.join(", ")
    )
}

/// FNV-1a over the requirement list and the interpreter version.
fn key(version: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in REQUIREMENTS.iter().copied().chain([version]) {
        for b in part.bytes().chain([0u8]) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{h:016x}")
}

/// The venv's interpreter (`bin/python`, or `Scripts/python.exe` on Windows).
fn venv_python(venv: &Path) -> PathBuf {
    if cfg!(windows) {
        venv.join("Scripts").join("python.exe")
    } else {
        venv.join("bin").join("python")
    }
}

/// Creates (once) the venv with [`REQUIREMENTS`] under `target/`, returning its path.
fn venv() -> Result<PathBuf> {
    let (python, version) = interpreter()?;
    let venv = root()
        .join("target")
        .join(format!("python-venv-{}", key(&version)));
    let ready = venv.join(".requirements-installed");
    if ready.exists() {
        return Ok(venv);
    }
    if venv.exists() {
        std::fs::remove_dir_all(&venv)
            .with_context(|| format!("removing the unfinished venv {}", venv.display()))?;
    }
    let mut cmd = Command::new(&python);
    cmd.args(["-m", "venv"]).arg(&venv);
    run(cmd).context("creating the venv for the Python tests")?;
    let mut cmd = Command::new(venv_python(&venv));
    cmd.args(["-m", "pip", "install", "--quiet"])
        .args(REQUIREMENTS);
    run(cmd).context("installing the Python test requirements from PyPI")?;
    std::fs::write(&ready, REQUIREMENTS.join("\n"))
        .with_context(|| format!("writing {}", ready.display()))?;
    Ok(venv)
}

/// Downloads (once) FilterPy's source distribution into `target/filterpy-sdist/`, returning
/// the archive's path: the conformance run (`tests/test_filterpy_suite.py`) takes FilterPy's
/// own test files from it. Nothing is installed; pip only fetches the archive.
fn filterpy_sdist(venv: &Path) -> Result<PathBuf> {
    let dir = root().join("target").join("filterpy-sdist");
    let version = FILTERPY_SDIST.trim_start_matches("filterpy==");
    let archive = dir.join(format!("filterpy-{version}.tar.gz"));
    if archive.exists() {
        return Ok(archive);
    }
    let mut cmd = Command::new(venv_python(venv));
    cmd.args([
        "-m",
        "pip",
        "download",
        "--quiet",
        "--no-deps",
        "--no-binary",
        ":all:",
    ])
    .arg("--dest")
    .arg(&dir)
    .arg(FILTERPY_SDIST);
    run(cmd).context("downloading FilterPy's source distribution from PyPI")?;
    if !archive.exists() {
        bail!("pip download left no {}", archive.display());
    }
    Ok(archive)
}

/// Builds the extension into the venv (a debug build: it reuses the workspace's optimised
/// dependencies, so only the bindings compile) and runs the pytest suite.
pub(crate) fn test() -> Result<()> {
    let venv = venv()?;
    let bin = venv_python(&venv)
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let path = std::env::join_paths(std::iter::once(bin.clone()).chain(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    )))
    .context("building PATH for the venv")?;
    let mut cmd = Command::new(venv_python(&venv));
    cmd.current_dir(root().join("python"))
        .args(["-m", "maturin", "develop", "--quiet"])
        .env("VIRTUAL_ENV", &venv)
        .env("PATH", &path);
    run(cmd).context("building the Python package (maturin develop)")?;
    let sdist = filterpy_sdist(&venv)?;
    let mut cmd = Command::new(venv_python(&venv));
    cmd.current_dir(root().join("python"))
        .args(["-m", "pytest", "-q", "tests"])
        .env("FILTERPY_SDIST", &sdist)
        .env("VIRTUAL_ENV", &venv)
        .env("PATH", &path);
    run(cmd).context("the Python package's tests (pytest)")
}
