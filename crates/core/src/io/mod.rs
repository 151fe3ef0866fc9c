//! File formats and safe writing: `.npy` stacks (memory-mapped), MATLAB `.mat` stacks (v5, and
//! v7.3 with the `mat73` feature; read, and written by `generate`), NetCDF-3 files, model folders, Parquet tables, and atomic writes (a temporary name in the same folder,
//! then a rename), so a reader never sees a half-written file; generated samples streamed with
//! direct I/O (`stream`); clutter stacks cut from scenes (`cut`); UAVSAR single-look complex scenes and
//! their annotations (`uavsar`); complex stacks in HDF5 files (`h5stack`); calibration
//! tables read at each pixel (`lut`); output folders the tool owns
//! (`outdir`: claim, lock, completeness; `journal`: what the tool wrote there); map coordinates
//! to pixels (`mapping`: affine transforms and ground control points; `projection`: SICD's
//! ground-to-image projection; `geogrid`: map coordinates at the nodes of a grid, as NISAR's
//! geolocation grid gives them).

pub mod atomic;
pub mod cut;
pub mod geogrid;
pub mod geotiff;
pub mod h5stack;
pub mod journal;
pub mod lut;
pub mod mapping;
pub mod mat;
pub mod model;
pub mod netcdf;
pub mod npy;
pub mod outdir;
pub mod polygon;
pub mod projection;
pub mod scenes;
pub mod sicd;
pub mod stream;
pub mod uavsar;
pub mod zarr;

/// What identifies a file's content without reading it: device, inode, size, and the
/// modification and change times in nanoseconds (the change time cannot be set back by a
/// user; any write moves it). Used by the job store's input-hash memo and by the hand-over of
/// an input's mapping from its hash to its load ([`npy::map_for_reading`]).
pub type FileId = (u64, u64, u64, i128, i128);

/// The [`FileId`] of a file's metadata.
pub fn file_id(m: &std::fs::Metadata) -> FileId {
    use std::os::unix::fs::MetadataExt;
    let ns = |s: i64, n: i64| i128::from(s) * 1_000_000_000 + i128::from(n);
    (
        m.dev(),
        m.ino(),
        m.len(),
        ns(m.mtime(), m.mtime_nsec()),
        ns(m.ctime(), m.ctime_nsec()),
    )
}

/// The text without a leading UTF-8 byte-order mark (some editors write one).
pub fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}
