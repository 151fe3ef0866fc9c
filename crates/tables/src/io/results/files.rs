//! Where a run puts its jobs' files beside the tables, named once for the runner that writes
//! them and the report that reads them (`out` is the run's folder).

use std::path::{Path, PathBuf};

/// `maps/`: one folder of `.npy` maps per job ([`super::maps`]).
pub fn maps_root(out: &Path) -> PathBuf {
    out.join("maps")
}

/// `maps/<job>/`: the maps of one job.
pub fn maps(out: &Path, job: &str) -> PathBuf {
    maps_root(out).join(job)
}

/// `maps.zarr/`: every job's maps in one Zarr v3 store (`outputs: {zarr_maps: true}`).
pub fn maps_zarr(out: &Path) -> PathBuf {
    out.join("maps.zarr")
}

/// `jobs/maps/<job>.chunks`: one job's maps staged for the Zarr store, in the job store (kept
/// for a resumed run's merge, not a result file).
pub fn staged_maps(out: &Path, job: &str) -> PathBuf {
    out.join("jobs").join("maps").join(format!("{job}.chunks"))
}

/// `samples/`: the generated samples of the synthesis jobs.
pub fn samples_root(out: &Path) -> PathBuf {
    out.join("samples")
}

/// `samples/<job>.npy`: one synthesis job's generated samples.
pub fn samples(out: &Path, job: &str) -> PathBuf {
    samples_root(out).join(format!("{job}.npy"))
}

/// `models/<job>/`: one synthesis job's fitted model.
pub fn model(out: &Path, job: &str) -> PathBuf {
    out.join("models").join(job)
}

/// `kspace/`: the k-space data of imaged datasets' analysis jobs.
pub fn kspace_root(out: &Path) -> PathBuf {
    out.join("kspace")
}

/// The suffix of a job's mean k-space image, `kspace/<job>.mean.npy` (Fig. 48).
pub const KSPACE_MEAN: &str = ".mean";

/// `kspace/<job><suffix>.npy`: one of a job's k-space arrays (`suffix` empty for the
/// data, `.freqs`, `.azimuths_deg`, `.mean`).
pub fn kspace(out: &Path, job: &str, suffix: &str) -> PathBuf {
    kspace_root(out).join(format!("{job}{suffix}.npy"))
}

/// `examples/<job>.npy`: a location training's example images (Fig. 72).
pub fn example(out: &Path, job: &str) -> PathBuf {
    out.join("examples").join(format!("{job}.npy"))
}

/// `networks/<job>/`: a CNN training's saved network.
pub fn network(out: &Path, job: &str) -> PathBuf {
    out.join("networks").join(job)
}
