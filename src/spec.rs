//! The experiment spec (v1): the YAML a user writes, parsed by serde with unknown keys
//! refused, and validated once into typed parameters. Every error names the spec file, the
//! YAML path (`datasets[0].alpha_h`) and, where the parser knows it, the line and column.
//!
//! The format is documented with a complete example in `docs/spec.md`.

use crate::analysis::check_levels;
use crate::npy::{self, NpyHeader};
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// A spec problem, located in the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {path}{loc}: {message}", file = file.display(), loc = location(*line, *column))]
pub struct SpecError {
    /// The spec file.
    pub file: PathBuf,
    /// YAML path of the offending value (`.` for the document).
    pub path: String,
    /// 1-based line, when the parser reports it.
    pub line: Option<usize>,
    /// 1-based column, when the parser reports it.
    pub column: Option<usize>,
    /// What is wrong.
    pub message: String,
}

fn location(line: Option<usize>, column: Option<usize>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!(" (line {l}, column {c})"),
        (Some(l), None) => format!(" (line {l})"),
        _ => String::new(),
    }
}

impl SpecError {
    /// An error at `path` with no line information.
    pub fn at(file: &Path, path: impl Into<String>, message: impl Into<String>) -> Self {
        SpecError {
            file: file.to_path_buf(),
            path: path.into(),
            line: None,
            column: None,
            message: message.into(),
        }
    }
}

/// Top level of a spec file, as written.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawSpec {
    /// Experiment name; also the default output folder `outputs/<name>`.
    pub name: String,
    /// Master seed from which every job's seed is derived.
    pub seed: u64,
    /// Free text for the report.
    #[serde(default)]
    pub description: Option<String>,
    /// Datasets to analyse (may be empty only with a `calibration` section).
    #[serde(default)]
    pub datasets: Vec<DatasetSpec>,
    /// Multiscale analysis settings (default: 1 level; needed with datasets).
    #[serde(default)]
    pub analysis: AnalysisSpec,
    /// Parameter sweeps.
    #[serde(default)]
    pub sweep: SweepSpec,
    /// Synthesis: methods fitted to every dataset and the samples they generate.
    #[serde(default)]
    pub synthesis: Option<SynthesisSpec>,
    /// Similarity metrics between each method's generated samples and the original (needs a
    /// `synthesis` section): names (`kl_pixel`, `kl_area`, `cmd`, `multiscale_rmse`) or
    /// `{name: {parameters}}`; validated by [`check_metrics`].
    #[serde(default)]
    pub metrics: Vec<serde_yaml_ng::Value>,
    /// How the noise floor of the metrics is measured (default `auto`).
    #[serde(default)]
    pub noise_floor: NoiseFloor,
    /// Hypothesis tests H1-H4 over `plant_<letter>_<wind>` datasets (ch. 5.1):
    /// `hypotheses.parquet` and `correlating_function.parquet`.
    #[serde(default)]
    pub hypotheses: Option<HypothesesSpec>,
    /// A simulated sphere calibration (2.3): `calibration.parquet` and
    /// `calibration_summary.parquet`; `datasets` may then be empty.
    #[serde(default)]
    pub calibration: Option<crate::calibration::ChainParams>,
    /// Output options.
    #[serde(default)]
    pub outputs: OutputsSpec,
}

/// `hypotheses:` section.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HypothesesSpec {
    /// Largest offset (pixels, each axis) of the mean 2-D correlating function (default 4).
    #[serde(default = "four")]
    pub max_offset: usize,
}

fn four() -> usize {
    4
}

/// The reference comparison that shows which metric differences are real: the same metrics
/// between two independent stacks of the original data.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum NoiseFloor {
    /// `draws` for synthetic datasets, `halves` for stacks read from files.
    #[default]
    Auto,
    /// The original against an independent draw of `synthesis.samples` samples from the same
    /// synthetic model (the comparison a perfect method would give).
    Draws,
    /// The first half of the original samples against the second half.
    Halves,
    /// No noise floor.
    None,
}

/// Parameters of one `metrics:` entry, as written (all optional; defaults in
/// [`crate::metrics`]).
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MetricParams {
    /// KL: number of bins.
    pub bins: Option<usize>,
    /// KL: pseudo-count of empty bins.
    pub smoothing: Option<f64>,
    /// KL: symmetric (eq. 23).
    pub symmetric: Option<bool>,
    /// KL: statistics in dB.
    pub db: Option<bool>,
    /// `kl_area`: block edge in pixels.
    pub block: Option<usize>,
}

