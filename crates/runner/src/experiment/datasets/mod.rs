//! The dataset kinds: one file each, implementing [`DatasetKind`] (its spec fields as written,
//! their check into a validated dataset, its shape and input files, the sizes and cost the
//! estimates read, and its materialisation into a stack; `kind.rs`), and one line each in the
//! registration at the bottom of `registry.rs`, which makes the [`Dataset`] enum, the parsed
//! entry [`KindSpec`] and their dispatch. A method the trait requires has no default, and the
//! dispatch is generated, so a new kind that forgets one does not compile.
//!
//! A `datasets:` entry is parsed by [`DatasetSpec`]'s deserialiser: `id` and `kind`, then the
//! kind's own fields (its `Spec`, which refuses what it does not take, naming the field at its
//! YAML path and line).

mod cost;
mod filtered_noise;
mod geotiff;
mod hdf5;
mod kind;
mod kspace;
mod mat;
mod netcdf;
mod npy;
mod raw;
mod registry;
mod scenes;
mod sicd;
mod spec;
mod uavsar;
mod vegetation;

pub use cost::{
    chain_sizes, file_sizes, imaging_flops, mie, plant, scene_sizes, Blame, Cost, Plant, Sizes,
    C128, C64, USUAL_GRID, USUAL_HALF_WIDTH, USUAL_IMAGE_SIZE, USUAL_PIXELS, USUAL_SAMPLES,
};
pub use filtered_noise::{filter_bank, generate, Family, FilterParams, FilteredNoise};
pub use geotiff::GeotiffDataset;
pub use hdf5::Hdf5Dataset;
pub use kind::{DataError, DatasetKind, Layout, Materialised, SavedKspace};
pub use kspace::{KspaceDataset, Vector};
pub use mat::MatDataset;
pub use netcdf::NetcdfDataset;
pub use npy::NpyDataset;
pub use raw::RawDataset;
pub use registry::{Dataset, KindSpec};
pub use scenes::{Paths, SceneDataset, SceneFormat, WindowSpec};
pub use sicd::SicdDataset;
pub use spec::DatasetSpec;
pub use uavsar::UavsarDataset;
pub use vegetation::{MeasurementSpec, VegetationDataset};
