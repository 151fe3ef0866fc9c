//! The spec's small sections, as written: `analysis` (the decomposition levels), `outputs`
//! (which files a run writes beside its tables) and `sweep` (the axes of a parameter sweep).

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

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
    /// Write every job's maps into one Zarr v3 store `maps.zarr/` (one array per map name
    /// with a job dimension), packed at the merge (default false).
    #[serde(default)]
    pub zarr_maps: bool,
    /// Largest lag of `filter_correlation.parquet` (default: the filter's half-width).
    #[serde(default)]
    pub filter_lags: Option<usize>,
}

/// The default of a flag that is on unless the spec says otherwise.
pub(super) fn yes() -> bool {
    true
}

impl Default for OutputsSpec {
    fn default() -> Self {
        OutputsSpec {
            npy_maps: true,
            zarr_maps: false,
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
