//! The parts of `manifest.json` the report shows: the spec, the provenance and each job's
//! identity, seeds and status. Read in one pass into typed fields; the rest (the `files`
//! record, each job's parameters and timings, which make up most of a big sweep's manifest) is
//! skipped without being built into JSON values.

use anyhow::{Context, Result};
use serde::Deserialize;
use serde_json::Value as Json;
use std::path::Path;

/// What the report reads of `manifest.json`; every field as the manifest has it (`null` when
/// absent).
#[derive(Debug, Default, Deserialize)]
pub struct Manifest {
    /// The spec, with defaults filled in.
    #[serde(default)]
    pub spec: Json,
    /// The spec's file name.
    #[serde(default)]
    pub spec_file: Json,
    /// The SHA-256 of the spec file.
    #[serde(default)]
    pub spec_hash_sha256: Json,
    /// Tool name and version.
    #[serde(default)]
    pub tool: Json,
    /// Git commit and dirtiness, or `null`.
    #[serde(default)]
    pub git: Json,
    /// The master seed.
    #[serde(default)]
    pub master_seed: Json,
    /// How seeds are derived.
    #[serde(default)]
    pub seed_derivation: Json,
    /// Worker threads of the run.
    #[serde(default)]
    pub threads: Json,
    /// The run's timings.
    #[serde(default)]
    pub timings: Json,
    /// When the run finished (unix seconds).
    #[serde(default)]
    pub finished_unix_s: Json,
    /// Every job, in plan order (`None` when the manifest has none).
    #[serde(default)]
    pub jobs: Option<Vec<Job>>,
}

/// One job of the manifest, as the provenance table shows it.
#[derive(Debug, Default, Deserialize)]
pub struct Job {
    /// The job id.
    #[serde(default)]
    pub job: Json,
    /// Its dataset.
    #[serde(default)]
    pub dataset: Json,
    /// Its method (`null` for a dataset's own job).
    #[serde(default)]
    pub method: Json,
    /// `ok` or `failed`.
    #[serde(default)]
    pub status: Json,
    /// The job's seed.
    #[serde(default)]
    pub seed: Json,
    /// The data seed.
    #[serde(default)]
    pub data_seed: Json,
    /// The generation seed.
    #[serde(default)]
    pub generation_seed: Json,
    /// Wall time of the job (s).
    #[serde(default)]
    pub elapsed_s: Json,
    /// The error of a failed job.
    #[serde(default)]
    pub error: Json,
}

impl Job {
    /// The field shown in the provenance table's column `key` (one of [`Job::COLUMNS`]).
    pub fn field(&self, key: &str) -> &Json {
        match key {
            "job" => &self.job,
            "dataset" => &self.dataset,
            "method" => &self.method,
            "status" => &self.status,
            "seed" => &self.seed,
            "data_seed" => &self.data_seed,
            "generation_seed" => &self.generation_seed,
            "elapsed_s" => &self.elapsed_s,
            _ => &self.error,
        }
    }

    /// The provenance table's columns, in order.
    pub const COLUMNS: [&'static str; 9] = [
        "job",
        "dataset",
        "method",
        "status",
        "seed",
        "data_seed",
        "generation_seed",
        "elapsed_s",
        "error",
    ];

    /// Whether the job finished.
    pub fn ok(&self) -> bool {
        self.status == "ok"
    }
}

impl Manifest {
    /// Reads `manifest.json` of the results folder `dir`.
    ///
    /// # Errors
    /// If the file is missing (not a results folder) or is not a manifest.
    pub fn read(dir: &Path) -> Result<Manifest> {
        let path = dir.join("manifest.json");
        let bytes = std::fs::read(&path).with_context(|| {
            format!(
                "{} is not a results folder (no manifest.json)",
                dir.display()
            )
        })?;
        serde_json::from_slice(&bytes).with_context(|| format!("reading {}", path.display()))
    }

    /// Every job, in plan order.
    pub fn jobs(&self) -> &[Job] {
        self.jobs.as_deref().unwrap_or_default()
    }

    /// The ids of the jobs that finished, in plan order.
    pub fn ok_jobs(&self) -> Vec<String> {
        self.jobs()
            .iter()
            .filter(|j| j.ok())
            .filter_map(|j| j.job.as_str().map(str::to_string))
            .collect()
    }
}