/// Validates the `metrics:` section into typed metrics.
///
/// # Errors
/// A [`SpecError`] naming `metrics[i]` (and the parameter) for an unknown name, a parameter
/// the metric does not take, a bad value, a metric listed twice, or metrics without a
/// `synthesis` section.
pub fn check_metrics(spec: &RawSpec, ctx: &Ctx) -> Result<Vec<crate::metrics::Metric>, SpecError> {
    use crate::metrics::{KlOptions, Metric};
    if !spec.metrics.is_empty() && spec.synthesis.is_none() {
        return Err(ctx.err(
            "metrics",
            "metrics compare generated samples with the original: add a `synthesis` section",
        ));
    }
    let names = "kl_pixel, kl_area, cmd, multiscale_rmse";
    let mut out: Vec<Metric> = Vec::new();
    for (i, entry) in spec.metrics.iter().enumerate() {
        let at = format!("metrics[{i}]");
        let (name, params) = match entry {
            serde_yaml_ng::Value::String(s) => (s.clone(), MetricParams::default()),
            serde_yaml_ng::Value::Mapping(m) if m.len() == 1 => {
                let (k, v) = m.iter().next().expect("one entry");
                let name = k.as_str().unwrap_or_default().to_string();
                let v = if v.is_null() {
                    serde_yaml_ng::Value::Mapping(Default::default())
                } else {
                    v.clone()
                };
                let params: MetricParams = serde_yaml_ng::from_value(v)
                    .map_err(|e| ctx.err(format!("{at}.{name}"), e.to_string()))?;
                (name, params)
            }
            _ => {
                return Err(ctx.err(
                    at,
                    format!("a metric is a name ({names}) or `{{name: {{parameters}}}}`"),
                ))
            }
        };
        let at = format!("{at}.{name}");
        let kl = |block_ok: bool| -> Result<KlOptions, SpecError> {
            if params.block.is_some() && !block_ok {
                return Err(ctx.err(format!("{at}.block"), "only kl_area takes `block`"));
            }
            let d = KlOptions::default();
            let o = KlOptions {
                bins: params.bins.unwrap_or(d.bins),
                smoothing: params.smoothing.unwrap_or(d.smoothing),
                symmetric: params.symmetric.unwrap_or(d.symmetric),
                db: params.db.unwrap_or(d.db),
            };
            if o.bins == 0 {
                return Err(ctx.err(format!("{at}.bins"), "bins must be at least 1"));
            }
            if !(o.smoothing >= 0.0 && o.smoothing.is_finite()) {
                return Err(ctx.err(
                    format!("{at}.smoothing"),
                    format!("smoothing {} must be finite and >= 0", o.smoothing),
                ));
            }
            Ok(o)
        };
        let metric = match name.as_str() {
            "kl_pixel" => Metric::KlPixel(kl(false)?),
            "kl_area" => {
                let block = params.block.unwrap_or(crate::metrics::DEFAULT_BLOCK);
                if block == 0 {
                    return Err(ctx.err(format!("{at}.block"), "block must be at least 1"));
                }
                Metric::KlArea(kl(true)?, block)
            }
            "cmd" | "multiscale_rmse" => {
                if params != MetricParams::default() {
                    return Err(ctx.err(&at, format!("{name} takes no parameters")));
                }
                if name == "cmd" {
                    Metric::Cmd
                } else {
                    Metric::MultiscaleRmse
                }
            }
            other => {
                return Err(ctx.err(at, format!("unknown metric {other:?}; known: {names}")));
            }
        };
        if out.iter().any(|m| m.name() == metric.name()) {
            return Err(ctx.err(at, format!("{name} is listed twice")));
        }
        if metric == Metric::MultiscaleRmse
            && spec
                .synthesis
                .as_ref()
                .is_some_and(|s| !s.analyse_generated)
        {
            return Err(ctx.err(
                at,
                "multiscale_rmse needs synthesis.analyse_generated: true",
            ));
        }
        out.push(metric);
    }
    Ok(out)
}

/// `synthesis:` section (ch. 4): every dataset is fitted by every method; each fit generates
/// `samples` new samples, from a seed shared by the methods of one dataset (common random
/// numbers, so method comparisons are paired).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SynthesisSpec {
    /// Methods: `method1`, `method2`, `full_covariance`, `uncorrelated`.
    pub methods: Vec<crate::synthesis::Method>,
    /// Samples to generate per fit.
    pub samples: usize,
    /// Filter half-width `K` of Methods 1 and 2 (default 8).
    #[serde(default = "default_half_width")]
    pub half_width: usize,
    /// Dyadic parameters `L` of Method 2 (default: `analysis.levels`).
    #[serde(default)]
    pub levels: Option<usize>,
    /// Write the generated samples to `samples/<job>.npy` (complex64 `[M, H, W]`).
    #[serde(default)]
    pub save_samples: bool,
    /// Analyse the generated samples too (rows with `source` = the method; default true).
    #[serde(default = "yes")]
    pub analyse_generated: bool,
}

fn default_half_width() -> usize {
    8
}

impl SynthesisSpec {
    /// Method 2's `L` given the analysis levels.
    pub fn dyadic_levels(&self, analysis: &AnalysisSpec) -> usize {
        self.levels.unwrap_or(analysis.levels)
    }

