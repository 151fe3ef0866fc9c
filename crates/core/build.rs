//! Build script of the core crate: with the mat73 feature and a static libhdf5 (HDF5_DIR laid
//! out by the workspace's `make hdf5`), the libraries that libhdf5.a needs (szip, zlib, libm,
//! libdl), linked into every binary and test of every crate that depends on the core; and the
//! decision itself, passed to the build scripts of the crates that depend on it directly as
//! `DEP_ISAR_CLUTTER_CORE_HDF5_LINK` (`static` or `dynamic`).

fn main() {
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
            println!("cargo:rustc-link-lib={lib}");
        }
    }
    println!(
        "cargo:hdf5_link={}",
        if static_hdf5 { "static" } else { "dynamic" }
    );
}
