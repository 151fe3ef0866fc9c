//! Build script: records the git commit of the source tree and whether tracked files differed
//! from it when the binary was built, for the provenance in every run's `manifest.json`
//! (`ISAR_CLUTTER_GIT_COMMIT`, `ISAR_CLUTTER_GIT_DIRTY`; empty outside a git checkout).

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    // The binary is linked as a position-dependent executable on x86-64 Linux: a PIE of this
    // size (polars) carries about 63,000 relocations that the loader applies at every start,
    // touching about 1.4 MB of pages (3 ms of a 20 ms run on the development VM).
    let target = std::env::var("TARGET").unwrap_or_default();
    if target == "x86_64-unknown-linux-gnu" {
        println!("cargo:rustc-link-arg-bins=-no-pie");
    }
    // mat73 with a static libhdf5 (HDF5_DIR laid out by `make hdf5`): the libraries that
    // libhdf5.a needs, after it on the link line.
    println!("cargo:rerun-if-env-changed=HDF5_DIR");
    // Static where HDF5_DIR's lib/ holds the archive and no shared library (the linker would
    // take the shared one).
    let static_hdf5 = std::env::var_os("CARGO_FEATURE_MAT73").is_some()
        && std::env::var_os("HDF5_DIR").is_some_and(|dir| {
            let lib = std::path::Path::new(&dir).join("lib");
            lib.join("libhdf5.a").exists() && !lib.join("libhdf5.so").exists()
        });
    if static_hdf5 {
        for lib in ["sz", "z", "m", "dl"] {
            println!("cargo:rustc-link-arg=-l{lib}");
        }
    }
    // For the test that the binary does not load libhdf5 at start (tests/mat.rs).
    println!(
        "cargo:rustc-env=ISAR_CLUTTER_HDF5_LINK={}",
        if static_hdf5 { "static" } else { "dynamic" }
    );
    for path in [
        "src",
        "crates",
        "Cargo.toml",
        "Cargo.lock",
        "build.rs",
        ".git/HEAD",
        ".git/index",
        ".git/refs",
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