    /// Validates the section for a dataset of size `h x w` (`at`: the YAML path).
    pub fn check(
        &self,
        ctx: &Ctx,
        analysis: &AnalysisSpec,
        h: usize,
        w: usize,
    ) -> Result<(), SpecError> {
        use crate::synthesis::Method;
        if self.methods.is_empty() {
            return Err(ctx.err("synthesis.methods", "name at least one method"));
        }
        for (i, m) in self.methods.iter().enumerate() {
            if self.methods[..i].contains(m) {
                return Err(ctx.err(
                    format!("synthesis.methods[{i}]"),
                    format!("{} is listed twice", m.as_str()),
                ));
            }
        }
        let min = if self.analyse_generated { 2 } else { 1 };
        if self.samples < min {
            return Err(ctx.err("synthesis.samples", format!("{} sample(s) requested; at least {min} (2 when the generated samples are analysed)", self.samples)));
        }
        if self.methods.contains(&Method::Method2) {
            let l = self.dyadic_levels(analysis);
            let need = crate::filters::dyadic_reach(l);
            if self.half_width < need {
                return Err(ctx.err("synthesis.half_width", format!("method2 with {l} level(s) reaches offset {need}; half_width {} would truncate it", self.half_width)));
            }
            check_levels(l, h, w)
                .map_err(|e| ctx.err("synthesis.levels", format!("method2: {e}")))?;
        }
        Ok(())
    }
}

/// `analysis:` section.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AnalysisSpec {
    // `Default` (1 level) serves calibration-only specs; with datasets the key is required.
    /// Number of decomposition levels `L` (maps for levels `1..=L`).
    pub levels: usize,
}

impl Default for AnalysisSpec {
    fn default() -> Self {
        AnalysisSpec { levels: 1 }
    }
}

/// `outputs:` section.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputsSpec {
    /// Write every map as `.npy` under `maps/<job>/` (default true).
    #[serde(default = "yes")]
    pub npy_maps: bool,
    /// Largest lag of `filter_correlation.parquet` (default: the filter's half-width).
    #[serde(default)]
    pub filter_lags: Option<usize>,
}

fn yes() -> bool {
    true
}

impl Default for OutputsSpec {
    fn default() -> Self {
        OutputsSpec {
            npy_maps: true,
            filter_lags: None,
        }
    }
}

/// `sweep:` section: `grid` axes combine in all combinations, `zip` axes are paired.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Field path -> values; every combination is a sweep point.
    #[serde(default)]
    pub grid: BTreeMap<String, Vec<serde_yaml_ng::Value>>,
    /// Field path -> values; all lists have one length and vary together.
    #[serde(default)]
    pub zip: BTreeMap<String, Vec<serde_yaml_ng::Value>>,
}

/// Dataset kinds.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum DatasetKind {
    /// Synthetic stack: white complex seed through a separable correlating filter.
    FilteredNoise,
    /// A stack read from a `.npy` file.
    Npy,
    /// Two variables of a NetCDF-3 file combined as `u + i v` (geophysical fields).
    Netcdf,
    /// Simulated ISAR images of a wind-blown plant (the physical forward model).
    VegetationIsar,
    /// Measured k-space data `E(f, phi)` imaged by the ISAR chain.
    Kspace,
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

/// Axis order of an `npy` stack.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// `[N, H, W]` (default).
    #[default]
    Nhw,
    /// `[H, W, N]` (MATLAB exports).
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
    /// `npy`: path of the stack, relative to the spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
    /// `npy`: axis order (`nhw` default, `hwn`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<Layout>,
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
    pub calibration: Option<crate::calibration::ChainParams>,
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

/// A parameter that is a scalar or a spatial map.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum ParamMap {
    /// The same value everywhere.
    Scalar(f64),
    /// A pattern or a `.npy` map.
    Pattern(PatternSpec),
}

/// Pattern kinds of a [`PatternSpec`].
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PatternKind {
    /// `value` everywhere.
    Constant,
    /// `left` on columns `< W/2`, `right` on the rest.
    LeftRight,
    /// `top` on rows `< H/2`, `bottom` on the rest.
    TopBottom,
    /// Linear from `from` (first column or row) to `to` (last) along `axis`.
    Ramp,
    /// An `[H, W]` real `.npy` file at `path` (relative to the spec file).
    Npy,
}

/// Axis of a ramp.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum RampAxis {
    /// Varies along columns.
    Horizontal,
    /// Varies along rows.
    Vertical,
}

/// A spatial map pattern as written: `{pattern: left_right, left: 0.5, right: 2}`.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PatternSpec {
    /// Which pattern.
    pub pattern: PatternKind,
    /// `constant`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    /// `left_right`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub left: Option<f64>,
    /// `left_right`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub right: Option<f64>,
    /// `top_bottom`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub top: Option<f64>,
    /// `top_bottom`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bottom: Option<f64>,
    /// `ramp`: direction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<RampAxis>,
    /// `ramp`: first value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<f64>,
    /// `ramp`: last value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub to: Option<f64>,
    /// `npy`: file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathBuf>,
}

