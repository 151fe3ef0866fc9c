//! The experiment spec (v1): the YAML a user writes, parsed by serde with unknown keys
//! refused, and validated once into typed parameters. Every error names the spec file, the
//! YAML path (`datasets[0].alpha_h`) and, where the parser knows it, the line and column.
//!
//! The format is documented with a complete example in `docs/spec.md`.

use crate::io::npy::{self, NpyHeader};
use crate::stats::analysis::check_levels;
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

mod dataset;
mod dataset_check;
mod maps;
mod metrics;
mod synthesis;

pub use dataset::*;
pub use maps::*;
pub use metrics::*;
pub use synthesis::*;

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
    pub calibration: Option<crate::physics::calibration::ChainParams>,
    /// Output options.
    #[serde(default)]
    pub outputs: OutputsSpec,
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
