//! The `datasets` section: a dataset as written (every kind's fields), and the validated
//! dataset kinds it becomes (filtered noise, `.npy`, MATLAB `.mat`, k-space, simulated plants,
//! NetCDF).

use super::*;

/// Dataset kinds.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum DatasetKind {
    /// Synthetic stack: white complex seed through a separable correlating filter.
    FilteredNoise,
    /// A stack read from a `.npy` file.
    Npy,
    /// A stack read from a variable of a MATLAB `.mat` file (v5, or v7.3 with the `mat73`
    /// feature).
    Mat,
    /// Two variables of a NetCDF-3 file combined as `u + i v` (geophysical fields).
    Netcdf,
    /// Simulated ISAR images of a wind-blown plant (the physical forward model).
    VegetationIsar,
    /// Measured k-space data `E(f, phi)` imaged by the ISAR chain.
    Kspace,
    /// A headerless file of little-endian complex64 values, `samples x size` of them.
    Raw,
}

/// Filter families of `filtered_noise`.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// `exp(-|d| / alpha)` per direction (`alpha_h`, `alpha_v`).
    Exponential,
    /// Dyadic steps `r_1..r_L` per direction (`r_h`, `r_v`).
    Dyadic,
}

/// Axis order of an `npy` or `mat` stack.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// `[N, H, W]` (the default of `npy`).
    #[default]
    Nhw,
    /// `[H, W, N]` (MATLAB's `H x W x N`, the default of `mat`).
    Hwn,
}

/// One dataset entry as written. Fields apply per kind; a field that does not belong to the
/// kind is an error.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DatasetSpec {
    /// Identifier used in job ids and tables.
    pub id: String,
    /// `filtered_noise` or `npy`.
    pub kind: DatasetKind,
    /// `filtered_noise`: filter family.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub family: Option<Family>,
    /// `filtered_noise`, exponential: horizontal alpha (scalar or map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha_h: Option<ParamMap>,
    /// `filtered_noise`, exponential: vertical alpha (scalar or map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha_v: Option<ParamMap>,
    /// `filtered_noise`, dyadic: horizontal `r_1..r_L`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_h: Option<Vec<ParamMap>>,
    /// `filtered_noise`, dyadic: vertical `r_1..r_L`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r_v: Option<Vec<ParamMap>>,
    /// `filtered_noise`: image size `[H, W]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size: Option<[usize; 2]>,
    /// `filtered_noise`: number of samples `N`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    /// `filtered_noise`: filter half-width `K` (default 8; the seed grid is padded by it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_width: Option<usize>,
    /// `filtered_noise`: real part of the mean map (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean: Option<ParamMap>,
    /// `filtered_noise`: imaginary part of the mean map (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mean_im: Option<ParamMap>,
    /// `filtered_noise`: standard-deviation map (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub std: Option<ParamMap>,
    /// `filtered_noise`: shape `nu` of a gamma texture (K-distributed clutter, see
    /// [`FilteredNoise::texture_shape`]); absent: Gaussian.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture_shape: Option<f64>,
    /// `npy`, `mat` (and `netcdf`, `kspace`): path of the file, relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// `npy`: axis order (`nhw` default, `hwn`); `mat`: the same, `hwn` by default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<Layout>,
    /// `mat`: the variable holding the stack (default: the file's only numeric 3-D array).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variable: Option<String>,
    /// `vegetation_isar`: plant preset `A`..`E`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plant: Option<String>,
    /// `vegetation_isar`: wind preset `none`, `light` or `medium`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wind: Option<String>,
    /// `vegetation_isar`: overrides of the preset's scene parameters (`plant`, `wind`,
    /// `noise_db`, `background_residual`, `sample_interval_s`), merged key by key.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<serde_yaml_ng::Value>,
    /// `vegetation_isar`: the stepped-frequency measurement (default 2-18 GHz x 51 degrees,
    /// 256 x 256 points).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measurement: Option<MeasurementSpec>,
    /// `kspace`: frequencies in Hz (a list, or a 1-D `.npy`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub freqs: Option<Vector>,
    /// `kspace`: azimuths in degrees (a list, or a 1-D `.npy`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub azimuths_deg: Option<Vector>,
    /// `vegetation_isar`: pass the simulated k-space data through a simulated measurement
    /// chain (system response, chamber clutter, background subtraction, noise) and calibrate
    /// them with a sphere (`a(f)`), as real measurements are; the chain's `f_start`, `f_stop`
    /// and `points` replace the measurement's frequencies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<crate::physics::calibration::ChainParams>,
    /// `vegetation_isar`: write the simulated k-space data to `kspace/<job>.npy` (with
    /// `kspace/<job>.freqs.npy` in Hz and `kspace/<job>.azimuths_deg.npy`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub save_kspace: Option<bool>,
    /// `vegetation_isar`, `kspace`: image size in pixels (default 64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image_size: Option<usize>,
    /// `netcdf`: the variable giving the real part, `[time, rows, cols]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub u: Option<String>,
    /// `netcdf`: the variable giving the imaginary part (absent: 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub v: Option<String>,
    /// `netcdf`: subtract each pixel's mean over the samples of the same calendar month
    /// (months from the time coordinate's `units`, e.g. `hour since 1980-01-14 14:00:00`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub remove_monthly_mean: Option<bool>,
}