impl<'de> Deserialize<'de> for ParamMap {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ParamMap;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or a pattern mapping such as {pattern: ramp, axis: horizontal, from: 0.5, to: 2}")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<ParamMap, E> {
                Ok(ParamMap::Scalar(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<ParamMap, E> {
                Ok(ParamMap::Scalar(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<ParamMap, E> {
                Ok(ParamMap::Scalar(v as f64))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ParamMap, A::Error> {
                PatternSpec::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(ParamMap::Pattern)
            }
        }
        d.deserialize_any(V)
    }
}

/// A [`ParamMap`] after validation.
#[derive(Debug, Clone, PartialEq)]
pub enum Map {
    /// One value everywhere.
    Constant(f64),
    /// Left and right halves.
    LeftRight(f64, f64),
    /// Top and bottom halves.
    TopBottom(f64, f64),
    /// Linear ramp.
    Ramp(RampAxis, f64, f64),
    /// A loaded `[H, W]` map.
    File(PathBuf, ndarray::Array2<f64>),
}

impl Map {
    /// The map evaluated on an `h x w` grid.
    pub fn grid(&self, h: usize, w: usize) -> ndarray::Array2<f64> {
        let lerp = |a: f64, b: f64, i: usize, n: usize| {
            if n <= 1 {
                a
            } else {
                a + (b - a) * i as f64 / (n - 1) as f64
            }
        };
        ndarray::Array2::from_shape_fn((h, w), |(r, c)| match self {
            Map::Constant(v) => *v,
            Map::LeftRight(l, rv) => {
                if c < w / 2 {
                    *l
                } else {
                    *rv
                }
            }
            Map::TopBottom(t, b) => {
                if r < h / 2 {
                    *t
                } else {
                    *b
                }
            }
            Map::Ramp(RampAxis::Horizontal, a, b) => lerp(*a, *b, c, w),
            Map::Ramp(RampAxis::Vertical, a, b) => lerp(*a, *b, r, h),
            Map::File(_, m) => m[[r, c]],
        })
    }

    /// Whether the map is the same value everywhere.
    pub fn is_constant(&self) -> bool {
        match self {
            Map::Constant(_) => true,
            Map::LeftRight(a, b) | Map::TopBottom(a, b) | Map::Ramp(_, a, b) => a == b,
            Map::File(_, m) => m.iter().all(|v| *v == m[[0, 0]]),
        }
    }

    /// All values the map takes (for range checks).
    fn values(&self) -> Vec<f64> {
        match self {
            Map::Constant(v) => vec![*v],
            Map::LeftRight(a, b) | Map::TopBottom(a, b) | Map::Ramp(_, a, b) => vec![*a, *b],
            Map::File(_, m) => m.iter().copied().collect(),
        }
    }
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

/// A validated dataset.
#[derive(Debug, Clone, PartialEq)]
pub enum Dataset {
    /// Synthetic filtered noise.
    FilteredNoise(Box<FilteredNoise>),
    /// A stack on disk.
    Npy(NpyDataset),
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
    pub measurement: crate::isar::Measurement,
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

fn f_start() -> f64 {
    2e9
}
fn f_stop() -> f64 {
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
    pub fn grid(&self) -> Result<crate::isar::Measurement, crate::isar::IsarError> {
        crate::isar::Measurement::uniform(
            self.f_start,
            self.f_stop,
            self.frequencies,
            self.azimuth_span_deg.to_radians(),
            self.azimuths,
        )
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
    pub scene: crate::vegetation::SceneParams,
    /// The measurement.
    pub measurement: MeasurementSpec,
    /// Image size.
    pub image_size: usize,
    /// Samples.
    pub samples: usize,
    /// Write the simulated k-space data to `kspace/<job>.npy`.
    pub save_kspace: bool,
    /// The measurement chain and calibration applied to the k-space data.
    pub calibration: Option<crate::calibration::ChainParams>,
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
    /// `(N, H, W)` of the stack this dataset yields.
    pub fn shape(&self) -> (usize, usize, usize) {
        match self {
            Dataset::FilteredNoise(f) => (f.samples, f.height, f.width),
            Dataset::Npy(n) => n.stack_shape(),
            Dataset::Netcdf(n) => n.shape,
            Dataset::Vegetation(v) => (v.samples, v.image_size, v.image_size),
            Dataset::Kspace(k) => (k.samples, k.image_size, k.image_size),
        }
    }

    /// The kind name used in tables.
    pub fn kind(&self) -> &'static str {
        match self {
            Dataset::FilteredNoise(_) => "filtered_noise",
            Dataset::Npy(_) => "npy",
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

/// Parses spec text, reporting errors against `file`.
///
/// # Errors
/// A [`SpecError`] naming the YAML path and, where known, the line and column.
pub fn parse(text: &str, file: &Path) -> Result<RawSpec, SpecError> {
    let de = serde_yaml_ng::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let loc = inner.location();
        let mut message = inner.to_string();
        // serde_yaml_ng appends "at line L column C"; the location is reported separately.
        if let Some(i) = message.find(" at line ") {
            message.truncate(i);
        }
        // It also prefixes its own (shorter) path, which the reported path already contains.
        if let Some((head, rest)) = message.split_once(": ") {
            if !head.contains(' ') && path.starts_with(head) {
                message = rest.to_string();
            }
        }
        SpecError {
            file: file.to_path_buf(),
            path,
            line: loc.as_ref().map(|l| l.line()),
            column: loc.as_ref().map(|l| l.column()),
            message,
        }
    })
}

/// Validation context: the spec file (for messages and relative paths).
pub struct Ctx<'a> {
    /// Spec file.
    pub file: &'a Path,
}

impl Ctx<'_> {
    /// Resolves a path relative to the spec file's folder.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.file.parent().unwrap_or(Path::new(".")).join(p)
        }
    }

    pub(crate) fn err(&self, path: impl Into<String>, msg: impl Into<String>) -> SpecError {
        SpecError::at(self.file, path, msg)
    }
}

impl ParamMap {
    /// Validates into a [`Map`] on an `h x w` grid (loads `.npy` maps).
    pub fn check(&self, ctx: &Ctx, at: &str, h: usize, w: usize) -> Result<Map, SpecError> {
        let p = match self {
            ParamMap::Scalar(v) => return Ok(Map::Constant(*v)),
            ParamMap::Pattern(p) => p,
        };
        let need = |v: Option<f64>, field: &str| {
            v.ok_or_else(|| {
                ctx.err(
                    format!("{at}.{field}"),
                    format!("pattern {} needs `{field}`", yaml_name(&p.pattern)),
                )
            })
        };
        let allowed: &[&str] = match p.pattern {
            PatternKind::Constant => &["value"],
            PatternKind::LeftRight => &["left", "right"],
            PatternKind::TopBottom => &["top", "bottom"],
            PatternKind::Ramp => &["axis", "from", "to"],
            PatternKind::Npy => &["path"],
        };
        let present = [
            ("value", p.value.is_some()),
            ("left", p.left.is_some()),
            ("right", p.right.is_some()),
            ("top", p.top.is_some()),
            ("bottom", p.bottom.is_some()),
            ("axis", p.axis.is_some()),
            ("from", p.from.is_some()),
            ("to", p.to.is_some()),
            ("path", p.path.is_some()),
        ];
        if let Some((f, _)) = present.iter().find(|(f, set)| *set && !allowed.contains(f)) {
            return Err(ctx.err(
                format!("{at}.{f}"),
                format!(
                    "`{f}` does not belong to pattern {} (it takes {})",
                    yaml_name(&p.pattern),
                    allowed.join(", ")
                ),
            ));
        }
        Ok(match p.pattern {
            PatternKind::Constant => Map::Constant(need(p.value, "value")?),
            PatternKind::LeftRight => {
                Map::LeftRight(need(p.left, "left")?, need(p.right, "right")?)
            }
            PatternKind::TopBottom => {
                Map::TopBottom(need(p.top, "top")?, need(p.bottom, "bottom")?)
            }
            PatternKind::Ramp => {
                let axis = p.axis.ok_or_else(|| {
                    ctx.err(
                        format!("{at}.axis"),
                        "pattern ramp needs `axis` (horizontal or vertical)",
                    )
                })?;
                Map::Ramp(axis, need(p.from, "from")?, need(p.to, "to")?)
            }
            PatternKind::Npy => {
                let rel = p
                    .path
                    .as_ref()
                    .ok_or_else(|| ctx.err(format!("{at}.path"), "pattern npy needs `path`"))?;
                let file = ctx.resolve(rel);
                let m = npy::read_real_map(&file)
                    .map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
                if m.dim() != (h, w) {
                    return Err(ctx.err(
                        format!("{at}.path"),
                        format!(
                            "{} has shape {:?}, the images are {h}x{w}",
                            file.display(),
                            m.shape()
                        ),
                    ));
                }
                Map::File(file, m)
            }
        })
    }
}

/// Checks every value of a map against a predicate.
fn check_range(
    ctx: &Ctx,
    at: &str,
    m: &Map,
    ok: impl Fn(f64) -> bool,
    what: &str,
) -> Result<(), SpecError> {
    match m.values().into_iter().find(|v| !ok(*v)) {
        Some(v) => Err(ctx.err(at, format!("{what}, got {v}"))),
        None => Ok(()),
    }
}

/// The spelling of an enum value in YAML (`filtered_noise`, `left_right`).
fn yaml_name<T: Serialize>(v: &T) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::String(s)) => s,
        _ => "?".into(),
    }
}

