//! Build script of the runner: records the git commit of the source tree and whether tracked
//! files differed from it when the crate was built, for the provenance in every run's
//! `manifest.json` (`ISAR_CLUTTER_GIT_COMMIT`, `ISAR_CLUTTER_GIT_DIRTY`; empty outside a git
//! checkout).

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    for path in [
        "../../src",
        "../../crates",
        "../../Cargo.toml",
        "../../Cargo.lock",
        // compiled in (the plants' calibration record, the reproduction's references): a
        // change there changes results, so it must mark the build dirty too
        "../../reproduction",
        "../../.git/HEAD",
        "../../.git/index",
        "../../.git/refs",
    ] {
        println!("cargo:rerun-if-changed={path}");
    }
    let commit = git(&["rev-parse", "HEAD"]).unwrap_or_default();
    let dirty = if commit.is_empty() {
        String::new()
    } else {
        git(&["status", "--porcelain", "--untracked-files=no"])
            .map(|s| (!s.is_empty()).to_string())
            .unwrap_or_default()
    };
    println!("cargo:rustc-env=ISAR_CLUTTER_GIT_COMMIT={commit}");
    println!("cargo:rustc-env=ISAR_CLUTTER_GIT_DIRTY={dirty}");
}
