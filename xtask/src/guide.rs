//! `cargo xtask docs`: builds the guide under `docs/` (an mdBook) into `target/guide/`,
//! installing `mdbook` with cargo into `target/tools/` the first time if it is not on `PATH`.

use std::path::PathBuf;
use std::process::Command;

use anyhow::{Context, Result};

use crate::{cargo, root, run};

/// The mdBook release the guide is built with (installed with `--locked`).
const MDBOOK: &str = "0.5.4";

/// The `mdbook` to run: the one on `PATH`, else the one under `target/tools/`, installed
/// there with cargo if it is missing.
fn mdbook() -> Result<PathBuf> {
    let on_path = Command::new("mdbook")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if on_path {
        return Ok(PathBuf::from("mdbook"));
    }
    let tools = root().join("target").join("tools");
    let bin = tools.join("bin").join("mdbook");
    if !bin.exists() {
        println!("xtask: installing mdbook {MDBOOK} into {}", tools.display());
        let mut cmd = cargo();
        cmd.args([
            "install",
            "mdbook",
            "--locked",
            "--version",
            MDBOOK,
            "--root",
        ])
        .arg(&tools);
        run(cmd).context("installing mdbook with cargo")?;
    }
    Ok(bin)
}

pub(crate) fn docs() -> Result<()> {
    let mut cmd = Command::new(mdbook()?);
    cmd.arg("build").arg(root().join("docs"));
    run(cmd).context("building the guide (mdbook build docs)")?;
    println!(
        "xtask: the guide is at {}",
        root().join("target/guide/index.html").display()
    );
    Ok(())
}