/// A validated `filtered_noise` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct FilteredNoise {
    /// Filter parameters.
    pub filter: FilterParams,
    /// Image height.
    pub height: usize,
    /// Image width.
    pub width: usize,
    /// Samples.
    pub samples: usize,
    /// Filter half-width `K`.
    pub half_width: usize,
    /// Mean, real part.
    pub mean: Map,
    /// Mean, imaginary part.
    pub mean_im: Map,
    /// Standard deviation.
    pub std: Map,
    /// K-distributed clutter: each sample is multiplied by `sqrt(tau)`, `tau ~ Gamma(nu, 1/nu)`
    /// (mean 1), one `tau` per sample (the power of one gust). Mean, variance and correlation
    /// maps are unchanged; the real and imaginary parts get excess kurtosis `3 / nu`. `None`:
    /// Gaussian.
    pub texture_shape: Option<f64>,
}

impl FilteredNoise {
    /// Zero-mean, unit-variance filtered noise of `size = (H, W)`, `samples` samples and filter
    /// half-width `half_width` (what a spec gives when `mean`, `mean_im` and `std` are unset).
    pub fn new(
        filter: FilterParams,
        (height, width): (usize, usize),
        samples: usize,
        half_width: usize,
    ) -> Self {
        FilteredNoise {
            filter,
            height,
            width,
            samples,
            half_width,
            mean: Map::Constant(0.0),
            mean_im: Map::Constant(0.0),
            std: Map::Constant(1.0),
            texture_shape: None,
        }
    }
}

/// Filter parameters per direction.
#[derive(Debug, Clone, PartialEq)]
pub enum FilterParams {
    /// Exponential: `alpha_h`, `alpha_v`.
    Exponential {
        /// Horizontal alpha map.
        alpha_h: Map,
        /// Vertical alpha map.
        alpha_v: Map,
    },
    /// Dyadic: `r_h`, `r_v`.
    Dyadic {
        /// Horizontal `r_1..r_L` maps.
        r_h: Vec<Map>,
        /// Vertical `r_1..r_L` maps.
        r_v: Vec<Map>,
    },
}

/// A validated `npy` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyDataset {
    /// Resolved path.
    pub path: PathBuf,
    /// Axis order.
    pub layout: Layout,
    /// Header of the file.
    pub header: NpyHeader,
}

/// A validated `raw` dataset: little-endian complex64 values (real, imaginary), C order.
#[derive(Debug, Clone, PartialEq)]
pub struct RawDataset {
    /// Resolved path.
    pub path: PathBuf,
    /// Axis order of the stored values.
    pub layout: Layout,
    /// `(N, H, W)`: `samples` and `size`.
    pub shape: (usize, usize, usize),
}

/// A validated `mat` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct MatDataset {
    /// Resolved path.
    pub path: PathBuf,
    /// The variable read (named in the spec, or the file's only numeric 3-D array).
    pub variable: String,
    /// Axis order of the variable's MATLAB dimensions.
    pub layout: Layout,
    /// The variable's MATLAB dimensions, e.g. `[H, W, N]`.
    pub dims: [usize; 3],
    /// Its MATLAB class (`single`, `double`, `int16`, ...).
    pub class: &'static str,
    /// Whether it is complex.
    pub complex: bool,
}

impl MatDataset {
    /// `(N, H, W)` after applying the layout.
    pub fn stack_shape(&self) -> (usize, usize, usize) {
        let [a, b, c] = self.dims;
        match self.layout {
            Layout::Nhw => (a, b, c),
            Layout::Hwn => (c, a, b),
        }
    }
}

