//! The experiment spec (v1): the YAML a user writes, parsed by serde with unknown keys
//! refused, and validated once into typed parameters. Every error names the spec file, the
//! YAML path (`datasets[0].alpha_h`) and, where the parser knows it, the line and column.
//!
//! The format is documented with a complete example in `docs/spec.md`.

use serde::{Deserialize, Serialize};
use std::path::Path;

mod cnn;
mod context;
pub mod datasets;
mod maps;
mod metrics;
mod sections;
mod synthesis;

pub use cnn::{
    Applications, ClassificationPlan, ClassificationSpec, CnnSections, DataRef, LocationPlan,
    LocationSpec, OneOrMany, MAX_TRAININGS,
};
pub use context::{Ctx, SpecError};
pub use datasets::{
    filter_bank, generate, DataError, Dataset, DatasetKind, DatasetSpec, Family, FilterParams,
    FilteredNoise, KspaceDataset, Layout, MatDataset, Materialised, MeasurementSpec, NetcdfDataset,
    NpyDataset, RawDataset, SavedKspace, Vector, VegetationDataset,
};
pub use maps::{Map, ParamMap, PatternKind, PatternSpec, RampAxis};
pub use metrics::{check_metrics, HypothesesSpec, MetricParams, NoiseFloor};
pub use sections::{AnalysisSpec, OutputsSpec, SweepSpec};
pub use synthesis::SynthesisSpec;

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
    pub calibration: Option<crate::physics::calibration::ChainParams>,
    /// Clutter classification with CNNs trained on generated clutter (ch. 5.3.2-5.3.7):
    /// `classification.parquet`.
    #[serde(default)]
    pub classification: Option<ClassificationSpec>,
    /// Target location with CNNs trained on generated clutter (ch. 5.3.8-5.3.9):
    /// `location.parquet` and `location_summary.parquet`.
    #[serde(default)]
    pub location: Option<LocationSpec>,
    /// Output options.
    #[serde(default)]
    pub outputs: OutputsSpec,
}

impl RawSpec {
    /// Its CNN sections, for [`Applications::validate`].
    pub fn cnn(&self) -> CnnSections<'_> {
        CnnSections {
            classification: self.classification.as_ref(),
            location: self.location.as_ref(),
        }
    }
}

pub use crate::io::strip_bom;

/// Parses spec text, reporting errors against `file`. A leading UTF-8 byte-order mark is
/// ignored; a number that is not finite is refused wherever it appears (see
/// [`check_finite`]).
///
/// # Errors
/// A [`SpecError`] naming the YAML path and, where known, the line and column.
pub fn parse(text: &str, file: &Path) -> Result<RawSpec, SpecError> {
    let text = strip_bom(text);
    let spec = parse_typed(text, file)?;
    let raw: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(text).map_err(|e| SpecError::at(file, ".", e.to_string()))?;
    check_finite(&raw, file)?;
    Ok(spec)
}

/// Refuses every number of the document that is NaN or infinite, naming its YAML path
/// (`datasets[0].mean`, `sweep.grid.datasets.d.mean[1]`): one rule for every float field,
/// sweep values included. The exception is `alpha_h`/`alpha_v`, where `.inf` means the
/// constant filter (`-.inf` its sign-alternating twin); NaN is refused there too.
///
/// # Errors
/// A [`SpecError`] at the first non-finite number.
pub fn check_finite(doc: &serde_yaml_ng::Value, file: &Path) -> Result<(), SpecError> {
    match first_non_finite(doc, String::new(), false) {
        None => Ok(()),
        Some((path, v)) => Err(SpecError::at(
            file,
            path,
            format!(
                "{v} is not allowed: every number must be finite (only `alpha_h` and `alpha_v` take .inf, the constant filter)"
            ),
        )),
    }
}

/// The YAML path and value of the first number under `v` (at `path`) that is NaN, or infinite
/// where `inf_ok` is false.
fn first_non_finite(v: &serde_yaml_ng::Value, path: String, inf_ok: bool) -> Option<(String, f64)> {
    use serde_yaml_ng::Value;
    match v {
        Value::Number(n) => n
            .as_f64()
            .filter(|x| x.is_nan() || (x.is_infinite() && !inf_ok))
            .map(|x| (if path.is_empty() { ".".into() } else { path }, x)),
        Value::Sequence(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, x)| first_non_finite(x, format!("{path}[{i}]"), inf_ok)),
        Value::Mapping(m) => m.iter().find_map(|(k, x)| {
            let key = match k {
                Value::String(s) => s.clone(),
                other => serde_yaml_ng::to_string(other)
                    .map(|s| s.trim_end().to_string())
                    .unwrap_or_default(),
            };
            // A sweep key (`datasets.d.alpha_h.to`) names its field by dotted parts.
            let alpha = key.split('.').any(|p| p == "alpha_h" || p == "alpha_v");
            let at = if path.is_empty() {
                key
            } else {
                format!("{path}.{key}")
            };
            first_non_finite(x, at, inf_ok || alpha)
        }),
        Value::Tagged(t) => first_non_finite(&t.value, path, inf_ok),
        Value::Null | Value::Bool(_) | Value::String(_) => None,
    }
}

/// The typed parse of [`parse`].
fn parse_typed(text: &str, file: &Path) -> Result<RawSpec, SpecError> {
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
