//! isar-clutter-core: the science of isar-clutter without its runner. The multiscale
//! statistics of a stack of complex ISAR images (Haar coefficient variances, directional
//! correlations, metrics, similarity), the correlating filters and the five synthesis methods
//! (fit a model, generate samples), the ISAR imaging chain and the vegetation stand-in, seeds
//! and ChaCha random streams, and the file formats that `fit` and `generate` need (`.npy`,
//! `.mat`, NetCDF, model folders, atomic writes, output folders). It compiles without polars,
//! burn, plotters or clap: the runner, the report and the networks live in the `isar-clutter`
//! crate above it, and the Python bindings build on this crate alone.
//!
//! - [`seeds`]: seed derivation and random streams, usable from every layer;
//! - [`stats`]: multiscale analysis, filters, metrics, CMD, similarity, samplers, slow oracles;
//! - [`synthesis`]: fit a model to a stack, generate new samples;
//! - [`physics`]: the ISAR imaging chain, Mie series, calibration, the vegetation stand-in;
//! - [`io`]: file formats and atomic writes;
//! - [`workflow`]: `fit` and `generate` from files to files (the model-folder policy);
//! - [`resources`]: the machine's memory, free disk and threads, read before a command spends them;
//! - [`alloc`]: the allocator of the binaries (large blocks mapped from the kernel) and fallible
//!   allocation of stacks.

#![warn(missing_docs)]

/// The tool's name, as its output folders' markers and manifests record it (the name of the
/// binary and of the top crate, whichever crate writes it).
pub const TOOL: &str = "isar-clutter";

pub mod alloc;
pub mod io;
pub mod location_grid;
pub mod physics;
pub mod resources;
pub mod seeds;
pub mod stats;
pub mod synthesis;
pub mod workflow;

/// An error and its causes as one line, `context: cause: root` as anyhow's `{:#}` prints them,
/// except that a cause whose text the line already ends with is left out: some libraries put
/// their cause in their own message and give it as `source()` too (ndarray-npy's
/// `I/O error: {e}`), which `{:#}` printed twice (`... (os error 28): No space left on device
/// (os error 28)`). The messages of `main` and of failed jobs are written with it.
pub fn error_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let part = cause.to_string();
        if text.is_empty() {
            text = part;
        } else if !text.ends_with(&part) {
            text.push_str(": ");
            text.push_str(&part);
        }
    }
    text
}