/// A validated dataset.
#[derive(Debug, Clone, PartialEq)]
pub enum Dataset {
    /// Synthetic filtered noise.
    FilteredNoise(Box<FilteredNoise>),
    /// A stack on disk.
    Npy(NpyDataset),
    /// A variable of a MATLAB `.mat` file.
    Mat(MatDataset),
    /// A headerless complex64 file.
    Raw(RawDataset),
    /// Two variables of a NetCDF-3 file.
    Netcdf(NetcdfDataset),
    /// Simulated ISAR images of a plant.
    Vegetation(Box<VegetationDataset>),
    /// Measured k-space data.
    Kspace(Box<KspaceDataset>),
}

/// A vector of numbers: a list in the spec, or a 1-D `.npy` file.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Vector {
    /// Values written in the spec.
    List(Vec<f64>),
    /// A 1-D `.npy` of real values, relative to the spec file.
    File(PathBuf),
}

/// A validated `kspace` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct KspaceDataset {
    /// The `[N, n_f, n_phi]` stack of `E(f, phi)`.
    pub path: PathBuf,
    /// Its header.
    pub header: NpyHeader,
    /// The measurement grid (frequencies in Hz, azimuths in radians).
    pub measurement: crate::physics::isar::Measurement,
    /// Image size.
    pub image_size: usize,
    /// Samples `N`.
    pub samples: usize,
}

/// `measurement:` of a `vegetation_isar` dataset: a uniform stepped-frequency, turntable
/// azimuth grid.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MeasurementSpec {
    /// First frequency (Hz).
    #[serde(default = "f_start")]
    pub f_start: f64,
    /// Last frequency (Hz).
    #[serde(default = "f_stop")]
    pub f_stop: f64,
    /// Frequency points.
    #[serde(default = "grid_points")]
    pub frequencies: usize,
    /// Azimuth span (degrees, centred on 0).
    #[serde(default = "span")]
    pub azimuth_span_deg: f64,
    /// Azimuth points.
    #[serde(default = "grid_points")]
    pub azimuths: usize,
}

pub(super) fn f_start() -> f64 {
    2e9
}
pub(super) fn f_stop() -> f64 {
    18e9
}
fn grid_points() -> usize {
    256
}
fn span() -> f64 {
    51.0
}

impl Default for MeasurementSpec {
    fn default() -> Self {
        MeasurementSpec {
            f_start: f_start(),
            f_stop: f_stop(),
            frequencies: grid_points(),
            azimuth_span_deg: span(),
            azimuths: grid_points(),
        }
    }
}

impl MeasurementSpec {
    /// The measurement grid.
    ///
    /// # Errors
    /// The imaging chain's error naming the bad parameter.
    pub fn grid(
        &self,
    ) -> Result<crate::physics::isar::Measurement, crate::physics::isar::IsarError> {
        crate::physics::isar::Measurement::uniform(
            self.f_start,
            self.f_stop,
            self.frequencies,
            self.azimuth_span_deg.to_radians(),
            self.azimuths,
        )
    }

    /// Checks the grid's parameters without building it: its size is the job's to estimate
    /// (a grid of 10^12 points is refused by the estimate, not allocated by the check).
    ///
    /// # Errors
    /// The imaging chain's error naming the bad parameter.
    pub fn check(&self) -> Result<(), crate::physics::isar::IsarError> {
        // Four points of each axis meet every rule a larger grid meets.
        crate::physics::isar::Measurement::uniform(
            self.f_start,
            self.f_stop,
            self.frequencies.min(4),
            self.azimuth_span_deg.to_radians(),
            self.azimuths.min(4),
        )
        .map(|_| ())
    }
}

/// A validated `vegetation_isar` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct VegetationDataset {
    /// Plant preset name.
    pub plant: String,
    /// Wind preset name.
    pub wind: String,
    /// The scene: the presets with the spec's overrides.
    pub scene: crate::physics::vegetation::SceneParams,
    /// The measurement.
    pub measurement: MeasurementSpec,
    /// Image size.
    pub image_size: usize,
    /// Samples.
    pub samples: usize,
    /// Write the simulated k-space data to `kspace/<job>.npy`.
    pub save_kspace: bool,
    /// The measurement chain and calibration applied to the k-space data.
    pub calibration: Option<crate::physics::calibration::ChainParams>,
}

