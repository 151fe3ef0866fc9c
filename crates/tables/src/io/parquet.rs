//! Parquet tables of a results folder, read whole and written atomically (Snappy-compressed,
//! through the core crate's [`atomic_write`]). The runner's and the report's only door to
//! Parquet files; the core crate knows nothing of polars.

use anyhow::{Context, Result};
use isar_clutter_core::io::atomic::atomic_write;
use polars::prelude::*;
use std::fs::File;
use std::path::Path;

/// Reads a Parquet table of a results folder; `Ok(None)` if the file does not exist.
///
/// # Errors
/// If the file exists but cannot be opened or read; the message names it.
pub fn read_parquet(path: &Path) -> Result<Option<DataFrame>> {
    if !path.exists() {
        return Ok(None);
    }
    let file = File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let df = anyhow::Context::with_context(ParquetReader::new(file).finish(), || {
        format!("reading {}", path.display())
    })?;
    Ok(Some(df))
}

/// Writes a DataFrame as Parquet (Snappy-compressed), atomically.
///
/// # Errors
/// If writing fails.
pub fn write_parquet(path: &Path, df: &mut DataFrame) -> Result<()> {
    atomic_write(path, |w| {
        ParquetWriter::new(w)
            .with_compression(ParquetCompression::Snappy)
            .set_parallel(false)
            .finish(df)?;
        Ok(())
    })
}
