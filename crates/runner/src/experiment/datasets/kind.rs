//! What every dataset kind implements ([`DatasetKind`]: its spec fields, their check, its
//! shape and input files, its sizes and cost, its materialisation and redraw) and the values
//! it hands over: the materialised stack ([`Materialised`], with its saved k-space), a stack's
//! axis order ([`Layout`]) and the errors of reading or making one ([`DataError`]).

use super::super::context::{Ctx, SpecError};
use super::cost::{Cost, Sizes};
use crate::io::npy::{NpyError, Stack};
use crate::stats::filters::FilterBank;
use ndarray::{Array2, Array3};
use num_complex::Complex64;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::PathBuf;

/// One kind of dataset (`kind: <NAME>` in a spec). Every method but [`Self::metadata`] is
/// required.
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
    /// not a mapped `.npy` (free) nor synthetic noise (cheap next to its jobs). Default: yes.
    fn worth_sharing(&self) -> bool {
        true
    }
    /// Whether a noise floor can draw it again: `Some(true)` cheaply (the default floor),
    /// `Some(false)` at its own cost (only when `draws` is asked for), `None` never (the
    /// default: data read from files).
    fn redrawable(&self) -> Option<bool> {
        None
    }
    /// The k-space grid `(frequencies, azimuths)` of data imaged from k-space, whose analysis
    /// jobs write the mean k-space image (`kspace/<job>.mean.npy`, drawn by the report).
    /// Default: none.
    fn kspace_grid(&self) -> Option<(usize, usize)> {
        None
    }
    /// The half-width of a known uniform filter whose exact lag correlations the analysis
    /// writes (`filter_correlation.parquet`); `None` for data without one (the default).
    fn known_filter(&self) -> Option<usize> {
        None
    }
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
    /// What the manifest records of the files it reads beyond their paths and hashes (a
    /// GeoTIFF's pixel type and georeferencing); `None` (the default): nothing.
    fn metadata(&self) -> Option<serde_json::Value> {
        None
    }
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
    /// A UAVSAR scene cannot be read.
    #[error(transparent)]
    Uavsar(#[from] crate::io::uavsar::UavsarError),
    /// A GeoTIFF or SICD scene cannot be read.
    #[error(transparent)]
    Scene(#[from] crate::io::scenes::SceneError),
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
