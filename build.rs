//! Build script of the binary: links it as a position-dependent executable, and tells the
//! tests whether libhdf5 is linked statically (`ISAR_CLUTTER_HDF5_LINK`). The git commit of the
//! provenance is the runner's build script's (crates/runner/build.rs).

fn main() {
    // The binary is linked as a position-dependent executable on x86-64 Linux: a PIE of this
    // size (polars) carries about 63,000 relocations that the loader applies at every start,
    // touching about 1.4 MB of pages (3 ms of a 20 ms run on the development VM).
    let target = std::env::var("TARGET").unwrap_or_default();
    if target == "x86_64-unknown-linux-gnu" {
        println!("cargo:rustc-link-arg-bins=-no-pie");
    }
    // How libhdf5 is linked, as the core crate's build script decided (static with mat73 and
    // an HDF5_DIR holding only the archive; the libraries libhdf5.a needs come from there too).
    let link =
        std::env::var("DEP_ISAR_CLUTTER_CORE_HDF5_LINK").unwrap_or_else(|_| "dynamic".into());
    // For the test that the binary does not load libhdf5 at start (tests/mat.rs).
    println!("cargo:rustc-env=ISAR_CLUTTER_HDF5_LINK={link}");
    println!("cargo:rerun-if-changed=build.rs");
}
