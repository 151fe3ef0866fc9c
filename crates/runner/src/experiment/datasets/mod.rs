//! The dataset kinds: one file each, implementing [`DatasetKind`] (its spec fields as written,
//! their check into a validated dataset, its shape and input files, the sizes and cost the
//! estimates read, and its materialisation into a stack), and one line each in the
//! registration at the bottom of this file, which makes the [`Dataset`] enum, the parsed
//! entry [`KindSpec`] and their dispatch. A method the trait requires has no default, and the
//! dispatch is generated, so a new kind that forgets one does not compile.
//!
//! A `datasets:` entry is parsed by [`DatasetSpec`]'s deserialiser: `id` and `kind`, then the
//! kind's own fields (its `Spec`, which refuses what it does not take, naming the field at its
//! YAML path and line).

use super::{check_levels, Ctx, SpecError};
use crate::io::npy::{NpyError, Stack};
use crate::stats::filters::FilterBank;
use ndarray::{Array2, Array3};
use num_complex::Complex64;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::PathBuf;

mod cost;
mod filtered_noise;
mod kspace;
mod mat;
mod netcdf;
mod npy;
mod raw;
mod spec;
mod vegetation;

pub use cost::{
    chain_sizes, file_sizes, imaging_flops, mie, plant, scene_sizes, Blame, Cost, Plant, Sizes,
    C128, C64, USUAL_GRID, USUAL_HALF_WIDTH, USUAL_IMAGE_SIZE, USUAL_PIXELS, USUAL_SAMPLES,
};
pub use filtered_noise::{filter_bank, generate, Family, FilterParams, FilteredNoise};
pub use kspace::{KspaceDataset, Vector};
pub use mat::MatDataset;
pub use netcdf::NetcdfDataset;
pub use npy::NpyDataset;
pub use raw::RawDataset;
pub use spec::DatasetSpec;
pub use vegetation::{MeasurementSpec, VegetationDataset};

/// One kind of dataset (`kind: <NAME>` in a spec). Every method is required.
pub trait DatasetKind: Sized + Clone + fmt::Debug + PartialEq + Send + Sync {
    /// The kind's name in specs and tables (`filtered_noise`).
    const NAME: &'static str;
    /// Every field its spec takes besides `id` and `kind`.
    const FIELDS: &'static [&'static str];
    /// The field blamed when the stack has fewer than 2 samples.
    const SAMPLES_FIELD: &'static str;
    /// Its fields as written (serde; every field optional where the check gives the message).
    type Spec: DeserializeOwned + Serialize + Clone + fmt::Debug + PartialEq;

    /// The fields that apply to `spec` (a sweep over `datasets.*.<field>` sets them): all of
    /// [`Self::FIELDS`], or those of its variant (a filter family).
    fn applies(spec: &Self::Spec) -> &'static [&'static str];
    /// Validates the fields (`at` is the entry's YAML path, e.g. `datasets[0]`): ranges, files
    /// (shapes from their headers), presets.
    ///
    /// # Errors
    /// A [`SpecError`] at the offending field's YAML path.
    fn check(spec: &Self::Spec, ctx: &Ctx, at: &str) -> Result<Self, SpecError>;
    /// `(N, H, W)` of the stack it yields.
    fn shape(&self) -> (usize, usize, usize);
    /// The files it reads (their content hashes go into its jobs' store keys).
    fn input_files(&self) -> Vec<PathBuf>;
    /// Whether the jobs of one group share one materialised copy (simulated or decoded data);
    /// not a mapped `.npy` (free) nor synthetic noise (cheap next to its jobs).
    fn worth_sharing(&self) -> bool;
    /// Whether a noise floor can draw it again: `Some(true)` cheaply (the default floor),
    /// `Some(false)` at its own cost (only when `draws` is asked for), `None` never.
    fn redrawable(&self) -> Option<bool>;
    /// The k-space grid `(frequencies, azimuths)` of data imaged from k-space, whose analysis
    /// jobs write the mean k-space image (`kspace/<job>.mean.npy`, drawn by the report).
    fn kspace_grid(&self) -> Option<(usize, usize)>;
    /// The half-width of a known uniform filter whose exact lag correlations the analysis
    /// writes (`filter_correlation.parquet`); `None` for data without one.
    fn known_filter(&self) -> Option<usize>;
    /// Records the sizes of its spec (at YAML path `at`) that its materialisation reads.
    fn sizes(&self, at: &str, s: &mut Sizes);
    /// Bytes and work of its materialisation.
    fn cost(&self) -> Cost;
    /// Bytes and work of an independent draw of `samples` samples (zero where
    /// [`Self::redrawable`] is `None`).
    fn redraw_cost(&self, samples: usize) -> Cost;
    /// Loads or generates its stack (`data_seed`: the job's data seed).
    ///
    /// # Errors
    /// [`DataError`] if a file cannot be read or the stack does not fit in memory.
    fn materialise(&self, data_seed: u64) -> Result<Materialised, DataError>;
    /// An independent draw of `samples` samples with `seed` (`data`: its materialisation, for
    /// what a draw reuses), as complex128 `[N, H, W]`; `None` where it cannot be drawn again.
    ///
    /// # Errors
    /// As [`Self::materialise`].
    fn redraw(
        &self,
        samples: usize,
        seed: u64,
        data: &Materialised,
    ) -> Option<Result<Array3<Complex64>, DataError>>;
}