impl DatasetSpec {
    /// Fields this dataset's kind (and family) takes besides `id` and `kind`.
    pub fn fields(&self) -> &'static [&'static str] {
        const NOISE: [&str; 8] = [
            "family",
            "size",
            "samples",
            "half_width",
            "mean",
            "mean_im",
            "std",
            "texture_shape",
        ];
        const EXP: [&str; 10] = [
            "alpha_h", "alpha_v", NOISE[0], NOISE[1], NOISE[2], NOISE[3], NOISE[4], NOISE[5],
            NOISE[6], NOISE[7],
        ];
        const DYADIC: [&str; 10] = [
            "r_h", "r_v", NOISE[0], NOISE[1], NOISE[2], NOISE[3], NOISE[4], NOISE[5], NOISE[6],
            NOISE[7],
        ];
        match (self.kind, self.family) {
            (DatasetKind::Npy, _) => &["path", "layout"],
            (DatasetKind::Netcdf, _) => &["path", "u", "v", "remove_monthly_mean"],
            (DatasetKind::Kspace, _) => &["path", "freqs", "azimuths_deg", "image_size"],
            (DatasetKind::VegetationIsar, _) => &[
                "plant",
                "wind",
                "samples",
                "scene",
                "measurement",
                "image_size",
                "save_kspace",
                "calibration",
            ],
            (DatasetKind::FilteredNoise, Some(Family::Dyadic)) => &DYADIC,
            (DatasetKind::FilteredNoise, _) => &EXP,
        }
    }

    /// Validates one dataset (`at` is its YAML path, e.g. `datasets[0]`).
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
        let fields = [
            ("family", self.family.is_some()),
            ("alpha_h", self.alpha_h.is_some()),
            ("alpha_v", self.alpha_v.is_some()),
            ("r_h", self.r_h.is_some()),
            ("r_v", self.r_v.is_some()),
            ("size", self.size.is_some()),
            ("samples", self.samples.is_some()),
            ("half_width", self.half_width.is_some()),
            ("mean", self.mean.is_some()),
            ("mean_im", self.mean_im.is_some()),
            ("std", self.std.is_some()),
            ("texture_shape", self.texture_shape.is_some()),
            ("path", self.path.is_some()),
            ("layout", self.layout.is_some()),
            ("plant", self.plant.is_some()),
            ("wind", self.wind.is_some()),
            ("scene", self.scene.is_some()),
            ("measurement", self.measurement.is_some()),
            ("image_size", self.image_size.is_some()),
            ("freqs", self.freqs.is_some()),
            ("save_kspace", self.save_kspace.is_some()),
            ("calibration", self.calibration.is_some()),
            ("azimuths_deg", self.azimuths_deg.is_some()),
            ("u", self.u.is_some()),
            ("v", self.v.is_some()),
            ("remove_monthly_mean", self.remove_monthly_mean.is_some()),
        ];
        let allowed = self.fields();
        if let Some((f, _)) = fields.iter().find(|(f, set)| *set && !allowed.contains(f)) {
            return Err(ctx.err(
                format!("{at}.{f}"),
                format!(
                    "`{f}` does not apply to this dataset (kind {}{}); it takes: {}",
                    yaml_name(&self.kind),
                    self.family
                        .map(|f| format!(", family {}", yaml_name(&f)))
                        .unwrap_or_default(),
                    allowed.join(", ")
                ),
            ));
        }
        let dataset = match self.kind {
            DatasetKind::Npy => Dataset::Npy(self.check_npy(ctx, at)?),
            DatasetKind::Netcdf => Dataset::Netcdf(self.check_netcdf(ctx, at)?),
            DatasetKind::Kspace => Dataset::Kspace(Box::new(self.check_kspace(ctx, at)?)),
            DatasetKind::VegetationIsar => {
                Dataset::Vegetation(Box::new(self.check_vegetation(ctx, at)?))
            }
            DatasetKind::FilteredNoise => {
                Dataset::FilteredNoise(Box::new(self.check_noise(ctx, at)?))
            }
        };
        let (n, h, w) = dataset.shape();
        if n < 2 {
            let field = if self.kind == DatasetKind::Npy {
                "path"
            } else {
                "samples"
            };
            return Err(ctx.err(
                format!("{at}.{field}"),
                format!("the stack has {n} sample(s); at least 2 are needed"),
            ));
        }
        check_levels(levels, h, w)
            .map_err(|e| ctx.err("analysis.levels", format!("dataset {}: {e}", self.id)))?;
        Ok(dataset)
    }

    fn check_kspace(&self, ctx: &Ctx, at: &str) -> Result<KspaceDataset, SpecError> {
        let rel = self
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind kspace needs `path`"))?;
        let path = ctx.resolve(rel);
        let header =
            npy::read_header(&path).map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        let [n, nf, nphi] = header.shape[..] else {
            return Err(ctx.err(
                format!("{at}.path"),
                format!(
                    "{} has shape {:?}; k-space data are [N, n_f, n_phi]",
                    path.display(),
                    header.shape
                ),
            ));
        };
        let vector = |v: &Option<Vector>, name: &str, len: usize| -> Result<Vec<f64>, SpecError> {
            let at = format!("{at}.{name}");
            let values = match v {
                None => return Err(ctx.err(&at, format!("kind kspace needs `{name}`"))),
                Some(Vector::List(l)) => l.clone(),
                Some(Vector::File(f)) => {
                    // Names the file, and the shape where it is not 1-D.
                    let f = ctx.resolve(f);
                    let m = npy::read_real_vector(&f).map_err(|e| ctx.err(&at, e.to_string()))?;
                    m.iter().copied().collect()
                }
            };
            if values.len() != len {
                return Err(ctx.err(
                    &at,
                    format!(
                        "{} values; the data have {len} along this axis",
                        values.len()
                    ),
                ));
            }
            Ok(values)
        };
        let freqs = vector(&self.freqs, "freqs", nf)?;
        let azimuths = vector(&self.azimuths_deg, "azimuths_deg", nphi)?
            .iter()
            .map(|d| d.to_radians())
            .collect();
        let measurement = crate::isar::Measurement { freqs, azimuths };
        measurement
            .validate()
            .map_err(|e| ctx.err(format!("{at}.freqs"), e.to_string()))?;
        let image_size = self.image_size.unwrap_or(64);
        if image_size < 2 {
            return Err(ctx.err(format!("{at}.image_size"), "image_size must be at least 2"));
        }
        Ok(KspaceDataset {
            path,
            header,
            measurement,
            image_size,
            samples: n,
        })
    }

    fn check_vegetation(&self, ctx: &Ctx, at: &str) -> Result<VegetationDataset, SpecError> {
        use crate::vegetation::SceneParams;
        let plant = self.plant.clone().ok_or_else(|| {
            ctx.err(
                format!("{at}.plant"),
                "kind vegetation_isar needs `plant` (A, B, C, D or E)",
            )
        })?;
        let wind = self.wind.clone().unwrap_or_else(|| "none".into());
        let preset = SceneParams::preset(&plant, &wind).ok_or_else(|| {
            let (field, what) = if crate::vegetation::PlantParams::preset(&plant).is_none() {
                (
                    "plant",
                    format!("unknown plant {plant:?}; presets: A, B, C, D, E"),
                )
            } else {
                (
                    "wind",
                    format!("unknown wind {wind:?}; presets: none, light, medium"),
                )
            };
            ctx.err(format!("{at}.{field}"), what)
        })?;
        let scene = match &self.scene {
            None => preset,
            Some(over) => {
                let mut base = serde_yaml_ng::to_value(&preset).expect("scene serialises");
                merge(&mut base, over);
                let s: SceneParams = serde_path_to_error::deserialize(base).map_err(|e| {
                    ctx.err(format!("{at}.scene.{}", e.path()), e.inner().to_string())
                })?;
                s
            }
        };
        scene
            .validate()
            .map_err(|e| ctx.err(format!("{at}.scene"), e.to_string()))?;
        let mut measurement = self.measurement.clone().unwrap_or_default();
        if let Some(c) = &self.calibration {
            c.check()
                .map_err(|(field, msg)| ctx.err(format!("{at}.calibration.{field}"), msg))?;
            measurement.f_start = c.f_start;
            measurement.f_stop = c.f_stop;
            measurement.frequencies = c.points;
        }
        measurement
            .grid()
            .map_err(|e| ctx.err(format!("{at}.measurement"), e.to_string()))?;
        let samples = self.samples.ok_or_else(|| {
            ctx.err(
                format!("{at}.samples"),
                "kind vegetation_isar needs `samples`",
            )
        })?;
        let image_size = self.image_size.unwrap_or(64);
        if image_size < 2 {
            return Err(ctx.err(format!("{at}.image_size"), "image_size must be at least 2"));
        }
        Ok(VegetationDataset {
            plant,
            wind,
            scene,
            measurement,
            image_size,
            samples,
            save_kspace: self.save_kspace.unwrap_or(false),
            calibration: self.calibration.clone(),
        })
    }

    fn check_netcdf(&self, ctx: &Ctx, at: &str) -> Result<NetcdfDataset, SpecError> {
        let rel = self
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind netcdf needs `path`"))?;
        let path = ctx.resolve(rel);
        let file = crate::netcdf::NcFile::open(&path)
            .map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        let u = self
            .u
            .clone()
            .ok_or_else(|| ctx.err(format!("{at}.u"), "kind netcdf needs `u` (a variable name)"))?;
        let names: Vec<&str> = file.variables().iter().map(|v| v.name.as_str()).collect();
        let shape_of = |name: &str, field: &str| -> Result<(usize, usize, usize), SpecError> {
            let var = file.variable(name).ok_or_else(|| {
                ctx.err(
                    format!("{at}.{field}"),
                    format!(
                        "{} has no variable {name:?} (it has: {})",
                        path.display(),
                        names.join(", ")
                    ),
                )
            })?;
            match file.shape(var)[..] {
                [n, h, w] => Ok((n, h, w)),
                ref s => Err(ctx.err(
                    format!("{at}.{field}"),
                    format!("variable {name:?} has shape {s:?}; a stack is 3-D [time, rows, cols]"),
                )),
            }
        };
        let shape = shape_of(&u, "u")?;
        if let Some(v) = &self.v {
            let sv = shape_of(v, "v")?;
            if sv != shape {
                return Err(ctx.err(
                    format!("{at}.v"),
                    format!("{v:?} has shape {sv:?}, {u:?} has {shape:?}; they must match"),
                ));
            }
        }
        let remove_monthly_mean = self.remove_monthly_mean.unwrap_or(false);
        if remove_monthly_mean {
            crate::netcdf_stack::months(&file, &u)
                .map_err(|e| ctx.err(format!("{at}.remove_monthly_mean"), e))?;
        }
        Ok(NetcdfDataset {
            path,
            u,
            v: self.v.clone(),
            remove_monthly_mean,
            shape,
        })
    }

    fn check_npy(&self, ctx: &Ctx, at: &str) -> Result<NpyDataset, SpecError> {
        let rel = self
            .path
            .as_ref()
            .ok_or_else(|| ctx.err(format!("{at}.path"), "kind npy needs `path`"))?;
        let path = ctx.resolve(rel);
        let header =
            npy::read_header(&path).map_err(|e| ctx.err(format!("{at}.path"), e.to_string()))?;
        if header.shape.len() != 3 {
            return Err(ctx.err(
                format!("{at}.path"),
                format!(
                    "{} has shape {:?}; a stack is 3-D ([N, H, W], or [H, W, N] with layout: hwn)",
                    path.display(),
                    header.shape
                ),
            ));
        }
        Ok(NpyDataset {
            path,
            layout: self.layout.unwrap_or_default(),
            header,
        })
    }

    fn check_noise(&self, ctx: &Ctx, at: &str) -> Result<FilteredNoise, SpecError> {
        let family = self.family.ok_or_else(|| {
            ctx.err(
                format!("{at}.family"),
                "kind filtered_noise needs `family` (exponential or dyadic)",
            )
        })?;
        let [h, w] = self.size.ok_or_else(|| {
            ctx.err(
                format!("{at}.size"),
                "kind filtered_noise needs `size: [H, W]`",
            )
        })?;
        if h == 0 || w == 0 {
            return Err(ctx.err(
                format!("{at}.size"),
                format!("size must be positive, got [{h}, {w}]"),
            ));
        }
        let samples = self.samples.ok_or_else(|| {
            ctx.err(
                format!("{at}.samples"),
                "kind filtered_noise needs `samples`",
            )
        })?;
        let half_width = self.half_width.unwrap_or(8);
        let map = |p: &Option<ParamMap>, name: &str, default: f64| -> Result<Map, SpecError> {
            match p {
                Some(p) => p.check(ctx, &format!("{at}.{name}"), h, w),
                None => Ok(Map::Constant(default)),
            }
        };
        let filter = match family {
            Family::Exponential => {
                let need = |p: &Option<ParamMap>, name: &str| -> Result<Map, SpecError> {
                    let p = p.as_ref().ok_or_else(|| {
                        ctx.err(
                            format!("{at}.{name}"),
                            format!("family exponential needs `{name}`"),
                        )
                    })?;
                    let m = p.check(ctx, &format!("{at}.{name}"), h, w)?;
                    check_range(
                        ctx,
                        &format!("{at}.{name}"),
                        &m,
                        |v| v != 0.0 && !v.is_nan(),
                        "alpha must be non-zero (negative alpha: sign-alternating filter)",
                    )?;
                    Ok(m)
                };
                FilterParams::Exponential {
                    alpha_h: need(&self.alpha_h, "alpha_h")?,
                    alpha_v: need(&self.alpha_v, "alpha_v")?,
                }
            }
            Family::Dyadic => {
                let list = |p: &Option<Vec<ParamMap>>, name: &str| -> Result<Vec<Map>, SpecError> {
                    let p = p.as_ref().ok_or_else(|| {
                        ctx.err(
                            format!("{at}.{name}"),
                            format!("family dyadic needs `{name}: [r_1, ..., r_L]`"),
                        )
                    })?;
                    if p.is_empty() {
                        return Err(ctx.err(format!("{at}.{name}"), "needs at least one parameter"));
                    }
                    let reach = crate::filters::dyadic_reach(p.len());
                    if half_width < reach {
                        return Err(ctx.err(format!("{at}.half_width"), format!("a {}-level dyadic filter reaches offset {reach}; half_width {half_width} would truncate it", p.len())));
                    }
                    p.iter()
                        .enumerate()
                        .map(|(i, m)| {
                            let m = m.check(ctx, &format!("{at}.{name}[{i}]"), h, w)?;
                            check_range(
                                ctx,
                                &format!("{at}.{name}[{i}]"),
                                &m,
                                f64::is_finite,
                                "r must be finite",
                            )?;
                            Ok(m)
                        })
                        .collect()
                };
                let (r_h, r_v) = (list(&self.r_h, "r_h")?, list(&self.r_v, "r_v")?);
                if r_h.len() != r_v.len() {
                    return Err(ctx.err(
                        format!("{at}.r_v"),
                        format!(
                            "r_h has {} parameters, r_v {}; they must match",
                            r_h.len(),
                            r_v.len()
                        ),
                    ));
                }
                FilterParams::Dyadic { r_h, r_v }
            }
        };
        let std = map(&self.std, "std", 1.0)?;
        check_range(
            ctx,
            &format!("{at}.std"),
            &std,
            |v| v >= 0.0 && v.is_finite(),
            "std must be finite and >= 0",
        )?;
        let texture_shape = self.texture_shape;
        if let Some(nu) = texture_shape {
            if !(nu > 0.0 && nu.is_finite()) {
                return Err(ctx.err(
                    format!("{at}.texture_shape"),
                    format!("texture_shape {nu} must be finite and > 0"),
                ));
            }
        }
        Ok(FilteredNoise {
            filter,
            height: h,
            width: w,
            samples,
            half_width,
            mean: map(&self.mean, "mean", 0.0)?,
            mean_im: map(&self.mean_im, "mean_im", 0.0)?,
            std,
            texture_shape,
        })
    }
}

/// Merges `over` into `base` key by key (mappings recursively; other values replace).
fn merge(base: &mut serde_yaml_ng::Value, over: &serde_yaml_ng::Value) {
    use serde_yaml_ng::Value;
    match (base, over) {
        (Value::Mapping(b), Value::Mapping(o)) => {
            for (k, v) in o {
                match b.get_mut(k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (slot, v) => *slot = v.clone(),
    }
}
