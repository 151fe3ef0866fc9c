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
    // mat73 with a static libhdf5 (HDF5_DIR laid out by `make hdf5`); the libraries that
    // libhdf5.a needs come from the core crate's build script (linked into every dependent).
    println!("cargo:rerun-if-env-changed=HDF5_DIR");
    // Static where HDF5_DIR's lib/ holds the archive and no shared library (the linker would
    // take the shared one).
    let static_hdf5 = std::env::var_os("CARGO_FEATURE_MAT73").is_some()
        && std::env::var_os("HDF5_DIR").is_some_and(|dir| {
            let lib = std::path::Path::new(&dir).join("lib");
            lib.join("libhdf5.a").exists() && !lib.join("libhdf5.so").exists()
        });
    // For the test that the binary does not load libhdf5 at start (tests/mat.rs).
    println!(
        "cargo:rustc-env=ISAR_CLUTTER_HDF5_LINK={}",
        if static_hdf5 { "static" } else { "dynamic" }
    );
    println!("cargo:rerun-if-changed=build.rs");
}