/// Axis order of an `npy`, `mat` or `raw` stack.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// `[N, H, W]` (the default of `npy`).
    #[default]
    Nhw,
    /// `[H, W, N]` (MATLAB's `H x W x N`, the default of `mat`).
    Hwn,
}

impl Layout {
    /// `(N, H, W)` of a stack stored with dimensions `[a, b, c]` in this order.
    pub fn stack_shape(self, [a, b, c]: [usize; 3]) -> (usize, usize, usize) {
        match self {
            Layout::Nhw => (a, b, c),
            Layout::Hwn => (c, a, b),
        }
    }
}

/// Why a dataset cannot be materialised.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A file cannot be read or decoded, or the imaging fails on its data.
    #[error(transparent)]
    Npy(#[from] NpyError),
    /// A MATLAB file's variable cannot be read.
    #[error(transparent)]
    Mat(#[from] crate::io::mat::MatError),
    /// A stack does not fit in memory.
    #[error(transparent)]
    Alloc(#[from] crate::alloc::AllocError),
}

/// Simulated k-space data an analysis job writes (`kspace/<job>.npy`, with the frequencies in
/// Hz and the azimuths in degrees beside it).
pub struct SavedKspace {
    /// `E(f, phi)`, `[N, n_f, n_phi]`.
    pub data: Array3<Complex64>,
    /// Frequencies (Hz).
    pub freqs: Vec<f64>,
    /// Azimuths (degrees).
    pub azimuths_deg: Vec<f64>,
}

/// A dataset ready for analysis.
pub struct Materialised {
    /// The stack.
    pub stack: Stack,
    /// Whether the stack's axes are `[H, W, N]`.
    pub hwn: bool,
    /// For synthetic data: the filter bank and the standard-deviation map (the ground truth).
    pub truth: Option<(FilterBank, Array2<f64>)>,
    /// For `vegetation_isar` with `save_kspace`: the simulated k-space data.
    pub kspace: Option<SavedKspace>,
    /// For data imaged from k-space: the mean over the samples of `E(f, phi)`, `[n_f, n_phi]`
    /// (the dissertation's mean k-space image, Fig. 48).
    pub mean_kspace: Option<Array2<Complex64>>,
}

impl Materialised {
    /// A stack with nothing beside it.
    pub fn plain(stack: Stack, hwn: bool) -> Self {
        Materialised {
            stack,
            hwn,
            truth: None,
            kspace: None,
            mean_kspace: None,
        }
    }
}

impl DatasetSpec {
    /// Validates one dataset (`at` is its YAML path, e.g. `datasets[0]`): its id, its kind's
    /// fields, at least 2 samples, and `levels` within its image size.
    ///
    /// # Errors
    /// A [`SpecError`] at the offending field's YAML path.
    pub fn check(&self, ctx: &Ctx, at: &str, levels: usize) -> Result<Dataset, SpecError> {
        if self.id.is_empty()
            || !self
                .id
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "_-".contains(c))
        {
            return Err(ctx.err(
                format!("{at}.id"),
                format!(
                    "dataset id {:?} must be non-empty ASCII letters, digits, `_` or `-`",
                    self.id
                ),
            ));
        }
        let dataset = self.kind.check(ctx, at)?;
        let (n, h, w) = dataset.shape();
        if n < 2 {
            return Err(ctx.err(
                format!("{at}.{}", self.kind.samples_field()),
                format!("the stack has {n} sample(s); at least 2 are needed"),
            ));
        }
        check_levels(levels, h, w)
            .map_err(|e| ctx.err("analysis.levels", format!("dataset {}: {e}", self.id)))?;
        Ok(dataset)
    }

    /// The fields that apply to this dataset besides `id` and `kind`.
    pub fn fields(&self) -> &'static [&'static str] {
        self.kind.applies()
    }
}

