//! File formats and safe writing: `.npy` stacks (memory-mapped), MATLAB `.mat` stacks (v5, and
//! v7.3 with the `mat73` feature; read, and written by `generate`), NetCDF-3 files, model folders, Parquet tables, and atomic writes (a temporary name in the same folder,
//! then a rename), so a reader never sees a half-written file; generated samples streamed with
//! direct I/O (`stream`); output folders the tool owns
//! (`outdir`: claim, lock, journal of what it wrote, completeness).

pub mod atomic;
pub mod mat;
pub mod model;
pub mod netcdf;
pub mod npy;
pub mod outdir;
pub mod stream;
