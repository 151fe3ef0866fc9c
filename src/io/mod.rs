//! File formats: everything of the core crate's [`isar_clutter_core::io`] (`.npy`, `.mat`,
//! NetCDF, model folders, atomic writes, output folders and their journal), re-exported under
//! the same paths, and the runner's Parquet tables ([`parquet`]), which the core crate leaves
//! out so that it compiles without polars.

pub use isar_clutter_core::io::*;

pub mod parquet;