/// Makes [`Dataset`] and [`KindSpec`] from the registered kinds, and their dispatch.
macro_rules! register {
    ($($variant:ident($kind:ty),)+) => {
        /// A validated dataset, of one of the registered kinds.
        #[derive(Debug, Clone, PartialEq)]
        pub enum Dataset {
            $(
                #[doc = concat!("A `", stringify!($variant), "` dataset.")]
                $variant(Box<$kind>),
            )+
        }

        /// A dataset entry's kind and fields as written.
        #[derive(Debug, Clone, PartialEq)]
        pub enum KindSpec {
            $(
                #[doc = concat!("The fields of a `", stringify!($variant), "` dataset.")]
                $variant(Box<<$kind as DatasetKind>::Spec>),
            )+
        }

        /// Every kind's name, in registration order.
        pub const KIND_NAMES: &[&str] = &[$(<$kind as DatasetKind>::NAME,)+];

        /// Every field some kind takes (to tell a field of another kind from a typo).
        pub(crate) const KIND_FIELDS: &[&[&str]] = &[$(<$kind as DatasetKind>::FIELDS,)+];

        impl KindSpec {
            /// Parses the fields of kind `name` from `fields` (a map's remaining entries).
            pub(crate) fn parse<'de, D: serde::Deserializer<'de>>(
                name: &str,
                fields: D,
            ) -> Result<KindSpec, D::Error> {
                $(
                    if name == <$kind as DatasetKind>::NAME {
                        return <<$kind as DatasetKind>::Spec as Deserialize>::deserialize(fields)
                            .map(|s| KindSpec::$variant(Box::new(s)));
                    }
                )+
                Err(serde::de::Error::unknown_variant(name, KIND_NAMES))
            }

            /// The fields the kind `name` takes (`None`: no such kind).
            pub(crate) fn fields_of(name: &str) -> Option<&'static [&'static str]> {
                $(
                    if name == <$kind as DatasetKind>::NAME {
                        return Some(<$kind as DatasetKind>::FIELDS);
                    }
                )+
                None
            }

            /// The kind's name.
            pub fn name(&self) -> &'static str {
                match self { $(KindSpec::$variant(_) => <$kind as DatasetKind>::NAME,)+ }
            }

            /// The fields that apply to these values.
            pub fn applies(&self) -> &'static [&'static str] {
                match self { $(KindSpec::$variant(s) => <$kind as DatasetKind>::applies(s),)+ }
            }

            /// The field blamed for too few samples.
            fn samples_field(&self) -> &'static str {
                match self {
                    $(KindSpec::$variant(_) => <$kind as DatasetKind>::SAMPLES_FIELD,)+
                }
            }

            /// The values as written, for serialisation.
            pub(crate) fn to_value(&self) -> serde_yaml_ng::Value {
                match self {
                    $(KindSpec::$variant(s) => {
                        serde_yaml_ng::to_value(s).expect("dataset fields serialise")
                    })+
                }
            }

            /// Validates the fields into a [`Dataset`].
            ///
            /// # Errors
            /// The kind's [`DatasetKind::check`] error.
            pub fn check(&self, ctx: &Ctx, at: &str) -> Result<Dataset, SpecError> {
                Ok(match self {
                    $(KindSpec::$variant(s) => {
                        Dataset::$variant(Box::new(<$kind as DatasetKind>::check(s, ctx, at)?))
                    })+
                })
            }
        }

        impl Dataset {
            /// The kind name used in specs and tables.
            pub fn kind(&self) -> &'static str {
                match self { $(Dataset::$variant(_) => <$kind as DatasetKind>::NAME,)+ }
            }
            /// See [`DatasetKind::shape`].
            pub fn shape(&self) -> (usize, usize, usize) {
                match self { $(Dataset::$variant(d) => d.shape(),)+ }
            }
            /// See [`DatasetKind::input_files`].
            pub fn input_files(&self) -> Vec<PathBuf> {
                match self { $(Dataset::$variant(d) => d.input_files(),)+ }
            }
            /// See [`DatasetKind::worth_sharing`].
            pub fn worth_sharing(&self) -> bool {
                match self { $(Dataset::$variant(d) => d.worth_sharing(),)+ }
            }
            /// See [`DatasetKind::redrawable`].
            pub fn redrawable(&self) -> Option<bool> {
                match self { $(Dataset::$variant(d) => d.redrawable(),)+ }
            }
            /// See [`DatasetKind::kspace_grid`].
            pub fn kspace_grid(&self) -> Option<(usize, usize)> {
                match self { $(Dataset::$variant(d) => d.kspace_grid(),)+ }
            }
            /// See [`DatasetKind::known_filter`].
            pub fn known_filter(&self) -> Option<usize> {
                match self { $(Dataset::$variant(d) => d.known_filter(),)+ }
            }
            /// See [`DatasetKind::sizes`].
            pub fn sizes(&self, at: &str, s: &mut Sizes) {
                match self { $(Dataset::$variant(d) => d.sizes(at, s),)+ }
            }
            /// See [`DatasetKind::cost`].
            pub fn cost(&self) -> Cost {
                match self { $(Dataset::$variant(d) => d.cost(),)+ }
            }
            /// See [`DatasetKind::redraw_cost`].
            pub fn redraw_cost(&self, samples: usize) -> Cost {
                match self { $(Dataset::$variant(d) => d.redraw_cost(samples),)+ }
            }
            /// See [`DatasetKind::materialise`].
            ///
            /// # Errors
            /// As there.
            pub fn materialise(&self, data_seed: u64) -> Result<Materialised, DataError> {
                match self { $(Dataset::$variant(d) => d.materialise(data_seed),)+ }
            }
            /// See [`DatasetKind::redraw`].
            pub fn redraw(
                &self,
                samples: usize,
                seed: u64,
                data: &Materialised,
            ) -> Option<Result<Array3<Complex64>, DataError>> {
                match self { $(Dataset::$variant(d) => d.redraw(samples, seed, data),)+ }
            }
        }
    };
}

// The registration: one line per kind.
register! {
    FilteredNoise(filtered_noise::FilteredNoise),
    Npy(npy::NpyDataset),
    Mat(mat::MatDataset),
    Raw(raw::RawDataset),
    Netcdf(netcdf::NetcdfDataset),
    Vegetation(vegetation::VegetationDataset),
    Kspace(kspace::KspaceDataset),
}
