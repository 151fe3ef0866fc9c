//! File formats: everything of the core crate's [`isar_clutter_core::io`] (`.npy`, `.mat`,
//! NetCDF, UAVSAR scenes, model folders, atomic writes, output folders and their journal),
//! re-exported under the same paths, the runner's Parquet tables ([`parquet`]), which the core
//! crate leaves out so that it compiles without polars, the job store's fragments ([`frame`]),
//! big tables written a row group at a time ([`groups`]), and the results folder's contract:
//! its tables ([`results`]) and its manifest ([`manifest`]).

pub use isar_clutter_core::io::{
    atomic, cut, file_id, geotiff, h5stack, journal, mapping, mat, model, netcdf, npy, outdir,
    polygon, scenes, sicd, stream, strip_bom, uavsar, zarr, FileId,
};

pub mod frame;
pub mod groups;
pub mod manifest;
pub mod parquet;
pub mod results;
