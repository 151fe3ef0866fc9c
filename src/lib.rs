//! isar-clutter: a declarative batch experiment runner for the multiscale modelling and
//! simulation of clutter in ISAR imaging (Mitchell, 2020). A YAML spec names datasets and
//! analysis settings; the plan expands sweeps into seeded jobs; the scheduler runs them and the
//! table assembly writes Parquet tables, `.npy` maps, a manifest and a report.
//!
//! The folders follow the data flow (`docs/architecture.md` draws it, with the rules of which
//! module may import which):
//!
//! - [`experiment`]: the spec, the YAML a user writes, parsed and validated section by section;
//! - [`run`]: plan (sweeps, job ids, seeds), the job kinds, the scheduler, table assembly, manifest;
//! - [`data`]: datasets materialised into stacks (files, filtered noise, simulated plants);
//! - [`io`]: file formats (`.npy`, NetCDF, model folders) and atomic writes;
//! - [`physics`]: the ISAR imaging chain, Mie series, calibration, the vegetation stand-in;
//! - [`stats`]: multiscale analysis, filters, metrics, CMD, similarity, samplers, slow oracles;
//! - [`synthesis`]: fit a model to a stack, generate new samples;
//! - [`apps`]: what is built on the statistics: the hypothesis tests (ch. 5.1);
//! - [`report`]: figures, the HTML report and the comparison tables;
//! - [`seeds`]: seed derivation and random streams, usable from every layer;
//! - [`alloc`]: the binary's allocator (large blocks mapped from the kernel).

#![warn(missing_docs)]

pub mod apps;
pub mod data;
pub mod experiment;
pub mod io;
pub mod report;
pub mod reproduction;
pub mod run;

pub use isar_clutter_core::{alloc, physics, seeds, stats, synthesis, workflow};

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