/// A validated `netcdf` dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct NetcdfDataset {
    /// Resolved path.
    pub path: PathBuf,
    /// Real-part variable.
    pub u: String,
    /// Imaginary-part variable.
    pub v: Option<String>,
    /// Remove the per-calendar-month mean.
    pub remove_monthly_mean: bool,
    /// `(N, H, W)`: the variables' shape.
    pub shape: (usize, usize, usize),
}

impl Dataset {
    /// The files the dataset reads (their content hashes go into its jobs' store keys).
    pub fn input_files(&self) -> Vec<PathBuf> {
        match self {
            Dataset::Npy(d) => vec![d.path.clone()],
            Dataset::Mat(d) => vec![d.path.clone()],
            Dataset::Raw(d) => vec![d.path.clone()],
            Dataset::Netcdf(d) => vec![d.path.clone()],
            Dataset::Kspace(d) => vec![d.path.clone()],
            Dataset::FilteredNoise(_) | Dataset::Vegetation(_) => vec![],
        }
    }

    /// `(N, H, W)` of the stack this dataset yields.
    pub fn shape(&self) -> (usize, usize, usize) {
        match self {
            Dataset::FilteredNoise(f) => (f.samples, f.height, f.width),
            Dataset::Npy(n) => n.stack_shape(),
            Dataset::Mat(m) => m.stack_shape(),
            Dataset::Raw(r) => r.shape,
            Dataset::Netcdf(n) => n.shape,
            Dataset::Vegetation(v) => (v.samples, v.image_size, v.image_size),
            Dataset::Kspace(k) => (k.samples, k.image_size, k.image_size),
        }
    }

    /// Whether the jobs of one group share one materialised copy of the dataset: simulated or
    /// decoded data (`.mat` and NetCDF stacks are decoded into memory); a mapped `.npy` is free
    /// and synthetic filtered noise cheap next to its jobs.
    pub fn worth_sharing(&self) -> bool {
        match self {
            Dataset::Vegetation(_)
            | Dataset::Kspace(_)
            | Dataset::Netcdf(_)
            | Dataset::Mat(_)
            | Dataset::Raw(_) => true,
            Dataset::FilteredNoise(_) | Dataset::Npy(_) => false,
        }
    }

    /// Whether a noise floor can draw the dataset again: `Some(true)` cheaply (filtered noise:
    /// the default), `Some(false)` at the dataset's own cost (simulated plants: only when
    /// `draws` is asked for), `None` never (data read from files).
    pub fn redrawable(&self) -> Option<bool> {
        match self {
            Dataset::FilteredNoise(_) => Some(true),
            Dataset::Vegetation(_) => Some(false),
            Dataset::Npy(_)
            | Dataset::Mat(_)
            | Dataset::Netcdf(_)
            | Dataset::Kspace(_)
            | Dataset::Raw(_) => None,
        }
    }

    /// The k-space grid `(frequencies, azimuths)` of data imaged from k-space (simulated
    /// plants, measured k-space), whose analysis jobs write the mean k-space image.
    pub fn kspace_grid(&self) -> Option<(usize, usize)> {
        match self {
            Dataset::Vegetation(v) => Some((v.measurement.frequencies, v.measurement.azimuths)),
            Dataset::Kspace(k) => Some((k.measurement.freqs.len(), k.measurement.azimuths.len())),
            Dataset::FilteredNoise(_)
            | Dataset::Npy(_)
            | Dataset::Mat(_)
            | Dataset::Netcdf(_)
            | Dataset::Raw(_) => None,
        }
    }

    /// The kind name used in tables.
    pub fn kind(&self) -> &'static str {
        match self {
            Dataset::FilteredNoise(_) => "filtered_noise",
            Dataset::Npy(_) => "npy",
            Dataset::Mat(_) => "mat",
            Dataset::Raw(_) => "raw",
            Dataset::Netcdf(_) => "netcdf",
            Dataset::Vegetation(_) => "vegetation_isar",
            Dataset::Kspace(_) => "kspace",
        }
    }
}

impl NpyDataset {
    /// `(N, H, W)` after applying the layout.
    pub fn stack_shape(&self) -> (usize, usize, usize) {
        let s = &self.header.shape;
        match self.layout {
            Layout::Nhw => (s[0], s[1], s[2]),
            Layout::Hwn => (s[2], s[0], s[1]),
        }
    }
}
