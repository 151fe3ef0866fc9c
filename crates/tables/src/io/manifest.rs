//! `manifest.json`'s format, defined once for the runner that writes it
//! (`run::manifest`) and the report and reproduction that read it: the provenance at its top
//! ([`Manifest`]'s fields up to `jobs`), every job's entry ([`Job`]), the run's [`Timings`].
//! The `files` record (each file's size and a table's SHA-256) is the core crate's
//! (`io::outdir::file_record`, read back by `io::outdir::check_complete`). A reader skips what
//! it does not name (each job's parameters and timings, the files) without building it.

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use serde_json::Value as Json;
use std::path::{Path, PathBuf};

/// The manifest's file name in a results folder.
pub const FILE: &str = "manifest.json";

/// The format tag the runner writes (`format`).
pub const FORMAT: &str = "isar-clutter-manifest/1";

/// The manifest of the results folder `dir`.
pub fn path(dir: &Path) -> PathBuf {
    dir.join(FILE)
}

/// The tool that wrote the manifest.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Tool {
    /// The crate's name.
    #[serde(default)]
    pub name: String,
    /// Its version.
    #[serde(default)]
    pub version: String,
}

/// The git state of the source tree when the binary was built.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Git {
    /// The commit.
    #[serde(default)]
    pub commit: String,
    /// Whether tracked files differed from it.
    #[serde(default)]
    pub dirty: bool,
    /// When it was recorded (`at build time`).
    #[serde(default)]
    pub recorded: String,
}

/// The run's wall times.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// The whole run, seconds.
    #[serde(default)]
    pub total_s: f64,
    /// Writing the tables, seconds.
    #[serde(default)]
    pub tables_s: f64,
}

/// `manifest.json`. The runner writes the fields up to `jobs` as the manifest's head (the
/// rest is skipped there and streamed after it: the jobs one by one, the files, the timings);
/// a reader reads them all but the files. Every field has a default, so that a manifest of an
/// older tool that lacks one still reads.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Manifest {
    /// [`FORMAT`].
    #[serde(default)]
    pub format: String,
    /// The tool that wrote it.
    #[serde(default)]
    pub tool: Tool,
    /// The git state at build time (`null` outside a git checkout).
    #[serde(default)]
    pub git: Option<Git>,
    /// The spec's file, as given.
    #[serde(default)]
    pub spec_file: String,
    /// The SHA-256 of the spec file.
    #[serde(default)]
    pub spec_hash_sha256: String,
    /// The spec, with defaults filled in.
    #[serde(default)]
    pub spec: Json,
    /// The master seed.
    #[serde(default)]
    pub master_seed: Option<u64>,
    /// Where the master seed came from (`spec` or `--seed`).
    #[serde(default)]
    pub master_seed_from: String,
    /// How seeds derive from the master seed.
    #[serde(default)]
    pub seed_derivation: String,
    /// The sample format of generated samples.
    #[serde(default)]
    pub sample_format: Option<u32>,
    /// Worker threads of the run.
    #[serde(default)]
    pub threads: Option<usize>,
    /// The calibration's seed, for a run with a calibration section.
    #[serde(default)]
    pub calibration_seed: Option<u64>,
    /// SHA-256 of the stand-in plants' calibration record compiled into the tool
    /// (`reproduction/plant_calibration.json`): the `vegetation_isar` presets' factors come
    /// from it, so two runs of one commit and spec differ where it does.
    #[serde(default)]
    pub plant_calibration_sha256: Option<String>,
    /// Where the CNN trainings ran (`cpu`; `cuda: <GPU>, driver CUDA <version>`; `cpu (auto:
    /// <why no GPU>)`), as `run` resolved `training.device` or `--device`; absent when the run
    /// did not resolve it (no CNN section, or a run by another command).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub training_device: Option<String>,
    /// Every job, in plan order (streamed by the runner after the head).
    #[serde(default, skip_serializing)]
    pub jobs: Vec<Job>,
    /// The run's wall times (written last).
    #[serde(default, skip_serializing)]
    pub timings: Option<Timings>,
    /// When the run finished, unix seconds (written last).
    #[serde(default, skip_serializing)]
    pub finished_unix_s: Option<u64>,
}

/// One job's entry: the fields every job has, and those of the dataset jobs that the
/// provenance shows (a job kind adds its own fields to the entry it writes; a reader skips
/// those it does not name).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Job {
    /// The job's id.
    #[serde(default)]
    pub job: String,
    /// Its kind (`analysis`, `synthesis`, ...).
    #[serde(default)]
    pub kind: String,
    /// Its canonical identity, which its seed derives from.
    #[serde(default)]
    pub identity: String,
    /// Its seed (`null` for a job that draws no random numbers).
    #[serde(default)]
    pub seed: Option<u64>,
    /// Its dataset (a dataset job's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<String>,
    /// Its method (a synthesis job's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// The seed of the dataset's draws (a dataset job's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data_seed: Option<u64>,
    /// The seed of the generated samples (a synthesis job's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generation_seed: Option<u64>,
    /// `ok` or `failed`.
    #[serde(default)]
    pub status: String,
    /// The error of a failed job.
    #[serde(default)]
    pub error: Option<String>,
    /// Its wall time, seconds.
    #[serde(default)]
    pub elapsed_s: Option<f64>,
    /// The job's own timings (written; a reader skips them).
    #[serde(default, skip_deserializing)]
    pub timing: Option<Json>,
    /// The build of the tool that computed its stored result.
    #[serde(default)]
    pub computed_by: Option<String>,
}

impl Job {
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

    /// The field of the provenance table's column `key` (one of [`Job::COLUMNS`]) as JSON
    /// (`null` when the job has none).
    pub fn field(&self, key: &str) -> Json {
        match key {
            "job" => self.job.clone().into(),
            "dataset" => self.dataset.clone().into(),
            "method" => self.method.clone().into(),
            "status" => self.status.clone().into(),
            "seed" => self.seed.into(),
            "data_seed" => self.data_seed.into(),
            "generation_seed" => self.generation_seed.into(),
            "elapsed_s" => self.elapsed_s.into(),
            _ => self.error.clone().into(),
        }
    }

    /// Whether the job finished.
    pub fn ok(&self) -> bool {
        self.status == "ok"
    }
}

impl Manifest {
    /// Reads the manifest of the results folder `dir`.
    ///
    /// # Errors
    /// If the file is missing (not a results folder) or is not a manifest; naming it.
    pub fn read(dir: &Path) -> Result<Manifest> {
        let path = path(dir);
        let bytes = std::fs::read(&path)
            .with_context(|| format!("{} is not a results folder (no {FILE})", dir.display()))?;
        serde_json::from_slice(&bytes).with_context(|| format!("reading {}", path.display()))
    }

    /// The ids of the jobs that finished, in plan order.
    pub fn ok_jobs(&self) -> Vec<String> {
        self.jobs
            .iter()
            .filter(|j| j.ok())
            .map(|j| j.job.clone())
            .collect()
    }
}
